//! A manifold of one point (a sphere's contact): [`solve_block`]'s solve without its buffers.

use super::*;

/// [`solve_block`] for a block of one row, the same floating-point operations in the same order
/// without the row buffer, the passes or the sums over the points. Returns what `solve_block`
/// does.
///
/// Why: sphere contacts are one-point manifolds, and in a settled pile of spheres nearly every
/// block is one; their per-block bookkeeping cost the hybrid's resting phase more than the
/// solve itself. With `N = 1` (`n = 1` below):
///
/// - the soft plane's `c = K_mean / a2` has `K_mean = 1^T A 1 / N^2`, the row's own `K` summed
///   from `0 + r x n` and `0 + I^-1 (r x n)` (kept as sums: `0 + x` is `x` except for the sign
///   of a zero), with the products and the quotient by `N^2 = 1` left out, which are exact;
/// - a pointwise row's share of the load is `N / load = 1 / load`;
/// - one pass: a lone row is the exact solve of its own regularised problem, so `solve_block`
///   returns after its first pass too (converged, whatever changed).
#[inline]
pub(super) fn solve_row(
    bodies: &mut [SolverBody],
    c: &mut ContactConstraint,
    block: &Block,
    solve: &ManifoldSolve,
) -> (bool, f32, bool) {
    let response = block.response(c.normal);
    let (fa, fb) = (response.a.angular, response.b.angular);
    let linear_a = response.a.along_normal * bodies[c.body_a].inverse_mass;
    let linear_b = response.b.along_normal * bodies[c.body_b].inverse_mass;
    let Some((bias, soft)) = block_row(c, bodies, solve) else {
        return (true, 0.0, false);
    };
    let k = held_diagonal(c, [linear_a, linear_b], [fa, fb]);
    if k <= 0.0 {
        return (true, 0.0, false);
    }
    let mut v = PairVelocities::load(bodies, c.body_a, c.body_b);
    let vn = c.normal_velocity_in(&v);
    let (residual, diagonal) = match solve.soft {
        Some(spring) if soft => {
            let total = 0.0 + c.normal_impulse;
            if c.friction > 0.0 && soft_tilt_stands(block, solve) {
                // Point by point, Box2D's soft row with the stiffness of the load's share.
                let share = if block.load > 0.0 {
                    1.0 / block.load
                } else {
                    0.0
                };
                let softness = spring.impulse_scale / spring.mass_scale;
                let own = if share > 0.0 { share } else { k } * softness;
                (vn + bias + own * c.normal_impulse, k + own)
            } else {
                // The soft plane: `c = min(K, 1 / load) / a2`. `K` summed over the one point
                // is the row's own `k` (the sums `0 + r x n`, `0 + I^-1 (r x n)` differ from the
                // row's terms only in the sign of a zero, which cannot change a positive `k`).
                let mut plane = k;
                if block.load > 0.0 {
                    plane = plane.min(1.0 / block.load);
                }
                let coupling = plane * spring.impulse_scale / spring.mass_scale;
                (vn + bias + coupling * total, k + coupling)
            }
        }
        _ => (vn + bias, k),
    };
    let delta = update_row(c, &mut v, residual / diagonal, &response);
    if delta != 0.0 {
        v.store(bodies, c.body_a, c.body_b);
    }
    (true, 0.0f32.max(delta.abs() * k), delta != 0.0)
}
