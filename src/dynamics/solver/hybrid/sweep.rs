//! The resting phase's sweep: each manifold solved as a block, the support held as far as it
//! is held.

use super::*;

/// One sweep of the hybrid method's resting solve: the soft step with each body pair's
/// manifold (`blocks`, contiguous ranges of `contacts` sharing one normal) solved as a block,
/// to convergence, before the next, and with only the manifold's mean penetration soft.
///
/// Why: a soft row per point lets an off-centre load tilt a face contact, since each corner
/// sinks in proportion to its share of the load. The contact normal turns with the tilted face,
/// so the load then pushes the body above sideways, further off centre: with frictionless
/// contacts this feedback grows exponentially at a rate of about `W / sqrt(k m)` (`W` the load,
/// `k` the contact's stiffness against tilting, `m` the mass pushed sideways). Point-by-point
/// Gauss-Seidel also adds a spurious tilt of its own, since the first corner solved takes more
/// than its share. Measured with Box2D's row-by-row soft step (`SolverMethod::SoftStep`): a
/// column of 10 cubes topples within 20 s and a light box is squeezed out from under a 100
/// times heavier one within a second. Solving the block removes the spurious tilt and the
/// compliance of a single manifold; the lag between manifolds is handled by their order (see
/// `shock_order`).
///
/// The manifold's rows therefore solve the regularised block problem
///
/// ```text
/// v_i' + b_i + c * sum_j(lambda_j') = 0   (lambda_i' >= 0, complementary),
/// c = K_mean / a2,  K_mean = 1^T A 1 / N^2,
/// ```
///
/// over its `N` penetrating points, with `A` the manifold's Delassus matrix (so `K_mean` is
/// the inverse effective mass of the manifold's centroid), `b_i = max(bias_rate s_i, -cap)` the
/// soft push-out, and `a2 = mass_scale / impulse_scale` Box2D's softness coefficient. Summed
/// over the points this is exactly Box2D's soft constraint for the manifold as a whole,
/// `v' + b + (K/a2) lambda' = 0`: the manifold sinks by the predictable
/// `W K_mean / (2 pi f)^2` under a load `W`. The tilt modes carry no regularisation, so they
/// are rigid: any load distribution is taken without tilting, and differences in penetration
/// are pushed out at the soft rate. With one point it is Box2D's soft row exactly. Speculative
/// points (`s > 0`) of a manifold none of whose points penetrates are rigid rows that may close
/// the gap, as in [`soft_sweep`](crate::dynamics::solver::soft_step::soft_sweep); in a manifold that penetrates they are points of the same
/// soft plane, in the sum and with their gap `s/h` as bias, so that they close against the
/// plane as it sinks (the block's rows then change continuously as a point's separation
/// crosses zero). Why: held at its gap, a point a hair apart (a rounding's 1e-10 m at 1 mm)
/// is a hinge while the other points sink at the soft rate, and the body turns about it: a
/// 1 mm die landed on another turned 1e-2 rad in one step (the soft sink, 0.28 mm, is a
/// quarter of its size). The Gauss-Seidel update of row `i` is
///
/// ```text
/// delta_i = -(v_i + b_i + c * sum_j lambda_j) / (K_ii + c).
/// ```
///
/// Sweeps between manifolds stay Gauss-Seidel (one per call), except that consecutive blocks
/// supporting the same body are swept together until none changes by more than the
/// tolerance: a cube resting on two others (in a pyramid) otherwise takes its whole load on
/// whichever support is solved first, rocks, and, frictionless, pushes its supports apart (a
/// pyramid of base 10 spread 0.8 m in 20 s that way; 4.8 cm solved together). A block with a
/// [`Support`] holds that body by [`Block::hold`]: its terms in `A` and its response to the
/// block's impulses are scaled by `1 - hold` (left out entirely when it is held wholly).
/// With [`Block::load`] set, `K_mean` is replaced by `min(K_mean, 1 / load)`, so the manifold
/// sinks by `g / (2 pi f)^2` under the load it carries.
///
/// A manifold with friction that is not a link of a held chain (its support released, see
/// `release_frictional_groups`, or its supported body carrying a released block, or no
/// support at all) is solved point by point instead: each penetrating point is Box2D's soft
/// row, `v_i' + b_i + c_i lambda_i' = 0` with `c_i = K_s / a2`, `K_s = N / load` (its share of
/// the load) or, where the block carries none, the row's own `K_ii`. The tilt is then soft
/// too, as stiff as the load it carries allows, and the manifold still sinks by
/// `g / (2 pi f)^2` under its load. A manifold with friction in a held chain (a body resting
/// on one held support, carrying only held blocks: a column) keeps the rigid tilt, and its
/// rows are solved to [`RIGID_FRICTION_TOLERANCE`] times the tolerance (1e-7 m/s by default).
///
/// Why both: with a rigid tilt stopped at the tolerance (1e-4 m/s), a block keeps a residual
/// tilt that becomes slip at the faces, and friction, warm-started from step to step, stores
/// it and feeds it back: a column of 20 cubes with friction 0.5 rocked in a growing cone
/// (27 cm in 20 s). Point by point, each link's tilt is soft, and along a column the soft
/// tilts add up: 30 cubes drifted 36 mm in 20 s, 20 cubes at 30 Hz 29 mm, and 30 cubes with
/// friction 1 at 30 Hz fell. With the rigid tilt solved to 1e-7 m/s these stand within 0.1 mm;
/// 1e-5 m/s was not enough (30 cubes at 30 Hz drifted 0.16-0.24 m in 10 s). It costs 3-5
/// iterations a block and sweep, run in the space of the block's normal velocities
/// (`Delassus` in `hybrid/delassus.rs`: the bodies read once and changed once a block solve;
/// a settled pile of 1,000 cubes 7.0-7.8 -> 6.3-7.0 ms a step). The rigid tilt is kept to
/// chains: under a body that carries released blocks (the bottom row of a wall, each cube
/// under two cubes resting on two supports) it took 24 iterations a block and made the
/// base-20 wall sway 3 mm out of its plane, still moving after 30 s (point by point: 0.1 mm),
/// at 45 % more cost.
///
/// Where masses alternate and in columns of 50 (20 s, measured 2026-12-07), these columns
/// failed while a held support took the block's impulse a substep late (see
/// [`held_warm_start`]): 20 cubes of 1 kg and 10 kg drifted 0.18-0.40 m at 60 Hz and fell at
/// 30 Hz; 10 of 1 kg and 0.01 kg fell after 4 s at 30 Hz and 16 s at 60 Hz, gaining 12-40 J;
/// 50 cubes drifted 0.49-5.6 m at 60 Hz and 0.08-0.32 m at 120 Hz, the figure moving with the
/// rounding of the iterations (without `Delassus`' projection of the biases, or dividing in
/// place of its reciprocal). With the held warm start all stand within 0.004 mm, and so do
/// the uniform columns of 18-30 cubes at 30 and 60 Hz (42 of 42). Left failing: 20 cubes of
/// 1 kg and 100 kg collapse at 60 Hz (step 981), and the 1:100 light column falls after 17 s
/// at 30 Hz.
///
/// A soft tilt must also hold its load up: tilted by `theta`, a manifold's rows push back with
/// a moment `W omega^2 <r^2> theta / g` (their load-scaled springs at their distances `r` from
/// the centroid), while the weight `W` it carries, its centre of mass a lever `l` above the
/// manifold, tips it by `W l theta`. Soft rows are used only where the first is at least
/// [`TILT_MARGIN`] times the second, `omega^2 <r^2> / g >= 4 l`; otherwise the block keeps its
/// rigid tilt. The soft sink `g / omega^2` (0.28 mm) is a fixed length, so this only tells
/// small bodies from large ones: a 1 m cube carrying a column of 20 has 90 times the moment it
/// needs, a 1 mm die under two more has 0.6 of it, and with soft rows a stack of three 1 mm dice
/// toppled within 10 steps.
pub fn manifold_sweep(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    blocks: &[Block],
    (frictions, transmitted): (&[ManifoldFriction], &Transmitted),
    solve: &ManifoldSolve,
    settling: &mut Settling,
    rows: &mut Vec<BlockRow>,
) -> Sweep {
    settling.begin(bodies.len());
    let mut sweep = Sweep {
        largest: 0.0,
        settled: true,
    };
    let mut start = 0;
    while start < blocks.len() {
        // Consecutive blocks that support the same body are solved together, block after
        // block, until none changes by more than the tolerance: a body resting on several
        // supports takes its load consistently from all of them within the sweep.
        let upper = blocks[start].upper(contacts);
        let end = match upper {
            Some(_) => {
                start
                    + blocks[start..]
                        .iter()
                        .take_while(|b| b.upper(contacts) == upper)
                        .count()
            }
            None => start + 1,
        };
        let passes = if end - start > 1 {
            solve.max_block_iterations.max(1)
        } else {
            1
        };
        for pass in 0..passes {
            let mut largest = 0.0f32;
            for (k, block) in blocks.iter().enumerate().take(end).skip(start) {
                let group = &mut contacts[block.range.clone()];
                let (converged, first, changed) = solve_block(bodies, group, block, solve, rows);
                largest = largest.max(first);
                if pass == 0 {
                    sweep.largest = sweep.largest.max(first);
                    sweep.settled &= converged;
                } else if changed {
                    // A later pass re-solved a block after its neighbours: the marks below
                    // no longer order the changes, so the sweep cannot count as settled.
                    sweep.settled = false;
                }
                if changed {
                    settling.changed(bodies, group[0].body_a, group[0].body_b, k);
                }
            }
            if largest <= solve.tolerance {
                break;
            }
        }
        for (k, block) in blocks.iter().enumerate().take(end).skip(start) {
            let group = &mut contacts[block.range.clone()];
            settling.friction_changed |= match frictions.get(k).filter(|f| f.ready) {
                Some(rows) => manifold_friction(bodies, group, rows, transmitted.of(k)),
                None => {
                    let scale = transmitted.bound_scale(k, group);
                    block_friction(bodies, group, scale)
                }
            };
        }
        start = end;
    }
    sweep.settled &= !settling.friction_changed
        && blocks.iter().enumerate().all(|(k, block)| {
            let c = &contacts[block.range.start];
            settling.undisturbed(c.body_a, c.body_b, k)
        });
    sweep
}

