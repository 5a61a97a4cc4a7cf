//! Newton's method on the gap between a moving point or shape and a convex shape, once for
//! every cast that uses it: a cast says what the gap is at a time along its motion
//! ([`Approach`]), [`newton`] walks the motion to the first contact.

use bevy::math::Vec3;
use parry3d::shape::Shape;

/// Newton steps (or bisection steps) at most before a cast gives up (a miss). A cast that hits
/// a surface at a steep angle converges in 3 to 6 steps; a grazing one halves its distance each
/// step.
const MAX_STEPS: usize = 64;

/// Each Newton step is shortened by this factor, so that a distance parry computes a little
/// long (its GJK distance stops within 1.1e-3 of the distance: `sqrt(10 eps)`) does not carry
/// a step past the contact; a step that still lands inside is bisected back.
const STEP: f32 = 1.0 - 2e-3;

/// The tolerance on a cast's distance, m: `1e-6` of the size of the numbers involved (the
/// coordinates, the shapes' bounding radii), 17 f32 ulps of them.
pub(super) fn tolerance(scale: f32) -> f32 {
    1e-6 * (1.0 + scale)
}

/// A convex shape as its core and a border around it: a capsule's segment and radius, a
/// rounded shape's inner shape and rounding (parry projects points on rounded shapes, and
/// measures distances to them, by GJK; on their inner shapes in closed form, or by GJK on
/// polytopes, where it ends exactly), any other shape and 0.
pub(super) fn core_and_border(shape: &dyn Shape) -> (&dyn Shape, f32) {
    if let Some(s) = shape.as_capsule() {
        (&s.segment, s.radius)
    } else if let Some(s) = shape.as_round_cuboid() {
        (&s.inner_shape, s.border_radius)
    } else if let Some(s) = shape.as_round_cylinder() {
        (&s.inner_shape, s.border_radius)
    } else if let Some(s) = shape.as_round_cone() {
        (&s.inner_shape, s.border_radius)
    } else if let Some(s) = shape.as_round_convex_polyhedron() {
        (&s.inner_shape, s.border_radius)
    } else if let Some(s) = shape.as_round_triangle() {
        (&s.inner_shape, s.border_radius)
    } else {
        (shape, 0.0)
    }
}

/// A straight motion along a unit direction towards a convex shape, as Newton's method reads
/// it: a ray's point, or a cast shape, against the collider.
pub(super) trait Approach {
    /// What a probe keeps beside the gap and the normal (a shape cast's closest points).
    type Near: Copy;

    /// What separates the two at time `t` (a distance along the motion); `None` when the
    /// query fails (the cast misses).
    fn probe(&self, t: f32) -> Option<Probe<Self::Near>>;

    /// Whether the motion at time `t` has reached the contact, for the bisection back from a
    /// step that landed past it; `None` when the query fails.
    fn reached(&self, t: f32) -> Option<bool>;
}

/// What separates the moving point or shape from the collider at one time.
pub(super) enum Probe<N> {
    /// Apart (or touching) by `gap`, m, which grows along the collider's outward `normal`.
    Apart { gap: f32, normal: Vec3, near: N },
    /// Past the contact.
    Inside,
}

/// Where Newton's method found the first contact.
pub(super) enum Reach<N> {
    /// At the start: the motion starts past the contact (or, when the cast asks, within the
    /// tolerance of it).
    Start,
    /// A step landed past the contact: `t`, the first time found past it by bisection, with
    /// the `normal` and `near` of the last probe before it.
    Crossed { t: f32, normal: Vec3, near: N },
    /// The gap closed, or stopped closing within the tolerance, at `t`: the probe there
    /// (`gap`, `normal`, `near`), the normal of the probe `before` it (minus the direction of
    /// motion at the start), and whether the gap had stopped closing (`receding`).
    Touching {
        t: f32,
        gap: f32,
        normal: Vec3,
        near: N,
        before: Vec3,
        receding: bool,
    },
}

/// Walks the motion along `dir` (unit) by Newton steps on the gap, `t += gap / rate` (each
/// shortened by [`STEP`]), to the first contact within `max`: along a straight motion the
/// distance to a convex shape is a convex function of the time, so each step lands at or
/// before the contact. A miss (`None`) when the gap stops shrinking farther than `tol` from
/// the contact, when the motion passes `max`, or when a query fails. `start_within`: a gap
/// within `tol` at the start is a contact at the start.
pub(super) fn newton<A: Approach>(
    approach: &A,
    dir: Vec3,
    max: f32,
    tol: f32,
    start_within: bool,
) -> Option<Reach<A::Near>> {
    let (mut t, mut outside) = (0.0f32, 0.0f32);
    let mut before = -dir;
    let mut last = None;
    for _ in 0..MAX_STEPS {
        let (gap, normal, near) = match approach.probe(t)? {
            Probe::Apart { gap, normal, near } => (gap, normal, near),
            Probe::Inside if t == 0.0 => return Some(Reach::Start),
            Probe::Inside => {
                // A step landed past the surface (rounding, or a distance called a hair short
                // by parry): the contact is between `outside` and `t`.
                let t = bisect(approach, outside, t, tol)?;
                // (`last` is set: a step was taken from a probe apart.)
                let near = last?;
                return Some(Reach::Crossed {
                    t,
                    normal: before,
                    near,
                });
            }
        };
        if t == 0.0 && start_within && gap <= tol {
            return Some(Reach::Start);
        }
        // How fast the gap shrinks along the motion, and the step to where it would close.
        let rate = -dir.dot(normal);
        let step = STEP * gap / rate;
        // Touching, or no longer approaching (within the tolerance: so close, the direction of
        // the normal is rounding), or no more progress in f32: a contact if within the
        // tolerance.
        let receding = rate <= 0.0;
        let stalled = receding || t + step == t || step <= 1e-3 * tol;
        if gap <= 0.0 || stalled {
            if gap > tol {
                // The gap no longer shrinks: the motion passes the shape.
                return None;
            }
            return Some(Reach::Touching {
                t,
                gap,
                normal,
                near,
                before,
                receding,
            });
        }
        before = normal;
        last = Some(near);
        outside = t;
        t += step;
        if t > max {
            return None;
        }
    }
    None
}

/// The first time past the contact between `outside` (before it) and `inside` (past it), to
/// `1e-3 tol`; `None` when a query fails.
fn bisect<A: Approach>(approach: &A, outside: f32, inside: f32, tol: f32) -> Option<f32> {
    let (mut lo, mut hi) = (outside, inside);
    for _ in 0..MAX_STEPS {
        if hi - lo <= 1e-3 * tol {
            break;
        }
        let mid = 0.5 * (lo + hi);
        if approach.reached(mid)? {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Some(hi)
}
