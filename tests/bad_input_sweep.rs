//! A seeded sweep of bad input: on one body of a small resting pile, awake and asleep, every
//! body component and every setting is set to NaN, infinity, 0, a negative value and 1e30 in
//! mid-run (at a step and for a duration drawn from a fixed seed), then restored. For each:
//! nothing panics, the bodies that never touched it are bit-identical to an undisturbed run,
//! there is at most one error line, and any quarantine ends on the step after the fix.

mod common;

use bevy::prelude::*;
use common::*;
use impact3d::dynamics::PhysicsLengthUnit;
use impact3d::prelude::*;
use impact3d::scenes::{self, headless_app};

const VALUES: [f32; 5] = [f32::NAN, f32::INFINITY, 0.0, -1.0, 1e30];
/// Steps of every run.
const STEPS: u32 = 80;

/// A fixed linear congruential sequence: the sweep is the same on every run.
struct Seed(u32);

impl Seed {
    fn below(&mut self, n: u32) -> u32 {
        self.0 = self.0.wrapping_mul(1664525).wrapping_add(1013904223);
        (self.0 >> 8) % n
    }
}

/// Ground; the bad body on top of another cube at x = 0; three cubes at x = 20 that never
/// touch them. Returns (app, bad, below, far cubes).
fn pile(sleeping: bool) -> (App, Entity, Entity, Vec<Entity>) {
    let mut app = headless_app(60.0);
    app.insert_resource(SleepConfig {
        enabled: sleeping,
        ..default()
    });
    let world = app.world_mut();
    scenes::ground(world);
    let mut cube = |x: f32, y: f32| {
        world
            .spawn((
                scenes::cuboid(Vec3::splat(0.5), 1.0, Vec3::new(x, y, 0.0)),
                Friction(0.5),
            ))
            .id()
    };
    let below = cube(0.0, 0.5);
    let bad = cube(0.0, 1.5);
    let far = vec![cube(20.0, 0.5), cube(20.0, 1.5), cube(20.0, 2.5)];
    (app, bad, below, far)
}

/// Sets one component of `e` to a value built from `v`; returns the restore.
type Break = fn(&mut EntityWorldMut, f32);

fn components() -> Vec<(&'static str, Break)> {
    vec![
        ("Transform::translation", |e, v| {
            e.get_mut::<Transform>().unwrap().translation = Vec3::splat(v)
        }),
        ("Transform::rotation", |e, v| {
            e.get_mut::<Transform>().unwrap().rotation = Quat::from_xyzw(v, v, v, v)
        }),
        ("LinearVelocity", |e, v| {
            e.insert(LinearVelocity(Vec3::splat(v)));
        }),
        ("AngularVelocity", |e, v| {
            e.insert(AngularVelocity(Vec3::splat(v)));
        }),
        ("Mass", |e, v| {
            e.insert(Mass(v));
        }),
        ("Density", |e, v| {
            e.remove::<Mass>().insert(Density(v));
        }),
        ("Restitution", |e, v| {
            e.insert(Restitution(v));
        }),
        ("Friction", |e, v| {
            e.insert(Friction(v));
        }),
        ("ComputedMass", |e, v| {
            let mut c = e.get_mut::<ComputedMass>().unwrap();
            c.inverse_mass = v;
            c.local_inverse_inertia = Mat3::from_diagonal(Vec3::splat(v));
        }),
    ]
}

/// Saves the bad body's components, for restoring them.
fn save(app: &App, e: Entity) -> impl Bundle + use<> {
    let w = app.world();
    (
        *w.get::<Transform>(e).unwrap(),
        *w.get::<LinearVelocity>(e).unwrap(),
        *w.get::<AngularVelocity>(e).unwrap(),
        Mass(1.0),
        Density::default(),
        *w.get::<Restitution>(e).unwrap(),
        *w.get::<Friction>(e).unwrap(),
    )
}

