//! Narrow phase: parry3d contact manifolds for each broad-phase pair, kept from step to step so
//! that each tracked contact point carries its accumulated impulse (warm starting).

use bevy::prelude::*;
use parry3d::math::Pose;
use parry3d::query::{
    ContactManifold, ContactManifoldsWorkspace, DefaultQueryDispatcher, NonlinearRigidMotion,
    PersistentQueryDispatcher, ShapeCastOptions, cast_shapes, cast_shapes_nonlinear, distance,
};
use parry3d::shape::{FeatureId, Shape, SharedShape};

use crate::dynamics::solver::ContactConstraint;

/// The impulses parry carries over to the matching contact point of the next step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactImpulse {
    /// Accumulated normal impulse, N s.
    pub normal: f32,
    /// Accumulated friction impulse along the two tangents, N s.
    pub tangent: [f32; 2],
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
    /// The pair touched (a point within [`TOUCH_DISTANCE`], or any impulse) in the last step.
    pub touching: bool,
    /// The pair was detect-only in the last step it was a candidate (a sensor in it, or no
    /// dynamic body: contacts never solved; see
    /// [`CandidatePairs::detect_only`](crate::pipeline::CandidatePairs::detect_only)).
    pub detect_only: bool,
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

/// The power of two nearest the world's length unit `unit` (m), in which contacts are generated
/// (see [`ContactPair::update`]): scaling by a power of two is exact in `f32`, so contact
/// generation at this unit gives bit for bit what it gives in metres, except where parry's
/// absolute tolerances decide. 1 for the default unit.
///
/// # Examples
///
/// ```
/// use impact3d::collision::narrow_phase::binary_unit;
///
/// assert_eq!(binary_unit(1.0), 1.0);
/// assert_eq!(binary_unit(1e-3), 1.0 / 1024.0);
/// assert_eq!(binary_unit(1e-2), 1.0 / 128.0);
/// assert_eq!(binary_unit(1e3), 1024.0);
/// ```
pub fn binary_unit(unit: f32) -> f32 {
    2f32.powi(unit.log2().round() as i32)
}

/// The colliders' shapes scaled to the world's length unit, for contact generation (see
/// [`ContactPair::update`]), each made once per shape and unit. A shape is known by its
/// allocation: the entry keeps the original alive, so its address is not reused while the
/// entry stands, and [`prune`](Self::prune) drops the entries of shapes nothing else holds.
#[derive(Default)]
pub struct UnitShapes {
    unit: f32,
    shapes: std::collections::HashMap<usize, (SharedShape, Option<SharedShape>)>,
}

impl UnitShapes {
    /// `shape` scaled by `1 / unit`, or `None` when parry cannot scale it.
    pub fn get(&mut self, shape: &SharedShape, unit: f32) -> Option<SharedShape> {
        if unit != self.unit {
            self.shapes.clear();
            self.unit = unit;
        }
        let key = std::sync::Arc::as_ptr(&shape.0) as *const u8 as usize;
        let (_, scaled) = self.shapes.entry(key).or_insert_with(|| {
            let scaled = shape
                .scale_dyn(Vec3::splat(1.0 / unit), 0)
                .map(|s| SharedShape(s.into()));
            (shape.clone(), scaled)
        });
        scaled.clone()
    }

    /// Drops the entries of shapes that only this cache still holds.
    pub fn prune(&mut self) {
        self.shapes
            .retain(|_, (original, _)| std::sync::Arc::strong_count(&original.0) > 1);
    }
}

/// Points closer than this count as touching for collision start and end, m (times the
/// world's [`PhysicsLengthUnit`](crate::dynamics::validation::PhysicsLengthUnit)).
pub const TOUCH_DISTANCE: f32 = 0.005;

