//! A small dense solve of an impact event's contact rows: the linear complementarity problem
//! `w = K lambda + q >= 0`, `lambda >= 0`, `lambda . w = 0`, with `K` the event's Delassus
//! matrix (the normal velocity change of each row per unit impulse on each row), `q` each
//! row's normal velocity less its target, `lambda` the impulses and `w` the rows' velocities
//! above their targets after them.
//!
//! Why a direct solve: Gauss-Seidel on the rows of a light body pressed between a heavy one
//! and the floor gains a factor `M / (M + m)` a pass (its off-diagonal term squared over the
//! diagonal ones), so 230 passes at 100:1 and 2,300 at 1000:1 for a tenth of the approach;
//! the exact answer is a handful of linear solves of the event's size.
//!
//! The method is the primal active set of Lawson and Hanson for a convex quadratic with
//! non-negative variables (`K` is symmetric positive semi-definite; the problem is
//! `min lambda K lambda / 2 + q . lambda` over `lambda >= 0`): starting from no impulse, the
//! row with the most negative `w` joins the free set, the free rows are solved as equalities
//! (`w = 0`) by a Cholesky factor grown a row at a time, and a row whose impulse would turn
//! negative leaves on the way there. Each step lowers the objective, so no free set repeats
//! and the solve ends. The rows of one manifold are often redundant (four corners of a face
//! in a plane: `K` of rank 3); a relative `1e-9` added to the diagonal keeps the factor
//! positive definite, and a redundant row never joins the free set, its `w` already zero
//! once the others are solved.

use bevy::math::{DMat3, DVec3};

use super::body::SolverBody;
use super::contact::ContactConstraint;
use crate::dynamics::solver::refill;

/// Relative regularisation of the diagonal (see the module doc): far below the f32 rounding
/// of the velocities (1e-7), far above f64's (1e-16), which a redundant row's pivot is.
const REGULARISATION: f64 = 1e-9;

/// One row in f64: its bodies, the normal and the lever arms' `r x n`, and `I^-1 (r x n)`.
#[derive(Clone, Copy, Debug)]
struct Row {
    a: usize,
    b: usize,
    n: DVec3,
    rn_a: DVec3,
    rn_b: DVec3,
    ang_a: DVec3,
    ang_b: DVec3,
    inverse_mass_a: f64,
    inverse_mass_b: f64,
}

/// The buffers of a dense event solve, kept across events.
#[derive(Default)]
pub(super) struct DenseSolve {
    rows: Vec<Row>,
    /// `q`: each row's normal velocity less its target, m/s.
    q: Vec<f64>,
    /// The columns of `K` computed so far (those of rows that were free), column-major with
    /// stride `n`: most rows of an event never push, and their columns are never needed.
    k: Vec<f64>,
    /// Whether each column of `K` is computed.
    computed: Vec<bool>,
    /// The impulses, N s.
    lambda: Vec<f64>,
    /// `w = K lambda + q`.
    w: Vec<f64>,
    /// The free rows, in the order of the Cholesky factor.
    free: Vec<usize>,
    /// Whether each row is free.
    is_free: Vec<bool>,
    /// The lower Cholesky factor of `K` on the free rows, row-major with stride `n`.
    factor: Vec<f64>,
    /// Scratch of the triangular solves.
    y: Vec<f64>,
    z: Vec<f64>,
}

/// The symmetric part of a body's world inverse inertia, in f64.
fn inverse_inertia(body: &SolverBody) -> DMat3 {
    let m = body.inverse_inertia.as_dmat3();
    (m + m.transpose()) * 0.5
}

impl DenseSolve {
    /// Starts a new event.
    pub(super) fn clear(&mut self) {
        self.rows.clear();
        self.q.clear();
    }