/// Every body component of the bad body, each bad value, awake and asleep.
#[test]
fn seeded_component_sweep() {
    let mut seed = Seed(0x9e37_79b9);
    for sleeping in [false, true] {
        let (mut reference, _, _, far) = pile(sleeping);
        scenes::run_steps(&mut reference, STEPS);
        let expected = snapshot(&reference, &far);
        for (name, set) in components() {
            for v in VALUES {
                let what = format!("{name} = {v} (sleeping {sleeping})");
                let (start, length) = (40 + seed.below(20), 1 + seed.below(3));
                capture_logs();
                let (mut app, bad, below, far) = pile(sleeping);
                scenes::run_steps(&mut app, start);
                if sleeping {
                    assert!(app.world().get::<Sleeping>(bad).is_some(), "{what}: awake");
                }
                let saved = save(&app, bad);
                // ComputedMass is the plugin's: restored by the plugin itself.
                let restore_computed = name != "ComputedMass";
                set(&mut app.world_mut().entity_mut(bad), v);
                let mut was_quarantined = false;
                for _ in 0..length {
                    app.update();
                    was_quarantined |= app.world().get::<Quarantined>(bad).is_some();
                    assert!(app.world().get::<Quarantined>(below).is_none(), "{what}");
                }
                if restore_computed {
                    app.world_mut().entity_mut(bad).insert(saved);
                }
                app.update();
                assert!(
                    app.world().get::<Quarantined>(bad).is_none(),
                    "{what}: the quarantine did not end on the step after the fix"
                );
                scenes::run_steps(&mut app, STEPS - start - length - 1);
                for e in [bad, below].into_iter().chain(far.iter().copied()) {
                    assert!(app.world().get::<Quarantined>(e).is_none(), "{what}");
                }
                assert_eq!(snapshot(&app, &far), expected, "{what}: far cubes changed");
                let errors: Vec<_> = take_logs()
                    .into_iter()
                    .filter(|(l, _)| *l == log::Level::Error)
                    .collect();
                assert!(errors.len() <= 1, "{what}: {errors:?}");
                assert_eq!(errors.len(), was_quarantined as usize, "{what}: {errors:?}");
            }
        }
    }
}

/// Sets one setting from `v`.
type Setting = fn(&mut World, f32);

fn settings() -> Vec<(&'static str, Setting)> {
    fn solver(w: &mut World) -> Mut<'_, SolverConfig> {
        w.resource_mut::<SolverConfig>()
    }
    fn narrow(w: &mut World) -> Mut<'_, NarrowPhaseConfig> {
        w.resource_mut::<NarrowPhaseConfig>()
    }
    fn count(v: f32) -> u32 {
        if v.is_nan() || v <= 0.0 { 0 } else { u32::MAX }
    }
    vec![
        ("substeps", |w, v| solver(w).substeps = count(v)),
        ("max_turn_per_substep", |w, v| {
            solver(w).max_turn_per_substep = v
        }),
        ("max_substeps", |w, v| solver(w).max_substeps = count(v)),
        ("iterations", |w, v| solver(w).iterations = count(v)),
        ("relax_iterations", |w, v| {
            solver(w).relax_iterations = count(v)
        }),
        ("max_propagation_sweeps", |w, v| {
            solver(w).max_propagation_sweeps = count(v)
        }),
        ("max_block_iterations", |w, v| {
            solver(w).max_block_iterations = count(v)
        }),
        ("velocity_tolerance", |w, v| {
            solver(w).velocity_tolerance = v
        }),
        ("restitution_threshold", |w, v| {
            solver(w).restitution_threshold = v
        }),
        ("contact_hertz", |w, v| solver(w).contact_hertz = v),
        ("contact_damping_ratio", |w, v| {
            solver(w).contact_damping_ratio = v
        }),
        ("max_push_out_speed", |w, v| {
            solver(w).max_push_out_speed = v
        }),
        ("baumgarte", |w, v| solver(w).baumgarte = v),
        ("linear_slop", |w, v| solver(w).linear_slop = v),
        ("contact_margin", |w, v| narrow(w).contact_margin = v),
        ("touch_distance", |w, v| narrow(w).touch_distance = v),
        ("linear_threshold", |w, v| {
            w.resource_mut::<SleepConfig>().linear_threshold = v
        }),
        ("time_to_sleep", |w, v| {
            w.resource_mut::<SleepConfig>().time_to_sleep = v
        }),
        ("Gravity", |w, v| {
            w.resource_mut::<Gravity>().0 = Vec3::splat(v)
        }),
        ("PhysicsLengthUnit", |w, v| {
            w.resource_mut::<PhysicsLengthUnit>().0 = v
        }),
    ]
}

