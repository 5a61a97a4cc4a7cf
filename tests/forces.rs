//! Forces and motion controls, whole-app under `MinimalPlugins` at 60 Hz: constant forces and
//! torques, one-off forces and impulses through `Forces`, gravity scale, damping, speed caps,
//! translation locks, `SleepingDisabled`, `RigidBodyDisabled`, `ColliderDisabled`, the physics
//! clock, and bad input. Each answer is worked out independently of the plugin (closed forms of
//! the integrators, the impulse formula in f64, geometry).

mod common;

use bevy::ecs::system::RunSystemOnce;
use bevy::prelude::*;
use common::*;
use impact3d::impulse::ImpulseBody;
use impact3d::prelude::*;
use impact3d::scenes::{self, headless_app, run_steps};

const DT: f32 = 1.0 / 60.0;
const G: f32 = 9.81;

/// A 60 Hz app without gravity.
fn weightless_app() -> App {
    let mut app = headless_app(60.0);
    app.insert_resource(Gravity(Vec3::ZERO));
    app
}

/// A constant force on a free body (no contact, gravity on): the solver moves a free body on
/// the exact parabola of gravity, and the force's acceleration follows the same law (see
/// `impact3d::dynamics::forces`), so after `n` steps `x = F t^2 / 2m` and `y = -g t^2 / 2`,
/// `v = (F/m t, -g t)`. Tolerance 1e-5 relative: f32 rounding over 60 steps of 4 substeps.
/// The symplectic Euler form `a dt^2 n (n + 1) / 2` is `a dt^2 n / 2` farther (1.7% of the
/// distance at n = 60); the free body is on the parabola, closer than a tenth of that.
#[test]
fn constant_force_free_body_follows_the_parabola() {
    let mut app = headless_app(60.0);
    let (mass, force) = (2.0, 3.0);
    let body = app
        .world_mut()
        .spawn((
            scenes::ball(0.25, mass, Vec3::new(0.0, 100.0, 0.0), Vec3::ZERO),
            ConstantForce::new(force, 0.0, 0.0),
        ))
        .id();
    let n = 60;
    run_steps(&mut app, n);
    let t = n as f32 * DT;
    let a = force / mass;
    let p = position(&app, body);
    let exact = 0.5 * a * t * t;
    assert!((p.x - exact).abs() <= 1e-5 * exact, "x {} vs {exact}", p.x);
    let fall = 0.5 * G * t * t;
    assert!(((100.0 - p.y) - fall).abs() <= 1e-4 * fall, "y {}", p.y);
    let v = velocity(&app, body);
    assert!((v.x - a * t).abs() <= 1e-5 * a * t, "vx {}", v.x);
    let symplectic = 0.5 * a * DT * DT * (n * (n + 1)) as f32;
    assert!((p.x - exact).abs() < 0.1 * (symplectic - exact));
}

/// A constant force on a box sliding on a frictionless floor (in contact every step, so the
/// solver's symplectic Euler, substep by substep, as for gravity): with `N = 4 n` substeps of
/// `h = dt / 4`, `x_N = a h^2 N (N + 1) / 2` (velocity first, then position), `a = F / m`, to
/// f32 rounding (1e-5 relative); against the exact `a t^2 / 2` it is ahead by `a h^2 N / 2`,
/// which the test checks as the bound.
#[test]
fn constant_force_in_contact_is_symplectic_euler() {
    let mut app = headless_app(60.0);
    scenes::ground(app.world_mut());
    let (mass, force) = (4.0, 6.0);
    let cube = app
        .world_mut()
        .spawn((
            scenes::cuboid(Vec3::splat(0.5), mass, Vec3::new(0.0, 0.5, 0.0)),
            ConstantForce::new(force, 0.0, 0.0),
        ))
        .id();
    let n = 90;
    run_steps(&mut app, n);
    let a = force / mass;
    let x = position(&app, cube).x;
    let (h, substeps) = (DT / 4.0, 4 * n);
    let symplectic = 0.5 * a * h * h * (substeps * (substeps + 1)) as f32;
    assert!(
        (x - symplectic).abs() <= 1e-5 * symplectic,
        "{x} vs {symplectic}"
    );
    let t = n as f32 * DT;
    let bound = 0.5 * a * h * h * substeps as f32;
    assert!((x - 0.5 * a * t * t).abs() <= bound * 1.001, "{x}");
    assert!((velocity(&app, cube).x - a * t).abs() <= 1e-5 * a * t);
    // Resting on the floor all along.
    assert!((position(&app, cube).y - 0.5).abs() < 1e-3);
}