/// Friction on a block's rows with friction, each row's
/// [`solve_friction`](crate::dynamics::solver::contact::solve_friction) in turn, on the
/// velocities of the block's two bodies (every row of a block joins the same two, see
/// `shock_order`) read once and written back once (see [`PairVelocities`]). Returns whether
/// any velocity changed. The bounds count what the block carries, `scale` times each row's
/// own (see [`Transmitted::bound_scale`]).
fn block_friction(bodies: &mut [SolverBody], group: &mut [ContactConstraint], scale: f32) -> bool {
    let (a, b) = (group[0].body_a, group[0].body_b);
    let mut v = PairVelocities::load(bodies, a, b);
    let mut changed = false;
    for c in group.iter_mut().filter(|c| c.friction > 0.0) {
        debug_assert_eq!((c.body_a, c.body_b), (a, b));
        changed |= solve_friction_scaled_in(&mut v, c, scale);
    }
    if changed {
        v.store(bodies, a, b);
    }
    changed
}

/// A block's friction under [`FrictionModel::Manifold`]: its [`ManifoldFriction`] rows on its
/// two bodies' velocities, read once and written back once, its bound counting what the block
/// carries (`carried`, see [`Transmitted`]). Returns whether any changed.
fn manifold_friction(
    bodies: &mut [SolverBody],
    group: &mut [ContactConstraint],
    rows: &ManifoldFriction,
    carried: f32,
) -> bool {
    let (a, b) = (group[0].body_a, group[0].body_b);
    let mut v = PairVelocities::load(bodies, a, b);
    let changed = rows.solve_in(&mut v, group, carried);
    if changed {
        v.store(bodies, a, b);
    }
    changed
}

