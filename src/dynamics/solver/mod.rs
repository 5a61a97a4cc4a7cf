//! The contact solver: plain functions over packed solver bodies and contact constraints.
//!
//! [`step`] is the whole solve of one fixed step, whichever [`SolverMethod`] is chosen. Its
//! stages, in order:
//!
//! 1. [`prepare_contacts`]: anchors, effective masses, approach velocities.
//! 2. The method's velocity solve, interleaved with [`integrate_velocities`] (gravity, with
//!    each body's [`extra_acceleration`](SolverBody::extra_acceleration)) and
//!    [`integrate_positions`]: see [`SolverMethod`] for each method's order of stages.
//! 3. The accumulated impulses stay in the contacts, for warm starting the next step.
//!
//! One file a method: [`hybrid`] (the default), [`propagation`], [`soft_step`],
//! [`sequential_impulses`] and [`jacobi`]; the row maths they share is in [`contact`] and
//! [`body`], the Gauss-Seidel bookkeeping in [`iterative`], the settings in [`config`].

pub mod body;
pub mod config;
pub mod contact;
pub mod hybrid;
pub mod iterative;
pub mod jacobi;
mod lcp;
pub mod ledger;
pub mod propagation;
pub mod push_out;
mod rows;
pub mod sequential_impulses;
pub mod soft_step;

use std::ops::Range;

use bevy::prelude::*;

pub use body::{Motion, SolverBody, integrate_positions, integrate_velocities};
pub use config::{FrictionModel, ImpactMessages, SolverConfig, SolverMethod, SolverStats};
pub use contact::{ContactConstraint, prepare_contacts, refresh_inertia, warm_start};
use propagation::{Propagation, PropagationScratch, propagate_with};

/// Solves one step of length `dt` (s) over `bodies` and `contacts` under `gravity` (m/s^2),
/// with `manifolds` the ranges of `contacts` that belong to one body pair (contiguous), and
/// returns what it did. Bodies end the step moved and with their new velocities; contacts keep
/// their accumulated impulses for the next step.
///
/// # Examples
///
/// ```
/// use bevy::math::{BVec3, Mat3, Quat, Vec3};
/// use impact3d::dynamics::solver::*;
///
/// // A unit-mass ball resting on static ground, contact at the origin.
/// let mut bodies = [
///     SolverBody::new(Motion::Static, Vec3::new(0.0, -1.0, 0.0), Quat::IDENTITY),
///     SolverBody::new(Motion::Dynamic, Vec3::new(0.0, 0.5, 0.0), Quat::IDENTITY)
///         .with_mass(1.0, Mat3::from_diagonal(Vec3::splat(10.0)), true, BVec3::FALSE),
/// ];
/// let mut contacts = [ContactConstraint::new(0, 1, Vec3::ZERO, Vec3::Y, 0.0, 0.0, 0.0)];
/// let stats = step(&mut bodies, &mut contacts, &[0..1], &SolverConfig::default(),
///     Vec3::new(0.0, -9.81, 0.0), 1.0 / 60.0);
/// // The soft contact holds the ball up: it sinks far less than a millimetre.
/// assert!((bodies[1].position.y - 0.5).abs() < 1e-3);
/// assert_eq!(stats.contacts, 1);
/// ```
pub fn step(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    manifolds: &[Range<usize>],
    config: &SolverConfig,
    gravity: Vec3,
    dt: f32,
) -> SolverStats {
    step_with_scratch(
        bodies,
        contacts,
        manifolds,
        config,
        gravity,
        dt,
        &mut SolverScratch::default(),
    )
}

/// `buffer` as `len` copies of `value`: its earlier contents dropped, its memory kept (the
/// solver's buffers are refilled so at every step, so that a steady step allocates nothing).
pub(crate) fn refill<T: Clone>(buffer: &mut Vec<T>, len: usize, value: T) {
    buffer.clear();
    buffer.resize(len, value);
}

/// Memory the solve keeps from one step to the next (see [`step_with_scratch`]): only its
/// buffers' allocations carry over, never their contents.
#[derive(Clone, Debug, Default)]
pub struct SolverScratch {
    hybrid: hybrid::HybridScratch,
    soft: soft_step::SoftScratch,
    rigid: sequential_impulses::RigidScratch,
    push_out: push_out::PushOut,
    propagation: PropagationScratch,
    /// Each contact as a group of its own (the propagation method's groups).
    singles: Vec<Range<usize>>,
}

