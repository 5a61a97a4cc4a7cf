//! Shared helpers of the `methods_*` tests (solver methods against the reference scenes of
//! `SCENES.md`): an app per solver method, readers of a body's state, and the momentum and
//! energy of a set of bodies.
#![allow(dead_code)]

use bevy::prelude::*;
use impact3d::prelude::*;
use impact3d::scenes;

#[path = "../common/mod.rs"]
mod common;
pub use common::*;

/// A headless app stepping at `hz` with `config` as its solver settings and sleeping off, so
/// that every step exercises the solver (a sleeping island is not solved at all).
pub fn app_with(hz: f64, config: SolverConfig) -> App {
    let mut app = scenes::headless_app(hz);
    app.insert_resource(config);
    app.insert_resource(SleepConfig {
        enabled: false,
        ..default()
    });
    app
}

/// A headless app at `hz` using `method` with its usual substeps and iterations
/// ([`SolverConfig::for_method`]), sleeping off.
pub fn app(hz: f64, method: SolverMethod) -> App {
    app_with(hz, SolverConfig::for_method(method))
}

/// `method`'s usual settings with `iterations` velocity iterations.
pub fn with_iterations(method: SolverMethod, iterations: u32) -> SolverConfig {
    SolverConfig {
        iterations,
        ..SolverConfig::for_method(method)
    }
}

/// Kinetic energy (translation plus rotation) of `bodies`, J.
pub fn kinetic_energy(app: &App, bodies: &[Entity]) -> f32 {
    totals(app, bodies).2
}

/// Linear momentum of `bodies`, kg m/s.
pub fn momentum(app: &App, bodies: &[Entity]) -> Vec3 {
    totals(app, bodies).0
}

/// Angular momentum of `bodies` about the origin, kg m^2/s.
pub fn angular_momentum(app: &App, bodies: &[Entity]) -> Vec3 {
    totals(app, bodies).1
}

/// Velocities along x of `bodies`, m/s.
pub fn vx(app: &App, bodies: &[Entity]) -> Vec<f32> {
    bodies.iter().map(|&b| velocity(app, b).x).collect()
}

/// The solver statistics of the last step.
pub fn stats(app: &App) -> SolverStats {
    *app.world().resource::<SolverStats>()
}

/// True when every body's pose and velocities are finite and it is not quarantined.
pub fn all_finite(app: &App, bodies: &[Entity]) -> bool {
    bodies.iter().all(|&e| {
        position(app, e).is_finite()
            && rotation(app, e).is_finite()
            && velocity(app, e).is_finite()
            && spin(app, e).is_finite()
            && app.world().get::<Quarantined>(e).is_none()
    })
}

/// `|a - b| <= tol` for each pair, with a message naming what differs.
#[track_caller]
pub fn assert_close(what: &str, actual: &[f32], expected: &[f32], tol: f32) {
    assert_eq!(actual.len(), expected.len(), "{what}");
    for (a, e) in actual.iter().zip(expected) {
        assert!(
            (a - e).abs() <= tol,
            "{what}: got {actual:?}, expected {expected:?} within {tol}"
        );
    }
}

/// `value` lies in `[lo, hi]`, with a message.
#[track_caller]
pub fn assert_in(what: &str, value: f32, lo: f32, hi: f32) {
    assert!(
        (lo..=hi).contains(&value),
        "{what}: {value} not in [{lo}, {hi}]"
    );
}
