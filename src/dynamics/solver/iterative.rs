//! The iterative velocity solvers over all contacts at once: sequential impulses (projected
//! Gauss-Seidel), Jacobi, and Box2D v3's soft step. They share the row maths of
//! [`ContactConstraint`] and differ in how a row's target is set and when its impulse is applied.

use std::ops::Range;

use bevy::math::Vec3;

use super::body::{Motion, SolverBody};
use super::contact::{ContactConstraint, solve_friction};
use super::propagation::time_of_impact;

/// What one sweep over the contacts did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sweep {
    /// The largest velocity change a row made, m/s.
    pub largest: f32,
    /// Another sweep would change nothing (see [`Settling`]).
    pub settled: bool,
}

impl Sweep {
    /// The iteration can stop: nothing is left to change, or nothing changed by more than
    /// `tolerance` (m/s).
    pub fn done(&self, tolerance: f32) -> bool {
        self.settled || self.largest <= tolerance
    }
}

/// Tells whether a Gauss-Seidel sweep has converged exactly.
///
/// Each row update is the exact solution of that row's own problem on the velocities it sees
/// (its impulse is clamped at zero, and a soft row is the exact solve of its regularised row;
/// the targets depend on positions, which do not move between iterations). A row therefore
/// stays satisfied until another row changes one of its bodies. If no row's dynamic bodies were
/// changed after that row was solved, a further sweep would change nothing: the iteration has
/// converged in this sweep, and an island of one contact costs one pass. Friction rows are not
/// tracked: any friction change counts as unsettling.
#[derive(Clone, Debug, Default)]
pub struct Settling {
    /// For each body, 1 + the index of the last row (or block) that changed its velocity in
    /// this sweep; 0 for none. Only dynamic bodies are marked: the others never change.
    last_change: Vec<u32>,
    /// A friction row changed velocities in this sweep.
    friction_changed: bool,
}

impl Settling {
    /// Starts a sweep over `bodies` bodies.
    pub fn begin(&mut self, bodies: usize) {
        self.last_change.clear();
        self.last_change.resize(bodies, 0);
        self.friction_changed = false;
    }

    /// Row (or block) `index` changed the velocities of bodies `a` and `b`.
    #[inline]
    fn changed(&mut self, bodies: &[SolverBody], a: usize, b: usize, index: usize) {
        for i in [a, b] {
            if bodies[i].motion == Motion::Dynamic {
                self.last_change[i] = index as u32 + 1;
            }
        }
    }

    /// No row (or block) `index` touching bodies `a` and `b` was disturbed after it was solved.
    #[inline]
    fn undisturbed(&self, a: usize, b: usize, index: usize) -> bool {
        let mark = index as u32 + 1;
        self.last_change[a] <= mark && self.last_change[b] <= mark
    }

    /// Whether the sweep just made over `contacts` row by row left every row satisfied.
    fn rows_settled(&self, contacts: &[ContactConstraint]) -> bool {
        !self.friction_changed
            && contacts
                .iter()
                .enumerate()
                .all(|(i, c)| c.normal_mass == 0.0 || self.undisturbed(c.body_a, c.body_b, i))
    }
}

/// How a rigid (non-soft) row picks its target normal velocity.
#[derive(Clone, Copy, Debug)]
pub struct RigidRows {
    /// `1/h`, 1/s.
    pub inv_h: f32,
    /// Baumgarte factor: the fraction of the penetration (beyond `slop`) removed per step.
    pub baumgarte: f32,
    /// Penetration left alone by Baumgarte, m.
    pub slop: f32,
    /// Restitution applies above this approach speed, m/s.
    pub restitution_threshold: f32,
    /// Largest speed at which penetration is pushed out, m/s
    /// ([`SolverConfig::max_push_out_speed`](super::SolverConfig::max_push_out_speed)).
    pub max_push_out: f32,
}

impl RigidRows {
    /// The smallest normal velocity the row accepts, m/s: the speculative gap `s/h` may close,
    /// penetration beyond the slop is pushed out at `baumgarte (-s - slop) / h` but no faster
    /// than `max_push_out` (as the soft step's push-out: uncapped, `0.2 d / h` pushes a 5 cm
    /// overlap out at 2.4 m/s at 240 Hz and a 0.5 m one at 24 m/s), and a row that bounces in
    /// this substep must separate at its `bounce` target (see [`arrival`]).
    #[inline]
    pub fn target(&self, c: &ContactConstraint, bodies: &[SolverBody], bounce: f32) -> f32 {
        let s = c.current_separation(bodies);
        let target = if s > 0.0 {
            -s * self.inv_h
        } else {
            (self.baumgarte * self.inv_h * (-s - self.slop).max(0.0)).min(self.max_push_out)
        };
        // NaN (no bounce) leaves the target as it is.
        target.max(bounce)
    }
}

/// How a rigid row meets its surface in one substep (see [`arrival`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Arrival {
    /// The row's restitution target after the substep's gravity, m/s; NaN when it does not
    /// bounce in this substep (no restitution, or no impact).
    pub bounce: f32,
    /// When the gap closes, s from the start of the substep.
    pub time: f32,
    /// The row closes faster than the restitution threshold within this substep: an impact.
    pub impact: bool,
}

