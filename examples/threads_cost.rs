//! What the feature `parallel` buys: the step time of a 1,000-sphere pour into a walled box
//! (friction 0.5, sleeping off, the default solver), with Bevy's default task pools or, with
//! `THREADS=n`, a compute pool of `n` threads. Only the narrow phase's manifolds run in
//! parallel; the rest of the step is one thread. Compare:
//!
//! ```sh
//! THREADS=2 cargo run --release --example threads_cost               # two compute threads
//! THREADS=1 cargo run --release --example threads_cost               # one: serial
//! cargo run --release --example threads_cost --no-default-features   # built for one thread
//! ```
//!
//! Times steps 100-199 (the pile landing and settling) after 100 steps of warm-up; the fastest
//! of three runs. (Bevy's default pools on a 2-core machine give the compute pool one thread,
//! on which the narrow phase runs serially, as Bevy's `Query::par_iter` does. The lab's
//! `--scaling --threads 1,2` measures the same on its scenes.)

use std::time::Instant;

use bevy::app::{TaskPoolOptions, TaskPoolPlugin};
use bevy::prelude::*;
use impact3d::prelude::*;
use impact3d::scenes::{self, Pour, PourBodies};

fn main() {
    let threads: Option<usize> = std::env::var("THREADS").ok().and_then(|v| v.parse().ok());
    let mut options = TaskPoolOptions::default();
    if let Some(n) = threads {
        options.compute.min_threads = n.max(1);
        options.compute.max_threads = n.max(1);
    }
    let ms = (0..3)
        .map(|_| {
            let mut app = scenes::headless_app_with(
                60.0,
                (
                    MinimalPlugins.set(TaskPoolPlugin {
                        task_pool_options: options.clone(),
                    }),
                    PhysicsPlugins::default(),
                ),
            );
            app.insert_resource(SleepConfig {
                enabled: false,
                ..default()
            });
            scenes::pour_into(
                app.world_mut(),
                &Pour::walled_box(1000, PourBodies::Spheres, 1.0, 0.5),
            );
            scenes::run_steps(&mut app, 100);
            let start = Instant::now();
            scenes::run_steps(&mut app, 100);
            start.elapsed().as_secs_f64() * 1000.0 / 100.0
        })
        .fold(f64::INFINITY, f64::min);
    let mode = match (cfg!(feature = "parallel"), threads) {
        (false, _) => "one thread".to_string(),
        (true, Some(n)) => format!("parallel, {} compute thread(s)", n.max(1)),
        (true, None) => "parallel, Bevy's default pools".to_string(),
    };
    println!(
        "1,000-sphere pour, friction 0.5, default solver, sleeping off, 60 Hz, {mode}: {ms:.2} ms per step"
    );
}