    /// Adds contact `c` (anchors as it is to be solved) with the normal velocity `target` it
    /// must reach at least, m/s.
    pub(super) fn push(&mut self, c: &ContactConstraint, bodies: &[SolverBody], target: f64) {
        let (a, b) = (&bodies[c.body_a], &bodies[c.body_b]);
        let n = c.normal.as_dvec3();
        let (rn_a, rn_b) = if c.angular {
            (c.rn_a.as_dvec3(), c.rn_b.as_dvec3())
        } else {
            (DVec3::ZERO, DVec3::ZERO)
        };
        let row = Row {
            a: c.body_a,
            b: c.body_b,
            n,
            rn_a,
            rn_b,
            ang_a: inverse_inertia(a) * rn_a,
            ang_b: inverse_inertia(b) * rn_b,
            inverse_mass_a: a.inverse_mass as f64,
            inverse_mass_b: b.inverse_mass as f64,
        };
        self.rows.push(row);
        self.q.push(normal_velocity(c, bodies) - target);
    }

    /// Solves the rows added. Returns the impulses, one a row in the order added, or `None`
    /// when the solve failed (a factor lost its positive pivot to rounding, or the step bound
    /// was reached), which leaves the caller its iterative solve.
    ///
    /// A row joins the free set while its `w` is below `-1e-12` of the largest `|q|`: far above
    /// the f64 rounding of `w` (1e-16 of the terms summed), and far below the `1e-9` of the
    /// regularisation. So the regularised problem is solved, not only the rigid one, whose
    /// impulses are not unique over redundant rows: four corners of a box landing flat each
    /// take a quarter, where stopping at the rigid answer left two diagonal corners with half
    /// each (the other two at `w = -1e-9 |q|`), an answer as right for the velocities but not
    /// for the impulses each contact reports, nor symmetric.
    pub(super) fn solve(&mut self) -> Option<&[f64]> {
        // Long on purpose: one pivoting loop (a row enters, the rows whose impulse reaches zero
        // leave, the factor is updated and the free set solved again), its steps sharing the
        // factor and the free set: the textbook algorithm reads best whole.
        let n = self.rows.len();
        let tolerance = 1e-12 * self.q.iter().fold(f64::MIN_POSITIVE, |m, q| m.max(q.abs()));
        refill(&mut self.computed, n, false);
        // Every entry read is written first: no clearing.
        for buffer in [&mut self.k, &mut self.factor] {
            if buffer.len() < n * n {
                buffer.resize(n * n, 0.0);
            }
        }
        refill(&mut self.lambda, n, 0.0);
        self.w.clear();
        self.w.extend_from_slice(&self.q);
        self.free.clear();
        refill(&mut self.is_free, n, false);
        // Each step adds a row or removes one, and a row enters only with the objective
        // falling: a bound far above what is needed (about n steps) that only a failure meets.
        for _ in 0..4 * n + 8 {
            // The row that approaches its target fastest enters.
            let entering = (0..n)
                .filter(|&i| !self.is_free[i] && self.w[i] < -tolerance)
                .min_by(|&i, &j| self.w[i].total_cmp(&self.w[j]));
            let Some(j) = entering else {
                return Some(&self.lambda);
            };
            self.column(j);
            self.free.push(j);
            self.is_free[j] = true;
            if !self.append(self.free.len() - 1) {
                return None;
            }
            loop {
                self.solve_free();
                let m = self.free.len();
                if (0..m).all(|f| self.z[f] > 0.0) {
                    for f in 0..m {
                        self.lambda[self.free[f]] = self.z[f];
                    }
                    break;
                }
                // Move from lambda towards z as far as every impulse stays >= 0; the rows
                // whose impulse reaches 0 leave.
                let mut step = 1.0f64;
                let mut blocking = usize::MAX;
                for f in 0..m {
                    let (l, z) = (self.lambda[self.free[f]], self.z[f]);
                    if z <= 0.0 {
                        let s = if l > 0.0 { l / (l - z) } else { 0.0 };
                        if s < step {
                            (step, blocking) = (s, f);
                        }
                    }
                }
                if step == 0.0 {
                    // Only the entering row, at 0, can block at once: it would take no
                    // impulse, which a row with `w < 0` cannot but by rounding. Give up.
                    return None;
                }
                for f in 0..m {
                    let i = self.free[f];
                    self.lambda[i] += step * (self.z[f] - self.lambda[i]);
                }
                if blocking != usize::MAX {
                    self.lambda[self.free[blocking]] = 0.0;
                }
                let lambda = &self.lambda;
                let is_free = &mut self.is_free;
                self.free.retain(|&i| {
                    let keep = lambda[i] > 0.0;
                    is_free[i] = keep;
                    keep
                });
                for f in 0..self.free.len() {
                    if !self.append(f) {
                        return None;
                    }
                }
                if self.free.is_empty() {
                    break;
                }
            }
            // w = K lambda + q.
            self.w.copy_from_slice(&self.q);
            for &f in &self.free {
                let (column, l) = (&self.k[f * n..(f + 1) * n], self.lambda[f]);
                for (w, k) in self.w.iter_mut().zip(column) {
                    *w += k * l;
                }
            }
        }
        None
    }

