//! What a settled pile costs each method: 4,000 spheres (r 0.5, density 1, friction 0.5)
//! poured into the walled 21 m box, 60 Hz, sleeping off, settled for 600 steps; then each
//! method's median and fastest step over the next 100 steps, the methods timed in turn in
//! each of three rounds so that a shared machine's load falls on all of them alike.
//!
//! ```sh
//! cargo run --release --example settled_pile_cost [--no-default-features]
//! ```
//!
//! Pass a count (`settled_pile_cost 1000`) for a smaller pile, and `--timed-only N` to run
//! only the N-th method (0 the default, 1 the soft step) for 1,000 timed steps, for a profiler.
//! `BODIES=boxes` (or `mixed`) in the environment pours cubes (or the mixed shapes) instead of
//! spheres. The environment overrides both methods' settings as `wall_cost`'s does
//! (`examples/support/config_env.rs`): `RELAX=n` their relax iterations (4: 2,000 spheres 9.7
//! -> 13.4 ms a step under the default, 2026-12-06), `FRICTION=per_point` the hybrid's
//! per-point friction.

use std::time::Instant;

use bevy::prelude::*;
use impact3d::prelude::*;
use impact3d::scenes::{self, Pour, PourBodies};

#[path = "support/config_env.rs"]
mod config_env;

/// A settled pile of `count` spheres under `method`, ready to be timed.
fn settled_pile(method: SolverMethod, count: usize) -> App {
    let mut app = scenes::headless_app(60.0);
    let mut config = SolverConfig::for_method(method);
    config_env::override_from_env(&mut config);
    app.insert_resource(config);
    app.insert_resource(SleepConfig {
        enabled: false,
        ..default()
    });
    scenes::pour_into(
        app.world_mut(),
        &Pour::walled_box(count, pour_bodies(), 1.0, 0.5),
    );
    scenes::run_steps(&mut app, 600);
    app
}

/// The pile's bodies: spheres, or `BODIES=boxes` / `BODIES=mixed` in the environment.
fn pour_bodies() -> PourBodies {
    match std::env::var("BODIES").as_deref() {
        Ok("boxes") => PourBodies::Boxes,
        Ok("mixed") => PourBodies::Mixed,
        _ => PourBodies::Spheres,
    }
}

/// Each step's time, ms, over `steps` steps.
fn step_times(app: &mut App, steps: usize) -> Vec<f64> {
    (0..steps)
        .map(|_| {
            let start = Instant::now();
            app.update();
            start.elapsed().as_secs_f64() * 1e3
        })
        .collect()
}

fn main() {
    let count = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(4000);
    let methods = [SolverMethod::Hybrid, SolverMethod::SoftStep];
    let args: Vec<String> = std::env::args().collect();
    if let Some(k) = args.iter().position(|a| a == "--timed-only") {
        let method = methods[args[k + 1].parse::<usize>().unwrap()];
        let mut app = settled_pile(method, count);
        let t = step_times(&mut app, 1000);
        println!(
            "{method:?}: {:.2} ms a step",
            t.iter().sum::<f64>() / 1000.0
        );
        return;
    }
    let mut apps: Vec<App> = methods.iter().map(|&m| settled_pile(m, count)).collect();
    let mut times = vec![Vec::new(); methods.len()];
    for _ in 0..3 {
        for (app, t) in apps.iter_mut().zip(&mut times) {
            t.extend(step_times(app, 100));
        }
    }
    println!(
        "settled pile of {count} {:?}, friction 0.5, 60 Hz, sleeping off:",
        pour_bodies()
    );
    let median = |t: &mut Vec<f64>| {
        t.sort_by(f64::total_cmp);
        (t[t.len() / 2], t[0])
    };
    let (base, _) = median(&mut times[1].clone());
    for (method, t) in methods.iter().zip(&mut times) {
        let (med, fastest) = median(t);
        println!(
            "  {method:?}: median {med:.2} ms, fastest {fastest:.2} ms, {:.2}x the soft step",
            med / base
        );
    }
}
