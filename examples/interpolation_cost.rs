//! Measures what transform interpolation costs per body: the same 10,000 spheres in free flight
//! (`scenes::sparse_flight`), 8 render frames per 60 Hz physics step, run with and without
//! `InterpolationConfig::all`; the difference in wall time per frame divided by the body count.
//!
//! ```sh
//! cargo run --release --example interpolation_cost
//! ```

use std::time::{Duration, Instant};

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use impact3d::prelude::*;
use impact3d::scenes;

const BODIES: usize = 10_000;
const FRAMES_PER_STEP: u32 = 8;
const FRAMES: u32 = 800;

/// Seconds per frame over `FRAMES` frames, after 80 warm-up frames.
fn run(all: bool) -> f64 {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        PhysicsPlugins::default().set(InterpolationPlugin { all }),
    ));
    let step = Time::<Fixed>::from_hz(60.0).timestep();
    app.insert_resource(Time::<Fixed>::from_hz(60.0))
        .insert_resource(TimeUpdateStrategy::ManualDuration(step / FRAMES_PER_STEP));
    app.update();
    scenes::sparse_flight(app.world_mut(), BODIES);
    for _ in 0..80 {
        app.update();
    }
    let start = Instant::now();
    for _ in 0..FRAMES {
        app.update();
    }
    start.elapsed().as_secs_f64() / FRAMES as f64
}

fn main() {
    let mut best = [Duration::MAX.as_secs_f64(); 2];
    for _ in 0..3 {
        for (slot, all) in [false, true].into_iter().enumerate() {
            best[slot] = best[slot].min(run(all));
        }
    }
    let per_body_ns = (best[1] - best[0]) / BODIES as f64 * 1e9;
    println!(
        "{BODIES} bodies, {FRAMES_PER_STEP} frames per step: {:.3} ms a frame without \
         interpolation, {:.3} ms with; {per_body_ns:.1} ns per body per frame",
        best[0] * 1e3,
        best[1] * 1e3
    );
}
