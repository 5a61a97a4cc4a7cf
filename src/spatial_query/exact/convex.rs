//! One convex shape cast against another by Newton's method on their distance, with parry's
//! meaning of the cast options.

use bevy::math::Vec3;
use parry3d::math::Pose;
use parry3d::query::{self, ClosestPoints, ShapeCastOptions};
use parry3d::shape::Shape;

use super::CastHit;
use super::newton::{Approach, Probe, Reach, core_and_border, newton, tolerance};

/// One convex shape cast against another by Newton's method on their distance (see the module
/// documentation), with parry's meaning of the options: a cast that starts within the target
/// distance (or penetrating) hits at 0, with the contact's points and normals, unless the
/// origin penetration is to be ignored and the shape moves out along the contact normal.
pub(super) fn convex_cast(
    pose1: &Pose,
    shape1: &dyn Shape,
    pose2: &Pose,
    dir: Vec3,
    shape2: &dyn Shape,
    options: &ShapeCastOptions,
) -> Option<CastHit> {
    // In the collider's frame, where the closest points near a contact are small numbers
    // whose difference keeps its precision; each shape as its core, its border added to the
    // target distance (a rounded shape is its core grown by its border).
    let local2 = pose1.inv_mul(pose2);
    let local_dir = pose1.rotation.inverse() * dir;
    let (core1, border1) = core_and_border(shape1);
    let (core2, border2) = core_and_border(shape2);
    let grown = ShapeCastOptions {
        target_distance: options.target_distance + border1 + border2,
        ..*options
    };
    let hit = local_convex_cast(core1, &local2, local_dir, core2, &grown)?;
    // Back from the cores to the surfaces, and to the world.
    let (n1, n2) = (hit.normal1, hit.normal2);
    Some(CastHit {
        distance: hit.distance,
        point1: pose1.transform_point(hit.point1 + n1 * border1),
        point2: pose1.transform_point(hit.point2 + n2 * border2),
        normal1: pose1.rotation * n1,
        normal2: pose1.rotation * n2,
    })
}

/// A shape (`shape2`, from `pose2` along `dir`) cast at another (`shape1`) at the origin: the
/// gap is their distance less the target distance, the normal points from `shape1` to
/// `shape2`, and the closest points are kept.
struct ShapesApproaching<'a> {
    shape1: &'a dyn Shape,
    pose2: &'a Pose,
    dir: Vec3,
    shape2: &'a dyn Shape,
    target: f32,
}

impl ShapesApproaching<'_> {
    /// The pose of `shape2` at time `t`.
    fn at(&self, t: f32) -> Pose {
        Pose::from_parts(self.pose2.translation + self.dir * t, self.pose2.rotation)
    }

    fn closest(&self, t: f32) -> Option<ClosestPoints> {
        query::closest_points(
            &Pose::IDENTITY,
            self.shape1,
            &self.at(t),
            self.shape2,
            f32::MAX,
        )
        .ok()
    }
}

impl Approach for ShapesApproaching<'_> {
    type Near = (Vec3, Vec3);

    fn probe(&self, t: f32) -> Option<Probe<(Vec3, Vec3)>> {
        match self.closest(t)? {
            ClosestPoints::WithinMargin(p1, p2) => {
                let delta = p2 - p1;
                let distance = delta.length();
                Some(Probe::Apart {
                    gap: distance - self.target,
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
            ClosestPoints::WithinMargin(p1, p2) => (p2 - p1).length() > self.target,
            _ => false,
        };
        Some(!apart)
    }
}

/// [`convex_cast`] with the collider at the origin: everything in its frame.
fn local_convex_cast(
    shape1: &dyn Shape,
    pose2: &Pose,
    dir: Vec3,
    shape2: &dyn Shape,
    options: &ShapeCastOptions,
) -> Option<CastHit> {
    let (s1, s2) = (
        shape1.compute_local_bounding_sphere(),
        shape2.compute_local_bounding_sphere(),
    );
    let scale = pose2.translation.abs().max_element()
        + s1.center.length()
        + s1.radius
        + s2.center.length()
        + s2.radius;
    let tol = tolerance(scale);
    let target = options.target_distance;
    let approach = ShapesApproaching {
        shape1,
        pose2,
        dir,
        shape2,
        target,
    };
    let touching = |t: f32, normal: Vec3, near: (Vec3, Vec3)| {
        touching_hit(shape1, &approach.at(t), shape2, t, normal, near, tol)
    };
    match newton(&approach, dir, options.max_time_of_impact, tol, true)? {
        Reach::Start => start_hit(shape1, pose2, dir, shape2, options),
        Reach::Crossed { t, normal, near } => touching(t, normal, near),
        // Within the target distance the closest points are well apart, and their direction
        // is the normal.
        Reach::Touching {
            t,
            normal,
            near: (p1, p2),
            ..
        } if target > 0.0 => Some(CastHit {
            distance: t,
            point1: p1,
            point2: p2,
            normal1: normal,
            normal2: -normal,
        }),
        Reach::Touching {
            t, near, before, ..
        } => touching(t, before, near),
    }
}

/// The hit of a cast that starts penetrating or within the target distance (parry's rule),
/// the collider at the origin.
fn start_hit(
    shape1: &dyn Shape,
    pose2: &Pose,
    dir: Vec3,
    shape2: &dyn Shape,
    options: &ShapeCastOptions,
) -> Option<CastHit> {
    let contact = query::contact(&Pose::IDENTITY, shape1, pose2, shape2, f32::MAX).ok()??;
    if !options.stop_at_penetration && contact.normal1.dot(dir) >= 0.0 {
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

/// The hit of a cast whose shapes touch at `t`, the collider at the origin: the contact's
/// points and normals (parry's contact query, reliable where the direction between two nearly
/// equal closest points is not), or the last closest points `last` and separating direction
/// `normal` if it finds none.
fn touching_hit(
    shape1: &dyn Shape,
    moved: &Pose,
    shape2: &dyn Shape,
    t: f32,
    normal: Vec3,
    last: (Vec3, Vec3),
    tol: f32,
) -> Option<CastHit> {
    let contact = query::contact(&Pose::IDENTITY, shape1, moved, shape2, 4.0 * tol).ok()?;
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
