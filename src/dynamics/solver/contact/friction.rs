//! The friction side of a contact row: the tangent rows, the tangential velocity, the
//! accumulated friction solve and the one-shot stick impulse of impact events.

use bevy::prelude::*;

use super::super::body::{PairVelocities, SolverBody};
use super::ContactConstraint;
use crate::impulse::{apply_row_impulse, row_inverse_mass};

impl ContactConstraint {
    /// Derives the two tangent rows from the anchors and `tangents`: `I^-1 (r x t)` for each
    /// body and tangent, and the tangent plane's inverse effective mass `K_t`.
    pub fn prepare_tangent_rows(&mut self, a: &SolverBody, b: &SolverBody) {
        let mut cross = [[Vec3::ZERO; 2]; 2];
        #[allow(clippy::needless_range_loop)] // four arrays indexed alike
        for k in 0..2 {
            let t = self.tangents[k];
            cross[0][k] = self.anchor_a.cross(t);
            cross[1][k] = self.anchor_b.cross(t);
            self.tangent_ang[0][k] = a.inverse_inertia * cross[0][k];
            self.tangent_ang[1][k] = b.inverse_inertia * cross[1][k];
        }
        // The linear part only on the diagonal (`t_k . t_l = 0` off it).
        let entry = |k: usize, l: usize, linear: [f32; 2]| {
            row_inverse_mass(
                linear,
                [
                    cross[0][k].dot(self.tangent_ang[0][l]),
                    cross[1][k].dot(self.tangent_ang[1][l]),
                ],
            )
        };
        let masses = [a.inverse_mass, b.inverse_mass];
        self.tangent_k = [
            entry(0, 0, masses),
            0.5 * (entry(0, 1, [0.0; 2]) + entry(1, 0, [0.0; 2])),
            entry(1, 1, masses),
        ];
    }

    /// Relative velocity along tangent `k`.
    #[inline]
    pub fn tangent_velocity(&self, bodies: &[SolverBody], k: usize) -> f32 {
        self.tangent_velocity_in(&PairVelocities::load(bodies, self.body_a, self.body_b), k)
    }

    /// [`tangent_velocity`](Self::tangent_velocity) with the bodies' velocities in `v`.
    #[inline]
    pub fn tangent_velocity_in(&self, v: &PairVelocities, k: usize) -> f32 {
        let t = self.tangents[k];
        (v.b.linear + v.b.angular.cross(self.anchor_b)
            - v.a.linear
            - v.a.angular.cross(self.anchor_a))
        .dot(t)
    }

    /// Applies, in one go, the friction impulse that stops the row's tangential slip, scaled
    /// down into the Coulomb disk `|t| <= limit`, and returns it (along the two tangents):
    /// `t = -s K_t^-1 v_t`, with `v_t` the tangential relative velocity, `K_t` the 2 x 2
    /// inverse effective mass of the tangent plane (the seed formula's denominator with `t_k`,
    /// `t_l` in place of `n, n`) and `s = min(1, limit / |K_t^-1 v_t|)`.
    ///
    /// It never adds energy: an impulse `t` in the tangent plane changes the kinetic energy by
    /// `t . v_t + t . K_t t / 2`, which for `t = -s K_t^-1 v_t` is
    /// `-s (1 - s / 2) v_t . K_t^-1 v_t <= 0` for `0 <= s <= 1`. (Clamping each tangent in turn
    /// against an accumulated impulse, as [`solve_friction`] does over iterations, has no such
    /// bound on a single application.) The tangent rows must be prepared.
    pub fn apply_stick_impulse(&self, bodies: &mut [SolverBody], limit: f32) -> [f32; 2] {
        // `K_t`, as `prepare_tangent_rows` derived it.
        let [k00, k01, k11] = self.tangent_k;
        let v = [
            self.tangent_velocity(bodies, 0),
            self.tangent_velocity(bodies, 1),
        ];
        let det = k00 * k11 - k01 * k01;
        // `K_t^-1 v_t`; a singular plane (relative 1e-6: f32 rounding of a rank-one `K_t`, a
        // body free to move along one tangent only) is solved tangent by tangent.
        let stick = if det > 1e-6 * k00 * k11 {
            [
                (k11 * v[0] - k01 * v[1]) / det,
                (k00 * v[1] - k01 * v[0]) / det,
            ]
        } else {
            [
                if k00 > 0.0 { v[0] / k00 } else { 0.0 },
                if k11 > 0.0 { v[1] / k11 } else { 0.0 },
            ]
        };
        let size = (stick[0] * stick[0] + stick[1] * stick[1]).sqrt();
        if size.is_nan() || size <= 0.0 {
            return [0.0; 2];
        }
        let s = (limit / size).min(1.0);
        let t = [-s * stick[0], -s * stick[1]];
        for (k, &impulse) in t.iter().enumerate() {
            if impulse != 0.0 {
                self.apply_tangent_impulse(bodies, k, impulse);
            }
        }
        t
    }

