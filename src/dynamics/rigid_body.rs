//! The components that make an entity a rigid body.

use bevy::prelude::*;

use super::forces::AccumulatedForces;
use super::mass::ComputedMass;
use super::sleep::SleepTimer;

/// How a body moves. Spawning `RigidBody` + [`Collider`](crate::collision::Collider) (+ the
/// `Transform` Bevy adds) is enough; the other body components are required with their defaults.
///
/// - `Dynamic`: moved by gravity and contacts; mass and inertia from the collider.
/// - `Static`: never moves; contacts treat it as infinitely heavy (`1/m = 0`, `I^-1 = 0`).
/// - `Kinematic`: moves at its [`LinearVelocity`] and [`AngularVelocity`] and pushes dynamic
///   bodies, but neither gravity nor contacts change it (`1/m = 0`, `I^-1 = 0`).
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[reflect(Component, Debug, Default, PartialEq)]
#[require(
    Transform,
    LinearVelocity,
    AngularVelocity,
    Restitution,
    Friction,
    Density,
    ComputedMass,
    SleepTimer,
    AccumulatedForces
)]
pub enum RigidBody {
    /// Moved by gravity and contacts.
    #[default]
    Dynamic,
    /// Never moves.
    Static,
    /// Moves at its set velocity; unaffected by contacts and gravity.
    Kinematic,
}

impl RigidBody {
    // These take `&self`: with `self` by value, a call on a `&RigidBody` (as from a query) would
    // resolve to `PartialReflect::is_dynamic(&self)` instead, which answers another question.

    /// True for [`RigidBody::Dynamic`].
    pub fn is_dynamic(&self) -> bool {
        *self == RigidBody::Dynamic
    }

    /// True for [`RigidBody::Static`].
    pub fn is_static(&self) -> bool {
        *self == RigidBody::Static
    }

    /// True for [`RigidBody::Kinematic`].
    pub fn is_kinematic(&self) -> bool {
        *self == RigidBody::Kinematic
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Regression: called through a reference, as a query yields it, `is_dynamic` must be ours,
    /// not `PartialReflect::is_dynamic` (which is false for every concrete type).
    #[test]
    fn is_dynamic_through_a_reference() {
        let body = &RigidBody::Dynamic;
        assert!(body.is_dynamic());
        assert!(!body.is_static() && !body.is_kinematic());
        assert!(RigidBody::Static.is_static());
    }
}

/// Linear velocity of the centre of mass, world frame, in m/s. Default zero.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Deref, DerefMut)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct LinearVelocity(pub Vec3);

/// Angular velocity, world frame, in rad/s. Default zero.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Deref, DerefMut)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct AngularVelocity(pub Vec3);

/// Coefficient of restitution `e` in `[0, 1]`: the ratio of separation to approach speed in an
/// impact. Default 0 (perfectly inelastic). A pair uses the larger of its two bodies' values,
/// unless one of them has a [`RestitutionCombine`].
/// Values outside `[0, 1]` are clamped, with a warning naming the entity.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Deref, DerefMut)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct Restitution(pub f32);

/// Coulomb friction coefficient, dimensionless. Default 0: friction is off and costs nothing.
/// A pair uses the larger of its two bodies' values (unless one of them has a
/// [`FrictionCombine`]); friction acts in the resting-contact solve
/// (see [`SolverMethod`](crate::dynamics::solver::SolverMethod)).
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Deref, DerefMut)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct Friction(pub f32);

/// How a pair's coefficient is made from its two bodies' values (avian3d 0.7's rules and
/// priority). When the two bodies ask for different rules, the later variant in this list wins:
/// `Max > Multiply > Min > GeometricMean > Average`.
///
/// # Examples
///
/// ```
/// use impact3d::prelude::*;
///
/// assert_eq!(CoefficientCombine::Average.mix(0.2, 0.8), 0.5);
/// assert_eq!(CoefficientCombine::Multiply.mix(0.2, 0.8), 0.2 * 0.8);
/// assert!(CoefficientCombine::Max > CoefficientCombine::Min);
/// ```
#[derive(Reflect, Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[reflect(Debug, PartialEq)]
pub enum CoefficientCombine {
    /// `(a + b) / 2`.
    Average = 1,
    /// `sqrt(a b)`.
    GeometricMean = 2,
    /// `min(a, b)`.
    Min = 3,
    /// `a b`.
    Multiply = 4,
    /// `max(a, b)`: impact3d's rule for pairs whose bodies ask for none.
    Max = 5,
}

