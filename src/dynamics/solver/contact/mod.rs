//! Contact constraints: one per contact point, prepared once per step from the solver bodies,
//! and the row operations every solver stage shares (normal velocity, apply an impulse, current
//! separation).

use bevy::math::{Quat, Vec3};

use super::body::{Motion, PairVelocities, SolverBody, pair_mut};
use super::ledger::{NO_LEDGER, RestitutionLedger};
use crate::impulse::{apply_row_impulse, row_inverse_mass};

mod friction;

pub(crate) use friction::{TangentPlane, solve_plane};
pub use friction::{solve_friction, solve_friction_in, solve_friction_scaled_in};

/// One contact point between bodies `body_a` and `body_b`, with its normal pointing from A to B.
/// Built by the narrow phase with [`ContactConstraint::new`], completed by [`prepare_contacts`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactConstraint {
    /// Index of body A in the solver body slice.
    pub body_a: usize,
    /// Index of body B.
    pub body_b: usize,
    /// Unit normal from A to B, world frame.
    pub normal: Vec3,
    /// Contact point, world frame, m.
    pub point: Vec3,
    /// Signed distance at the start of the step (negative: penetration), m.
    pub separation: f32,
    /// Combined restitution in `[0, 1]`.
    pub restitution: f32,
    /// Combined friction coefficient; 0 skips friction entirely.
    pub friction: f32,
    /// Accumulated normal impulse, N s: the warm-start value on entry, the final one on exit.
    pub normal_impulse: f32,
    /// Accumulated friction impulse along the two tangents, N s.
    pub tangent_impulse: [f32; 2],
    /// This point's share of its manifold's accumulated twist friction, an angular impulse
    /// about the normal, N m s (the hybrid's [`FrictionModel::Manifold`](super::FrictionModel);
    /// zero otherwise). Applied as the pure torque its twist row applies, so that the warm
    /// start puts back exactly what the row reads (see `ManifoldFriction::solve_in`).
    pub twist_impulse: f32,
    /// Normal velocity, m/s, added to the rows' first-order `v_rel . n` for a contact on a face
    /// of a turning kinematic body, carried to its end-of-step pose: the mean normal velocity of
    /// the kinematic body's contact point over the step, `(x(dt) - x(0)) . n / dt`, less the
    /// `(v + w x r) . n` of its start anchor (with the sign of that body's side). The rows then
    /// move the point where the kinematic body's prescribed motion puts it at the end of the
    /// step, not along its start tangent (which falls short by `(cos(theta/2) - cos theta)`,
    /// 3 theta^2 / 8 of the travel, for a turn of theta in the step). Zero for every other
    /// contact.
    pub drive: f32,

    // Filled by `prepare_contacts`.
    /// `r_A = P - x_A` at the start of the step.
    pub anchor_a: Vec3,
    /// `r_B = P - x_B`.
    pub anchor_b: Vec3,
    /// `r_A x n`.
    pub rn_a: Vec3,
    /// `r_B x n`.
    pub rn_b: Vec3,
    /// `I_A^-1 (r_A x n)`: angular velocity change of A per unit impulse (with sign -).
    pub ang_a: Vec3,
    /// `I_B^-1 (r_B x n)`.
    pub ang_b: Vec3,
    /// The angular terms are non-zero: when false (spheres through their centres, particles,
    /// fixed bodies), the rows skip all angular work.
    pub angular: bool,
    /// `1/K`, the effective mass along the normal, kg; 0 when neither body can move.
    pub normal_mass: f32,
    /// `separation - (r_B - r_A) . n`, so that the current separation is this plus the
    /// normal part of the anchors' displacement since the start of the step.
    pub base_separation: f32,
    /// Normal velocity `v_n` at preparation, m/s (negative: approaching).
    pub approach_velocity: f32,
    /// Tangent directions, world frame.
    pub tangents: [Vec3; 2],
    /// The tangent plane's 2 x 2 inverse effective mass `K_t` (the seed formula's denominator
    /// with `t_k`, `t_l` in place of `n`, `n`), as its entries `[k00, k01, k11]`, 1/kg.
    pub tangent_k: [f32; 3],
    /// `I^-1 (r x t)` for A and B and each tangent.
    pub tangent_ang: [[Vec3; 2]; 2],

    // Results of the step.
    /// Largest accumulated normal impulse seen in the step (restitution applies only to contacts
    /// that pushed), N s.
    pub max_normal_impulse: f32,
    /// Total normal impulse applied over the step, all stages, N s.
    pub total_impulse: f32,
    /// The contact was resolved as an impact (approach above the restitution threshold).
    pub impact: bool,
    /// The row's account in the step's [`RestitutionLedger`]
    /// ([`NO_LEDGER`]: none).
    pub ledger: u32,
}

