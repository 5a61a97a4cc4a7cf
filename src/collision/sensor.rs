//! Components that ask the step to report contacts rather than (or besides) resolve them:
//! [`Sensor`], [`CollisionEventsEnabled`] and [`CollidingEntities`] (avian3d 0.7's names).
//!
//! The step finds contacts for every pair with a dynamic or sleeping body. A pair of
//! non-dynamic bodies (kinematic with static, kinematic with kinematic, or static with a static
//! sensor) has its contacts found only when one of its bodies carries one of these components,
//! so scenes that ask for nothing pay nothing for such pairs. Those pairs and every pair with a
//! [`Sensor`] get contacts and touching state (for [`CollisionStart`](crate::CollisionStart),
//! [`CollisionEnd`](crate::CollisionEnd), [`CollisionStarted`](crate::CollisionStarted),
//! [`CollisionEnded`](crate::CollisionEnded) and [`CollidingEntities`]) but never solver rows.

use bevy::ecs::entity::EntityHashSet;
use bevy::prelude::*;

/// A body that detects, never pushes: its contacts are found and reported (collision messages,
/// observers, [`CollidingEntities`]) but resolve nothing, so bodies pass through it and it
/// passes through them. A dynamic sensor still moves under gravity and keeps its mass; a
/// static or kinematic one is a trigger volume. A static sensor also detects static bodies.
///
/// Touching is decided as for any pair: a contact point of the two shapes, at their poses at
/// the start of the step, within
/// [`NarrowPhaseConfig::touch_distance`](crate::collision::NarrowPhaseConfig::touch_distance)
/// (default 5 mm). A body so fast that it crosses a sensor between two steps is not seen.
///
/// # Examples
///
/// ```
/// use bevy::prelude::*;
/// use impact3d::prelude::*;
///
/// # let mut world = World::new();
/// // A trigger volume that observers on it hear about.
/// world.spawn((RigidBody::Static, Collider::cuboid(1.0, 1.0, 1.0), Sensor,
///     CollisionEventsEnabled));
/// ```
#[derive(Reflect, Component, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Debug, Component, Default, PartialEq)]
pub struct Sensor;

/// Asks for [`CollisionStart`](crate::CollisionStart) and [`CollisionEnd`](crate::CollisionEnd)
/// for this body: they are written as messages for every pair of which either body has the
/// marker, and triggered as entity events on each body of the pair that has it (as avian3d
/// 0.7 does). It also makes the step find the contacts of this body's kinematic and static
/// pairs (see the [module](self)).
#[derive(Reflect, Component, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Debug, Component, Default, PartialEq)]
pub struct CollisionEventsEnabled;

/// The colliders this collider touches now, kept by the step (insert it, empty, on the
/// colliders that need it), as avian3d's: a body's own collider is named by the body's
/// entity, a child collider by its own. Updated in [`PhysicsSystems::Messages`](crate::schedule::PhysicsSystems) from
/// the same touching state as the collision messages; filled from the current contacts when
/// inserted. It also makes the step find the contacts of this body's kinematic and static
/// pairs (see the [module](self)).
///
/// # Examples
///
/// ```
/// use bevy::prelude::*;
/// use impact3d::prelude::*;
///
/// fn report(bodies: Query<(Entity, &CollidingEntities)>) {
///     for (entity, touching) in &bodies {
///         println!("{entity} touches {} bodies", touching.len());
///     }
/// }
/// # let mut world = World::new();
/// world.spawn((RigidBody::Dynamic, Collider::sphere(0.5), CollidingEntities::default()));
/// ```
#[derive(Reflect, Component, Clone, Debug, Default, Deref, DerefMut, PartialEq, Eq)]
#[reflect(Debug, Component, Default, PartialEq)]
pub struct CollidingEntities(pub EntityHashSet);

/// What a body asks the step to report, as the prepare stage reads it: bits of
/// [`Reporting::SENSOR`], [`Reporting::EVENTS`] and [`Reporting::COLLIDING`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Reporting(pub u8);

impl Reporting {
    /// The body is a [`Sensor`].
    pub const SENSOR: u8 = 1;
    /// The body has [`CollisionEventsEnabled`].
    pub const EVENTS: u8 = 2;
    /// The body has [`CollidingEntities`].
    pub const COLLIDING: u8 = 4;

    /// Whether the body is a sensor.
    pub fn sensor(self) -> bool {
        self.0 & Self::SENSOR != 0
    }

    /// Whether the body asks for anything: its kinematic and static pairs are then found.
    pub fn any(self) -> bool {
        self.0 != 0
    }
}
