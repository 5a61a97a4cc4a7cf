//! A refactor's check: the pose hash of a 300-body mixed pour (spheres, boxes, capsules, hulls,
//! mass ratios to 100:1) after 200 steps at 60 Hz, sleeping off, for every method, frictionless
//! and with friction 0.5. A change that moves code without changing behaviour prints the same
//! ten hashes before and after; run it on both sides of a change and compare:
//!
//! ```sh
//! cargo run --release --example hash_probe
//! ```

use bevy::prelude::*;
use impact3d::prelude::*;
use impact3d::scenes::{self, Pour, PourBodies};

/// Every method, in the order the probe prints them.
const METHODS: [SolverMethod; 5] = [
    SolverMethod::Hybrid,
    SolverMethod::Propagation,
    SolverMethod::SequentialImpulses,
    SolverMethod::SoftStep,
    SolverMethod::Jacobi,
];

/// Hash of the bits of every body's translation and rotation after 200 steps of the pour under
/// `method` with friction `friction`.
fn pour_hash(method: SolverMethod, friction: f32) -> u64 {
    let mut app = scenes::headless_app(60.0);
    app.insert_resource(SolverConfig::for_method(method));
    app.insert_resource(SleepConfig {
        enabled: false,
        ..default()
    });
    let spawned = scenes::pour_into(
        app.world_mut(),
        &Pour::walled_box(300, PourBodies::Mixed, 1.0, friction),
    );
    scenes::run_steps(&mut app, 200);
    scenes::pose_hash(app.world(), &spawned.bodies)
}

fn main() {
    for method in METHODS {
        for friction in [0.0, 0.5] {
            println!(
                "{method:?} friction {friction}: {:016x}",
                pour_hash(method, friction)
            );
        }
    }
}
