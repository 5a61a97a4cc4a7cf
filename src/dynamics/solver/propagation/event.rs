//! One impact event: its rows at the time of impact, their targets, the block solve (exact
//! or Gauss-Seidel), friction in rounds, and the displacement owed for the part of the step
//! before the event.

use std::ops::Range;

use bevy::math::Vec3;

use super::super::body::SolverBody;
use super::super::contact::ContactConstraint;
use super::super::lcp::{self, DenseSolve};
use super::Propagation;
use super::friction::{EVENT_FRICTION_ROUNDS, apply_friction, retarget};
use super::timing::*;
use crate::dynamics::solver::refill;
use crate::impulse::row_impulse;

/// An inelastic impact event (every contact of its groups `e = 0`) takes in the touching
/// inelastic groups (see [`joins`]) of its bodies, and theirs in turn, nearest first, until it
/// has this many rows (with [`Propagation::join_touching`]); up to [`DENSE_ROWS`] rows it is
/// solved exactly ([`lcp`]).
///
/// Why: a touching contact with `e = 0` holds, whether it is struck or pressed. Left out of the
/// event, a heavy body landing on a light one on the floor stopped only the pair: both then
/// moved down at `M / (M + m)` of the approach, the light body's floor contact stopped it in its
/// own event, the heavy one struck it again, and so on, a factor `M / (M + m)` a sweep (the
/// mixed pour's landings, ratios to 100:1, hit the bound of 64 sweeps). With the floor contact
/// in the event, both stop at once. Only inelastic events and contacts: with restitution, the
/// order of the impacts is the physics (Newton's cradle; a ball dropped on a box resting on the
/// ground gives the box its momentum, which the ground then takes, and does not rebound as from
/// the ground), which is what propagation resolves. 64 rows: 16 box manifolds; the events'
/// cost grows with the cube of the rows that push (a 4,000-sphere pour's landings cost 1.4 times
/// the bound-limited sweeps with 64, 1.7 times with 128).
pub(super) const JOINED_ROWS: usize = 64;

/// Events of at most this many solving rows are solved exactly ([`lcp`]); larger ones (many
/// simultaneous impacts) by Gauss-Seidel on the block.
pub(super) const DENSE_ROWS: usize = 256;

/// Buffers of [`resolve_event`], kept across events of a pass.
#[derive(Default)]
pub(super) struct EventScratch {
    /// Copies of the event's rows, anchors moved to the time of impact.
    rows: Vec<ContactConstraint>,
    /// Per row: its index in the contact slice, its restitution target (NaN: not closing, it
    /// takes no part) and its accumulated impulse of this resolution.
    state: Vec<(usize, f32, f32)>,
    /// Velocities of the event's bodies before it: `(body, v, w)`.
    pub(super) before: Vec<(usize, Vec3, Vec3)>,
    /// Per body, its index in `before`, or `u32::MAX`.
    slot: Vec<u32>,
    /// The exact solve of the block.
    dense: DenseSolve,
    /// Per row, its target in f64 (NaN: it takes no part).
    targets: Vec<f64>,
    /// Per row, its impulse in the block solve of the current round (see
    /// [`EVENT_FRICTION_ROUNDS`]).
    round: Vec<f32>,
    /// The rows that pushed in a round, as (body a, body b, row), sorted by pair.
    pairs: Vec<(usize, usize, usize)>,
}

impl EventScratch {
    /// Ready for a pass over `bodies` bodies (the buffers' memory kept).
    pub(super) fn reset(&mut self, bodies: usize) {
        // `before` names the last pass's bodies, whose slots the next event would clear.
        self.before.clear();
        refill(&mut self.slot, bodies, u32::MAX);
    }

    /// The last event changed the velocities of `body`, one of its bodies.
    pub(super) fn changed(&self, body: usize, bodies: &[SolverBody]) -> bool {
        let (_, v, w) = self.before[self.slot[body] as usize];
        bodies[body].linear_velocity != v || bodies[body].angular_velocity != w
    }
}

