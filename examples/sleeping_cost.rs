//! What sleeping bodies cost: 10,000 spheres on a sparse grid (`scenes::sparse_flight`), once
//! awake in free flight and once all asleep, timed over 100 steps after 10 of warm-up.
//!
//! ```sh
//! cargo run --release --example sleeping_cost          # both
//! cargo run --release --example sleeping_cost asleep   # or only `asleep` / `awake`
//! ```

use std::time::Instant;

use impact3d::prelude::*;
use impact3d::scenes;

fn main() {
    let which: Vec<bool> = match std::env::args().nth(1).as_deref() {
        Some("asleep") => vec![true],
        Some("awake") => vec![false],
        _ => vec![false, true],
    };
    for asleep in which {
        let mut app = scenes::headless_app(60.0);
        let bodies = scenes::sparse_flight(app.world_mut(), 10_000);
        if asleep {
            for &b in &bodies {
                app.world_mut().entity_mut(b).insert(Sleeping::default());
            }
        }
        scenes::run_steps(&mut app, 10);
        let start = Instant::now();
        scenes::run_steps(&mut app, 100);
        let ms = start.elapsed().as_secs_f64() * 1000.0 / 100.0;
        let state = if asleep { "asleep" } else { "awake " };
        println!("10,000 spheres {state}: {ms:.2} ms per step");
    }
}
