//! Narrow phase: parry3d contact manifolds for each broad-phase pair, kept from step to step so
//! that each tracked contact point carries its accumulated impulse (warm starting), and the
//! settings they are generated with ([`NarrowPhaseConfig`]).

use bevy::prelude::*;
use parry3d::math::Pose;
use parry3d::query::{
    ContactManifold, ContactManifoldsWorkspace, DefaultQueryDispatcher, PersistentQueryDispatcher,
};
use parry3d::shape::{FeatureId, Shape};

mod config;
mod halfspace;
mod pairs;
mod toi;
mod units;

pub(crate) use config::BOX_MARGIN_SHARE;
pub use config::{NarrowPhaseConfig, TOUCH_DISTANCE};
pub use pairs::ContactPairs;
pub use toi::{Meeting, StepMotion, time_of_impact};
pub use units::{UnitShapes, binary_unit};

/// The impulses parry carries over to the matching contact point of the next step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactImpulse {
    /// Accumulated normal impulse, N s.
    pub normal: f32,
    /// Accumulated friction impulse along the two tangents, N s.
    pub tangent: [f32; 2],
    /// The point's share of its manifold's twist friction about the normal, N m s.
    pub twist: f32,
}

/// A parry manifold whose points carry [`ContactImpulse`].
pub type Manifold = ContactManifold<(), ContactImpulse>;

/// The persistent contact state of one pair of colliders, `a < b`.
pub struct ContactPair {
    /// The first entity (the smaller); contact normals point from `a` to `b`.
    pub a: Entity,
    /// The second entity.
    pub b: Entity,
    /// Contact manifolds, in `a`'s local frame for points `local_p1` and normal `local_n1`.
    pub manifolds: Vec<Manifold>,
    workspace: Option<ContactManifoldsWorkspace>,
    /// The pair touched (a point within [`NarrowPhaseConfig::touch_distance`], or any impulse)
    /// in the last step.
    pub touching: bool,
    /// The pair was detect-only in the last step it was a candidate (a sensor in it, or no
    /// dynamic body: contacts never solved; see
    /// [`CandidatePairs::detect_only`](crate::pipeline::CandidatePairs::detect_only)).
    pub detect_only: bool,
    /// A body of the pair has child colliders (see
    /// [`CompoundParts`](crate::collision::parts::CompoundParts)) in the last step it was a
    /// candidate: its contacts are sorted out collider by collider, and `part_touching` holds
    /// its touching colliders.
    pub compound: bool,
    /// For a `compound` pair, the pairs of colliders `(on a, on b)` that touched in the last
    /// step, sorted: what collision events between colliders are reported from.
    pub part_touching: Vec<(Entity, Entity)>,
    /// The length, m, of one unit of `manifolds`' points, distances and sub-shape poses: the
    /// length unit the pair's contacts were generated in (see [`ContactPair::update`]).
    unit: f32,
}

impl ContactPair {
    fn new(a: Entity, b: Entity) -> Self {
        ContactPair {
            a,
            b,
            manifolds: Vec::new(),
            workspace: None,
            touching: false,
            detect_only: false,
            compound: false,
            part_touching: Vec::new(),
            unit: 1.0,
        }
    }

    /// Recomputes the manifolds for the shapes at `pose_a` and `pose_b`, keeping contact points
    /// that persist (and their impulses). `prediction` (m) is how far apart shapes may be and
    /// still produce (speculative) contacts. Returns false when parry has no algorithm for the
    /// pair of shapes.
    ///
    /// `shape_a` and `shape_b` are the colliders' shapes scaled to the length `unit` (m; see
    /// [`UnitShapes`] and [`binary_unit`]): parry works on them with the poses' translations and
    /// the prediction divided by `unit`, and the manifolds keep that unit
    /// ([`world_points`](Self::world_points) and [`surface_points`](Self::surface_points) give
    /// metres). A change of unit starts the pair's manifolds afresh.
    ///
    /// Why: parry's contact generation has absolute tolerances, tuned for shapes about a metre
    /// across. Its clipping of two polygonal faces (`PolygonalFeature::contacts`, via
    /// `closest_points_line2d`) takes two edges for parallel when `|d1|^2 |d2|^2 - (d1 . d2)^2`
    /// is at most `f32::EPSILON` (1.2e-7 m^4), so it drops every crossing of two edges at right
    /// angles shorter than 1.9 cm (two 1 mm edges: 1e-12 m^4). Where the corners of the contact
    /// polygon are edge crossings (two faces of the same size, nearly one on the other, offset
    /// or turned by a hair), those corners go missing. Two 1 mm dice, one on the other, offset
    /// by 1e-3 of their size and turned by 1e-3 rad in random directions: 2 points (on a
    /// diagonal) in 1,466 of 2,000 trials, none in 533, 3 in one; the same dice at 1 m have 4
    /// to 8 points in every trial. Two points on a diagonal are a hinge: a 1 mm die
    /// dropped on another tipped off it about the hinge, its manifold kept by parry's
    /// coherence (which only checks the points it has). In the unit, a 1 mm die is a 1 unit
    /// die to parry.
    pub fn update(
        &mut self,
        pose_a: &Pose,
        shape_a: &dyn Shape,
        pose_b: &Pose,
        shape_b: &dyn Shape,
        prediction: f32,
        unit: f32,
    ) -> bool {
        if unit != self.unit {
            self.manifolds.clear();
            self.workspace = None;
            self.unit = unit;
        }
        let mut pos12 = pose_a.inv_mul(pose_b);
        pos12.translation /= unit;
        if halfspace::halfspace_manifold(
            &pos12,
            shape_a,
            shape_b,
            prediction / unit,
            &mut self.manifolds,
        ) {
            return true;
        }
        DefaultQueryDispatcher
            .contact_manifolds(
                &pos12,
                shape_a,
                shape_b,
                prediction / unit,
                &mut self.manifolds,
                &mut self.workspace,
            )
            .is_ok()
    }