/// Applies `+impulse` to B and `-impulse` to A along each body's response direction, with its
/// angular response scaled by its factor, to the bodies' velocities in `v`.
#[inline]
pub(super) fn apply_response(
    c: &ContactConstraint,
    v: &mut PairVelocities,
    impulse: f32,
    r: &Response,
) {
    let (dir_a, dir_b) = (r.a.direction_for(c.normal), r.b.direction_for(c.normal));
    let (turn_a, turn_b) = (r.a.turn(c.angular), r.b.turn(c.angular));
    apply_row_impulse(
        &mut v.a.linear,
        &mut v.a.angular,
        v.a.inverse_mass,
        (dir_a != Vec3::ZERO).then(|| -(impulse * dir_a)),
        (turn_a > 0.0).then(|| (-(turn_a * impulse), c.ang_a)),
    );
    apply_row_impulse(
        &mut v.b.linear,
        &mut v.b.angular,
        v.b.inverse_mass,
        (dir_b != Vec3::ZERO).then(|| impulse * dir_b),
        (turn_b > 0.0).then_some((turn_b * impulse, c.ang_b)),
    );
}

/// Whether a manifold's soft tilt holds its load up with [`TILT_MARGIN`] to spare (see
/// [`manifold_sweep`]): `omega^2 <r^2> / g >= TILT_MARGIN * lever`, `<r^2>` its
/// [`Block::spread`]. A manifold that carries no load has its own effective mass's stiffness,
/// Box2D's soft row, and always stands.
pub(super) fn soft_tilt_stands(block: &Block, solve: &ManifoldSolve) -> bool {
    if block.load <= 0.0 || block.lever <= 0.0 {
        return true;
    }
    solve.tilt_stiffness * block.spread >= TILT_MARGIN * block.lever
}

