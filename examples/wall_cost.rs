//! What the awake wall of base 20 (210 cubes, friction 0.5, 60 Hz, sleeping off) costs and how
//! far its top cube moves: prints the median step time over `steps` and the top cube's largest
//! displacement (its sink included). Method index 0 (default) the hybrid, 1 the soft step, 2
//! sequential impulses; 600 steps unless given. For trying settings without a rebuild, the
//! environment overrides the method's `SolverConfig`: `HZ` (contact hertz), `SUB` (substeps),
//! `ITER` (iterations), `RELAX` (relax iterations), `BLOCK` (block iterations), `PUSH` (push-out
//! speed), `TOL` (velocity tolerance), `WARM=0` (no warm start), `FRICTION=per_point` (the
//! hybrid's per-point friction).
//!
//! ```sh
//! cargo run --release --example wall_cost [method index] [steps]
//! HZ=45 cargo run --release --example wall_cost 1
//! ```

use std::time::Instant;

#[path = "support/config_env.rs"]
mod config_env;

use bevy::prelude::*;
use impact3d::prelude::*;
use impact3d::scenes;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let method = match args.get(1).map(String::as_str) {
        Some("1") => SolverMethod::SoftStep,
        Some("2") => SolverMethod::SequentialImpulses,
        _ => SolverMethod::Hybrid,
    };
    let steps: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(600);
    let mut app = scenes::headless_app(60.0);
    let mut config = SolverConfig::for_method(method);
    config_env::override_from_env(&mut config);
    app.insert_resource(config);
    app.insert_resource(SleepConfig {
        enabled: false,
        ..default()
    });
    let cubes = scenes::pyramid_with(app.world_mut(), 20, false, 0.5);
    let top = *cubes.last().unwrap();
    let at = |app: &mut App| app.world().get::<Transform>(top).unwrap().translation;
    let starts: Vec<Vec3> = cubes
        .iter()
        .map(|&e| app.world().get::<Transform>(e).unwrap().translation)
        .collect();
    app.update();
    let start = at(&mut app);
    let mut times = Vec::new();
    let mut moved = 0f32;
    let mut sink = 0f32;
    for step in 0..steps {
        let t = Instant::now();
        app.update();
        times.push(t.elapsed().as_secs_f64() * 1e3);
        let p = at(&mut app);
        moved = moved.max(p.distance(start));
        sink = sink.max(start.y - p.y);
        if std::env::var("ROWS").is_ok() && step % 60 == 59 {
            let mut i = 0;
            let mut line = String::new();
            for row in 0..20 {
                let n = 20 - row;
                let dx: Vec<f32> = (i..i + n)
                    .map(|k| {
                        app.world()
                            .get::<Transform>(cubes[k])
                            .unwrap()
                            .translation
                            .x
                            - starts[k].x
                    })
                    .collect();
                let dy: f32 = (i..i + n)
                    .map(|k| {
                        app.world()
                            .get::<Transform>(cubes[k])
                            .unwrap()
                            .translation
                            .y
                            - starts[k].y
                    })
                    .sum::<f32>()
                    / n as f32;
                line += &format!(
                    "r{row}: x[{:+.3} .. {:+.3}] y{:+.4}\n",
                    dx[0],
                    dx[n - 1],
                    dy
                );
                i += n;
            }
            println!("{line}");
        }
        if step % 60 == 59 {
            println!(
                "t {:5.1} s: top {:?}, moved {:.4} m",
                (step + 1) as f32 / 60.0,
                p - start,
                moved
            );
        }
    }
    times.sort_by(f64::total_cmp);
    println!(
        "{method:?}: median {:.3} ms, moved {moved:.4} m (sink {sink:.4})",
        times[times.len() / 2]
    );
}