/// How a rigid row arrives in one substep of `h` s. `approach` is the row's normal velocity
/// at the start of the substep, before its gravity (m/s), `separation` its separation then
/// (m), `gn` the pair's relative acceleration along the normal (m/s^2).
///
/// A row makes an impact when it approaches faster than `threshold` and its gap closes within
/// the substep, at `t = time_of_impact(s, v, g_n)`. Its approach at impact is `v + g_n t`, it
/// leaves at `-e (v + g_n t)`, and gravity acts on for the rest of the substep, so the row's
/// bounce target after the substep's gravity is
///
/// ```text
/// -e (v + g_n t) + g_n (h - t)
/// ```
///
/// Why: the target used to be `-e v` with `v` taken at the step's preparation, in every
/// substep and whether or not the gap closed within it. That holds the separation speed
/// against gravity in every substep after the bounce (each one adding `m e v g h` of energy),
/// bounces contacts whose gap does not close this substep (off a surface the body never
/// reaches), and, on coupled rows, asks a row to separate at the speed its bodies had before
/// another row turned them: in the energy property test a 4 g capsule bouncing on the floor
/// with e = 1 gained 10% of its energy per bounce (sequential impulses, seed 111), and Jacobi
/// failed 14 of 200 worlds. The approach is taken per substep, before gravity: a resting
/// contact, which approaches only by its substep's `g h`, never bounces, whatever the step
/// (see `resting_box_large_step_never_hops`). The bounce happens at `t`, not at the start of
/// the substep: the caller owes the bodies the position they would have lost (see
/// `rigid_substeps` in the solver module).
#[inline]
pub fn arrival(
    c: &ContactConstraint,
    approach: f32,
    separation: f32,
    gn: f32,
    threshold: f32,
    h: f32,
) -> Arrival {
    let mut arrival = Arrival {
        bounce: f32::NAN,
        time: 0.0,
        impact: false,
    };
    if c.normal_mass > 0.0 && approach < -threshold {
        let t = time_of_impact(separation, approach, gn);
        if t < h {
            arrival.time = t;
            arrival.impact = true;
            if c.restitution > 0.0 {
                arrival.bounce = -c.restitution * (approach + gn * t) + gn * (h - t);
            }
        }
    }
    arrival
}