/// How one body moves over a step, for time-of-impact queries.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepMotion {
    /// The body origin's pose at the start of the step (the collider's pose).
    pub pose: Pose,
    /// The centre of mass in the body frame, about which it turns, m.
    pub local_center: Vec3,
    /// Velocity of the centre of mass, m/s.
    pub linear: Vec3,
    /// Angular velocity, rad/s.
    pub angular: Vec3,
    /// How far rotation alone can carry a point of the shape in the step, `|w| R dt`, m (zero
    /// for a sphere, whose surface rotation does not move).
    pub spin_reach: f32,
}

impl StepMotion {
    /// parry's description of this motion.
    pub fn nonlinear(&self) -> NonlinearRigidMotion {
        NonlinearRigidMotion::new(self.pose, self.local_center, self.linear, self.angular)
    }

    /// The body origin's pose at time `t` in the step, turning about the centre of mass.
    pub fn pose_at(&self, t: f32) -> Pose {
        self.nonlinear().position_at_time(t)
    }
}

/// When two moving shapes first meet within `[0, dt]`, if they do.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Meeting {
    /// They stay apart for the whole step.
    Miss,
    /// They meet (or already touch) at this time, s.
    At(f32),
    /// parry has no time-of-impact query for this pair of shapes: assume they may meet.
    Unknown,
}

/// Whether shapes `a` and `b` come within `tolerance` (m) of each other within `dt` (s) along
/// their motions. The linear cast moves each shape with its centre-of-mass velocity and counts
/// as meeting anything within `tolerance + a.spin_reach + b.spin_reach` (what rotation can add);
/// when rotation can carry a point farther than `spin_tolerance`, the cast is refined by
/// parry's nonlinear cast, which follows the rotation (and gives the exact time of impact).
///
/// # Examples
///
/// ```
/// use bevy::math::{Quat, Vec3};
/// use parry3d::math::Pose;
/// use parry3d::shape::Ball;
/// use impact3d::collision::narrow_phase::{Meeting, StepMotion, time_of_impact};
///
/// let at = |x: f32, y: f32, vx: f32| StepMotion {
///     pose: Pose::from_parts(Vec3::new(x, y, 0.0), Quat::IDENTITY),
///     local_center: Vec3::ZERO,
///     linear: Vec3::new(vx, 0.0, 0.0),
///     angular: Vec3::ZERO,
///     spin_reach: 0.0,
/// };
/// let ball = Ball::new(0.5);
/// // 10 m/s for 1 s closes a 2 m gap at t = 0.2 s; passing 1.5 m above, they miss.
/// assert!(matches!(
///     time_of_impact(&ball, &at(-3.0, 0.0, 10.0), &ball, &at(0.0, 0.0, 0.0), 1.0, 0.0, 0.1),
///     Meeting::At(t) if (t - 0.2).abs() < 1e-4
/// ));
/// assert_eq!(
///     time_of_impact(&ball, &at(-3.0, 1.5, 10.0), &ball, &at(0.0, 0.0, 0.0), 1.0, 0.0, 0.1),
///     Meeting::Miss
/// );
/// ```
pub fn time_of_impact(
    shape_a: &dyn Shape,
    a: &StepMotion,
    shape_b: &dyn Shape,
    b: &StepMotion,
    dt: f32,
    tolerance: f32,
    spin_tolerance: f32,
) -> Meeting {
    let options = ShapeCastOptions {
        max_time_of_impact: dt,
        target_distance: tolerance + a.spin_reach + b.spin_reach,
        stop_at_penetration: true,
        compute_impact_geometry_on_penetration: false,
    };
    let linear = cast_shapes(
        &a.pose, a.linear, shape_a, &b.pose, b.linear, shape_b, options,
    );
    let t = match linear {
        // parry's linear cast reports nothing for shapes that do not move relative to each
        // other, even within the target distance: check the distance at the start.
        Ok(None) => {
            return match distance(&a.pose, shape_a, &b.pose, shape_b) {
                Ok(d) if d <= options.target_distance => Meeting::At(0.0),
                Ok(_) => Meeting::Miss,
                Err(_) => Meeting::Unknown,
            };
        }
        Ok(Some(hit)) => hit.time_of_impact,
        Err(_) => return Meeting::Unknown,
    };
    if a.spin_reach + b.spin_reach <= spin_tolerance {
        return Meeting::At(t);
    }
    match cast_shapes_nonlinear(
        &a.nonlinear(),
        shape_a,
        &b.nonlinear(),
        shape_b,
        0.0,
        dt,
        true,
    ) {
        Ok(None) => Meeting::Miss,
        Ok(Some(hit)) => Meeting::At(hit.time_of_impact),
        Err(_) => Meeting::At(t),
    }
}