impl ContactConstraint {
    /// A contact as the narrow phase reports it; the rest is filled by [`prepare_contacts`].
    pub fn new(
        body_a: usize,
        body_b: usize,
        point: Vec3,
        normal: Vec3,
        separation: f32,
        restitution: f32,
        friction: f32,
    ) -> Self {
        ContactConstraint {
            body_a,
            body_b,
            normal,
            point,
            separation,
            restitution,
            friction,
            normal_impulse: 0.0,
            tangent_impulse: [0.0; 2],
            twist_impulse: 0.0,
            drive: 0.0,
            anchor_a: Vec3::ZERO,
            anchor_b: Vec3::ZERO,
            rn_a: Vec3::ZERO,
            rn_b: Vec3::ZERO,
            ang_a: Vec3::ZERO,
            ang_b: Vec3::ZERO,
            angular: false,
            normal_mass: 0.0,
            base_separation: separation,
            approach_velocity: 0.0,
            tangents: [Vec3::ZERO; 2],
            tangent_k: [0.0; 3],
            tangent_ang: [[Vec3::ZERO; 2]; 2],
            max_normal_impulse: 0.0,
            total_impulse: 0.0,
            impact: false,
            ledger: super::ledger::NO_LEDGER,
        }
    }

    /// Derives the normal row from the anchors: `r x n`, `I^-1 (r x n)` for each body and the
    /// effective mass `1/K`. A row whose angular terms vanish is marked non-angular.
    pub fn prepare_normal_row(&mut self, a: &SolverBody, b: &SolverBody) {
        self.rn_a = self.anchor_a.cross(self.normal);
        self.rn_b = self.anchor_b.cross(self.normal);
        self.ang_a = a.inverse_inertia * self.rn_a;
        self.ang_b = b.inverse_inertia * self.rn_b;
        let linear = a.inverse_mass + b.inverse_mass;
        let terms = [self.rn_a.dot(self.ang_a), self.rn_b.dot(self.ang_b)];
        let angular = terms[0] + terms[1];
        // Relative 1e-7 is f32 rounding of r x n for r parallel to n: treat it as exactly zero.
        // A turning kinematic body cannot be turned by the contact (no angular term in K), but
        // its rotation still moves the contact point: `w . (r x n)` must stay in the normal
        // velocity, or a spinning kinematic bar passes through a ball without pushing it.
        let driven = |body: &SolverBody, rn: Vec3| {
            body.motion == Motion::Kinematic && body.angular_velocity.dot(rn) != 0.0
        };
        self.angular = angular > 1e-7 * linear.max(f32::MIN_POSITIVE)
            || driven(a, self.rn_a)
            || driven(b, self.rn_b);
        if !self.angular {
            self.rn_a = Vec3::ZERO;
            self.rn_b = Vec3::ZERO;
            self.ang_a = Vec3::ZERO;
            self.ang_b = Vec3::ZERO;
        }
        let k = if self.angular {
            row_inverse_mass([a.inverse_mass, b.inverse_mass], terms)
        } else {
            linear
        };
        self.normal_mass = if k > 0.0 { 1.0 / k } else { 0.0 };
    }

    /// The normal part of the relative velocity at the contact, `v_rel . n`, using
    /// `(w x r) . n = w . (r x n)`, with a turning kinematic body's [`drive`](Self::drive).
    #[inline]
    pub fn normal_velocity(&self, bodies: &[SolverBody]) -> f32 {
        let (a, b) = (&bodies[self.body_a], &bodies[self.body_b]);
        self.normal_velocity_of(
            (a.linear_velocity, a.angular_velocity),
            (b.linear_velocity, b.angular_velocity),
            self.drive,
        )
    }

    /// [`normal_velocity`](Self::normal_velocity) with the bodies' velocities in `v`.
    #[inline]
    pub fn normal_velocity_in(&self, v: &PairVelocities) -> f32 {
        self.normal_velocity_of(
            (v.a.linear, v.a.angular),
            (v.b.linear, v.b.angular),
            self.drive,
        )
    }

