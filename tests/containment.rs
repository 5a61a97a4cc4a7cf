//! Bad input stays contained: a bad or absurd value on one body quarantines that body alone,
//! before the solve, with one error line naming it; the quarantine ends on the step after the
//! value is fixed; bodies that never touched it are bit-identical to a run without the bad
//! value. Bad settings are logged once and replaced by the last good value, so they quarantine
//! nobody and change nothing.

mod common;

use bevy::prelude::*;
use common::*;
use impact3d::prelude::*;
use impact3d::scenes::{self, headless_app, run_steps};

/// A ground, a column of two 1 kg cubes at x = 0 (the second is the one given bad input) and,
/// 20 m away, a column of three that never touches it (the bystanders). Friction 0.5.
struct Piles {
    app: App,
    /// The cube that gets the bad value (top of the first column).
    bad: Entity,
    /// The cube it rests on.
    below: Entity,
    /// The far column.
    bystanders: Vec<Entity>,
}

fn piles(method: SolverMethod, sleeping: bool) -> Piles {
    let mut app = headless_app(60.0);
    app.insert_resource(SolverConfig::for_method(method));
    app.insert_resource(SleepConfig {
        enabled: sleeping,
        ..default()
    });
    let world = app.world_mut();
    scenes::ground(world);
    let mut column = |x: f32, n: usize, name: &str| -> Vec<Entity> {
        (0..n)
            .map(|i| {
                world
                    .spawn((
                        scenes::cuboid(Vec3::splat(0.5), 1.0, Vec3::new(x, 0.5 + i as f32, 0.0)),
                        Friction(0.5),
                        Name::new(format!("{name} {i}")),
                    ))
                    .id()
            })
            .collect()
    };
    let near = column(0.0, 2, "near");
    let bystanders = column(20.0, 3, "far");
    Piles {
        app,
        bad: near[1],
        below: near[0],
        bystanders,
    }
}

/// Asserts that `bodies` are bit-identical to `expected` (a [`snapshot`] of a run without the
/// bad value), under every method. (Sequential impulses and Jacobi used to stop iterating when
/// the largest change over *all* contacts fell below a tolerance, so a far island's iteration
/// count depended on the bad body's contacts; they now stop early only on exact convergence.)
fn assert_unaffected(
    method: SolverMethod,
    app: &App,
    bodies: &[Entity],
    expected: &[[u32; 13]],
    what: &str,
) {
    let got = snapshot(app, bodies);
    assert_eq!(
        got, expected,
        "{method:?} {what}: a body that never touched it changed"
    );
}

fn errors() -> Vec<String> {
    take_logs()
        .into_iter()
        .filter(|(level, _)| *level == log::Level::Error)
        .map(|(_, text)| text)
        .collect()
}

fn quarantined(app: &App, e: Entity) -> bool {
    app.world().get::<Quarantined>(e).is_some()
}

/// Regression (issue 9): NaN gravity for one step quarantined both cubes of `stack(2)` for
/// good, an error per cube per step. Now the bad gravity is logged once, the last good one is
/// used, no body is quarantined, and the run is bit-identical to one without the bad value.
#[test]
fn quarantine_ends_when_gravity_is_fixed() {
    capture_logs();
    let run = |bad: bool| {
        let mut app = headless_app(60.0);
        app.insert_resource(SleepConfig {
            enabled: false,
            ..default()
        });
        let cubes = scenes::stack(app.world_mut(), 2);
        for &c in &cubes {
            app.world_mut().entity_mut(c).insert(Friction(0.5));
        }
        run_steps(&mut app, 10);
        if bad {
            app.insert_resource(Gravity(Vec3::new(0.0, f32::NAN, 0.0)));
        }
        app.update();
        app.insert_resource(Gravity::default());
        for _ in 0..60 {
            app.update();
            assert!(cubes.iter().all(|&c| !quarantined(&app, c)));
        }
        snapshot(&app, &cubes)
    };
    let reference = run(false);
    take_logs();
    let disturbed = run(true);
    assert_eq!(disturbed, reference);
    let errors = errors();
    assert_eq!(errors.len(), 1, "{errors:?}");
    assert!(
        errors[0].contains("Gravity") && errors[0].contains("NaN"),
        "{}",
        errors[0]
    );
}

