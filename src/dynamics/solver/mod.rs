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
mod lcp;
pub mod propagation;

use std::ops::Range;

use bevy::prelude::*;

pub use body::{Motion, SolverBody, integrate_positions, integrate_velocities};
pub use contact::{ContactConstraint, prepare_contacts, refresh_inertia, warm_start};
use iterative::{
    Arrival, Block, ManifoldSolve, RigidRows, Settling, Softness, Support, apply_restitution,
    arrival, jacobi_sweep, manifold_sweep, sequential_sweep, soft_sweep,
};
use propagation::{Propagation, propagate};

/// The contact solver to use. Every method uses the same contact data; switch at run time by
/// changing [`SolverConfig::method`] (or use [`SolverConfig::for_method`] for its recommended
/// substeps and iterations).
///
/// | method | good at | costs | fails at (measured in `tests/methods_*.rs`, 60 Hz) |
/// |---|---|---|---|
/// | `Hybrid` (default) | impacts exact (cradle, stacked-ball drop, box landing flat without spin, simultaneous impacts solved together), never hops at rest, stacks of 20, a pyramid, 1000:1 pairs and piles of 4,000 stand awake, sinking 0.28 mm per contact; no energy gain in the random worlds of `tests/energy.rs` | one propagation sweep per wave of impacts + 4 soft substeps, each manifold a block | awake with friction, a base-20 wall sinks 3.1 cm and columns of 30 cubes drift 4.2 cm in 20 s; awake and frictionless, f32 rounding drifts bodies sideways slowly (sleeping stops both) |
/// | `Propagation` | Newton's cradle and the stacked-ball drop exact in any contact order; corners meeting together are one event (a box lands flat without spin) | sweeps until nothing approaches | no position correction, so stacks under large loads sink; no energy gain in the random worlds of `tests/energy.rs` |
/// | `SequentialImpulses` | resting contact exactly still; warm-started baseline | `iterations` sweeps, fewer only when exactly settled | cradle and stacked-ball drop give the LCP answer; one iteration spins a flat box (1.26 rad/s); stacks and mass ratios fall; restitution with friction on a fast-spinning body can gain energy (3 of 200 random worlds, up to 0.6%) |
/// | `SoftStep` | Box2D v3: robust push-out, bounded sink; restitution pass repeated until coupled contacts agree | `substeps` x (`iterations` + relax) sweeps | restitution only for contacts approaching at preparation (cradle and drop lose 24-25% energy); frictionless stacks and mass ratios fall; some random worlds gain energy (3 of 200, up to 6%) |
/// | `Jacobi` | order independence: symmetric scenes stay symmetric | `iterations` sweeps | slow convergence with mass splitting (flat box rebounds at 0.94 for e = 1, 5-ball cradle far off); stacks bounce; no energy gain in the random worlds of `tests/energy.rs` |
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum SolverMethod {
    /// Impacts (approach faster than [`SolverConfig::restitution_threshold`]) resolved by
    /// propagation, one body pair's manifold at a time, at their time of impact; then resting
    /// contact by the soft step with no restitution pass. Stages: prepare, propagate impacts,
    /// then per substep: gravity, warm start, soft solve, integrate positions, relax. When no
    /// contact can take an impulse after the impacts (all separate faster than the push-out
    /// cap), the resting phase does no sweeps at all.
    ///
    /// The resting phase differs from [`SolverMethod::SoftStep`] in three ways, all to keep
    /// frictionless stacks and mass ratios standing: each manifold is solved as one block with
    /// only its mean penetration soft (its tilt is rigid); manifolds are solved from the ground
    /// up with the supporting body held as far as its own supports hold it (wholly for a body
    /// resting squarely, not at all for one free to move along the push); and each manifold's
    /// stiffness is scaled by the mass it carries, so that every supporting contact sinks by
    /// the same `g / (2 pi f)^2` (see `manifold_sweep`, `shock_order`, `support_holds` and
    /// `carried_loads`).
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
    /// integrate positions. Only the approach a contact had before the step's gravity is
    /// bounced, so a resting body never hops. No position correction.
    Propagation,
    /// Projected Gauss-Seidel with accumulated impulses clamped at >= 0, warm starting,
    /// restitution targets for the rows whose gap closes within the substep, from their
    /// approach then (see `iterative::arrival`), and Baumgarte position correction. Stages per
    /// substep: gravity, warm start, `iterations` sweeps, integrate.
    SequentialImpulses,
    /// Box2D v3's soft step: per substep gravity, warm start, soft solve, integrate positions,
    /// relax; then one restitution pass using the approach speed recorded at preparation.
    SoftStep,
    /// Simultaneous (Jacobi) sweeps: every contact solved from the same velocities, then all
    /// applied, with optional mass splitting. Stages as `SequentialImpulses`.
    Jacobi,
}

