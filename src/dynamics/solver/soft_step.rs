//! Box2D v3's soft step ([`SolverMethod::SoftStep`](super::SolverMethod::SoftStep)), also the
//! hybrid method's resting phase: per substep gravity, warm start, the soft solve, position
//! integration and the relax pass; then the restitution pass.

use bevy::prelude::*;

use crate::impulse::row_impulse;

use super::body::{SolverBody, integrate_positions_owing, integrate_velocities};
use super::contact::{ContactConstraint, refresh_inertia, warm_start};
use super::hybrid::{
    Block, BlockRow, ManifoldFriction, ManifoldSolve, Transmitted, held_warm_start,
    manifold_frictions, manifold_sweep,
};
use super::iterative::{Settling, Sweep};
use super::ledger::RestitutionLedger;
use super::{SolverConfig, SolverStats};

/// The soft substeps' buffers (the soft step's and the hybrid's resting phase's), kept from
/// step to step: their contents are rebuilt every step; only their memory is reused.
#[derive(Clone, Debug, Default)]
pub struct SoftScratch {
    /// The sweeps' settling marks and the restitution ledger.
    settling: Settling,
    /// A manifold block's rows (see [`manifold_sweep`]).
    rows: Vec<BlockRow>,
    /// Each block's friction rows under [`FrictionModel::Manifold`](super::FrictionModel::Manifold)
    /// (empty per point).
    frictions: Vec<ManifoldFriction>,
    /// The bodies' velocities before a substep's gravity (see
    /// [`RestitutionLedger::charge_split`]).
    before: Vec<Vec3>,
    /// The restitution pass's rows' impulses before their bounce (see [`apply_restitution`]).
    resting: Vec<f32>,
    /// What each of the hybrid's blocks carries beyond its own impulse (see [`Transmitted`]).
    transmitted: Transmitted,
}

impl SoftScratch {
    /// No restitution ledger for the next substeps (as a new scratch has none).
    pub(super) fn close_ledger(&mut self) {
        self.settling.ledger.close();
    }
}

/// The soft step's solve of one step (see [`super::step`]): the substeps, then the restitution
/// pass.
pub(super) fn solve(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    config: &SolverConfig,
    gravity: Vec3,
    dt: f32,
    stats: &mut SolverStats,
    scratch: &mut SoftScratch,
) {
    scratch.settling.ledger.reset(bodies, contacts);
    soft_substeps(
        bodies,
        contacts,
        Resting::Rows,
        scratch,
        config,
        gravity,
        dt,
        stats,
    );
    apply_restitution(
        bodies,
        contacts,
        &mut scratch.settling.ledger,
        config.restitution_threshold,
        config.max_block_iterations,
        config.velocity_tolerance,
        &mut scratch.resting,
    );
}

/// How the soft step solves its rows.
#[derive(Clone, Copy, Debug)]
pub(super) enum Resting<'a> {
    /// Box2D v3's soft step, row by row (the `SoftStep` method).
    Rows,
    /// The hybrid method's resting phase: each manifold solved as a block (see
    /// [`manifold_sweep`]), and the last relax pass leaving fast speculative contacts to the next
    /// step's impact phase.
    Manifolds(&'a [Block]),
    /// Nothing can take an impulse (see [`resting_phase_idle`](super::hybrid::resting_phase_idle)): only gravity and integration.
    Idle,
}

