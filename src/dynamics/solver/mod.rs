//! The contact solver: plain functions over packed solver bodies and contact constraints.
//!
//! [`step`] is the whole solve of one fixed step, whichever [`SolverMethod`] is chosen. Its
//! stages, in order:
//!
//! 1. [`prepare_contacts`]: anchors, effective masses, approach velocities.
//! 2. The method's velocity solve, interleaved with [`integrate_velocities`] (gravity) and
//!    [`integrate_positions`]: see [`SolverMethod`] for each method's order of stages.
//! 3. The accumulated impulses stay in the contacts, for warm starting the next step.

pub mod body;
pub mod contact;
pub mod iterative;
pub mod propagation;

use std::ops::Range;

use bevy::prelude::*;

pub use body::{Motion, SolverBody, integrate_positions, integrate_velocities};
pub use contact::{ContactConstraint, prepare_contacts, warm_start};
use iterative::{
    RigidRows, Softness, apply_restitution, jacobi_sweep, sequential_sweep, soft_sweep,
};
use propagation::{Propagation, propagate};

/// The contact solver to use. Every method uses the same contact data; switch at run time by
/// changing [`SolverConfig::method`] (or use [`SolverConfig::for_method`] for its recommended
/// substeps and iterations).
///
/// | method | good at | costs | fails at |
/// |---|---|---|---|
/// | `Hybrid` (default) | impacts exact (cradle, bounces), stable stacks | one propagation pass + soft substeps | very long inelastic chains fall back to the soft solve |
/// | `Propagation` | Newton's cradle, event-by-event impacts | sweeps until nothing approaches | resting contact with `e > 0` hops; `e = 0` stacks collapse slowly (bounded sweeps) |
/// | `SequentialImpulses` | the common baseline, warm-started | `iterations` sweeps | cradle gives the LCP answer; stacks need many iterations; Baumgarte adds energy |
/// | `SoftStep` | stacks and mass ratios, bounded sink | `substeps` x (`iterations` + relax) sweeps | cradle gives the LCP answer; restitution only above the threshold |
/// | `Jacobi` | order independence, parallelisable | `iterations` sweeps | slow convergence; without mass splitting it overshoots |
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum SolverMethod {
    /// Impacts (approach faster than [`SolverConfig::restitution_threshold`]) resolved by
    /// propagation, one body pair's manifold at a time, at their time of impact; then resting
    /// contact by the soft step with no restitution pass. Stages: prepare, propagate impacts,
    /// then per substep: gravity, warm start, soft solve, integrate positions, relax.
    ///
    /// Why: propagation is the only method that gets chains of impacts right (Newton's cradle,
    /// stacked-ball drops), and the soft step is the most robust for resting stacks and high
    /// mass ratios. Splitting contacts by approach speed gives each job to the method that does
    /// it well, and since the impacts are resolved before gravity acts, a body at rest never
    /// sees gravity's `g dt` as an approach, so it never hops whatever its restitution.
    #[default]
    Hybrid,
    /// Every approaching contact resolved as an isolated two-body impact with the impulse
    /// formula, sweeping until none approaches (at most
    /// [`SolverConfig::max_propagation_sweeps`]). Stages: prepare, gravity, propagate,
    /// integrate positions. No position correction.
    Propagation,
    /// Projected Gauss-Seidel with accumulated impulses clamped at >= 0, warm starting,
    /// restitution targets from the pre-solve normal velocity, and Baumgarte position
    /// correction. Stages per substep: gravity, warm start, `iterations` sweeps, integrate.
    SequentialImpulses,
    /// Box2D v3's soft step: per substep gravity, warm start, soft solve, integrate positions,
    /// relax; then one restitution pass using the approach speed recorded at preparation.
    SoftStep,
    /// Simultaneous (Jacobi) sweeps: every contact solved from the same velocities, then all
    /// applied, with optional mass splitting. Stages as `SequentialImpulses`.
    Jacobi,
}

