//! The iterative velocity solvers over all contacts at once: sequential impulses (projected
//! Gauss-Seidel), Jacobi, and Box2D v3's soft step. They share the row maths of
//! [`ContactConstraint`] and differ in how a row's target is set and when its impulse is applied.

use super::body::SolverBody;
use super::contact::{ContactConstraint, solve_friction};

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
}

impl RigidRows {
    /// The smallest normal velocity the row accepts, m/s: the speculative gap `s/h` may close,
    /// penetration beyond the slop is pushed out at `baumgarte (-s - slop) / h`, and an impact
    /// faster than the threshold must separate at `-e v_n`, with `v_n` taken before the solve.
    #[inline]
    pub fn target(&self, c: &ContactConstraint, bodies: &[SolverBody]) -> f32 {
        let s = c.current_separation(bodies);
        let mut target = if s > 0.0 {
            -s * self.inv_h
        } else {
            self.baumgarte * self.inv_h * (-s - self.slop).max(0.0)
        };
        if c.restitution > 0.0 && c.approach_velocity < -self.restitution_threshold {
            target = target.max(-c.restitution * c.approach_velocity);
        }
        target
    }
}

/// One projected Gauss-Seidel sweep: each row in turn, on the latest velocities, accumulated
/// impulse clamped at >= 0. Returns the largest velocity change a row made, m/s.
pub fn sequential_sweep(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    rows: &RigidRows,
) -> f32 {
    let mut largest = 0.0f32;
    for c in contacts.iter_mut() {
        if c.normal_mass == 0.0 {
            continue;
        }
        let vn = c.normal_velocity(bodies);
        let target = rows.target(c, bodies);
        let new = (c.normal_impulse + c.normal_mass * (target - vn)).max(0.0);
        let delta = new - c.normal_impulse;
        if delta != 0.0 {
            c.normal_impulse = new;
            c.apply_normal_impulse(bodies, delta);
            largest = largest.max(delta.abs() / c.normal_mass);
        }
        c.max_normal_impulse = c.max_normal_impulse.max(new);
        if c.friction > 0.0 {
            solve_friction(bodies, c);
        }
    }
    largest
}

/// One Jacobi sweep: every row computes its impulse from the same velocities, then all are
/// applied together. With `split`, each body's inverse mass and inertia are scaled by the
/// number of rows that touch it when computing a row's effective mass (mass splitting), which
/// makes the sweep a convergent averaging instead of an overshooting sum.
/// Returns the largest velocity change a row made, m/s.
pub fn jacobi_sweep(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    rows: &RigidRows,
    counts: &[u32],
    deltas: &mut Vec<f32>,
) -> f32 {
    deltas.clear();
    for c in contacts.iter_mut() {
        if c.normal_mass == 0.0 {
            deltas.push(0.0);
            continue;
        }
        let vn = c.normal_velocity(bodies);
        let target = rows.target(c, bodies);
        let mass = if counts.is_empty() {
            c.normal_mass
        } else {
            split_mass(c, bodies, counts)
        };
        let new = (c.normal_impulse + mass * (target - vn)).max(0.0);
        deltas.push(new - c.normal_impulse);
        c.normal_impulse = new;
        c.max_normal_impulse = c.max_normal_impulse.max(new);
    }
    let mut largest = 0.0f32;
    for (c, &delta) in contacts.iter().zip(deltas.iter()) {
        if delta != 0.0 {
            c.apply_normal_impulse(bodies, delta);
            largest = largest.max(delta.abs() / c.normal_mass);
        }
    }
    for c in contacts.iter_mut().filter(|c| c.friction > 0.0) {
        solve_friction(bodies, c);
    }
    largest
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
/// Returns the largest velocity change a row made, m/s.
pub fn soft_sweep(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    soft: Option<&Softness>,
    inv_h: f32,
    max_push_out: f32,
    leave_impacts: Option<f32>,
) -> f32 {
    let mut largest = 0.0f32;
    for c in contacts.iter_mut() {
        if c.normal_mass == 0.0 {
            continue;
        }
        let s = c.current_separation(bodies);
        if let Some(threshold) = leave_impacts {
            if s > 0.0 && c.normal_velocity(bodies) < -threshold {
                continue;
            }
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
        }
        c.max_normal_impulse = c.max_normal_impulse.max(new);
        if c.friction > 0.0 {
            solve_friction(bodies, c);
        }
    }
    largest
}

/// Box2D v3's restitution pass, after the substeps: a contact that approached faster than
/// `threshold` at preparation and pushed during the step is driven to separate at `-e v_n`,
/// with `v_n` the approach velocity recorded at preparation.
pub fn apply_restitution(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    threshold: f32,
) {
    for c in contacts.iter_mut() {
        if c.restitution == 0.0
            || c.approach_velocity > -threshold
            || c.max_normal_impulse == 0.0
            || c.normal_mass == 0.0
        {
            continue;
        }
        let vn = c.normal_velocity(bodies);
        let impulse = -c.normal_mass * (vn + c.restitution * c.approach_velocity);
        let new = (c.normal_impulse + impulse).max(0.0);
        let delta = new - c.normal_impulse;
        if delta != 0.0 {
            c.normal_impulse = new;
            c.apply_normal_impulse(bodies, delta);
            c.total_impulse += delta;
            c.impact = true;
        }
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
