//! The geometry of debug drawing: plain functions that append the line segments of a shape,
//! a box, an arrow or a cross to a `Vec`, with no ECS in them.

use std::f32::consts::TAU;

use bevy::prelude::*;
use parry3d::math::Pose;
use parry3d::shape::Shape;

use super::PhysicsGizmos;

/// Appends the 12 edges of the box `[mins, maxs]` placed at `pose`.
pub fn box_segments(mins: Vec3, maxs: Vec3, pose: &Pose, out: &mut Vec<[Vec3; 2]>) {
    let corner = |i: usize| {
        let p = Vec3::new(
            if i & 1 == 0 { mins.x } else { maxs.x },
            if i & 2 == 0 { mins.y } else { maxs.y },
            if i & 4 == 0 { mins.z } else { maxs.z },
        );
        pose.transform_point(p)
    };
    for i in 0..8 {
        for bit in [1, 2, 4] {
            if i & bit == 0 {
                out.push([corner(i), corner(i | bit)]);
            }
        }
    }
}

/// Appends an arc of `segments` segments about `center` in the plane spanned by `u` and `v`
/// (orthonormal), radius `r`, from angle `from` to `to` (rad, from `u` towards `v`).
fn arc_segments(
    center: Vec3,
    u: Vec3,
    v: Vec3,
    r: f32,
    (from, to): (f32, f32),
    segments: u32,
    out: &mut Vec<[Vec3; 2]>,
) {
    let at = |k: u32| {
        let a = from + (to - from) * k as f32 / segments as f32;
        center + r * (a.cos() * u + a.sin() * v)
    };
    for k in 0..segments {
        out.push([at(k), at(k + 1)]);
    }
}