    /// Applies friction impulse `impulse` along tangent `k` (+ to B, - to A).
    #[inline]
    pub fn apply_tangent_impulse(&self, bodies: &mut [SolverBody], k: usize, impulse: f32) {
        let mut v = PairVelocities::load(bodies, self.body_a, self.body_b);
        self.apply_tangent_impulse_in(&mut v, k, impulse);
        v.store(bodies, self.body_a, self.body_b);
    }

    /// [`apply_tangent_impulse`](Self::apply_tangent_impulse) to the bodies' velocities in `v`.
    #[inline]
    pub fn apply_tangent_impulse_in(&self, v: &mut PairVelocities, k: usize, impulse: f32) {
        let p = impulse * self.tangents[k];
        apply_row_impulse(
            &mut v.a.linear,
            &mut v.a.angular,
            v.a.inverse_mass,
            Some(-p),
            Some((-impulse, self.tangent_ang[0][k])),
        );
        apply_row_impulse(
            &mut v.b.linear,
            &mut v.b.angular,
            v.b.inverse_mass,
            Some(p),
            Some((impulse, self.tangent_ang[1][k])),
        );
    }
}

/// Coulomb friction on one contact, the disc of radius `friction * normal_impulse`: where the
/// contact sticks, Gauss-Seidel over its two tangent rows, each solved for zero slip on the
/// velocities the other leaves; where that would leave the disc (the contact slides), the
/// point of the disc nearest stopping the slip in the metric of the tangent plane's inverse
/// effective mass ([`disc_solve`]), which brakes a slide straight against its direction.
/// Returns whether any velocity changed.
///
/// Each update is the exact minimum of the kinetic energy along its row, or over the disc, so
/// friction never adds energy. Solving both tangents from the same velocities and then
/// clamping radially overshoots where the rows are coupled through the body's rotation (a
/// thin capsule, whose inertia differs greatly between axes): a 45 kg capsule landing at 9 m/s
/// gained 2 kJ of spin that way (the energy property test, seed 138).
pub fn solve_friction(bodies: &mut [SolverBody], c: &mut ContactConstraint) -> bool {
    if friction_idle(c) {
        return false;
    }
    let mut v = PairVelocities::load(bodies, c.body_a, c.body_b);
    let changed = solve_friction_in(&mut v, c);
    if changed {
        v.store(bodies, c.body_a, c.body_b);
    }
    changed
}

/// `impulse` clamped into `[-room, room]`, `room = sqrt(room2)`, exactly as
/// `impulse.clamp(-room, room)`, with the square root taken only where the impulse may reach
/// the bound.
///
/// Why: the square root is on the chain of row updates (the second tangent's room waits for
/// the first tangent's new impulse), and most rows stick well inside their disc. The result is
/// the same: `impulse^2 < room2 (1 - 4 eps)` with `room2` a normal number (each side rounded
/// within a relative `eps / 2`) puts `|impulse|` below the rounded `room`, where the clamp
/// returns `impulse` unchanged; anything else (the bound, a zero or subnormal `room2`, a NaN)
/// takes the clamp itself.
#[inline]
pub(crate) fn clamp_to_room(impulse: f32, room2: f32) -> f32 {
    if room2 >= f32::MIN_POSITIVE && impulse * impulse < room2 * (1.0 - 4.0 * f32::EPSILON) {
        impulse
    } else {
        let room = room2.sqrt();
        impulse.clamp(-room, room)
    }
}