impl SolverMethod {
    /// Every method, the default first.
    pub const ALL: [SolverMethod; 5] = [
        SolverMethod::Hybrid,
        SolverMethod::Propagation,
        SolverMethod::SequentialImpulses,
        SolverMethod::SoftStep,
        SolverMethod::Jacobi,
    ];
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
    /// Bodies in the step, static ones included; sleeping bodies that sit the step out (see
    /// [`SleepingSet`](crate::dynamics::sleep::SleepingSet)) are not among them.
    pub bodies: u32,
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
        }
    }
    prepare_contacts(bodies, contacts);

    let propagation =
        |threshold: f32, gravity: Vec3, integrated_gravity: Vec3, join: bool| Propagation {
            join_touching: join,
            threshold,
            chain_threshold: config.velocity_tolerance,
            max_sweeps: config.max_propagation_sweeps,
            dt,
            gravity,
            integrated_gravity,
            substeps: config.substeps.max(1),
            max_block_iterations: config.max_block_iterations,
            velocity_tolerance: config.velocity_tolerance,
            touch: config.linear_slop,
        };
    match config.method {
        SolverMethod::Hybrid => {
            let report = propagate(
                bodies,
                contacts,
                manifolds,
                &propagation(config.restitution_threshold, gravity, Vec3::ZERO, true),
            );
            stats.propagation_sweeps = report.sweeps;
            stats.propagation_bound_hit = report.bound_hit;
            if resting_phase_idle(bodies, contacts, config, gravity, dt) {
                soft_substeps(
                    bodies,
                    contacts,
                    Resting::Idle,
                    config,
                    gravity,
                    dt,
                    &mut stats,
                );
            } else {
                let mut blocks = shock_order(bodies, contacts, manifolds, config.linear_slop);
                // The sweeps visit the blocks in shock order: lay the contacts out in that
                // order, so that they read them in sequence rather than all over the slice.
                let (mut ordered, origin) = in_block_order(contacts, &mut blocks);
                let resting = Resting::Manifolds(&blocks);
                soft_substeps(
                    bodies,
                    &mut ordered,
                    resting,
                    config,
                    gravity,
                    dt,
                    &mut stats,
                );
                for (block, range) in blocks.iter().zip(origin) {
                    contacts[range].copy_from_slice(&ordered[block.range.clone()]);
                }
            }
        }
        SolverMethod::SoftStep => {
            soft_substeps(
                bodies,
                contacts,
                Resting::Rows,
                config,
                gravity,
                dt,
                &mut stats,
            );
            // The bounce is solved with the inertia the bodies have now (see
            // `refresh_inertia`); the substeps keep the rows of the start of the step, as Box2D
            // does.
            refresh_inertia(bodies, contacts);
            apply_restitution(
                bodies,
                contacts,
                config.restitution_threshold,
                config.max_block_iterations,
                config.velocity_tolerance,
            );
        }
        SolverMethod::Propagation => {
            integrate_velocities(bodies, gravity, dt);
            let singles: Vec<Range<usize>> = (0..contacts.len()).map(|i| i..i + 1).collect();
            let report = propagate(
                bodies,
                contacts,
                &singles,
                &propagation(config.velocity_tolerance, Vec3::ZERO, gravity, false),
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
        max_push_out: config.max_push_out_speed,
    };
    let jacobi = config.method == SolverMethod::Jacobi;
    let counts = if jacobi {
        contact_counts(bodies.len(), contacts)
    } else {
        Vec::new()
    };
    let mut deltas = Vec::new();
    let mut settling = Settling::default();
    // Restitution targets come from each row's approach at the start of its substep, before
    // the substep's gravity, and only for rows whose gap closes within it (see `arrival`).
    let mut arrivals: Vec<Arrival> = Vec::with_capacity(contacts.len());
    // Per body: the earliest time into the substep of a bounce it takes part in, and its
    // velocities before the substep's solve.
    let mut bounced: Vec<(usize, f32, Vec3, Vec3)> = Vec::new();
    for substep in 0..n {
        if substep > 0 {
            refresh_inertia(bodies, contacts);
        }
        integrate_velocities(bodies, gravity, h);
        // The approach without this substep's gravity, but with its gyroscopic update of the
        // spin: the velocities the rows are then solved from.
        arrivals.clear();
        arrivals.extend(contacts.iter().map(|c| {
            let gn = propagation::relative_gravity(c, bodies, gravity);
            arrival(
                c,
                c.normal_velocity(bodies) - gn * h,
                c.current_separation(bodies),
                gn,
                config.restitution_threshold,
                h,
            )
        }));
        // A bounce at time t into the substep: its bodies move on their free paths until t,
        // `v t + g t^2 / 2`, and at their solved velocities after, so each is owed
        // `(v - v') t + g t^2 / 2` of position over what integration gives (`v` the velocity
        // at the start of the substep, before gravity, `v'` the solved one), and its rotation
        // `(w - w') t`, as an impact of propagation is. Without it a body bounces where it was at
        // the start of the substep, up to `|v| h` short of the surface, and a ball bouncing
        // under gravity gains the potential energy of that height: at 1/15 s an e = 0.8 ball
        // rose 0.15 m above its drop height (`step_sweep_sequential_impulses`).
        bounced.clear();
        for (c, a) in contacts.iter().zip(&arrivals) {
            if a.bounce.is_nan() || a.time <= 0.0 {
                continue;
            }
            for i in [c.body_a, c.body_b] {
                let b = &bodies[i];
                if b.motion != Motion::Dynamic {
                    continue;
                }
                match bounced.iter_mut().find(|e| e.0 == i) {
                    Some(e) => e.1 = e.1.min(a.time),
                    None => bounced.push((
                        i,
                        a.time,
                        b.linear_velocity - gravity * h,
                        b.angular_velocity,
                    )),
                }
            }
        }
        warm_start(bodies, contacts);
        for _ in 0..config.iterations.max(1) {
            stats.iterations += 1;
            let sweep = if jacobi {
                jacobi_sweep(
                    bodies,
                    contacts,
                    &rows,
                    &arrivals,
                    &counts,
                    config.mass_splitting,
                    &mut deltas,
                )
            } else {
                sequential_sweep(bodies, contacts, &rows, &arrivals, &mut settling)
            };
            // Only an exact convergence ends the iterations early: the largest change is taken
            // over the whole world, so stopping at a tolerance would let one island's iteration
            // count depend on every other island, and bodies that never touched a disturbed
            // one would not come out bit-identical.
            if sweep.settled {
                break;
            }
        }
        for &(i, t, v, w) in &bounced {
            let b = &mut bodies[i];
            b.impact_offset += (v - b.linear_velocity) * t + 0.5 * gravity * t * t;
            b.impact_rotation += (w - b.angular_velocity) * t;
        }
        integrate_positions(bodies, gravity, h);
        for (c, a) in contacts.iter_mut().zip(&arrivals) {
            c.total_impulse += c.normal_impulse;
            if a.impact && c.normal_impulse > 0.0 {
                c.impact = true;
            }
        }
    }
    // A bounce's impulse does not recur: an impact with restitution is not kept for the next
    // step's warm start, where an unconverged iteration would apply it again (one iteration on
    // a 3-ball cradle gained 138% energy that way). Resting contacts, and inelastic impacts,
    // whose impulse is what holds the bodies together next step, keep theirs. (Since
    // restitution targets are taken before gravity, a resting contact no longer counts as an
    // impact at large steps.)
    for c in contacts
        .iter_mut()
        .filter(|c| c.impact && c.restitution > 0.0)
    {
        c.normal_impulse = 0.0;
    }
}

/// The manifolds of the hybrid method's resting solve, ordered from the ground up and each with
/// its support, which is held while the manifold is solved (shock propagation, after
/// Guendelman, Bridson and Fedkiw, "Nonconvex rigid bodies with stacking", 2003) as far as its
/// own supports hold it (see [`support_holds`]), and with the mass it carries (see
/// [`carried_loads`]).
///
/// A body's level is its distance, in contacts, from the nearest static or kinematic body
/// (level 0); bodies that touch none share the largest level. A manifold between bodies of
/// different levels is solved with the lower body held (wholly, when it rests squarely on held
/// supports: it then takes no impulse in the solve), and manifolds are solved in ascending order of their lower level, so one sweep settles each
/// body on its support, up a whole stack. Manifolds that support the same body are adjacent,
/// and `manifold_sweep` solves them together.
///
/// Why: Gauss-Seidel passes a correction down a stack and back only slowly (by
/// `cos^2(pi / 2N)` per sweep for N boxes, by `M / (M + m)` for a heavy box on a light one),
/// and while it lags, an upper body tilts almost freely under an off-centre load. A tilted face
/// turns the contact normal, which, with frictionless contacts, pushes the body below sideways,
/// further off centre: the lag acts like a soft hinge and the stack is unstable. Measured with
/// two-body manifold solves and 4 substeps at 60 Hz, a 100:1 pair is squeezed apart within
/// two seconds and a column of 20 cubes topples within ten; with this order both stand. With
/// the support fixed, a manifold's solve no longer has to converge through its support, which
/// is what lets [`carried_loads`] stiffen it by the load it carries without slowing the solve.
///
/// The support's response to the block's impulses comes one substep late, through the warm
/// start that every substep begins with (both bodies receive the accumulated impulses): over
/// substeps the support receives `lambda_0 + ... + lambda_(n-1)` and the supported body
/// `lambda_1 + ... + lambda_n`, so momentum is conserved up to one substep's impulse change
/// `lambda_n - lambda_0`, a bounded amount rather than a drift, and only in islands that touch a
/// static or kinematic body (which take momentum anyway). In an island that touches none, every
/// body has the same level and every manifold is solved two-body, conserving momentum exactly.
///
/// Without a consistent partition of `contacts` into `manifolds` (a caller of [`step`] may pass
/// none), each contact is its own block.
fn shock_order(
    bodies: &[SolverBody],
    contacts: &[ContactConstraint],
    manifolds: &[Range<usize>],
    touch: f32,
) -> Vec<Block> {
    let covered = manifolds.iter().map(|r| r.len()).sum::<usize>() == contacts.len()
        && manifolds
            .iter()
            .all(|r| r.end <= contacts.len() && !r.is_empty());
    let ranges: Vec<Range<usize>> = if covered {
        manifolds.to_vec()
    } else {
        (0..contacts.len()).map(|i| i..i + 1).collect()
    };
    // Only touching manifolds (a point within `touch`) make levels: a speculative contact is no
    // support. (With it, a die resting on another had the level of the lower die: at 1 mm the
    // step's fall `g dt^2`, 2.7 mm at 60 Hz, reaches the ground through the lower die, and the
    // pair of dice was then solved two-body, with no support held and no load carried.)
    let touching: Vec<bool> = ranges
        .iter()
        .map(|r| touches(&contacts[r.clone()], touch))
        .collect();
    let level = levels(
        bodies,
        ranges
            .iter()
            .zip(&touching)
            .filter(|(_, t)| **t)
            .map(|(r, _)| (contacts[r.start].body_a, contacts[r.start].body_b)),
    );
    // Sorted by (lower level, supported body), ties in manifold order: the keys are made unique
    // by the manifold's index, so the blocks themselves are moved once.
    let mut keys: Vec<(u32, usize, usize)> = ranges
        .iter()
        .enumerate()
        .map(|(k, range)| {
            let c = &contacts[range.start];
            let (la, lb) = (level[c.body_a], level[c.body_b]);
            let upper = match la.cmp(&lb) {
                std::cmp::Ordering::Less => c.body_b,
                std::cmp::Ordering::Greater => c.body_a,
                std::cmp::Ordering::Equal => usize::MAX,
            };
            (la.min(lb), upper, k)
        })
        .collect();
    keys.sort_unstable();
    let mut blocks: Vec<Block> = keys
        .iter()
        .map(|&(_, _, k)| {
            let range = ranges[k].clone();
            let c = &contacts[range.start];
            let support = match level[c.body_a].cmp(&level[c.body_b]) {
                std::cmp::Ordering::Less => Support::A,
                std::cmp::Ordering::Greater => Support::B,
                std::cmp::Ordering::Equal => Support::Neither,
            };
            Block {
                range,
                support,
                hold: 0.0,
                push: Vec3::ZERO,
                load: 0.0,
                lever: 0.0,
                spread: 0.0,
                touching: touching[k],
            }
        })
        .collect();
    support_holds(bodies, contacts, &mut blocks, touch);
    release_frictional_groups(bodies.len(), contacts, &mut blocks);
    carried_loads(bodies, contacts, &mut blocks);
    blocks
}

/// Each body's level: 0 for a static or kinematic body, one more than its lowest neighbour
/// through `pairs` for a dynamic one (`u32::MAX` if no chain of pairs reaches a fixed body).
/// A breadth-first search from the fixed bodies over the pairs, in a compressed adjacency
/// list: each pair is looked at twice, however tall the stacks.
fn levels(bodies: &[SolverBody], pairs: impl Iterator<Item = (usize, usize)> + Clone) -> Vec<u32> {
    let mut level: Vec<u32> = bodies
        .iter()
        .map(|b| {
            if b.motion == Motion::Dynamic {
                u32::MAX
            } else {
                0
            }
        })
        .collect();
    let mut start = vec![0u32; bodies.len() + 1];
    for (a, b) in pairs.clone() {
        start[a + 1] += 1;
        start[b + 1] += 1;
    }
    for i in 0..bodies.len() {
        start[i + 1] += start[i];
    }
    let mut next = start.clone();
    let mut neighbours = vec![0u32; start[bodies.len()] as usize];
    for (a, b) in pairs {
        neighbours[next[a] as usize] = b as u32;
        next[a] += 1;
        neighbours[next[b] as usize] = a as u32;
        next[b] += 1;
    }
    let mut queue: Vec<u32> = (0..bodies.len() as u32)
        .filter(|&i| level[i as usize] == 0)
        .collect();
    let mut head = 0;
    while head < queue.len() {
        let from = queue[head] as usize;
        head += 1;
        let via = level[from] + 1;
        for &to in &neighbours[start[from] as usize..start[from + 1] as usize] {
            if level[to as usize] == u32::MAX {
                level[to as usize] = via;
                queue.push(to);
            }
        }
    }
    level
}

/// Solves the manifolds of a body that rests on several supports, with friction on any of
/// them, as plain two-body blocks: no support held, no load carried through them.
///
/// Why: a held support takes the reaction of the block above it one substep late (through the
/// warm start). Under a body on one support that lag is harmless, but a body on several
/// supports (every cube of a wall, resting on two) can rock on them, and each support answers
/// the shift of load a substep late: in the awake wall of base 20 with friction 0.5 that
/// rocking grew, its kinetic energy doubling about every 30 steps from step 60 until the
/// wall's top moved 10 cm (2.1 m before the holds were weighed by the support cone). Solved
/// two-body with the soft stiffness of their own effective mass (Box2D's), the wall's
/// manifolds are stable: the top cube sinks 3.1 cm in the first half second and stays there.
/// Stiffer springs are not: carrying the load through them, or only doubling their own
/// stiffness, lets the wall collapse. Friction is what makes this sound: the held support and
/// the rigid tilt of a frictionless block are there to stop a tilted face pushing the body
/// above it sideways, and friction resists that push. Frictionless groups (a frictionless
/// pyramid needs its supports held) are left as they are. Only touching manifolds
/// ([`Block::touching`]) count as supports: a speculative one (a 1 mm die's contact with the
/// ground through the die it rests on) is not a second support.
fn release_frictional_groups(bodies: usize, contacts: &[ContactConstraint], blocks: &mut [Block]) {
    let mut supports = vec![(0u32, false); bodies];
    for block in blocks.iter().filter(|b| b.touching) {
        if let Some(upper) = block.upper(contacts) {
            supports[upper].0 += 1;
            supports[upper].1 |= contacts[block.range.start].friction > 0.0;
        }
    }
    for block in blocks.iter_mut() {
        if let Some(upper) = block.upper(contacts)
            && supports[upper].0 > 1
            && supports[upper].1
        {
            block.support = Support::Neither;
            block.hold = 0.0;
        }
    }
}

/// Some row of the manifold can push and is within `touch` (m) of touching.
fn touches(rows: &[ContactConstraint], touch: f32) -> bool {
    rows.iter()
        .any(|c| c.separation <= touch && c.normal_mass > 0.0)
}

/// Copies `contacts` in the order of `blocks` and points each block at its copy. Returns the
/// copy and each block's range in `contacts`.
fn in_block_order(
    contacts: &[ContactConstraint],
    blocks: &mut [Block],
) -> (Vec<ContactConstraint>, Vec<Range<usize>>) {
    let mut ordered = Vec::with_capacity(contacts.len());
    let mut origin = Vec::with_capacity(blocks.len());
    for block in blocks.iter_mut() {
        let start = ordered.len();
        ordered.extend_from_slice(&contacts[block.range.clone()]);
        origin.push(std::mem::replace(&mut block.range, start..ordered.len()));
    }
    (ordered, origin)
}

/// A touching manifold that supports a body, as [`support_holds`] sees it from that body.
#[derive(Clone, Copy, Debug, Default)]
struct SupportEntry {
    /// Unit normal from the support to the supported body.
    normal: Vec3,
    /// How firmly the support resists a push along `normal`, in `(0, 1]`: `1 / (1 + m K)`,
    /// `m` the supported body's mass and `K` the support's remaining inverse effective mass
    /// along the manifold (0 for a static or kinematic support, so 1).
    strength: f32,
    /// Its first touching points (world frame), for the tipping test; a manifold's points
    /// beyond these (duplicates of a face's corners) add nothing to its footprint's hull.
    footprint: [Vec3; 4],
    /// How many of `footprint` are set.
    points: u8,
}

/// Most support manifolds of one body that [`support_holds`] looks at; a body resting on more
/// (a sphere wedged among many) is treated as held by the first ones only, which can only
/// under-estimate the hold.
const MAX_SUPPORTS: usize = 8;

/// Sets each supported block's [`Block::hold`]: how much of its support's response its
/// support's own supports take. `blocks` must be in `shock_order`'s order, so that a body's
/// supporting blocks come before the blocks it supports.
///
/// Shock propagation holds a support fixed while the body above is solved, and the support
/// gets the reaction a substep later (through the warm start). That is sound only when the
/// support really is held: a push on it must go into its own supports. Where it is not (a
/// light ball on the floor struck from above at an angle, a ball of a pile pushed sideways
/// out of the pocket it sits in), the impulse computed against a fixed support is `1 + M/m`
/// times the true two-body impulse, and the support, which is free to move, leaves with
/// `M/m - 1` times the energy the impact released: a 0.05 kg ball striking a 5 kg one left at
/// 109 m/s, 485 times the energy it came with. So the hold is computed, not assumed:
///
/// - Frictionless rigid supports with normals `g_i` (pointing into the support body S) stop a
///   push on S along `-n` only in the cone they span: S's velocity change per unit push is
///   `-(n - P(n)) / m`, `P` the projection onto the cone `{sum a_i g_i, a_i >= 0}` (Moreau's
///   decomposition), so its inverse effective mass along `n` is `(1 - |P(n)|^2) / m`: the hold
///   is `|P(n)|^2`. A column (`n` along the support normal) is held wholly; the light ball on
///   the floor struck at 52 degrees keeps `sin^2` of its freedom.
/// - A support that is itself partly free holds less: for a chain (S on T), the exact two-row
///   solve gives `|P|^2 / (1 + m_S K_T)`, `K_T` what remains of T's inverse effective mass along
///   its manifold. With several supports the weakest one that takes part is used, which can
///   only under-estimate the hold.
/// - Rotation: where the block can turn S (its rows have angular terms on S), S is held only if
///   the line of action through the block's centroid along `n` meets the polygon of S's support
///   points (projected along the mean support normal); a load outside it tips S, so then the
///   hold is 0.
///
/// Only touching points (separation at most `touch`, the length-scaled linear slop) support.
/// Under-estimating the hold is safe: a hold of 0 is the plain two-body solve, which never adds
/// energy; over-estimating it is what added energy.
fn support_holds(
    bodies: &[SolverBody],
    contacts: &[ContactConstraint],
    blocks: &mut [Block],
    touch: f32,
) {
    let touching = |c: &ContactConstraint| c.separation <= touch && c.normal_mass > 0.0;
    // The support entries of each body, in one buffer: body `i` has at most `room[i]` of them,
    // at `start[i]..start[i] + count[i]`.
    let mut start = vec![0u32; bodies.len() + 1];
    for block in blocks.iter() {
        if let Some(upper) = block.upper(contacts) {
            start[upper + 1] = (start[upper + 1] + 1).min(MAX_SUPPORTS as u32);
        }
    }
    for i in 0..bodies.len() {
        start[i + 1] += start[i];
    }
    let mut count = vec![0u32; bodies.len()];
    let mut entries = vec![SupportEntry::default(); start[bodies.len()] as usize];
    for block in blocks.iter_mut() {
        let Some((upper, lower)) = block.pair(contacts) else {
            continue;
        };
        let rows = &contacts[block.range.clone()];
        let sign = if block.support == Support::A {
            1.0
        } else {
            -1.0
        };
        let normal = sign * rows[0].normal;
        let support_body = &bodies[lower];
        let lower_fixed = support_body.motion != Motion::Dynamic;
        // A pair's rows on several manifolds (a body on a trimesh's triangles) do not share
        // one normal: the support's response along one normal means nothing for the others,
        // so such a block is solved two-body.
        let one_normal = rows
            .iter()
            .all(|c| c.normal.dot(rows[0].normal) >= 1.0 - 1e-6);
        let (hold, push) = if lower_fixed {
            (1.0, Vec3::ZERO)
        } else if !one_normal {
            (0.0, normal)
        } else {
            let centroid = rows.iter().map(|c| c.point).sum::<Vec3>() / rows.len() as f32;
            // The block's rows have a lever arm on the support (relative 1e-7 of its inverse
            // mass is f32 rounding of `r x n` for `r` along `n`, as in `prepare_normal_row`).
            let turns = rows.iter().any(|c| {
                c.angular && {
                    let (rn, ang) = if block.support == Support::A {
                        (c.rn_a, c.ang_a)
                    } else {
                        (c.rn_b, c.ang_b)
                    };
                    rn.dot(ang) > 1e-7 * support_body.inverse_mass
                }
            });
            let first = start[lower] as usize;
            let below = &entries[first..first + count[lower] as usize];
            hold_of(below, normal, centroid, turns)
        };
        block.hold = hold;
        // `push` is along `normal` (support to supported); the block's rows use the contact
        // normal, which is `sign * normal`.
        block.push = sign * push;
        // This manifold, if touching, supports `upper`.
        let room = start[upper + 1] - start[upper];
        if count[upper] >= room {
            continue;
        }
        let mut entry = SupportEntry {
            normal,
            ..SupportEntry::default()
        };
        let mut centroid = Vec3::ZERO;
        let mut points = 0usize;
        for c in rows.iter().filter(|c| touching(c)) {
            centroid += c.point;
            if points < entry.footprint.len() {
                entry.footprint[points] = c.point;
            }
            points += 1;
        }
        if points == 0 {
            continue;
        }
        entry.points = points.min(entry.footprint.len()) as u8;
        entry.strength = if lower_fixed {
            1.0
        } else {
            let r = centroid / points as f32 - support_body.position;
            let rn = r.cross(normal);
            let k_lower = support_body.inverse_mass + rn.dot(support_body.inverse_inertia * rn);
            let m_upper = 1.0 / bodies[upper].inverse_mass.max(f32::MIN_POSITIVE);
            1.0 / (1.0 + m_upper * (1.0 - block.hold) * k_lower)
        };
        entries[(start[upper] + count[upper]) as usize] = entry;
        count[upper] += 1;
    }
}

/// The hold of a support with the given support manifolds and footprint, for a push along `-n`
/// through `point` (see [`support_holds`]), and the support's free response direction
/// `n - s P(n)` (whose component along `n` is `1 - hold`); `turns`: the push has a lever arm
/// on the support.
fn hold_of(entries: &[SupportEntry], n: Vec3, point: Vec3, turns: bool) -> (f32, Vec3) {
    if entries.is_empty() {
        return (0.0, n);
    }
    if turns {
        let axis = entries
            .iter()
            .map(|e| e.normal)
            .sum::<Vec3>()
            .normalize_or_zero();
        let footprint = entries
            .iter()
            .flat_map(|e| e.footprint[..e.points as usize].iter().copied());
        if axis == Vec3::ZERO || !line_meets_footprint(footprint, point, n, axis) {
            return (0.0, n);
        }
    }
    let normals: Vec<Vec3> = entries.iter().map(|e| e.normal).collect();
    let (projection, used) = cone_projection(n, &normals);
    let strength = entries
        .iter()
        .enumerate()
        .filter(|(i, _)| used & (1 << i) != 0)
        .map(|(_, e)| e.strength)
        .fold(1.0f32, f32::min);
    let hold = (projection.dot(n) * strength).clamp(0.0, 1.0);
    (hold, n - strength * projection)
}

/// Whether the line through `point` along `n` crosses the convex hull of `footprint`, all
/// projected on the plane normal to `axis`: the hull is covered by the triangles of its points,
/// so the test is "inside some triangle" (at most `MAX_SUPPORTS` manifolds of 4 points).
fn line_meets_footprint(
    footprint: impl Iterator<Item = Vec3>,
    point: Vec3,
    n: Vec3,
    axis: Vec3,
) -> bool {
    let along = n.dot(axis);
    if along.abs() < 1e-6 {
        return false;
    }
    let (u, v) = axis.any_orthonormal_pair();
    let flat = |p: Vec3| Vec2::new(p.dot(u), p.dot(v));
    let mut buffer = [Vec2::ZERO; 4 * MAX_SUPPORTS];
    let mut len = 0;
    let mut height = 0.0f32;
    for p in footprint.take(buffer.len()) {
        buffer[len] = flat(p);
        height += p.dot(axis);
        len += 1;
    }
    if len == 0 {
        return false;
    }
    let pts = &buffer[..len];
    // Where the line crosses the plane of the footprint's mean height along `axis`.
    let hit = flat(point + n * ((height / len as f32 - point.dot(axis)) / along));
    let cross = |o: Vec2, a: Vec2, b: Vec2| (a - o).perp_dot(b - o);
    for i in 0..pts.len() {
        for j in i + 1..pts.len() {
            for k in j + 1..pts.len() {
                let (a, b, c) = (pts[i], pts[j], pts[k]);
                let area = cross(a, b, c);
                if area.abs()
                    <= f32::EPSILON * (b - a).length_squared().max((c - a).length_squared())
                {
                    continue;
                }
                let s = area.signum();
                if s * cross(a, b, hit) >= 0.0
                    && s * cross(b, c, hit) >= 0.0
                    && s * cross(c, a, hit) >= 0.0
                {
                    return true;
                }
            }
        }
    }
    false
}

/// The projection of `n` onto the convex cone spanned by `generators` (at most 32), and a bit
/// mask of the generators with a positive weight in it.
///
/// In 3D the projection is `n` itself when `n` is inside the cone of some three generators,
/// and otherwise lies on a ray or a two-generator face of the cone (Caratheodory), so trying
/// every single generator, pair and triple and keeping the closest feasible point is exact.
fn cone_projection(n: Vec3, generators: &[Vec3]) -> (Vec3, u32) {
    let mut best = (Vec3::ZERO, 0u32, n.length_squared());
    let consider = |p: Vec3, used: u32, best: &mut (Vec3, u32, f32)| {
        let d = (n - p).length_squared();
        if d < best.2 {
            *best = (p, used, d);
        }
    };
    let k = generators.len().min(32);
    for i in 0..k {
        let a = n.dot(generators[i]);
        if a > 0.0 {
            consider(a * generators[i], 1 << i, &mut best);
        }
        for j in i + 1..k {
            let (gi, gj) = (generators[i], generators[j]);
            // Least squares on the plane of gi, gj: [gi.gi gi.gj; gi.gj gj.gj] a = [n.gi; n.gj].
            let (aa, ab, bb) = (gi.dot(gi), gi.dot(gj), gj.dot(gj));
            let det = aa * bb - ab * ab;
            if det > 1e-9 {
                let (ni, nj) = (n.dot(gi), n.dot(gj));
                let (x, y) = ((bb * ni - ab * nj) / det, (aa * nj - ab * ni) / det);
                if x > 0.0 && y > 0.0 {
                    consider(x * gi + y * gj, (1 << i) | (1 << j), &mut best);
                }
            }
            for (l, &gl) in generators.iter().enumerate().take(k).skip(j + 1) {
                let m = Mat3::from_cols(gi, gj, gl);
                let det = m.determinant();
                if det.abs() > 1e-9 {
                    let w = m.inverse() * n;
                    if w.min_element() > 0.0 {
                        consider(n, (1 << i) | (1 << j) | (1 << l), &mut best);
                    }
                }
            }
        }
    }
    (best.0, best.1)
}

/// Sets each supported block's [`Block::load`]: the mass of its upper body plus everything that
/// body carries, shared equally among the body's supports. `blocks` must be in `shock_order`'s
/// order (ascending lower level), so that walking it backwards visits every block a body
/// supports before the blocks that support it.
///
/// Why: a soft manifold sinks by `W K / (2 pi f)^2` under a load `W`, `K` being its inverse
/// effective mass in the soft step. With `K` the manifold's own, the weight piles up: a column
/// of `N` cubes sinks by about `g N^2 / (2 pi f)^2` (11 cm for 20 cubes at 30 Hz), and a light
/// box under a 1000 times heavier one by 28 cm, deep enough for the contact normals to turn
/// and squeeze it out. Setting `K = 1 / load` (never softer than the manifold's own `K`) makes
/// every supporting contact sink by the same `g / (2 pi f)^2`, 0.28 mm at 30 Hz, whatever rests
/// on it: 5.5 mm for the 20-cube column, 0.28 mm under the 1000:1 pair. Only the
/// regularisation changes, and with the support held fixed the stiffer block still converges
/// in one pass: its only free body is the supported one.
fn carried_loads(bodies: &[SolverBody], contacts: &[ContactConstraint], blocks: &mut [Block]) {
    let mass = |i: usize| {
        let b = &bodies[i];
        if b.motion == Motion::Dynamic && b.inverse_mass > 0.0 {
            1.0 / b.inverse_mass
        } else {
            0.0
        }
    };
    let mut load: Vec<f32> = (0..bodies.len()).map(mass).collect();
    // The mass-weighted sum of the positions of what each body carries (itself included), for
    // each block's lever.
    let mut moment: Vec<Vec3> = bodies
        .iter()
        .enumerate()
        .map(|(i, b)| mass(i) * b.position)
        .collect();
    // Only touching blocks share the load; a speculative one (not touching) is given the whole
    // load of its upper body, as if it were its only support, and passes none on.
    let mut supports = vec![0u32; bodies.len()];
    for block in blocks.iter().filter(|b| b.touching) {
        if let Some(upper) = block.upper(contacts) {
            supports[upper] += 1;
        }
    }
    for block in blocks.iter_mut().rev() {
        if let Some((upper, lower)) = block.pair(contacts) {
            if load[upper] > 0.0 {
                let center = moment[upper] / load[upper];
                (block.lever, block.spread) = lever(&contacts[block.range.clone()], upper, center);
            }
            if !block.touching {
                block.load = load[upper];
                continue;
            }
            let fraction = 1.0 / supports[upper] as f32;
            let share = load[upper] * fraction;
            block.load = share;
            if bodies[lower].motion == Motion::Dynamic {
                load[lower] += share;
                let carried = moment[upper] * fraction;
                moment[lower] += carried;
            }
        }
    }
}

/// A manifold's [`Block::lever`] and [`Block::spread`]: how high the centre of mass `center`
/// of what it carries stands above the manifold's centroid, along its normal towards the
/// supported body `upper`, m (0 if below); and the mean square distance of its points from
/// that centroid over two, m^2 (the second moment about one axis of a rectangle's corners).
fn lever(rows: &[ContactConstraint], upper: usize, center: Vec3) -> (f32, f32) {
    let c = &rows[0];
    let up = if c.body_b == upper {
        c.normal
    } else {
        -c.normal
    };
    let n = rows.len() as f32;
    let centroid = rows.iter().map(|r| r.point).sum::<Vec3>() / n;
    let spread = rows
        .iter()
        .map(|r| (r.point - centroid).length_squared())
        .sum::<f32>()
        / (2.0 * n);
    ((center - centroid).dot(up).max(0.0), spread)
}

/// True when, after the impact phase, no contact can take any impulse in the hybrid method's
/// resting phase, which can then be skipped: so an island of one impact and no resting contact
/// costs one propagation pass and nothing else.
///
/// A row of the resting phase pushes only while `v_n + bias < 0`, and its bias is at least
/// `-max_push_out_speed` (a speculative row's `s/h` is positive). Between substeps only gravity
/// changes `v_n`, by at least `min(g_n, 0) dt` over the step. So a contact with no accumulated
/// impulse to warm-start and `v_n + min(g_n, 0) dt >= max_push_out_speed` stays inactive, and
/// if every contact does, no impulse is applied at all.
fn resting_phase_idle(
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
        let g = |i: usize| {
            if bodies[i].motion == Motion::Dynamic {
                gravity
            } else {
                Vec3::ZERO
            }
        };
        let gn = (g(c.body_b) - g(c.body_a)).dot(c.normal);
        c.normal_impulse == 0.0
            && c.normal_velocity(bodies) + gn.min(0.0) * dt >= config.max_push_out_speed
    })
}

