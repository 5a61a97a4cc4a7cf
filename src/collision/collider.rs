//! The `Collider` component: a parry3d shape attached at the body's origin.

use bevy::prelude::*;
use parry3d::mass_properties::MassProperties;
use parry3d::math::Pose;
use parry3d::shape::{HeightFieldFlags, Shape, ShapeType, SharedShape, TriMeshFlags};
use parry3d::utils::Array2;

use crate::dynamics::validation::{MAX_LENGTH, within};

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
/// `half_space`, and with feature `mesh` the `..._from_mesh` ones) still accept bad input (empty, degenerate, non-finite or out of range, sizes
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

/// How [`scaled_shape`] scaled a shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scaling {
    /// Exactly as asked.
    Exact,
    /// The shape cannot take the asked non-uniform scale (a sphere, capsule, rounded box; a
    /// cylinder or cone scaled differently along its two radial axes; a part of a compound
    /// turned against the scale's axes): the nearest it can take was used.
    Nearest,
}

/// `shape` scaled by `scale` (each component finite and > 0) along its local axes, and whether
/// that was exact. Cuboids, convex hulls, triangle meshes, heightfields and half-spaces take any
/// scale exactly (a half-space's normal turns as the scaled plane does); cylinders and cones a
/// scale whose x and z are equal (their radius by x, their height by y). A shape that cannot take
/// the scale gets the nearest uniform one, the geometric mean `(sx sy sz)^(1/3)`, which keeps
/// its volume (a cylinder or cone keeps its height scale and takes `(sx sz)^(1/2)` for its
/// radius, which keeps its volume too). A compound scales its parts' positions exactly and
/// each part along its own axes: exactly when the part's axes are the scale's (up to sign and
/// order), else by the lengths the scale gives its axes. `Err` names a shape parry cannot scale
/// (a hull degenerate after scaling).
///
/// # Examples
///
/// ```
/// use bevy::prelude::*;
/// use impact3d::collision::collider::{Scaling, scaled_shape};
/// use impact3d::prelude::*;
///
/// let (box2, how) = scaled_shape(Collider::cuboid(0.5, 0.5, 0.5).shape(), Vec3::new(2.0, 1.0, 1.0)).unwrap();
/// assert_eq!(box2.as_cuboid().unwrap().half_extents, Vec3::new(1.0, 0.5, 0.5));
/// assert_eq!(how, Scaling::Exact);
/// let (ball, how) = scaled_shape(Collider::sphere(1.0).shape(), Vec3::new(8.0, 1.0, 1.0)).unwrap();
/// assert_eq!(ball.as_ball().unwrap().radius, 2.0); // (8 x 1 x 1)^(1/3)
/// assert_eq!(how, Scaling::Nearest);
/// ```
pub fn scaled_shape(shape: &SharedShape, scale: Vec3) -> Result<(SharedShape, Scaling), String> {
    if scale == Vec3::ONE {
        return Ok((shape.clone(), Scaling::Exact));
    }
    let mut how = Scaling::Exact;
    let scaled = scale_part(shape.as_ref(), scale, &mut how)?;
    Ok((scaled, how))
}

