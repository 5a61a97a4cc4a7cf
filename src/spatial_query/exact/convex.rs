//! One convex shape cast against another by Newton's method on their distance, with parry's
//! meaning of the cast options.

use bevy::math::Vec3;
use parry3d::math::Pose;
use parry3d::query::{self, ClosestPoints, ShapeCastOptions};

use super::newton::{Approach, Probe, Reach, core_and_border, newton, tolerance};
use super::{CastHit, ShapeCast};

/// One convex shape cast against another by Newton's method on their distance (see the module
/// documentation), with parry's meaning of the options: a cast that starts within the target
/// distance (or penetrating) hits at 0, with the contact's points and normals, unless the
/// origin penetration is to be ignored and the shape moves out along the contact normal.
pub(super) fn convex_cast(cast: &ShapeCast) -> Option<CastHit> {
    // In the collider's frame, where the closest points near a contact are small numbers
    // whose difference keeps its precision; each shape as its core, its border added to the
    // target distance (a rounded shape is its core grown by its border).
    let (local2, local_dir) = cast.in_collider_frame();
    let (core1, border1) = core_and_border(cast.shape1);
    let (core2, border2) = core_and_border(cast.shape2);
    let grown = ShapeCastOptions {
        target_distance: cast.options.target_distance + border1 + border2,
        ..*cast.options
    };
    let hit = local_convex_cast(&ShapeCast {
        pose1: &Pose::IDENTITY,
        shape1: core1,
        pose2: &local2,
        dir: local_dir,
        shape2: core2,
        options: &grown,
    })?;
    // Back from the cores to the surfaces, and to the world.
    let (pose1, n1, n2) = (cast.pose1, hit.normal1, hit.normal2);
    Some(CastHit {
        distance: hit.distance,
        point1: pose1.transform_point(hit.point1 + n1 * border1),
        point2: pose1.transform_point(hit.point2 + n2 * border2),
        normal1: pose1.rotation * n1,
        normal2: pose1.rotation * n2,
    })
}

impl ShapeCast<'_> {
    /// The pose of the cast shape at time `t` (a distance along the motion).
    fn at(&self, t: f32) -> Pose {
        Pose::from_parts(self.pose2.translation + self.dir * t, self.pose2.rotation)
    }

    /// The closest points of the two shapes at time `t`; `None` when the query fails.
    fn closest(&self, t: f32) -> Option<ClosestPoints> {
        query::closest_points(self.pose1, self.shape1, &self.at(t), self.shape2, f32::MAX).ok()
    }
}

/// The gap of a shape cast is the shapes' distance less the target distance; its normal points
/// from the collider to the cast shape; a probe keeps the closest points.
impl Approach for ShapeCast<'_> {
    type Near = (Vec3, Vec3);

    fn probe(&self, t: f32) -> Option<Probe<(Vec3, Vec3)>> {
        match self.closest(t)? {
            ClosestPoints::WithinMargin(p1, p2) => {
                let delta = p2 - p1;
                let distance = delta.length();
                Some(Probe::Apart {
                    gap: distance - self.options.target_distance,
                    normal: delta / distance,
                    near: (p1, p2),
                })
            }
            // parry calls shapes a hair apart intersecting.
            ClosestPoints::Intersecting => Some(Probe::Inside),
            ClosestPoints::Disjoint => None,
        }
    }

    fn reached(&self, t: f32) -> Option<bool> {
        let apart = match self.closest(t)? {
            ClosestPoints::WithinMargin(p1, p2) => {
                (p2 - p1).length() > self.options.target_distance
            }
            _ => false,
        };
        Some(!apart)
    }
}

/// [`convex_cast`] in the collider's frame: `cast.pose1` is the identity.
fn local_convex_cast(cast: &ShapeCast) -> Option<CastHit> {
    let (s1, s2) = (
        cast.shape1.compute_local_bounding_sphere(),
        cast.shape2.compute_local_bounding_sphere(),
    );
    let scale = cast.pose2.translation.abs().max_element()
        + s1.center.length()
        + s1.radius
        + s2.center.length()
        + s2.radius;
    let tol = tolerance(scale);
    let max = cast.options.max_time_of_impact;
    match newton(cast, cast.dir, max, tol, true)? {
        Reach::Start => start_hit(cast),
        Reach::Crossed { t, normal, near } => touching_hit(cast, t, normal, near, tol),
        // Within the target distance the closest points are well apart, and their direction
        // is the normal.
        Reach::Touching {
            t,
            normal,
            near: (p1, p2),
            ..
        } if cast.options.target_distance > 0.0 => Some(CastHit {
            distance: t,
            point1: p1,
            point2: p2,
            normal1: normal,
            normal2: -normal,
        }),
        Reach::Touching {
            t, near, before, ..
        } => touching_hit(cast, t, before, near, tol),
    }
}

/// The hit of a cast that starts penetrating or within the target distance (parry's rule),
/// in the collider's frame.
fn start_hit(cast: &ShapeCast) -> Option<CastHit> {
    let contact =
        query::contact(cast.pose1, cast.shape1, cast.pose2, cast.shape2, f32::MAX).ok()??;
    if !cast.options.stop_at_penetration && contact.normal1.dot(cast.dir) >= 0.0 {
        return None;
    }
    Some(CastHit {
        distance: 0.0,
        point1: contact.point1,
        point2: contact.point2,
        normal1: contact.normal1,
        normal2: contact.normal2,
    })
}

/// The hit of a cast whose shapes touch at `t`, in the collider's frame: the contact's points
/// and normals (parry's contact query, reliable where the direction between two nearly equal
/// closest points is not), or the last closest points `last` and separating direction
/// `normal` if it finds none.
fn touching_hit(
    cast: &ShapeCast,
    t: f32,
    normal: Vec3,
    last: (Vec3, Vec3),
    tol: f32,
) -> Option<CastHit> {
    let moved = cast.at(t);
    let contact = query::contact(cast.pose1, cast.shape1, &moved, cast.shape2, 4.0 * tol).ok()?;
    Some(match contact {
        Some(c) => CastHit {
            distance: t,
            point1: c.point1,
            point2: c.point2,
            normal1: c.normal1,
            normal2: c.normal2,
        },
        None => CastHit {
            distance: t,
            point1: last.0,
            point2: last.1,
            normal1: normal,
            normal2: -normal,
        },
    })
}