/// Solves one manifold block to convergence (see [`manifold_sweep`]). Returns whether it
/// converged exactly, the largest change of its first pass, and whether any velocity changed.
pub(super) fn solve_block(
    bodies: &mut [SolverBody],
    group: &mut [ContactConstraint],
    block: &Block,
    solve: &ManifoldSolve,
    rows: &mut Vec<BlockRow>,
) -> (bool, f32, bool) {
    // Long on purpose: one block solve read top to bottom (each row's bias, the soft plane's
    // coupling, then the passes over the rows), its steps sharing a dozen locals (the support's
    // response, the soft sums); split, they would travel together as a struct of their own.
    if let [c] = group {
        return solve_row(bodies, c, block, solve);
    }
    // The support responds along its free direction, its rotation scaled by `1 - hold`.
    let response = block.response(group[0].normal);
    let (fa, fb) = (response.a.angular, response.b.angular);
    let linear_a = response.a.along_normal * bodies[group[0].body_a].inverse_mass;
    let linear_b = response.b.along_normal * bodies[group[0].body_b].inverse_mass;
    let diagonal = |c: &ContactConstraint| held_diagonal(c, [linear_a, linear_b], [fa, fb]);
    rows.clear();
    // Sums over the soft points: count, r x n and I^-1 (r x n) of each body, and the impulse.
    let mut count = 0u32;
    let [mut rn_a, mut ang_a, mut rn_b, mut ang_b] = [Vec3::ZERO; 4];
    let mut total = 0.0f32;
    for c in group.iter() {
        let Some(row) = block_row(c, bodies, solve) else {
            rows.push(None);
            continue;
        };
        if row.1 {
            count += 1;
            rn_a += c.rn_a;
            ang_a += c.ang_a;
            rn_b += c.rn_b;
            ang_b += c.ang_b;
            total += c.normal_impulse;
        }
        rows.push(Some(row));
    }
    // A manifold that penetrates is one soft plane: its speculative points (`s > 0`) are soft
    // rows too, with their gap `s/h` as bias, so that they close against the plane as it
    // sinks. See `manifold_sweep`.
    if count > 0 {
        for (c, row) in group.iter().zip(rows.iter_mut()) {
            if let Some((_, soft)) = row
                && !*soft
            {
                *soft = true;
                total += c.normal_impulse;
            }
        }
    }
    // With friction, each penetrating point is its own soft row, Box2D's, with the stiffness of
    // its share of the load the block carries (`load / N`), or of its own effective mass where
    // the block carries none: the tilt is soft, and the manifold still sinks by `g / (2 pi f)^2`
    // under its load. Not in a held chain (a column), whose tilt stays rigid and is solved
    // tighter. See `manifold_sweep`.
    let friction = group[0].friction > 0.0;
    let held_chain = block.support != Support::Neither && !block.carries_released;
    let pointwise = friction && !held_chain && soft_tilt_stands(block, solve);
    // A rigid tilt with friction is solved far tighter (see `manifold_sweep`).
    let tolerance = if friction && !pointwise {
        solve.tolerance * RIGID_FRICTION_TOLERANCE
    } else {
        solve.tolerance
    };
    let share = if block.load > 0.0 && count > 0 {
        count as f32 / block.load
    } else {
        0.0
    };
    let softness = solve
        .soft
        .map_or(0.0, |soft| soft.impulse_scale / soft.mass_scale);
    // c = K_mean / a2, K_mean = 1^T A 1 / N^2 (the points share the normal, so the linear part
    // of 1^T A 1 is N^2 (1/m_A + 1/m_B)): the `K` of the manifold's centroid, from the rows'
    // `r x n` and `I^-1 (r x n)` terms summed over the points (each row's own `K` is
    // `row_inverse_mass`'s, in `diagonal` above).
    let coupling = match (solve.soft, count) {
        // Point by point, the rows do not use it.
        _ if pointwise => 0.0,
        (Some(soft), n) if n > 0 => {
            let n2 = (n * n) as f32;
            let sum = row_inverse_mass(
                [n2 * linear_a, n2 * linear_b],
                [fa * rn_a.dot(ang_a), fb * rn_b.dot(ang_b)],
            );
            let mut k = sum / n2;
            if block.load > 0.0 {
                k = k.min(1.0 / block.load);
            }
            k * soft.impulse_scale / soft.mass_scale
        }
        _ => 0.0,
    };

    // Every row of the block touches the same two bodies, so a row stays satisfied (see
    // [`Settling`]) unless a later row changes something: the pass has converged when no row
    // after the first taking part changed.
    let first_row = rows.iter().position(Option::is_some);
    // A rigid tilt with friction iterates long: in the space of the rows' velocities.
    if friction && !pointwise && group.len() <= DELASSUS_ROWS {
        let mut delassus = Delassus::new(bodies, group, &response);
        let (converged, first, changed) = delassus.iterate(
            group,
            rows,
            diagonal,
            (coupling, total),
            (tolerance, first_row, solve.max_block_iterations.max(1)),
            solve.max_push_out,
        );
        delassus.apply(bodies, group, &response);
        return (converged, first, changed);
    }
    // The rows' bodies (every row of a block joins the same two, see `shock_order`) in locals
    // for the passes (see `PairVelocities`).
    let (body_a, body_b) = (group[0].body_a, group[0].body_b);
    let mut v = PairVelocities::load(bodies, body_a, body_b);
    let mut first = 0.0f32;
    let mut changed = false;
    let converged = 'passes: {
        for iteration in 0..solve.max_block_iterations.max(1) {
            let mut last_changed = None;
            let mut largest = 0.0f32;
            for (i, (c, row)) in group.iter_mut().zip(rows.iter()).enumerate() {
                let Some((bias, soft)) = *row else { continue };
                let k = diagonal(c);
                if k <= 0.0 {
                    continue;
                }
                let vn = c.normal_velocity_in(&v);
                let (residual, diagonal) = if soft && pointwise {
                    let own = if share > 0.0 { share } else { k } * softness;
                    (vn + bias + own * c.normal_impulse, k + own)
                } else if soft {
                    (vn + bias + coupling * total, k + coupling)
                } else {
                    (vn + bias, k)
                };
                let delta = update_row(c, &mut v, residual / diagonal, &response);
                if delta != 0.0 {
                    if soft {
                        total += delta;
                    }
                    largest = largest.max(delta.abs() * k);
                    last_changed = Some(i);
                    changed = true;
                }
            }
            if iteration == 0 {
                first = largest;
            }
            if last_changed <= first_row {
                break 'passes true;
            }
            if largest <= tolerance {
                break;
            }
        }
        false
    };
    if changed {
        v.store(bodies, body_a, body_b);
    }
    (converged, first, changed)
}

