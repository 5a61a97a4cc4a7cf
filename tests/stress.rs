//! The stress family of issue 8 (`impact3d::scenes`), under every solver method: piles poured
//! into a walled box, walls and pyramids of boxes, columns, boxes on a trimesh, and the issue's
//! small cases (light against heavy, the symmetric three-ball hit).
//!
//! For each scene and method, every step: no body faster than the scene's largest free-fall
//! speed plus a margin (see [`speed_limit`]); no body's centre outside the container (or below
//! the floor); no body quarantined; and under the default method, `SolverStats::
//! propagation_bound_hit` never set. Sleeping is off (the solver alone) except in the
//! `*_sleeping` scenes, the stability scenes with the default `SleepConfig`.
//!
//! Each (scene, method) is one test function (`scene::method`), so each can fail and be
//! ignored on its own. The default `cargo test` runs a short version of each scene
//! ([`Case::short`] steps at 60 Hz); `long_*` (ignored) run every scene for its full duration:
//! `cargo test --release --test stress -- --ignored`. `STRESS_CASES` in the environment (a
//! comma-separated list of substrings of case names) runs only the cases it names, so a slow
//! method's long run can be split: `STRESS_CASES=boxes,mixed cargo test --release --test stress
//! long_propagation -- --ignored`.
//!
//! Then the stability targets of the default method (`Hybrid`): the base-20 wall and the
//! 20-cube column with friction hold awake, the frictionless 1000:1 pair holds, light against
//! heavy keeps its energy, and the symmetric three-ball hit gives the symmetric answer.

mod common;

use bevy::prelude::*;
use common::*;
use impact3d::prelude::*;
use impact3d::scenes::{self, Pour, PourBodies, Spawned};

/// Standard gravity of the scenes, m/s^2.
const G: f32 = 9.81;

/// A stress scene: how it is built and for how long it runs.
struct Case {
    name: &'static str,
    build: fn(&mut World) -> Spawned,
    /// Steps at 60 Hz in the default `cargo test` (debug build).
    short: u32,
    /// Steps at 60 Hz of the full version (ignored tests, release).
    long: u32,
    /// Sleeping on (the default `SleepConfig`) instead of off.
    sleeping: bool,
}

/// A pour of issue 8's walled box (21 m x 21 m, bodies of size 0.5 m).
fn walled(
    world: &mut World,
    count: usize,
    bodies: PourBodies,
    density: f32,
    friction: f32,
) -> Spawned {
    scenes::pour_into(world, &Pour::walled_box(count, bodies, density, friction))
}

/// A structure standing on the ground: bodies must stay within `reach` m of the axis.
fn standing(bodies: Vec<Entity>, reach: f32, top: f32) -> Spawned {
    Spawned {
        bodies,
        half_width: reach,
        top,
        floor: true,
    }
}

/// Bodies in free space (no gravity): nothing to stay in, speeds bounded by the initial ones.
fn floating(bodies: Vec<Entity>) -> Spawned {
    Spawned {
        bodies,
        half_width: f32::INFINITY,
        top: 0.0,
        floor: false,
    }
}

fn spheres_1000_friction(w: &mut World) -> Spawned {
    walled(w, 1000, PourBodies::Spheres, 1.0, 0.5)
}
fn spheres_1000_frictionless(w: &mut World) -> Spawned {
    walled(w, 1000, PourBodies::Spheres, 1.0, 0.0)
}
fn spheres_1000_dense_friction(w: &mut World) -> Spawned {
    walled(w, 1000, PourBodies::Spheres, 1000.0, 0.5)
}
fn spheres_1000_dense_frictionless(w: &mut World) -> Spawned {
    walled(w, 1000, PourBodies::Spheres, 1000.0, 0.0)
}
fn spheres_4000_friction(w: &mut World) -> Spawned {
    walled(w, 4000, PourBodies::Spheres, 1.0, 0.5)
}
fn spheres_4000_frictionless(w: &mut World) -> Spawned {
    walled(w, 4000, PourBodies::Spheres, 1000.0, 0.0)
}
fn boxes_1000_friction(w: &mut World) -> Spawned {
    walled(w, 1000, PourBodies::Boxes, 1.0, 0.5)
}
fn boxes_1000_frictionless(w: &mut World) -> Spawned {
    walled(w, 1000, PourBodies::Boxes, 1000.0, 0.0)
}
fn mixed_1000_friction(w: &mut World) -> Spawned {
    walled(w, 1000, PourBodies::Mixed, 1000.0, 0.5)
}
fn wall_base20(w: &mut World) -> Spawned {
    // A toppling wall reaches at most its height (20 m) beyond its half base (10.5 m).
    standing(scenes::pyramid_with(w, 20, false, 0.5), 31.0, 19.5)
}
fn pyramid3d_base8(w: &mut World) -> Spawned {
    standing(scenes::pyramid_with(w, 8, true, 0.5), 13.0, 7.5)
}
fn column20_friction(w: &mut World) -> Spawned {
    standing(scenes::column(w, 20, 0.5, 1.0), 21.0, 19.5)
}
fn column100_alternating(w: &mut World) -> Spawned {
    standing(scenes::column(w, 100, 0.0, 1000.0), 101.0, 99.5)
}
fn trimesh_boxes(w: &mut World) -> Spawned {
    scenes::boxes_on_trimesh(w, 200, 0.5)
}
fn light_heavy(w: &mut World) -> Spawned {
    // The light ball rests on the half-space floor; the heavy one floats above it.
    let (a, b) = scenes::light_against_heavy(w);
    standing(vec![a, b], f32::INFINITY, 0.0)
}
fn three_balls(w: &mut World) -> Spawned {
    let (a, b, c) = scenes::three_ball_hit(w);
    floating(vec![a, b, c])
}

