//! The `Collider` component: a parry3d shape attached at the body's origin.

use bevy::prelude::*;
use parry3d::mass_properties::MassProperties;
use parry3d::shape::{Shape, ShapeType, SharedShape};

mod constructors;
#[cfg(feature = "mesh")]
mod from_mesh;
mod mass;
mod scale;

use mass::shape_mass_properties;
pub use mass::{BodyPart, body_leaves, body_shape, part_mass_properties};
pub use scale::{Scaling, scaled_shape};

/// Takes the collider out of contacts: the body still moves (gravity, forces, its velocity)
/// and keeps the mass its collider gives it, but nothing collides with it (as avian's
/// `ColliderDisabled`). Remove it and the collider takes part again from the next step.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct ColliderDisabled;

/// The collision shape of a body, placed at the entity's world pose and scaled by its world
/// scale (a `Transform` is required, so a collider spawned without one gets the identity). On
/// an entity with a [`RigidBody`](crate::dynamics::RigidBody) it is that body's; on a
/// descendant of one (through Bevy's `ChildOf`) without a `RigidBody` of its own it is a part
/// of the nearest such ancestor, which then is a compound body of all its colliders (see
/// [`ColliderOf`]); with no `RigidBody` on it or above it, it is a static collider. Mass and
/// inertia come from its (scaled) volume times [`Density`](crate::dynamics::Density) unless
/// [`Mass`](crate::dynamics::Mass) overrides them.
///
/// Constructors that cannot fail in their signature (`sphere`, `cuboid`, `capsule`, `cylinder`,
/// `cone`, `round_cuboid`, `compound`, `trimesh`, `convex_decomposition`, `heightfield`,
/// `half_space`, and with feature `mesh` the `..._from_mesh` ones) still accept bad input (empty,
/// degenerate, non-finite or out of range, sizes above
/// [`MAX_LENGTH`](crate::dynamics::validation::MAX_LENGTH)): such a collider carries the reason,
/// and the body that uses it is quarantined with a logged error naming the entity instead of
/// entering the solve. No constructor panics.
///
/// # Examples
///
/// ```
/// use impact3d::prelude::*;
///
/// let ball = Collider::sphere(0.5);
/// let crate_box = Collider::cuboid(0.5, 0.25, 1.0);
/// assert!(ball.error().is_none() && crate_box.error().is_none());
/// assert!(Collider::sphere(-1.0).error().is_some());
/// ```
#[derive(Component, Clone)]
#[require(Transform)]
pub struct Collider {
    shape: SharedShape,
    error: Option<String>,
}

impl std::fmt::Debug for Collider {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Collider")
            .field("shape", &self.shape.shape_type())
            .field("error", &self.error)
            .finish()
    }
}

impl Collider {
    /// The parry3d shape.
    pub fn shape(&self) -> &SharedShape {
        &self.shape
    }

    /// Why this collider cannot be used, if it cannot.
    pub fn error(&self) -> Option<&str> {
        self.error.as_deref()
    }

    /// True for shapes without a bounded volume (half-space, trimesh, heightfield): only static
    /// or kinematic bodies may use them.
    pub fn is_unbounded_or_hollow(&self) -> bool {
        is_unbounded_or_hollow(self.shape.as_ref())
    }

    /// Mass, centre of mass and inertia of the collider at `density` (kg/m^3): parry's, except
    /// for rounded boxes (parry ignores the rounding; see [`round_cuboid`](Self::round_cuboid))
    /// and compounds with such parts, whose parts are summed here with the same rule.
    pub fn mass_properties(&self, density: f32) -> MassProperties {
        shape_mass_properties(self.shape.as_ref(), density)
    }

    /// True when every contact normal on this shape passes through its centre (a sphere), so
    /// contacts can never change its spin.
    pub fn is_sphere(&self) -> bool {
        self.shape.shape_type() == ShapeType::Ball
    }
}

/// The body a collider on a descendant entity belongs to (avian3d's name): set by the plugin
/// each step on every entity with a [`Collider`] and no
/// [`RigidBody`](crate::dynamics::RigidBody) whose nearest ancestor with a `RigidBody` (through
/// `ChildOf`) is `body`, and removed when it no longer has one. Read-only: the hierarchy decides,
/// a value written here is replaced. The body's own collider (on the body's entity) has none.
///
/// Such a collider is a part of its body: its shape is placed at its pose relative to the body
/// (the `Transform`s in between, the body's own scale included) and scaled by its scale
/// relative to the body's frame; the body's mass, centre of mass and inertia are the sum of its
/// colliders' (see [`ComputedMass`](crate::dynamics::ComputedMass)). Its contacts, impacts and
/// collision events are its body's, reported with the body's entity. The body's
/// `Restitution`, `Friction`, `CollisionLayers`, `Sensor` and `CollisionEventsEnabled` apply to
/// all its colliders; those components on a child collider are not read. A child collider with
/// [`ColliderDisabled`] is left out of its body (no shape, no mass).
///
/// A triangle mesh, heightfield or half-space cannot be a part of a compound shape: on a child
/// entity it stays a static collider at its world pose (a warning names it once if its body is
/// not static), as does any child collider of a body whose own collider is one of these.
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq, Eq)]
#[reflect(Component, Debug, PartialEq)]
pub struct ColliderOf {
    /// The entity of the [`RigidBody`](crate::dynamics::RigidBody) this collider is part of.
    pub body: Entity,
}

/// True for shapes without a bounded volume (half-space, trimesh, heightfield): they cannot be
/// a part of a compound, and only static or kinematic bodies may use them.
pub fn is_unbounded_or_hollow(shape: &dyn Shape) -> bool {
    matches!(
        shape.shape_type(),
        ShapeType::HalfSpace | ShapeType::TriMesh | ShapeType::HeightField
    )
}
