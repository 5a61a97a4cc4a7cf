//! The `Collider` constructors: each checks its input, and a collider built from bad input
//! carries the reason instead of panicking.

use bevy::prelude::*;
use parry3d::math::Pose;
use parry3d::shape::{HeightFieldFlags, SharedShape, TriMeshFlags};
use parry3d::utils::Array2;

use super::Collider;
use crate::dynamics::validation::{MAX_LENGTH, within};

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
    pub(crate) fn invalid(error: String) -> Self {
        Collider {
            shape: SharedShape::ball(1.0),
            error: Some(error),
        }
    }

    /// A point at the body's origin (a sphere of radius 0): the default shape of a
    /// [`ShapeCaster`](crate::spatial_query::ShapeCaster), whose cast is then a ray's. Not for
    /// bodies: it has no mass.
    pub(crate) fn point() -> Self {
        Collider {
            shape: SharedShape::ball(0.0),
            error: None,
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

    /// A solid cylinder along the local y axis, `radius` m and `height` m tall (full height,
    /// avian3d's meaning), centred at the body's origin: it stands on a flat end.
    pub fn cylinder(radius: f32, height: f32) -> Self {
        let error =
            positive("cylinder radius", radius).or_else(|| positive("cylinder height", height));
        Self::checked(|| SharedShape::cylinder(0.5 * height, radius), error)
    }

    /// A solid cone along the local y axis, apex up: a base of `radius` m at `y = -height/2`, the
    /// apex at `y = +height/2` (full height, avian3d's meaning). Its centre of mass is a quarter
    /// of the height above the base, at `y = -height/4`.
    pub fn cone(radius: f32, height: f32) -> Self {
        let error = positive("cone radius", radius).or_else(|| positive("cone height", height));
        Self::checked(|| SharedShape::cone(0.5 * height, radius), error)
    }

    /// A box of full side lengths `x_length`, `y_length`, `z_length` m with its edges and corners
    /// rounded by `border_radius` m, added outside it (avian3d's meaning: unlike
    /// [`cuboid`](Self::cuboid), which takes half extents, these are full lengths). Its half
    /// extents are `length / 2 + border_radius`. Mass properties are those of the rounded solid
    /// (closed form: the box, six slabs, twelve quarter cylinders and eight eighths of a ball),
    /// not of the inner box alone as parry's are.
    pub fn round_cuboid(x_length: f32, y_length: f32, z_length: f32, border_radius: f32) -> Self {
        let error = positive("round cuboid x length", x_length)
            .or_else(|| positive("round cuboid y length", y_length))
            .or_else(|| positive("round cuboid z length", z_length))
            .or_else(|| positive("round cuboid border radius", border_radius));
        Self::checked(
            || {
                SharedShape::round_cuboid(
                    0.5 * x_length,
                    0.5 * y_length,
                    0.5 * z_length,
                    border_radius,
                )
            },
            error,
        )
    }

    /// One collider made of several, each placed at `(position, rotation)` in the body's frame.
    /// Mass, centre of mass and inertia are the parts' summed by the parallel-axis theorem.
    /// Nested compounds are flattened. A part that carries an error, an empty list, a
    /// non-finite or too distant position (beyond [`MAX_LENGTH`]), a rotation that is not a
    /// finite non-zero quaternion (it is normalised), or a part without volume (half-space,
    /// trimesh, heightfield) gives a collider that carries the error.
    pub fn compound(parts: Vec<(Vec3, Quat, Collider)>) -> Self {
        if parts.is_empty() {
            return Self::invalid("compound has no parts".to_string());
        }
        let mut shapes = Vec::with_capacity(parts.len());
        for (i, (position, rotation, collider)) in parts.into_iter().enumerate() {
            if let Some(error) = collider.error() {
                return Self::invalid(format!("compound part {i}: {error}"));
            }
            if !within(position.abs().max_element(), MAX_LENGTH) {
                return Self::invalid(format!(
                    "compound part {i}: position {position} is not finite or farther than \
                     {MAX_LENGTH:e} m"
                ));
            }
            let norm = rotation.length_squared();
            if !(norm.is_finite() && norm >= 1e-12) {
                return Self::invalid(format!(
                    "compound part {i}: rotation {rotation} is not a finite, non-zero quaternion"
                ));
            }
            let pose = Pose::from_parts(position, rotation.normalize());
            if let Some(inner) = collider.shape.as_compound() {
                shapes.extend(inner.shapes().iter().map(|(p, s)| (pose * *p, s.clone())));
            } else if collider.is_unbounded_or_hollow() {
                return Self::invalid(format!(
                    "compound part {i}: a {:?} has no volume and cannot be a part",
                    collider.shape.shape_type()
                ));
            } else {
                shapes.push((pose, collider.shape));
            }
        }
        Collider {
            shape: SharedShape::compound(shapes),
            error: None,
        }
    }

    /// A heightfield for static ground: a grid over the local x-z plane, `scale.x` by `scale.z`
    /// m, centred at the body's origin. `heights[i][j]` is the height (times `scale.y`) of the
    /// sample at `x = (i / (rows - 1) - 1/2) scale.x`, `z = (j / (columns - 1) - 1/2) scale.z`
    /// (avian3d's layout: rows along x, columns along z); each cell is two triangles. It has no
    /// volume, so a dynamic body using it is quarantined. Internal edges are fixed as for
    /// [`trimesh`](Self::trimesh). Fewer than two rows or two columns, rows of unequal length,
    /// a non-finite height or one beyond [`MAX_LENGTH`] after scaling, or a scale component
    /// not in `(0, MAX_LENGTH]`, gives a collider that carries the error.
    pub fn heightfield(heights: Vec<Vec<f32>>, scale: Vec3) -> Self {
        let rows = heights.len();
        let columns = heights.first().map_or(0, Vec::len);
        let error = positive("heightfield scale x", scale.x)
            .or_else(|| positive("heightfield scale y", scale.y))
            .or_else(|| positive("heightfield scale z", scale.z))
            .or_else(|| {
                (rows < 2 || columns < 2).then(|| {
                    format!(
                        "heightfield needs at least 2 x 2 samples, got {rows} rows of {columns}"
                    )
                })
            })
            .or_else(|| {
                heights.iter().position(|r| r.len() != columns).map(|i| {
                    format!(
                        "heightfield row {i} has {} samples, row 0 has {columns}",
                        heights[i].len()
                    )
                })
            })
            .or_else(|| {
                heights
                    .iter()
                    .flatten()
                    .find(|h| !within((**h * scale.y).abs(), MAX_LENGTH))
                    .map(|h| {
                        format!(
                            "heightfield height {h} (times scale y {}) is not finite or beyond \
                             {MAX_LENGTH:e} m",
                            scale.y
                        )
                    })
            });
        if let Some(error) = error {
            return Self::invalid(error);
        }
        // parry's grid is column-major with its rows along z: element (j, i) at j + i * columns
        // is heights[i][j], which is `heights` flattened row after row.
        let data: Vec<f32> = heights.into_iter().flatten().collect();
        Collider {
            shape: SharedShape::heightfield_with_flags(
                Array2::new(columns, rows, data),
                scale,
                HeightFieldFlags::FIX_INTERNAL_EDGES,
            ),
            error: None,
        }
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
        let (vertices, indices) = match checked_mesh("trimesh", vertices, indices) {
            Ok(mesh) => mesh,
            Err(error) => return Self::invalid(error),
        };
        match SharedShape::trimesh_with_flags(vertices, indices, TriMeshFlags::FIX_INTERNAL_EDGES) {
            Ok(shape) => Collider { shape, error: None },
            Err(e) => Self::invalid(format!("trimesh rejected: {e:?}")),
        }
    }

    /// A compound of convex parts approximating the solid bounded by the triangle mesh
    /// `vertices`, `indices` (parry's VHACD with its default parameters, each part the exact
    /// hull of its triangles), so that a dynamic body can have a concave shape. The mesh is
    /// checked as for [`trimesh`](Self::trimesh); a mesh that gives no part carries an error.
    pub fn convex_decomposition(vertices: Vec<Vec3>, indices: Vec<[u32; 3]>) -> Self {
        use parry3d::transformation::vhacd::{VHACD, VHACDParameters};
        let (vertices, indices) = match checked_mesh("convex decomposition", vertices, indices) {
            Ok(mesh) => mesh,
            Err(error) => return Self::invalid(error),
        };
        let decomposition =
            VHACD::decompose(&VHACDParameters::default(), &vertices, &indices, true);
        let parts: Vec<(Pose, SharedShape)> = decomposition
            .compute_exact_convex_hulls(&vertices, &indices)
            .into_iter()
            .filter_map(|(points, triangles)| SharedShape::convex_mesh(points, &triangles))
            .filter(|part| {
                let volume = part.mass_properties(1.0).mass();
                volume.is_finite() && volume > 0.0
            })
            .map(|part| (Pose::IDENTITY, part))
            .collect();
        if parts.is_empty() {
            return Self::invalid("convex decomposition gave no part with volume".to_string());
        }
        Collider {
            shape: SharedShape::compound(parts),
            error: None,
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
}

/// Checks a triangle mesh for [`Collider::trimesh`] and [`Collider::convex_decomposition`]
/// (`what` names it in errors) and drops its degenerate triangles.
fn checked_mesh(
    what: &str,
    vertices: Vec<Vec3>,
    indices: Vec<[u32; 3]>,
) -> Result<(Vec<Vec3>, Vec<[u32; 3]>), String> {
    if vertices.is_empty() {
        return Err(format!("{what} has no vertices"));
    }
    if let Some((i, v)) = vertices
        .iter()
        .enumerate()
        .find(|(_, v)| !within(v.abs().max_element(), MAX_LENGTH))
    {
        return Err(format!(
            "{what} vertex {i} = {v} is not finite or farther than {MAX_LENGTH:e} m"
        ));
    }
    let n = vertices.len();
    if let Some((t, tri)) = indices
        .iter()
        .enumerate()
        .find(|(_, tri)| tri.iter().any(|&i| i as usize >= n))
    {
        return Err(format!(
            "{what} triangle {t} = {tri:?} indexes past its {n} vertices"
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
        return Err(format!("{what} has no triangle of non-zero area"));
    }
    Ok((vertices, indices))
}

fn positive(what: &str, value: f32) -> Option<String> {
    (!(value > 0.0 && value <= MAX_LENGTH))
        .then(|| format!("{what} must be > 0 and <= {MAX_LENGTH:e} m, got {value:?}"))
}