impl CoefficientCombine {
    /// The coefficient of a pair whose bodies have `a` and `b` under this rule.
    pub fn mix(self, a: f32, b: f32) -> f32 {
        match self {
            CoefficientCombine::Average => (a + b) * 0.5,
            CoefficientCombine::GeometricMean => (a * b).sqrt(),
            CoefficientCombine::Min => a.min(b),
            CoefficientCombine::Multiply => a * b,
            CoefficientCombine::Max => a.max(b),
        }
    }

    /// The rule of a pair whose bodies ask for `a` and `b` (`None`: no preference): the
    /// higher-priority one, [`Max`](Self::Max) when neither asks.
    pub fn of_pair(a: Option<Self>, b: Option<Self>) -> Self {
        a.max(b).unwrap_or(CoefficientCombine::Max)
    }
}

/// The rule by which this body's [`Restitution`] combines with another body's in a contact
/// (see [`CoefficientCombine`] for the priority when the two ask for different rules). Without
/// it a body states no preference: a pair where neither body has one uses `Max`, as before
/// combine rules existed.
///
/// A separate component rather than a field of [`Restitution`] (avian3d puts a
/// `combine_rule` field there) so that `Restitution(f32)` stays the tuple struct every scene
/// writes, and so that "no preference" exists: impact3d's default rule, `Max`, has the highest
/// priority, so a default that took part in the priority would override every body's choice.
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq, Eq, Deref, DerefMut)]
#[reflect(Component, Debug, PartialEq)]
pub struct RestitutionCombine(pub CoefficientCombine);

/// The rule by which this body's [`Friction`] combines with another body's in a contact: as
/// [`RestitutionCombine`] for friction (no preference without it; `Max` when neither asks).
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq, Eq, Deref, DerefMut)]
#[reflect(Component, Debug, PartialEq)]
pub struct FrictionCombine(pub CoefficientCombine);

/// The combine rules a body asks for (`None`: no preference), as the step keeps them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CombineRules {
    /// From [`RestitutionCombine`].
    pub restitution: Option<CoefficientCombine>,
    /// From [`FrictionCombine`].
    pub friction: Option<CoefficientCombine>,
}

/// Optional mass override in kg. Without it the mass is the collider's volume times [`Density`];
/// with it the inertia is scaled to match, keeping the collider's mass distribution.
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq, Deref, DerefMut)]
#[reflect(Component, Debug, PartialEq)]
pub struct Mass(pub f32);

/// Density in kg/m^3, used when no [`Mass`] is given. Default 1000 (water).
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq, Deref, DerefMut)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct Density(pub f32);

impl Default for Density {
    fn default() -> Self {
        Density(1000.0)
    }
}

/// Locks translation along and rotation about world axes. Default: nothing locked.
///
/// - Rotation: a locked axis has its row and column of the world inverse inertia zeroed, so no
///   contact, torque or impulse turns the body about it; with all three locked the body is a
///   particle and the solver skips the angular terms of its contacts.
/// - Translation: the centre of mass keeps its coordinate along a locked axis exactly (the
///   step starts with that velocity component zeroed, and the coordinate and the component are
///   put back after the solve). The contact solve itself still treats the body as free along
///   the axis (its inverse mass is a scalar), so a body that hits a translation-locked one
///   along a locked axis rebounds as from a free body of the same mass, not as from a wall.
///
/// # Examples
///
/// ```
/// use bevy::prelude::*;
/// use impact3d::prelude::*;
///
/// // A puck that slides in the xz plane and only turns about y.
/// let puck = LockedAxes::new()
///     .lock_translation_y()
///     .lock_rotation_x()
///     .lock_rotation_z();
/// assert_eq!(puck.translation, BVec3::new(false, true, false));
/// assert_eq!(puck.rotation, BVec3::new(true, false, true));
/// ```
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct LockedAxes {
    /// Rotation about world x, y, z is locked.
    pub rotation: BVec3,
    /// Translation along world x, y, z is locked.
    pub translation: BVec3,
}

