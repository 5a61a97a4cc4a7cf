//! Jacobi ([`SolverMethod::Jacobi`](super::SolverMethod::Jacobi)): every row computed from the
//! velocities of the sweep's start, with mass splitting, so the order of the rows does not
//! matter.

use super::body::{Motion, SolverBody};
use super::contact::{ContactConstraint, solve_friction};
use super::iterative::Sweep;
use super::ledger::{NO_LEDGER, RestitutionLedger};
use super::sequential_impulses::{Arrival, RigidRows, ledger_bounce, ledger_velocity};
use crate::dynamics::solver::refill;
use crate::impulse::row_inverse_mass;

/// How many contacts touch each body (for Jacobi mass splitting), into `counts`.
pub(super) fn contact_counts(bodies: usize, contacts: &[ContactConstraint], counts: &mut Vec<u32>) {
    refill(counts, bodies, 0);
    for c in contacts {
        counts[c.body_a] += 1;
        counts[c.body_b] += 1;
    }
}

/// One Jacobi sweep: every row computes its impulse from the same velocities, then all are
/// applied together. With `split`, each body's inverse mass and inertia are scaled by the
/// number of rows that touch it when computing a row's effective mass (mass splitting), which
/// makes the sweep a convergent averaging instead of an overshooting sum.
///
/// `counts` holds how many rows touch each body (see `contact_counts`). The sweep has converged
/// exactly when no body that a changed row touches is touched by any other row: each changed
/// row was then solved alone with its full effective mass (a split count of 1).
///
/// `deltas` is scratch space; `ledger` records the rows' work and limits their bounces (see
/// [`RestitutionLedger::record_shared`]).
#[allow(clippy::too_many_arguments)]
pub fn jacobi_sweep(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    rows: &RigidRows,
    arrivals: &[Arrival],
    counts: &[u32],
    split: bool,
    deltas: &mut Vec<(f32, f32)>,
    ledger: &mut RestitutionLedger,
) -> Sweep {
    deltas.clear();
    for (c, arrival) in contacts.iter_mut().zip(arrivals) {
        if c.normal_mass == 0.0 {
            deltas.push((0.0, 0.0));
            continue;
        }
        let vn = c.normal_velocity(bodies);
        let target = rows.target(c, bodies, ledger_bounce(c, arrival, ledger, vn));
        let mass = if split {
            split_mass(c, bodies, counts)
        } else {
            c.normal_mass
        };
        let new = (c.normal_impulse + mass * (target - vn)).max(0.0);
        deltas.push((new - c.normal_impulse, vn));
        c.normal_impulse = new;
        c.max_normal_impulse = c.max_normal_impulse.max(new);
    }
    let mut largest = 0.0f32;
    let mut settled = true;
    for (c, &(delta, _)) in contacts.iter().zip(deltas.iter()) {
        if delta != 0.0 {
            c.apply_normal_impulse(bodies, delta);
            largest = largest.max(delta.abs() / c.normal_mass);
            let shared = |i: usize| bodies[i].motion == Motion::Dynamic && counts[i] > 1;
            settled &= !shared(c.body_a) && !shared(c.body_b);
        }
    }
    for ((c, &(delta, vn)), arrival) in contacts.iter().zip(deltas.iter()).zip(arrivals) {
        if delta != 0.0 && c.ledger != NO_LEDGER {
            ledger.record_shared(
                c,
                delta,
                ledger_velocity(arrival, vn),
                ledger_velocity(arrival, c.normal_velocity(bodies)),
            );
        }
    }
    for c in contacts.iter_mut().filter(|c| c.friction > 0.0) {
        settled &= !solve_friction(bodies, c);
    }
    Sweep { largest, settled }
}

/// Effective mass of a row with each body's share split `count` ways.
pub(super) fn split_mass(c: &ContactConstraint, bodies: &[SolverBody], counts: &[u32]) -> f32 {
    let (na, nb) = (
        counts[c.body_a].max(1) as f32,
        counts[c.body_b].max(1) as f32,
    );
    let (a, b) = (&bodies[c.body_a], &bodies[c.body_b]);
    let linear = [na * a.inverse_mass, nb * b.inverse_mass];
    let k = if c.angular {
        row_inverse_mass(linear, [na * c.rn_a.dot(c.ang_a), nb * c.rn_b.dot(c.ang_b)])
    } else {
        linear[0] + linear[1]
    };
    if k > 0.0 { 1.0 / k } else { 0.0 }
}