    /// Computes column `j` of `K` (once): `K_ij` sums, over each body the two rows share, the
    /// sign of the body in each row times `n_i . n_j / m + (r_i x n_i) . I^-1 (r_j x n_j)`.
    fn column(&mut self, j: usize) {
        if self.computed[j] {
            return;
        }
        self.computed[j] = true;
        let n = self.rows.len();
        let rj = self.rows[j];
        let sides_j = [(rj.a, -1.0, rj.ang_a), (rj.b, 1.0, rj.ang_b)];
        for i in 0..n {
            let ri = &self.rows[i];
            let sides_i = [
                (ri.a, -1.0, ri.rn_a, ri.inverse_mass_a),
                (ri.b, 1.0, ri.rn_b, ri.inverse_mass_b),
            ];
            let mut k = 0.0;
            for &(body_i, sign_i, rn_i, inverse_mass) in &sides_i {
                for &(body_j, sign_j, ang_j) in &sides_j {
                    if body_i == body_j {
                        k += sign_i * sign_j * (inverse_mass * ri.n.dot(rj.n) + rn_i.dot(ang_j));
                    }
                }
            }
            if i == j {
                k *= 1.0 + REGULARISATION;
            }
            self.k[j * n + i] = k;
        }
    }

    /// Computes row `f` of the Cholesky factor of `K` on the free rows, the rows before it
    /// being done. False if its pivot is not positive.
    fn append(&mut self, f: usize) -> bool {
        let n = self.rows.len();
        let i = self.free[f];
        for g in 0..=f {
            let mut s = self.k[self.free[g] * n + i];
            for h in 0..g {
                s -= self.factor[f * n + h] * self.factor[g * n + h];
            }
            if g < f {
                self.factor[f * n + g] = s / self.factor[g * n + g];
            } else if s > 0.0 {
                self.factor[f * n + f] = s.sqrt();
            } else {
                return false;
            }
        }
        true
    }

    /// `z` on the free rows: `K_FF z = -q_F`.
    fn solve_free(&mut self) {
        let n = self.rows.len();
        let m = self.free.len();
        refill(&mut self.y, m, 0.0);
        refill(&mut self.z, m, 0.0);
        for f in 0..m {
            let mut s = -self.q[self.free[f]];
            for h in 0..f {
                s -= self.factor[f * n + h] * self.y[h];
            }
            self.y[f] = s / self.factor[f * n + f];
        }
        // L^T z = y, by rows of L (contiguous): each z found is taken out of the rest of y.
        for h in (0..m).rev() {
            let z = self.y[h] / self.factor[h * n + h];
            self.z[h] = z;
            let row = &self.factor[h * n..h * n + h];
            for (y, l) in self.y[..h].iter_mut().zip(row) {
                *y -= l * z;
            }
        }
    }
}

/// The normal velocity of `c`, as [`ContactConstraint::normal_velocity`], in f64.
pub(super) fn normal_velocity(c: &ContactConstraint, bodies: &[SolverBody]) -> f64 {
    let (a, b) = (&bodies[c.body_a], &bodies[c.body_b]);
    let n = c.normal.as_dvec3();
    let mut vn =
        (b.linear_velocity.as_dvec3() - a.linear_velocity.as_dvec3()).dot(n) + c.drive as f64;
    if c.angular {
        vn += b.angular_velocity.as_dvec3().dot(c.rn_b.as_dvec3())
            - a.angular_velocity.as_dvec3().dot(c.rn_a.as_dvec3());
    }
    vn
}

#[cfg(test)]
mod tests;