/// Which contacts send an [`Impact`](crate::Impact) message.
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ImpactMessages {
    /// None: no message work at all.
    Off,
    /// Contacts resolved as impacts (approach faster than the restitution threshold). Default.
    #[default]
    Impacts,
    /// Every contact that received any normal impulse in the step, resting ones included.
    AllContacts,
}

/// Solver settings, read every step: change them at run time.
#[derive(Resource, Reflect, Clone, Debug, PartialEq)]
#[reflect(Resource, Debug, Default, PartialEq)]
pub struct SolverConfig {
    /// The contact solver. Default [`SolverMethod::Hybrid`].
    pub method: SolverMethod,
    /// Substeps per fixed step (soft step, hybrid, and also sequential impulses and Jacobi).
    /// Default 4.
    pub substeps: u32,
    /// Velocity iterations per substep for the iterative methods; they stop earlier once no
    /// contact's velocity changes by more than `velocity_tolerance`. Default 1 (soft step).
    pub iterations: u32,
    /// Relax iterations per substep (soft step, hybrid). Default 1.
    pub relax_iterations: u32,
    /// Early-out tolerance on the largest velocity change an iteration makes, m/s.
    /// Default 1e-4.
    pub velocity_tolerance: f32,
    /// Restitution applies only to contacts approaching faster than this, m/s; slower contacts
    /// are resting and inelastic. Default 0.5.
    pub restitution_threshold: f32,
    /// Bound on propagation sweeps per step; a warning is logged when it is hit. Default 64.
    pub max_propagation_sweeps: u32,
    /// Iterations of the small block solve of one manifold's points during propagation.
    /// Default 64 (it stops at `velocity_tolerance` long before that in practice).
    pub max_block_iterations: u32,
    /// Soft contact stiffness, Hz (capped at a quarter of the substep rate). Default 30.
    pub contact_hertz: f32,
    /// Soft contact damping ratio, dimensionless. Default 10.
    pub contact_damping_ratio: f32,
    /// Largest speed at which soft contacts push penetration out, m/s. Default 3.
    pub max_push_out_speed: f32,
    /// Baumgarte factor of sequential impulses and Jacobi, in [0, 1]. Default 0.2.
    pub baumgarte: f32,
    /// Penetration Baumgarte leaves alone, m. Default 0.005.
    pub linear_slop: f32,
    /// Start each step from the previous step's impulses. Default true.
    pub warm_start: bool,
    /// Mass splitting for Jacobi. Default true.
    pub mass_splitting: bool,
    /// Contacts are generated this far before shapes touch, m. Default 0.02.
    pub contact_margin: f32,
    /// Widen each pair's contact margin by how far the pair can close in one step, so fast
    /// bodies are caught before they pass through thin ones (speculative contacts). Default true.
    pub speculative_contacts: bool,
    /// Which contacts send [`Impact`](crate::Impact) messages. Default
    /// [`ImpactMessages::Impacts`].
    pub impact_messages: ImpactMessages,
}

impl Default for SolverConfig {
    fn default() -> Self {
        SolverConfig {
            method: SolverMethod::Hybrid,
            substeps: 4,
            iterations: 1,
            relax_iterations: 1,
            velocity_tolerance: 1e-4,
            restitution_threshold: 0.5,
            max_propagation_sweeps: 64,
            max_block_iterations: 64,
            contact_hertz: 30.0,
            contact_damping_ratio: 10.0,
            max_push_out_speed: 3.0,
            baumgarte: 0.2,
            linear_slop: 0.005,
            warm_start: true,
            mass_splitting: true,
            contact_margin: 0.02,
            speculative_contacts: true,
            impact_messages: ImpactMessages::Impacts,
        }
    }
}