/// A constant torque on a sphere (isotropic, so no gyroscopic term): `alpha = tau / I` with
/// `I = 2/5 m r^2`; after `n` steps `w = alpha n dt` and the turn is `alpha dt^2 n (n+1) / 2`
/// (symplectic Euler). Tolerances: 1e-5 relative on `w` (f32 rounding), 1e-5 rad on the
/// angle (quaternion composition over 240 substeps).
#[test]
fn constant_torque_on_a_sphere() {
    let mut app = weightless_app();
    let (mass, radius, torque) = (2.0, 0.5, 0.3);
    let ball = app
        .world_mut()
        .spawn((
            scenes::ball(radius, mass, Vec3::ZERO, Vec3::ZERO),
            ConstantTorque::new(0.0, 0.0, torque),
        ))
        .id();
    let n = 60;
    run_steps(&mut app, n);
    let alpha = torque / (0.4 * mass * radius * radius);
    let w = spin(&app, ball);
    let expected = alpha * n as f32 * DT;
    assert!(
        (w.z - expected).abs() <= 1e-5 * expected,
        "{w} vs {expected}"
    );
    assert!(w.x == 0.0 && w.y == 0.0);
    let (axis, angle) = rotation(&app, ball).to_axis_angle();
    let turned = 0.5 * alpha * DT * DT * (n * (n + 1)) as f32;
    assert!(
        (axis.z * angle - turned).abs() <= 1e-5,
        "{angle} vs {turned}"
    );
    assert_eq!(position(&app, ball), Vec3::ZERO);
}

/// An impulse at a point through `Forces` changes the velocities at once by the seed formula:
/// bit for bit what `ImpulseBody::apply_impulse` (the code that applies a contact impulse)
/// gives, and, in f64 from the box's inertia `m (b^2 + c^2) / 12`, `dv = J/m` and
/// `dw = R I_b^-1 R^T (r x J)` to 1e-6 relative (f32 rounding).
#[test]
fn impulse_at_a_point_is_the_seed_formula() {
    let mut app = weightless_app();
    let (mass, half) = (3.0, Vec3::new(0.5, 0.25, 1.0));
    let rot = Quat::from_euler(EulerRot::XYZ, 0.3, -0.7, 1.1);
    let (v0, w0) = (Vec3::new(1.0, -2.0, 0.5), Vec3::ZERO);
    let cube = app
        .world_mut()
        .spawn((
            scenes::cuboid(half, mass, Vec3::new(1.0, 2.0, 3.0)),
            LinearVelocity(v0),
        ))
        .insert(Transform::from_xyz(1.0, 2.0, 3.0).with_rotation(rot))
        .id();
    run_steps(&mut app, 1); // derives the mass
    let (impulse, point) = (Vec3::new(0.4, 1.5, -0.8), Vec3::new(1.3, 2.6, 2.2));
    let before = (
        position(&app, cube),
        rotation(&app, cube),
        velocity(&app, cube),
    );
    assert_eq!(before.2, v0);
    let computed = *app.world().get::<ComputedMass>(cube).unwrap();
    app.world_mut()
        .run_system_once(move |mut q: Query<Forces>| {
            q.single_mut()
                .unwrap()
                .apply_linear_impulse_at_point(impulse, point);
        })
        .unwrap();
    let (v, w) = (velocity(&app, cube), spin(&app, cube));

    let mut seed = ImpulseBody {
        inverse_mass: computed.inverse_mass,
        inverse_inertia: computed.world_inverse_inertia(before.1.normalize(), BVec3::FALSE),
        center_of_mass: before.0,
        linear_velocity: v0,
        angular_velocity: w0,
    };
    seed.apply_impulse(point, impulse);
    assert_eq!((v, w), (seed.linear_velocity, seed.angular_velocity));

    // Independently, in f64.
    let m = mass as f64;
    let size = (half * 2.0).as_dvec3();
    let inertia = bevy::math::DVec3::new(
        m * (size.y * size.y + size.z * size.z) / 12.0,
        m * (size.x * size.x + size.z * size.z) / 12.0,
        m * (size.x * size.x + size.y * size.y) / 12.0,
    );
    let r = bevy::math::DMat3::from_quat(before.1.as_dquat().normalize());
    let world_inverse = r * bevy::math::DMat3::from_diagonal(inertia.recip()) * r.transpose();
    let lever = (point - before.0).as_dvec3();
    let dw = world_inverse * lever.cross(impulse.as_dvec3());
    let dv = impulse.as_dvec3() / m;
    assert!(((v - v0).as_dvec3() - dv).length() <= 1e-6 * dv.length());
    assert!(
        ((w - w0).as_dvec3() - dw).length() <= 1e-6 * dw.length(),
        "{w} vs {dw}"
    );
}