impl LockedAxes {
    /// All rotation locked: the body translates only.
    pub const ROTATION_LOCKED: LockedAxes = LockedAxes {
        rotation: BVec3::TRUE,
        translation: BVec3::FALSE,
    };

    /// All translation locked: the body turns about its centre of mass only.
    pub const TRANSLATION_LOCKED: LockedAxes = LockedAxes {
        rotation: BVec3::FALSE,
        translation: BVec3::TRUE,
    };

    /// Everything locked: the body does not move at all.
    pub const ALL_LOCKED: LockedAxes = LockedAxes {
        rotation: BVec3::TRUE,
        translation: BVec3::TRUE,
    };

    /// Nothing locked.
    pub const fn new() -> Self {
        LockedAxes {
            rotation: BVec3::FALSE,
            translation: BVec3::FALSE,
        }
    }

    /// Locks rotation about the world axes marked true (translation unlocked).
    pub fn rotation(x: bool, y: bool, z: bool) -> Self {
        LockedAxes {
            rotation: BVec3::new(x, y, z),
            translation: BVec3::FALSE,
        }
    }

    /// Locks translation along the world axes marked true (rotation unlocked).
    pub fn translation(x: bool, y: bool, z: bool) -> Self {
        LockedAxes {
            rotation: BVec3::FALSE,
            translation: BVec3::new(x, y, z),
        }
    }

    /// Also locks translation along world x.
    pub const fn lock_translation_x(mut self) -> Self {
        self.translation.x = true;
        self
    }

    /// Also locks translation along world y.
    pub const fn lock_translation_y(mut self) -> Self {
        self.translation.y = true;
        self
    }

    /// Also locks translation along world z.
    pub const fn lock_translation_z(mut self) -> Self {
        self.translation.z = true;
        self
    }

    /// Also locks rotation about world x.
    pub const fn lock_rotation_x(mut self) -> Self {
        self.rotation.x = true;
        self
    }

    /// Also locks rotation about world y.
    pub const fn lock_rotation_y(mut self) -> Self {
        self.rotation.y = true;
        self
    }

    /// Also locks rotation about world z.
    pub const fn lock_rotation_z(mut self) -> Self {
        self.rotation.z = true;
        self
    }
}

/// Gravity, in m/s^2. Default `(0, -9.81, 0)`.
#[derive(Resource, Reflect, Clone, Copy, Debug, PartialEq, Deref, DerefMut)]
#[reflect(Resource, Debug, Default, PartialEq)]
pub struct Gravity(pub Vec3);

impl Default for Gravity {
    fn default() -> Self {
        Gravity(Vec3::new(0.0, -9.81, 0.0))
    }
}

/// Marks a body that bad input (non-finite pose or velocity, bad mass or density, a degenerate
/// collider) keeps out of the solve. The reason is logged as an error once, naming the entity;
/// the marker is removed, with a log line, as soon as the body's input is valid again.
#[derive(Component, Clone, Debug, PartialEq, Eq)]
pub struct Quarantined {
    /// Why the body is left out.
    pub reason: String,
}

/// Takes the body (and its collider) out of the simulation entirely: it is not read, moved or
/// collided with, and other bodies pass through it; its components keep their values. Remove
/// the component and the body rejoins the next step as it was (as avian's
/// `RigidBodyDisabled`). On a collider without a `RigidBody` it removes that static collider.
///
/// # Examples
///
/// ```
/// use bevy::prelude::*;
/// use impact3d::prelude::*;
///
/// fn hide(mut commands: Commands, crates: Query<Entity, With<RigidBody>>) {
///     for e in &crates {
///         commands.entity(e).insert(RigidBodyDisabled);
///     }
/// }
/// # bevy::ecs::system::assert_is_system(hide);
/// ```
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct RigidBodyDisabled;
