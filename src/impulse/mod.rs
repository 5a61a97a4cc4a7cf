//! The collision impulse between two rigid bodies, as plain functions usable without an `App`.
//!
//! Bodies A and B touch at point `P` with unit normal `n` pointing from A to B. With
//! `r = P - x` (x the centre of mass), the relative velocity at the contact is
//! `v_rel = (v_B + w_B x r_B) - (v_A + w_A x r_A)` and its normal part is `v_n = v_rel . n`
//! (negative while the bodies approach). For restitution `e` in `[0, 1]` the scalar impulse is
//!
//! ```text
//! j = -(1 + e) v_n / K,
//! K = 1/m_A + 1/m_B + [(I_A^-1 (r_A x n)) x r_A + (I_B^-1 (r_B x n)) x r_B] . n
//! ```
//!
//! and it is applied as `-j n` to A and `+j n` to B, on linear velocity (`v' = v -/+ j n / m`)
//! and on angular velocity (`w' = w -/+ I^-1 (r x j n)`), with `I^-1` the world-space inverse
//! inertia. Static and kinematic bodies have `1/m = 0` and `I^-1 = 0`.
//!
//! Because `((I^-1 u) x r) . n = u . (I^-1 u)` for `u = r x n` and a symmetric `I^-1`,
//! the bracket is computed in the second form, which is cheaper and symmetric by construction.
//!
//! # Examples
//!
//! ```
//! use bevy::math::{Mat3, Vec3};
//! use impact3d::impulse::{ImpulseBody, collision_impulse};
//!
//! // Case 1 of the reference scenes: m1 = 1 at +2 m/s meets m2 = 3 at -1 m/s, e = 0.5.
//! let a = ImpulseBody::sphere_like(1.0, Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0));
//! let b = ImpulseBody::sphere_like(3.0, Vec3::X, Vec3::new(-1.0, 0.0, 0.0));
//! let j = collision_impulse(&a, &b, Vec3::new(0.5, 0.0, 0.0), Vec3::X, 0.5);
//! assert!((j - 3.375).abs() < 1e-5);
//! ```

use bevy::math::{Mat3, Vec3};

/// One side of a contact, as the impulse formula sees it: mass, world inverse inertia, pose and
/// velocities. A static or kinematic body has `inverse_mass = 0` and `inverse_inertia = 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImpulseBody {
    /// `1/m` in 1/kg; zero for static and kinematic bodies.
    pub inverse_mass: f32,
    /// World-space inverse inertia tensor `I^-1 = R I_body^-1 R^T`, in 1/(kg m^2).
    pub inverse_inertia: Mat3,
    /// World position of the centre of mass, in m.
    pub center_of_mass: Vec3,
    /// Linear velocity of the centre of mass, in m/s.
    pub linear_velocity: Vec3,
    /// Angular velocity, world frame, in rad/s.
    pub angular_velocity: Vec3,
}

impl ImpulseBody {
    /// A body that contacts cannot move (static, or kinematic with the given velocities).
    pub fn fixed(center_of_mass: Vec3, linear_velocity: Vec3, angular_velocity: Vec3) -> Self {
        Self {
            inverse_mass: 0.0,
            inverse_inertia: Mat3::ZERO,
            center_of_mass,
            linear_velocity,
            angular_velocity,
        }
    }

    /// A body of mass `mass` whose rotation the contact cannot change (a particle, or a sphere hit
    /// through its centre): its inverse inertia is left at zero.
    pub fn sphere_like(mass: f32, center_of_mass: Vec3, linear_velocity: Vec3) -> Self {
        Self {
            inverse_mass: 1.0 / mass,
            inverse_inertia: Mat3::ZERO,
            center_of_mass,
            linear_velocity,
            angular_velocity: Vec3::ZERO,
        }
    }

    /// Velocity of the material point of this body at world position `point`: `v + w x r`.
    pub fn velocity_at(&self, point: Vec3) -> Vec3 {
        self.linear_velocity + self.angular_velocity.cross(point - self.center_of_mass)
    }

