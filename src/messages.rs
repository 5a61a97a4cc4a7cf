//! Messages the plugin writes each step. Read them with `MessageReader`.

use bevy::prelude::*;

/// A contact that received a collision impulse in the last step (which contacts count is set by
/// [`SolverConfig::impact_messages`](crate::dynamics::SolverConfig::impact_messages)).
#[derive(Message, Clone, Copy, Debug, PartialEq)]
pub struct Impact {
    /// The body the normal points away from.
    pub a: Entity,
    /// The body the normal points towards.
    pub b: Entity,
    /// Contact point, world frame, m.
    pub point: Vec3,
    /// Unit normal from `a` to `b`.
    pub normal: Vec3,
    /// The scalar impulse `j` applied to this contact over the step, N s: `+j n` on `b` and
    /// `-j n` on `a`.
    pub impulse: f32,
}

/// Two colliders started touching in the last step.
#[derive(Message, Clone, Copy, Debug, PartialEq, Eq)]
pub struct CollisionStarted(pub Entity, pub Entity);

/// Two colliders stopped touching in the last step (or one of them was despawned, lost its
/// collider or was quarantined).
#[derive(Message, Clone, Copy, Debug, PartialEq, Eq)]
pub struct CollisionEnded(pub Entity, pub Entity);