/// [`step`], with its buffers kept in `scratch` between calls: the same results, without
/// allocating them again every step (the hybrid method's copy of the contacts in block order
/// is as large as the contacts).
pub fn step_with_scratch(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    manifolds: &[Range<usize>],
    config: &SolverConfig,
    gravity: Vec3,
    dt: f32,
    scratch: &mut SolverScratch,
) -> SolverStats {
    let mut stats = SolverStats {
        bodies: bodies.len() as u32,
        contacts: contacts.len() as u32,
        ..default()
    };
    for body in bodies.iter_mut() {
        body.delta_position = Vec3::ZERO;
        body.delta_rotation = Quat::IDENTITY;
        body.impact_offset = Vec3::ZERO;
        body.impact_rotation = Vec3::ZERO;
        body.impact_time = 0.0;
        body.ballistic = body.motion == Motion::Dynamic;
    }
    for c in contacts.iter() {
        bodies[c.body_a].ballistic = false;
        bodies[c.body_b].ballistic = false;
    }
    if !config.warm_start {
        for c in contacts.iter_mut() {
            c.normal_impulse = 0.0;
            c.tangent_impulse = [0.0; 2];
            c.twist_impulse = 0.0;
        }
    } else if !(config.method == SolverMethod::Hybrid
        && config.friction_model == FrictionModel::Manifold)
    {
        // Only the manifold friction reads a twist (a model or method changed at run time).
        for c in contacts.iter_mut() {
            c.twist_impulse = 0.0;
        }
    }
    prepare_contacts(bodies, contacts);

    match config.method {
        SolverMethod::Hybrid => hybrid::solve(
            bodies,
            contacts,
            manifolds,
            config,
            gravity,
            dt,
            &mut stats,
            &mut scratch.hybrid,
        ),
        SolverMethod::SoftStep => soft_step::solve(
            bodies,
            contacts,
            config,
            gravity,
            dt,
            &mut stats,
            &mut scratch.soft,
        ),
        SolverMethod::Propagation => {
            integrate_velocities(bodies, gravity, dt);
            let singles = &mut scratch.singles;
            singles.clear();
            singles.extend((0..contacts.len()).map(|i| i..i + 1));
            let report = propagate_with(
                bodies,
                contacts,
                singles,
                &propagation_params(config, config.velocity_tolerance, gravity, true, false, dt),
                &mut scratch.propagation,
            );
            stats.propagation_sweeps = report.sweeps;
            stats.propagation_bound_hit = report.bound_hit;
            for c in contacts.iter_mut() {
                c.normal_impulse = c.total_impulse;
            }
            // Penetration is pushed out by split impulses, as under sequential impulses: the
            // propagation pass stops approach, not overlap, so whatever a step leaves (a pass
            // cut short at its bound, rounding) stayed, and under a pile it grew: a sphere at
            // the bottom of a 1,000-sphere pour sank 15 cm into the floor in 250 steps and
            // through it by step 1,041.
            let rows = sequential_impulses::RigidRows {
                inv_h: 1.0 / dt,
                baumgarte: config.baumgarte,
                slop: config.linear_slop,
                restitution_threshold: config.restitution_threshold,
                max_push_out: config.max_push_out_speed,
            };
            let push_out = &mut scratch.push_out;
            if push_out.solve(bodies, contacts, &rows, config.iterations, None) {
                push_out.displace(bodies, dt);
            }
            integrate_positions(bodies, gravity, dt);
        }
        SolverMethod::SequentialImpulses | SolverMethod::Jacobi => {
            sequential_impulses::rigid_substeps(
                bodies,
                contacts,
                config,
                gravity,
                dt,
                &mut stats,
                &mut scratch.rigid,
            );
        }
    }
    stats.impacts = contacts.iter().filter(|c| c.impact).count() as u32;
    stats
}