/// Resolves one impact event: the rows of `event`'s groups, solved together as one block at
/// time `toi` into the step.
///
/// Each row's anchors are moved to where its two bodies meet at `toi`: each body's material
/// point has moved by its velocity times `t`, and the two surface points meet at one common
/// point, so that the equal and opposite impulses act at the same place (with anchors from the
/// start of the step they would act at two points `t (u_B - u_A)` apart, a spurious torque).
/// The common point is the mean of the two material points weighted by inverse mass,
/// `(w_A u_A + w_B u_B) t` from the start, `w = (1/m) / (1/m_A + 1/m_B)`: the midpoint for equal masses,
/// and the moving body's own point against a fixed one. The latter matters: a wall's closest
/// point at the start of the step is not the point that gets hit, and a ball sliding along the
/// wall as it closes in (a fast ball falling under gravity) would otherwise be struck off its
/// line of centres and set spinning (at 100 m/s, 0.1 s of gravity, that cost 10% of the normal
/// impulse).
///
/// Each closing row's target is `-e v_n - (1 + e) g_n t` (see [`propagate`](super::propagate)), with `v_n` taken
/// before the event, and the accumulated impulses (clamped at >= 0) are the exact solution of
/// the event's block ([`lcp`]), or beyond [`DENSE_ROWS`] rows (or should that solve fail)
/// found by Gauss-Seidel on it; a single row is solved in one pass, `j = -(1+e) v_n / K`. The
/// exact block solution never adds energy: with `v'_i = -e v_i` on every row that pushes and
/// `lambda_i = 0` on the others, the energy change `sum lambda_i (v_i + v'_i) / 2 =
/// sum lambda_i (1 - e) v_i / 2` is at most 0, since `v_i < 0`. A joined touching row (see
/// [`JOINED_ROWS`]) has the target `-max(v_n, 0) - max(s, 0) / (dt - t)`: it may not approach,
/// or if it separated, not faster than it separated, or if it is apart by `s` (within the
/// touch distance), not faster than closes the gap by the end of the step; its term
/// `lambda_i (v_i + v'_i) / 2` is then at most `lambda_i min(v_i, 0) / 2 <= 0` as well.
///
/// When the velocities already include the step's gravity (`params.integrated_gravity`, the
/// propagation method), only the approach the row had when it met is bounced: with `g_n` the
/// pair's relative gravity along the normal (pulling them together, `g_n < 0`), the row met at
/// `v_n - g_n (dt - t)` and gravity then acts on for `dt - t`, so the target is
/// `-e (v_n - g_n (dt - t)) + g_n (dt - t)`, and never below 0: a row whose bounce gravity
/// would undo within the step rests. (Without integrated gravity the target is `-e v_n` as it
/// always was, bit for bit: `v_n`, taken at the anchors moved to the time of impact, may be
/// positive there, and the hybrid method's impacts are left exactly as they were.) A resting contact, whose whole approach is the step's
/// `g dt`, is then inelastic whatever its restitution. (Bouncing `v_n` itself bounced the
/// step's gravity too: an e = 1 box resting on the ground hopped 3 cm, and in the energy
/// property test a 4 g capsule gained 5-20% of its energy per bounce, seed 111.) A pull apart
/// (`g_n > 0`) is left out of the target, which can only lower it.
///
/// Long (about 140 lines) on purpose: most of it is the one loop that builds each row and its
/// target (joined, closing or idle, in f32 and f64), whose cases share the row's start-of-step
/// values; the rounds and the friction are their own functions ([`solve_block`],
/// [`apply_friction`], [`retarget`]).
#[allow(clippy::too_many_arguments)]
pub(super) fn resolve_event(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    groups: &[Range<usize>],
    event: &[usize],
    met: &[bool],
    joined: &[bool],
    spent: &[bool],
    inelastic: bool,
    toi: f32,
    params: &Propagation,
    scratch: &mut EventScratch,
) {
    let EventScratch {
        rows,
        state,
        before,
        slot,
        dense,
        targets,
        round,
        pairs,
    } = scratch;
    rows.clear();
    state.clear();
    for &(i, _, _) in before.iter() {
        slot[i] = u32::MAX;
    }
    before.clear();
    targets.clear();
    for &g in event {
        let range = groups[g].clone();
        let first = &contacts[range.start];
        let (ia, ib) = (first.body_a, first.body_b);
        for i in [ia, ib] {
            if slot[i] == u32::MAX {
                slot[i] = before.len() as u32;
                before.push((i, bodies[i].linear_velocity, bodies[i].angular_velocity));
            }
        }
        let gn = pass_gravity(first, bodies, params);
        let integrated = relative_gravity(
            first,
            bodies,
            params.integrated_gravity,
            params.accelerations_integrated,
        );
        for index in range {
            let start = &contacts[index];
            if joined[g] {
                // A touching inelastic row: it may not approach after the event, or if it
                // separated, not faster than it separated (so that it never adds energy).
                let row = at_time(start, bodies, toi);
                let (target, exact) = if touches(start, params.touch) {
                    let vn = lcp::normal_velocity(&row, bodies);
                    let rest = (params.dt - toi) as f64;
                    let gap = if start.total_impulse > 0.0 || rest <= 0.0 {
                        0.0
                    } else {
                        start.separation.max(0.0) as f64 / rest
                    };
                    let t = -(vn.max(0.0)) - gap;
                    (t as f32, t)
                } else {
                    (f32::NAN, f64::NAN)
                };
                rows.push(row);
                state.push((index, target, 0.0));
                targets.push(exact);
                continue;
            }
            let vn = start.normal_velocity(bodies);
            let closing = start.normal_mass > 0.0
                && vn < 0.0
                && closes_within(gap(start, met[g]), vn, gn, params);
            let mut row = at_time(start, bodies, toi);
            // A group that has spent its bounce in this pass is inelastic (see `struck_again`).
            if spent[g] {
                row.restitution = 0.0;
            }
            // The target in f64 for the exact solve (the same formula).
            targets.push(if closing {
                let vn = lcp::normal_velocity(&row, bodies);
                let (e, toi, gn) = (row.restitution as f64, toi as f64, gn as f64);
                let after = integrated.min(0.0) as f64 * (params.dt as f64 - toi);
                let bounce = if after < 0.0 {
                    (-e * (vn - after).min(0.0) + after).max(0.0)
                } else {
                    -e * vn
                };
                bounce - (1.0 + e) * gn * toi
            } else {
                f64::NAN
            });
            // Points that are not closing within the step take no part (NaN marks them).
            let target = if closing {
                let vn = row.normal_velocity(bodies);
                let after = integrated.min(0.0) * (params.dt - toi);
                let bounce = if after < 0.0 {
                    (-row.restitution * (vn - after).min(0.0) + after).max(0.0)
                } else {
                    -row.restitution * vn
                };
                bounce - (1.0 + row.restitution) * gn * toi
            } else {
                f32::NAN
            };
            rows.push(row);
            state.push((index, target, 0.0));
        }
    }

    // The block's impulses (see `solve_block`); then, where rows have friction, rounds of
    // friction and normal holds (see `EVENT_FRICTION_ROUNDS`).
    // Under the hybrid method only an inelastic event takes friction: the others are solved
    // in one round (see `EVENT_FRICTION_ROUNDS`).
    let rounds = if inelastic || !params.join_touching {
        EVENT_FRICTION_ROUNDS
    } else {
        1
    };
    for round_count in 1..=rounds {
        solve_block(rows, state, targets, round, bodies, dense, params);
        for (entry, &j) in state.iter_mut().zip(round.iter()) {
            entry.2 += j;
        }
        // The last round ends with the normal block: friction never leaves a row approaching.
        if round_count == rounds {
            break;
        }
        if !apply_friction(rows, round, state, pairs, contacts, bodies, params)
            || !retarget(rows, state, targets, bodies, params)
        {
            break;
        }
    }
    let mut joined_rows = event
        .iter()
        .flat_map(|&g| groups[g].clone().map(move |_| joined[g]));
    for &(index, _, accumulated) in state.iter() {
        let joined = joined_rows.next().expect("a flag a row");
        if accumulated > 0.0 {
            let c = &mut contacts[index];
            c.total_impulse += accumulated;
            // A touching row that only held is not an impact.
            c.impact |= !joined;
        }
    }
    for &(i, v, w) in before.iter() {
        owe_offset(&mut bodies[i], v, w, toi);
    }
}