/// Every scene of the family. Short versions (chosen so the file stays near two minutes in the
/// debug build): the piles for 40 steps, past the first layer's landing at step 36, where
/// the default blows up today (at step 38; issue 8 saw steps 44-57 with another spacing), the
/// mixed pour for 55 (propagation pushes a body under the floor at step 53); the walls and
/// pyramids for 10-20 steps (the 3D pyramid under the default costs most: 0.6 s a step in
/// the debug build), the columns for 1-2 s, the small cases for the 1 s that contains their
/// impacts. The long versions are 10-30 s.
const CASES: &[Case] = &[
    Case {
        name: "spheres_1000_friction",
        build: spheres_1000_friction,
        short: 40,
        long: 1800,
        sleeping: false,
    },
    Case {
        name: "spheres_1000_frictionless",
        build: spheres_1000_frictionless,
        short: 40,
        long: 1800,
        sleeping: false,
    },
    Case {
        name: "spheres_1000_dense_friction",
        build: spheres_1000_dense_friction,
        short: 40,
        long: 1800,
        sleeping: false,
    },
    Case {
        name: "spheres_1000_dense_frictionless",
        build: spheres_1000_dense_frictionless,
        short: 40,
        long: 1800,
        sleeping: false,
    },
    Case {
        name: "spheres_4000_friction",
        build: spheres_4000_friction,
        short: 40,
        long: 1200,
        sleeping: false,
    },
    Case {
        name: "spheres_4000_frictionless",
        build: spheres_4000_frictionless,
        short: 40,
        long: 1200,
        sleeping: false,
    },
    Case {
        name: "boxes_1000_friction",
        build: boxes_1000_friction,
        short: 40,
        long: 1800,
        sleeping: false,
    },
    Case {
        name: "boxes_1000_frictionless",
        build: boxes_1000_frictionless,
        short: 40,
        long: 1800,
        sleeping: false,
    },
    Case {
        name: "mixed_1000_friction",
        build: mixed_1000_friction,
        short: 55,
        long: 1800,
        sleeping: false,
    },
    Case {
        name: "wall_base20",
        build: wall_base20,
        short: 20,
        long: 1200,
        sleeping: false,
    },
    Case {
        name: "wall_base20_sleeping",
        build: wall_base20,
        short: 20,
        long: 1200,
        sleeping: true,
    },
    Case {
        name: "pyramid3d_base8",
        build: pyramid3d_base8,
        short: 10,
        long: 1200,
        sleeping: false,
    },
    Case {
        name: "pyramid3d_base8_sleeping",
        build: pyramid3d_base8,
        short: 10,
        long: 1200,
        sleeping: true,
    },
    Case {
        name: "column20_friction",
        build: column20_friction,
        short: 120,
        long: 1200,
        sleeping: false,
    },
    Case {
        name: "column20_friction_sleeping",
        build: column20_friction,
        short: 120,
        long: 1200,
        sleeping: true,
    },
    Case {
        name: "column100_alternating",
        build: column100_alternating,
        short: 60,
        long: 1200,
        sleeping: false,
    },
    Case {
        name: "column100_alternating_sleeping",
        build: column100_alternating,
        short: 60,
        long: 1200,
        sleeping: true,
    },
    Case {
        name: "trimesh_boxes",
        build: trimesh_boxes,
        short: 40,
        long: 1800,
        sleeping: false,
    },
    Case {
        name: "trimesh_boxes_sleeping",
        build: trimesh_boxes,
        short: 40,
        long: 1800,
        sleeping: true,
    },
    Case {
        name: "light_against_heavy",
        build: light_heavy,
        short: 60,
        long: 600,
        sleeping: false,
    },
    Case {
        name: "three_ball_hit",
        build: three_balls,
        short: 60,
        long: 600,
        sleeping: false,
    },
];

/// The largest speed a body of the scene may reach, m/s: the free-fall speed from the highest
/// spawn, `sqrt(2 g top)`, plus the fastest initial speed, plus `max_push_out_speed`.
///
/// Why that margin: every scene has e = 0 except the three-ball hit (e = 1, no gravity, where
/// energy alone bounds every speed by the 1 m/s of the striker), so no body can move faster
/// than it would falling freely from its spawn height, except by what pushing penetration out
/// gives it: the soft contacts push out at no more than `max_push_out_speed` (3 m/s) relative
/// to the body pushed from. The bound is loose on purpose (issue 8's failures are 11 m/s to
/// 4e18 m/s in a pile whose free fall is 7.6 m/s); what it catches is energy created.
///
/// It is not a law for a structure that collapses: inelastic contacts can pass energy from
/// bodies the ground stops to one body still moving, whose speed then exceeds its own free
/// fall while the world's energy falls. The 20-cube column, once it has toppled under
/// sequential impulses, lands in a chain: at step 562 of the long run its top cube is thrown to
/// 22.76 m/s (limit 22.56) by the cube below it, which the ground trips and spins up (2.8 to
/// 11.1 rad/s), while the world loses 43 J that step and its mechanical energy never rises
/// above its start. Replayed from the sequential impulses' states at steps 548 and 552, the
/// default method throws the top cube to 23.04 and 23.11 m/s too (see the README).
fn speed_limit(spawned: &Spawned, initial: f32, config: &SolverConfig) -> f32 {
    (2.0 * G * spawned.top).sqrt() + initial + config.max_push_out_speed
}

/// What a run of a case found.
#[derive(Debug, Default)]
struct Outcome {
    /// The first violation, if any.
    failure: Option<String>,
    /// The largest speed seen, m/s, and the step.
    fastest: (f32, u32),
}

/// Runs `case` for `steps` at 60 Hz under `method` with its usual settings.
fn run(case: &Case, method: SolverMethod, steps: u32) -> Outcome {
    let mut app = scenes::headless_app(60.0);
    let config = SolverConfig::for_method(method);
    app.insert_resource(config.clone());
    app.insert_resource(SleepConfig {
        enabled: case.sleeping,
        ..default()
    });
    let spawned = (case.build)(app.world_mut());
    let initial = spawned
        .bodies
        .iter()
        .map(|&e| {
            app.world()
                .get::<LinearVelocity>(e)
                .map_or(0.0, |v| v.0.length())
        })
        .fold(0.0, f32::max);
    let limit = speed_limit(&spawned, initial, &config);
    let mut outcome = Outcome::default();
    for step in 1..=steps {
        app.update();
        let stats = *app.world().resource::<SolverStats>();
        if method == SolverMethod::Hybrid && stats.propagation_bound_hit {
            outcome.failure = Some(format!(
                "step {step}: propagation bound hit ({} sweeps, {} contacts)",
                stats.propagation_sweeps, stats.contacts
            ));
            return outcome;
        }
        for (i, &e) in spawned.bodies.iter().enumerate() {
            if let Some(q) = app.world().get::<Quarantined>(e) {
                outcome.failure = Some(format!("step {step}: body {i} quarantined: {}", q.reason));
                return outcome;
            }
            let (p, v) = (position(&app, e), velocity(&app, e).length());
            if v > outcome.fastest.0 {
                outcome.fastest = (v, step);
            }
            // A NaN speed fails too.
            if v.is_nan() || v > limit {
                outcome.failure = Some(format!(
                    "step {step}: body {i} at {v:.4} m/s > limit {limit:.2} m/s"
                ));
                return outcome;
            }
            let outside = p.x.abs().max(p.z.abs());
            let inside = outside <= spawned.half_width && (p.y > 0.0 || !spawned.floor);
            if !inside {
                outcome.failure = Some(format!(
                    "step {step}: body {i} left the container at {p} (half width {})",
                    spawned.half_width
                ));
                return outcome;
            }
        }
    }
    outcome
}