/// A force applied through `Forces` acts on the next step only: after it, `v = F/m dt`, and
/// the step after leaves `v` as it is (no gravity). A force at a point off the centre of mass
/// also gives the torque `r x F`: on a sphere, `w = (r x F) / I dt`. Angular and linear
/// impulses change the velocities at once. Tolerance 1e-5 relative (f32 rounding).
#[test]
fn forces_act_for_one_step_and_impulses_at_once() {
    let mut app = weightless_app();
    let (mass, radius) = (2.0, 0.5);
    let ball = app
        .world_mut()
        .spawn(scenes::ball(radius, mass, Vec3::ZERO, Vec3::ZERO))
        .id();
    run_steps(&mut app, 1);
    let (force, lever) = (Vec3::new(0.0, 4.0, 0.0), Vec3::new(0.5, 0.0, 0.0));
    app.world_mut()
        .run_system_once(move |mut q: Query<Forces>| {
            let mut f = q.single_mut().unwrap();
            let point = f.center_of_mass() + lever;
            f.apply_force_at_point(force, point);
        })
        .unwrap();
    assert_eq!(
        velocity(&app, ball),
        Vec3::ZERO,
        "a force waits for the step"
    );
    run_steps(&mut app, 1);
    let inertia = 0.4 * mass * radius * radius;
    let (v1, w1) = (velocity(&app, ball), spin(&app, ball));
    let expected_v = force / mass * DT;
    let expected_w = lever.cross(force) / inertia * DT;
    assert!(
        (v1 - expected_v).length() <= 1e-5 * expected_v.length(),
        "{v1}"
    );
    assert!(
        (w1 - expected_w).length() <= 1e-5 * expected_w.length(),
        "{w1}"
    );
    run_steps(&mut app, 1);
    assert_eq!((velocity(&app, ball), spin(&app, ball)), (v1, w1));
    app.world_mut()
        .run_system_once(|mut q: Query<Forces>| {
            let mut f = q.single_mut().unwrap();
            f.apply_linear_impulse(Vec3::new(2.0, 0.0, 0.0));
            f.apply_angular_impulse(Vec3::new(0.0, 0.2, 0.0));
        })
        .unwrap();
    let (v2, w2) = (velocity(&app, ball), spin(&app, ball));
    assert!((v2 - v1 - Vec3::new(1.0, 0.0, 0.0)).length() <= 1e-6);
    assert!((w2 - w1 - Vec3::new(0.0, 0.2 / inertia, 0.0)).length() <= 1e-5);
}

/// Gravity scale: 0 floats, 2 falls twice as far as 1 in the same time (ratio 2 to 1e-4, f32
/// rounding), -1 rises as far as 1 falls, and `GravityScale(1.0)` is bit-identical to no
/// component. A floating body has no drift at all, at y = 1 as at y = 100: its extra
/// acceleration is `(0 - 1) g = -g` exactly, the solver integrates `g + (-g)`, which is 0 in
/// IEEE arithmetic, so its velocity and position get exactly zero added.
#[test]
fn gravity_scale() {
    let mut app = headless_app(60.0);
    let y0 = 100.0;
    let mut spawn = |x: f32, y: f32, scale: Option<f32>| {
        let mut e =
            app.world_mut()
                .spawn(scenes::ball(0.25, 1.0, Vec3::new(x, y, 0.0), Vec3::ZERO));
        if let Some(s) = scale {
            e.insert(GravityScale(s));
        }
        e.id()
    };
    let plain = spawn(0.0, y0, None);
    let one = spawn(2.0, y0, Some(1.0));
    let two = spawn(6.0, y0, Some(2.0));
    let up = spawn(8.0, y0, Some(-1.0));
    let zero = spawn(4.0, 1.0, Some(0.0));
    let zero_high = spawn(10.0, y0, Some(0.0));
    run_steps(&mut app, 120);
    let drop = |e| y0 - position(&app, e).y;
    assert_eq!(
        snapshot(&app, &[plain])[0][1..],
        snapshot(&app, &[one])[0][1..]
    );
    assert_eq!(position(&app, zero), Vec3::new(4.0, 1.0, 0.0));
    assert_eq!(position(&app, zero_high), Vec3::new(10.0, y0, 0.0));
    assert_eq!(velocity(&app, zero), Vec3::ZERO);
    assert_eq!(velocity(&app, zero_high), Vec3::ZERO);
    let fall = 0.5 * G * 4.0;
    assert!((drop(plain) - fall).abs() <= 1e-4 * fall);
    assert!(
        (drop(two) / drop(plain) - 2.0).abs() <= 1e-4,
        "{}",
        drop(two)
    );
    assert!((drop(up) / drop(plain) + 1.0).abs() <= 1e-4, "{}", drop(up));
}

