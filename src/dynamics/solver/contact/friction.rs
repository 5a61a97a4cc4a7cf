//! The friction side of a contact row: the tangent rows, the tangential velocity, the
//! accumulated friction solve and the one-shot stick impulse of impact events.

use super::super::body::{PairVelocities, SolverBody};
use super::ContactConstraint;
use crate::impulse::{apply_row_impulse, row_inverse_mass};

impl ContactConstraint {
    /// Derives the two tangent rows from the anchors and `tangents`: `I^-1 (r x t)` for each
    /// body and tangent, and the effective masses along the tangents.
    pub fn prepare_tangent_rows(&mut self, a: &SolverBody, b: &SolverBody) {
        for k in 0..2 {
            let t = self.tangents[k];
            let (ra_t, rb_t) = (self.anchor_a.cross(t), self.anchor_b.cross(t));
            self.tangent_ang[0][k] = a.inverse_inertia * ra_t;
            self.tangent_ang[1][k] = b.inverse_inertia * rb_t;
            let kt = row_inverse_mass(
                [a.inverse_mass, b.inverse_mass],
                [
                    ra_t.dot(self.tangent_ang[0][k]),
                    rb_t.dot(self.tangent_ang[1][k]),
                ],
            );
            self.tangent_mass[k] = if kt > 0.0 { 1.0 / kt } else { 0.0 };
        }
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
        let (a, b) = (&bodies[self.body_a], &bodies[self.body_b]);
        let (ra, rb) = (self.anchor_a, self.anchor_b);
        // `K_t`'s entries are the seed formula's denominator for the tangents `t_i`, `t_l`
        // ([`row_inverse_mass`]; the linear part only on the diagonal, `t_i . t_l = 0` off it).
        let k = |i: usize, l: usize| {
            let t = self.tangents[i];
            let linear = if i == l {
                [a.inverse_mass, b.inverse_mass]
            } else {
                [0.0; 2]
            };
            let angular = [
                ra.cross(t).dot(self.tangent_ang[0][l]),
                rb.cross(t).dot(self.tangent_ang[1][l]),
            ];
            row_inverse_mass(linear, angular)
        };
        let (k00, k01, k11) = (k(0, 0), 0.5 * (k(0, 1) + k(1, 0)), k(1, 1));
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

/// Coulomb friction on one contact: Gauss-Seidel over its two tangent rows, each solved for
/// zero slip on the current velocities and clamped to its slice of the disc of radius
/// `friction * normal_impulse` (given the other tangent's impulse). Returns whether any
/// velocity changed.
///
/// Each row update is the exact minimum of the kinetic energy along that row over an interval,
/// so friction never adds energy. Solving both tangents from the same velocities and then
/// clamping, as before, overshoots where the rows are coupled through the body's rotation (a
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
pub(super) fn clamp_to_room(impulse: f32, room2: f32) -> f32 {
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
    if friction_idle(c) {
        return false;
    }
    let limit = c.friction * c.normal_impulse.max(0.0);
    let mut changed = false;
    for k in 0..2 {
        let other = c.tangent_impulse[1 - k];
        let room2 = (limit * limit - other * other).max(0.0);
        let old = c.tangent_impulse[k];
        let new = clamp_to_room(old - c.tangent_mass[k] * c.tangent_velocity_in(v, k), room2);
        let delta = new - old;
        if delta != 0.0 {
            c.tangent_impulse[k] = new;
            c.apply_tangent_impulse_in(v, k, delta);
            changed = true;
        }
    }
    changed
}