/// One projected Gauss-Seidel sweep: each row in turn, on the latest velocities, accumulated
/// impulse clamped at >= 0.
pub fn sequential_sweep(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    rows: &RigidRows,
    arrivals: &[Arrival],
    settling: &mut Settling,
) -> Sweep {
    settling.begin(bodies.len());
    let mut largest = 0.0f32;
    for (i, c) in contacts.iter_mut().enumerate() {
        if c.normal_mass == 0.0 {
            continue;
        }
        let vn = c.normal_velocity(bodies);
        let target = rows.target(c, bodies, arrivals[i].bounce);
        let new = (c.normal_impulse + c.normal_mass * (target - vn)).max(0.0);
        let delta = new - c.normal_impulse;
        if delta != 0.0 {
            c.normal_impulse = new;
            c.apply_normal_impulse(bodies, delta);
            largest = largest.max(delta.abs() / c.normal_mass);
            settling.changed(bodies, c.body_a, c.body_b, i);
        }
        c.max_normal_impulse = c.max_normal_impulse.max(new);
        if c.friction > 0.0 {
            settling.friction_changed |= solve_friction(bodies, c);
        }
    }
    Sweep {
        largest,
        settled: settling.rows_settled(contacts),
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
pub fn jacobi_sweep(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    rows: &RigidRows,
    arrivals: &[Arrival],
    counts: &[u32],
    split: bool,
    deltas: &mut Vec<f32>,
) -> Sweep {
    deltas.clear();
    for (c, arrival) in contacts.iter_mut().zip(arrivals) {
        if c.normal_mass == 0.0 {
            deltas.push(0.0);
            continue;
        }
        let vn = c.normal_velocity(bodies);
        let target = rows.target(c, bodies, arrival.bounce);
        let mass = if split {
            split_mass(c, bodies, counts)
        } else {
            c.normal_mass
        };
        let new = (c.normal_impulse + mass * (target - vn)).max(0.0);
        deltas.push(new - c.normal_impulse);
        c.normal_impulse = new;
        c.max_normal_impulse = c.max_normal_impulse.max(new);
    }
    let mut largest = 0.0f32;
    let mut settled = true;
    for (c, &delta) in contacts.iter().zip(deltas.iter()) {
        if delta != 0.0 {
            c.apply_normal_impulse(bodies, delta);
            largest = largest.max(delta.abs() / c.normal_mass);
            let shared = |i: usize| bodies[i].motion == Motion::Dynamic && counts[i] > 1;
            settled &= !shared(c.body_a) && !shared(c.body_b);
        }
    }
    for c in contacts.iter_mut().filter(|c| c.friction > 0.0) {
        settled &= !solve_friction(bodies, c);
    }
    Sweep { largest, settled }
}

/// Effective mass of a row with each body's share split `count` ways.
fn split_mass(c: &ContactConstraint, bodies: &[SolverBody], counts: &[u32]) -> f32 {
    let (na, nb) = (
        counts[c.body_a].max(1) as f32,
        counts[c.body_b].max(1) as f32,
    );
    let (a, b) = (&bodies[c.body_a], &bodies[c.body_b]);
    let mut k = na * a.inverse_mass + nb * b.inverse_mass;
    if c.angular {
        k += na * c.rn_a.dot(c.ang_a) + nb * c.rn_b.dot(c.ang_b);
    }
    if k > 0.0 { 1.0 / k } else { 0.0 }
}

/// Soft-constraint coefficients for a spring of `hertz` and damping ratio `zeta` integrated
/// implicitly over a substep `h` (Box2D v3, `b2MakeSoft`). With `omega = 2 pi hertz`:
///
/// ```text
/// a1 = 2 zeta + h omega,  a2 = h omega a1,  a3 = 1 / (1 + a2)
/// bias_rate = omega / a1,  mass_scale = a2 a3,  impulse_scale = a3
/// ```
///
/// A row then solves `lambda = -m mass_scale (v_n + bias_rate s) - impulse_scale lambda_acc`:
/// a stiff damped spring that pushes penetration `s < 0` out smoothly instead of all at once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Softness {
    /// 1/s.
    pub bias_rate: f32,
    /// Dimensionless.
    pub mass_scale: f32,
    /// Dimensionless.
    pub impulse_scale: f32,
}

impl Softness {
    /// See the type docs.
    pub fn new(hertz: f32, zeta: f32, h: f32) -> Self {
        if hertz <= 0.0 {
            return Softness {
                bias_rate: 0.0,
                mass_scale: 1.0,
                impulse_scale: 0.0,
            };
        }
        let omega = 2.0 * std::f32::consts::PI * hertz;
        let a1 = 2.0 * zeta + h * omega;
        let a2 = h * omega * a1;
        let a3 = 1.0 / (1.0 + a2);
        Softness {
            bias_rate: omega / a1,
            mass_scale: a2 * a3,
            impulse_scale: a3,
        }
    }
}

/// One soft-step sweep (Box2D v3 `b2SolveContact`). With `soft = Some`, penetration is pushed
/// out by the soft spring at no more than `max_push_out` m/s; with `None` (the relax pass) the
/// rows are rigid and carry no bias. A speculative gap `s > 0` may always close at `s/h`.
///
/// `leave_impacts = Some(threshold)` skips speculative rows approaching faster than
/// `threshold`: the hybrid method's last relax pass, which looks one substep past the end of
/// the step, leaves such a row to the next step's impact phase instead of braking it
/// inelastically here.
pub fn soft_sweep(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    soft: Option<&Softness>,
    inv_h: f32,
    max_push_out: f32,
    leave_impacts: Option<f32>,
    settling: &mut Settling,
) -> Sweep {
    settling.begin(bodies.len());
    let mut largest = 0.0f32;
    for (i, c) in contacts.iter_mut().enumerate() {
        if c.normal_mass == 0.0 {
            continue;
        }
        let s = c.current_separation(bodies);
        if leave_impacts.is_some_and(|t| s > 0.0 && c.normal_velocity(bodies) < -t) {
            continue;
        }
        let (bias, mass_scale, impulse_scale) = if s > 0.0 {
            (s * inv_h, 1.0, 0.0)
        } else if let Some(soft) = soft {
            (
                (soft.bias_rate * s).max(-max_push_out),
                soft.mass_scale,
                soft.impulse_scale,
            )
        } else {
            (0.0, 1.0, 0.0)
        };
        let vn = c.normal_velocity(bodies);
        let impulse = -c.normal_mass * mass_scale * (vn + bias) - impulse_scale * c.normal_impulse;
        let new = (c.normal_impulse + impulse).max(0.0);
        let delta = new - c.normal_impulse;
        if delta != 0.0 {
            c.normal_impulse = new;
            c.apply_normal_impulse(bodies, delta);
            largest = largest.max(delta.abs() / c.normal_mass);
            settling.changed(bodies, c.body_a, c.body_b, i);
        }
        c.max_normal_impulse = c.max_normal_impulse.max(new);
        if c.friction > 0.0 {
            settling.friction_changed |= solve_friction(bodies, c);
        }
    }
    Sweep {
        largest,
        settled: settling.rows_settled(contacts),
    }
}

/// Settings of [`manifold_sweep`].
#[derive(Clone, Copy, Debug)]
pub struct ManifoldSolve {
    /// The soft spring for penetrating points; `None` for the rigid relax pass.
    pub soft: Option<Softness>,
    /// `1/h`, 1/s.
    pub inv_h: f32,
    /// Largest push-out speed, m/s.
    pub max_push_out: f32,
    /// Skip speculative rows approaching faster than this, m/s (see [`soft_sweep`]).
    pub leave_impacts: Option<f32>,
    /// Most Gauss-Seidel iterations spent on one manifold per sweep.
    pub max_block_iterations: u32,
    /// A manifold's iterations stop once no row changes by more than this, m/s.
    pub tolerance: f32,
    /// `omega^2 / |g|`, 1/m: the soft contact's angular frequency squared over gravity's
    /// magnitude (infinite without gravity). A load-carrying manifold with friction gets soft
    /// rows only where this times its points' second moment is at least [`TILT_MARGIN`] times
    /// its lever (see [`manifold_sweep`]).
    pub tilt_stiffness: f32,
}

/// How much stiffer than its load's toppling moment the soft tilt of a load-carrying manifold
/// must be, for its points to be solved as soft rows (see [`manifold_sweep`]).
pub const TILT_MARGIN: f32 = 4.0;

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
/// `shock_order` in the solver module).
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
/// the gap, as in [`soft_sweep`]; in a manifold that penetrates they are points of the same
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
/// A manifold with friction is solved point by point instead: each penetrating point is
/// Box2D's soft row, `v_i' + b_i + c_i lambda_i' = 0` with `c_i = K_s / a2`, `K_s = N / load`
/// (its share of the load) or, where the block carries none, the row's own `K_ii`. The tilt is
/// then soft too, as stiff as the load it carries allows, and the manifold still sinks by
/// `g / (2 pi f)^2` under its load. Why: with a rigid tilt, a block stops at `tolerance` with a
/// residual tilt that becomes slip at the faces, and friction, warm-started from step to step,
/// stores it and feeds it back: a column of 20 cubes with friction 0.5 rocked in a growing
/// cone (27 cm in 20 s; 0.23 mm point by point). The rigid tilt exists to stop a tilted face
/// pushing a frictionless body sideways, which friction resists on its own.
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
        for block in &blocks[start..end] {
            for c in contacts[block.range.clone()]
                .iter_mut()
                .filter(|c| c.friction > 0.0)
            {
                settling.friction_changed |= solve_friction(bodies, c);
            }
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

/// One row of a manifold block: `(bias, soft)`, or `None` when the row takes no part.
pub type BlockRow = Option<(f32, bool)>;

/// Which body of a manifold block is its support, held by [`Block::hold`] while the block is
/// solved (see `shock_order` and `support_holds` in the solver module).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Support {
    /// Neither: both bodies respond (the usual two-body solve).
    Neither,
    /// Body A supports body B.
    A,
    /// Body B supports body A.
    B,
}

/// One manifold of the hybrid method's resting solve: its contacts, its support, how firmly
/// that support is held, and the mass it carries.
#[derive(Clone, Debug, PartialEq)]
pub struct Block {
    /// The manifold's range in the contact slice.
    pub range: Range<usize>,
    /// The body held (wholly or partly) while the block is solved.
    pub support: Support,
    /// The fraction of the support's response to this block's impulse that the support's own
    /// supports take, in `[0, 1]`: the support responds in the block's solve with its inverse
    /// mass and inertia scaled by `1 - hold`. 1 for a static or kinematic support and for a body
    /// resting squarely on supports that are themselves held; 0 for a body free to move along
    /// the block's normal (see `support_holds` in the solver module).
    pub hold: f32,
    /// The support's linear response per unit impulse along the contact normal, in place of
    /// the normal itself (scaled by its inverse mass): the part of a push that its own supports
    /// do not take, `n - s P(n)` in `support_holds`' terms. Its component along the normal is
    /// `1 - hold`. Unused without a support.
    pub push: Vec3,
    /// The mass this manifold carries, kg: its supported body and that body's share of
    /// everything it carries in turn (see `shock_order` in the solver module). 0 for a manifold
    /// with no support, whose stiffness is then set by its own effective mass.
    pub load: f32,
    /// How high the centre of mass of what it carries stands above its centroid, along its
    /// normal, m (see `carried_loads` in the solver module): the arm through which a tilt of
    /// the manifold moves that weight sideways. 0 with no support.
    pub lever: f32,
    /// The mean square distance of its points from their centroid over two, m^2 (the second
    /// moment about one axis of a rectangle's corners), set with [`Block::lever`].
    pub spread: f32,
    /// Some point of it can push and is within the touch distance at the start of the step:
    /// only touching manifolds make levels, support, share loads (see `shock_order`).
    pub touching: bool,
}

impl Block {
    /// (the body this block supports, its support), if it has a support.
    pub fn pair(&self, contacts: &[ContactConstraint]) -> Option<(usize, usize)> {
        let c = &contacts[self.range.start];
        match self.support {
            Support::A => Some((c.body_b, c.body_a)),
            Support::B => Some((c.body_a, c.body_b)),
            Support::Neither => None,
        }
    }

    /// The body this block supports, if it has a support.
    pub fn upper(&self, contacts: &[ContactConstraint]) -> Option<usize> {
        self.pair(contacts).map(|(upper, _)| upper)
    }

    /// How each body responds to the block's impulse along `normal`: per body, its linear
    /// direction (the normal for a free body, [`Block::push`] for the support) and the factor on
    /// its angular response (1 for a free body, `1 - hold` for the support).
    pub fn response(&self, normal: Vec3) -> Response {
        let free = Side {
            direction: None,
            along_normal: 1.0,
            angular: 1.0,
        };
        let held = if self.hold > 0.0 {
            Side {
                direction: Some(self.push),
                along_normal: normal.dot(self.push),
                angular: 1.0 - self.hold.min(1.0),
            }
        } else {
            free
        };
        let (a, b) = match self.support {
            Support::Neither => (free, free),
            Support::A => (held, free),
            Support::B => (free, held),
        };
        Response { a, b }
    }
}

/// How one body of a block responds to the block's impulse.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Side {
    /// Direction of its velocity change per unit impulse, before its inverse mass; `None`: the
    /// row's own normal (a free body).
    pub direction: Option<Vec3>,
    /// `direction . n`: 1 for a free body (exactly), `1 - hold` for a held support.
    pub along_normal: f32,
    /// Factor on its angular response.
    pub angular: f32,
}

