//! Unit tests of the solver bodies.

use super::*;

/// Free fall: a body in contact follows symplectic Euler, y = g h^2 n (n + 1) / 2 after n
/// steps; a ballistic one the exact parabola y = g (n h)^2 / 2. Both reach v = g n h.
/// Tolerance 1e-5 relative: f32 rounding over 100 additions.
#[test]
fn free_fall_symplectic_and_ballistic() {
    for ballistic in [false, true] {
        let mut body = SolverBody::new(Motion::Dynamic, Vec3::ZERO, Quat::IDENTITY).with_mass(
            1.0,
            Mat3::IDENTITY,
            true,
            BVec3::FALSE,
        );
        body.ballistic = ballistic;
        let mut bodies = [body];
        let (g, h, n) = (Vec3::new(0.0, -10.0, 0.0), 0.01, 100);
        for _ in 0..n {
            integrate_velocities(&mut bodies, g, h);
            integrate_positions(&mut bodies, g, h);
        }
        let steps = n as f32;
        let y = if ballistic {
            -5.0 * (h * steps).powi(2)
        } else {
            -5.0 * h * h * steps * (steps + 1.0)
        };
        assert!(
            (bodies[0].position.y - y).abs() <= 1e-5 * y.abs(),
            "{ballistic}"
        );
        assert!((bodies[0].linear_velocity.y + 10.0).abs() <= 1e-5);
    }
}

/// An extra acceleration `a` is integrated with gravity: under `g = -10` and `a = +4` a
/// body falls as under `-6`, `y = -3 h^2 n (n + 1)` in contact and `y = -3 (n h)^2` in
/// free flight (1e-5 relative, f32 rounding over 100 steps). With `a = -g` (a gravity scale
/// of 0) the two cancel exactly: the body keeps its position and velocity bit for bit,
/// in contact or not.
#[test]
fn extra_acceleration_adds_to_gravity() {
    let (g, h, n) = (Vec3::new(0.0, -10.0, 0.0), 0.01, 100);
    for ballistic in [false, true] {
        for (extra, effective) in [(Vec3::new(0.0, 4.0, 0.0), -6.0), (-g, 0.0)] {
            let mut body = SolverBody::new(Motion::Dynamic, Vec3::Y, Quat::IDENTITY)
                .with_mass(1.0, Mat3::IDENTITY, true, BVec3::FALSE)
                .with_velocity(Vec3::X, Vec3::ZERO);
            body.ballistic = ballistic;
            body.extra_acceleration = extra;
            let mut bodies = [body];
            for _ in 0..n {
                integrate_velocities(&mut bodies, g, h);
                integrate_positions(&mut bodies, g, h);
            }
            let steps = n as f32;
            let drop = if ballistic {
                0.5 * effective * (h * steps).powi(2)
            } else {
                0.5 * effective * h * h * steps * (steps + 1.0)
            };
            let b = &bodies[0];
            if effective == 0.0 {
                assert_eq!(b.position.y, 1.0, "{ballistic}");
                assert_eq!(b.linear_velocity, Vec3::X, "{ballistic}");
            } else {
                assert!(
                    (b.position.y - 1.0 - drop).abs() <= 1e-5 * drop.abs(),
                    "{ballistic}: {}",
                    b.position.y
                );
                let v = effective * h * steps;
                assert!((b.linear_velocity.y - v).abs() <= 1e-5 * v.abs());
            }
        }
    }
}

/// Static bodies never move; kinematic bodies ignore gravity and move at their velocity.
#[test]
fn static_and_kinematic_bodies() {
    let mut bodies = [
        SolverBody::new(Motion::Static, Vec3::ONE, Quat::IDENTITY).with_velocity(Vec3::X, Vec3::Y),
        SolverBody::new(Motion::Kinematic, Vec3::ZERO, Quat::IDENTITY)
            .with_velocity(Vec3::X, Vec3::ZERO),
    ];
    for _ in 0..10 {
        integrate_velocities(&mut bodies, Vec3::new(0.0, -10.0, 0.0), 0.1);
        integrate_positions(&mut bodies, Vec3::new(0.0, -10.0, 0.0), 0.1);
    }
    assert_eq!(bodies[0].position, Vec3::ONE);
    assert!((bodies[1].position - Vec3::X).length() <= 1e-6);
}