    /// Applies the impulse `impulse` (N s, world frame) at world position `point`.
    pub fn apply_impulse(&mut self, point: Vec3, impulse: Vec3) {
        self.linear_velocity += self.inverse_mass * impulse;
        self.angular_velocity +=
            self.inverse_inertia * (point - self.center_of_mass).cross(impulse);
    }

    /// Kinetic energy `m v^2 / 2 + w.I w / 2` in J, for a body with invertible mass and inertia.
    /// Bodies with `inverse_mass = 0` contribute nothing.
    pub fn kinetic_energy(&self) -> f32 {
        if self.inverse_mass == 0.0 {
            return 0.0;
        }
        let linear = 0.5 * self.linear_velocity.length_squared() / self.inverse_mass;
        let angular = if self.inverse_inertia.determinant().abs() > 0.0 {
            0.5 * self
                .angular_velocity
                .dot(self.inverse_inertia.inverse() * self.angular_velocity)
        } else {
            0.0
        };
        linear + angular
    }
}

/// The normal part of the relative contact velocity, `v_n = v_rel . n`; negative when the bodies
/// approach.
pub fn normal_velocity(a: &ImpulseBody, b: &ImpulseBody, point: Vec3, normal: Vec3) -> f32 {
    (b.velocity_at(point) - a.velocity_at(point)).dot(normal)
}

/// The denominator `K` of the impulse formula: the inverse effective mass of the contact along
/// `normal`, in 1/kg. Zero when neither body can be moved by the contact.
pub fn inverse_effective_mass(a: &ImpulseBody, b: &ImpulseBody, point: Vec3, normal: Vec3) -> f32 {
    let rn_a = (point - a.center_of_mass).cross(normal);
    let rn_b = (point - b.center_of_mass).cross(normal);
    row_inverse_mass(
        [a.inverse_mass, b.inverse_mass],
        [
            rn_a.dot(a.inverse_inertia * rn_a),
            rn_b.dot(b.inverse_inertia * rn_b),
        ],
    )
}

/// `K` in the prepared form the solver runs. A contact row keeps, per body, `u = r x n` and
/// `I^-1 u`, so each body's angular term is `u . (I^-1 u)`, and
///
/// ```text
/// K = (1/m_A + 1/m_B) + (u_A . I_A^-1 u_A + u_B . I_B^-1 u_B),
/// ```
///
/// with `linear` the two inverse masses and `angular` the two angular terms (zero for a row
/// whose lever arms vanish). Every `K` of the solver is computed here: the normal rows
/// ([`prepare_normal_row`](crate::dynamics::solver::ContactConstraint::prepare_normal_row)),
/// the friction rows (with the tangent in place of `n`), Jacobi's mass splitting, the hybrid
/// method's manifold blocks (each row's `K`, the block's mean `K`, and a support's own side
/// when its hold is computed); where a method scales a body's response (Jacobi splits a body's
/// mass among its contacts, the hybrid method holds a support in part), it passes that body's
/// two terms scaled. [`inverse_effective_mass`] is this with the terms of two
/// [`ImpulseBody`]s. (The exact solve of an inelastic event, `solver/lcp.rs`, builds the
/// whole Delassus matrix in f64, whose diagonal is this `K` and whose other entries couple
/// two rows: the one place the formula is generalised rather than called. The friction stick
/// impulse's 2 x 2 tangent matrix calls it for each entry, the linear part on the diagonal.)
///
/// # Examples
///
/// ```
/// use impact3d::impulse::row_inverse_mass;
///
/// // Two unit masses, lever arms along the normal (no angular terms): K = 2.
/// assert_eq!(row_inverse_mass([1.0, 1.0], [0.0, 0.0]), 2.0);
/// ```
#[inline]
pub fn row_inverse_mass(linear: [f32; 2], angular: [f32; 2]) -> f32 {
    (linear[0] + linear[1]) + (angular[0] + angular[1])
}