/// A row that pushes nothing and holds no friction impulse has no room on either tangent: each
/// update of [`solve_friction`] would clamp to a zero and change nothing. Speculative rows
/// (within the margin but apart) are such rows: in a settled pile of 4,000 spheres, returning
/// early for them took `solve_friction` from 18 % to 16 % of the step.
#[inline]
fn friction_idle(c: &ContactConstraint) -> bool {
    c.friction * c.normal_impulse.max(0.0) == 0.0 && c.tangent_impulse == [0.0; 2]
}

/// [`solve_friction`] on the velocities of the contact's bodies in `v` (see
/// [`PairVelocities`]).
#[inline]
pub fn solve_friction_in(v: &mut PairVelocities, c: &mut ContactConstraint) -> bool {
    solve_friction_scaled_in(v, c, 1.0)
}

/// [`solve_friction_in`] with the disc's radius `scale` times the row's own: the hybrid's
/// held chains, whose rows bear more than their own normal impulse (see
/// [`Transmitted`](crate::dynamics::solver::hybrid::Transmitted)).
#[inline]
pub fn solve_friction_scaled_in(
    v: &mut PairVelocities,
    c: &mut ContactConstraint,
    scale: f32,
) -> bool {
    if friction_idle(c) {
        return false;
    }
    let limit = c.friction * c.normal_impulse.max(0.0) * scale;
    let mut impulse = c.tangent_impulse;
    let changed = solve_plane(&*c, v, &mut impulse, limit);
    c.tangent_impulse = impulse;
    changed
}

/// A friction pair's two rows along the tangents of one plane, on a body pair's velocities: a
/// contact point's ([`ContactConstraint`]) or a manifold's centroid (the hybrid's manifold
/// friction), solved alike by [`solve_plane`].
pub(crate) trait TangentPlane {
    /// The relative velocity along tangent `k`.
    fn slip(&self, v: &PairVelocities, k: usize) -> f32;
    /// Applies impulse `delta` along tangent `k` (`-` to body A, `+` to body B).
    fn apply(&self, v: &mut PairVelocities, k: usize, delta: f32);
    /// The plane's inverse effective mass `K_t`, `[k00, k01, k11]`.
    fn inverse_mass(&self) -> [f32; 3];
}

impl TangentPlane for ContactConstraint {
    #[inline]
    fn slip(&self, v: &PairVelocities, k: usize) -> f32 {
        self.tangent_velocity_in(v, k)
    }

    #[inline]
    fn apply(&self, v: &mut PairVelocities, k: usize, delta: f32) {
        self.apply_tangent_impulse_in(v, k, delta);
    }

    #[inline]
    fn inverse_mass(&self) -> [f32; 3] {
        self.tangent_k
    }
}

/// One update of a friction pair on the velocities `v`, bounded by the Coulomb disc of radius
/// `limit`: `impulse` (the pair's accumulated impulse along its two tangents) is updated.
/// Returns whether any velocity changed.
///
/// Sticking: the two tangent rows in turn, each stopping the slip the first leaves, kept
/// wherever neither leaves its slice of the disc (each update the minimum of the energy along
/// its row). Sliding (the rows in turn would leave the disc): the point of the disc nearest
/// stopping the slip ([`disc_solve`]).
#[inline]
pub(crate) fn solve_plane(
    plane: &impl TangentPlane,
    v: &mut PairVelocities,
    impulse: &mut [f32; 2],
    limit: f32,
) -> bool {
    let k_t = plane.inverse_mass();
    let mut tried = *v;
    let mut rows = *impulse;
    let mut changed = false;
    let mut inside = true;
    for k in 0..2 {
        let other = rows[1 - k];
        let room2 = (limit * limit - other * other).max(0.0);
        let diagonal = k_t[2 * k];
        let mass = if diagonal > 0.0 { 1.0 / diagonal } else { 0.0 };
        let wanted = rows[k] - mass * plane.slip(&tried, k);
        let new = clamp_to_room(wanted, room2);
        inside &= new == wanted;
        let delta = new - rows[k];
        if delta != 0.0 {
            rows[k] = new;
            plane.apply(&mut tried, k, delta);
            changed = true;
        }
    }
    if inside {
        *impulse = rows;
        *v = tried;
        return changed;
    }
    let slip = [plane.slip(v, 0), plane.slip(v, 1)];
    let new = disc_solve(*impulse, slip, k_t, limit);
    let mut changed = false;
    for (k, &new) in new.iter().enumerate() {
        let delta = new - impulse[k];
        if delta != 0.0 {
            impulse[k] = new;
            plane.apply(v, k, delta);
            changed = true;
        }
    }
    changed
}