/// Substeps of this step: `config.substeps`, or more where a dynamic body in contact whose
/// inertia is not the same about every axis would turn more than
/// `config.max_turn_per_substep` in one (see there), at most `config.max_substeps`.
pub(crate) fn substeps(
    bodies: &[SolverBody],
    contacts: &[ContactConstraint],
    config: &SolverConfig,
    dt: f32,
) -> u32 {
    let n = config.substeps.max(1);
    // The turn over the step: the spin's, and the one an impact owes the body.
    let turn = |i: usize| {
        let b = &bodies[i];
        if b.motion == Motion::Dynamic && !b.isotropic {
            b.angular_velocity.length() * dt + b.impact_rotation.length()
        } else {
            0.0
        }
    };
    let largest = contacts
        .iter()
        .map(|c| turn(c.body_a).max(turn(c.body_b)))
        .fold(0.0f32, f32::max);
    let needed = (largest / config.max_turn_per_substep).ceil();
    if needed > n as f32 {
        (needed.min(u32::MAX as f32) as u32).min(config.max_substeps.max(n))
    } else {
        n
    }
}

/// The impact phase's parameters from the settings: contacts approaching faster than
/// `threshold` (m/s) are impacts; `gravity` (m/s^2) and the bodies' extra accelerations are
/// integrated after the pass (the hybrid method) or, `integrated`, before it (the propagation
/// method); `join_touching`: an inelastic event takes in the touching inelastic contacts of
/// its bodies (the hybrid method).
fn propagation_params(
    config: &SolverConfig,
    threshold: f32,
    gravity: Vec3,
    integrated: bool,
    join_touching: bool,
    dt: f32,
) -> Propagation {
    let (after, before) = if integrated {
        (Vec3::ZERO, gravity)
    } else {
        (gravity, Vec3::ZERO)
    };
    Propagation {
        join_touching,
        touch: config.linear_slop,
        threshold,
        chain_threshold: config.velocity_tolerance,
        max_sweeps: config.max_propagation_sweeps,
        dt,
        gravity: after,
        integrated_gravity: before,
        accelerations_integrated: integrated,
        substeps: config.substeps.max(1),
        max_block_iterations: config.max_block_iterations,
        velocity_tolerance: config.velocity_tolerance,
        wait_in_cluster: true,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `substeps` asks `ceil(w dt / max_turn)` substeps of a non-isotropic body in contact
    /// turning at `w`, never fewer than `substeps` nor more than `max_substeps`, and nothing of
    /// an isotropic body or of one without a contact: 100 rad/s over 1/60 s is 1.667 rad, 6.67
    /// turns of 0.25 rad, so 7 substeps.
    #[test]
    fn substeps_follow_the_fastest_turn_in_contact() {
        let body = |isotropic: bool, spin: f32| {
            SolverBody::new(Motion::Dynamic, Vec3::new(0.0, 1.0, 0.0), Quat::IDENTITY)
                .with_mass(1.0, Mat3::IDENTITY, isotropic, BVec3::FALSE)
                .with_velocity(Vec3::ZERO, Vec3::new(0.0, 0.0, spin))
        };
        let ground = SolverBody::new(Motion::Static, Vec3::ZERO, Quat::IDENTITY);
        let contact =
            ContactConstraint::new(0, 1, Vec3::new(0.0, 0.5, 0.0), Vec3::Y, 0.0, 0.0, 0.0);
        let config = SolverConfig::default();
        let dt = 1.0 / 60.0;
        let run = |spinning: SolverBody, contacts: &[ContactConstraint], config: &SolverConfig| {
            substeps(&[ground, spinning], contacts, config, dt)
        };
        let one = [contact];
        assert_eq!(run(body(false, 100.0), &one, &config), 7);
        assert_eq!(run(body(false, -100.0), &one, &config), 7);
        assert_eq!(run(body(false, 30.0), &one, &config), 4);
        assert_eq!(run(body(true, 100.0), &one, &config), 4);
        assert_eq!(run(body(false, 100.0), &[], &config), 4);
        let capped = SolverConfig {
            max_substeps: 5,
            ..default()
        };
        assert_eq!(run(body(false, 100.0), &one, &capped), 5);
        let never = SolverConfig {
            max_turn_per_substep: f32::INFINITY,
            ..default()
        };
        assert_eq!(run(body(false, 1e6), &one, &never), 4);
    }
}
