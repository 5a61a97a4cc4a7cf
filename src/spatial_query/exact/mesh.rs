//! A convex shape cast against the triangles of a triangle mesh or a heightfield, those its
//! swept box meets, one by one.

use bevy::math::Vec3;
use parry3d::bounding_volume::{Aabb, BoundingVolume};
use parry3d::partitioning::TraversalAction;
use parry3d::query::{Ray, RayCast};
use parry3d::shape::Triangle;

use super::convex::convex_cast;
use super::newton::tolerance;
use super::{CastHit, ShapeCast, nearest};

/// A convex shape cast against the triangles of a triangle mesh or a heightfield that its
/// swept box meets.
pub(super) fn triangles_cast(cast: &ShapeCast) -> Option<CastHit> {
    let (shape1, options) = (cast.shape1, cast.options);
    // The sweep in the mesh's frame: the cast shape's box, grown by the target distance,
    // moving along the local direction.
    let (local2, local_dir) = cast.in_collider_frame();
    let aabb = cast.shape2.compute_aabb(&local2);
    let reach = 0.5 * (aabb.maxs - aabb.mins)
        + Vec3::splat(options.target_distance + tolerance(aabb.maxs.abs().max_element()));
    let center = Ray::new(aabb.center(), local_dir);
    let sweeps = |b: &Aabb, max: f32| {
        Aabb::new(b.mins - reach, b.maxs + reach)
            .cast_local_ray(&center, max, true)
            .is_some()
    };
    let max = options.max_time_of_impact;
    let mut triangles: Vec<(u32, Triangle)> = Vec::new();
    if let Some(mesh) = shape1.as_trimesh() {
        mesh.bvh().traverse(|node| {
            if !sweeps(&node.aabb(), max) {
                return TraversalAction::Prune;
            }
            if let Some(i) = node.leaf_data() {
                triangles.push((i, mesh.triangle(i)));
            }
            TraversalAction::Continue
        });
    } else if let Some(field) = shape1.as_heightfield() {
        // The sweep ends where the box leaves the field's box, or at `max`.
        let bounds = shape1.compute_local_aabb();
        let grown = Aabb::new(bounds.mins - reach, bounds.maxs + reach);
        let end = exit_time(&grown, &center).min(max);
        let moved = Aabb::new(aabb.mins + local_dir * end, aabb.maxs + local_dir * end);
        let swept = aabb.merged(&moved).loosened(options.target_distance);
        field.map_elements_in_local_aabb(&swept, &mut |i, t| triangles.push((i, *t)));
    }
    triangles.sort_unstable_by_key(|&(i, _)| i);
    nearest(
        triangles
            .iter()
            .map(|(_, t)| convex_cast(&ShapeCast { shape1: t, ..*cast })),
    )
}

/// When a ray leaves a box (0 if it starts outside and moves away).
fn exit_time(b: &Aabb, ray: &Ray) -> f32 {
    let mut t = f32::INFINITY;
    for k in 0..3 {
        let d = ray.dir[k];
        if d > 0.0 {
            t = t.min((b.maxs[k] - ray.origin[k]) / d);
        } else if d < 0.0 {
            t = t.min((b.mins[k] - ray.origin[k]) / d);
        }
    }
    t.max(0.0)
}
