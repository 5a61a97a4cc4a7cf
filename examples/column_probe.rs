//! The light alternating column (`scenes::column`, 10 cubes of 1 kg and 0.01 kg, sleeping off,
//! 10 s) at 30, 60 and 120 Hz with friction 0, 0.2 and 1: the largest rise of mechanical energy
//! above the start and where the top cube ends (the pinned failure
//! `column_alternating_light_with_friction_pinned`).
//!
//! ```sh
//! cargo run --release --example column_probe
//! ```
//!
//! Environment: `METHOD=soft` (the soft step instead of the default), `N` (cubes), `RATIO` (light
//! over heavy mass), `ONLY=60,1` (one rate and friction, with each step's rise on stderr),
//! `RATES=30,60` and `FRICTIONS=0.4,0.5` (the rates and frictions to run),
//! `TRACE=1` (every 10th step, each cube's horizontal offset / tilt, rad), `SECS` (seconds to
//! run, default 10), and overrides of
//! `SolverConfig`: `HZ` (contact hertz), `SUB`, `ITER`, `RELAX`, `BLOCK`, `PUSH`, `TOL`, `WARM=0`,
//! `FRICTION=manifold` or `per_point`.
#[path = "support/config_env.rs"]
mod config_env;

use bevy::prelude::*;
use impact3d::prelude::*;
use impact3d::scenes;

fn energy(app: &App, bodies: &[Entity]) -> f64 {
    let w = app.world();
    bodies
        .iter()
        .map(|&e| {
            let m = w.get::<ComputedMass>(e).unwrap();
            let t = w.get::<Transform>(e).unwrap();
            let v = w.get::<LinearVelocity>(e).unwrap().0.as_dvec3();
            let om = w.get::<AngularVelocity>(e).unwrap().0.as_dvec3();
            let mass = 1.0 / m.inverse_mass as f64;
            let q = t.rotation.as_dquat().normalize();
            let lw = q.inverse() * om;
            let inertia = m.local_inverse_inertia.as_dmat3().inverse();
            0.5 * mass * v.length_squared()
                + 0.5 * lw.dot(inertia * lw)
                + mass * 9.81 * t.translation.y as f64
        })
        .sum()
}

fn main() {
    let soft = std::env::var("METHOD").is_ok_and(|m| m == "soft");
    let n: usize = std::env::var("N")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(10);
    let ratio: f32 = std::env::var("RATIO")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0.01);
    let list = |name: &str, default: &[f64]| -> Vec<f64> {
        std::env::var(name).map_or(default.to_vec(), |s| {
            s.split(',').filter_map(|x| x.parse().ok()).collect()
        })
    };
    for hz in list("RATES", &[30.0, 60.0, 120.0]) {
        for friction in list("FRICTIONS", &[0.0, 0.2, 1.0]) {
            let friction = friction as f32;
            let only = std::env::var("ONLY").ok();
            if only
                .as_ref()
                .is_some_and(|o| *o != format!("{hz},{friction}"))
            {
                continue;
            }
            let mut app = scenes::headless_app(hz);
            app.insert_resource(SleepConfig {
                enabled: false,
                ..default()
            });
            let mut config = SolverConfig::for_method(if soft {
                SolverMethod::SoftStep
            } else {
                SolverMethod::Hybrid
            });
            config_env::override_from_env(&mut config);
            app.insert_resource(config);
            let cubes = scenes::column(app.world_mut(), n, friction, ratio);
            app.update();
            let e0 = energy(&app, &cubes);
            let (mut worst, mut at) = (0.0f64, 0);
            let steps = (std::env::var("SECS")
                .ok()
                .and_then(|s| s.parse::<f64>().ok())
                .unwrap_or(10.0)
                * hz) as u32;
            for step in 0..steps {
                app.update();
                let rise = energy(&app, &cubes) - e0;
                if only.is_some() {
                    eprintln!("STEP {step} rise {rise:.3}");
                }
                if std::env::var("TRACE").is_ok() && step % 10 == 0 {
                    let w = app.world();
                    let line: Vec<String> = cubes
                        .iter()
                        .map(|&e| {
                            let t = w.get::<Transform>(e).unwrap();
                            let ang = t.rotation.to_axis_angle().1;
                            format!("{:.1e}/{:.1e}", t.translation.xz().length(), ang)
                        })
                        .collect();
                    eprintln!("{step}: {}", line.join(" "));
                }
                if rise > worst {
                    worst = rise;
                    at = step;
                }
            }
            let top = app
                .world()
                .get::<Transform>(*cubes.last().unwrap())
                .unwrap()
                .translation;
            println!(
                "{hz} Hz friction {friction}: worst rise {worst:.3} J at step {at}; top at {top:.2}, {:.3e} m aside",
                top.xz().length()
            );
        }
    }
}
