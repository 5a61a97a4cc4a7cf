//! Restitution's energy ledger: how much a bounce may give back, per island of the step
//! (Stronge's energetic coefficient of restitution, summed over coupled contacts).

use bevy::math::Vec3;

use super::body::{Motion, SolverBody};
use super::contact::ContactConstraint;
use crate::dynamics::solver::refill;

/// [`ContactConstraint::ledger`] of a row that keeps no ledger.
pub const NO_LEDGER: u32 = u32::MAX;

/// The energy budget of restitution, one account per island of the step (bodies joined by
/// contacts between dynamic bodies), kept by the rows with restitution in it.
///
/// A normal impulse `d lambda` on a row changes its bodies' kinetic energy by
/// `d lambda (v_n + v_n') / 2 = m (v_n'^2 - v_n^2) / 2`, with `m = 1/K` the row's effective
/// mass: exactly, whatever the bodies' masses and inertia. Split at `v_n = 0`, the part below
/// zero is energy taken from the bodies' approach (or given back to it), the part above zero
/// energy given to their separation. Each row with restitution `e` adds `e^2` times what it
/// takes from approach to its island's account and takes out what it gives to separation; a
/// bounce may give at most what the account holds ([`bounce_limit`](Self::bounce_limit)).
///
/// Why: Newton's rule, `v_n' = -e v_n`, creates energy where friction takes part (Kane's
/// paradox): friction turns a fast-spinning body and changes its normal velocity through the
/// coupling of the rows, so less normal impulse stops the approach than `|v_n| / K`, while the
/// bounce still asks for `e |v_n|`. A 2 kg hull spinning at 115 rad/s that bounced with e = 1
/// and friction 0.5 gained 6 % of its world's energy (the energy property test, sequential
/// impulses; 73 of its long run's 4,800 worlds gained, 5 after). For a lone frictionless
/// contact the limit is `e |v_n|`, Newton's rule, so it changes nothing there. The account is
/// the island's and not the row's because coupled contacts pass energy on: in a Newton's
/// cradle of three balls the struck contact gives back more than it took, the next one takes
/// without giving, and the energy-conserving answer `(-1/3, 2/3, 2/3)` needs both (a
/// per-row limit stops it at the inelastic `(0, 1/2, 1/2)`).
///
/// With the limit, the normal impulses of an island's rows with restitution do no net
/// positive work beyond what rows push out of penetration, and friction rows never do (see
/// [`solve_friction`](super::contact::solve_friction)).
#[derive(Clone, Debug, Default)]
pub struct RestitutionLedger {
    /// Per island: `e^2` times the energy its rows took from approach, less the energy they
    /// gave to separation, J.
    budget: Vec<f32>,
    /// Per body: its island's account, or [`NO_LEDGER`]; empty when there is no account.
    body_account: Vec<u32>,
    /// [`reset`](Self::reset)'s union-find forest and per-root accounts, kept for their
    /// memory only.
    parent: Vec<u32>,
    account: Vec<u32>,
}

impl RestitutionLedger {
    /// Opens an account for each island that has a row with restitution, and gives each such
    /// row its island's ([`ContactConstraint::ledger`]); every other row gets [`NO_LEDGER`].
    /// Islands are joined through dynamic bodies only, numbered in contact order.
    pub fn new(bodies: &[SolverBody], contacts: &mut [ContactConstraint]) -> Self {
        let mut ledger = RestitutionLedger::default();
        ledger.reset(bodies, contacts);
        ledger
    }

    /// [`new`](Self::new) in place: the same accounts, in the memory of the last ones.
    pub fn reset(&mut self, bodies: &[SolverBody], contacts: &mut [ContactConstraint]) {
        let RestitutionLedger {
            budget,
            body_account,
            parent,
            account,
        } = self;
        join_islands(bodies, contacts, parent);
        refill(account, bodies.len(), NO_LEDGER);
        budget.clear();
        body_account.clear();
        for c in contacts.iter_mut() {
            c.ledger = NO_LEDGER;
            if c.restitution <= 0.0 || c.normal_mass == 0.0 {
                continue;
            }
            let Some(r) = contact_island(bodies, c, parent) else {
                continue;
            };
            let r = r as usize;
            if account[r] == NO_LEDGER {
                account[r] = budget.len() as u32;
                budget.push(0.0);
            }
            c.ledger = account[r];
        }
        if !budget.is_empty() {
            body_account.extend((0..bodies.len()).map(|i| account[root(parent, i) as usize]));
        }
    }

    /// No account at all (as [`default`](Default::default)), keeping the memory.
    pub fn close(&mut self) {
        self.budget.clear();
        self.body_account.clear();
    }

    /// Whether any island keeps an account (else nothing needs recording).
    pub fn is_open(&self) -> bool {
        !self.budget.is_empty()
    }

