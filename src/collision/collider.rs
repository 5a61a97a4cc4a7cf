//! The `Collider` component: a parry3d shape attached at the body's origin.

use bevy::prelude::*;
use parry3d::shape::{ShapeType, SharedShape, TriMeshFlags};

use crate::dynamics::validation::{MAX_LENGTH, within};

/// Takes the collider out of contacts: the body still moves (gravity, forces, its velocity)
/// and keeps the mass its collider gives it, but nothing collides with it (as avian's
/// `ColliderDisabled`). Remove it and the collider takes part again from the next step.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct ColliderDisabled;

/// The collision shape of a body, placed at the entity's `Transform` (bodies are top-level
/// entities; scale is ignored). Mass and inertia come from its volume times
/// [`Density`](crate::dynamics::Density) unless [`Mass`](crate::dynamics::Mass) overrides them.
///
/// Constructors that cannot fail in their signature (`sphere`, `cuboid`, `capsule`, `trimesh`,
/// `half_space`) still accept bad input (empty, degenerate, non-finite or out of range, sizes
/// above [`MAX_LENGTH`]): such a collider carries the reason, and the body that uses it is
/// quarantined with a logged error naming the entity instead of entering the solve. No
/// constructor panics.
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
    fn checked(shape: impl FnOnce() -> SharedShape, error: Option<String>) -> Self {
        match error {
            Some(error) => Self::invalid(error),
            None => Collider {
                shape: shape(),
                error: None,
            },
        }
    }

    /// A collider that carries `error`. Its placeholder shape keeps every collider a valid parry
    /// shape; it never collides, because a body whose collider has an error is quarantined.
    fn invalid(error: String) -> Self {
        Collider {
            shape: SharedShape::ball(1.0),
            error: Some(error),
        }
    }

    /// A sphere of `radius` m centred at the body's origin.
    pub fn sphere(radius: f32) -> Self {
        let error = positive("sphere radius", radius);
        Self::checked(|| SharedShape::ball(radius), error)
    }

    /// A box with half extents `hx`, `hy`, `hz` in m, centred at the body's origin.
    pub fn cuboid(hx: f32, hy: f32, hz: f32) -> Self {
        let error = positive("cuboid half extent x", hx)
            .or_else(|| positive("cuboid half extent y", hy))
            .or_else(|| positive("cuboid half extent z", hz));
        Self::checked(|| SharedShape::cuboid(hx, hy, hz), error)
    }

    /// A capsule along the local y axis: a cylinder of `half_height` m capped by hemispheres of
    /// `radius` m.
    pub fn capsule(radius: f32, half_height: f32) -> Self {
        let error = positive("capsule radius", radius).or_else(|| {
            (!(0.0..=MAX_LENGTH).contains(&half_height)).then(|| {
                format!(
                    "capsule half height must be >= 0 and <= {MAX_LENGTH:e} m, got {half_height}"
                )
            })
        });
        Self::checked(|| SharedShape::capsule_y(half_height, radius), error)
    }

    /// The convex hull of `points` (local frame, m). `None` when the hull is degenerate
    /// (fewer than four points off a common plane), or a point is not finite or farther than
    /// [`MAX_LENGTH`] from the origin.
    pub fn convex_hull(points: &[Vec3]) -> Option<Self> {
        if points.len() < 4
            || points
                .iter()
                .any(|p| !within(p.abs().max_element(), MAX_LENGTH))
        {
            return None;
        }
        let shape = SharedShape::convex_hull(points)?;
        let volume = shape.mass_properties(1.0).mass();
        (volume.is_finite() && volume > 0.0).then_some(Collider { shape, error: None })
    }

    /// A triangle mesh (local frame, m), for static bodies: it has no volume, so a dynamic body
    /// using it is quarantined.
    ///
    /// Duplicate vertices are merged and internal edges fixed (parry's
    /// `TriMeshFlags::FIX_INTERNAL_EDGES`): a body sliding across the seam between two
    /// triangles of a flat surface gets the surface's normal, not a bump from the edge.
    /// Degenerate triangles (zero area, or repeating a vertex) are dropped. A mesh with no
    /// vertices, an index out of range, a non-finite vertex or one farther than [`MAX_LENGTH`],
    /// or no triangle left, gives a collider that carries the error.
    pub fn trimesh(vertices: Vec<Vec3>, indices: Vec<[u32; 3]>) -> Self {
        if vertices.is_empty() {
            return Self::invalid("trimesh has no vertices".to_string());
        }
        if let Some((i, v)) = vertices
            .iter()
            .enumerate()
            .find(|(_, v)| !within(v.abs().max_element(), MAX_LENGTH))
        {
            return Self::invalid(format!(
                "trimesh vertex {i} = {v} is not finite or farther than {MAX_LENGTH:e} m"
            ));
        }
        let n = vertices.len();
        if let Some((t, tri)) = indices
            .iter()
            .enumerate()
            .find(|(_, tri)| tri.iter().any(|&i| i as usize >= n))
        {
            return Self::invalid(format!(
                "trimesh triangle {t} = {tri:?} indexes past its {n} vertices"
            ));
        }
        let indices: Vec<[u32; 3]> = indices
            .into_iter()
            .filter(|&[a, b, c]| {
                let (a, b, c) = (
                    vertices[a as usize],
                    vertices[b as usize],
                    vertices[c as usize],
                );
                // Zero area in f32: the cross product of two edges vanishes against their
                // lengths (relative 1e-6, about eight ulps of the product).
                let cross = (b - a).cross(c - a).length();
                cross > 1e-6 * (b - a).length() * (c - a).length()
            })
            .collect();
        if indices.is_empty() {
            return Self::invalid("trimesh has no triangle of non-zero area".to_string());
        }
        match SharedShape::trimesh_with_flags(vertices, indices, TriMeshFlags::FIX_INTERNAL_EDGES) {
            Ok(shape) => Collider { shape, error: None },
            Err(e) => Self::invalid(format!("trimesh rejected: {e:?}")),
        }
    }

    /// The half-space below the plane through the body's origin with outward normal
    /// `outward_normal` (local frame; normalised here): an infinite ground for static bodies.
    pub fn half_space(outward_normal: Vec3) -> Self {
        let n = outward_normal.normalize_or_zero();
        let error = (n == Vec3::ZERO || !n.is_finite()).then(|| {
            format!("half-space normal must be finite and non-zero, got {outward_normal}")
        });
        Self::checked(|| SharedShape::halfspace(n), error)
    }

    /// The parry3d shape.
    pub fn shape(&self) -> &SharedShape {
        &self.shape
    }

    /// Why this collider cannot be used, if it cannot.
    pub fn error(&self) -> Option<&str> {
        self.error.as_deref()
    }

    /// True for shapes without a bounded volume (half-space, trimesh): only static or kinematic
    /// bodies may use them.
    pub fn is_unbounded_or_hollow(&self) -> bool {
        matches!(
            self.shape.shape_type(),
            ShapeType::HalfSpace | ShapeType::TriMesh
        )
    }

    /// True when every contact normal on this shape passes through its centre (a sphere), so
    /// contacts can never change its spin.
    pub fn is_sphere(&self) -> bool {
        self.shape.shape_type() == ShapeType::Ball
    }
}

fn positive(what: &str, value: f32) -> Option<String> {
    (!(value > 0.0 && value <= MAX_LENGTH))
        .then(|| format!("{what} must be > 0 and <= {MAX_LENGTH:e} m, got {value:?}"))
}