/// Every pair the broad phase reported in the last step, sorted by `(a, b)`: the pairs of the
/// step's candidates, and the resting pairs set aside while a sleeping body of theirs sits out
/// the steps (see [`SleepingSet`](crate::dynamics::sleep::SleepingSet)), which keep their
/// manifolds and touching state untouched.
#[derive(Resource, Default)]
pub struct ContactPairs {
    pairs: Vec<ContactPair>,
    resting: Vec<ContactPair>,
}

impl ContactPairs {
    /// Every pair, sorted by `(a, b)`.
    pub fn iter(&self) -> impl Iterator<Item = &ContactPair> {
        let mut live = self.pairs.iter().peekable();
        let mut resting = self.resting.iter().peekable();
        std::iter::from_fn(move || match (live.peek(), resting.peek()) {
            (Some(p), Some(q)) if (q.a, q.b) < (p.a, p.b) => resting.next(),
            (Some(_), _) => live.next(),
            (None, _) => resting.next(),
        })
    }

    /// The pair of `a` and `b` (in either order), if the broad phase reported it.
    pub fn get(&self, a: Entity, b: Entity) -> Option<&ContactPair> {
        let key = (a.min(b), a.max(b));
        let find = |pairs: &'_ [ContactPair]| pairs.binary_search_by(|p| (p.a, p.b).cmp(&key)).ok();
        find(&self.pairs)
            .map(|i| &self.pairs[i])
            .or_else(|| find(&self.resting).map(|i| &self.resting[i]))
    }

    /// The pairs of this step's candidates, in order (the resting pairs set aside are not
    /// among them).
    pub fn candidates(&self) -> &[ContactPair] {
        &self.pairs
    }

    /// Mutable access to the pairs of this step's candidates, in order.
    pub fn pairs_mut(&mut self) -> &mut [ContactPair] {
        &mut self.pairs
    }

    /// Whether any pair is set aside.
    pub fn has_resting(&self) -> bool {
        !self.resting.is_empty()
    }

    /// Moves the candidate pairs whose flag in `aside` is set (one flag per pair of
    /// [`candidates`](Self::candidates)) to the resting pairs.
    pub fn set_aside(&mut self, aside: &[bool]) {
        let (moved, kept): (Vec<_>, Vec<_>) = std::mem::take(&mut self.pairs)
            .into_iter()
            .zip(aside)
            .partition(|&(_, &a)| a);
        self.pairs = kept.into_iter().map(|(p, _)| p).collect();
        let moved = moved.into_iter().map(|(p, _)| p).collect();
        self.resting = merge(std::mem::take(&mut self.resting), moved);
    }

    /// Moves the resting pairs for which `wake` is true back among the candidate pairs.
    pub fn revive(&mut self, mut wake: impl FnMut(&ContactPair) -> bool) {
        let (woken, kept): (Vec<_>, Vec<_>) = std::mem::take(&mut self.resting)
            .into_iter()
            .partition(|p| wake(p));
        self.resting = kept;
        self.pairs = merge(std::mem::take(&mut self.pairs), woken);
    }