/// Is the setting in `world` invalid, by the validation functions the pipeline calls (unit
/// tested against their documented ranges in `dynamics::validation`)?
fn invalid(world: &World) -> bool {
    let config = world.resource::<SolverConfig>();
    let narrow = world.resource::<NarrowPhaseConfig>();
    let sleep = world.resource::<SleepConfig>();
    !config.validated(&SolverConfig::default()).1.is_empty()
        || !narrow.validated(&NarrowPhaseConfig::default()).1.is_empty()
        || !sleep.validated(&SleepConfig::default()).1.is_empty()
        || !world
            .resource::<Gravity>()
            .validated(Gravity::default())
            .1
            .is_empty()
        || world
            .resource::<PhysicsLengthUnit>()
            .validated(1.0)
            .1
            .is_some()
}

/// Every setting, each bad value, awake and asleep: an invalid value is one error line and
/// changes nothing (the whole run is bit-identical to an undisturbed one); a valid one (0 is a
/// valid margin, say) logs nothing; either way nobody is quarantined and nothing panics.
#[test]
fn seeded_settings_sweep() {
    let mut seed = Seed(0x85eb_ca6b);
    for sleeping in [false, true] {
        let (mut reference, bad, below, far) = pile(sleeping);
        let all: Vec<Entity> = [bad, below].into_iter().chain(far).collect();
        scenes::run_steps(&mut reference, STEPS);
        let expected = snapshot(&reference, &all);
        for (name, set) in settings() {
            for v in VALUES {
                let what = format!("{name} from {v} (sleeping {sleeping})");
                let (start, length) = (40 + seed.below(20), 1 + seed.below(3));
                capture_logs();
                let (mut app, ..) = pile(sleeping);
                scenes::run_steps(&mut app, start);
                let saved = (
                    app.world().resource::<SolverConfig>().clone(),
                    app.world().resource::<SleepConfig>().clone(),
                    *app.world().resource::<Gravity>(),
                    *app.world().resource::<PhysicsLengthUnit>(),
                    app.world().resource::<NarrowPhaseConfig>().clone(),
                );
                set(app.world_mut(), v);
                let is_invalid = invalid(app.world());
                scenes::run_steps(&mut app, length);
                app.insert_resource(saved.0);
                app.insert_resource(saved.1);
                app.insert_resource(saved.2);
                app.insert_resource(saved.3);
                app.insert_resource(saved.4);
                scenes::run_steps(&mut app, STEPS - start - length);
                for &e in &all {
                    assert!(app.world().get::<Quarantined>(e).is_none(), "{what}");
                }
                let errors: Vec<_> = take_logs()
                    .into_iter()
                    .filter(|(l, _)| *l == log::Level::Error)
                    .collect();
                if is_invalid {
                    assert_eq!(snapshot(&app, &all), expected, "{what}: changed the run");
                    assert_eq!(errors.len(), 1, "{what}: {errors:?}");
                    assert!(errors[0].1.contains(name), "{what}: {}", errors[0].1);
                } else {
                    assert!(errors.is_empty(), "{what}: {errors:?}");
                }
            }
        }
    }
}
