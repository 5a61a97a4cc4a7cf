//! Character movement for kinematic characters.
//!
//! - [`MoveAndSlide`], a system parameter with avian3d 0.7's move and slide API:
//!   [`move_and_slide`](MoveAndSlide::move_and_slide), [`cast_move`](MoveAndSlide::cast_move),
//!   [`depenetrate`](MoveAndSlide::depenetrate),
//!   [`depenetrate_intersections`](MoveAndSlide::depenetrate_intersections),
//!   [`intersections`](MoveAndSlide::intersections) and
//!   [`project_velocity`](MoveAndSlide::project_velocity), configured by
//!   [`MoveAndSlideConfig`], built on [`SpatialQuery`](crate::spatial_query::SpatialQuery)'s
//!   exact shape casts.
//! - [`MoveAndSlide::move_character`]: move and slide for a walking character with what
//!   Rapier's `KinematicCharacterController` adds: stepping up ledges, a steepest climbable
//!   slope, snapping to the ground, and whether (and on what) it stands, configured by
//!   [`CharacterConfig`], reported in a [`CharacterOutput`].
//! - [`KinematicCharacter`], a component that does that every physics step at a velocity, run
//!   by the [`CharacterPlugin`].
//! - [`project_velocity`], the projection of a motion onto several planes at once, a plain
//!   function.

mod config;
mod controller;
mod depenetration;
mod hits;
mod move_and_slide;
mod project;
mod walk;

pub use config::{
    COS_5_DEGREES, CharacterConfig, DepenetrationConfig, MAX_ITERATIONS, MoveAndSlideConfig,
};
pub use controller::{
    CharacterPlugin, CharacterSystems, KinematicCharacter, move_kinematic_characters,
};
pub use hits::{
    ContactPoint, MoveAndSlideHitData, MoveAndSlideHitResponse, MoveAndSlideOutput, MoveHitData,
};
pub use move_and_slide::MoveAndSlide;
pub use project::project_velocity;
pub use walk::{CharacterHit, CharacterOutput};