/// Regression (issue 9): `Mass(3e38)` on one cube for one step kept both cubes of `stack(2)`
/// quarantined for good. Now the cube alone is quarantined (one error naming it), its
/// neighbour is not, and the quarantine ends on the step after the mass is restored, with no
/// further errors.
#[test]
fn quarantine_ends_when_mass_is_fixed() {
    capture_logs();
    let mut p = piles(SolverMethod::Hybrid, false);
    run_steps(&mut p.app, 10);
    p.app.world_mut().entity_mut(p.bad).insert(Mass(3e38));
    p.app.update();
    assert!(quarantined(&p.app, p.bad));
    assert!(!quarantined(&p.app, p.below));
    p.app.world_mut().entity_mut(p.bad).insert(Mass(1.0));
    p.app.update();
    assert!(
        !quarantined(&p.app, p.bad),
        "quarantine ends on the step after the fix"
    );
    for _ in 0..60 {
        p.app.update();
        assert!(!quarantined(&p.app, p.bad) && !quarantined(&p.app, p.below));
    }
    let errors = errors();
    assert_eq!(errors.len(), 1, "{errors:?}");
    assert!(
        errors[0].contains("\"near 1\"") && errors[0].contains("3e38"),
        "{}",
        errors[0]
    );
    // Back at rest on the lower cube: its centre within 1 cm of y = 1.5 (it fell, unsupported,
    // for one step: 9.81 / 60^2 = 2.7 mm, then settles back; the soft contact sinks 0.28 mm).
    let y = position(&p.app, p.bad).y;
    assert!((y - 1.5).abs() < 0.01, "{y}");
}

/// Changes that set one body's input to a finite but absurd value, each with its restore:
/// `(what, set, restore)`.
type Change = fn(&mut EntityWorldMut);