    /// Forgets the pair's manifolds and parry's workspace, so that the next
    /// [`update`](Self::update) computes them afresh. parry's manifolds are coherent: for a
    /// small relative motion they move the points they have, keeping their features, which
    /// holds while shapes barely touch but not through a deep overlap (a cube passing through
    /// a sensor kept the features it entered with, and read 3 m deep when 12 mm clear on the
    /// far side). Detect-only pairs, which overlap deeply, are recomputed this way each step.
    pub fn reset(&mut self) {
        self.manifolds.clear();
        self.workspace = None;
    }

    /// World contact points of the pair: `(manifold, point index, world point, world normal
    /// from a to b, signed distance)`, the point being the midpoint of the two surface points.
    pub fn world_points(
        &self,
        pose_a: &Pose,
        pose_b: &Pose,
    ) -> impl Iterator<Item = (usize, usize, Vec3, Vec3, f32)> + '_ {
        let (pose_a, pose_b, unit) = (*pose_a, *pose_b, self.unit);
        self.manifolds
            .iter()
            .enumerate()
            .flat_map(move |(m, manifold)| {
                let (frame_a, frame_b) = self.frames(manifold, &pose_a, &pose_b);
                let normal = frame_a.rotation * manifold.local_n1;
                manifold.points.iter().enumerate().map(move |(k, p)| {
                    let p1 = frame_a.transform_point(p.local_p1 * unit);
                    let p2 = frame_b.transform_point(p.local_p2 * unit);
                    (m, k, 0.5 * (p1 + p2), normal, p.dist * unit)
                })
            })
    }

    /// The two surface points of point `k` of manifold `m` in the world, `(on a, on b)`, and
    /// whether each lies on a face of its shape (rather than an edge or a vertex): the normal of
    /// a point on a face of one shape is that face's normal, so it turns with that shape.
    pub fn surface_points(
        &self,
        m: usize,
        k: usize,
        pose_a: &Pose,
        pose_b: &Pose,
    ) -> ((Vec3, bool), (Vec3, bool)) {
        let manifold = &self.manifolds[m];
        let (frame_a, frame_b) = self.frames(manifold, pose_a, pose_b);
        let p = &manifold.points[k];
        (
            (
                frame_a.transform_point(p.local_p1 * self.unit),
                p.fid1.is_face(),
            ),
            (
                frame_b.transform_point(p.local_p2 * self.unit),
                p.fid2.is_face(),
            ),
        )
    }

    /// The frames, in metres, of `manifold`'s sub-shapes of a and b for the bodies at `pose_a`
    /// and `pose_b`.
    fn frames(&self, manifold: &Manifold, pose_a: &Pose, pose_b: &Pose) -> (Pose, Pose) {
        let frame = |pose: &Pose, sub: Option<Pose>| match sub {
            Some(sub) => pose * Pose::from_parts(sub.translation * self.unit, sub.rotation),
            None => *pose,
        };
        (
            frame(pose_a, manifold.subshape_pos1),
            frame(pose_b, manifold.subshape_pos2),
        )
    }
}

/// The outward normal of the face of `shape` (turned by `rotation`) that faces `outward`, if
/// `shape` is a polyhedron (a cuboid or a convex hull) with a face within `max_angle` (rad) of
/// `outward`; `None` for curved shapes (spheres, capsules) and where an edge or a vertex faces
/// `outward`.
///
/// # Examples
///
/// ```
/// use bevy::math::{Quat, Vec3};
/// use impact3d::collision::Collider;
/// use impact3d::collision::narrow_phase::face_normal_toward;
///
/// let cube = Collider::cuboid(0.5, 0.5, 0.5);
/// let tilt = Quat::from_rotation_z(1e-4);
/// // The top face, tilted 1e-4 rad, is within 1e-3 rad of straight up: its own normal.
/// let n = face_normal_toward(cube.shape().as_ref(), tilt, Vec3::Y, 1e-3).unwrap();
/// assert!((n - tilt * Vec3::Y).length() < 1e-7);
/// // A sphere has no faces.
/// let ball = Collider::sphere(0.5);
/// assert_eq!(face_normal_toward(ball.shape().as_ref(), tilt, Vec3::Y, 1e-3), None);
/// ```
pub fn face_normal_toward(
    shape: &dyn Shape,
    rotation: Quat,
    outward: Vec3,
    max_angle: f32,
) -> Option<Vec3> {
    let local = rotation.inverse() * outward;
    let face = if shape.as_cuboid().is_some() {
        let a = local.abs();
        let k = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut n = Vec3::ZERO;
        n[k] = local[k].signum();
        n
    } else if let Some(hull) = shape.as_convex_polyhedron() {
        match hull.support_feature_id_toward(local) {
            id @ FeatureId::Face(_) => hull.feature_normal(id)?,
            _ => return None,
        }
    } else {
        return None;
    };
    (face.dot(local) >= max_angle.cos()).then(|| rotation * face)
}

#[cfg(test)]
mod tests;