/// `GravityScale(0.0)` bodies that touch something do not creep, under every method (kept
/// awake for 2 s with `SleepingDisabled`, where creep would show): a box placed on the floor,
/// and a ball pressed against a frictionless wall by 1 N. The extra acceleration `-g` is
/// integrated with gravity substep by substep, so the two cancel exactly in every substep (the
/// start-of-step velocity change `-g dt` of the first version made them rise
/// `g dt^2 (n - 1) / 2n`, 1.0 mm a step: the box rose 2.6 cm before it lost the floor, the ball
/// 3.1 cm). Bound: 1e-6 m on the height (8 f32 ulps at 0.5 m; measured: 0, bit for bit). The
/// ball sinks into the wall by the soft contact's `F / (m omega^2)` at most, `omega = 2 pi 30`
/// (2.8e-5 m; the rigid methods do not sink), and with sleeping enabled it falls asleep.
#[test]
fn weightless_bodies_in_contact_do_not_creep() {
    let omega = 2.0 * std::f32::consts::PI * 30.0;
    let (radius, force) = (0.25, 1.0);
    let sink = force / (omega * omega);
    for method in SolverMethod::ALL {
        for sleeping in [false, true] {
            let mut app = headless_app(60.0);
            app.insert_resource(SolverConfig::for_method(method));
            scenes::ground(app.world_mut());
            app.world_mut().spawn((
                RigidBody::Static,
                Collider::cuboid(0.5, 5.0, 5.0),
                Transform::from_xyz(-10.5, 3.0, 0.0),
            ));
            let cube = app
                .world_mut()
                .spawn((
                    scenes::cuboid(Vec3::splat(0.5), 1.0, Vec3::new(0.0, 0.5, 0.0)),
                    GravityScale(0.0),
                ))
                .id();
            let ball = app
                .world_mut()
                .spawn((
                    scenes::ball(radius, 1.0, Vec3::new(-10.0 + radius, 2.0, 0.0), Vec3::ZERO),
                    GravityScale(0.0),
                    ConstantForce::new(-force, 0.0, 0.0),
                ))
                .id();
            if !sleeping {
                app.world_mut().entity_mut(cube).insert(SleepingDisabled);
                app.world_mut().entity_mut(ball).insert(SleepingDisabled);
            }
            for step in 0..120 {
                run_steps(&mut app, 1);
                let (c, b) = (position(&app, cube), position(&app, ball));
                assert!((c.y - 0.5).abs() <= 1e-6, "{method:?} step {step}: box {c}");
                assert!(
                    (b.y - 2.0).abs() <= 1e-6,
                    "{method:?} step {step}: ball {b}"
                );
                let into = -10.0 + radius - b.x;
                assert!(
                    (-1e-6..=sink * 1.01).contains(&into),
                    "{method:?} step {step}: ball {into} m into the wall"
                );
            }
            if sleeping {
                for e in [cube, ball] {
                    assert!(
                        app.world().get::<Sleeping>(e).is_some(),
                        "{method:?}: not asleep"
                    );
                }
            }
        }
    }
}

/// `GravityScale(5.0)` with restitution 0.5 on the floor rests and sleeps under every method:
/// the extra `4 g` is integrated substep by substep like gravity, so a resting contact sees
/// only `5 g h` (0.2 m/s at 240 Hz) a substep as its approach, below the 0.5 m/s restitution
/// threshold. (As a start-of-step `4 g dt` it was an approach of 0.65 m/s: the ball bounced at
/// 0.16 m/s and never slept.) A ball and a box, placed touching: they never move up faster
/// than 1e-5 m/s (measured: 0 and 1.4e-6 m/s) and fall asleep within 1 s. The soft methods'
/// contact sinks by `5 g / omega^2` (1.38 mm at 30 Hz) under five times the weight: kept
/// awake, within 1% after 200 steps (the soft contact is overdamped, damping ratio 10, and
/// approaches its rest depth exponentially; measured 1.380 mm of 1.3805), and asleep, at most
/// that and at least 97% of it (the body falls asleep while still settling at under the sleep
/// threshold: measured 1.362 mm). The rigid methods stop it within the linear slop (5 mm).
#[test]
fn heavy_bouncy_bodies_rest_and_sleep() {
    let omega = 2.0 * std::f32::consts::PI * 30.0;
    let scale = 5.0;
    let predicted = scale * G / (omega * omega);
    for method in SolverMethod::ALL {
        let soft = matches!(method, SolverMethod::Hybrid | SolverMethod::SoftStep);
        for awake in [false, true] {
            let mut app = headless_app(60.0);
            app.insert_resource(SolverConfig::for_method(method));
            scenes::ground(app.world_mut());
            let ball = app
                .world_mut()
                .spawn((
                    scenes::ball(0.25, 1.0, Vec3::new(0.0, 0.25, 0.0), Vec3::ZERO),
                    GravityScale(scale),
                    Restitution(0.5),
                ))
                .id();
            let cube = app
                .world_mut()
                .spawn((
                    scenes::cuboid(Vec3::splat(0.5), 1.0, Vec3::new(3.0, 0.5, 0.0)),
                    GravityScale(scale),
                    Restitution(0.5),
                ))
                .id();
            let bodies = [(ball, 0.25), (cube, 0.5)];
            if awake {
                for (e, _) in bodies {
                    app.world_mut().entity_mut(e).insert(SleepingDisabled);
                }
            }
            let steps = if awake { 200 } else { 60 };
            for step in 0..steps {
                run_steps(&mut app, 1);
                for (e, _) in bodies {
                    let v = velocity(&app, e).y;
                    assert!(v <= 1e-5, "{method:?} step {step}: moving up at {v}");
                }
            }
            for (e, rest) in bodies {
                let sink = rest - position(&app, e).y;
                if soft && awake {
                    assert!(
                        (sink - predicted).abs() <= 0.01 * predicted,
                        "{method:?}: sink {sink} vs {predicted}"
                    );
                } else if soft {
                    assert!(
                        (0.97 * predicted..=1.01 * predicted).contains(&sink),
                        "{method:?}: sink {sink} vs {predicted}"
                    );
                } else {
                    assert!((-1e-6..=0.005).contains(&sink), "{method:?}: sink {sink}");
                }
                if !awake {
                    assert!(
                        app.world().get::<Sleeping>(e).is_some(),
                        "{method:?}: not asleep"
                    );
                }
            }
        }
    }
}