/// Solves the normal rows of an event's block towards their targets (`state`'s, and `targets`
/// in f64 for the exact solve; NaN: the row takes no part), from no impulse: the exact
/// solution of the block ([`lcp`]) up to [`DENSE_ROWS`] rows, or Gauss-Seidel on it (should
/// the exact solve fail, or beyond), where a single row is solved in one pass,
/// `j = (target - v_n) / K`. Applies the impulses (clamped >= 0) and leaves them in `impulses`,
/// one a row.
pub(super) fn solve_block(
    rows: &[ContactConstraint],
    state: &[(usize, f32, f32)],
    targets: &[f64],
    impulses: &mut Vec<f32>,
    bodies: &mut [SolverBody],
    dense: &mut DenseSolve,
    params: &Propagation,
) {
    refill(impulses, rows.len(), 0.0);
    let solving = state.iter().filter(|(_, t, _)| !t.is_nan()).count();
    let mut iterations = if solving == 1 {
        1
    } else {
        params.max_block_iterations.max(1)
    };
    if solving > 1 && solving <= DENSE_ROWS {
        dense.clear();
        for (row, &target) in rows.iter().zip(targets.iter()) {
            if !target.is_nan() {
                dense.push(row, bodies, target);
            }
        }
        if let Some(solved) = dense.solve() {
            let mut solved = solved.iter();
            for ((row, &target), accumulated) in
                rows.iter().zip(targets.iter()).zip(impulses.iter_mut())
            {
                if target.is_nan() {
                    continue;
                }
                let j = *solved.next().expect("one impulse a solving row") as f32;
                if j > 0.0 {
                    *accumulated = j;
                    row.apply_normal_impulse(bodies, j);
                }
            }
            iterations = 0;
        }
    }
    for _ in 0..iterations {
        let mut largest_change = 0.0f32;
        for ((c, (_, target, _)), accumulated) in
            rows.iter().zip(state.iter()).zip(impulses.iter_mut())
        {
            if target.is_nan() {
                continue;
            }
            let vn = c.normal_velocity(bodies);
            let new = (*accumulated + row_impulse(c.normal_mass, vn, *target)).max(0.0);
            let delta = new - *accumulated;
            if delta != 0.0 {
                *accumulated = new;
                c.apply_normal_impulse(bodies, delta);
                largest_change = largest_change.max(delta.abs() / c.normal_mass);
            }
        }
        if largest_change <= params.velocity_tolerance {
            break;
        }
    }
}

/// Records that `body` moved at `(v, w)` until `toi` and at its current velocity after.
pub(super) fn owe_offset(body: &mut SolverBody, v: Vec3, w: Vec3, toi: f32) {
    if body.inverse_mass == 0.0 && body.inverse_inertia == bevy::math::Mat3::ZERO {
        return;
    }
    body.impact_offset -= (body.linear_velocity - v) * toi;
    body.impact_rotation -= (body.angular_velocity - w) * toi;
    body.impact_time = toi;
}
