//! The hybrid method (the default, [`SolverMethod::Hybrid`](super::SolverMethod::Hybrid)): an
//! impact phase ([`propagate`], impacts in time order, each
//! manifold a block), then a soft resting phase in which each manifold is solved as a block, in
//! shock order (supports before what they support), with the supports held only as far as
//! they really are held and each manifold as stiff as the load it carries.

use std::ops::Range;

use bevy::prelude::*;

use super::body::{Motion, PairVelocities, SolverBody};
use super::contact::{ContactConstraint, solve_friction_scaled_in};
use super::iterative::{Settling, Sweep};
use super::propagation::{PropagationScratch, propagate_with};
use super::soft_step::{Resting, SoftScratch, Softness, soft_substeps};
use super::{FrictionModel, SolverConfig, SolverStats, propagation_params};
use crate::impulse::{apply_row_impulse, row_inverse_mass};

mod block;
mod delassus;
mod loads;
mod manifold_friction;
mod order;
mod row;
mod support;
mod sweep;
#[cfg(test)]
mod tests;
mod transmit;

pub use block::*;
use delassus::*;
use loads::*;
pub use manifold_friction::*;
use order::*;
use row::*;
use support::*;
pub use sweep::*;
pub use transmit::*;

/// The resting phase's buffers, kept from step to step (in [`SolverScratch`](super::SolverScratch)):
/// their contents are rebuilt every step; only their memory is reused.
#[derive(Clone, Debug, Default)]
pub struct HybridScratch {
    /// The blocks in shock order.
    blocks: Vec<Block>,
    /// The contacts in block order.
    ordered: Vec<ContactConstraint>,
    /// Each block's range in the step's contacts.
    origin: Vec<Range<usize>>,
    /// The soft substeps' buffers.
    soft: SoftScratch,
    /// The shock order's buffers.
    order: OrderScratch,
    /// The impact phase's buffers.
    impacts: PropagationScratch,
}

/// The hybrid method's solve of one step (see [`super::step`]): the impact phase, then the
/// resting phase over the manifolds as blocks in shock order (or only gravity and integration
/// when no contact can take an impulse).
#[allow(clippy::too_many_arguments)]
pub(super) fn solve(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    manifolds: &[Range<usize>],
    config: &SolverConfig,
    gravity: Vec3,
    dt: f32,
    stats: &mut SolverStats,
    scratch: &mut HybridScratch,
) {
    let report = propagate_with(
        bodies,
        contacts,
        manifolds,
        &propagation_params(
            config,
            config.restitution_threshold,
            gravity,
            false,
            true,
            dt,
        ),
        &mut scratch.impacts,
    );
    stats.propagation_sweeps = report.sweeps;
    stats.propagation_bound_hit = report.bound_hit;
    // The resting phase keeps no restitution ledger (its impacts are the impact phase's).
    scratch.soft.close_ledger();
    if resting_phase_idle(bodies, contacts, config, gravity, dt) {
        soft_substeps(
            bodies,
            contacts,
            Resting::Idle,
            &mut scratch.soft,
            config,
            gravity,
            dt,
            stats,
        );
    } else {
        let HybridScratch {
            blocks,
            ordered,
            origin,
            soft,
            order,
            impacts: _,
        } = scratch;
        shock_order(
            blocks,
            bodies,
            contacts,
            manifolds,
            config.linear_slop,
            order,
        );
        // The sweeps visit the blocks in shock order: lay the contacts out in that order, so
        // that they read them in sequence rather than all over the slice.
        in_block_order(contacts, blocks, ordered, origin);
        soft_substeps(
            bodies,
            ordered,
            Resting::Manifolds(blocks),
            soft,
            config,
            gravity,
            dt,
            stats,
        );
        from_block_order(bodies, contacts, ordered, blocks, origin);
    }
}

/// True when, after the impact phase, no contact can take any impulse in the hybrid method's
/// resting phase, which can then be skipped: so an island of one impact and no resting contact
/// costs one propagation pass and nothing else.
///
/// A row of the resting phase pushes only while `v_n + bias < 0`, and its bias is at least
/// `-max_push_out_speed` (a speculative row's `s/h` is positive). Between substeps only gravity
/// (with the bodies' extra accelerations, [`SolverBody::acceleration`]) changes `v_n`, by at
/// least `min(g_n, 0) dt` over the step. So a contact with no accumulated
/// impulse to warm-start and `v_n + min(g_n, 0) dt >= max_push_out_speed` stays inactive, and
/// if every contact does, no impulse is applied at all.
pub(super) fn resting_phase_idle(
    bodies: &[SolverBody],
    contacts: &[ContactConstraint],
    config: &SolverConfig,
    gravity: Vec3,
    dt: f32,
) -> bool {
    contacts.iter().all(|c| {
        if c.normal_mass == 0.0 {
            return true;
        }
        // Each body's gravity with its extra acceleration, which can pull a contact apart
        // (a body with `GravityScale(0.0)` on the floor) or press it together harder.
        let g = |i: usize| bodies[i].acceleration(gravity);
        let gn = (g(c.body_b) - g(c.body_a)).dot(c.normal);
        c.normal_impulse == 0.0
            && c.normal_velocity(bodies) + gn.min(0.0) * dt >= config.max_push_out_speed
    })
}