/// The short version of the case named `name` under `method`: fails with the first violation.
fn short(name: &str, method: SolverMethod) {
    let case = CASES.iter().find(|c| c.name == name).expect("a case");
    let outcome = run(case, method, case.short);
    if let Some(failure) = outcome.failure {
        panic!(
            "{name} under {method:?}: {failure} (fastest before: {:.3} m/s at step {})",
            outcome.fastest.0, outcome.fastest.1
        );
    }
}

/// One test per method of the short version of a case; each method's attributes (an
/// `#[ignore = "..."]` with the failure's numbers) in its own brackets, in the order hybrid,
/// propagation, sequential impulses, soft step, Jacobi.
macro_rules! stress {
    ($name:ident, [$(#[$h:meta])*], [$(#[$p:meta])*], [$(#[$si:meta])*], [$(#[$ss:meta])*], [$(#[$j:meta])*]) => {
        mod $name {
            use super::*;
            $(#[$h])*
            #[test]
            fn hybrid() {
                short(stringify!($name), SolverMethod::Hybrid);
            }
            $(#[$p])*
            #[test]
            fn propagation() {
                short(stringify!($name), SolverMethod::Propagation);
            }
            $(#[$si])*
            #[test]
            fn sequential_impulses() {
                short(stringify!($name), SolverMethod::SequentialImpulses);
            }
            $(#[$ss])*
            #[test]
            fn soft_step() {
                short(stringify!($name), SolverMethod::SoftStep);
            }
            $(#[$j])*
            #[test]
            fn jacobi() {
                short(stringify!($name), SolverMethod::Jacobi);
            }
        }
    };
}

stress!(spheres_1000_friction, [], [], [], [], []);
stress!(spheres_1000_frictionless, [], [], [], [], []);
stress!(spheres_1000_dense_friction, [], [], [], [], []);
stress!(spheres_1000_dense_frictionless, [], [], [], [], []);
stress!(spheres_4000_friction, [], [], [], [], []);
stress!(spheres_4000_frictionless, [], [], [], [], []);
stress!(boxes_1000_friction, [], [], [], [], []);
stress!(boxes_1000_frictionless, [], [], [], [], []);
stress!(
    mixed_1000_friction,
    [], [#[ignore = "fails (issue 8): step 45, a body at 13.4 m/s (limit 12.29 m/s; 13.6 before propagation pushed penetration out): squeezed out between heavy bodies through contacts that rest, which carry no friction under propagation (see EVENT_FRICTION_ROUNDS); 12.5 m/s at step 44 before its impacts carried friction"]], [], [], []
);
stress!(wall_base20, [], [], [], [], []);
stress!(wall_base20_sleeping, [], [], [], [], []);
stress!(pyramid3d_base8, [], [], [], [], []);
stress!(pyramid3d_base8_sleeping, [], [], [], [], []);
stress!(column20_friction, [], [], [], [], []);
stress!(column20_friction_sleeping, [], [], [], [], []);
stress!(
    column100_alternating,
    [], [], [], [#[ignore = "fails: step 58, a cube at 71.1 m/s (limit 47.18 m/s; step 43, 49.7 m/s when first pinned): the column collapses"]], [#[ignore = "fails: step 23, the bottom 1 kg cube is pushed through the floor (centre at y = -0.001 m; at step 24 and -0.020 m before split impulses)"]]
);
stress!(
    column100_alternating_sleeping,
    [], [], [], [#[ignore = "fails (sleeping on too): step 58, a cube at 71.1 m/s (limit 47.18 m/s): the column collapses"]], [#[ignore = "fails (sleeping on too): step 23, the bottom 1 kg cube is pushed through the floor (centre at y = -0.001 m)"]]
);
stress!(trimesh_boxes, [], [], [], [], []);
stress!(trimesh_boxes_sleeping, [], [], [], [], []);
stress!(light_against_heavy, [], [], [], [], []);
stress!(three_ball_hit, [], [], [], [], []);

/// Whether the `STRESS_CASES` filter (see the module's doc) lets case `name` run: every case
/// when it is unset or empty.
fn selected(name: &str) -> bool {
    let filter = std::env::var("STRESS_CASES").unwrap_or_default();
    let parts: Vec<&str> = filter.split(',').filter(|p| !p.is_empty()).collect();
    parts.is_empty() || parts.iter().any(|p| name.contains(p))
}

/// Every case at its full length under `method` (those `STRESS_CASES` selects); fails listing
/// every failing case.
///
/// Known failures of the long runs (2026-12-07, release; the short versions pass or are pinned
/// above): the hybrid none. Sequential impulses: the 100-body 1000:1 column (a cube leaves
/// the container at step 230, sleeping or not; before the sliding-friction fix also the
/// friction column, 22.8 m/s against its bound of 22.6). The soft step: the 100-body column
/// (71 m/s at step 58, pinned short too). Jacobi: the 100-body column (pinned short too) and
/// the mixed pour (a light hull pressed through the floor at step 115; it passed at 8.1 m/s
/// before the sliding-friction fix). Propagation: see the README's methods table. Collapses
/// under the speed bound pass these checks, and are in the README's methods table: the
/// friction column under sequential impulses (20.7 m/s) and the soft step (awake, 7.9 m/s),
/// the awake wall under Jacobi (19 m/s).
fn long(method: SolverMethod) {
    let failures: Vec<String> = CASES
        .iter()
        .filter(|case| selected(case.name))
        .filter_map(|case| {
            let outcome = run(case, method, case.long);
            println!(
                "{} under {method:?}: fastest {:.3} m/s at step {}{}",
                case.name,
                outcome.fastest.0,
                outcome.fastest.1,
                outcome
                    .failure
                    .as_deref()
                    .map_or(String::new(), |f| format!(": {f}"))
            );
            outcome.failure.map(|f| format!("{}: {f}", case.name))
        })
        .collect();
    assert!(failures.is_empty(), "{method:?}:\n{}", failures.join("\n"));
}

#[test]
#[ignore = "long: cargo test --release --test stress -- --ignored"]
fn long_hybrid() {
    long(SolverMethod::Hybrid);
}

#[test]
#[ignore = "long: cargo test --release --test stress -- --ignored"]
fn long_propagation() {
    long(SolverMethod::Propagation);
}

#[test]
#[ignore = "long: cargo test --release --test stress -- --ignored"]
fn long_sequential_impulses() {
    long(SolverMethod::SequentialImpulses);
}

#[test]
#[ignore = "long: cargo test --release --test stress -- --ignored"]
fn long_soft_step() {
    long(SolverMethod::SoftStep);
}

#[test]
#[ignore = "long: cargo test --release --test stress -- --ignored"]
fn long_jacobi() {
    long(SolverMethod::Jacobi);
}

// ---------------------------------------------------------------------------------------------
// Stability targets of the default method.
// ---------------------------------------------------------------------------------------------

/// 400 mixed shapes of 0.1 m (spheres, cuboids, capsules, hulls; masses from 4 g to 0.42 kg)
/// with friction 1 poured into a box of 4.2 m at 120 Hz (the 0.1 m member of
/// `examples/family_probe`'s mixed pours), the default, sleeping off, for 200 steps (1.7 s,
/// the pile has landed): no body faster than the free fall from the highest spawn plus the
/// push-out ([`speed_limit`], 6.5 m/s), none outside the box, none quarantined.
///
/// Before (2026-12-07): at step 91 a 4 g hull on the floor, under a 0.42 kg capsule whose
/// contact normal leaned 4 degrees off the floor's, left at 12.9 m/s: its hold (0.995) was not
/// a whole one, so its warm start took the capsule's whole impulse a substep late, a hundred
/// times its own weight. Now a support on fixed bodies passes on the part of the load their
/// friction holds (see `mark_passing_on` in `src/dynamics/solver/hybrid/transmit.rs`): 2.7 m/s
/// at most over the 8 s of the probe.
#[test]
fn small_mixed_pour_with_friction_stays_under_free_fall() {
    let pour = Pour::walled_box_sized(400, PourBodies::Mixed, 1.0, 1.0, 0.1);
    let mut app = awake_default_at(120.0);
    let spawned = scenes::pour_into(app.world_mut(), &pour);
    let limit = speed_limit(&spawned, 0.0, &SolverConfig::default());
    for step in 1..=200 {
        app.update();
        for &b in &spawned.bodies {
            let w = app.world();
            let v = w.get::<LinearVelocity>(b).unwrap().0.length();
            let p = w.get::<Transform>(b).unwrap().translation;
            assert!(v <= limit, "step {step}: {b} at {v} m/s (limit {limit})");
            assert!(
                p.x.abs().max(p.z.abs()) <= spawned.half_width && p.y > 0.0,
                "step {step}: {b} left the box at {p}"
            );
            assert!(w.get::<Quarantined>(b).is_none(), "step {step}: {b}");
        }
    }
}

/// A headless app at `hz` with the default solver and sleeping off.
fn awake_default_at(hz: f64) -> App {
    let mut app = scenes::headless_app(hz);
    app.insert_resource(SleepConfig {
        enabled: false,
        ..default()
    });
    app
}

/// A headless app at 60 Hz with the default solver and sleeping off.
fn awake_default() -> App {
    awake_default_at(60.0)
}

/// Fixed steps of `app` in `seconds`.
fn steps_for(app: &App, seconds: f32) -> u32 {
    let dt = app
        .world()
        .resource::<Time<Fixed>>()
        .timestep()
        .as_secs_f32();
    (seconds / dt).round() as u32
}

/// `(largest displacement of the top cube, its displacement over the second half)`, m, of a
/// pyramid wall (2D, base `base`, friction `friction`) standing `seconds` under `app`.
fn wall_motion(mut app: App, base: usize, friction: f32, seconds: f32) -> (f32, f32) {
    let steps = steps_for(&app, seconds);
    let cubes = scenes::pyramid_with(app.world_mut(), base, false, friction);
    let top = *cubes.last().unwrap();
    let start = position(&app, top);
    let (mut moved, mut half) = (0f32, start);
    for step in 0..steps {
        app.update();
        moved = moved.max(position(&app, top).distance(start));
        if step + 1 == steps / 2 {
            half = position(&app, top);
        }
    }
    (moved, position(&app, top).distance(half))
}

/// Issue 8: awake, friction 0.5, the base-20 wall (210 cubes) holds: its top cube moves less
/// than 1 cm in 10 s. The 1 cm is the criterion: well above the soft sink of the 20
/// contacts under the top cube with load-scaled stiffness (20 x 0.28 mm = 5.5 mm), far below a
/// collapse (0.22 m).
///
/// Pinned: the wall is stable (see `walls_with_friction_settle_awake`) but the top cube sinks
/// 3.2 cm (1.3 cm of it sideways, as the wall spreads) in the first half second: its cubes rest
/// on two supports each, and such manifolds are solved with the stiffness of their own
/// effective mass, not of the load they carry (`release_frictional_groups` in the solver says
/// why). Before that the wall rocked on its held supports and its top moved 10.4 cm, still
/// growing (2.11 m before the support hold).
#[test]
#[ignore = "fails (issue 8): the top cube moves 3.2 cm in 10 s (criterion 1 cm; 3.173 cm measured 2026-12-07 with the manifold friction, 3.27 cm per point), nearly all of it the soft sink of the first half second (10.4 cm and growing before); 10 s of 210 cubes, run in release"]
fn wall_base20_holds_awake() {
    let (moved, _) = wall_motion(awake_default(), 20, 0.5, 10.0);
    assert!(moved < 0.01, "the wall's top cube moved {moved} m in 10 s");
}

/// Issue 8: awake walls with friction settle and stay: the top cube moves less than 1 mm over
/// the second half of the run (a wall that rocks or creeps moves centimetres: the base-20 wall
/// moved 10 cm in 10 s, growing, before its multi-support manifolds were released from their
/// held supports), and less than 4 cm in all (its soft sink, measured 3.2 cm for base 20).
/// Measured over the second half: 0.1 mm (base 20, friction 0.5, 60 Hz).
#[test]
fn walls_with_friction_settle_awake() {
    for (base, friction, hz, seconds) in [(20, 0.5, 60.0, 10.0), (10, 1.0, 120.0, 5.0)] {
        let (moved, late) = wall_motion(awake_default_at(hz), base, friction, seconds);
        assert!(
            late < 1e-3 && moved < 0.04,
            "base {base}, friction {friction}, {hz} Hz: the top moved {moved} m, {late} m in the second half"
        );
    }
}

/// The largest sideways displacement, m, of the top of a column of `n` cubes (alternating 1 kg
/// and `ratio` kg) with friction `friction`, standing `seconds` under `app`.
fn column_drift(mut app: App, n: usize, friction: f32, ratio: f32, seconds: f32) -> f32 {
    let steps = steps_for(&app, seconds);
    let cubes = scenes::column(app.world_mut(), n, friction, ratio);
    let top = *cubes.last().unwrap();
    let start = position(&app, top);
    let mut drift = 0f32;
    for _ in 0..steps {
        app.update();
        let d = position(&app, top) - start;
        drift = drift.max(Vec2::new(d.x, d.z).length());
    }
    drift
}

/// Issue 8: awake, friction 0.5, a column of 20 cubes drifts less than 1 mm sideways in 20 s
/// (the top cube's horizontal displacement; its vertical sink, 20 x 0.28 mm, is not drift).
/// Friction holds a column against sideways motion, so the 1 mm is only rounding's room.
/// Measured 0.001 mm (0.23 mm solved point by point with load-scaled soft rows; 27 cm before
/// that, with a rigid tilt stopped at 1e-4 m/s: see `manifold_sweep`).
#[test]
fn column20_friction_holds_awake() {
    let drift = column_drift(awake_default(), 20, 0.5, 1.0, 20.0);
    assert!(
        drift < 1e-3,
        "the column's top cube drifted {drift} m sideways in 20 s"
    );
}

/// Issue 8, the column's family: counts, frictions, step rates and mass ratios, awake for
/// 20 s, each within the 1 mm. Measured (mm, release, 2026-12-07): 10 cubes, friction
/// 0.2: under 0.001; 20, friction 1.0: 0.001; 20 at 120 Hz: 0.001; 30 cubes: under 0.001; 20
/// at 30 Hz: 0.003 (0.074 with the rigid tilt's iterations on the bodies, 170 with them
/// dividing in velocity space before the biases were projected, see `project_biases`);
/// 20 alternating 1 kg and 0.1 kg: 0.001. Before a manifold with friction on a held support
/// kept a rigid tilt solved to 1e-7 m/s (see `manifold_sweep` in the solver), it was solved
/// point by point with soft rows, and these drifted 0.12, 0.25, 0.09, 36, 29 and 1.2 mm (the
/// 30-cube and 30 Hz members were pinned). Friction's value does not enter while no contact
/// slides: 0.1 and 1.0 give the same drift as 0.5.
#[test]
fn column_friction_family_holds_awake() {
    for (n, friction, ratio, hz) in [
        (10, 0.2, 1.0, 60.0),
        (20, 1.0, 1.0, 60.0),
        (20, 0.5, 1.0, 120.0),
        (30, 0.5, 1.0, 60.0),
        (20, 0.5, 1.0, 30.0),
        (20, 0.5, 0.1, 60.0),
    ] {
        let drift = column_drift(awake_default_at(hz), n, friction, ratio, 20.0);
        assert!(
            drift < 1e-3,
            "{n} cubes, friction {friction}, ratio {ratio}, {hz} Hz: the top drifted {drift} m"
        );
    }
}

/// Issue 8, the column's family with masses alternating 1 kg and 10 kg and with 50 cubes
/// (friction 0.5, 20 s awake), each within the 1 mm. Measured 2026-12-07 (release,
/// `examples/column_probe`): 1:10 at 30 and 60 Hz 0.8 and 0.3 um; 50 cubes at 60 and 120 Hz
/// 2.9 and 3.9 um. Before (the pinned figures below) a held support took, a substep late, the
/// whole impulse of the block above it, and its own supports had answered the impulse of the
/// substep before: now a wholly held support with friction takes none of it, and the load is
/// carried down the chain (`held_warm_start` and `Transmitted` in the solver).
#[test]
fn column_friction_family_heavy_holds_awake() {
    for (n, ratio, hz) in [
        (20, 10.0, 30.0),
        (20, 10.0, 60.0),
        (50, 1.0, 60.0),
        (50, 1.0, 120.0),
    ] {
        let drift = column_drift(awake_default_at(hz), n, 0.5, ratio, 20.0);
        assert!(
            drift < 1e-3,
            "{n} cubes, ratio {ratio}, {hz} Hz: the top drifted {drift} m"
        );
    }
}

/// Issue 8, the member of the column's family that still fails (the 1 mm criterion, 20 s
/// awake, friction 0.5): 20 cubes alternating 1 kg and 100 kg collapse (2026-12-07, since the
/// held warm start: at step 981, gaining 8.3 kJ). Before the held warm start, under the
/// manifold friction (the default since 2026-12-07, measured with `examples/column_probe`):
/// 20 cubes alternating 1 kg and 10 kg drift 0.18 m at 60 Hz,
/// gaining 6.6 J, and fall at 30 Hz (45 J); alternating 1 kg and 100 kg they collapse; 50
/// cubes drift 0.49 m at 60 Hz (0.7 J) and 84 mm at 120 Hz. Per point, the same day: 0.31 m,
/// falls (85 J), collapses, 0.33 m (2.2 J), 0.22 m. Before (per point, measured 2026-12-07,
/// release, the rigid tilt iterated in velocity
/// space with its penetrating biases projected): 20 cubes alternating 1 kg and 10 kg drift
/// 0.40 m at 60 Hz (0.27 m with the iterations on the bodies, 2.1 mm while such manifolds were
/// solved point by point) and fall at 30 Hz; 20 cubes alternating 1 kg and 100 kg collapse
/// (5.0 m; 3.6 m before); 50 cubes drift 5.6 m at 60 Hz (75 mm on the bodies, 4.0 m point by
/// point) and 0.32 m at 120 Hz (0.61 m, 46 mm). These runs turn on rounding: each moved with
/// the rounding of the same iterations (the 1:100 column 0.59 m and 50 cubes 2.4 m before the
/// projection, 7.2 m and 3.1 m projecting every row). The held support answers its block a substep late (through the warm start),
/// and a heavy cube's rigid tilt hands a light support below it torques ten times its own.
#[test]
#[ignore = "fails (issue 8): 20 cubes alternating 1:100 collapse (2026-12-07: step 981, gaining 8.3 kJ)"]
fn column_friction_family_pinned() {
    let drift = column_drift(awake_default_at(60.0), 20, 0.5, 100.0, 20.0);
    assert!(
        drift < 1e-3,
        "20 cubes, ratio 100, 60 Hz: the top drifted {drift} m"
    );
}

/// Issue 8, the column's family wider: uniform columns of 18-30 cubes, friction 0.4, 0.5 and
/// 0.7, at 30 and 60 Hz (42 columns, 20 s awake each), every one within the 1 mm.
/// Measured 2026-12-07 (release) since a wholly held support takes no part of what it passes
/// on (`held_warm_start` in the solver): all 42 within 0.0012 mm (30 cubes at 30 Hz
/// 1.16e-6 m; the 60 Hz ones within 4.1e-7 m), the drift the same bits for each friction (no
/// corner reaches its bound). Before it, under the manifold friction: 39 of 42 within
/// 0.006 mm and 30 cubes at 30 Hz 1.5 mm (failing; at 30 Hz such columns fell within 40 s,
/// which now stand, see the README's "Friction"). Per point before that: all under 0.013 mm;
/// since a sliding contact takes the nearest point of the Coulomb disc (`disc_solve`), the
/// 60 Hz columns still all under 0.03 mm, but at 30 Hz 20 cubes drifted 0.18-0.35 mm, 22
/// cubes 0.65 mm, 30 cubes 0.98 mm with friction 0.5 and 0.119 m with friction 0.4. Before
/// the biases of a rigid tilt were projected onto a rigid motion's fields (`project_biases` in
/// the solver), one of the 42 failed, a different one with the rounding of the iterations.
/// Run it after any change to the resting phase. About 20 s in release; `#[ignore]`d for the
/// default run.
#[test]
#[ignore = "long: 42 columns of 20 s; cargo test --release --test stress -- --ignored column_friction_family_wide"]
fn column_friction_family_wide() {
    let mut failed = Vec::new();
    for hz in [30.0, 60.0] {
        for n in [18, 19, 20, 21, 22, 25, 30] {
            for friction in [0.4, 0.5, 0.7] {
                let drift = column_drift(awake_default_at(hz), n, friction, 1.0, 20.0);
                println!("{n} cubes, friction {friction}, {hz} Hz: {drift:.3e} m");
                if drift >= 1e-3 {
                    failed.push(format!(
                        "{n} cubes, friction {friction}, {hz} Hz: {drift} m"
                    ));
                }
            }
        }
    }
    assert!(failed.is_empty(), "drifted past 1 mm: {failed:?}");
}

/// Issue 8: the frictionless 1000:1 pair (a 1000 kg cube on a 1 kg cube) holds awake as today:
/// neither cube moves more than 5 cm (the lab's tolerance for its stability scenes) in 10 s.
#[test]
fn heavy_pair_1000_holds_awake() {
    let mut app = awake_default();
    let (lower, upper) = scenes::cube_on_cube(app.world_mut(), 1000.0);
    let start = [position(&app, lower), position(&app, upper)];
    let mut moved = 0f32;
    for _ in 0..600 {
        app.update();
        for (e, s) in [lower, upper].into_iter().zip(start) {
            moved = moved.max(position(&app, e).distance(s));
        }
    }
    assert!(moved < 0.05, "the 1000:1 pair moved {moved} m in 10 s");
}

/// Issue 8: frictionless columns alternating 1 kg and 1000 kg cubes hold awake: over 10 s no
/// cube moves faster than 1e-3 m/s and the top drifts less than 1 mm sideways (10 and 20
/// cubes). Measured: 4.0e-5 and 6.2e-5 m/s. Before a pressed light cube took its normals from
/// its own faces (`lighter_face_normal`), its heavy neighbours' faces gave them, their rounding
/// tilts squeezed it out sideways, and the 10-cube column reached 2.3e-2 m/s by 10 s, still
/// growing (the 100-cube one slid a light cube out at 0.3 m/s and blew up at step 116).
#[test]
fn alternating_1000_columns_hold_awake() {
    for n in [10, 20] {
        let mut app = awake_default();
        let cubes = scenes::column(app.world_mut(), n, 0.0, 1000.0);
        let top = *cubes.last().unwrap();
        let start = position(&app, top);
        let (mut fastest, mut drift) = (0f32, 0f32);
        for _ in 0..600 {
            app.update();
            for &c in &cubes {
                fastest = fastest.max(velocity(&app, c).length());
            }
            let d = position(&app, top) - start;
            drift = drift.max(Vec2::new(d.x, d.z).length());
        }
        assert!(
            fastest < 1e-3 && drift < 1e-3,
            "{n} cubes: fastest {fastest} m/s, the top drifted {drift} m"
        );
    }
}

/// Issue 8: light against heavy keeps its energy: with e = 0 and no gravity the kinetic energy
/// may only fall from its 0.625 J (1e-5 relative: f32 rounding of the reading).
///
/// What it should fall to: the light ball (m = 0.05 kg) meets the heavy one (M = 5 kg) with
/// the line of centres `n = (0.433, 0.55, 0) / 0.7` (the centres 0.7 m apart, 0.55 m apart in
/// height) while resting on the floor. Solving the hit and the floor together, inelastically
/// (impulse `j` along `n` between the balls, `j n_y` from the floor keeping the light ball's
/// `v_y = 0`): `(v_heavy - v_light).n = 0` gives `j (1/M + n_x^2/m) = 5 n_x`, `j = 0.3938`
/// N s, the light ball left at (0.127, 0, 0) m/s and the heavy ball at 0.0788 m/s along `n`:
/// 0.0159 J. A sequential solve gives a different split, but never more than 0.625 J.
#[test]
fn light_against_heavy_keeps_energy() {
    let mut app = awake_default();
    let (light, heavy) = scenes::light_against_heavy(app.world_mut());
    // The light ball's 0.05 kg at 5 m/s (`ComputedMass` is derived in the first step).
    let e0 = 0.625f64;
    let mut highest = e0;
    for _ in 0..120 {
        app.update();
        highest = highest.max(kinetic(&app, &[light, heavy]));
    }
    assert!(
        highest <= e0 * (1.0 + 1e-5),
        "kinetic energy rose from {e0} J to {highest} J"
    );
}

/// Kinetic energy of `bodies`, J (f64, from the stored f32 state).
fn kinetic(app: &App, bodies: &[Entity]) -> f64 {
    bodies.iter().map(|&e| body_state(app, e).kinetic).sum()
}

/// Issue 8: the symmetric three-ball hit gives the symmetric, simultaneous answer and keeps
/// its energy at e = 1.
///
/// Derivation (unit masses, A at (1, 0) m/s, B and C at rest, normals from A
/// `n_B = (cos 30, sin 30)`, `n_C = (cos 30, -sin 30)`; impulses `j_B n_B` on B, `j_C n_C` on
/// C, minus both on A). Solved together, each contact's restitution law
/// `(v_X - v_A).n_X = -e (v0_X - v0_A).n_X = cos 30` (the approach was `-cos 30`); by symmetry
/// `j_B = j_C = j`, so `v_A = (1 - 2 j cos 30, 0)`, `v_B = j n_B`, and
/// `j - (1 - 2 j cos 30) cos 30 = cos 30`, i.e. `j (1 + 2 cos^2 30) = 2 cos 30`,
/// `j = 2 (0.866025) / 2.5 = 0.692820`: A (1 - 2 j cos 30, 0) = (-0.2, 0), B = j n_B =
/// (0.6, 0.346410), C (0.6, -0.346410). Energy: (0.04 + 2 (0.36 + 0.12)) / 2 = 0.5 J, the
/// striker's 0.5 J; momentum 0.6 + 0.6 - 0.2 = 1 along x.
///
/// Tolerances: 1e-3 m/s on each velocity, ten times the solver's velocity tolerance (1e-4
/// m/s, where its block solves stop); energy within 1e-3 relative (the same 1e-4 m/s on
/// speeds of order 1). Today the hybrid resolves one contact first and treats the 0.43 m/s
/// re-impact as inelastic (under the 0.5 m/s threshold): asymmetric, 9.4% of the energy lost.
#[test]
fn three_ball_hit_is_symmetric() {
    let mut app = awake_default();
    let (a, b, c) = scenes::three_ball_hit(app.world_mut());
    scenes::run_steps(&mut app, 60);
    let s = 0.6 * 30f32.to_radians().tan();
    for (e, expected) in [
        (a, Vec3::new(-0.2, 0.0, 0.0)),
        (b, Vec3::new(0.6, s, 0.0)),
        (c, Vec3::new(0.6, -s, 0.0)),
    ] {
        let v = velocity(&app, e);
        assert!(
            (v - expected).abs().max_element() <= 1e-3,
            "got A {}, B {}, C {}; expected A (-0.2, 0), B (0.6, +-{s})",
            velocity(&app, a),
            velocity(&app, b),
            velocity(&app, c)
        );
    }
    let e = kinetic(&app, &[a, b, c]);
    assert!(
        (e - 0.5).abs() <= 1e-3 * 0.5,
        "energy {e} J, expected 0.5 J"
    );
}

/// Mechanical energy (kinetic plus `m g y`) of `bodies`, J.
fn mechanical(app: &App, bodies: &[Entity]) -> f64 {
    bodies
        .iter()
        .map(|&b| {
            let s = body_state(app, b);
            s.kinetic + s.mass * G as f64 * s.center.y
        })
        .sum()
}

/// Issue 8: a column of 10 cubes alternating 1 kg (the bottom one) and 0.01 kg, with friction
/// 0.2 and 1.0, awake for 20 s at 60 and 120 Hz: its energy never rises. Answer: a resting
/// column's mechanical energy never rises above its start by more than its soft contacts
/// store, at most `4 n M g delta` (as in `tests/energy.rs`: `n` = 10 cubes, `M` = 5.05 kg,
/// `delta` the soft sink, 0.28 mm): 0.55 J. Measured 2026-12-07 (release, `column_probe`):
/// no rise at all, the top within 2e-7 m of its line, since a wholly held support with
/// friction takes no part of the impulse it passes on (`held_warm_start` in the solver). Before
/// that: 7.5 and 23.6 J at 60 Hz (the column fell), none at 120 Hz; see the pinned 30 Hz
/// member below.
#[test]
fn column_alternating_light_with_friction_holds() {
    alternating_light_column_keeps_its_energy(&[60.0, 120.0]);
}

/// Pinned (issue 8): the same column at 30 Hz, under the default, gains energy and falls.
/// Measured 2026-12-07 since the held warm start (release, `column_probe`, 20 s): it stands
/// 17 s and falls then, gaining 40.5 J with friction 0.2 and 15.4 J with friction 1.0 (step
/// 520-521). Under the manifold friction before it (the default since 2026-12-07;
/// `examples/column_probe`, 20 s, the largest rise, J, and its step): friction 0.2: 3.1 (234)
/// at 30 Hz, 7.5 (813) at 60 Hz, none at 120 Hz; friction 1.0: 10.4 (271), 23.6 (919), none.
/// Per point, the same day: 17.6 (264), 8.5 (958), none; 254 (216), 11.2 (792), none.
/// Measured per point before (20 s, release, 2026-12-07, the rigid tilt of held
/// chains iterated in velocity space; the largest rise above the start, J, and its step):
/// friction 0.2: 29.4 (244) at 30 Hz, 11.8 (938) at 60 Hz, none at 120 Hz; friction 1.0:
/// 40.0 (228), 28.4 (938), none. The column stands 4 s at 30 Hz and 16 s at 60 Hz and falls
/// then (the top cube below 9 m at steps 260-264 and 973-1017). On 2026-12-06, the same solve
/// on the bodies without the projection of its biases: 2.3 (386), 6.6 (807), none; 12.5 (420),
/// 31.5 (776), none; standing 13 s at 30 Hz. Before
/// (10 s, each link's tilt soft): friction 0.2: 27 (46) at 30 Hz, 17 (149) at 60 Hz, 14 (985)
/// at 120 Hz; friction 1.0: 91 (59), 45 (195), 21 (712). The column collapsed: its light
/// cubes tilt 0.1-0.3 rad between their 1 kg neighbours and are squeezed out sideways
/// (7-14 m/s at 30 Hz, friction 0.2), and the energy comes in those steps. The
/// soft contacts' push-out is its source: with `max_push_out_speed = 0` no run gains, under the
/// default or `SoftStep` (which gains 4.5 J at 30 Hz with friction 1.0, and nothing once its
/// relax pass converges, 32 iterations). The default's relax pass holds the light supports and
/// hands them each held block's change a substep late through the warm start: more relax
/// iterations make it worse (32: 163,554 J at 30 Hz, friction 0.2). Holding no support lighter
/// than what it carries cut the rises to 5.8 J (none with 16 relax iterations) but lets the
/// 1000:1 heavy-on-light pair squeeze its light box out (`heavy_on_light_default`, 14.7 m).
/// Frictionless, the same column stands (no rise in 10 s at 30, 60 and 120 Hz); under
/// `Propagation` and sequential impulses (both push out by split impulses) it gains nothing;
/// Jacobi crushes it (0.27 m). The README's "Energy and stability" has the earlier traces.
#[test]
#[ignore = "fails (issue 8): at 30 Hz the default's 1:100 alternating column with friction gains energy as it falls after 17 s (2026-12-07: 40.5 and 15.4 J with friction 0.2 and 1.0); see doc"]
fn column_alternating_light_with_friction_pinned() {
    alternating_light_column_keeps_its_energy(&[30.0]);
}

/// The assertion of [`column_alternating_light_with_friction_holds`] at each rate of `rates`.
fn alternating_light_column_keeps_its_energy(rates: &[f64]) {
    for &hz in rates {
        for friction in [0.2, 1.0] {
            let mut app = awake_default_at(hz);
            let cubes = scenes::column(app.world_mut(), 10, friction, 0.01);
            app.update();
            let e0 = mechanical(&app, &cubes);
            let weight: f64 =
                cubes.iter().map(|&b| body_state(&app, b).mass).sum::<f64>() * G as f64;
            let sink = G as f64 / (2.0 * std::f64::consts::PI * 30.0).powi(2);
            let allowance = 4.0 * cubes.len() as f64 * weight * sink;
            for step in 0..steps_for(&app, 20.0) {
                app.update();
                let e = mechanical(&app, &cubes);
                assert!(
                    e <= e0 + allowance,
                    "{hz} Hz, friction {friction}, step {step}: energy {e} J, start {e0} J"
                );
            }
        }
    }
}

/// Issue 8, a family the stress scenes had no member of: piles with restitution. 400 bodies
/// (spheres, or the mixed shapes with mass ratios to 100:1) poured into the walled box of
/// `Pour::walled_box` (r 0.5 m, density 1), every body with restitution `e`, 60 Hz, the
/// default, sleeping off, for 2 s (the pile lands at about step 35 and bounces): the default
/// never hits its propagation bound, no body is quarantined, and the mechanical energy
/// (kinetic plus `m g y`) never rises above its value after the first step, by more than the
/// soft contacts can store: the pile's weight `M g` sunk by 4 soft sinks `g / (2 pi 30 Hz)^2`
/// per layer, 2 layers (the allowance of `tests/energy.rs`, with the layers that carry each
/// other in place of every body). A pile with restitution loses energy at every bounce; no
/// step may give it back. (Speed is not bounded by the free fall here: with `e > 0` and
/// 100:1 masses a light body under a heavy one leaves faster than it fell, as in
/// `galilean_cannon`.)
///
/// Before (measured, release, 8 s at 60 Hz): the bound was hit in 24 steps (spheres, e = 0.2,
/// frictionless), 13 (spheres, e = 0.5), 148 (mixed, e = 0.2), 58 (mixed, e = 0.5, friction
/// 0.3); at 30 and 120 Hz alike. In a touching cluster an impact with restitution was passed
/// back and forth between the same bodies at one instant, smaller each time (inelastic
/// collapse), some groups 50 times in one pass: now a group struck again at the instant of its
/// last impact is inelastic (see `struck_again` in `solver/propagation/timing.rs`). After: no
/// bound hit in the same runs, e = 0.2 to 1, spheres, boxes and mixed, friction 0 and 0.3, at
/// 30, 60 and 120 Hz (`examples/family_probe.rs`).
#[test]
fn piles_with_restitution_never_hit_the_bound() {
    for (bodies, e, friction) in [
        (PourBodies::Spheres, 0.2, 0.0),
        (PourBodies::Spheres, 0.5, 0.0),
        (PourBodies::Mixed, 0.2, 0.0),
        (PourBodies::Mixed, 0.5, 0.3),
    ] {
        let mut app = awake_default();
        let spawned = walled(app.world_mut(), 400, bodies, 1.0, friction);
        for &b in &spawned.bodies {
            app.world_mut().entity_mut(b).insert(Restitution(e));
        }
        app.update();
        let e0 = mechanical(&app, &spawned.bodies);
        let weight: f64 = spawned
            .bodies
            .iter()
            .map(|&b| body_state(&app, b).mass * G as f64)
            .sum();
        let sink = G as f64 / (2.0 * std::f64::consts::PI * 30.0).powi(2);
        let allowance = 4.0 * 2.0 * weight * sink;
        let what = format!("{bodies:?}, e = {e}, friction {friction}");
        for step in 2..=120 {
            app.update();
            let stats = *app.world().resource::<SolverStats>();
            assert!(
                !stats.propagation_bound_hit,
                "{what}: step {step}, bound hit ({} sweeps)",
                stats.propagation_sweeps
            );
            for &b in &spawned.bodies {
                assert!(app.world().get::<Quarantined>(b).is_none(), "{what}: {b}");
            }
            let now = mechanical(&app, &spawned.bodies);
            assert!(
                now <= e0 + allowance,
                "{what}: step {step}, energy {now} J above {e0} J + {allowance} J"
            );
        }
    }
}
