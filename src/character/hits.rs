//! What move and slide gives: its output, its hits, and the answer a hit callback returns
//! (avian3d 0.7's types).

use bevy::prelude::*;

/// The result of [`MoveAndSlide::move_and_slide`](super::MoveAndSlide::move_and_slide).
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Debug, PartialEq)]
pub struct MoveAndSlideOutput {
    /// Where the shape ended, world frame: set the `Transform`'s translation to it.
    pub position: Vec3,
    /// The velocity left after sliding along everything hit (into no contact plane), m/s: the
    /// input velocity of the next move, if the caller keeps one.
    pub projected_velocity: Vec3,
}

/// A surface met during [`MoveAndSlide::move_and_slide`](super::MoveAndSlide::move_and_slide),
/// given to its `on_hit` callback, which may change the normal, the position and the velocity.
#[derive(Debug, PartialEq)]
pub struct MoveAndSlideHitData<'a> {
    /// The body whose collider was hit.
    pub entity: Entity,
    /// How far the shape was moved along the cast (the hit's distance less the skin), m; 0 for
    /// a contact found near the shape rather than by the cast.
    pub distance: f32,
    /// The point on the hit collider, world frame.
    pub point: Vec3,
    /// The hit collider's outward normal there: the plane the motion will slide along.
    pub normal: &'a mut Dir3,
    /// The shape's position at this iteration.
    pub position: &'a mut Vec3,
    /// The velocity at this iteration, before it is projected.
    pub velocity: &'a mut Vec3,
    /// The distance to the surface without the skin, m: the cast's distance to the hit, or for
    /// a contact near the shape its separation (negative when they overlap).
    pub collision_distance: f32,
}

impl MoveAndSlideHitData<'_> {
    /// Whether the shape touches or overlaps the hit collider (no gap at all, not even the
    /// skin).
    pub fn intersects(&self) -> bool {
        self.collision_distance <= 0.0
    }
}

/// What to do with a hit, as the `on_hit` callback of
/// [`MoveAndSlide::move_and_slide`](super::MoveAndSlide::move_and_slide) answers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MoveAndSlideHitResponse {
    /// Slide along the hit's plane, and go on.
    Accept,
    /// Do not slide along it (the shape was still moved up to it), and go on.
    Ignore,
    /// Stop the move here (the shape was still moved up to the hit).
    Abort,
}

/// A hit of [`MoveAndSlide::cast_move`](super::MoveAndSlide::cast_move).
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Debug, PartialEq)]
pub struct MoveHitData {
    /// The body whose collider was hit.
    pub entity: Entity,
    /// How far the shape can move along the cast and keep the skin's gap to the hit (its
    /// distance less `skin / cos` of the angle between the motion and the normal), m, at least
    /// 0: 0 when it starts overlapping or closer than the skin.
    pub distance: f32,
    /// The point on the hit collider, world frame.
    pub point1: Vec3,
    /// The point on the cast shape at its pose at the hit, world frame.
    pub point2: Vec3,
    /// The hit collider's outward normal at `point1`.
    pub normal1: Vec3,
    /// The cast shape's outward normal at `point2`.
    pub normal2: Vec3,
    /// How far the shape travels until it touches, without the skin, m (0 when it starts
    /// overlapping).
    pub collision_distance: f32,
}

impl MoveHitData {
    /// Whether the shape started touching or overlapping the hit collider.
    pub fn intersects(self) -> bool {
        self.collision_distance == 0.0
    }
}

/// The deepest point of a contact found by
/// [`MoveAndSlide::intersections`](super::MoveAndSlide::intersections).
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Debug, PartialEq)]
pub struct ContactPoint {
    /// The point on the other collider, world frame.
    pub point: Vec3,
    /// How deep the shapes overlap there, m: positive when they overlap, negative when they
    /// are apart (within the prediction distance).
    pub penetration: f32,
}