    /// Charges each island's account with the energy a substep's split of gravity (with the
    /// bodies' extra accelerations, `a`) and position integration added to its bodies:
    /// `m h a.(v0 - v1) + m |a|^2 h^2 / 2` a body, where positive, with `v0` its velocity before
    /// the substep's gravity (`before`) and `v1` the one its position is integrated with (now).
    ///
    /// Why: gravity raises a body's kinetic energy by `m a.v0 h + m |a|^2 h^2 / 2` and its
    /// potential falls by `m a.v1 h` only as it moves; where a contact stops it in between, the
    /// rows take the difference as approach energy, which a bounce would give back as if it had
    /// been there before the step: a 3.5 kg ball at 27.6 m/s against a body on the floor, e = 1,
    /// 41 Hz x 8, took 2.9 J a substep that way, and its world gained 22 J (0.3 %) in the step
    /// (the energy property test, soft step, seed 1477).
    pub fn charge_split(&mut self, bodies: &[SolverBody], before: &[Vec3], gravity: Vec3, h: f32) {
        for ((b, &v0), &account) in bodies.iter().zip(before).zip(&self.body_account) {
            if account == NO_LEDGER || b.inverse_mass == 0.0 {
                continue;
            }
            let a = b.acceleration(gravity);
            let excess = h * a.dot(v0 - b.linear_velocity) + 0.5 * a.length_squared() * h * h;
            if excess > 0.0 {
                self.budget[account as usize] -= excess / b.inverse_mass;
            }
        }
    }

    /// Records the work of a normal impulse that took row `c`'s normal velocity from `vn` to
    /// `vn_after` (m/s) by itself (`vn_after = vn + impulse K`, a row-by-row sweep); nothing
    /// for a row without a ledger.
    #[inline]
    pub fn record(&mut self, c: &ContactConstraint, vn: f32, vn_after: f32) {
        if c.ledger == NO_LEDGER {
            return;
        }
        let half_mass = 0.5 * c.normal_mass;
        let approach = |v: f32| half_mass * v.min(0.0) * v.min(0.0);
        let separation = |v: f32| half_mass * v.max(0.0) * v.max(0.0);
        let e2 = c.restitution * c.restitution;
        self.budget[c.ledger as usize] +=
            e2 * (approach(vn) - approach(vn_after)) - (separation(vn_after) - separation(vn));
    }

    /// Records the work of normal impulse `impulse` (N s) on row `c` applied together with
    /// other rows' (a Jacobi sweep), which took the row's normal velocity from `vn` to
    /// `vn_after` (m/s, after every row of the sweep): all the sweep's impulses grow together
    /// along a straight line in velocity, so the row's work is `impulse` times the mean of its
    /// normal velocity along that line, split where it crosses zero. The works of all rows sum
    /// to the change of kinetic energy exactly; for a row alone it is [`record`](Self::record).
    pub fn record_shared(&mut self, c: &ContactConstraint, impulse: f32, vn: f32, vn_after: f32) {
        if c.ledger == NO_LEDGER {
            return;
        }
        let (low, high) = (vn.min(vn_after), vn.max(vn_after));
        let (below, above) = if high <= 0.0 {
            (0.5 * (vn + vn_after), 0.0)
        } else if low >= 0.0 {
            (0.0, 0.5 * (vn + vn_after))
        } else {
            let span = high - low;
            (-0.5 * low * low / span, 0.5 * high * high / span)
        };
        let e2 = c.restitution * c.restitution;
        self.budget[c.ledger as usize] += -e2 * impulse * below - impulse * above;
    }

    /// The fastest separation, m/s, that an impulse from normal velocity `vn` may give row `c`
    /// in a bounce: the one that spends its island's account, counting `e^2` times the approach
    /// this impulse itself stops:
    ///
    /// ```text
    /// v^2 = max(v_n, 0)^2 + e^2 min(v_n, 0)^2 + 2 budget / m
    /// ```
    ///
    /// Unlimited for a row without a ledger.
    #[inline]
    pub fn bounce_limit(&self, c: &ContactConstraint, vn: f32) -> f32 {
        if c.ledger == NO_LEDGER {
            return f32::INFINITY;
        }
        let (approach, separation) = (vn.min(0.0), vn.max(0.0));
        let e2 = c.restitution * c.restitution;
        let v2 = separation * separation
            + e2 * approach * approach
            + 2.0 * self.budget[c.ledger as usize] / c.normal_mass;
        v2.max(0.0).sqrt()
    }

    /// `bounce`, row `c`'s restitution target (NaN: none), within
    /// [`bounce_limit`](Self::bounce_limit) from normal velocity `vn`.
    #[inline]
    pub fn limited_bounce(&self, c: &ContactConstraint, bounce: f32, vn: f32) -> f32 {
        if bounce.is_nan() {
            bounce
        } else {
            bounce.min(self.bounce_limit(c, vn))
        }
    }
}

