//! Split impulses: penetration pushed out by a pseudo-velocity that moves the bodies and is
//! then forgotten, so that pushing out never adds kinetic energy (used by
//! [`SolverMethod::SequentialImpulses`](super::SolverMethod::SequentialImpulses) and
//! [`SolverMethod::Jacobi`](super::SolverMethod::Jacobi)).
//!
//! Baumgarte's push-out asks a penetrating row to separate at `beta (-s - slop) / h`: the
//! bodies keep that speed after the overlap is gone. Each contact of a chain of overlapping
//! bodies adds up to `max_push_out_speed` to the body it pushes, so a body at the end of a
//! chain leaves at several times the cap: in the random energy worlds a 3.9 kg hull spawned in
//! a chain of overlaps left at 9.4 m/s with a 3 m/s cap (sequential impulses, seed 1102).
//! Split impulses (Catto's, Bullet's `splitImpulse`) solve the same rows on a second,
//! pseudo-velocity per body, start it at zero each substep, move the bodies by it for the
//! substep, and drop it: the overlap goes at the same rate, the velocities the velocity rows
//! solved are untouched.

use bevy::prelude::*;

use crate::impulse::row_impulse;

use super::body::{Motion, SolverBody, pair_mut};
use super::contact::ContactConstraint;
use super::jacobi::split_mass;
use super::sequential_impulses::RigidRows;
use crate::dynamics::solver::refill;

/// The pseudo-velocities of one substep's push-out, and the rows' accumulated push-out
/// impulses; kept between substeps for their buffers.
#[derive(Clone, Debug, Default)]
pub struct PushOut {
    /// Per body: linear (m/s) and angular (rad/s) pseudo-velocity.
    velocities: Vec<(Vec3, Vec3)>,
    /// Per row: accumulated push-out impulse, N s.
    impulses: Vec<f32>,
    /// Per row: the smallest pseudo normal velocity it accepts, m/s (see
    /// [`RigidRows::push_out`]).
    targets: Vec<f32>,
    /// Per row: a Jacobi sweep's impulse changes, N s.
    deltas: Vec<f32>,
}

impl PushOut {
    /// Solves the push-out rows of `contacts`, `iterations` sweeps (fewer when a sweep changes
    /// nothing), from zero pseudo-velocity; returns whether any row pushes. The sweeps are
    /// the velocity rows' kind: projected Gauss-Seidel, or with `jacobi` (the bodies' contact
    /// counts, for mass splitting when `split`) simultaneous sweeps, every row from the same
    /// pseudo-velocities, so that the push-out keeps Jacobi's independence of row order.
    ///
    /// A row penetrating deeper than the slop (at the bodies' current pose) asks for the
    /// pseudo normal velocity `min(beta (-s - slop) / h, max_push_out)`; every other row takes
    /// part too, as a bound on approach (0, or its speculative gap's `-s/h`), so that a push
    /// at one corner of a face turns the body about its other corners instead of driving them
    /// in (push-out rows alone walked a 3-cube column 0.2 m sideways at 15 Hz, where its
    /// contacts rest at the slop). The accumulated impulse only pushes. The rows' effective
    /// masses are the velocity rows' (`1/K` of the seed formula).
    pub fn solve(
        &mut self,
        bodies: &[SolverBody],
        contacts: &[ContactConstraint],
        rows: &RigidRows,
        iterations: u32,
        jacobi: Option<(&[u32], bool)>,
    ) -> bool {
        self.velocities.clear();
        self.velocities
            .resize(bodies.len(), (Vec3::ZERO, Vec3::ZERO));
        self.targets.clear();
        let mut pushes = false;
        self.targets.extend(contacts.iter().map(|c| {
            let target = rows.push_out(c, bodies);
            pushes |= target > 0.0 && c.normal_mass > 0.0;
            target
        }));
        if !pushes {
            return false;
        }
        refill(&mut self.impulses, contacts.len(), 0.0);
        for _ in 0..iterations.max(1) {
            let changed = match jacobi {
                None => self.gauss_seidel_sweep(bodies, contacts),
                Some((counts, split)) => self.jacobi_sweep(bodies, contacts, counts, split),
            };
            if !changed {
                break;
            }
        }
        true
    }

    /// One Gauss-Seidel sweep over the pushing rows; returns whether any impulse changed.
    fn gauss_seidel_sweep(
        &mut self,
        bodies: &[SolverBody],
        contacts: &[ContactConstraint],
    ) -> bool {
        let mut changed = false;
        for (i, c) in contacts.iter().enumerate() {
            if c.normal_mass == 0.0 {
                continue;
            }
            let vn = self.normal_velocity(c);
            let old = self.impulses[i];
            let new = (old + row_impulse(c.normal_mass, vn, self.targets[i])).max(0.0);
            if new != old {
                changed = true;
                self.impulses[i] = new;
                self.apply(c, bodies, new - old);
            }
        }
        changed
    }

    /// One Jacobi sweep: every pushing row's impulse from the same pseudo-velocities (with
    /// each body's share split over its contacts when `split`), then all applied.
    fn jacobi_sweep(
        &mut self,
        bodies: &[SolverBody],
        contacts: &[ContactConstraint],
        counts: &[u32],
        split: bool,
    ) -> bool {
        self.deltas.clear();
        for (i, c) in contacts.iter().enumerate() {
            if c.normal_mass == 0.0 {
                self.deltas.push(0.0);
                continue;
            }
            let mass = if split {
                split_mass(c, bodies, counts)
            } else {
                c.normal_mass
            };
            let old = self.impulses[i];
            let new = (old + row_impulse(mass, self.normal_velocity(c), self.targets[i])).max(0.0);
            self.deltas.push(new - old);
            self.impulses[i] = new;
        }
        let mut changed = false;
        for (i, c) in contacts.iter().enumerate() {
            let delta = self.deltas[i];
            if delta != 0.0 {
                changed = true;
                self.apply(c, bodies, delta);
            }
        }
        changed
    }

    /// Moves each dynamic body by its pseudo-velocity over `h` s: added to the displacement
    /// it is owed in this substep (`impact_offset`, `impact_rotation`), which
    /// [`integrate_positions`](super::body::integrate_positions) applies without touching its
    /// velocity.
    pub fn displace(&self, bodies: &mut [SolverBody], h: f32) {
        for (b, &(v, w)) in bodies.iter_mut().zip(&self.velocities) {
            if b.motion == Motion::Dynamic && (v != Vec3::ZERO || w != Vec3::ZERO) {
                b.impact_offset += v * h;
                b.impact_rotation += w * h;
            }
        }
    }

    /// The row's normal pseudo-velocity, m/s.
    fn normal_velocity(&self, c: &ContactConstraint) -> f32 {
        c.normal_velocity_of(self.velocities[c.body_a], self.velocities[c.body_b], 0.0)
    }

    /// Applies `+impulse n` to B's pseudo-velocity and `-impulse n` to A's.
    fn apply(&mut self, c: &ContactConstraint, bodies: &[SolverBody], impulse: f32) {
        let (a, b) = pair_mut(&mut self.velocities, c.body_a, c.body_b);
        c.apply_normal_impulse_to(
            (&mut a.0, &mut a.1, bodies[c.body_a].inverse_mass),
            (&mut b.0, &mut b.1, bodies[c.body_b].inverse_mass),
            impulse,
        );
    }
}