/// Appends the wireframe of `shape` at `pose`:
///
/// | shape | segments |
/// |---|---|
/// | ball | three great circles, `3 n` (`n` = `circle_segments`) |
/// | cuboid | 12 edges |
/// | capsule | a ring at each end of the axis, 4 lines along it, two half circles over each cap: `4 n + 4` |
/// | cylinder | a ring at each end, 4 lines along its side: `2 n + 4` |
/// | cone | a ring at its base, 4 lines to its apex: `n + 4` |
/// | rounded box | its inner box and its outer bounding box: 24 |
/// | compound | each part's wireframe at its pose |
/// | convex polyhedron | its edges |
/// | triangle mesh, heightfield | their distinct triangle edges |
/// | half-space | a square grid of `half_space_lines` lines each way, `half_space_size` from the body origin: `2 x lines` |
/// | anything else | its local bounding box, 12 |
pub fn shape_segments(
    shape: &dyn Shape,
    pose: &Pose,
    config: &PhysicsGizmos,
    out: &mut Vec<[Vec3; 2]>,
) {
    // Long on purpose: one arm per kind of shape in the table above, each a few lines; split,
    // the arms would be a dozen one-call functions.
    let n = config.circle_segments.max(4) & !1;
    let rot = pose.rotation;
    let (x, y, z) = (rot * Vec3::X, rot * Vec3::Y, rot * Vec3::Z);
    let origin = pose.translation;
    if let Some(ball) = shape.as_ball() {
        let r = ball.radius;
        for (u, v) in [(x, y), (y, z), (z, x)] {
            arc_segments(origin, u, v, r, (0.0, TAU), n, out);
        }
    } else if let Some(cuboid) = shape.as_cuboid() {
        box_segments(-cuboid.half_extents, cuboid.half_extents, pose, out);
    } else if let Some(capsule) = shape.as_capsule() {
        let (a, b) = (
            pose.transform_point(capsule.segment.a),
            pose.transform_point(capsule.segment.b),
        );
        let r = capsule.radius;
        let axis = (b - a).try_normalize().unwrap_or(y);
        let (u, v) = axis.any_orthonormal_pair();
        for c in [a, b] {
            arc_segments(c, u, v, r, (0.0, TAU), n, out);
        }
        for side in [u, -u, v, -v] {
            out.push([a + r * side, b + r * side]);
        }
        for w in [u, v] {
            // Half circles from w through the axis tip to -w.
            arc_segments(b, w, axis, r, (0.0, TAU / 2.0), n / 2, out);
            arc_segments(a, w, -axis, r, (0.0, TAU / 2.0), n / 2, out);
        }
    } else if let Some(cylinder) = shape.as_cylinder() {
        let (r, hh) = (cylinder.radius, cylinder.half_height);
        let (top, bottom) = (origin + hh * y, origin - hh * y);
        for c in [top, bottom] {
            arc_segments(c, x, z, r, (0.0, TAU), n, out);
        }
        for side in [x, -x, z, -z] {
            out.push([bottom + r * side, top + r * side]);
        }
    } else if let Some(cone) = shape.as_cone() {
        let (r, hh) = (cone.radius, cone.half_height);
        let (apex, base) = (origin + hh * y, origin - hh * y);
        arc_segments(base, x, z, r, (0.0, TAU), n, out);
        for side in [x, -x, z, -z] {
            out.push([base + r * side, apex]);
        }
    } else if let Some(round) = shape.as_round_cuboid() {
        let h = round.inner_shape.half_extents;
        box_segments(-h, h, pose, out);
        let outer = h + Vec3::splat(round.border_radius);
        box_segments(-outer, outer, pose, out);
    } else if let Some(compound) = shape.as_compound() {
        for (part_pose, part) in compound.shapes() {
            shape_segments(part.as_ref(), &(pose * *part_pose), config, out);
        }
    } else if let Some(field) = shape.as_heightfield() {
        let mut edges: Vec<[Vec3; 2]> = Vec::new();
        for tri in field.triangles() {
            for (p, q) in [(tri.a, tri.b), (tri.b, tri.c), (tri.c, tri.a)] {
                let (p, q) = if p.to_array() <= q.to_array() {
                    (p, q)
                } else {
                    (q, p)
                };
                edges.push([p, q]);
            }
        }
        edges.sort_unstable_by(|e, f| {
            e[0].to_array()
                .partial_cmp(&f[0].to_array())
                .unwrap_or(std::cmp::Ordering::Equal)
                .then(
                    e[1].to_array()
                        .partial_cmp(&f[1].to_array())
                        .unwrap_or(std::cmp::Ordering::Equal),
                )
        });
        edges.dedup();
        for [p, q] in edges {
            out.push([pose.transform_point(p), pose.transform_point(q)]);
        }
    } else if let Some(hull) = shape.as_convex_polyhedron() {
        let points = hull.points();
        for edge in hull.edges() {
            let [i, j] = edge.vertices;
            out.push([
                pose.transform_point(points[i as usize]),
                pose.transform_point(points[j as usize]),
            ]);
        }
    } else if let Some(mesh) = shape.as_trimesh() {
        let vertices = mesh.vertices();
        let mut edges: Vec<(u32, u32)> = mesh
            .indices()
            .iter()
            .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
            .map(|(i, j)| (i.min(j), i.max(j)))
            .collect();
        edges.sort_unstable();
        edges.dedup();
        for (i, j) in edges {
            out.push([
                pose.transform_point(vertices[i as usize]),
                pose.transform_point(vertices[j as usize]),
            ]);
        }
    } else if let Some(half_space) = shape.as_halfspace() {
        let normal = rot * half_space.normal;
        let (u, v) = normal.any_orthonormal_pair();
        let (size, lines) = (config.half_space_size, config.half_space_lines.max(2));
        for k in 0..lines {
            let s = -size + 2.0 * size * k as f32 / (lines - 1) as f32;
            out.push([origin + s * u - size * v, origin + s * u + size * v]);
            out.push([origin + s * v - size * u, origin + s * v + size * u]);
        }
    } else {
        let aabb = shape.compute_local_aabb();
        box_segments(aabb.mins, aabb.maxs, pose, out);
    }
}

/// Appends an arrow from `from` along `vector`: the shaft and two head lines a fifth of its
/// length (3 segments). Nothing for a zero or non-finite vector.
pub fn arrow_segments(from: Vec3, vector: Vec3, out: &mut Vec<[Vec3; 2]>) {
    let length = vector.length();
    if !(length > 0.0 && length.is_finite() && from.is_finite()) {
        return;
    }
    let dir = vector / length;
    let tip = from + vector;
    let side = dir.any_orthonormal_vector();
    let head = 0.2 * length;
    out.push([from, tip]);
    out.push([tip, tip - head * dir + 0.5 * head * side]);
    out.push([tip, tip - head * dir - 0.5 * head * side]);
}

/// Appends a cross of half size `size` at `point`, one line per axis (3 segments).
pub fn cross_segments(point: Vec3, size: f32, out: &mut Vec<[Vec3; 2]>) {
    for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
        out.push([point - size * axis, point + size * axis]);
    }
}