/// How the soft step solves its rows.
#[derive(Clone, Copy, Debug)]
enum Resting<'a> {
    /// Box2D v3's soft step, row by row (the `SoftStep` method).
    Rows,
    /// The hybrid method's resting phase: each manifold solved as a block (see
    /// [`manifold_sweep`]), and the last relax pass leaving fast speculative contacts to the next
    /// step's impact phase.
    Manifolds(&'a [Block]),
    /// Nothing can take an impulse (see [`resting_phase_idle`]): only gravity and integration.
    Idle,
}

/// The soft step over `config.substeps` substeps: per substep gravity, warm start, the soft
/// solve, position integration and the relax pass (Box2D v3's restitution pass is left to the
/// caller).
fn soft_substeps(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    resting: Resting,
    config: &SolverConfig,
    gravity: Vec3,
    dt: f32,
    stats: &mut SolverStats,
) {
    let n = config.substeps.max(1);
    let h = dt / n as f32;
    let inv_h = 1.0 / h;
    let hertz = config.contact_hertz.min(0.25 * inv_h);
    let soft = Softness::new(hertz, config.contact_damping_ratio, h);
    let omega = 2.0 * std::f32::consts::PI * hertz;
    let tilt_stiffness = omega * omega / gravity.length();
    let mut settling = Settling::default();
    let mut rows = Vec::new();
    let mut sweep = |bodies: &mut [SolverBody],
                     contacts: &mut [ContactConstraint],
                     soft: Option<Softness>,
                     leave_impacts: Option<f32>| match resting {
        Resting::Manifolds(blocks) => {
            let solve = ManifoldSolve {
                soft,
                inv_h,
                max_push_out: config.max_push_out_speed,
                leave_impacts,
                max_block_iterations: config.max_block_iterations,
                tolerance: config.velocity_tolerance,
                tilt_stiffness,
            };
            manifold_sweep(bodies, contacts, blocks, &solve, &mut settling, &mut rows)
        }
        Resting::Rows | Resting::Idle => soft_sweep(
            bodies,
            contacts,
            soft.as_ref(),
            inv_h,
            config.max_push_out_speed,
            leave_impacts,
            &mut settling,
        ),
    };
    let skip = matches!(resting, Resting::Idle);
    let hybrid = matches!(resting, Resting::Manifolds(_));
    for substep in 0..n {
        integrate_velocities(bodies, gravity, h);
        if !skip {
            warm_start(bodies, contacts);
            for _ in 0..config.iterations.max(1) {
                stats.iterations += 1;
                if sweep(bodies, contacts, Some(soft), None).done(config.velocity_tolerance) {
                    break;
                }
            }
        }
        integrate_positions(bodies, gravity, h);
        if !skip {
            // In the hybrid method, the last relax pass leaves impacts that close after the
            // step to the next step's impact phase.
            let leave_impacts =
                (hybrid && substep + 1 == n).then_some(config.restitution_threshold);
            for _ in 0..config.relax_iterations {
                stats.iterations += 1;
                if sweep(bodies, contacts, None, leave_impacts).done(config.velocity_tolerance) {
                    break;
                }
            }
        }
        for c in contacts.iter_mut() {
            c.total_impulse += c.normal_impulse;
        }
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

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::math::{BVec3, Mat3, Quat};

    fn cube(motion: Motion, mass: f32) -> SolverBody {
        SolverBody::new(motion, Vec3::ZERO, Quat::IDENTITY).with_mass(
            1.0 / mass,
            Mat3::from_diagonal(Vec3::splat(6.0 / mass)),
            true,
            BVec3::FALSE,
        )
    }

    /// Levels worked out by hand: a static floor (0) and a kinematic platform (5) are level 0;
    /// a column 1, 2, 3 on the floor is 1, 2, and 2 for 3, which also touches 4; body 4 rests on
    /// 3 and on the platform, so it is 1 (its lowest neighbour, not the column below it); 6
    /// hangs on 4 only (2); 7 touches
    /// nothing fixed through any chain, nor does 8 that rests on it (u32::MAX). Pairs listed
    /// top-down and twice, so one pass in list order would not find the answer.
    #[test]
    fn levels_are_hops_from_the_nearest_fixed_body() {
        let mut bodies: Vec<SolverBody> = (0..9).map(|_| cube(Motion::Dynamic, 1.0)).collect();
        bodies[0] = cube(Motion::Static, 1.0);
        bodies[5] = cube(Motion::Kinematic, 1.0);
        let pairs = [
            (8, 7),
            (6, 4),
            (3, 4),
            (2, 3),
            (1, 2),
            (0, 1),
            (4, 5),
            (3, 2),
        ];
        let level = levels(&bodies, pairs.iter().copied());
        assert_eq!(level, vec![0, 1, 2, 2, 1, 0, 2, u32::MAX, u32::MAX]);
    }

    /// One single-point manifold per body pair (normals from the first body to the second).
    fn manifolds(pairs: &[(usize, usize)]) -> (Vec<ContactConstraint>, Vec<Range<usize>>) {
        let contacts = pairs
            .iter()
            .map(|&(a, b)| ContactConstraint::new(a, b, Vec3::ZERO, Vec3::Y, 0.0, 0.0, 0.0))
            .collect();
        let ranges = (0..pairs.len()).map(|i| i..i + 1).collect();
        (contacts, ranges)
    }

    /// A column (ground 0, then cubes of 1, 2 and 3 kg, listed top down): blocks come out
    /// ground up, each supported by the body below and carrying the mass above it: 6, 5, 3 kg.
    #[test]
    fn column_loads_are_the_mass_above() {
        let bodies = [
            SolverBody::new(Motion::Static, Vec3::ZERO, Quat::IDENTITY),
            cube(Motion::Dynamic, 1.0),
            cube(Motion::Dynamic, 2.0),
            cube(Motion::Dynamic, 3.0),
        ];
        let (mut contacts, ranges) = manifolds(&[(2, 3), (1, 2), (0, 1)]);
        prepare_contacts(&bodies, &mut contacts);
        let blocks = shock_order(&bodies, &contacts, &ranges, 0.005);
        let order: Vec<(usize, Support, f32)> = blocks
            .iter()
            .map(|b| (b.range.start, b.support, b.load))
            .collect();
        assert_eq!(
            order,
            [
                (2, Support::A, 6.0),
                (1, Support::A, 5.0),
                (0, Support::A, 3.0)
            ]
        );
    }

    /// A small pyramid: cubes 1 and 2 (1 kg) on the ground, cube 3 (2 kg) on both, and cube 4
    /// (1 kg) touching cube 1 from the side at the same level. Cube 3's load is shared equally
    /// (1 kg per support), each ground manifold carries its cube plus that share (2 kg), and
    /// the side contact has no support and no load. Cube 3's two manifolds are adjacent.
    #[test]
    fn shared_loads_split_between_supports() {
        let bodies = [
            SolverBody::new(Motion::Static, Vec3::ZERO, Quat::IDENTITY),
            cube(Motion::Dynamic, 1.0),
            cube(Motion::Dynamic, 1.0),
            cube(Motion::Dynamic, 2.0),
            cube(Motion::Dynamic, 1.0),
        ];
        let (mut contacts, ranges) = manifolds(&[(1, 3), (0, 1), (4, 1), (2, 3), (0, 2), (0, 4)]);
        prepare_contacts(&bodies, &mut contacts);
        let blocks = shock_order(&bodies, &contacts, &ranges, 0.005);
        let load = |start: usize| blocks.iter().find(|b| b.range.start == start).unwrap();
        assert_eq!(load(1).load, 2.0);
        assert_eq!(load(4).load, 2.0);
        assert_eq!(load(5).load, 1.0);
        assert_eq!(load(0).load, 1.0);
        assert_eq!(load(3).load, 1.0);
        assert_eq!((load(2).support, load(2).load), (Support::Neither, 0.0));
        let tops: Vec<usize> = blocks
            .iter()
            .enumerate()
            .filter(|(_, b)| b.upper(&contacts) == Some(3))
            .map(|(i, _)| i)
            .collect();
        assert_eq!(tops.len(), 2);
        assert_eq!(tops[1], tops[0] + 1);
    }
    /// The projection onto a cone: a vector inside the cone of three generators is its own
    /// projection; outside a single generator's ray it is `(n . g) g`; between two generators
    /// (outside their plane) it lies on their face; opposite every generator it is zero.
    #[test]
    fn cone_projection_cases() {
        let (x, y, z) = (Vec3::X, Vec3::Y, Vec3::Z);
        let n = Vec3::new(1.0, 2.0, 3.0).normalize();
        let (p, used) = cone_projection(n, &[x, y, z]);
        assert!((p - n).length() < 1e-6 && used == 0b111);
        let n = Vec3::new(0.6, 0.8, 0.0);
        let (p, used) = cone_projection(n, &[y]);
        assert!((p - 0.8 * y).length() < 1e-6 && used == 1);
        // Between x and y, with a z part: the face's projection drops the z part.
        let n = Vec3::new(0.48, 0.64, 0.6);
        let (p, used) = cone_projection(n, &[x, y]);
        assert!((p - Vec3::new(0.48, 0.64, 0.0)).length() < 1e-6 && used == 0b11);
        let (p, used) = cone_projection(-y, &[y, x]);
        assert_eq!((p, used), (Vec3::ZERO, 0));
    }

    /// A ball of 1 kg on static ground, struck from above along `n` at angle `theta` from the
    /// vertical: its hold is `cos^2 theta` and it is free to move along `n - cos theta y` (the
    /// projection of `n` across the ground normal), exactly the frictionless rigid answer. A
    /// ball on another ball that rests squarely on the ground (a column of two) is held wholly
    /// along the vertical, and a ball with nothing below it (touching only speculatively) not
    /// at all.
    #[test]
    fn holds_follow_the_support_cone() {
        let ball = |y: f32| {
            SolverBody::new(Motion::Dynamic, Vec3::new(0.0, y, 0.0), Quat::IDENTITY).with_mass(
                1.0,
                Mat3::from_diagonal(Vec3::splat(10.0)),
                true,
                BVec3::FALSE,
            )
        };
        let theta = 0.9f32;
        let n = Vec3::new(theta.sin(), theta.cos(), 0.0);
        let bodies = [
            SolverBody::new(Motion::Static, Vec3::ZERO, Quat::IDENTITY),
            ball(0.5),
            ball(0.5 + 1.0),
        ];
        let floor = ContactConstraint::new(0, 1, Vec3::ZERO, Vec3::Y, 0.0, 0.0, 0.0);
        let hit =
            ContactConstraint::new(1, 2, Vec3::new(0.0, 0.5, 0.0) + 0.5 * n, n, 0.0, 0.0, 0.0);
        let mut contacts = [floor, hit];
        prepare_contacts(&bodies, &mut contacts);
        let blocks = shock_order(&bodies, &contacts, &[0..1, 1..2], 0.005);
        let struck = blocks.iter().find(|b| b.range == (1..2)).unwrap();
        let c2 = theta.cos().powi(2);
        assert!((struck.hold - c2).abs() < 1e-6, "{}", struck.hold);
        assert!((struck.push - (n - theta.cos() * Vec3::Y)).length() < 1e-6);
        // A column of two: held wholly.
        let column = ContactConstraint::new(1, 2, Vec3::new(0.0, 1.0, 0.0), Vec3::Y, 0.0, 0.0, 0.0);
        let mut contacts = [floor, column];
        prepare_contacts(&bodies, &mut contacts);
        let blocks = shock_order(&bodies, &contacts, &[0..1, 1..2], 0.005);
        let top = blocks.iter().find(|b| b.range == (1..2)).unwrap();
        assert!((top.hold - 1.0).abs() < 1e-6 && top.push.length() < 1e-6);
        // The lower ball only speculatively on the ground (a 1 cm gap): not held.
        let gap = ContactConstraint::new(0, 1, Vec3::ZERO, Vec3::Y, 0.01, 0.0, 0.0);
        let mut contacts = [gap, column];
        prepare_contacts(&bodies, &mut contacts);
        let blocks = shock_order(&bodies, &contacts, &[0..1, 1..2], 0.005);
        let top = blocks.iter().find(|b| b.range == (1..2)).unwrap();
        assert_eq!(top.hold, 0.0);
    }
}
