//! Debug drawing with Bevy's gizmos (cargo feature `debug`): collider wireframes coloured by
//! state, bounding boxes, contact points and normals, impacts, velocities and sleeping islands.
//!
//! It needs Bevy's `GizmoPlugin` (part of `DefaultPlugins`) but not the render stack: without
//! one, the lines are recorded into `GizmoAsset`s and nothing is drawn, which is how the tests
//! check it.
//!
//! # Examples
//!
//! ```no_run
//! use bevy::prelude::*;
//! use impact3d::prelude::*;
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, PhysicsPlugins::default(), PhysicsDebugPlugin))
//!     .insert_resource(PhysicsGizmos { aabbs: true, ..default() })
//!     .run();
//! ```
//!
//! The geometry is plain functions that append line segments (`[start, end]`, world frame) to
//! a `Vec`: [`shape_segments`], [`box_segments`], [`arrow_segments`], [`cross_segments`]. The
//! systems gather what to draw and hand each segment to `Gizmos::line`, so what a scene draws
//! is exactly the segments these functions produce.

use bevy::color::palettes::css;
use bevy::gizmos::config::GizmoConfigGroup;
use bevy::gizmos::{AppGizmoBuilder, GizmoPlugin};
use bevy::prelude::*;

use crate::dynamics::RigidBody;
use crate::messages::Impact;

mod draw;
mod segments;

pub use draw::*;
pub use segments::*;

/// The gizmo group impact3d draws in; its `GizmoConfig` (line width, depth bias, on/off for
/// all layers) is in Bevy's `GizmoConfigStore`.
#[derive(Default, Reflect, GizmoConfigGroup)]
pub struct PhysicsGizmoGroup;

/// What [`PhysicsDebugPlugin`] draws, in which colours and at which sizes. Every layer can be
/// switched on and off at run time.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct PhysicsGizmos {
    /// Collider wireframes, coloured by the body's state. Default true.
    pub colliders: bool,
    /// Bounding boxes of bounded colliders. Default false.
    pub aabbs: bool,
    /// Contact points (a small cross) and normals (from the first body of the pair to the
    /// second) closer than
    /// [`NarrowPhaseConfig::touch_distance`](crate::collision::NarrowPhaseConfig::touch_distance).
    /// Default true.
    pub contacts: bool,
    /// Each `Impact` as an arrow along its normal, `impulse_scale x j` long, fading out over
    /// `impact_fade`. Default true.
    pub impacts: bool,
    /// Linear and angular velocity arrows of moving bodies. Default false.
    pub velocities: bool,
    /// A line from each sleeping body to the body its island is named after. Default false.
    pub islands: bool,
    /// Awake dynamic body. Default orange.
    pub dynamic_color: Color,
    /// Sleeping body. Default slate grey.
    pub sleeping_color: Color,
    /// Static body (or a collider without `RigidBody`). Default dark grey.
    pub static_color: Color,
    /// Kinematic body. Default violet.
    pub kinematic_color: Color,
    /// `Quarantined` body. Default red.
    pub quarantined_color: Color,
    /// Bounding boxes. Default yellow.
    pub aabb_color: Color,
    /// Contact points. Default cyan.
    pub contact_color: Color,
    /// Contact normals. Default light green.
    pub normal_color: Color,
    /// Impact arrows (their alpha fades). Default magenta.
    pub impact_color: Color,
    /// Linear velocity arrows. Default light blue.
    pub velocity_color: Color,
    /// Angular velocity arrows. Default gold.
    pub angular_velocity_color: Color,
    /// Island lines. Default white.
    pub island_color: Color,
    /// Length of a contact normal, m. Default 0.3.
    pub normal_length: f32,
    /// Half size of a contact point's cross, m. Default 0.04.
    pub contact_size: f32,
    /// Impact arrow length per unit of impulse, m / (N s). Default 0.5.
    pub impulse_scale: f32,
    /// Longest impact arrow, m. Default 2.
    pub max_impact_length: f32,
    /// How long an impact arrow stays, fading, s. Default 1.
    pub impact_fade: f32,
    /// Velocity arrow length per unit of speed, s (m per m/s, m per rad/s). Default 0.1.
    pub velocity_scale: f32,
    /// Half side of the square patch drawn for a half-space, m. Default 10.
    pub half_space_size: f32,
    /// Grid lines per direction on a half-space patch (at least 2). Default 11.
    pub half_space_lines: u32,
    /// Segments of a full circle in sphere and capsule wireframes (even, at least 4). Default
    /// 24.
    pub circle_segments: u32,
}