/// The implicit midpoint rule itself (f64, before the f32 projection) keeps `w.I w` and
/// `|I w|` to 1e-12 relative over 100 steps of `h |w|` = 3.3 rad (a box at 200 rad/s at
/// 60 Hz, the case the one-step implicit Euler got wrong): f64 rounding (1e-16) times the
/// Newton tolerance's 1e-12 per step, with room.
#[test]
fn midpoint_rule_conserves_both_invariants() {
    let inertia = DMat3::from_diagonal(DVec3::new(0.0433, 0.0867, 0.1133));
    let mut w = DVec3::new(0.48, 0.8, 0.36) * 200.0;
    let (e0, l0) = (w.dot(inertia * w), (inertia * w).length());
    for _ in 0..100 {
        w = midpoint_rotation(inertia, w, 1.0 / 60.0).expect("converges");
        let (e, l) = (w.dot(inertia * w), (inertia * w).length());
        assert!((e / e0 - 1.0).abs() <= 1e-12, "energy {e0} -> {e}");
        assert!((l / l0 - 1.0).abs() <= 1e-12, "|L| {l0} -> {l}");
    }
    // It is not the identity: the box tumbles.
    assert!((w.normalize() - DVec3::new(0.48, 0.8, 0.36)).length() > 0.1);
}

/// A turn owed to an impact (`impact_rotation`) together with a fast spin: integrating the
/// positions turns the body without a torque, so its rotational energy `w . I w / 2` is
/// what it was (to f32 rounding, 1e-6 relative), whatever the two rotations. A box with
/// three different moments, spinning at 165 rad/s about a general axis (2.75 rad in the
/// 1/60 s substep) and owed a 0.5 rad turn about another axis. (With one rotation by the
/// sum `w h + turn` the first case's energy rose 19%, 588 J to 698 J; in the energy
/// property test a capsule gained 1.7% of its world's energy so, sequential impulses,
/// seed 21.)
#[test]
fn owed_turn_keeps_spin_energy() {
    let inverse = Vec3::new(1.0 / 0.02, 1.0 / 0.05, 1.0 / 0.06);
    for turn in [
        Vec3::new(0.0, 0.0, 0.5),
        Vec3::new(0.3, -0.2, 0.1),
        Vec3::new(-0.4, 0.25, 0.0),
    ] {
        let mut body = SolverBody::new(Motion::Dynamic, Vec3::ZERO, Quat::from_rotation_x(0.3))
            .with_mass(1.0, Mat3::from_diagonal(inverse), false, BVec3::FALSE)
            .with_velocity(Vec3::ZERO, Vec3::new(0.48, 0.8, 0.36).normalize() * 165.0);
        let (e0, _) = spin_state(&body);
        body.impact_rotation = turn;
        let mut bodies = [body];
        integrate_positions(&mut bodies, Vec3::ZERO, 1.0 / 60.0);
        let (e1, _) = spin_state(&bodies[0]);
        assert!((e1 / e0 - 1.0).abs() <= 1e-6, "{turn}: {e0} -> {e1}");
    }
}

/// Kinetic energy `w.I w / 2` and angular momentum `I w` of a free body.
fn spin_state(b: &SolverBody) -> (f32, Vec3) {
    let l = b.inverse_inertia.inverse() * b.angular_velocity;
    (0.5 * b.angular_velocity.dot(l), l)
}

/// Torque-free tumbling, 10 s at 4 substeps of 1/240 s: kinetic energy never rises (to
/// 1e-5 relative, f32 rounding), angular momentum keeps its direction and loses little
/// magnitude. Bodies: an asymmetric box spun about all axes, and the lab's thin bar
/// (1 m x 2 cm x 2 cm, 1 kg) spinning at 3.2 rad/s about its long axis's normal with a
/// 0.01 rad/s wobble, whose energy the explicit update multiplied by 150 in one second.
#[test]
fn tumbling_never_gains_energy() {
    let bar = {
        let i = |a: f32, b: f32| (a * a + b * b) / 12.0;
        Vec3::new(1.0 / i(0.02, 0.02), 1.0 / i(1.0, 0.02), 1.0 / i(1.0, 0.02))
    };
    for (inverse, w0, momentum_tolerance) in [
        (Vec3::new(1.0, 0.5, 0.25), Vec3::new(1.0, 2.0, 0.5), 0.05),
        (bar, Vec3::new(0.01, 0.0, 3.2), 1e-3),
    ] {
        let mut bodies = [SolverBody::new(Motion::Dynamic, Vec3::ZERO, Quat::IDENTITY)
            .with_mass(1.0, Mat3::from_diagonal(inverse), false, BVec3::FALSE)
            .with_velocity(Vec3::ZERO, w0)];
        let (ke0, l0) = spin_state(&bodies[0]);
        for _ in 0..2400 {
            integrate_velocities(&mut bodies, Vec3::ZERO, 1.0 / 240.0);
            integrate_positions(&mut bodies, Vec3::ZERO, 1.0 / 240.0);
            let (ke, _) = spin_state(&bodies[0]);
            assert!(ke <= ke0 * (1.0 + 1e-5), "{w0}: energy rose {ke0} -> {ke}");
        }
        let (_, l1) = spin_state(&bodies[0]);
        // The implicit step damps a little: the bound is what it must stay within.
        assert!(
            (l1 - l0).length() <= momentum_tolerance * l0.length(),
            "{w0}: {l0} -> {l1}"
        );
    }
}
