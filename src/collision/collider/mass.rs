//! Mass properties of a collider's shape (rounded boxes summed by pieces) and of a body made
//! of several colliders (its parts).

use bevy::prelude::*;
use parry3d::mass_properties::MassProperties;
use parry3d::math::Pose;
use parry3d::shape::{Shape, SharedShape};

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

/// For each subshape of [`body_shape`]`(parts)`, the index of the part it comes from (a lone
/// part at the body's origin is itself: each of its subshapes, if it is a compound, is that
/// part's).
pub fn body_leaves(parts: &[BodyPart]) -> Vec<u32> {
    let leaves = |part: &BodyPart| part.shape.as_compound().map_or(1, |c| c.shapes().len());
    if let [part] = parts
        && part.pose == Pose::IDENTITY
    {
        return vec![0; leaves(part)];
    }
    let mut out = Vec::with_capacity(parts.len());
    for (i, part) in parts.iter().enumerate() {
        out.extend(std::iter::repeat_n(i as u32, leaves(part)));
    }
    out
}

/// Mass properties of one part at its density (or scaled to its own mass), in the body's frame.
pub fn part_mass_properties(part: &BodyPart) -> MassProperties {
    let mut props = shape_mass_properties(part.shape.as_ref(), part.density);
    if let Some(m) = part.mass {
        props.set_mass(m, true);
    }
    props.transform_by(&part.pose)
}

/// Mass properties of `shape` at `density`: see
/// [`Collider::mass_properties`](super::Collider::mass_properties).
pub(super) fn shape_mass_properties(shape: &dyn Shape, density: f32) -> MassProperties {
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