/// Bodies resting on the floor under a gravity scale stay put: a box with scale 2 and one with
/// 0.5 rest at y = 0.5 (within the soft contact's sink under twice the weight, 1 mm) with
/// speed under 1 mm/s after 2 s, and fall asleep.
#[test]
fn gravity_scaled_boxes_rest() {
    let mut app = headless_app(60.0);
    scenes::ground(app.world_mut());
    let boxes: Vec<Entity> = [2.0, 0.5]
        .iter()
        .enumerate()
        .map(|(i, &s)| {
            app.world_mut()
                .spawn((
                    scenes::cuboid(Vec3::splat(0.5), 1.0, Vec3::new(3.0 * i as f32, 0.5, 0.0)),
                    GravityScale(s),
                ))
                .id()
        })
        .collect();
    let mut worst: f32 = 0.0;
    for step in 0..150 {
        run_steps(&mut app, 1);
        for &b in &boxes {
            assert!((position(&app, b).y - 0.5).abs() < 1e-3, "step {step}");
            if step >= 30 {
                worst = worst.max(velocity(&app, b).length());
            }
        }
    }
    assert!(worst < 1e-3, "speed {worst}");
    assert!(
        boxes
            .iter()
            .all(|&b| app.world().get::<Sleeping>(b).is_some())
    );
}

/// Linear and angular damping, no gravity: after `n` steps `v = v0 / (1 + c dt)^n` (the
/// implicit Euler form, f32 rounding 1e-5 relative), within `n (c dt)^2 / 2 * e^{-c t}` of
/// the exact `v0 e^{-c t}` (the difference of the two per-step factors, accumulated);
/// the position is the sum of the step velocities times `dt` (symplectic Euler).
#[test]
fn damping_matches_its_closed_form() {
    let mut app = weightless_app();
    let (c, k, v0, w0) = (2.0f32, 3.0f32, 4.0f32, 5.0f32);
    let ball = app
        .world_mut()
        .spawn((
            scenes::ball(0.5, 1.0, Vec3::ZERO, Vec3::new(v0, 0.0, 0.0)),
            AngularVelocity(Vec3::new(0.0, w0, 0.0)),
            LinearDamping(c),
            AngularDamping(k),
        ))
        .id();
    let n = 60;
    run_steps(&mut app, n);
    let factor = |c: f32, n: i32| (1.0 + c as f64 * DT as f64).powi(-n);
    let v = velocity(&app, ball).x as f64;
    let expected = v0 as f64 * factor(c, n as i32);
    assert!((v - expected).abs() <= 1e-5 * expected, "{v} vs {expected}");
    let w = spin(&app, ball).y as f64;
    let expected_w = w0 as f64 * factor(k, n as i32);
    assert!(
        (w - expected_w).abs() <= 1e-5 * expected_w,
        "{w} vs {expected_w}"
    );
    let t = (n as f32 * DT) as f64;
    let exact = v0 as f64 * (-(c as f64) * t).exp();
    let bound = n as f64 * (c as f64 * DT as f64).powi(2) / 2.0 * v0 as f64;
    assert!((v - exact).abs() <= bound, "{v} vs {exact}, bound {bound}");
    let x: f64 = (1..=n as i32)
        .map(|i| v0 as f64 * factor(c, i))
        .sum::<f64>()
        * DT as f64;
    let px = position(&app, ball).x as f64;
    assert!((px - x).abs() <= 1e-5 * x, "{px} vs {x}");
}

/// Speed caps: a ball falling with `MaxLinearSpeed(2.0)` never reports a speed above 2 m/s
/// (1e-6 relative, the f32 rounding of the scaling) and reaches it; spun with
/// `MaxAngularSpeed(1.0)` and a torque, its spin stops at 1 rad/s.
#[test]
fn speed_caps() {
    let mut app = headless_app(60.0);
    let ball = app
        .world_mut()
        .spawn((
            scenes::ball(0.25, 1.0, Vec3::new(0.0, 100.0, 0.0), Vec3::ZERO),
            MaxLinearSpeed(2.0),
            MaxAngularSpeed(1.0),
            ConstantTorque::new(0.0, 1.0, 0.0),
        ))
        .id();
    for _ in 0..60 {
        run_steps(&mut app, 1);
        assert!(velocity(&app, ball).length() <= 2.0 * (1.0 + 1e-6));
        assert!(spin(&app, ball).length() <= 1.0 + 1e-6);
    }
    assert!((velocity(&app, ball).length() - 2.0).abs() <= 1e-5);
    assert!((spin(&app, ball).length() - 1.0).abs() <= 1e-5);
}