fn absurd_changes() -> [(&'static str, Change, Change); 5] {
    [
        (
            "Mass(3e38)",
            |e| {
                e.insert(Mass(3e38));
            },
            |e| {
                e.insert(Mass(1.0));
            },
        ),
        (
            "Mass(1e30)",
            |e| {
                e.insert(Mass(1e30));
            },
            |e| {
                e.insert(Mass(1.0));
            },
        ),
        (
            "LinearVelocity(1e30)",
            |e| {
                e.insert(LinearVelocity(Vec3::splat(1e30)));
            },
            |e| {
                e.insert(LinearVelocity(Vec3::ZERO));
            },
        ),
        (
            "AngularVelocity(1e30)",
            |e| {
                e.insert(AngularVelocity(Vec3::splat(1e30)));
            },
            |e| {
                e.insert(AngularVelocity(Vec3::ZERO));
            },
        ),
        (
            "Density(1e30)",
            |e| {
                e.remove::<Mass>().insert(Density(1e30));
            },
            |e| {
                e.insert((Mass(1.0), Density(1000.0)));
            },
        ),
    ]
}

/// Regression (issue 9): in a resting pile, one body given `Mass(3e38)`, `LinearVelocity(1e30)`
/// or `AngularVelocity(1e30)` got 34-99 other bodies quarantined. Such finite but absurd input
/// is now quarantined before the solve: the far column is bit-identical to an undisturbed run,
/// the body's neighbour is never quarantined, one error line per bad value, and the quarantine
/// ends on the step after the fix. Every method.
#[test]
fn absurd_values_never_reach_other_bodies() {
    let changes = absurd_changes();
    for method in SolverMethod::ALL {
        let mut reference = piles(method, false);
        run_steps(&mut reference.app, 80);
        let expected = snapshot(&reference.app, &reference.bystanders);
        for (what, set, restore) in changes {
            capture_logs();
            let mut p = piles(method, false);
            run_steps(&mut p.app, 10);
            set(&mut p.app.world_mut().entity_mut(p.bad));
            run_steps(&mut p.app, 3);
            assert!(quarantined(&p.app, p.bad), "{method:?} {what}");
            assert!(!quarantined(&p.app, p.below), "{method:?} {what}");
            restore(&mut p.app.world_mut().entity_mut(p.bad));
            p.app.update();
            assert!(
                !quarantined(&p.app, p.bad),
                "{method:?} {what}: quarantine ended"
            );
            run_steps(&mut p.app, 66);
            assert_unaffected(method, &p.app, &p.bystanders, &expected, what);
            let errors = errors();
            assert_eq!(errors.len(), 1, "{method:?} {what}: {errors:?}");
            assert!(errors[0].contains("near 1"), "{}", errors[0]);
        }
    }
}

/// Regression (issue 9): a box sent at 1e30 m/s into a wall moved a box 50 m behind it to
/// 9.8e19 m. Now the fast box is quarantined before it reaches any contact; the far box does
/// not move at all (it rests on the ground, sleeping off: bit-identical to a run without the
/// fast box's velocity).
#[test]
fn absurd_speed_box_leaves_far_box_alone() {
    let run = |speed: f32| {
        let mut app = headless_app(60.0);
        app.insert_resource(SleepConfig {
            enabled: false,
            ..default()
        });
        scenes::ground(app.world_mut());
        app.world_mut().spawn((
            RigidBody::Static,
            Collider::cuboid(0.1, 2.0, 2.0),
            Transform::from_xyz(3.0, 2.0, 0.0),
        ));
        let fast = app
            .world_mut()
            .spawn((
                scenes::cuboid(Vec3::splat(0.5), 1.0, Vec3::new(0.0, 0.5, 0.0)),
                LinearVelocity(Vec3::new(speed, 0.0, 0.0)),
            ))
            .id();
        let far = app
            .world_mut()
            .spawn(scenes::cuboid(
                Vec3::splat(0.5),
                1.0,
                Vec3::new(53.0, 0.5, 0.0),
            ))
            .id();
        let mut fast_quarantined = false;
        for _ in 0..30 {
            app.update();
            fast_quarantined |= quarantined(&app, fast);
            assert!(!quarantined(&app, far), "the far box was reached");
        }
        (fast_quarantined, snapshot(&app, &[far]))
    };
    let (fast_quarantined, far) = run(1e30);
    assert!(fast_quarantined);
    assert_eq!(far, run(0.0).1);
}

/// Every bad setting is logged once (naming the field and the value), replaced by the last good
/// value, quarantines nobody, and leaves the run bit-identical to one without it. Today NaN or
/// negative `contact_margin` panicked in parry, NaN `contact_hertz` or `baumgarte` under
/// sequential impulses dropped a pile through the floor, and a negative damping ratio
/// quarantined bodies.
#[test]
fn bad_settings_are_logged_once_and_replaced() {
    type Set = fn(&mut World, f32);
    let settings: [(&str, Set); 14] = [
        ("contact_margin", |w, v| {
            w.resource_mut::<NarrowPhaseConfig>().contact_margin = v
        }),
        ("touch_distance", |w, v| {
            w.resource_mut::<NarrowPhaseConfig>().touch_distance = v
        }),
        ("contact_hertz", |w, v| {
            w.resource_mut::<SolverConfig>().contact_hertz = v
        }),
        ("baumgarte", |w, v| {
            w.resource_mut::<SolverConfig>().baumgarte = v
        }),
        ("contact_damping_ratio", |w, v| {
            w.resource_mut::<SolverConfig>().contact_damping_ratio = v
        }),
        ("velocity_tolerance", |w, v| {
            w.resource_mut::<SolverConfig>().velocity_tolerance = v
        }),
        ("restitution_threshold", |w, v| {
            w.resource_mut::<SolverConfig>().restitution_threshold = v
        }),
        ("max_push_out_speed", |w, v| {
            w.resource_mut::<SolverConfig>().max_push_out_speed = v
        }),
        ("linear_slop", |w, v| {
            w.resource_mut::<SolverConfig>().linear_slop = v
        }),
        ("substeps", |w, v| {
            w.resource_mut::<SolverConfig>().substeps = count(v)
        }),
        ("iterations", |w, v| {
            w.resource_mut::<SolverConfig>().iterations = count(v)
        }),
        ("linear_threshold", |w, v| {
            w.resource_mut::<SleepConfig>().linear_threshold = v
        }),
        ("time_to_sleep", |w, v| {
            w.resource_mut::<SleepConfig>().time_to_sleep = v
        }),
        ("Gravity", |w, v| {
            w.resource_mut::<Gravity>().0 = Vec3::new(v, -9.81, 0.0)
        }),
    ];
    /// A bad count for the integer fields: 0, or one too many to be a setting.
    fn count(v: f32) -> u32 {
        if v > 0.0 { u32::MAX } else { 0 }
    }
    for method in [
        SolverMethod::Hybrid,
        SolverMethod::SequentialImpulses,
        SolverMethod::Jacobi,
    ] {
        for sleeping in [false, true] {
            let mut reference = piles(method, sleeping);
            run_steps(&mut reference.app, 40);
            let all: Vec<Entity> = [reference.bad, reference.below]
                .into_iter()
                .chain(reference.bystanders.clone())
                .collect();
            let expected = snapshot(&reference.app, &all);
            for (name, set) in settings {
                for bad in [f32::NAN, f32::INFINITY, -1.0, 1e30] {
                    if (name == "time_to_sleep" && bad == 1e30)
                        || (name == "Gravity" && bad == -1.0)
                    {
                        continue; // valid: never sleep; a gravity of (-1, -9.81, 0)
                    }
                    capture_logs();
                    let mut p = piles(method, sleeping);
                    run_steps(&mut p.app, 10);
                    let saved = (
                        p.app.world().resource::<SolverConfig>().clone(),
                        p.app.world().resource::<SleepConfig>().clone(),
                        *p.app.world().resource::<Gravity>(),
                        p.app.world().resource::<NarrowPhaseConfig>().clone(),
                    );
                    set(p.app.world_mut(), bad);
                    run_steps(&mut p.app, 3);
                    p.app.insert_resource(saved.0);
                    p.app.insert_resource(saved.1);
                    p.app.insert_resource(saved.2);
                    p.app.insert_resource(saved.3);
                    run_steps(&mut p.app, 27);
                    let what = format!("{method:?} sleeping {sleeping}: {name} = {bad}");
                    assert_eq!(snapshot(&p.app, &all), expected, "{what}");
                    assert!(all.iter().all(|&e| !quarantined(&p.app, e)), "{what}");
                    let errors = errors();
                    assert_eq!(errors.len(), 1, "{what}: {errors:?}");
                    assert!(errors[0].contains(name), "{what}: {}", errors[0]);
                }
            }
        }
    }
}

/// A zero step length (here: physics run in `Update` with a paused clock) is logged once and
/// the last good step length is used; nothing panics.
#[test]
fn zero_dt_uses_the_last_good_step() {
    use bevy::time::TimeUpdateStrategy;
    use std::time::Duration;
    capture_logs();
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, PhysicsPlugins::new(Update)))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(
            20,
        )));
    app.insert_resource(Gravity(Vec3::ZERO));
    let ball = app
        .world_mut()
        .spawn(scenes::ball(0.5, 1.0, Vec3::ZERO, Vec3::X))
        .id();
    run_steps(&mut app, 3);
    take_logs();
    let x = position(&app, ball).x;
    app.insert_resource(TimeUpdateStrategy::ManualDuration(Duration::ZERO));
    run_steps(&mut app, 3);
    // Three steps of the last good 20 ms at 1 m/s: 6 cm (f32 rounding of a few additions).
    let moved = position(&app, ball).x - x;
    assert!((moved - 0.06).abs() < 1e-5, "{moved}");
    let errors = errors();
    assert_eq!(errors.len(), 1, "{errors:?}");
    assert!(errors[0].contains("dt = 0"), "{}", errors[0]);
}

