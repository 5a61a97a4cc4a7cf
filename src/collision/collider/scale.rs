//! Scaling a shape by a body's (possibly non-uniform) scale: exactly where parry3d can, else
//! the nearest scale the shape can take.

use bevy::prelude::*;
use parry3d::math::Pose;
use parry3d::shape::{Shape, SharedShape};

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