/// Resets `parent` to one set per body and joins the sets through contacts between dynamic
/// bodies: the islands of the step, as a union-find forest (see [`root`]).
pub(super) fn join_islands(
    bodies: &[SolverBody],
    contacts: &[ContactConstraint],
    parent: &mut Vec<u32>,
) {
    let dynamic = |i: usize| bodies[i].motion == Motion::Dynamic;
    parent.clear();
    parent.extend(0..bodies.len() as u32);
    for c in contacts {
        if dynamic(c.body_a) && dynamic(c.body_b) {
            let (a, b) = (root(parent, c.body_a), root(parent, c.body_b));
            if a != b {
                parent[a.max(b) as usize] = a.min(b);
            }
        }
    }
}

/// The island (its root in `parent`, from [`join_islands`]) of contact `c`'s dynamic body
/// (body A's if both are); `None` if neither is dynamic.
pub(super) fn contact_island(
    bodies: &[SolverBody],
    c: &ContactConstraint,
    parent: &mut [u32],
) -> Option<u32> {
    let dynamic = |i: usize| bodies[i].motion == Motion::Dynamic;
    if dynamic(c.body_a) {
        Some(root(parent, c.body_a))
    } else if dynamic(c.body_b) {
        Some(root(parent, c.body_b))
    } else {
        None
    }
}

/// The root of `i` in the union-find forest `parent`, halving the path on the way.
fn root(parent: &mut [u32], i: usize) -> u32 {
    let mut i = i as u32;
    while parent[i as usize] != i {
        let up = parent[parent[i as usize] as usize];
        parent[i as usize] = up;
        i = up;
    }
    i
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::solver::body::kinetic_energy;
    use crate::dynamics::solver::contact::prepare_contacts;
    use bevy::math::{BVec3, Mat3, Quat, Vec3};

    /// The works `record_shared` books for impulses applied together sum to the change of
    /// kinetic energy (a conservation law: with e = 1 the account is minus that change). Three
    /// dynamic bodies in a chain with a static one, anisotropic inertia, four rows sharing
    /// bodies, 200 seeded draws of velocities and simultaneous impulses of either sign.
    /// Tolerance 1e-4 of the energy scale: f32 velocities, energies summed in f64.
    #[test]
    fn shared_works_sum_to_the_energy_change() {
        let mut seed = 0x0123_4567_89ab_cdefu64;
        let mut unit = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32 - 0.5
        };
        for _ in 0..200 {
            let mut body = |x: f32| {
                let v = Vec3::new(unit(), unit(), unit()) * 4.0;
                let w = Vec3::new(unit(), unit(), unit()) * 8.0;
                let q = Quat::from_scaled_axis(Vec3::new(unit(), unit(), unit()) * 3.0);
                let moments = Vec3::new(1.0 + unit(), 0.3 + unit() * 0.2, 1.2 + unit());
                SolverBody::new(Motion::Dynamic, Vec3::new(x, 0.0, 0.0), q)
                    .with_mass(
                        1.0 + unit(),
                        Mat3::from_diagonal(moments.recip()),
                        false,
                        BVec3::FALSE,
                    )
                    .with_velocity(v, w)
            };
            let mut bodies = vec![
                SolverBody::new(Motion::Static, Vec3::new(-1.0, 0.0, 0.0), Quat::IDENTITY),
                body(0.0),
                body(1.0),
                body(2.0),
            ];
            let n = Vec3::X;
            let mut contacts: Vec<ContactConstraint> = [(0, 1), (1, 2), (2, 3), (1, 3)]
                .iter()
                .map(|&(a, b)| {
                    let point = Vec3::new(a as f32 - 0.5, unit() * 0.4, unit() * 0.4);
                    ContactConstraint::new(a, b, point, n, 0.0, 1.0, 0.0)
                })
                .collect();
            prepare_contacts(&bodies, &mut contacts);
            let mut ledger = RestitutionLedger::new(&bodies, &mut contacts);
            assert_eq!(ledger.budget.len(), 1);
            let before = kinetic_energy(&bodies);
            let start: Vec<f32> = contacts
                .iter()
                .map(|c| c.normal_velocity(&bodies))
                .collect();
            let impulses: Vec<f32> = contacts.iter().map(|_| unit() * 2.0).collect();
            for (c, &j) in contacts.iter().zip(&impulses) {
                c.apply_normal_impulse(&mut bodies, j);
            }
            for ((c, &j), &vn) in contacts.iter().zip(&impulses).zip(&start) {
                ledger.record_shared(c, j, vn, c.normal_velocity(&bodies));
            }
            let change = kinetic_energy(&bodies) - before;
            let scale = before + kinetic_energy(&bodies) + 1.0;
            assert!(
                (ledger.budget[0] as f64 + change).abs() <= 1e-4 * scale,
                "budget {} vs energy change {change}",
                ledger.budget[0]
            );
        }
    }
}
