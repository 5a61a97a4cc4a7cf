//! Rays on the convex shapes parry casts by GJK: convex hulls clipped by their faces' planes,
//! and the rest (capsules, cylinders, cones, rounded shapes) by Newton's method on the distance
//! from the ray's point to the shape.

use bevy::math::Vec3;
use parry3d::query::{Ray, RayIntersection};
use parry3d::shape::{ConvexPolyhedron, FeatureId, Shape, ShapeType};

use super::newton::{Approach, Probe, Reach, core_and_border, newton, tolerance};

/// The shapes parry casts rays on by GJK.
pub(super) fn cast_by_gjk(shape: ShapeType) -> bool {
    matches!(
        shape,
        ShapeType::Capsule
            | ShapeType::Cylinder
            | ShapeType::Cone
            | ShapeType::ConvexPolyhedron
            | ShapeType::RoundCuboid
            | ShapeType::RoundTriangle
            | ShapeType::RoundCylinder
            | ShapeType::RoundCone
            | ShapeType::RoundConvexPolyhedron
    )
}

/// A ray (local frame, unit direction) on a convex polyhedron, clipped by its faces' planes:
/// it is inside the polyhedron between the last plane it enters and the first it leaves.
pub(super) fn hull_ray(
    hull: &ConvexPolyhedron,
    ray: &Ray,
    max: f32,
    solid: bool,
) -> Option<RayIntersection> {
    let (points, corners) = (hull.points(), hull.vertices_adj_to_face());
    let (mut enter, mut leave) = (0.0f32, f32::INFINITY);
    let (mut enter_normal, mut leave_normal) = (Vec3::ZERO, Vec3::ZERO);
    for face in hull.faces() {
        let n = face.normal;
        let on_plane = points[corners[face.first_vertex_or_edge as usize] as usize];
        // Signed distance of the origin above the plane, and how fast the ray climbs.
        let (height, climb) = (n.dot(ray.origin - on_plane), n.dot(ray.dir));
        if climb == 0.0 {
            if height > 0.0 {
                return None;
            }
        } else {
            let t = -height / climb;
            if climb < 0.0 {
                if t > enter || (height > 0.0 && enter_normal == Vec3::ZERO) {
                    enter = enter.max(t);
                    enter_normal = n;
                }
            } else if t < leave {
                leave = t;
                leave_normal = n;
            }
        }
    }
    if enter > leave || leave < 0.0 {
        return None;
    }
    let inside = enter_normal == Vec3::ZERO;
    let (t, normal) = match (inside, solid) {
        (true, true) => (0.0, Vec3::ZERO),
        (true, false) => (leave, -leave_normal),
        (false, _) => (enter, enter_normal),
    };
    (t <= max).then(|| RayIntersection::new(t, normal, FeatureId::Unknown))
}

/// The distance from `p` (local frame) to a convex shape given as its core and border,
/// negative inside, and the direction from the closest point of the core to `p` (zero when
/// `p` is in the core).
fn distance_to(core: &dyn Shape, border: f32, p: Vec3) -> (f32, Vec3) {
    let projection = core.project_local_point(p, true);
    if projection.is_inside {
        return (-border.max(f32::MIN_POSITIVE), Vec3::ZERO);
    }
    let delta = p - projection.point;
    let length = delta.length();
    (length - border, delta / length)
}

/// A ray (local frame, unit direction) on a convex shape.
pub(super) fn convex_ray(
    shape: &dyn Shape,
    ray: &Ray,
    max: f32,
    solid: bool,
) -> Option<RayIntersection> {
    let (core, border) = core_and_border(shape);
    if distance_to(core, border, ray.origin).0 > 0.0 {
        let (t, normal) = ray_entry(shape, core, border, ray, max)?;
        return Some(RayIntersection::new(t, normal, FeatureId::Unknown));
    }
    if solid {
        return Some(RayIntersection::new(0.0, Vec3::ZERO, FeatureId::Unknown));
    }
    // Hollow, from inside: where the ray leaves is where the reversed ray enters, coming from
    // a point past the shape's bounding sphere.
    let sphere = shape.compute_local_bounding_sphere();
    let past = (sphere.center - ray.origin).dot(ray.dir) + sphere.radius * 1.01 + 1e-3;
    let back = Ray::new(ray.point_at(past), -ray.dir);
    let (s, normal) = ray_entry(shape, core, border, &back, past)?;
    let t = past - s;
    (t <= max).then(|| RayIntersection::new(t.max(0.0), -normal, FeatureId::Unknown))
}

/// The point of a ray (local frame, unit direction) against a convex shape given as its core
/// and border: the gap is the point's distance to the shape.
struct PointOnRay<'a> {
    core: &'a dyn Shape,
    border: f32,
    ray: &'a Ray,
}

impl Approach for PointOnRay<'_> {
    type Near = ();

    fn probe(&self, t: f32) -> Option<Probe<()>> {
        let (distance, normal) = distance_to(self.core, self.border, self.ray.point_at(t));
        Some(if distance < 0.0 {
            Probe::Inside
        } else {
            Probe::Apart {
                gap: distance,
                normal,
                near: (),
            }
        })
    }

    fn reached(&self, t: f32) -> Option<bool> {
        Some(distance_to(self.core, self.border, self.ray.point_at(t)).0 < 0.0)
    }
}

/// Where a ray (local frame, unit direction) starting outside a convex shape (`shape`, as
/// `core` and `border`) enters it within `max`, and the outward normal there.
fn ray_entry(
    shape: &dyn Shape,
    core: &dyn Shape,
    border: f32,
    ray: &Ray,
    max: f32,
) -> Option<(f32, Vec3)> {
    let sphere = shape.compute_local_bounding_sphere();
    let tol = tolerance(ray.origin.abs().max_element() + sphere.center.length() + sphere.radius);
    let point = PointOnRay { core, border, ray };
    Some(match newton(&point, ray.dir, max, tol, false)? {
        Reach::Start => (0.0, -ray.dir),
        Reach::Crossed { t, normal, .. } => (t, normal),
        // On the surface: its normal there (the last one if it has none).
        Reach::Touching {
            t,
            gap,
            normal,
            before,
            ..
        } if gap <= 0.0 => (t, if normal == Vec3::ZERO { before } else { normal }),
        // The ray passes, or touches within the tolerance, so close that the direction is
        // rounding: the normal before.
        Reach::Touching {
            t,
            before,
            receding: true,
            ..
        } => (t, before),
        // No more progress in f32 within the tolerance.
        Reach::Touching { t, normal, .. } => (t, normal),
    })
}