impl SolverConfig {
    /// The defaults with `method` and the substeps and iterations it is usually run with:
    /// hybrid and soft step 4 substeps of 1 iteration, sequential impulses 1 x 10, Jacobi
    /// 1 x 20, propagation 1 substep.
    pub fn for_method(method: SolverMethod) -> Self {
        let (substeps, iterations) = match method {
            SolverMethod::Hybrid | SolverMethod::SoftStep => (4, 1),
            SolverMethod::SequentialImpulses => (1, 10),
            SolverMethod::Jacobi => (1, 20),
            SolverMethod::Propagation => (1, 1),
        };
        SolverConfig {
            method,
            substeps,
            iterations,
            ..default()
        }
    }
}

/// What the last step's solve did. Read it as the [`SolverStats`] resource.
#[derive(Resource, Reflect, Clone, Copy, Debug, Default, PartialEq)]
#[reflect(Resource, Debug, Default, PartialEq)]
pub struct SolverStats {
    /// Contact points in the solve.
    pub contacts: u32,
    /// Velocity iterations actually run (all substeps, solve and relax), after early-outs.
    pub iterations: u32,
    /// Propagation sweeps.
    pub propagation_sweeps: u32,
    /// The propagation sweep bound was hit.
    pub propagation_bound_hit: bool,
    /// Contacts resolved as impacts.
    pub impacts: u32,
}

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
    let mut stats = SolverStats {
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
        }
    }
    prepare_contacts(bodies, contacts);

    let propagation = |threshold: f32, gravity: Vec3| Propagation {
        threshold,
        max_sweeps: config.max_propagation_sweeps,
        dt,
        gravity,
        substeps: config.substeps.max(1),
        max_block_iterations: config.max_block_iterations,
        velocity_tolerance: config.velocity_tolerance,
    };
    match config.method {
        SolverMethod::Hybrid => {
            let report = propagate(
                bodies,
                contacts,
                manifolds,
                &propagation(config.restitution_threshold, gravity),
            );
            stats.propagation_sweeps = report.sweeps;
            stats.propagation_bound_hit = report.bound_hit;
            soft_substeps(bodies, contacts, Some(manifolds), config, gravity, dt, false, &mut stats);
        }
        SolverMethod::SoftStep => {
            soft_substeps(bodies, contacts, None, config, gravity, dt, true, &mut stats);
        }
        SolverMethod::Propagation => {
            integrate_velocities(bodies, gravity, dt);
            let singles: Vec<Range<usize>> = (0..contacts.len()).map(|i| i..i + 1).collect();
            let report = propagate(
                bodies,
                contacts,
                &singles,
                &propagation(config.velocity_tolerance, Vec3::ZERO),
            );
            stats.propagation_sweeps = report.sweeps;
            stats.propagation_bound_hit = report.bound_hit;
            for c in contacts.iter_mut() {
                c.normal_impulse = c.total_impulse;
            }
            integrate_positions(bodies, gravity, dt);
        }
        SolverMethod::SequentialImpulses | SolverMethod::Jacobi => {
            rigid_substeps(bodies, contacts, config, gravity, dt, &mut stats);
        }
    }
    stats.impacts = contacts.iter().filter(|c| c.impact).count() as u32;
    stats
}

