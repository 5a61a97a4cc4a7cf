//! What the feature `parallel` buys: the step time of a 1,000-sphere pour into a walled box
//! (friction 0.5, sleeping off, the default solver), with Bevy's default task pools. Only the
//! narrow phase's manifolds run in parallel; the rest of the step is one thread. Build it both
//! ways and compare:
//!
//! ```sh
//! cargo run --release --example threads_cost                         # parallel (default)
//! cargo run --release --example threads_cost --no-default-features   # one thread
//! ```
//!
//! Times steps 100-199 (the pile landing and settling) after 100 steps of warm-up; the fastest
//! of three runs. (Bevy's default pools on a 2-core machine give the compute pool one thread,
//! and the thread that runs the step works on the narrow phase's chunks too: two workers.)

use std::time::Instant;

use bevy::prelude::*;
use impact3d::prelude::*;
use impact3d::scenes::{self, Pour, PourBodies};

fn main() {
    let ms = (0..3)
        .map(|_| {
            let mut app = scenes::headless_app(60.0);
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
    let mode = if cfg!(feature = "parallel") {
        "parallel"
    } else {
        "one thread"
    };
    println!(
        "1,000-sphere pour, friction 0.5, default solver, sleeping off, 60 Hz, {mode}: {ms:.2} ms per step"
    );
}