/// How the two bodies of a block respond to its impulse (see [`Block::response`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Response {
    /// Body A.
    pub a: Side,
    /// Body B.
    pub b: Side,
}

/// Applies `+impulse` to B and `-impulse` to A along each body's response direction, with its
/// angular response scaled by its factor.
#[inline]
fn apply_response(c: &ContactConstraint, bodies: &mut [SolverBody], impulse: f32, r: &Response) {
    let (a, b) = super::body::pair_mut(bodies, c.body_a, c.body_b);
    let (dir_a, dir_b) = (
        r.a.direction.unwrap_or(c.normal),
        r.b.direction.unwrap_or(c.normal),
    );
    if dir_a != Vec3::ZERO {
        a.linear_velocity -= a.inverse_mass * (impulse * dir_a);
    }
    if c.angular && r.a.angular > 0.0 {
        a.angular_velocity -= (r.a.angular * impulse) * c.ang_a;
    }
    if dir_b != Vec3::ZERO {
        b.linear_velocity += b.inverse_mass * (impulse * dir_b);
    }
    if c.angular && r.b.angular > 0.0 {
        b.angular_velocity += (r.b.angular * impulse) * c.ang_b;
    }
}

/// Whether a manifold's soft tilt holds its load up with [`TILT_MARGIN`] to spare (see
/// [`manifold_sweep`]): `omega^2 <r^2> / g >= TILT_MARGIN * lever`, `<r^2>` its
/// [`Block::spread`]. A manifold that carries no load has its own effective mass's stiffness,
/// Box2D's soft row, and always stands.
fn soft_tilt_stands(block: &Block, solve: &ManifoldSolve) -> bool {
    if block.load <= 0.0 || block.lever <= 0.0 {
        return true;
    }
    solve.tilt_stiffness * block.spread >= TILT_MARGIN * block.lever
}