/// The soft step over `config.substeps` substeps: per substep gravity, warm start, the soft
/// solve, position integration and the relax pass (Box2D v3's restitution pass is left to the
/// caller).
///
/// Unlike Box2D, the rows' angular terms are re-derived after each position integration for
/// the bodies whose inertia turned with them (`refresh_inertia`), so that the relax pass and
/// the next substep change a body's spin with the inertia its energy is measured with. Why:
/// a relax pass that releases an impulse gives back `-d lambda (v_n + v_n') / 2`, which equals
/// what the solve took only under the same inertia; a 311 kg capsule spinning at 253 rad/s
/// (a rad per substep) over the floor got 125 kJ back for the 34 kJ its speculative contact
/// took, 13% of its world's energy in one step (the energy property test, the default, seed
/// 1716). With the refresh the default fails 3 of the 4,800 long-test worlds instead of 6,
/// the soft step 45 instead of 53.
///
/// The rows' normal impulses record their work in `settling`'s ledger (for the restitution
/// pass; the hybrid's is empty).
#[allow(clippy::too_many_arguments)]
pub(super) fn soft_substeps(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    resting: Resting,
    scratch: &mut SoftScratch,
    config: &SolverConfig,
    gravity: Vec3,
    dt: f32,
    stats: &mut SolverStats,
) {
    let n = super::substeps(bodies, contacts, config, dt);
    let h = dt / n as f32;
    let inv_h = 1.0 / h;
    let hertz = config.contact_hertz.min(0.25 * inv_h);
    let soft = Softness::new(hertz, config.contact_damping_ratio, h);
    let omega = 2.0 * std::f32::consts::PI * hertz;
    let tilt_stiffness = omega * omega / gravity.length();
    let SoftScratch {
        settling,
        rows,
        frictions,
        before,
        transmitted,
        ..
    } = scratch;
    settling.friction_changed = false;
    if let Resting::Manifolds(blocks) = resting {
        manifold_frictions(config.friction_model, bodies, contacts, blocks, frictions);
    }
    let mut sweep = |bodies: &mut [SolverBody],
                     contacts: &mut [ContactConstraint],
                     settling: &mut Settling,
                     friction: (&[ManifoldFriction], &Transmitted),
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
            manifold_sweep(bodies, contacts, blocks, friction, &solve, settling, rows)
        }
        Resting::Rows | Resting::Idle => soft_sweep(
            bodies,
            contacts,
            soft.as_ref(),
            inv_h,
            config.max_push_out_speed,
            leave_impacts,
            settling,
        ),
    };
    let skip = matches!(resting, Resting::Idle);
    let hybrid = matches!(resting, Resting::Manifolds(_));
    let tolerance = config.velocity_tolerance;
    // Velocities before each substep's gravity, for the restitution ledger (see
    // `RestitutionLedger::charge_split`).
    for substep in 0..n {
        if settling.ledger.is_open() {
            before.clear();
            before.extend(bodies.iter().map(|b| b.linear_velocity));
        }
        integrate_velocities(bodies, gravity, h);
        if !skip {
            match resting {
                // The hybrid's held supports take no part of the impulses they pass on, which
                // are carried down to the friction bounds beneath (see `held_warm_start`).
                Resting::Manifolds(blocks) => {
                    transmitted.compute(bodies, contacts, blocks);
                    held_warm_start(bodies, contacts, blocks);
                }
                Resting::Rows | Resting::Idle => {
                    warm_start(bodies, contacts, &mut settling.ledger);
                }
            }
            solve_rows(config.iterations.max(1), stats, || {
                let friction = (&frictions[..], &*transmitted);
                sweep(bodies, contacts, settling, friction, Some(soft), None).done(tolerance)
            });
        }
        if settling.ledger.is_open() {
            settling.ledger.charge_split(bodies, before, gravity, h);
        }
        integrate_positions_owing(bodies, gravity, h, 1.0 / (n - substep) as f32);
        if !skip {
            // The rows' `I^-1 (r x n)` at the inertia the bodies turned to, for the relax
            // pass and the next substep (see `refresh_inertia`).
            refresh_inertia(bodies, contacts);
            if let Resting::Manifolds(blocks) = resting {
                for (rows, block) in frictions.iter_mut().zip(blocks) {
                    rows.refresh(bodies, &contacts[block.range.clone()]);
                }
            }
            // In the hybrid method, the last relax pass leaves impacts that close after the
            // step to the next step's impact phase.
            let leave_impacts =
                (hybrid && substep + 1 == n).then_some(config.restitution_threshold);
            relax(config.relax_iterations, stats, || {
                let friction = (&frictions[..], &*transmitted);
                sweep(bodies, contacts, settling, friction, None, leave_impacts).done(tolerance)
            });
        }
        store_impulses(contacts);
        if let Resting::Manifolds(blocks) = resting {
            store_carried(contacts, blocks, transmitted);
        }
    }
}

/// Adds to the impulse each of the hybrid's rows took over the step its share of what its
/// block carried in the substep (see [`Transmitted`]): a row reports the load that rests on
/// it, the weight of a whole column at its foot.
fn store_carried(contacts: &mut [ContactConstraint], blocks: &[Block], transmitted: &Transmitted) {
    for (k, block) in blocks.iter().enumerate() {
        let rows = &mut contacts[block.range.clone()];
        let scale = transmitted.bound_scale(k, rows) - 1.0;
        if scale == 0.0 {
            continue;
        }
        for c in rows.iter_mut() {
            c.total_impulse += c.normal_impulse.max(0.0) * scale;
        }
    }
}

/// Box2D's solve stage: up to `iterations` sweeps of the soft rows (`sweep`, given the
/// softness), which push penetration out at the soft rate.
fn solve_rows(iterations: u32, stats: &mut SolverStats, sweep: impl FnMut() -> bool) {
    iterate(iterations, stats, sweep);
}

/// Box2D's relax stage: up to `iterations` sweeps of the rigid rows (`sweep`, without
/// softness or push-out) after the positions moved, removing the velocity the soft solve added.
fn relax(iterations: u32, stats: &mut SolverStats, sweep: impl FnMut() -> bool) {
    iterate(iterations, stats, sweep);
}

/// Runs up to `iterations` sweeps (each counted in `stats`), stopping after the first that
/// reports itself done.
fn iterate(iterations: u32, stats: &mut SolverStats, mut sweep: impl FnMut() -> bool) {
    for _ in 0..iterations {
        stats.iterations += 1;
        if sweep() {
            break;
        }
    }
}