    /// Stores each solved row's impulses in its manifold point (`keys`: the row's candidate
    /// pair, manifold and point), so that the next step starts from them (warm starting). A
    /// non-finite impulse (its bodies' results are non-finite too, and they are quarantined) is
    /// not carried over: warm-started, it would make the next step non-finite again, and the
    /// quarantine would never end.
    pub fn store_impulses(&mut self, rows: &[ContactConstraint], keys: &[(u32, u32, u32)]) {
        for (c, &(p, m, k)) in rows.iter().zip(keys) {
            let finite = c.normal_impulse.is_finite()
                && c.tangent_impulse[0].is_finite()
                && c.tangent_impulse[1].is_finite();
            self.pairs[p as usize].manifolds[m as usize].points[k as usize].data = if finite {
                ContactImpulse {
                    normal: c.normal_impulse,
                    tangent: c.tangent_impulse,
                }
            } else {
                ContactImpulse::default()
            };
        }
    }

    /// Sets each candidate pair's touching state from the step's solved rows: a pair touches
    /// when a row is within `touch` (m) or pushed in the step, or (a pair without rows: a
    /// detect-only pair) when it is among `detected`; a `dormant` pair keeps its state. Pairs
    /// that start and stop touching are pushed to `started` and `ended`.
    #[allow(clippy::too_many_arguments)]
    pub fn update_touching(
        &mut self,
        rows: &[ContactConstraint],
        keys: &[(u32, u32, u32)],
        detected: &[u32],
        dormant: &[bool],
        touch: f32,
        started: &mut Vec<(Entity, Entity)>,
        ended: &mut Vec<(Entity, Entity)>,
    ) {
        let mut touching: Vec<bool> = self
            .pairs
            .iter()
            .zip(dormant)
            .map(|(pair, &dormant)| dormant && pair.touching)
            .collect();
        for (c, &(p, _, _)) in rows.iter().zip(keys) {
            if c.separation <= touch || c.total_impulse > 0.0 {
                touching[p as usize] = true;
            }
        }
        for &p in detected {
            touching[p as usize] = true;
        }
        for (pair, now) in self.pairs.iter_mut().zip(touching) {
            match (pair.touching, now) {
                (false, true) => started.push((pair.a, pair.b)),
                (true, false) => ended.push((pair.a, pair.b)),
                _ => {}
            }
            pair.touching = now;
        }
    }

    /// Replaces the candidate pairs with `candidates` (sorted by `(a, b)`, `a < b`), keeping the
    /// state of pairs that persist. Pairs that are gone are passed to `removed` (touching ones
    /// end a collision). The resting pairs are left as they are.
    pub fn retain_candidates(
        &mut self,
        candidates: &[(Entity, Entity)],
        mut removed: impl FnMut(&ContactPair),
    ) {
        let old = std::mem::take(&mut self.pairs);
        let mut old = old.into_iter().peekable();
        self.pairs.reserve(candidates.len());
        for &(a, b) in candidates {
            while let Some(p) = old.next_if(|p| (p.a, p.b) < (a, b)) {
                removed(&p);
            }
            match old.next_if(|p| (p.a, p.b) == (a, b)) {
                Some(p) => self.pairs.push(p),
                None => self.pairs.push(ContactPair::new(a, b)),
            }
        }
        for p in old {
            removed(&p);
        }
    }
}

/// Two lists of pairs sorted by `(a, b)`, merged.
fn merge(a: Vec<ContactPair>, b: Vec<ContactPair>) -> Vec<ContactPair> {
    if b.is_empty() {
        return a;
    }
    let mut out = Vec::with_capacity(a.len() + b.len());
    let (mut a, mut b) = (a.into_iter().peekable(), b.into_iter().peekable());
    loop {
        let take_b = match (a.peek(), b.peek()) {
            (Some(p), Some(q)) => (q.a, q.b) < (p.a, p.b),
            (Some(_), None) => false,
            (None, Some(_)) => true,
            (None, None) => return out,
        };
        out.extend(if take_b { b.next() } else { a.next() });
    }
}

#[cfg(test)]
mod tests;