/// [`scaled_shape`] for one shape, recording in `how` when it was not exact.
fn scale_part(shape: &dyn Shape, s: Vec3, how: &mut Scaling) -> Result<SharedShape, String> {
    use parry3d::shape::{Capsule, Cone, Cuboid, Cylinder, RoundShape};
    let uniform = s.x == s.y && s.y == s.z;
    let mut nearest = || {
        if !uniform {
            *how = Scaling::Nearest;
        }
        if uniform {
            s.x
        } else {
            (s.x * s.y * s.z).cbrt()
        }
    };
    let degenerate = || format!("a {:?} scaled by {s} is degenerate", shape.shape_type());
    Ok(if let Some(ball) = shape.as_ball() {
        SharedShape::ball(ball.radius * nearest())
    } else if let Some(cuboid) = shape.as_cuboid() {
        SharedShape::new(Cuboid::new(cuboid.half_extents * s))
    } else if let Some(round) = shape.as_round_cuboid() {
        let u = nearest();
        SharedShape::new(RoundShape {
            inner_shape: Cuboid::new(round.inner_shape.half_extents * u),
            border_radius: round.border_radius * u,
        })
    } else if let Some(capsule) = shape.as_capsule() {
        let u = nearest();
        SharedShape::new(Capsule::new(
            capsule.segment.a * u,
            capsule.segment.b * u,
            capsule.radius * u,
        ))
    } else if let Some(cylinder) = shape.as_cylinder() {
        let radial = radial_scale(s, how);
        SharedShape::new(Cylinder::new(
            cylinder.half_height * s.y,
            cylinder.radius * radial,
        ))
    } else if let Some(cone) = shape.as_cone() {
        let radial = radial_scale(s, how);
        SharedShape::new(Cone::new(cone.half_height * s.y, cone.radius * radial))
    } else if let Some(hull) = shape.as_convex_polyhedron() {
        SharedShape::new(hull.clone().scaled(s).ok_or_else(degenerate)?)
    } else if let Some(mesh) = shape.as_trimesh() {
        SharedShape::new(mesh.clone().scaled(s))
    } else if let Some(field) = shape.as_heightfield() {
        SharedShape::new(field.clone().scaled(s))
    } else if let Some(half) = shape.as_halfspace() {
        SharedShape::new(half.scaled(s).ok_or_else(degenerate)?)
    } else if let Some(compound) = shape.as_compound() {
        let mut parts = Vec::with_capacity(compound.shapes().len());
        for (pose, part) in compound.shapes() {
            let local = part_scale(pose.rotation, s, how);
            let placed = Pose::from_parts(pose.translation * s, pose.rotation);
            parts.push((placed, scale_part(part.as_ref(), local, how)?));
        }
        SharedShape::compound(parts)
    } else {
        return Err(format!("a {:?} cannot be scaled here", shape.shape_type()));
    })
}

/// The radius scale of a cylinder or cone (its axis along y) under `s`: `s.x` when `s.x == s.z`,
/// else the nearest, `(s.x s.z)^(1/2)`.
fn radial_scale(s: Vec3, how: &mut Scaling) -> f32 {
    if s.x == s.z {
        s.x
    } else {
        *how = Scaling::Nearest;
        (s.x * s.z).sqrt()
    }
}

/// The scale along the axes of a part turned by `rotation` that the scale `s` of its compound's
/// frame gives: the length of each of its axes after scaling, `|s * (R e_k)|`. Exact when the
/// part's axes are the frame's up to sign and order (or `s` is uniform); otherwise the scaled
/// part would be sheared, and this is the nearest scale along its own axes.
fn part_scale(rotation: Quat, s: Vec3, how: &mut Scaling) -> Vec3 {
    if s.x == s.y && s.y == s.z {
        return s;
    }
    let r = Mat3::from_quat(rotation);
    let mut local = Vec3::ZERO;
    let mut aligned = true;
    for k in 0..3 {
        let axis = r.col(k);
        local[k] = (axis * s).length();
        // An axis along a frame axis has one component of magnitude 1 (to rounding).
        aligned &= axis.abs().max_element() > 1.0 - 1e-6;
    }
    if !aligned {
        *how = Scaling::Nearest;
    }
    local
}

/// True for shapes without a bounded volume (half-space, trimesh, heightfield): they cannot be
/// a part of a compound, and only static or kinematic bodies may use them.
pub fn is_unbounded_or_hollow(shape: &dyn Shape) -> bool {
    matches!(
        shape.shape_type(),
        ShapeType::HalfSpace | ShapeType::TriMesh | ShapeType::HeightField
    )
}

/// One collider of a compound body, for [`body_shape`] and
/// [`ComputedMass::from_parts`](crate::dynamics::ComputedMass::from_parts): its shape, already
/// scaled, placed at `pose` in the body's frame (the body's origin, unscaled), with its own
/// density (kg/m^3) or mass (kg).
#[derive(Clone, Debug)]
pub struct BodyPart {
    /// The scaled shape.
    pub shape: SharedShape,
    /// Its pose in the body's frame.
    pub pose: Pose,
    /// Its density, kg/m^3.
    pub density: f32,
    /// Its own mass, kg, when it has a [`Mass`](crate::dynamics::Mass): its inertia is scaled to
    /// match.
    pub mass: Option<f32>,
}