impl Default for PhysicsGizmos {
    fn default() -> Self {
        PhysicsGizmos {
            colliders: true,
            aabbs: false,
            contacts: true,
            impacts: true,
            velocities: false,
            islands: false,
            dynamic_color: css::ORANGE.into(),
            sleeping_color: css::SLATE_GRAY.into(),
            static_color: css::DIM_GRAY.into(),
            kinematic_color: css::VIOLET.into(),
            quarantined_color: css::RED.into(),
            aabb_color: css::YELLOW.into(),
            contact_color: css::AQUA.into(),
            normal_color: css::LIGHT_GREEN.into(),
            impact_color: css::MAGENTA.into(),
            velocity_color: css::LIGHT_BLUE.into(),
            angular_velocity_color: css::GOLD.into(),
            island_color: css::WHITE.into(),
            normal_length: 0.3,
            contact_size: 0.04,
            impulse_scale: 0.5,
            max_impact_length: 2.0,
            impact_fade: 1.0,
            velocity_scale: 0.1,
            half_space_size: 10.0,
            half_space_lines: 11,
            circle_segments: 24,
        }
    }
}

/// Per-body override of [`PhysicsGizmos`]: each `Some` replaces the global setting for this
/// body. `DebugRender::default()` changes nothing.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq)]
pub struct DebugRender {
    /// Draw this body's collider.
    pub collider: Option<bool>,
    /// Draw this body's bounding box.
    pub aabb: Option<bool>,
    /// Draw this body's velocity arrows.
    pub velocity: Option<bool>,
    /// Colour of this body's collider, whatever its state.
    pub color: Option<Color>,
}

impl DebugRender {
    /// Nothing drawn for this body.
    pub fn hidden() -> Self {
        DebugRender {
            collider: Some(false),
            aabb: Some(false),
            velocity: Some(false),
            color: None,
        }
    }

    /// The collider drawn in `color`.
    pub fn colored(color: impl Into<Color>) -> Self {
        DebugRender {
            collider: Some(true),
            color: Some(color.into()),
            ..default()
        }
    }
}

/// Impacts still being drawn, with their age in s.
#[derive(Resource, Default, Debug)]
pub struct ImpactTrails(pub Vec<(Impact, f32)>);

/// The systems of [`PhysicsDebugPlugin`], in `PostUpdate`.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PhysicsDebugSystems;

/// Draws the physics with gizmos (see [`crate::debug`]). Adds Bevy's `GizmoPlugin` if the app
/// has none.
pub struct PhysicsDebugPlugin;

impl Plugin for PhysicsDebugPlugin {
    fn build(&self, app: &mut App) {
        if !app.is_plugin_added::<GizmoPlugin>() {
            app.add_plugins(GizmoPlugin);
        }
        app.init_gizmo_group::<PhysicsGizmoGroup>()
            .init_resource::<PhysicsGizmos>()
            .init_resource::<ImpactTrails>()
            .add_systems(
                PostUpdate,
                (
                    draw_colliders,
                    draw_aabbs,
                    draw_contacts,
                    update_impact_trails,
                    draw_impacts,
                    draw_velocities,
                    draw_islands,
                )
                    .chain()
                    .in_set(PhysicsDebugSystems)
                    .after(TransformSystems::Propagate),
            );
    }
}

/// A body's state, for the colour of its collider.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BodyState {
    /// Dynamic and awake.
    Dynamic,
    /// Dynamic and sleeping.
    Sleeping,
    /// Static, or a collider without `RigidBody`.
    Static,
    /// Kinematic.
    Kinematic,
    /// Left out of the step for bad input.
    Quarantined,
}

impl BodyState {
    /// The state of a body from its components: quarantine first, then sleep, then its kind.
    pub fn of(body: Option<&RigidBody>, sleeping: bool, quarantined: bool) -> Self {
        match (
            quarantined,
            sleeping,
            body.copied().unwrap_or(RigidBody::Static),
        ) {
            (true, _, _) => BodyState::Quarantined,
            (false, _, RigidBody::Static) => BodyState::Static,
            (false, _, RigidBody::Kinematic) => BodyState::Kinematic,
            (false, true, RigidBody::Dynamic) => BodyState::Sleeping,
            (false, false, RigidBody::Dynamic) => BodyState::Dynamic,
        }
    }

    /// The configured colour of this state.
    pub fn color(self, config: &PhysicsGizmos) -> Color {
        match self {
            BodyState::Dynamic => config.dynamic_color,
            BodyState::Sleeping => config.sleeping_color,
            BodyState::Static => config.static_color,
            BodyState::Kinematic => config.kinematic_color,
            BodyState::Quarantined => config.quarantined_color,
        }
    }
}