/// Sequential impulses or Jacobi, over `config.substeps` substeps.
fn rigid_substeps(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    config: &SolverConfig,
    gravity: Vec3,
    dt: f32,
    stats: &mut SolverStats,
) {
    let n = config.substeps.max(1);
    let h = dt / n as f32;
    let rows = RigidRows {
        inv_h: 1.0 / h,
        baumgarte: config.baumgarte,
        slop: config.linear_slop,
        restitution_threshold: config.restitution_threshold,
    };
    let jacobi = config.method == SolverMethod::Jacobi;
    let counts = if jacobi && config.mass_splitting {
        contact_counts(bodies.len(), contacts)
    } else {
        Vec::new()
    };
    let mut deltas = Vec::new();
    for substep in 0..n {
        integrate_velocities(bodies, gravity, h);
        if substep == 0 {
            // Restitution targets come from the normal velocity just before the solve.
            for c in contacts.iter_mut() {
                c.approach_velocity = c.normal_velocity(bodies);
            }
        }
        warm_start(bodies, contacts);
        for _ in 0..config.iterations.max(1) {
            stats.iterations += 1;
            let largest = if jacobi {
                jacobi_sweep(bodies, contacts, &rows, &counts, &mut deltas)
            } else {
                sequential_sweep(bodies, contacts, &rows)
            };
            if largest <= config.velocity_tolerance {
                break;
            }
        }
        integrate_positions(bodies, gravity, h);
        for c in contacts.iter_mut() {
            c.total_impulse += c.normal_impulse;
            if c.approach_velocity < -config.restitution_threshold && c.normal_impulse > 0.0 {
                c.impact = true;
            }
        }
    }
}

/// The soft step over `config.substeps` substeps, with Box2D's restitution pass if
/// `restitution`.
fn soft_substeps(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    blocks: Option<&[Range<usize>]>,
    config: &SolverConfig,
    gravity: Vec3,
    dt: f32,
    restitution: bool,
    stats: &mut SolverStats,
) {
    let n = config.substeps.max(1);
    let h = dt / n as f32;
    let inv_h = 1.0 / h;
    let soft = Softness::new(
        config.contact_hertz.min(0.25 * inv_h),
        config.contact_damping_ratio,
        h,
    );
    for substep in 0..n {
        integrate_velocities(bodies, gravity, h);
        warm_start(bodies, contacts);
        for _ in 0..config.iterations.max(1) {
            stats.iterations += 1;
            if proto_sweep(
                bodies,
                contacts, blocks, config.velocity_tolerance * PROTO_TOL,
                Some(&soft),
                inv_h,
                config.max_push_out_speed,
                None,
            ) <= config.velocity_tolerance
            {
                break;
            }
        }
        integrate_positions(bodies, gravity, h);
        // In the hybrid method, the last relax pass leaves impacts that close after the step
        // to the next step's impact phase.
        let leave_impacts =
            (!restitution && substep + 1 == n).then_some(config.restitution_threshold);
        for _ in 0..config.relax_iterations {
            stats.iterations += 1;
            if proto_sweep(
                bodies,
                contacts, blocks, config.velocity_tolerance * PROTO_TOL,
                None,
                inv_h,
                config.max_push_out_speed,
                leave_impacts,
            ) <= config.velocity_tolerance
            {
                break;
            }
        }
        for c in contacts.iter_mut() {
            c.total_impulse += c.normal_impulse;
        }
    }
    if restitution {
        apply_restitution(bodies, contacts, config.restitution_threshold);
    }
}

/// How many contacts touch each body (for Jacobi mass splitting).
fn contact_counts(bodies: usize, contacts: &[ContactConstraint]) -> Vec<u32> {
    let mut counts = vec![0u32; bodies];
    for c in contacts {
        counts[c.body_a] += 1;
        counts[c.body_b] += 1;
    }
    counts
}

const PROTO_TOL: f32 = 1.0;
#[allow(clippy::too_many_arguments)]
fn proto_sweep(bodies: &mut [SolverBody], contacts: &mut [ContactConstraint], blocks: Option<&[Range<usize>]>, tol: f32,
    soft: Option<&Softness>, inv_h: f32, max_push_out: f32, leave: Option<f32>) -> f32 {
    let Some(blocks) = blocks else { return soft_sweep(bodies, contacts, soft, inv_h, max_push_out, leave) };
    let mut largest = 0.0f32;
    for b in blocks {
        for it in 0..64 {
            let l = soft_sweep(bodies, &mut contacts[b.clone()], soft, inv_h, max_push_out, leave);
            if it == 0 { largest = largest.max(l); }
            if l <= tol { break; }
        }
    }
    largest
}
