//! The solver settings the probe examples take from the environment (included by
//! `#[path]`: a folder without `main.rs` is not an example of its own).

use impact3d::prelude::{FrictionModel, SolverConfig};

/// Overrides fields of `config` from the environment, for trying settings without a rebuild:
/// `HZ` (contact hertz), `SUB` (substeps), `ITER` (iterations), `RELAX` (relax iterations),
/// `BLOCK` (block iterations), `PUSH` (largest push-out speed, m/s), `TOL` (velocity tolerance,
/// m/s), `SLOP` (linear slop, m), `WARM=0` (no warm start), `FRICTION=manifold` or
/// `FRICTION=per_point` (the hybrid's friction model, [`FrictionModel`]).
pub fn override_from_env(config: &mut SolverConfig) {
    let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<f32>().ok());
    if let Some(h) = env("HZ") {
        config.contact_hertz = h;
    }
    if let Some(n) = env("SUB") {
        config.substeps = n as u32;
    }
    if let Some(n) = env("ITER") {
        config.iterations = n as u32;
    }
    if let Some(n) = env("RELAX") {
        config.relax_iterations = n as u32;
    }
    if let Some(n) = env("BLOCK") {
        config.max_block_iterations = n as u32;
    }
    if let Some(v) = env("PUSH") {
        config.max_push_out_speed = v;
    }
    if let Some(v) = env("TOL") {
        config.velocity_tolerance = v;
    }
    if let Some(v) = env("SLOP") {
        config.linear_slop = v;
    }
    if env("WARM") == Some(0.0) {
        config.warm_start = false;
    }
    match std::env::var("FRICTION").as_deref() {
        Ok("manifold") => config.friction_model = FrictionModel::Manifold,
        Ok("per_point") => config.friction_model = FrictionModel::PerPoint,
        _ => {}
    }
}