/// The impulse a row needs to bring its normal velocity from `v_n` to `target`, in the
/// prepared form the solver runs: `j = (target - v_n) / K`, with `normal_mass = 1/K` (from
/// [`row_inverse_mass`]). With `target = -e v_n` it is the seed formula `j = -(1 + e) v_n / K`
/// ([`collision_impulse`]); the solver's rows pass the velocity they must reach (a restitution
/// target, a speculative gap's closing speed, or 0 to stop an approach), and clamp the
/// accumulated impulse to push only.
///
/// # Examples
///
/// ```
/// use impact3d::impulse::{row_impulse, row_inverse_mass};
///
/// // Two unit masses approaching at 2 m/s, e = 1: j = -(1 + 1)(-2) / 2 = 2.
/// let normal_mass = 1.0 / row_inverse_mass([1.0, 1.0], [0.0, 0.0]);
/// assert_eq!(row_impulse(normal_mass, -2.0, 2.0), 2.0);
/// ```
#[inline]
pub fn row_impulse(normal_mass: f32, normal_velocity: f32, target: f32) -> f32 {
    normal_mass * (target - normal_velocity)
}

/// Applies a row's impulse to one body, in the prepared form the solver runs: the linear
/// part `v += impulse / m` (`impulse` is `+j n` for B, `-j n` for A, or the impulse along a
/// held support's free direction), and, where the row has angular terms, the angular part
/// `w += j I^-1 (r x n)` from the row's stored `I^-1 (r x n)` (`turn = (+j or -j, I^-1 (r x
/// n))`: the seed's `w' = w -/+ I^-1 (r x j n)` with the `r x n` computed once per row).
/// `linear: None` leaves the linear velocity untouched (a body held wholly along the normal).
///
/// # Examples
///
/// ```
/// use bevy::math::Vec3;
/// use impact3d::impulse::apply_row_impulse;
///
/// // j = 2 along +x on a 0.5 kg body, with I^-1 (r x n) = (0, 0, 3): dv = 4 x, dw = 6 z.
/// let (mut v, mut w) = (Vec3::ZERO, Vec3::ZERO);
/// apply_row_impulse(&mut v, &mut w, 2.0, Some(2.0 * Vec3::X), Some((2.0, Vec3::Z * 3.0)));
/// assert_eq!((v, w), (Vec3::X * 4.0, Vec3::Z * 6.0));
/// ```
#[inline]
pub fn apply_row_impulse(
    linear_velocity: &mut Vec3,
    angular_velocity: &mut Vec3,
    inverse_mass: f32,
    linear: Option<Vec3>,
    turn: Option<(f32, Vec3)>,
) {
    if let Some(impulse) = linear {
        *linear_velocity += inverse_mass * impulse;
    }
    if let Some((j, angular_response)) = turn {
        *angular_velocity += j * angular_response;
    }
}

/// The scalar impulse `j = -(1 + e) v_n / K` for one contact (see the module docs).
///
/// It is the formula alone: positive for approaching bodies, negative for separating ones, and
/// zero when `K = 0` (a pair of static or kinematic bodies has no impulse). `restitution` is used
/// as given; callers clamp it to `[0, 1]`.
pub fn collision_impulse(
    a: &ImpulseBody,
    b: &ImpulseBody,
    point: Vec3,
    normal: Vec3,
    restitution: f32,
) -> f32 {
    let k = inverse_effective_mass(a, b, point, normal);
    if k <= 0.0 {
        return 0.0;
    }
    -(1.0 + restitution) * normal_velocity(a, b, point, normal) / k
}

/// Resolves one contact as an isolated impact: when the bodies approach, computes `j` with
/// [`collision_impulse`], applies `-j n` to `a` and `+j n` to `b`, and returns `j`. Returns 0 and
/// changes nothing when they do not approach or neither can move.
pub fn resolve_impact(
    a: &mut ImpulseBody,
    b: &mut ImpulseBody,
    point: Vec3,
    normal: Vec3,
    restitution: f32,
) -> f32 {
    if normal_velocity(a, b, point, normal) >= 0.0 {
        return 0.0;
    }
    let j = collision_impulse(a, b, point, normal, restitution);
    if j > 0.0 {
        a.apply_impulse(point, -j * normal);
        b.apply_impulse(point, j * normal);
    }
    j.max(0.0)
}

#[cfg(test)]
mod tests;