/// Adds each row's impulse of the substep to the impulse it took over the step (what
/// [`Impact`](crate::Impact) messages report, and what tells the contacts that pushed).
fn store_impulses(contacts: &mut [ContactConstraint]) {
    for c in contacts.iter_mut() {
        c.total_impulse += c.normal_impulse;
    }
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

impl Softness {
    /// The soft row's impulse increment, N s, for a penetrating row (separation `s <= 0`, m) of
    /// effective mass `mass` (kg) at normal velocity `vn` (m/s) with `accumulated` (N s) taken
    /// so far in the substep (with the warm start): Box2D's
    /// `-m mass_scale (v_n + bias_rate s) - impulse_scale lambda`, which drives `v_n` to the
    /// spring's speed `-(bias_rate s + impulse_scale lambda / (mass_scale m))`, with that speed
    /// capped at `max_push_out` (m/s).
    ///
    /// Why the speed and not the bias: at rest the spring's speed is zero, its bias
    /// `bias_rate s` balanced by the load term, `impulse_scale lambda / (mass_scale m)`, which
    /// for a row carrying `k` times its effective mass's weight is `k g / (omega a1)` (2.5 mm/s
    /// per weight at 30 Hz, whatever the length unit). Box2D caps the bias alone, so a row whose
    /// load asks for a bias beyond the cap cannot hold it at any depth: with the cap scaled to
    /// 3 mm/s by `PhysicsLengthUnit(1e-3)`, the ground corners of a 1 mm die under another
    /// (each carrying twice its effective mass's weight, 5 mm/s) let the die sink at about
    /// 2 mm/s, step after step, its whole height into the ground. Capping the speed instead
    /// pushes a fresh overlap out no faster than the cap and leaves the spring's holding force
    /// whole; where the cap does not bind the impulse is Box2D's, bit for bit.
    pub fn row_impulse(
        &self,
        mass: f32,
        vn: f32,
        s: f32,
        accumulated: f32,
        max_push_out: f32,
    ) -> f32 {
        let bias = self.bias_rate * s;
        let load = self.impulse_scale * accumulated / (self.mass_scale * mass);
        if bias + load >= -max_push_out {
            -mass * self.mass_scale * (vn + bias) - self.impulse_scale * accumulated
        } else {
            -mass * self.mass_scale * (vn - max_push_out)
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
    settling.sweep_rows(bodies, contacts, |c, _, bodies, _| {
        let s = c.current_separation(bodies);
        if leave_impacts.is_some_and(|t| s > 0.0 && c.normal_velocity(bodies) < -t) {
            return None;
        }
        let vn = c.normal_velocity(bodies);
        let impulse = if s > 0.0 {
            -c.normal_mass * (vn + s * inv_h)
        } else if let Some(soft) = soft {
            soft.row_impulse(c.normal_mass, vn, s, c.normal_impulse, max_push_out)
        } else {
            -c.normal_mass * vn
        };
        Some((vn, (c.normal_impulse + impulse).max(0.0)))
    })
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
///
/// Each bounce is kept within what its island's rows took from the approach in the step
/// (`ledger`, see [`RestitutionLedger`]): Newton's `-e v_n` creates energy where friction
/// turned the bodies (Kane's paradox).
///
/// A row keeps as its impulse for the next step's warm start what it carried before the bounce,
/// not the bounce: the warm start stands for the load a contact goes on carrying, and a bounce
/// is over once given. Warm-started, it was given again: in a cluster of overlapping bodies
/// whose contacts stayed in their manifolds as the bodies flew apart, the next step's warm start
/// raised the kinetic energy from 55 kJ to 153 kJ, more than the solve could take back (the
/// energy property test, soft step, seed 1904: 2.6 times the world's starting energy).
pub fn apply_restitution(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    ledger: &mut RestitutionLedger,
    threshold: f32,
    max_iterations: u32,
    tolerance: f32,
    resting: &mut Vec<f32>,
) {
    let active = |c: &ContactConstraint| {
        c.restitution > 0.0
            && c.approach_velocity <= -threshold
            && c.max_normal_impulse > 0.0
            && c.normal_mass > 0.0
    };
    // Each active row's impulse before its bounce: what the next step warm-starts.
    resting.clear();
    resting.extend(
        contacts
            .iter()
            .filter(|c| active(c))
            .map(|c| c.normal_impulse),
    );
    let rows = resting.len();
    let passes = if rows > 1 { max_iterations.max(1) } else { 1 };
    for _ in 0..passes {
        let mut largest = 0.0f32;
        for c in contacts.iter_mut().filter(|c| active(c)) {
            let vn = c.normal_velocity(bodies);
            let bounce = ledger.limited_bounce(c, -(c.restitution * c.approach_velocity), vn);
            let impulse = row_impulse(c.normal_mass, vn, bounce);
            let new = (c.normal_impulse + impulse).max(0.0);
            let delta = new - c.normal_impulse;
            if delta != 0.0 {
                ledger.record(c, vn, vn + delta / c.normal_mass);
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
    for (c, &before) in contacts
        .iter_mut()
        .filter(|c| active(c))
        .zip(resting.iter())
    {
        c.normal_impulse = c.normal_impulse.min(before);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