/// Translation locks keep the coordinate bit for bit: a box locked along y does not fall, and
/// one locked along x keeps its x when a ball hits it along x (and the ball is still stopped
/// by it, rebounding as from a free 1 kg box: e = 1, equal masses, the ball stops).
#[test]
fn translation_locks_keep_the_coordinate() {
    let mut app = headless_app(60.0);
    let start = Vec3::new(0.25, 3.0, -1.0);
    let floating = app
        .world_mut()
        .spawn((
            scenes::cuboid(Vec3::splat(0.5), 1.0, start),
            LinearVelocity(Vec3::new(1.0, 0.0, 0.5)),
            LockedAxes::new().lock_translation_y(),
        ))
        .id();
    let x0 = 10.3;
    let locked = app
        .world_mut()
        .spawn((
            scenes::cuboid(Vec3::splat(0.5), 1.0, Vec3::new(x0, 50.0, 0.0)),
            LockedAxes::translation(true, false, false),
            Restitution(1.0),
        ))
        .id();
    let ball = app
        .world_mut()
        .spawn((
            scenes::ball(
                0.25,
                1.0,
                Vec3::new(x0 - 2.0, 50.0, 0.0),
                Vec3::new(6.0, 0.0, 0.0),
            ),
            Restitution(1.0),
        ))
        .id();
    for _ in 0..60 {
        run_steps(&mut app, 1);
        assert_eq!(position(&app, floating).y, start.y);
        assert_eq!(position(&app, locked).x, x0);
        assert_eq!(velocity(&app, floating).y, 0.0);
        assert_eq!(velocity(&app, locked).x, 0.0);
    }
    let p = position(&app, floating);
    assert!((p.x - (start.x + 1.0)).abs() < 1e-4 && (p.z - (start.z + 0.5)).abs() < 1e-4);
    // The ball hit the box and stopped (its x velocity went from 6 to about 0).
    assert!(
        velocity(&app, ball).x.abs() < 0.1,
        "{}",
        velocity(&app, ball)
    );
    assert!(position(&app, ball).x < x0 - 0.7);
}

/// `SleepingDisabled`: a box resting on the floor never sleeps, nor does a box resting on it
/// (its island), while a box of its own beside them sleeps as usual; inserted on a sleeping
/// box, it wakes it.
#[test]
fn sleeping_disabled() {
    let mut app = headless_app(60.0);
    scenes::ground(app.world_mut());
    let spawn = |app: &mut App, p: Vec3| {
        app.world_mut()
            .spawn(scenes::cuboid(Vec3::splat(0.5), 1.0, p))
            .id()
    };
    let bottom = spawn(&mut app, Vec3::new(0.0, 0.5, 0.0));
    let top = spawn(&mut app, Vec3::new(0.0, 1.5, 0.0));
    let alone = spawn(&mut app, Vec3::new(5.0, 0.5, 0.0));
    app.world_mut().entity_mut(bottom).insert(SleepingDisabled);
    let asleep = |app: &App, e| app.world().get::<Sleeping>(e).is_some();
    run_steps(&mut app, 300);
    assert!(asleep(&app, alone));
    assert!(!asleep(&app, bottom) && !asleep(&app, top));
    app.world_mut().entity_mut(alone).insert(SleepingDisabled);
    run_steps(&mut app, 2);
    assert!(!asleep(&app, alone));
    run_steps(&mut app, 120);
    assert!(!asleep(&app, alone));
}

/// `RigidBodyDisabled`: a disabled dynamic ball does not fall (bit for bit, 60 steps); a box
/// dropped on a disabled platform falls through it, on the free-fall parabola (1e-4
/// relative); the ball, re-enabled, falls from where it was, `g t^2 / 2` in `t` (1e-4).
#[test]
fn rigid_body_disabled() {
    let mut app = headless_app(60.0);
    let ball = app
        .world_mut()
        .spawn((
            scenes::ball(0.25, 1.0, Vec3::new(0.0, 5.0, 0.0), Vec3::ZERO),
            RigidBodyDisabled,
        ))
        .id();
    app.world_mut().spawn((
        RigidBody::Static,
        Collider::cuboid(2.0, 0.5, 2.0),
        Transform::from_xyz(5.0, 0.0, 0.0),
        RigidBodyDisabled,
    ));
    let dropped = app
        .world_mut()
        .spawn(scenes::cuboid(
            Vec3::splat(0.5),
            1.0,
            Vec3::new(5.0, 2.0, 0.0),
        ))
        .id();
    run_steps(&mut app, 60);
    assert_eq!(position(&app, ball), Vec3::new(0.0, 5.0, 0.0));
    assert_eq!(velocity(&app, ball), Vec3::ZERO);
    let fall = 0.5 * G * 1.0;
    let y = position(&app, dropped).y;
    assert!(((2.0 - y) - fall).abs() <= 1e-4 * fall, "fell through: {y}");
    app.world_mut()
        .entity_mut(ball)
        .remove::<RigidBodyDisabled>();
    run_steps(&mut app, 30);
    let t = 0.5;
    let drop = 5.0 - position(&app, ball).y;
    assert!((drop - 0.5 * G * t * t).abs() <= 1e-4 * drop, "{drop}");
}

