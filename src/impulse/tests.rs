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
    for (e, j_expected, w_expected) in [(1.0, 1.065877, -1.538462), (0.5, 0.799408, -0.153846)] {
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