    /// [`normal_velocity`](Self::normal_velocity) for the linear and angular velocities `a` of
    /// body A and `b` of B (the bodies' own, or another velocity of theirs, as the push-out's
    /// pseudo-velocity), plus `drive`.
    #[inline]
    pub fn normal_velocity_of(&self, a: (Vec3, Vec3), b: (Vec3, Vec3), drive: f32) -> f32 {
        let mut vn = (b.0 - a.0).dot(self.normal) + drive;
        if self.angular {
            vn += b.1.dot(self.rn_b) - a.1.dot(self.rn_a);
        }
        vn
    }

    /// Applies `+impulse n` to B and `-impulse n` to A.
    #[inline]
    pub fn apply_normal_impulse(&self, bodies: &mut [SolverBody], impulse: f32) {
        let (a, b) = pair_mut(bodies, self.body_a, self.body_b);
        self.apply_normal_impulse_to(
            (
                &mut a.linear_velocity,
                &mut a.angular_velocity,
                a.inverse_mass,
            ),
            (
                &mut b.linear_velocity,
                &mut b.angular_velocity,
                b.inverse_mass,
            ),
            impulse,
        );
    }

    /// [`apply_normal_impulse`](Self::apply_normal_impulse) to the linear and angular
    /// velocities of A and B given with their inverse masses (the bodies' own, or another
    /// velocity of theirs, as the push-out's pseudo-velocity).
    #[inline]
    pub fn apply_normal_impulse_to(
        &self,
        a: (&mut Vec3, &mut Vec3, f32),
        b: (&mut Vec3, &mut Vec3, f32),
        impulse: f32,
    ) {
        let p = impulse * self.normal;
        let angular = self.angular;
        apply_row_impulse(
            a.0,
            a.1,
            a.2,
            Some(-p),
            angular.then_some((-impulse, self.ang_a)),
        );
        apply_row_impulse(
            b.0,
            b.1,
            b.2,
            Some(p),
            angular.then_some((impulse, self.ang_b)),
        );
    }

    /// The separation now, from the bodies' motion since the start of the step: anchors fixed
    /// in each body, moved by its displacement and rotation (first order in the rotation,
    /// exact in the translation). Spheres through their centres ignore rotation, which is exact.
    #[inline]
    pub fn current_separation(&self, bodies: &[SolverBody]) -> f32 {
        let (a, b) = (&bodies[self.body_a], &bodies[self.body_b]);
        let mut d = b.delta_position - a.delta_position;
        if self.angular {
            d += rotate(b.delta_rotation, self.anchor_b) - rotate(a.delta_rotation, self.anchor_a);
        } else {
            d += self.anchor_b - self.anchor_a;
        }
        d.dot(self.normal) + self.base_separation
    }
}

fn rotate(q: Quat, v: Vec3) -> Vec3 {
    if q == Quat::IDENTITY { v } else { q * v }
}

/// Fills the derived fields of each contact from the bodies at the start of the step: anchors,
/// `r x n`, `I^-1 (r x n)`, the effective mass `1/K` (the denominator of the impulse formula of
/// [`crate::impulse`]), the approach velocity and, where friction is on, the tangent rows.
///
/// A contact whose angular terms vanish (both `r x n` zero, or both bodies unable to rotate)
/// is marked non-angular, and every stage then skips its angular work.
pub fn prepare_contacts(bodies: &[SolverBody], contacts: &mut [ContactConstraint]) {
    for c in contacts.iter_mut() {
        let (a, b) = (&bodies[c.body_a], &bodies[c.body_b]);
        c.anchor_a = c.point - a.position;
        c.anchor_b = c.point - b.position;
        c.prepare_normal_row(a, b);
        c.base_separation = c.separation - (c.anchor_b - c.anchor_a).dot(c.normal);
        c.approach_velocity = c.normal_velocity(bodies);
        c.max_normal_impulse = 0.0;
        c.total_impulse = 0.0;
        c.impact = false;
        c.ledger = super::ledger::NO_LEDGER;
        if c.normal_mass == 0.0 {
            c.normal_impulse = 0.0;
        }
        if c.friction > 0.0 {
            let t0 = c.normal.any_orthonormal_vector();
            c.tangents = [t0, c.normal.cross(t0)];
            c.prepare_tangent_rows(a, b);
        } else {
            c.tangent_impulse = [0.0; 2];
            c.twist_impulse = 0.0;
        }
    }
}