/// The new accumulated friction impulse of a tangent plane (two rows): the impulse in the
/// Coulomb disc `|f| <= limit` closest to stopping the slip, in the metric of the plane's
/// inverse effective mass. With `old` the accumulated impulse, `slip` the tangential relative
/// velocity and `K = [k00, k01, k11]` the plane's `K_t`, the unbounded answer is
/// `f* = old - K^-1 slip` (the slip stopped); where that lies outside the disc, the answer is
/// the point of the disc nearest `f*` as `K` measures distance, `(K + mu I)^-1 K f*` with
/// `mu >= 0` setting its length to `limit` (found by Newton's method on
/// `1/|f(mu)| - 1/limit`, the trust-region secular equation, which converges from `mu = 0`
/// without overshooting).
///
/// Why: an impulse change `d` changes the kinetic energy by `d . slip + d . K d / 2`, which
/// is `(|new - f*|_K^2 - |old - f*|_K^2) / 2`: the nearest point of the disc to `f*` in that
/// metric lowers the energy the most, and never raises it while `old` lies in the disc. It is
/// also the same whatever the tangent basis, so friction brakes a slide straight against its
/// direction. Solving the two tangents one after the other, each clamped to its slice of the
/// disc given the other, let the first tangent take the whole disc and keep it while it
/// slipped: a cube sliding at 30 degrees to the first tangent braked along it first and slid
/// 0.61 m, 0.24 m of it sideways, where it should stop straight after 0.40 m.
///
/// [`solve_friction`] uses it only where the rows in turn would leave the disc (a slide): a
/// sticking contact keeps the two rows in turn, each exact along its row. Why: stacks stand
/// on sticking contacts, and their long-run stability turns on the rounding of these updates
/// (a column of 20 cubes at 30 Hz, standing within 0.003 mm for 20 s with the rows, drifted
/// 2.1 mm, growing, with the plane's exact 2 x 2 stick in their place).
///
/// A `K` near singular (see [`DISC_CONDITION`]: a body free to move along one tangent only,
/// or nearly) is solved tangent by tangent, each row clamped to its slice of the disc.
#[inline]
pub(crate) fn disc_solve(old: [f32; 2], slip: [f32; 2], k: [f32; 3], limit: f32) -> [f32; 2] {
    let [k00, k01, k11] = k.map(f64::from);
    // Exact in f64 (products of f32 carry 48 bits), so `f*` is exact for the stored `K`.
    let det = k00 * k11 - k01 * k01;
    // Also a NaN `K`.
    if det.partial_cmp(&(DISC_CONDITION * k00 * k11)) != Some(std::cmp::Ordering::Greater) {
        return rows_solve(old, slip, k, limit);
    }
    let [s0, s1] = slip.map(f64::from);
    let target = [
        f64::from(old[0]) - (k11 * s0 - k01 * s1) / det,
        f64::from(old[1]) - (k00 * s1 - k01 * s0) / det,
    ];
    let limit = f64::from(limit);
    if target[0].hypot(target[1]) <= limit {
        return target.map(|f| f as f32);
    }
    if limit == 0.0 || !(target[0].is_finite() && target[1].is_finite()) {
        return [0.0; 2];
    }
    project_onto_disc(target, [k00, k01, k11], limit)
}

