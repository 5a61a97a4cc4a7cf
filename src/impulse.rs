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
/// two rows: the one place the formula is generalised rather than called.)
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
mod tests {
    //! The closed-form cases of the reference scenes (cases 1, 2, 4, 5, 6, 7). Tolerance 1e-5:
    //! the expected values are quoted to six digits and the arithmetic is a handful of f32
    //! operations on numbers of order 1, whose rounding error is about 1e-7.
    use super::*;

    const TOL: f32 = 1e-5;

    fn close(actual: f32, expected: f32) -> bool {
        (actual - expected).abs() <= TOL
    }

    /// Case 1: head-on, 1D, m1 = 1 at +2, m2 = 3 at -1, for e in {0, 0.5, 1}.
    #[test]
    fn head_on_matches_closed_form() {
        for (e, v1, v2, j_expected) in [
            (0.0, -0.25, -0.25, 2.25),
            (0.5, -1.375, 0.125, 3.375),
            (1.0, -2.5, 0.5, 4.5),
        ] {
            let mut a = ImpulseBody::sphere_like(1.0, Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0));
            let mut b = ImpulseBody::sphere_like(3.0, Vec3::X, Vec3::new(-1.0, 0.0, 0.0));
            let ke_before = a.kinetic_energy() + b.kinetic_energy();
            let j = resolve_impact(&mut a, &mut b, Vec3::new(0.5, 0.0, 0.0), Vec3::X, e);
            assert!(close(j, j_expected), "e={e}: j={j}");
            assert!(
                close(a.linear_velocity.x, v1),
                "e={e}: v1'={}",
                a.linear_velocity.x
            );
            assert!(
                close(b.linear_velocity.x, v2),
                "e={e}: v2'={}",
                b.linear_velocity.x
            );
            // Energy lost = mu (1 - e^2) (v1 - v2)^2 / 2 with mu = 3/4, v1 - v2 = 3.
            let lost = ke_before - a.kinetic_energy() - b.kinetic_energy();
            assert!(
                close(lost, 0.5 * 0.75 * (1.0 - e * e) * 9.0),
                "e={e}: lost {lost}"
            );
        }
    }

    /// Case 2: oblique equal spheres, frictionless; B at rest, A at (1,0,0) spinning (0,0,5),
    /// normal at 30 degrees. Spins and tangential velocities do not change.
    #[test]
    fn oblique_spheres_keep_spin_and_tangential_velocity() {
        let angle = 30f32.to_radians();
        let n = Vec3::new(angle.cos(), angle.sin(), 0.0);
        for (e, va, vb) in [
            (1.0, (0.25, -0.433013), (0.75, 0.433013)),
            (0.8, (0.325, -0.389711), (0.675, 0.389711)),
        ] {
            // Solid spheres of radius 0.5 and mass 1: I = 2/5 m R^2 = 0.1.
            let inv_i = Mat3::from_diagonal(Vec3::splat(10.0));
            let mut a = ImpulseBody {
                inverse_mass: 1.0,
                inverse_inertia: inv_i,
                center_of_mass: Vec3::ZERO,
                linear_velocity: Vec3::X,
                angular_velocity: Vec3::new(0.0, 0.0, 5.0),
            };
            let mut b = ImpulseBody {
                center_of_mass: n,
                linear_velocity: Vec3::ZERO,
                angular_velocity: Vec3::ZERO,
                ..a
            };
            resolve_impact(&mut a, &mut b, 0.5 * n, n, e);
            assert!(close(a.linear_velocity.x, va.0) && close(a.linear_velocity.y, va.1));
            assert!(close(b.linear_velocity.x, vb.0) && close(b.linear_velocity.y, vb.1));
            assert_eq!(a.angular_velocity, Vec3::new(0.0, 0.0, 5.0));
            assert_eq!(b.angular_velocity, Vec3::ZERO);
        }
    }

    /// A thin rod of length 1 and mass 1 with `I = 1/12` about axes perpendicular to it (z and,
    /// for a rod along x, y), tilted `theta` from horizontal in the xy plane.
    fn rod(theta: f32, linear_velocity: Vec3, angular_velocity: Vec3) -> (ImpulseBody, Vec3) {
        let axis = Vec3::new(theta.cos(), theta.sin(), 0.0);
        // I_body = diag(0, 1/12, 1/12) along (axis, perpendiculars); the rod's own axis carries
        // no inertia, so its inverse is taken as zero there (no torque can act along it here).
        let perp = Vec3::new(-theta.sin(), theta.cos(), 0.0);
        let inv_i = 12.0
            * (Mat3::from_cols(perp, Vec3::ZERO, Vec3::ZERO)
                * Mat3::from_cols(perp, Vec3::ZERO, Vec3::ZERO).transpose()
                + Mat3::from_diagonal(Vec3::Z));
        let body = ImpulseBody {
            inverse_mass: 1.0,
            inverse_inertia: inv_i,
            center_of_mass: Vec3::ZERO,
            linear_velocity,
            angular_velocity,
        };
        // The lower end touches the ground.
        (body, -0.5 * axis)
    }

    /// Case 4: thin rod landing on one end, e = 1, for theta in {30, 45, 60} degrees.
    #[test]
    fn rod_landing_on_one_end() {
        for (deg, vy, wz) in [
            (30.0f32, -0.384615, -3.197632),
            (45.0, -0.2, -3.394113),
            (60.0, 0.142857, -3.428571),
        ] {
            let (mut body, end) = rod(deg.to_radians(), Vec3::new(0.0, -1.0, 0.0), Vec3::ZERO);
            let mut ground = ImpulseBody::fixed(end - Vec3::Y, Vec3::ZERO, Vec3::ZERO);
            let ke_before = body.kinetic_energy_rod();
            resolve_impact(&mut ground, &mut body, end, Vec3::Y, 1.0);
            assert!(
                close(body.linear_velocity.y, vy),
                "{deg}: vy'={}",
                body.linear_velocity.y
            );
            // The lower end is at -x, so the upward impulse there spins the rod about -z.
            assert!(
                close(body.angular_velocity.z, wz),
                "{deg}: w'={}",
                body.angular_velocity.z
            );
            assert!(
                close(body.kinetic_energy_rod(), ke_before),
                "{deg}: energy changed"
            );
        }
    }

    /// Case 5: spinning rod, centre at rest, end touching the ground at 30 degrees, w0 = 4.
    #[test]
    fn spinning_rod_end_strikes_ground() {
        let theta = 30f32.to_radians();
        for (e, j_expected, w_expected) in [(1.0, 1.065877, -1.538462), (0.5, 0.799408, -0.153846)]
        {
            // Spin +4 about z drives the lower end (-x, -y) downward at (L/2) w0 cos(theta).
            let (mut body, end) = rod(theta, Vec3::ZERO, Vec3::new(0.0, 0.0, 4.0));
            let mut ground = ImpulseBody::fixed(end - Vec3::Y, Vec3::ZERO, Vec3::ZERO);
            let j = resolve_impact(&mut ground, &mut body, end, Vec3::Y, e);
            assert!(close(j, j_expected), "e={e}: j={j}");
            assert!(close(body.linear_velocity.y, j), "v' = j/m upward");
            assert!(
                close(body.angular_velocity.z, w_expected),
                "e={e}: w'={}",
                body.angular_velocity.z
            );
        }
    }

    /// Case 6: a ball at -3 m/s hits a wall moving at +2 m/s with e = 0.8; it leaves at +6 m/s.
    #[test]
    fn moving_kinematic_wall() {
        let mut wall = ImpulseBody::fixed(Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0), Vec3::ZERO);
        let mut ball = ImpulseBody::sphere_like(1.0, Vec3::X, Vec3::new(-3.0, 0.0, 0.0));
        resolve_impact(&mut wall, &mut ball, Vec3::new(0.5, 0.0, 0.0), Vec3::X, 0.8);
        assert!(
            close(ball.linear_velocity.x, 6.0),
            "{}",
            ball.linear_velocity.x
        );
        assert_eq!(wall.linear_velocity, Vec3::new(2.0, 0.0, 0.0));
        // Two fixed bodies: K = 0, no impulse.
        let mut other = ImpulseBody::fixed(Vec3::X, Vec3::new(-1.0, 0.0, 0.0), Vec3::ZERO);
        assert_eq!(
            resolve_impact(&mut wall, &mut other, Vec3::X, Vec3::X, 1.0),
            0.0
        );
    }

    /// Case 7: for any single impulse, delta KE = -(1 - e^2) v_n^2 / (2K), and linear and angular
    /// momentum (about the origin) are conserved. Checked on an off-centre box-box contact.
    #[test]
    fn energy_identity_and_momentum_for_an_off_centre_impact() {
        let inv_a = Mat3::from_diagonal(Vec3::new(6.0, 3.0, 2.0));
        let rot = bevy::math::Quat::from_rotation_y(0.4) * bevy::math::Quat::from_rotation_x(0.3);
        let inv_b = Mat3::from_quat(rot)
            * Mat3::from_diagonal(Vec3::new(1.5, 4.0, 2.5))
            * Mat3::from_quat(rot).transpose();
        for e in [0.0, 0.3, 1.0] {
            let mut a = ImpulseBody {
                inverse_mass: 0.5,
                inverse_inertia: inv_a,
                center_of_mass: Vec3::new(0.0, 0.0, 0.0),
                linear_velocity: Vec3::new(1.0, 0.2, -0.1),
                angular_velocity: Vec3::new(0.3, -0.5, 0.8),
            };
            let mut b = ImpulseBody {
                inverse_mass: 0.25,
                inverse_inertia: inv_b,
                center_of_mass: Vec3::new(1.2, 0.3, 0.1),
                linear_velocity: Vec3::new(-0.5, 0.0, 0.3),
                angular_velocity: Vec3::new(-0.2, 0.4, 0.1),
            };
            let (p, n) = (
                Vec3::new(0.6, 0.35, 0.2),
                Vec3::new(0.9, 0.3, 0.1).normalize(),
            );
            let vn = normal_velocity(&a, &b, p, n);
            let k = inverse_effective_mass(&a, &b, p, n);
            let momentum = |a: &ImpulseBody, b: &ImpulseBody| {
                a.linear_velocity / a.inverse_mass + b.linear_velocity / b.inverse_mass
            };
            let angular = |x: &ImpulseBody| {
                x.center_of_mass.cross(x.linear_velocity / x.inverse_mass)
                    + x.inverse_inertia.inverse() * x.angular_velocity
            };
            let (ke0, p0, l0) = (
                a.kinetic_energy() + b.kinetic_energy(),
                momentum(&a, &b),
                angular(&a) + angular(&b),
            );
            resolve_impact(&mut a, &mut b, p, n, e);
            let ke1 = a.kinetic_energy() + b.kinetic_energy();
            assert!(
                close(ke1 - ke0, -(1.0 - e * e) * vn * vn / (2.0 * k)),
                "e={e}"
            );
            assert!((momentum(&a, &b) - p0).length() <= TOL);
            assert!((angular(&a) + angular(&b) - l0).length() <= TOL);
            // With e = 1 the contact leaves separating at the speed it approached.
            assert!(close(normal_velocity(&a, &b, p, n), -e * vn));
        }
    }

    impl ImpulseBody {
        /// Kinetic energy of the thin rod of `rod()`, whose inverse inertia is singular along the
        /// rod's own axis (no spin about it is ever produced here).
        fn kinetic_energy_rod(&self) -> f32 {
            0.5 * self.linear_velocity.length_squared() / self.inverse_mass
                + 0.5 * self.angular_velocity.length_squared() / 12.0
        }
    }
}