/// Regression (issue 9): writing NaN into `ComputedMass` spread NaN to 34-49 bodies, and a
/// negative inverse mass let a body wander 78 m with no log. It is read-only in fact: a written
/// value is replaced by the recomputed one before the step uses it, so the run is bit-identical
/// to one without the write (every body, the written one included), with one warning naming
/// the body and no quarantine.
#[test]
fn written_computed_mass_is_recomputed() {
    let written = [
        ("NaN", f32::NAN, Mat3::IDENTITY),
        ("negative inverse mass", -1.0, Mat3::IDENTITY),
        (
            "negative inverse inertia",
            1.0,
            Mat3::from_diagonal(Vec3::splat(-6.0)),
        ),
    ];
    for sleeping in [false, true] {
        let mut reference = piles(SolverMethod::Hybrid, sleeping);
        run_steps(&mut reference.app, 70);
        let all: Vec<Entity> = [reference.bad, reference.below]
            .into_iter()
            .chain(reference.bystanders.clone())
            .collect();
        let expected = snapshot(&reference.app, &all);
        for (what, inverse_mass, inverse_inertia) in written {
            capture_logs();
            let mut p = piles(SolverMethod::Hybrid, sleeping);
            run_steps(&mut p.app, 40);
            let mut computed = p.app.world_mut().get_mut::<ComputedMass>(p.bad).unwrap();
            computed.inverse_mass = inverse_mass;
            computed.local_inverse_inertia = inverse_inertia;
            run_steps(&mut p.app, 30);
            assert_eq!(
                snapshot(&p.app, &all),
                expected,
                "{what}, sleeping {sleeping}"
            );
            assert_eq!(
                p.app
                    .world()
                    .get::<ComputedMass>(p.bad)
                    .unwrap()
                    .inverse_mass,
                1.0
            );
            assert!(!quarantined(&p.app, p.bad));
            let logs = take_logs();
            let warnings: Vec<_> = logs
                .iter()
                .filter(|(l, t)| *l == log::Level::Warn && t.contains("ComputedMass"))
                .collect();
            assert_eq!(warnings.len(), 1, "{what}: {logs:?}");
            assert!(warnings[0].1.contains("\"near 1\""), "{}", warnings[0].1);
            assert!(
                logs.iter().all(|(l, _)| *l != log::Level::Error),
                "{logs:?}"
            );
        }
    }
}