/// `ColliderDisabled`: a box over the ground falls through it on the free-fall parabola
/// (1e-4 relative), while a box without it lands.
#[test]
fn collider_disabled_falls_through() {
    let (mut app, ghost) = on_ground((
        scenes::cuboid(Vec3::splat(0.5), 1.0, Vec3::new(0.0, 2.0, 0.0)),
        ColliderDisabled,
    ));
    let solid = app
        .world_mut()
        .spawn(scenes::cuboid(
            Vec3::splat(0.5),
            1.0,
            Vec3::new(3.0, 2.0, 0.0),
        ))
        .id();
    run_steps(&mut app, 90);
    let t = 1.5;
    let y = position(&app, ghost).y;
    assert!(
        ((2.0 - y) - 0.5 * G * t * t).abs() <= 1e-4 * (2.0 - y),
        "{y}"
    );
    assert!((position(&app, solid).y - 0.5).abs() < 1e-3);
}

/// The physics clock: paused, nothing moves (bit for bit) and no step runs; at relative speed 2
/// each frame's step is twice as long, so a body at constant velocity covers twice the
/// distance per frame (exactly: `2 v dt`), and a falling one `g (2 n dt)^2 / 2` after n frames
/// (1e-4, the free-fall parabola). `Time<Virtual>` is not touched.
#[test]
fn physics_clock_pauses_and_speeds_up() {
    let mut app = headless_app(60.0);
    let ball = app
        .world_mut()
        .spawn(scenes::ball(
            0.25,
            1.0,
            Vec3::new(0.0, 100.0, 0.0),
            Vec3::ZERO,
        ))
        .id();
    run_steps(&mut app, 10);
    app.world_mut().resource_mut::<PhysicsTime>().pause();
    let before = snapshot(&app, &[ball]);
    run_steps(&mut app, 30);
    assert_eq!(snapshot(&app, &[ball]), before);
    assert_eq!(
        app.world().resource::<Time<Virtual>>().relative_speed(),
        1.0
    );

    let mut app = weightless_app();
    app.world_mut()
        .resource_mut::<PhysicsTime>()
        .set_relative_speed(2.0);
    let v = 3.0;
    let mover = app
        .world_mut()
        .spawn(scenes::ball(0.25, 1.0, Vec3::ZERO, Vec3::new(v, 0.0, 0.0)))
        .id();
    app.world_mut().insert_resource(Gravity::default());
    let faller = app
        .world_mut()
        .spawn((
            scenes::ball(0.25, 1.0, Vec3::new(5.0, 100.0, 0.0), Vec3::ZERO),
            GravityScale(1.0),
        ))
        .id();
    app.world_mut().entity_mut(mover).insert(GravityScale(0.0));
    for frame in 1..=30 {
        let x0 = position(&app, mover).x;
        run_steps(&mut app, 1);
        let dx = position(&app, mover).x - x0;
        assert!((dx - 2.0 * v * DT).abs() <= 1e-5, "frame {frame}: {dx}");
    }
    let t = 2.0 * 30.0 * DT;
    let drop = 100.0 - position(&app, faller).y;
    assert!((drop - 0.5 * G * t * t).abs() <= 1e-4 * drop, "{drop}");
}

/// A change made to a body's components.
type Edit = Box<dyn Fn(&mut EntityWorldMut)>;

/// Bad input: a NaN force, a negative damping and a NaN gravity scale each keep the body out of
/// the step (it does not move), with one error naming the body by its `Name` over 30 steps;
/// corrected, the body rejoins (falls again).
#[test]
fn bad_motion_input_is_quarantined_once() {
    let cases: [(&str, Edit, Edit); 4] = [
        (
            "ConstantForce",
            Box::new(|e| {
                e.insert(ConstantForce::new(f32::NAN, 0.0, 0.0));
            }),
            Box::new(|e| {
                e.insert(ConstantForce::new(1.0, 0.0, 0.0));
            }),
        ),
        (
            "LinearDamping",
            Box::new(|e| {
                e.insert(LinearDamping(-1.0));
            }),
            Box::new(|e| {
                e.insert(LinearDamping(0.5));
            }),
        ),
        (
            "GravityScale",
            Box::new(|e| {
                e.insert(GravityScale(f32::NAN));
            }),
            Box::new(|e| {
                e.remove::<GravityScale>();
            }),
        ),
        (
            "MaxLinearSpeed",
            Box::new(|e| {
                e.insert(MaxLinearSpeed(f32::NAN));
            }),
            Box::new(|e| {
                e.insert(MaxLinearSpeed(f32::INFINITY));
            }),
        ),
    ];
    for (what, bad, good) in cases {
        capture_logs();
        let mut app = headless_app(60.0);
        let body = app
            .world_mut()
            .spawn((
                scenes::ball(0.25, 1.0, Vec3::new(0.0, 10.0, 0.0), Vec3::ZERO),
                Name::new("probe"),
            ))
            .id();
        bad(&mut app.world_mut().entity_mut(body));
        run_steps(&mut app, 30);
        assert!(app.world().get::<Quarantined>(body).is_some(), "{what}");
        assert_eq!(position(&app, body).y, 10.0, "{what}");
        let errors: Vec<_> = take_logs()
            .into_iter()
            .filter(|(level, text)| *level == log::Level::Error && text.contains("\"probe\""))
            .collect();
        assert_eq!(errors.len(), 1, "{what}: {errors:?}");
        assert!(errors[0].1.contains(what), "{what}: {}", errors[0].1);
        good(&mut app.world_mut().entity_mut(body));
        run_steps(&mut app, 30);
        assert!(app.world().get::<Quarantined>(body).is_none(), "{what}");
        assert!(position(&app, body).y < 9.0, "{what}");
    }
}