/// Re-derives the rows' angular terms (`I^-1 (r x n)`, `I^-1 (r x t)` and the effective masses)
/// from the bodies' current world inverse inertia, for every row that touches a dynamic body
/// whose inertia is not isotropic; the anchors stay those of the start of the step. Called
/// between substeps, after [`integrate_positions`](super::body::integrate_positions) has turned
/// the bodies and refreshed their inertia.
///
/// Why: a row changes a body's spin by `lambda I^-1 (r x n)` and its kinetic energy by
/// `lambda (v_n + v_n') / 2` only when `I` is the inertia the energy is measured with. With the
/// inertia of the start of the step, a body that has turned since gets its spin changed along
/// the wrong axis for its present inertia, and the change of `w . I w / 2` no longer matches
/// what the row's velocities say: a 2 kg hull spinning at 115 rad/s (a quarter turn per step)
/// gained 103 J, 23% of its world's energy, in one rigid bounce with e = 1 (the energy property
/// test, sequential impulses, seed 107), although the row itself reflected its normal velocity
/// exactly.
pub fn refresh_inertia(bodies: &[SolverBody], contacts: &mut [ContactConstraint]) {
    for c in contacts.iter_mut() {
        if !c.inertia_turns(bodies) {
            continue;
        }
        let (a, b) = (&bodies[c.body_a], &bodies[c.body_b]);
        c.prepare_normal_row(a, b);
        if c.friction > 0.0 {
            c.prepare_tangent_rows(a, b);
        }
    }
}

impl ContactConstraint {
    /// Whether [`refresh_inertia`] re-derives this row: it touches a dynamic body whose
    /// inertia is not isotropic.
    #[inline]
    pub fn inertia_turns(&self, bodies: &[SolverBody]) -> bool {
        let turned = |b: &SolverBody| b.motion == Motion::Dynamic && !b.isotropic;
        turned(&bodies[self.body_a]) || turned(&bodies[self.body_b])
    }
}

/// Applies the accumulated impulses (normal and friction) carried over from the previous step
/// or substep (its work recorded in `ledger`, on rows that keep one).
///
/// Consecutive rows of the same two bodies (a manifold's) are applied to their velocities held
/// in locals, read once and written back once (see [`PairVelocities`]): the same operations in
/// the same order.
pub fn warm_start(
    bodies: &mut [SolverBody],
    contacts: &[ContactConstraint],
    ledger: &mut RestitutionLedger,
) {
    let mut held: Option<((usize, usize), PairVelocities)> = None;
    for c in contacts {
        let pushes = c.normal_impulse != 0.0;
        let holds = c.friction > 0.0 && (c.tangent_impulse != [0.0; 2] || c.twist_impulse != 0.0);
        if !pushes && !holds {
            continue;
        }
        let pair = (c.body_a, c.body_b);
        let v = match &mut held {
            Some((p, v)) if *p == pair => v,
            _ => {
                if let Some(((a, b), v)) = held {
                    v.store(bodies, a, b);
                }
                &mut held
                    .insert((pair, PairVelocities::load(bodies, pair.0, pair.1)))
                    .1
            }
        };
        if pushes {
            if c.ledger != NO_LEDGER {
                let vn = c.normal_velocity_in(v);
                ledger.record(c, vn, vn + c.normal_impulse / c.normal_mass);
            }
            c.apply_normal_impulse_to(
                (&mut v.a.linear, &mut v.a.angular, v.a.inverse_mass),
                (&mut v.b.linear, &mut v.b.angular, v.b.inverse_mass),
                c.normal_impulse,
            );
        }
        c.warm_start_friction_in(bodies, v);
    }
    if let Some(((a, b), v)) = held {
        v.store(bodies, a, b);
    }
}

impl ContactConstraint {
    /// Applies the row's accumulated friction (its tangent impulses and its twist share) to its
    /// bodies' velocities in `v`, as a warm start does; `bodies` gives their inverse inertias.
    /// Returns whether it applied any.
    #[inline]
    pub fn warm_start_friction_in(&self, bodies: &[SolverBody], v: &mut PairVelocities) -> bool {
        if self.friction <= 0.0 {
            return false;
        }
        let mut applied = false;
        for k in 0..2 {
            if self.tangent_impulse[k] != 0.0 {
                self.apply_tangent_impulse_in(v, k, self.tangent_impulse[k]);
                applied = true;
            }
        }
        if self.twist_impulse != 0.0 {
            let twist = self.twist_impulse * self.normal;
            v.a.angular -= bodies[self.body_a].inverse_inertia * twist;
            v.b.angular += bodies[self.body_b].inverse_inertia * twist;
            applied = true;
        }
        applied
    }
}

#[cfg(test)]
pub(crate) mod tests;
