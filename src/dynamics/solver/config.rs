//! The solver's settings ([`SolverConfig`], [`SolverMethod`], [`ImpactMessages`]) and what a
//! step's solve reports ([`SolverStats`]).

use bevy::prelude::*;

/// The contact solver to use. Every method uses the same contact data; switch at run time by
/// changing [`SolverConfig::method`] (or use [`SolverConfig::for_method`] for its recommended
/// substeps and iterations).
///
/// | method | good at | costs | fails at (measured in `tests/methods_*.rs`, 60 Hz) |
/// |---|---|---|---|
/// | `Hybrid` (default) | impacts exact (cradle, stacked-ball drop, box landing flat without spin, simultaneous impacts solved together), never hops at rest, stacks of 20, a pyramid, 1000:1 pairs and piles of 4,000 stand awake, sinking 0.28 mm per contact; no energy gain in the 5,000 random worlds of `tests/energy.rs` (default and long runs) | one propagation sweep per wave of impacts + 4 soft substeps, each manifold a block | awake with friction, a base-20 wall sinks 3.1 cm, columns of 50 cubes or of alternating masses drift or fall (README, Energy and stability); awake and frictionless, f32 rounding drifts bodies sideways slowly (sleeping stops both) |
/// | `Propagation` | Newton's cradle and the stacked-ball drop exact in any contact order; corners meeting together are one event (a box lands flat without spin) | sweeps until nothing approaches | no position correction, so stacks under large loads sink; no energy gain in the random worlds of `tests/energy.rs` |
/// | `SequentialImpulses` | resting contact exactly still; warm-started baseline | `iterations` sweeps, fewer only when exactly settled | cradle and stacked-ball drop give the LCP answer; one iteration spins a flat box (1.26 rad/s); stacks and mass ratios fall; no energy gain in the 5,000 random worlds of `tests/energy.rs` (default and long runs) |
/// | `SoftStep` | Box2D v3: robust push-out, bounded sink; restitution pass repeated until coupled contacts agree | `substeps` x (`iterations` + relax) sweeps | restitution only for contacts approaching at preparation (cradle and drop lose 24-25% energy); frictionless stacks and mass ratios fall; no energy gain in the 5,000 random worlds of `tests/energy.rs` (default and long runs) |
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
    /// approach then (see `sequential_impulses::arrival`), and split-impulse position
    /// correction (a pseudo-velocity that moves the bodies and is dropped, see
    /// [`PushOut`](super::push_out::PushOut)). Stages per substep: gravity, warm start,
    /// `iterations` sweeps, push-out, integrate.
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

/// How the hybrid method solves friction on a manifold of several points (a face or an edge
/// resting on another body).
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum FrictionModel {
    /// Two friction rows at each contact point, each bounded by its own point's normal impulse
    /// (Box2D's).
    PerPoint,
    /// Two friction rows at the manifold's centroid bounded together by the manifold's total
    /// normal impulse, and a twist row about the normal bounded by that times the points' mean
    /// distance from the centroid (Rapier's default, `FrictionModel::Simplified`): three rows
    /// for a face's four points instead of eight. The impulses are handed back to the points
    /// (each an even share of the resultant and of the twist), so contact persistence carries
    /// them. Hybrid method only: the other methods solve friction per point. Single-point
    /// manifolds (spheres) are per point either way. Default since 2026-12-07: uniform columns
    /// stand longer with it (see the README's "Friction").
    #[default]
    Manifold,
}

/// Solver settings, read every step: change them at run time. The contact margin, speculative
/// contacts and the touch distance are the narrow phase's
/// ([`NarrowPhaseConfig`](crate::collision::NarrowPhaseConfig)).
#[derive(Resource, Reflect, Clone, Debug, PartialEq)]
#[reflect(Resource, Debug, Default, PartialEq)]
pub struct SolverConfig {
    /// The contact solver. Default [`SolverMethod::Hybrid`].
    pub method: SolverMethod,
    /// Substeps per fixed step (soft step, hybrid, and also sequential impulses and Jacobi).
    /// Default 4.
    pub substeps: u32,
    /// Largest turn of a body in contact over one substep, rad: a step in which a dynamic,
    /// non-isotropic body with a contact spins at `w` and is owed a turn `t` by the step's
    /// impacts runs `ceil((|w| dt + |t|) / max_turn_per_substep)` substeps if that is more than
    /// `substeps`, up to `max_substeps` (soft step and hybrid; the owed turn is then spread over
    /// the substeps). Infinite: never more than `substeps`. Default 0.25.
    ///
    /// Why: a contact's rows are linear in the body's turn, and a body's kinetic energy at a
    /// given angular momentum depends on its orientation unless its inertia is the same about
    /// every axis. An impulse a row applies, the body then turning with it for a substep, and
    /// the relax pass releasing it (the gap opened as the body turned) leaves the angular
    /// momentum as it was but the body at an orientation where it carries more energy. The
    /// energy property test's worlds gained up to 13 kJ (1.3 %) in one step that way, with
    /// bodies turning 0.8-4 rad a substep (a 613 kg box at 310 rad/s, 30.9 Hz x 4); turning
    /// at most 0.25 rad a substep, none of them gains.
    pub max_turn_per_substep: f32,
    /// The most substeps `max_turn_per_substep` may ask for in one step. Default 64.
    pub max_substeps: u32,
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
    /// Largest speed at which contacts push penetration out, m/s (soft contacts; the
    /// pseudo-velocity of sequential impulses and Jacobi). Default 3.
    pub max_push_out_speed: f32,
    /// Position-correction factor of sequential impulses and Jacobi, in [0, 1]: the fraction of
    /// the penetration beyond `linear_slop` a substep pushes out, by a pseudo-velocity that
    /// moves the bodies and is then dropped (split impulses: pushing out adds no kinetic
    /// energy). Default 0.2.
    pub baumgarte: f32,
    /// Penetration the position correction leaves alone, m. Default 0.005.
    pub linear_slop: f32,
    /// Start each step from the previous step's impulses. Default true.
    pub warm_start: bool,
    /// Mass splitting for Jacobi. Default true.
    pub mass_splitting: bool,
    /// How the hybrid method solves a manifold's friction. Default
    /// [`FrictionModel::Manifold`].
    pub friction_model: FrictionModel,
    /// Which contacts send [`Impact`](crate::Impact) messages. Default
    /// [`ImpactMessages::Impacts`].
    pub impact_messages: ImpactMessages,
}

impl Default for SolverConfig {
    fn default() -> Self {
        SolverConfig {
            method: SolverMethod::Hybrid,
            substeps: 4,
            max_turn_per_substep: 0.25,
            max_substeps: 64,
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
            friction_model: FrictionModel::Manifold,
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
