//! One impact event: its rows at the time of impact, their targets, the block solve (exact
//! or Gauss-Seidel), friction in rounds, and the displacement owed for the part of the step
//! before the event.

use std::ops::Range;

use bevy::math::Vec3;

use super::super::body::SolverBody;
use super::super::contact::ContactConstraint;
use super::super::lcp::{self, DenseSolve};
use super::Propagation;
use super::timing::*;
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

/// An event whose rows have friction is solved in at most this many rounds: the normal block,
/// then each body pair whose rows pushed in the round stops its tangential slip at the centre
/// of its normal impulses, within the Coulomb disk of their sum (see [`manifold_centre`] and
/// [`ContactConstraint::apply_stick_impulse`]), and, if that set rows
/// approaching again (friction at one contact presses on the others through the bodies'
/// turning and through oblique normals), the block again from no impulse, with targets
/// `min(target, -max(v_n, 0))` at the velocities after the friction. The last round is the
/// normal block alone, so friction never ends an event with a row approaching.
///
/// Each application takes energy out or none: the friction by its own bound; a later block,
/// since a row that pushes ends at its target `v'` from a velocity `v` with `v + v' <=
/// min(v, 0) <= 0` (its energy change `sum lambda (v + v') / 2`, as for the first block). The
/// tangential impulses of the rounds sum to at most `mu` times the normal ones (each round
/// stays within its own disk), so the event stays within Coulomb's cone. Why in the event:
/// friction applied once after the block, the approaches it left became new impacts of the
/// pass, a sweep each, and the mixed pour (friction 0.5, ratios to 100:1) hit the bound of 64
/// sweeps at step 48; without friction in the event at all, a light body was squeezed out
/// sideways between two heavy ones at 13.2 m/s (its free-fall bound 12.3 m/s), which Coulomb
/// friction at its contacts resists.
///
/// Which events: under the hybrid method ([`Propagation::join_touching`]) the inelastic ones,
/// all their rows (the touching rows being holds inside an impact). An inelastic event takes in
/// the touching rows of its bodies, so what its friction sets approaching nearby is solved in
/// its own rounds; an event with restitution does not, and there friction at one contact set
/// the bodies' other contacts approaching as new events, whose friction set the first one
/// approaching again: random world 2006 of the energy test (restitutions 0.7-1, spins to
/// 18 rad/s) hit the bound of 64 sweeps at steps 6, 10 and 11, and the held supports of the
/// resting phase then shot a 0.1 kg box out at 1,243 m/s (4.4 times the world's energy).
///
/// Which rows: under the propagation method (every event), whose pass is also its resting
/// solve, only rows that did not touch at the step's start. There a resting contact is an
/// impact every step, one body pair at a time, and friction at it couples a stack into one
/// column that rocks on its base, the tilt growing 2-fold in 3 steps (two 1 mm dice at
/// 60 Hz, 1 m dice under 1000 g by scaling: they toppled into each other at 30, 60 and
/// 120 Hz, and so did two and three 1 cm dice at 30 Hz); that is, propagation's resting
/// contacts stay frictionless, as before.
pub(super) const EVENT_FRICTION_ROUNDS: u32 = 4;

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
    /// Scratch for a pass over `bodies` bodies.
    pub(super) fn new(bodies: usize) -> Self {
        EventScratch {
            slot: vec![u32::MAX; bodies],
            ..EventScratch::default()
        }
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
/// Each closing row's target is `-e v_n - (1 + e) g_n t` (see [`propagate`]), with `v_n` taken
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
            let row = at_time(start, bodies, toi);
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
    for round_count in 1..=EVENT_FRICTION_ROUNDS {
        solve_block(rows, state, targets, round, bodies, dense, params);
        for (entry, &j) in state.iter_mut().zip(round.iter()) {
            entry.2 += j;
        }
        // The last round ends with the normal block: friction never leaves a row approaching.
        if round_count == EVENT_FRICTION_ROUNDS {
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

/// Friction in a round of an event (see [`EVENT_FRICTION_ROUNDS`]): one stick impulse a body
/// pair, at the centre of the pair's normal impulses `round`, within the Coulomb disk of their
/// sum (see [`manifold_centre`]), in the pairs' order (an event's rows of one pair are one
/// group under the hybrid method, a group each under propagation). Which events and rows take
/// part: see [`EVENT_FRICTION_ROUNDS`]. Returns whether any pair took friction.
fn apply_friction(
    rows: &[ContactConstraint],
    round: &[f32],
    state: &[(usize, f32, f32)],
    pairs: &mut Vec<(usize, usize, usize)>,
    contacts: &[ContactConstraint],
    bodies: &mut [SolverBody],
    params: &Propagation,
) -> bool {
    pairs.clear();
    // Under the hybrid method, only an inelastic event (see [`EVENT_FRICTION_ROUNDS`]).
    if params.join_touching && rows.iter().any(|row| row.restitution != 0.0) {
        return false;
    }
    pairs.extend(
        rows.iter()
            .zip(round.iter())
            .enumerate()
            .filter(|(i, (row, j))| {
                **j > 0.0
                    && row.friction > 0.0
                    && (params.join_touching || !touches(&contacts[state[*i].0], params.touch))
            })
            .map(|(i, (row, _))| (row.body_a, row.body_b, i)),
    );
    pairs.sort_unstable();
    let mut slipping = false;
    for pair in pairs.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
        let pair = pair.iter().map(|&(_, _, i)| (&rows[i], round[i]));
        if let Some((centre, load)) = manifold_centre(pair, bodies) {
            centre.apply_stick_impulse(bodies, centre.friction * load);
            slipping = true;
        }
    }
    slipping
}

/// After friction in a round, the next round holds what friction set approaching, at targets
/// that can only take energy out: `min(target, -max(v_n, 0))` (see [`EVENT_FRICTION_ROUNDS`]),
/// in `state` (f32) and `targets` (f64). Returns whether any row approaches below its target
/// by more than the velocity tolerance.
fn retarget(
    rows: &[ContactConstraint],
    state: &mut [(usize, f32, f32)],
    targets: &mut [f64],
    bodies: &[SolverBody],
    params: &Propagation,
) -> bool {
    let mut approaching = false;
    for ((row, entry), exact) in rows.iter().zip(state.iter_mut()).zip(targets.iter_mut()) {
        if entry.1.is_nan() {
            continue;
        }
        let vn = row.normal_velocity(bodies);
        entry.1 = entry.1.min(-vn.max(0.0));
        *exact = exact.min(-lcp::normal_velocity(row, bodies).max(0.0));
        approaching |= vn < entry.1 - params.velocity_tolerance;
    }
    approaching
}

/// The friction row of one body pair's rows in an event (with the round's normal impulses):
/// the row that pushed hardest, moved to the centre of the normal impulses (their
/// impulse-weighted mean anchor on each body), with its tangent rows prepared there, and the
/// round's total normal impulse, its Coulomb load; `None` if the pair has no friction or did
/// not push.
///
/// Why the centre and not each point: a manifold's normal impulses are not unique (four
/// corners on a face hold a body with any of many splits; the exact solve returns one at a
/// vertex, two corners), but their resultant and its line of action are (they stop the same
/// body velocities). Friction limited corner by corner by such a split pushes unevenly and
/// turns the body: a 1 mm die resting on another at 30 Hz (friction 0.5) tilted from f32
/// rounding, 2-fold a step, until one corner took a step's fall alone (243 rad/s) and the
/// pair fell apart. At the centre, the load and its point are the resultant's.
pub(super) fn manifold_centre<'a>(
    pair: impl Iterator<Item = (&'a ContactConstraint, f32)> + Clone,
    bodies: &[SolverBody],
) -> Option<(ContactConstraint, f32)> {
    let (hardest, most) = pair.clone().max_by(|x, y| x.1.total_cmp(&y.1))?;
    if most.is_nan() || most <= 0.0 || hardest.friction.is_nan() || hardest.friction <= 0.0 {
        return None;
    }
    let (mut load, mut anchor_a, mut anchor_b) = (0.0, Vec3::ZERO, Vec3::ZERO);
    for (row, j) in pair.filter(|&(_, j)| j > 0.0) {
        load += j;
        anchor_a += j * row.anchor_a;
        anchor_b += j * row.anchor_b;
    }
    let mut centre = *hardest;
    centre.anchor_a = anchor_a / load;
    centre.anchor_b = anchor_b / load;
    centre.prepare_tangent_rows(&bodies[centre.body_a], &bodies[centre.body_b]);
    Some((centre, load))
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
    impulses.clear();
    impulses.resize(rows.len(), 0.0);
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
