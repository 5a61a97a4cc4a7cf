//! Depenetration and the contacts it works from: [`MoveAndSlide::depenetrate`],
//! [`MoveAndSlide::depenetrate_intersections`], [`MoveAndSlide::intersections`].

use bevy::prelude::*;
use parry3d::bounding_volume::{Aabb, BoundingVolume};
use parry3d::math::Pose;
use parry3d::query::{ContactManifold, DefaultQueryDispatcher, PersistentQueryDispatcher};
use parry3d::shape::Shape;

use super::MoveAndSlide;
use super::config::{DepenetrationConfig, check_input};
use super::hits::ContactPoint;
use crate::collision::Collider;
use crate::spatial_query::SpatialQueryFilter;

impl MoveAndSlide<'_, '_> {
    /// The offset that moves `shape` out of every collider it overlaps and to at least the
    /// skin's distance from each one it is closer to than that, as nearly as
    /// [`DepenetrationConfig::depenetration_iterations`] passes over the contacts allow
    /// ([`depenetrate_intersections`](Self::depenetrate_intersections) on the contacts of
    /// [`intersections`](Self::intersections)). Zero for bad input.
    #[must_use]
    pub fn depenetrate(
        &self,
        shape: &Collider,
        shape_position: Vec3,
        shape_rotation: Quat,
        config: &DepenetrationConfig,
        filter: &SpatialQueryFilter,
    ) -> Vec3 {
        if config.depenetration_iterations == 0 || config.validate().is_err() {
            return Vec3::ZERO;
        }
        let skin = self.unit() * config.skin_width;
        let mut contacts = Vec::new();
        self.intersections(
            shape,
            shape_position,
            shape_rotation,
            skin,
            filter,
            |_, c, n| {
                contacts.push((n, c.penetration + skin));
                true
            },
        );
        self.depenetrate_intersections(config, &contacts)
    }

    /// The offset that moves a shape `depth` along each `(normal, depth)` (length units) at
    /// once: Gauss-Seidel passes, each pushing along every normal by what is still missing
    /// along it, until a pass's sum is below
    /// [`DepenetrationConfig::max_depenetration_error`] or the passes run out. Contacts deeper
    /// than [`DepenetrationConfig::penetration_rejection_threshold`] are left out.
    #[must_use]
    pub fn depenetrate_intersections(
        &self,
        config: &DepenetrationConfig,
        intersections: &[(Dir3, f32)],
    ) -> Vec3 {
        let unit = self.unit();
        let mut offset = Vec3::ZERO;
        for _ in 0..config.depenetration_iterations {
            let mut error = 0.0;
            for (normal, depth) in intersections {
                // (A NaN depth is rejected too.)
                if depth.is_nan() || *depth > unit * config.penetration_rejection_threshold {
                    continue;
                }
                let missing = (depth - offset.dot(normal.as_vec3())).max(0.0);
                error += missing;
                offset += missing * normal.as_vec3();
            }
            if error < unit * config.max_depenetration_error {
                break;
            }
        }
        offset
    }

    /// Calls `callback` with each collider (among those `filter` admits, sensors left out) that
    /// `shape` at `shape_position` overlaps or comes within `prediction_distance` (length
    /// units) of, once per contact manifold (several for a triangle mesh or a compound): the
    /// entity, the deepest point, and the collider's outward normal there, along which the
    /// shape would be pushed out. In order of entity, then manifold. Stops when `callback`
    /// returns false.
    pub fn intersections(
        &self,
        shape: &Collider,
        shape_position: Vec3,
        shape_rotation: Quat,
        prediction_distance: f32,
        filter: &SpatialQueryFilter,
        mut callback: impl FnMut(Entity, &ContactPoint, Dir3) -> bool,
    ) {
        if check_input(shape, shape_position, shape_rotation).is_err()
            || prediction_distance.is_nan()
            || prediction_distance < 0.0
        {
            return;
        }
        let pose = Pose::from_parts(shape_position, shape_rotation.normalize());
        let query = shape
            .shape()
            .compute_aabb(&pose)
            .loosened(prediction_distance.min(f32::MAX));
        let mut found = Vec::new();
        self.colliders.candidates(
            &self.tree,
            |aabb: &Aabb| aabb.intersects(&query),
            |c| {
                if !filter.test(c.entity, c.layers)
                    || !self.live.contains(c.entity)
                    || self.is_sensor(c.entity)
                {
                    return;
                }
                for (point, normal) in contacts(
                    &c.pose,
                    c.shape.as_ref(),
                    &pose,
                    shape.shape().as_ref(),
                    prediction_distance,
                ) {
                    found.push((c.entity, point, normal));
                }
            },
        );
        // The tree's order depends on its shape: sort (stably, keeping manifold order).
        found.sort_by_key(|(entity, _, _)| *entity);
        for (entity, point, normal) in found {
            if !callback(entity, &point, normal) {
                break;
            }
        }
    }
}

/// The deepest point of each contact manifold between the collider `shape1` at `pose1` and the
/// moving `shape2` at `pose2`, within `prediction`, with the collider's outward normal (world
/// frame). The collider is parry's first shape: its half-space contacts are right that way.
fn contacts(
    pose1: &Pose,
    shape1: &dyn Shape,
    pose2: &Pose,
    shape2: &dyn Shape,
    prediction: f32,
) -> Vec<(ContactPoint, Dir3)> {
    let mut manifolds: Vec<ContactManifold<(), ()>> = Vec::new();
    let pos12 = pose1.inv_mul(pose2);
    let ok = DefaultQueryDispatcher
        .contact_manifolds(
            &pos12,
            shape1,
            shape2,
            prediction,
            &mut manifolds,
            &mut None,
        )
        .is_ok();
    if !ok {
        return Vec::new();
    }
    let mut out = Vec::new();
    for manifold in &manifolds {
        let frame = match manifold.subshape_pos1 {
            Some(sub) => *pose1 * sub,
            None => *pose1,
        };
        let deepest = manifold
            .points
            .iter()
            .filter(|p| p.dist <= prediction && p.dist.is_finite())
            .min_by(|a, b| a.dist.total_cmp(&b.dist));
        let (Some(p), Ok(normal)) = (deepest, Dir3::new(frame.rotation * manifold.local_n1)) else {
            continue;
        };
        let point = ContactPoint {
            point: frame.transform_point(p.local_p1),
            penetration: -p.dist,
        };
        out.push((point, normal));
    }
    out
}
