//! Unit tests of the external forces, gravity scale, damping and speed caps.

use super::*;
use crate::dynamics::solver::Motion;

fn body(v: Vec3) -> SolverBody {
    SolverBody::new(Motion::Dynamic, Vec3::ZERO, Quat::IDENTITY)
        .with_mass(0.5, Mat3::IDENTITY, true, BVec3::FALSE)
        .with_velocity(v, Vec3::new(0.0, 2.0, 0.0))
}

/// `start_step`: the linear acceleration goes to the solver body (the locked component
/// dropped), `v = v0 / (1 + c dt)` and `w = (w0 + alpha dt) / (1 + c dt)` with the locked
/// component zeroed, to the f32 rounding of these few operations (1e-6 relative).
#[test]
fn start_step_hands_over_damps_and_locks() {
    let motion = BodyMotion {
        linear_acceleration: Vec3::new(2.0, 0.0, -4.0),
        angular_acceleration: Vec3::new(0.0, 3.0, 0.0),
        linear_damping: 0.5,
        angular_damping: 1.0,
        locked_translation: BVec3::new(false, false, true),
        ..default()
    };
    let mut b = body(Vec3::new(1.0, 1.0, 1.0));
    let dt = 0.1;
    motion.start_step(&mut b, dt);
    assert_eq!(b.extra_acceleration, Vec3::new(2.0, 0.0, 0.0));
    let expected = Vec3::new(1.0 / 1.05, 1.0 / 1.05, 0.0);
    assert!(
        (b.linear_velocity - expected).length() <= 1e-6,
        "{}",
        b.linear_velocity
    );
    let w = (2.0 + 0.3) / 1.1;
    assert!((b.angular_velocity.y - w).abs() <= 1e-6);
}

/// `end_step`: a locked coordinate is put back exactly (and the free ones are left as the
/// solver left them, bit for bit), and a speed above the cap is scaled to the cap (1e-6
/// relative).
#[test]
fn end_step_locks_and_caps() {
    let motion = BodyMotion {
        linear_acceleration: Vec3::new(0.0, 0.0, 10.0),
        locked_translation: BVec3::new(true, false, false),
        max_linear_speed: 2.0,
        ..default()
    };
    let mut b = body(Vec3::new(3.0, 4.0, 0.0));
    b.position = Vec3::new(0.7, 1.0, 2.0);
    b.ballistic = true;
    motion.end_step(&mut b, Vec3::new(0.25, 0.0, 0.0));
    assert_eq!(b.position, Vec3::new(0.25, 1.0, 2.0));
    assert_eq!(b.linear_velocity.x, 0.0);
    assert!((b.linear_velocity.length() - 2.0).abs() <= 2e-6);
    assert!(b.linear_velocity.y > 0.0 && b.angular_velocity.y == 2.0);
}
