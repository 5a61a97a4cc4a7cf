//! What the iterative solvers share: a sweep's outcome ([`Sweep`]) and the bookkeeping that
//! tells when a Gauss-Seidel sweep has converged exactly ([`Settling`]).

use super::body::{Motion, SolverBody};
use super::contact::{ContactConstraint, solve_friction};
use super::ledger::RestitutionLedger;
use crate::dynamics::solver::refill;

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
    pub(super) last_change: Vec<u32>,
    /// A friction row changed velocities in this sweep.
    pub(super) friction_changed: bool,
    /// Where the rows' normal impulses record their work (empty: nowhere).
    pub(super) ledger: RestitutionLedger,
}

impl Settling {
    /// Starts a sweep over `bodies` bodies.
    pub fn begin(&mut self, bodies: usize) {
        refill(&mut self.last_change, bodies, 0);
        self.friction_changed = false;
    }

    /// Row (or block) `index` changed the velocities of bodies `a` and `b`.
    #[inline]
    pub(super) fn changed(&mut self, bodies: &[SolverBody], a: usize, b: usize, index: usize) {
        for i in [a, b] {
            if bodies[i].motion == Motion::Dynamic {
                self.last_change[i] = index as u32 + 1;
            }
        }
    }

    /// Row `index` of a row-by-row sweep, at normal velocity `vn`, takes `new` as its
    /// accumulated normal impulse (already clamped): the change is applied to its bodies,
    /// recorded (with its work, in the ledger), and counted in `largest` (as a
    /// velocity change, m/s); then its friction is solved.
    #[inline]
    pub(super) fn accept(
        &mut self,
        c: &mut ContactConstraint,
        index: usize,
        vn: f32,
        new: f32,
        bodies: &mut [SolverBody],
        largest: &mut f32,
    ) {
        let delta = new - c.normal_impulse;
        if delta != 0.0 {
            self.ledger.record(c, vn, vn + delta / c.normal_mass);
            c.normal_impulse = new;
            c.apply_normal_impulse(bodies, delta);
            *largest = largest.max(delta.abs() / c.normal_mass);
            self.changed(bodies, c.body_a, c.body_b, index);
        }
        c.max_normal_impulse = c.max_normal_impulse.max(new);
        if c.friction > 0.0 {
            self.friction_changed |= solve_friction(bodies, c);
        }
    }

    /// One row-by-row sweep over `contacts`: for each row with an effective mass, `row` gives
    /// its normal velocity as the ledger measures it (the row's own, or less the gravity after
    /// a bounce: see [`ledger_velocity`](super::sequential_impulses::ledger_velocity)) and its
    /// new accumulated normal impulse (already clamped), or `None`
    /// to leave it, from the row, its index, the latest velocities and the ledger; the change is
    /// then accepted (see [`accept`](Self::accept)).
    #[inline]
    pub(super) fn sweep_rows(
        &mut self,
        bodies: &mut [SolverBody],
        contacts: &mut [ContactConstraint],
        mut row: impl FnMut(
            &ContactConstraint,
            usize,
            &[SolverBody],
            &RestitutionLedger,
        ) -> Option<(f32, f32)>,
    ) -> Sweep {
        self.begin(bodies.len());
        let mut largest = 0.0f32;
        for (i, c) in contacts.iter_mut().enumerate() {
            if c.normal_mass == 0.0 {
                continue;
            }
            let Some((vn, new)) = row(c, i, bodies, &self.ledger) else {
                continue;
            };
            self.accept(c, i, vn, new, bodies, &mut largest);
        }
        Sweep {
            largest,
            settled: self.rows_settled(contacts),
        }
    }

    /// No row (or block) `index` touching bodies `a` and `b` was disturbed after it was solved.
    #[inline]
    pub(super) fn undisturbed(&self, a: usize, b: usize, index: usize) -> bool {
        let mark = index as u32 + 1;
        self.last_change[a] <= mark && self.last_change[b] <= mark
    }

    /// Whether the sweep just made over `contacts` row by row left every row satisfied.
    pub(super) fn rows_settled(&self, contacts: &[ContactConstraint]) -> bool {
        !self.friction_changed
            && contacts
                .iter()
                .enumerate()
                .all(|(i, c)| c.normal_mass == 0.0 || self.undisturbed(c.body_a, c.body_b, i))
    }
}