/// The shape of a body made of `parts` (not empty, none unbounded or hollow unless it is the
/// only one): a lone part at the body's origin is itself, so a scaled sphere stays a sphere;
/// otherwise the compound of the parts, compound parts flattened into it.
pub fn body_shape(parts: &[BodyPart]) -> SharedShape {
    if let [part] = parts
        && part.pose == Pose::IDENTITY
    {
        return part.shape.clone();
    }
    let mut shapes = Vec::with_capacity(parts.len());
    for part in parts {
        if let Some(inner) = part.shape.as_compound() {
            shapes.extend(
                inner
                    .shapes()
                    .iter()
                    .map(|(p, s)| (part.pose * *p, s.clone())),
            );
        } else {
            shapes.push((part.pose, part.shape.clone()));
        }
    }
    SharedShape::compound(shapes)
}

/// Mass properties of one part at its density (or scaled to its own mass), in the body's frame.
pub fn part_mass_properties(part: &BodyPart) -> MassProperties {
    let mut props = shape_mass_properties(part.shape.as_ref(), part.density);
    if let Some(m) = part.mass {
        props.set_mass(m, true);
    }
    props.transform_by(&part.pose)
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

/// Mass properties of `shape` at `density`: see [`Collider::mass_properties`].
fn shape_mass_properties(shape: &dyn Shape, density: f32) -> MassProperties {
    if let Some(round) = shape.as_round_cuboid() {
        round_cuboid_mass_properties(round.inner_shape.half_extents, round.border_radius, density)
    } else if let Some(compound) = shape.as_compound() {
        compound
            .shapes()
            .iter()
            .map(|(pose, part)| shape_mass_properties(part.as_ref(), density).transform_by(pose))
            .sum()
    } else {
        shape.mass_properties(density)
    }
}

/// Mass properties of the box of half extents `h` rounded by `r` (the set of points within `r`
/// of the box), density `rho`, by its pieces: the box; the six slabs `r` thick on its faces;
/// the twelve quarter cylinders of radius `r` along its edges (a quarter disc's centroid is
/// `4r / (3 pi)` from each side, its mean squared distance from a side `r^2 / 4`); the eight
/// eighths of a ball at its corners (centroid `3r/8`, mean squared `r^2 / 5`). Each piece adds
/// its second moments `S_k = sum m x_k^2` about the centre; `I_x = S_y + S_z` and so on. The
/// centre of mass is the origin, and by symmetry the axes are principal.
fn round_cuboid_mass_properties(h: Vec3, r: f32, rho: f32) -> MassProperties {
    use std::f32::consts::PI;
    let (a, b, c) = (h.x, h.y, h.z);
    let mut mass = 0.0;
    let mut second = Vec3::ZERO;
    // The box.
    let m = rho * 8.0 * a * b * c;
    mass += m;
    second += m * h * h / 3.0;
    // Slabs: two on the faces normal to axis k, each of mass rho r (area of the face).
    let outer_mean_square = |x: f32| ((x + r).powi(3) - x.powi(3)) / (3.0 * r);
    for k in 0..3 {
        let (u, v) = ((k + 1) % 3, (k + 2) % 3);
        let m = 2.0 * rho * r * 4.0 * h[u] * h[v];
        mass += m;
        let mut s = Vec3::ZERO;
        s[k] = m * outer_mean_square(h[k]);
        s[u] = m * h[u] * h[u] / 3.0;
        s[v] = m * h[v] * h[v] / 3.0;
        second += s;
    }
    // Quarter cylinders: four along axis k, each of length 2 h_k.
    let quarter_mean_square = |x: f32| x * x + 2.0 * x * 4.0 * r / (3.0 * PI) + r * r / 4.0;
    for k in 0..3 {
        let (u, v) = ((k + 1) % 3, (k + 2) % 3);
        let m = 4.0 * rho * 2.0 * h[k] * PI * r * r / 4.0;
        mass += m;
        let mut s = Vec3::ZERO;
        s[k] = m * h[k] * h[k] / 3.0;
        s[u] = m * quarter_mean_square(h[u]);
        s[v] = m * quarter_mean_square(h[v]);
        second += s;
    }
    // Corners: eight eighths of a ball, one ball in all.
    let m = rho * 4.0 / 3.0 * PI * r.powi(3);
    mass += m;
    second += m * (h * h + 2.0 * h * 3.0 * r / 8.0 + Vec3::splat(r * r / 5.0));
    let inertia = Vec3::new(
        second.y + second.z,
        second.x + second.z,
        second.x + second.y,
    );
    MassProperties::new(Vec3::ZERO, mass, inertia)
}

fn positive(what: &str, value: f32) -> Option<String> {
    (!(value > 0.0 && value <= MAX_LENGTH))
        .then(|| format!("{what} must be > 0 and <= {MAX_LENGTH:e} m, got {value:?}"))
}

#[cfg(feature = "mesh")]
mod from_mesh {
    use bevy::mesh::{Indices, Mesh, PrimitiveTopology, VertexAttributeValues};
    use bevy::prelude::*;

    use super::Collider;

    impl Collider {
        /// A static triangle mesh ([`trimesh`](Self::trimesh)) from a Bevy `Mesh`'s positions
        /// and triangles (feature `mesh`). Unlike avian3d, which returns an `Option`, a mesh
        /// that cannot be read (not a triangle list, no `Float32x3` positions) gives a collider
        /// that carries the error, as every other constructor here.
        pub fn trimesh_from_mesh(mesh: &Mesh) -> Self {
            match mesh_triangles(mesh) {
                Ok((vertices, indices)) => Self::trimesh(vertices, indices),
                Err(error) => Self::invalid(error),
            }
        }

        /// The convex hull of a Bevy `Mesh`'s vertex positions ([`convex_hull`](Self::convex_hull);
        /// feature `mesh`); a mesh that cannot be read or whose hull is degenerate gives a
        /// collider that carries the error.
        pub fn convex_hull_from_mesh(mesh: &Mesh) -> Self {
            match mesh_triangles(mesh) {
                Ok((vertices, _)) => Self::convex_hull(&vertices).unwrap_or_else(|| {
                    Self::invalid(
                        "mesh's convex hull is degenerate or a vertex is not finite or too far"
                            .to_string(),
                    )
                }),
                Err(error) => Self::invalid(error),
            }
        }

        /// A compound of convex parts from a Bevy `Mesh`
        /// ([`convex_decomposition`](Self::convex_decomposition); feature `mesh`).
        pub fn convex_decomposition_from_mesh(mesh: &Mesh) -> Self {
            match mesh_triangles(mesh) {
                Ok((vertices, indices)) => Self::convex_decomposition(vertices, indices),
                Err(error) => Self::invalid(error),
            }
        }
    }

    /// The positions and triangles of a triangle-list `mesh` (without indices, every three
    /// vertices are a triangle).
    fn mesh_triangles(mesh: &Mesh) -> Result<(Vec<Vec3>, Vec<[u32; 3]>), String> {
        if mesh.primitive_topology() != PrimitiveTopology::TriangleList {
            return Err(format!(
                "mesh topology is {:?}, not a triangle list",
                mesh.primitive_topology()
            ));
        }
        let unreadable = |e| format!("mesh data cannot be read here: {e}");
        let vertices: Vec<Vec3> = match mesh
            .try_attribute_option(Mesh::ATTRIBUTE_POSITION)
            .map_err(unreadable)?
        {
            Some(VertexAttributeValues::Float32x3(positions)) => {
                positions.iter().map(|&p| Vec3::from_array(p)).collect()
            }
            Some(_) => return Err("mesh positions are not Float32x3".to_string()),
            None => return Err("mesh has no positions".to_string()),
        };
        let flat: Vec<u32> = match mesh.try_indices_option().map_err(unreadable)? {
            Some(Indices::U16(i)) => i.iter().map(|&i| i as u32).collect(),
            Some(Indices::U32(i)) => i.clone(),
            None => (0..vertices.len() as u32).collect(),
        };
        let indices = flat.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
        Ok((vertices, indices))
    }
}