/// A force through `Forces` on a sleeping body wakes it and acts: the box resting asleep on the
/// floor, pushed sideways by 60 N for one step (frictionless), moves off at `F/m dt`.
#[test]
fn a_force_wakes_a_sleeping_body() {
    let mut app = headless_app(60.0);
    let cube = scenes::stack(app.world_mut(), 1)[0];
    run_steps(&mut app, 150);
    assert!(app.world().get::<Sleeping>(cube).is_some());
    app.world_mut()
        .run_system_once(|mut q: Query<Forces>| {
            for mut f in &mut q {
                f.apply_force(Vec3::new(60.0, 0.0, 0.0));
            }
        })
        .unwrap();
    run_steps(&mut app, 1);
    assert!(app.world().get::<Sleeping>(cube).is_none());
    let vx = velocity(&app, cube).x;
    let expected = 60.0 / mass(&app, cube) * DT;
    assert!(
        (vx - expected).abs() <= 1e-5 * expected,
        "{vx} vs {expected}"
    );
}

/// Disabling the bottom box of a sleeping stack of two takes it out of the world: the top box
/// wakes (its resting pair ended) and falls to the floor (rests at y = 0.5 within 1 mm); the
/// bottom box, asleep and disabled, has not moved by a bit; enabled again, it rejoins
/// overlapping the top one and is pushed out, and both end up resting (speeds under 1 cm/s).
#[test]
fn disabling_a_support_wakes_what_rests_on_it() {
    let mut app = headless_app(60.0);
    let cubes = scenes::stack(app.world_mut(), 2);
    run_steps(&mut app, 120);
    assert!(
        cubes
            .iter()
            .all(|&c| app.world().get::<Sleeping>(c).is_some())
    );
    let bottom_at = snapshot(&app, &cubes[..1]);
    app.world_mut()
        .entity_mut(cubes[0])
        .insert(RigidBodyDisabled);
    run_steps(&mut app, 120);
    assert!(
        (position(&app, cubes[1]).y - 0.5).abs() < 1e-3,
        "{}",
        position(&app, cubes[1])
    );
    assert_eq!(snapshot(&app, &cubes[..1]), bottom_at);
    app.world_mut()
        .entity_mut(cubes[0])
        .remove::<RigidBodyDisabled>();
    run_steps(&mut app, 240);
    for &c in &cubes {
        let p = position(&app, c);
        assert!(p.is_finite() && p.y > 0.4, "{p}");
        assert!(velocity(&app, c).length() < 0.01, "{}", velocity(&app, c));
    }
}

/// `ColliderDisabled` inserted on a box asleep on the floor wakes it and it falls through. Its
/// pair with the floor ends in the first step, which wakes its island at the end of that step
/// (as when a support is despawned), so after 60 steps it has fallen for 59: `g (59 dt)^2 / 2`
/// from where it slept (1e-4 relative, f32 rounding).
#[test]
fn collider_disabled_on_a_sleeping_body() {
    let mut app = headless_app(60.0);
    let cube = scenes::stack(app.world_mut(), 1)[0];
    run_steps(&mut app, 150);
    assert!(app.world().get::<Sleeping>(cube).is_some());
    let y0 = position(&app, cube).y;
    app.world_mut().entity_mut(cube).insert(ColliderDisabled);
    run_steps(&mut app, 60);
    assert!(app.world().get::<Sleeping>(cube).is_none());
    let drop = y0 - position(&app, cube).y;
    let t = 59.0 * DT;
    assert!((drop - 0.5 * G * t * t).abs() <= 1e-4 * drop, "{drop}");
}

/// Paused, an interpolated body is shown at the pose the last physics step wrote, and stays
/// there bit for bit (interpolating between the last two poses while no step runs would show
/// it between them, moving back and forth as the frame's fraction of the step changes).
#[test]
fn paused_interpolated_body_stays_at_its_last_pose() {
    let mut app = headless_app(60.0);
    let ball = app
        .world_mut()
        .spawn((
            scenes::ball(0.25, 1.0, Vec3::new(0.0, 10.0, 0.0), Vec3::X),
            TransformInterpolation,
        ))
        .id();
    run_steps(&mut app, 10);
    app.world_mut().resource_mut::<PhysicsTime>().pause();
    run_steps(&mut app, 1);
    let end = app
        .world()
        .get::<impact3d::interpolation::InterpolationState>(ball)
        .unwrap()
        .end;
    for _ in 0..5 {
        run_steps(&mut app, 1);
        assert_eq!((position(&app, ball), rotation(&app, ball)), end);
    }
}
