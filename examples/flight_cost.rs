//! What a step costs per body when nothing collides: 10,000 spheres in free flight
//! (`scenes::sparse_flight`: no gravity, sleeping off), 300 steps timed one by one after 10 of
//! warm-up; prints the median and the fastest step. Most of such a step is per-body
//! bookkeeping (the prepare stage, write back, the spatial query's records), so this is the
//! scene to profile it with.
//!
//! ```sh
//! cargo run --release --example flight_cost          # 10,000 spheres
//! cargo run --release --example flight_cost 1000     # or another count
//! ```

use std::time::Instant;

use impact3d::prelude::*;
use impact3d::scenes;

fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(10_000);
    let mut app = scenes::headless_app(60.0);
    app.insert_resource(SleepConfig {
        enabled: false,
        ..Default::default()
    });
    scenes::sparse_flight(app.world_mut(), n);
    scenes::run_steps(&mut app, 10);
    let mut ms: Vec<f64> = (0..300)
        .map(|_| {
            let start = Instant::now();
            app.update();
            start.elapsed().as_secs_f64() * 1000.0
        })
        .collect();
    ms.sort_by(f64::total_cmp);
    println!(
        "{n} spheres in free flight: median {:.2} ms, fastest {:.2} ms per step",
        ms[ms.len() / 2],
        ms[0]
    );
}