/// Every log line about a body names it by its `Name` where it has one (`body "crate 3"
/// (12v0)`), else by its id alone (`body 12v0`): quarantine, rejoin and clamp messages.
#[test]
fn log_lines_name_bodies_by_name() {
    capture_logs();
    let (mut app, named) = on_ground((
        scenes::ball(0.5, 1.0, Vec3::new(0.0, 0.5, 0.0), Vec3::NAN),
        Name::new("crate 3"),
    ));
    let anonymous = app
        .world_mut()
        .spawn((
            scenes::ball(0.5, 1.0, Vec3::new(3.0, 0.5, 0.0), Vec3::ZERO),
            Restitution(2.0),
        ))
        .id();
    run_steps(&mut app, 2);
    app.world_mut()
        .entity_mut(named)
        .insert(LinearVelocity(Vec3::ZERO));
    run_steps(&mut app, 2);
    let logs: Vec<String> = take_logs().into_iter().map(|(_, t)| t).collect();
    let named_label = format!("body \"crate 3\" ({named})");
    let lines_about = |needle: &str| logs.iter().filter(|t| t.contains(needle)).count();
    assert_eq!(logs.len(), 3, "{logs:?}");
    assert_eq!(
        lines_about(&format!("{named_label} is left out")),
        1,
        "{logs:?}"
    );
    assert_eq!(
        lines_about(&format!("{named_label} is valid again")),
        1,
        "{logs:?}"
    );
    assert_eq!(
        lines_about(&format!("body {anonymous} has restitution 2")),
        1,
        "{logs:?}"
    );
}

