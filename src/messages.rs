//! Messages the plugin writes each step. Read them with `MessageReader`.

use bevy::prelude::*;

use crate::collision::ContactPairs;
use crate::dynamics::ImpactMessages;
use crate::dynamics::solver::ContactConstraint;

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

/// Two colliders started touching in the last step: `(a, b)`, `a < b`, one message per pair,
/// for every pair the step tracks, no opt-in needed. (impact3d's own message, kept as it was;
/// [`CollisionStart`] is avian3d's, sent only for bodies that ask for it and also triggered on
/// them.)
#[derive(Message, Clone, Copy, Debug, PartialEq, Eq)]
pub struct CollisionStarted(pub Entity, pub Entity);

/// Two colliders stopped touching in the last step (or one of them was despawned, lost its
/// collider or was quarantined, or the pair stopped being tracked: its layers no longer
/// interact, or the opt-in that made the step track a pair of non-dynamic bodies was
/// removed). `(a, b)`, `a < b`, for every pair, as [`CollisionStarted`].
#[derive(Message, Clone, Copy, Debug, PartialEq, Eq)]
pub struct CollisionEnded(pub Entity, pub Entity);

/// Two colliders started touching in the last step (avian3d 0.7's event). Written as a message
/// for each pair of colliders of which either collider, or its body, has
/// [`CollisionEventsEnabled`](crate::collision::CollisionEventsEnabled) (`body1 < body2`), and
/// triggered as an entity event on each collider of the pair that has it (on itself or on its
/// body), with that collider as `collider1`, so an observer on either collider hears of it:
///
/// ```
/// use bevy::prelude::*;
/// use impact3d::prelude::*;
///
/// # let mut world = World::new();
/// world
///     .spawn((RigidBody::Static, Collider::cuboid(1.0, 1.0, 1.0), Sensor,
///         CollisionEventsEnabled))
///     .observe(|start: On<CollisionStart>| {
///         println!("{} entered trigger {}", start.collider2, start.collider1);
///     });
/// ```
///
/// Pairs of every kind are reported, sensors and kinematic or static bodies included (see
/// [`crate::collision::sensor`]). A body's colliders, its own and those on its descendants
/// (see [`ColliderOf`](crate::collision::ColliderOf)), are one compound shape in the step, but
/// each contact knows which of them it is on: events name the collider (the child's entity
/// for a child collider, the body's for its own) in `collider1` and its body in `body1`, as
/// avian3d does, and likewise for `collider2` and `body2`. Each pair of colliders starts and
/// ends on its own. A collider that is not part of a body is its own body
/// (`body1 == Some(collider1)`).
#[derive(EntityEvent, Message, Clone, Copy, Debug, PartialEq, Eq)]
pub struct CollisionStart {
    /// The collider that started touching `collider2`; the event's target when observed.
    #[event_target]
    pub collider1: Entity,
    /// The other collider.
    pub collider2: Entity,
    /// The body of `collider1` (itself for a body's own collider or a collider without a body).
    pub body1: Option<Entity>,
    /// The body of `collider2` (itself for a body's own collider or a collider without a body).
    pub body2: Option<Entity>,
}

/// Two colliders stopped touching in the last step (or one of them left the step, as for
/// [`CollisionEnded`]): avian3d 0.7's event, written and triggered as [`CollisionStart`] is.
/// When `collider2` was despawned, only `collider1`'s observers hear of it.
#[derive(EntityEvent, Message, Clone, Copy, Debug, PartialEq, Eq)]
pub struct CollisionEnd {
    /// The collider that stopped touching `collider2`; the event's target when observed.
    #[event_target]
    pub collider1: Entity,
    /// The other collider.
    pub collider2: Entity,
    /// The body of `collider1` (itself for a body's own collider or a collider without a body).
    pub body1: Option<Entity>,
    /// The body of `collider2` (itself for a body's own collider or a collider without a body).
    pub body2: Option<Entity>,
}

/// The step's [`Impact`]s from its solved rows (`keys`: each row's candidate pair, manifold
/// and point in `pairs`): the rows that struck ([`ImpactMessages::Impacts`]), or every row
/// that pushed ([`ImpactMessages::AllContacts`]), or none, with the impulse each took over the
/// step.
pub fn impacts(
    pairs: &ContactPairs,
    rows: &[ContactConstraint],
    keys: &[(u32, u32, u32)],
    which: ImpactMessages,
) -> impl Iterator<Item = Impact> {
    rows.iter()
        .zip(keys)
        .filter(move |(c, _)| match which {
            ImpactMessages::Off => false,
            ImpactMessages::Impacts => c.impact,
            ImpactMessages::AllContacts => c.total_impulse > 0.0,
        })
        .map(|(c, &(p, _, _))| {
            let pair = &pairs.candidates()[p as usize];
            Impact {
                a: pair.a,
                b: pair.b,
                point: c.point,
                normal: c.normal,
                impulse: c.total_impulse,
            }
        })
}