/// Solves one manifold block to convergence (see [`manifold_sweep`]). Returns whether it
/// converged exactly, the largest change of its first pass, and whether any velocity changed.
fn solve_block(
    bodies: &mut [SolverBody],
    group: &mut [ContactConstraint],
    block: &Block,
    solve: &ManifoldSolve,
    rows: &mut Vec<BlockRow>,
) -> (bool, f32, bool) {
    // The support responds along its free direction, its rotation scaled by `1 - hold`.
    let response = block.response(group[0].normal);
    let (fa, fb) = (response.a.angular, response.b.angular);
    let linear = response.a.along_normal * bodies[group[0].body_a].inverse_mass
        + response.b.along_normal * bodies[group[0].body_b].inverse_mass;
    // `K_ii` of row `c` with the support's response scaled.
    let diagonal = |c: &ContactConstraint| {
        let mut k = linear;
        if c.angular {
            k += fa * c.rn_a.dot(c.ang_a) + fb * c.rn_b.dot(c.ang_b);
        }
        k
    };
    rows.clear();
    // Sums over the soft points: count, r x n and I^-1 (r x n) of each body, and the impulse.
    let mut count = 0u32;
    let [mut rn_a, mut ang_a, mut rn_b, mut ang_b] = [Vec3::ZERO; 4];
    let mut total = 0.0f32;
    for c in group.iter() {
        if c.normal_mass == 0.0 {
            rows.push(None);
            continue;
        }
        let s = c.current_separation(bodies);
        if solve
            .leave_impacts
            .is_some_and(|t| s > 0.0 && c.normal_velocity(bodies) < -t)
        {
            rows.push(None);
            continue;
        }
        let row = if s > 0.0 {
            (s * solve.inv_h, false)
        } else if let Some(soft) = solve.soft {
            (
                (soft.bias_rate * s).max(-solve.max_push_out),
                soft.impulse_scale > 0.0,
            )
        } else {
            (0.0, false)
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
    // under its load. See `manifold_sweep`.
    let pointwise = group[0].friction > 0.0 && soft_tilt_stands(block, solve);
    let share = if block.load > 0.0 && count > 0 {
        count as f32 / block.load
    } else {
        0.0
    };
    let softness = solve
        .soft
        .map_or(0.0, |soft| soft.impulse_scale / soft.mass_scale);
    // c = K_mean / a2, K_mean = 1^T A 1 / N^2 (the points share the normal, so the linear part
    // of 1^T A 1 is N^2 (1/m_A + 1/m_B)).
    let coupling = match (solve.soft, count) {
        // Point by point, the rows do not use it.
        _ if pointwise => 0.0,
        (Some(soft), n) if n > 0 => {
            let n = n as f32;
            let sum = n * n * linear + fa * rn_a.dot(ang_a) + fb * rn_b.dot(ang_b);
            let mut k = sum / (n * n);
            if block.load > 0.0 {
                k = k.min(1.0 / block.load);
            }
            k * soft.impulse_scale / soft.mass_scale
        }
        _ => 0.0,
    };

    let mut first = 0.0f32;
    let mut changed = false;
    // Every row of the block touches the same two bodies, so a row stays satisfied (see
    // [`Settling`]) unless a later row changes something: the pass has converged when no row
    // after the first taking part changed.
    let first_row = rows.iter().position(Option::is_some);
    for iteration in 0..solve.max_block_iterations.max(1) {
        let mut last_changed = None;
        let mut largest = 0.0f32;
        for (i, (c, row)) in group.iter_mut().zip(rows.iter()).enumerate() {
            let Some((bias, soft)) = *row else { continue };
            let k = diagonal(c);
            if k <= 0.0 {
                continue;
            }
            let vn = c.normal_velocity(bodies);
            let (residual, diagonal) = if soft && pointwise {
                let own = if share > 0.0 { share } else { k } * softness;
                (vn + bias + own * c.normal_impulse, k + own)
            } else if soft {
                (vn + bias + coupling * total, k + coupling)
            } else {
                (vn + bias, k)
            };
            let new = (c.normal_impulse - residual / diagonal).max(0.0);
            let delta = new - c.normal_impulse;
            if delta != 0.0 {
                c.normal_impulse = new;
                apply_response(c, bodies, delta, &response);
                if soft {
                    total += delta;
                }
                largest = largest.max(delta.abs() * k);
                last_changed = Some(i);
                changed = true;
            }
            c.max_normal_impulse = c.max_normal_impulse.max(new);
        }
        if iteration == 0 {
            first = largest;
        }
        if last_changed <= first_row {
            return (true, first, changed);
        }
        if largest <= solve.tolerance {
            break;
        }
    }
    (false, first, changed)
}

/// Box2D v3's restitution pass, after the substeps: a contact that approached faster than
/// `threshold` at preparation and pushed during the step is driven to separate at `-e v_n`,
/// with `v_n` the approach velocity recorded at preparation.
///
/// Box2D makes one pass. With several coupled restitution rows (a ball striking two balls at
/// once) one Gauss-Seidel pass overshoots: each later row speeds up the bodies of the rows
/// before it, which then separate faster than `-e v_n`, and energy is created (a symmetric
/// three-ball hit gained 12% with e = 1, and came out asymmetric). So the pass is repeated,
/// with accumulated impulses clamped at >= 0, until no row changes by more than `tolerance`
/// (m/s) or `max_iterations` passes; an island with one restitution row still costs one pass.
pub fn apply_restitution(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    threshold: f32,
    max_iterations: u32,
    tolerance: f32,
) {
    let active = |c: &ContactConstraint| {
        c.restitution > 0.0
            && c.approach_velocity <= -threshold
            && c.max_normal_impulse > 0.0
            && c.normal_mass > 0.0
    };
    let rows = contacts.iter().filter(|c| active(c)).count();
    let passes = if rows > 1 { max_iterations.max(1) } else { 1 };
    for _ in 0..passes {
        let mut largest = 0.0f32;
        for c in contacts.iter_mut().filter(|c| active(c)) {
            let vn = c.normal_velocity(bodies);
            let impulse = -c.normal_mass * (vn + c.restitution * c.approach_velocity);
            let new = (c.normal_impulse + impulse).max(0.0);
            let delta = new - c.normal_impulse;
            if delta != 0.0 {
                c.normal_impulse = new;
                c.apply_normal_impulse(bodies, delta);
                c.total_impulse += delta;
                c.impact = true;
                largest = largest.max(delta.abs() / c.normal_mass);
            }
        }
        if largest <= tolerance {
            break;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A friction manifold's soft tilt holds its load up where `omega^2 <r^2> / g` is at least
    /// four times the lever (worked by hand below), whatever its size otherwise.
    #[test]
    fn soft_tilt_stands_by_size_against_lever() {
        // A face of four corners at +-h: <r^2> = h^2 (2 h^2 from the centroid, over two).
        let face = |h: f32| -> Vec<ContactConstraint> {
            [(-h, -h), (h, -h), (h, h), (-h, h)]
                .iter()
                .map(|&(x, z)| {
                    ContactConstraint::new(0, 1, Vec3::new(x, 0.0, z), Vec3::Y, 0.0, 0.0, 0.5)
                })
                .collect()
        };
        // The block carrying a load whose centre of mass stands `l` above the face's centroid,
        // with its lever and spread as the solver derives them (`carried_loads`).
        let block = |h: f32, l: f32| {
            let (lever, spread) = super::super::lever(&face(h), 1, Vec3::new(0.0, l, 0.0));
            assert!((lever - l).abs() <= 1e-6 * l, "lever {lever} for {l}");
            assert!(
                (spread - h * h).abs() <= 1e-6 * h * h,
                "spread {spread} for {h}"
            );
            Block {
                range: 0..4,
                support: Support::A,
                hold: 1.0,
                push: Vec3::Y,
                load: 1.0,
                lever,
                spread,
                touching: true,
            }
        };
        // 30 Hz over 9.81 m/s^2: omega^2 / g = 3621.9 1/m.
        let omega = 2.0 * std::f32::consts::PI * 30.0;
        let solve = ManifoldSolve {
            soft: None,
            inv_h: 240.0,
            max_push_out: 3.0,
            leave_impacts: None,
            max_block_iterations: 64,
            tolerance: 1e-4,
            tilt_stiffness: omega * omega / 9.81,
        };
        // A 1 m cube's face under a column of 20 (centre of mass 10 m up): 3621.9 x 0.25 = 905
        // against 4 x 10 = 40.
        assert!(soft_tilt_stands(&block(0.5, 10.0), &solve));
        // A 1 mm die's face under two more (lever 1.5 mm): 3621.9 x 2.5e-7 = 9.1e-4 against
        // 4 x 1.5e-3 = 6e-3.
        assert!(!soft_tilt_stands(&block(5e-4, 1.5e-3), &solve));
        // The bound: h^2 omega^2 / g = 4 l, for h = 0.5, at l = 226.4 m.
        let l = 0.25 * omega * omega / 9.81 / TILT_MARGIN;
        assert!(soft_tilt_stands(&block(0.5, l * 0.999), &solve));
        assert!(!soft_tilt_stands(&block(0.5, l * 1.001), &solve));
        // No load: Box2D's own-mass row, always.
        let mut free = block(5e-4, 1e3);
        free.load = 0.0;
        assert!(soft_tilt_stands(&free, &solve));
    }

    /// The soft coefficients of Box2D's defaults (30 Hz, zeta 10, h = 1/240 s) match a hand
    /// evaluation of the formulas: omega = 188.496, a1 = 20.785, a2 = 16.324.
    #[test]
    fn softness_matches_hand_evaluation() {
        let s = Softness::new(30.0, 10.0, 1.0 / 240.0);
        let omega = 2.0 * std::f32::consts::PI * 30.0;
        let a1 = 20.0 + omega / 240.0;
        let a2 = omega / 240.0 * a1;
        // Relative 1e-6: the same few f32 operations.
        assert!((s.bias_rate - omega / a1).abs() <= 1e-6 * s.bias_rate);
        assert!((s.mass_scale - a2 / (1.0 + a2)).abs() <= 1e-6);
        assert!((s.impulse_scale - 1.0 / (1.0 + a2)).abs() <= 1e-6);
        assert!((a2 - 16.324).abs() < 1e-3);
    }

    /// `arrival` against free fall worked by hand: a ball 0.2 m above the floor falling at
    /// 4 m/s under g = 10 m/s^2, e = 0.8, in a 1/15 s substep, meets it when
    /// `0.2 - 4 t - 5 t^2 = 0`, at `t = (sqrt(20) - 4) / 10` = 0.047214 s, at 4.47214 m/s;
    /// it leaves at 0.8 times that and gravity slows it for the remaining 0.019453 s:
    /// 3.57771 - 0.19453 = 3.38318 m/s (1e-5: f32 rounding). The same ball 1 m up at 1 m/s
    /// does not reach the floor within a 1/60 s substep (no impact, no bounce); at 0.3 m/s it
    /// is below the 0.5 m/s threshold (resting, not an impact); with e = 0 it is an impact
    /// without a bounce.
    #[test]
    fn arrival_matches_free_fall() {
        let row = |e: f32| ContactConstraint {
            normal_mass: 1.0,
            ..ContactConstraint::new(0, 1, Vec3::ZERO, Vec3::Y, 0.0, e, 0.0)
        };
        let a = arrival(&row(0.8), -4.0, 0.2, -10.0, 0.5, 1.0 / 15.0);
        let t = (20f32.sqrt() - 4.0) / 10.0;
        assert!(a.impact && (a.time - t).abs() <= 1e-6, "{a:?}");
        assert!((a.bounce - 3.38318).abs() <= 1e-5, "{a:?}");
        let far = arrival(&row(0.8), -1.0, 1.0, -10.0, 0.5, 1.0 / 60.0);
        assert!(!far.impact && far.bounce.is_nan(), "{far:?}");
        let slow = arrival(&row(0.8), -0.3, 0.0, -10.0, 0.5, 1.0 / 60.0);
        assert!(!slow.impact && slow.bounce.is_nan(), "{slow:?}");
        let dead = arrival(&row(0.0), -4.0, 0.2, -10.0, 0.5, 1.0 / 15.0);
        assert!(dead.impact && dead.bounce.is_nan(), "{dead:?}");
    }

    fn box_on_ground(corners: &[Vec3]) -> (Vec<SolverBody>, Vec<ContactConstraint>) {
        use crate::dynamics::solver::body::Motion;
        use crate::dynamics::solver::contact::prepare_contacts;
        use bevy::math::{BVec3, Mat3, Quat};
        let bodies = vec![
            SolverBody::new(Motion::Static, Vec3::ZERO, Quat::IDENTITY),
            SolverBody::new(Motion::Dynamic, Vec3::new(0.0, 0.49, 0.0), Quat::IDENTITY)
                .with_mass(
                    1.0,
                    Mat3::from_diagonal(Vec3::splat(6.0)),
                    true,
                    BVec3::FALSE,
                )
                .with_velocity(Vec3::new(0.0, -0.5, 0.0), Vec3::new(0.3, 0.0, -0.2)),
        ];
        let mut contacts: Vec<_> = corners
            .iter()
            .map(|&p| ContactConstraint::new(0, 1, p, Vec3::Y, -0.01, 0.0, 0.0))
            .collect();
        prepare_contacts(&bodies, &mut contacts);
        (bodies, contacts)
    }

    /// One `manifold_sweep` over `contacts` as a single two-body block (no support, no load) at
    /// `h = 1/240` s with Box2D's 3 m/s push-out cap, iterated to `tolerance`.
    fn sweep_one_block(
        bodies: &mut [SolverBody],
        contacts: &mut [ContactConstraint],
        soft: Softness,
        tolerance: f32,
    ) -> Sweep {
        let solve = ManifoldSolve {
            soft: Some(soft),
            inv_h: 240.0,
            max_push_out: 3.0,
            leave_impacts: None,
            max_block_iterations: 64,
            tolerance,
            tilt_stiffness: f32::INFINITY,
        };
        let blocks = [Block {
            range: 0..contacts.len(),
            support: Support::Neither,
            hold: 0.0,
            push: Vec3::ZERO,
            load: 0.0,
            lever: 0.0,
            spread: 0.0,
            touching: true,
        }];
        manifold_sweep(
            bodies,
            contacts,
            &blocks,
            &solve,
            &mut Settling::default(),
            &mut Vec::new(),
        )
    }

    /// A manifold block of one point is Box2D's soft row exactly (see `manifold_sweep`): the
    /// same velocities and impulse, to f32 rounding (1e-6), for a penetrating, approaching,
    /// spinning box corner.
    #[test]
    fn manifold_block_of_one_point_is_the_soft_row() {
        let soft = Softness::new(30.0, 10.0, 1.0 / 240.0);
        let (mut rows_bodies, mut rows) = box_on_ground(&[Vec3::new(0.5, -0.01, 0.5)]);
        let (mut block_bodies, mut block) = (rows_bodies.clone(), rows.clone());
        soft_sweep(
            &mut rows_bodies,
            &mut rows,
            Some(&soft),
            240.0,
            3.0,
            None,
            &mut Settling::default(),
        );
        let sweep = sweep_one_block(&mut block_bodies, &mut block, soft, 1e-6);
        assert!(sweep.settled, "one row settles in one pass");
        assert!((rows[0].normal_impulse - block[0].normal_impulse).abs() <= 1e-6);
        let (a, b) = (&rows_bodies[1], &block_bodies[1]);
        assert!((a.linear_velocity - b.linear_velocity).length() <= 1e-6);
        assert!((a.angular_velocity - b.angular_velocity).length() <= 1e-6);
    }

    /// A face manifold takes any load distribution without tilting: four corners of a spinning
    /// box, penetrating equally, end with no relative velocity between the corners (the tilt
    /// modes are rigid; 1e-4 m/s is the block tolerance), while the mean obeys the soft law
    /// `v' + b + c sum(lambda) = 0` of the manifold as a whole.
    #[test]
    fn manifold_block_is_rigid_in_tilt() {
        let soft = Softness::new(30.0, 10.0, 1.0 / 240.0);
        let corners = [(0.5, 0.5), (0.5, -0.5), (-0.5, 0.5), (-0.5, -0.5)]
            .map(|(x, z)| Vec3::new(x, -0.01, z));
        let (mut bodies, mut contacts) = box_on_ground(&corners);
        sweep_one_block(&mut bodies, &mut contacts, soft, 1e-7);
        let v: Vec<f32> = contacts
            .iter()
            .map(|c| c.normal_velocity(&bodies))
            .collect();
        for vi in &v {
            assert!((vi - v[0]).abs() <= 1e-4, "{v:?}");
        }
        // Mean law: v' + b + (K/a2) sum(lambda) = 0 with K = 1/m for the centroid under the
        // centre of mass; b = bias_rate s.
        let total: f32 = contacts.iter().map(|c| c.normal_impulse).sum();
        let a2 = soft.mass_scale / soft.impulse_scale;
        let residual = v[0] + soft.bias_rate * -0.01 + total / a2;
        assert!(residual.abs() <= 1e-4, "{residual}");
    }

    /// A face manifold with three corners touching (`s = 0`) and the fourth a hair apart
    /// (`s = 1e-6` m, 16 ulps of the 0.5 m anchors of this 1 m box), carrying the weight of a
    /// 1 kg box that lands at `g h` (0.041 m/s), sinks as one plane: the plane sinks 13 um in
    /// the substep, far past the hair, so the fourth corner sinks with the others, only
    /// faster by its gap's `s/h` (2.4e-4 m/s), and the box hardly turns. Measured: corner
    /// velocities within 1.2e-4 m/s of each other, the box turning at 9.5e-5 rad/s; bounds
    /// `s/h` plus the block tolerance (1e-4 m/s), and 2e-4 rad/s (that spread over the 1.4 m
    /// diagonal, with margin). Before, the corner a hair apart was a rigid row held at its gap
    /// while the other three sank at the soft rate: a hinge, corner velocities 1.4e-3 m/s apart
    /// and the box turning at 9.7e-4 rad/s. The soft sink is a fixed 0.28 mm whatever the
    /// size, so such a hinge tilts a small body the more: a 1 mm die landed on another turned
    /// 1e-2 rad in one step (corners 1e-10 m apart, at 1 mm 2 ulps).
    #[test]
    fn manifold_block_corner_a_hair_apart_sinks_with_the_rest() {
        use crate::dynamics::solver::body::Motion;
        use crate::dynamics::solver::contact::prepare_contacts;
        use bevy::math::{BVec3, Mat3, Quat};
        let soft = Softness::new(30.0, 10.0, 1.0 / 240.0);
        let mut bodies = vec![
            SolverBody::new(Motion::Static, Vec3::ZERO, Quat::IDENTITY),
            SolverBody::new(Motion::Dynamic, Vec3::new(0.0, 0.5, 0.0), Quat::IDENTITY)
                .with_mass(
                    1.0,
                    Mat3::from_diagonal(Vec3::splat(6.0)),
                    true,
                    BVec3::FALSE,
                )
                .with_velocity(Vec3::new(0.0, -9.81 / 240.0, 0.0), Vec3::ZERO),
        ];
        let gap = 1e-6;
        let corners = [
            (0.5, 0.5, gap),
            (0.5, -0.5, 0.0),
            (-0.5, 0.5, 0.0),
            (-0.5, -0.5, 0.0),
        ];
        let mut contacts: Vec<_> = corners
            .into_iter()
            .map(|(x, z, s)| {
                ContactConstraint::new(0, 1, Vec3::new(x, 0.0, z), Vec3::Y, s, 0.0, 0.0)
            })
            .collect();
        prepare_contacts(&bodies, &mut contacts);
        sweep_one_block(&mut bodies, &mut contacts, soft, 1e-7);
        let v: Vec<f32> = contacts
            .iter()
            .map(|c| c.normal_velocity(&bodies))
            .collect();
        let spread =
            v.iter().fold(f32::MIN, |m, &x| m.max(x)) - v.iter().fold(f32::MAX, |m, &x| m.min(x));
        assert!(spread <= gap * 240.0 + 1e-4, "{v:?}");
        assert!(v.iter().all(|&x| x < -1e-3), "the plane sinks: {v:?}");
        let w = bodies[1].angular_velocity.length();
        assert!(w <= 2e-4, "turned at {w} rad/s");
    }
}
