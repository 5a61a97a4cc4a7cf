//! Friction in an impact event: the rounds, the stick impulse of each body pair at the
//! centre of its normal impulses, and the targets of the round after.

use bevy::math::Vec3;

use super::super::body::SolverBody;
use super::super::contact::ContactConstraint;
use super::super::lcp;
use super::Propagation;
use super::timing::touches;

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

/// Friction in a round of an event (see [`EVENT_FRICTION_ROUNDS`]): one stick impulse a body
/// pair, at the centre of the pair's normal impulses `round`, within the Coulomb disk of their
/// sum (see [`manifold_centre`]), in the pairs' order (an event's rows of one pair are one
/// group under the hybrid method, a group each under propagation). Which events and rows take
/// part: see [`EVENT_FRICTION_ROUNDS`]. Returns whether any pair took friction.
pub(super) fn apply_friction(
    rows: &[ContactConstraint],
    round: &[f32],
    state: &[(usize, f32, f32)],
    pairs: &mut Vec<(usize, usize, usize)>,
    contacts: &[ContactConstraint],
    bodies: &mut [SolverBody],
    params: &Propagation,
) -> bool {
    pairs.clear();
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
        let (centre, load) = manifold_centre(pair, bodies);
        centre.apply_stick_impulse(bodies, centre.friction * load);
        slipping = true;
    }
    slipping
}

/// After friction in a round, the next round holds what friction set approaching, at targets
/// that can only take energy out: `min(target, -max(v_n, 0))` (see [`EVENT_FRICTION_ROUNDS`]),
/// in `state` (f32) and `targets` (f64). Returns whether any row approaches below its target
/// by more than the velocity tolerance.
pub(super) fn retarget(
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
/// round's total normal impulse, its Coulomb load. The rows all pushed (`j > 0`) and have
/// friction, and there is at least one ([`apply_friction`] passes only those).
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
) -> (ContactConstraint, f32) {
    let (hardest, _) = pair
        .clone()
        .max_by(|x, y| x.1.total_cmp(&y.1))
        .expect("a pair's rows in the event");
    let (mut load, mut anchor_a, mut anchor_b) = (0.0, Vec3::ZERO, Vec3::ZERO);
    for (row, j) in pair {
        load += j;
        anchor_a += j * row.anchor_a;
        anchor_b += j * row.anchor_b;
    }
    let mut centre = *hardest;
    centre.anchor_a = anchor_a / load;
    centre.anchor_b = anchor_b / load;
    centre.prepare_tangent_rows(&bodies[centre.body_a], &bodies[centre.body_b]);
    (centre, load)
}