/// `K_t` is solved as a plane only where `det K >= DISC_CONDITION k00 k11` (a condition number
/// up to about 4,000), else tangent by tangent. Why: `f*` inverts `K`, and the stored `K`
/// differs from what the rows' impulses do to the velocities by f32 rounding (a relative
/// 1e-7); inverting amplifies that by the condition number `c`, and the energy the plane's
/// step may then take in error grows as `1e-14 c^3` of what it takes: 6e-4 at 4,000, but
/// orders above 1 near the f32 rounding of a singular `K`.
const DISC_CONDITION: f64 = 1e-3;

/// The point of the disc `|f| <= limit` nearest `target` (outside it) in the metric of
/// `K = [k00, k01, k11]` (see [`disc_solve`]): `f(mu) = (K + mu I)^-1 K target` with `mu >= 0`
/// found by Newton's method on `1/|f(mu)| - 1/limit`, in f64 (so that `|f|^3` neither
/// overflows nor underflows for any f32 input), then scaled onto the circle (by at most
/// [`DISC_TOLERANCE`]).
fn project_onto_disc(target: [f64; 2], k: [f64; 3], limit: f64) -> [f32; 2] {
    let [k00, k01, k11] = k;
    let [t0, t1] = target;
    let w = [k00 * t0 + k01 * t1, k01 * t0 + k11 * t1];
    // `(K + mu I)^-1 x`.
    let solve = |mu: f64, x: [f64; 2]| {
        let (a, d) = (k00 + mu, k11 + mu);
        let det = a * d - k01 * k01;
        [(d * x[0] - k01 * x[1]) / det, (a * x[1] - k01 * x[0]) / det]
    };
    let mut mu = 0.0f64;
    let mut f = target;
    for _ in 0..DISC_ITERATIONS {
        let size = f[0].hypot(f[1]);
        if size <= limit * (1.0 + DISC_TOLERANCE) {
            break;
        }
        // `f' = -(K + mu I)^-1 f`; `d/dmu (1/|f|) = -(f . f') / |f|^3`.
        let slope = solve(mu, f);
        let rate = (f[0] * slope[0] + f[1] * slope[1]) / (size * size * size);
        let step = (1.0 / limit - 1.0 / size) / rate;
        if !(step > 0.0 && step.is_finite()) {
            break;
        }
        mu += step;
        f = solve(mu, w);
    }
    let size = f[0].hypot(f[1]);
    let scale = if size > limit { limit / size } else { 1.0 };
    let f = [(f[0] * scale) as f32, (f[1] * scale) as f32];
    if f[0].is_finite() && f[1].is_finite() {
        f
    } else {
        [0.0; 2]
    }
}

/// Newton steps of [`disc_solve`]'s projection at most (it converges in 2-5).
const DISC_ITERATIONS: usize = 16;

/// [`disc_solve`]'s projection stops within this relative distance of the disc's edge.
const DISC_TOLERANCE: f64 = 1e-6;

/// [`disc_solve`] for a singular `K`: Gauss-Seidel over the two tangents, each row solved for
/// zero slip on the slip the first leaves and clamped to its slice of the disc given the other
/// tangent's impulse; each update the exact minimum of the energy along its row.
fn rows_solve(old: [f32; 2], slip: [f32; 2], k: [f32; 3], limit: f32) -> [f32; 2] {
    let [k00, k01, k11] = k;
    let mut f = old;
    let mut slip = slip;
    let diagonal = [k00, k11];
    for row in 0..2 {
        if diagonal[row] <= 0.0 {
            continue;
        }
        let other = f[1 - row];
        let room2 = (limit * limit - other * other).max(0.0);
        let new = clamp_to_room(f[row] - slip[row] / diagonal[row], room2);
        let delta = new - f[row];
        f[row] = new;
        // The slip this row's change leaves on both tangents: `K` times the change.
        if row == 0 {
            slip = [slip[0] + k00 * delta, slip[1] + k01 * delta];
        }
    }
    f
}