/// Regression (issue 9): in a resting pile of 50 bodies, one body given `Mass(3e38)`,
/// `LinearVelocity(1e30)` or `AngularVelocity(1e30)` got 34-99 other bodies quarantined, none
/// of which rejoined, and 24,000 log lines followed the fix. In a pyramid of 55 cubes, the bad
/// value on a cube of the middle row for one step now quarantines that cube alone, with one
/// error line and one line when it rejoins on the next step, and nothing more in 60 steps.
#[test]
fn one_bad_body_in_a_pile_quarantines_only_itself() {
    let changes = absurd_changes().into_iter().filter(|(what, _, _)| {
        [
            "Mass(3e38)",
            "LinearVelocity(1e30)",
            "AngularVelocity(1e30)",
        ]
        .contains(what)
    });
    for (what, set, restore) in changes {
        capture_logs();
        let mut app = headless_app(60.0);
        app.insert_resource(SleepConfig {
            enabled: false,
            ..default()
        });
        let cubes = scenes::pyramid(app.world_mut(), 10);
        let bad = cubes[30];
        run_steps(&mut app, 10);
        set(&mut app.world_mut().entity_mut(bad));
        app.update();
        restore(&mut app.world_mut().entity_mut(bad));
        for step in 0..60 {
            app.update();
            for &c in &cubes {
                assert!(
                    !quarantined(&app, c),
                    "{what}: step {step}: {c} quarantined"
                );
                assert!(position(&app, c).is_finite(), "{what}");
            }
        }
        let logs = take_logs();
        assert_eq!(logs.len(), 2, "{what}: {logs:?}");
        assert!(
            logs[0].1.contains("left out") && logs[1].1.contains("rejoins"),
            "{logs:?}"
        );
    }
}

/// The bounds are where the step's products stay finite: bodies at them (1e6 m/s, 1e6 rad/s,
/// 1e12 kg and 1e-9 kg, 9e6 m from the origin, a kinematic bar turning at 1e5 rad/s) never
/// produce a non-finite state under any method: nothing non-finite is written, and every
/// error is about an input out of range (a body the step pushed past a bound is quarantined
/// the next step, as bad input), never about a non-finite result.
#[test]
fn values_at_the_bounds_stay_finite() {
    let mut seed = 1u32;
    let mut next = move || {
        seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
        (seed >> 8) as f32 / (1u32 << 24) as f32 - 0.5
    };
    for method in SolverMethod::ALL {
        for trial in 0..4 {
            capture_logs();
            let mut app = headless_app(60.0);
            app.insert_resource(SolverConfig::for_method(method));
            let cubes = scenes::stack(app.world_mut(), 3);
            let speed = [1e6f32, 9.9e5, 1e5, 1e3][trial];
            let mass = [1e12f32, 1e-9, 1.0, 1e11][trial];
            let spin = [1e5f32, 0.0, 9.9e5, 1e6][trial];
            let dir = Vec3::new(next(), next(), next()).normalize();
            app.world_mut().entity_mut(cubes[1]).insert((
                Mass(mass),
                LinearVelocity(dir * speed),
                AngularVelocity(dir.cross(Vec3::Y).normalize_or_zero() * spin),
            ));
            app.world_mut().spawn((
                RigidBody::Kinematic,
                Collider::cuboid(1.0, 0.05, 0.1),
                Transform::from_xyz(0.0, 0.12, 3.0),
                AngularVelocity(Vec3::Y * 1e5),
            ));
            app.world_mut().spawn((scenes::ball(
                0.1,
                1e-9,
                Vec3::new(0.6, 0.1, 3.3),
                Vec3::ZERO,
            ),));
            app.world_mut().spawn((
                RigidBody::Dynamic,
                Collider::capsule(0.1, 0.3),
                Mass(1e12),
                Transform::from_xyz(9e6, 9e6, 0.0),
                LinearVelocity(Vec3::X * 1e6),
            ));
            run_steps(&mut app, 40);
            let mut q = app
                .world_mut()
                .query::<(&Transform, Option<&LinearVelocity>)>();
            for (t, v) in q.iter(app.world()) {
                assert!(
                    t.translation.is_finite() && t.rotation.is_finite(),
                    "{method:?}"
                );
                assert!(v.is_none_or(|v| v.0.is_finite()), "{method:?}");
            }
            for error in errors() {
                assert!(
                    error.contains("above 1e6") || error.contains("beyond 1e7"),
                    "{method:?} trial {trial}: {error}"
                );
            }
        }
    }
}