/// `K_ii` of row `c` with the support's response scaled: `linear` its bodies' linear terms
/// (inverse masses times their response along the normal), `angular` the factors on their
/// angular terms.
#[inline]
pub(super) fn held_diagonal(c: &ContactConstraint, linear: [f32; 2], angular: [f32; 2]) -> f32 {
    if c.angular {
        row_inverse_mass(
            linear,
            [
                angular[0] * c.rn_a.dot(c.ang_a),
                angular[1] * c.rn_b.dot(c.ang_b),
            ],
        )
    } else {
        linear[0] + linear[1]
    }
}

/// A row's part in its block's solve (see [`manifold_sweep`]), from its separation `s` now:
/// `(bias, soft)` with `bias = s/h` for a speculative row (`s > 0`, rigid), else the soft
/// push-out `max(bias_rate s, -cap)` (soft where the spring has any softness), or 0 in the rigid
/// relax pass. `None` when it takes no part: no effective mass, or a speculative row approaching
/// faster than [`ManifoldSolve::leave_impacts`].
#[inline]
pub(super) fn block_row(
    c: &ContactConstraint,
    bodies: &[SolverBody],
    solve: &ManifoldSolve,
) -> BlockRow {
    if c.normal_mass == 0.0 {
        return None;
    }
    let s = c.current_separation(bodies);
    if solve
        .leave_impacts
        .is_some_and(|t| s > 0.0 && c.normal_velocity(bodies) < -t)
    {
        return None;
    }
    Some(if s > 0.0 {
        (s * solve.inv_h, false)
    } else if let Some(soft) = solve.soft {
        (
            (soft.bias_rate * s).max(-solve.max_push_out),
            soft.impulse_scale > 0.0,
        )
    } else {
        (0.0, false)
    })
}

/// One Gauss-Seidel update of a block's row: its accumulated impulse less `step` (the residual
/// over the diagonal), clamped at zero, the change applied to the bodies through `response`
/// and the largest impulse recorded. Returns the change.
#[inline]
pub(super) fn update_row(
    c: &mut ContactConstraint,
    v: &mut PairVelocities,
    step: f32,
    response: &Response,
) -> f32 {
    let new = (c.normal_impulse - step).max(0.0);
    let delta = new - c.normal_impulse;
    if delta != 0.0 {
        c.normal_impulse = new;
        apply_response(c, v, delta, response);
    }
    c.max_normal_impulse = c.max_normal_impulse.max(new);
    delta
}
