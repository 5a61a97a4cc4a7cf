//! Runs one configuration of one scene and times it.
//!
//! The time of a step is the wall time of [`Engine::step`] alone: for impact3d and avian3d one
//! run of the schedule their physics plugin steps in (no `Main` schedule, no fixed-time loop),
//! for Rapier one `PhysicsPipeline::step`. Building the scene and reading states for the
//! metrics happen between steps and are not timed. The first steps of a run are a warm-up and
//! are left out; the reported figure is the median of the rest. Short scenes are run again
//! from the start until enough steps have been timed; a run that has blown up (see
//! [`crate::scenes::Probe::hopeless`]) is stopped where it is, timed over the steps it ran.

use std::time::Instant;

use crate::engines;
use crate::scenes::{Metrics, Probe, Scene, SceneSpec};
use crate::sweep::RunConfig;

/// Scenes with more dynamic bodies than this are sampled for the metrics every
/// [`SAMPLE_EVERY`] steps (and at the end) rather than every step.
const SAMPLE_ABOVE: usize = 200;
/// See [`SAMPLE_ABOVE`].
const SAMPLE_EVERY: usize = 10;

/// What one run gave.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunResult {
    /// Median wall time of one physics step after the warm-up, ms.
    pub ms_per_step: f64,
    /// Steps in one run of the scene.
    pub steps: usize,
    /// The scene's error and side metrics.
    pub metrics: Metrics,
}

/// Steps left out of the timing at the start of a run of `steps` steps.
pub fn warm_up(steps: usize) -> usize {
    (steps / 10).min(10)
}

/// Median of `values` (which it sorts); 0 for none.
pub fn median(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    values.sort_by(f64::total_cmp);
    let mid = values.len() / 2;
    if values.len() % 2 == 1 {
        values[mid]
    } else {
        0.5 * (values[mid - 1] + values[mid])
    }
}

/// Short runs are repeated from a fresh scene until at least this many steps, or
/// [`ENOUGH_MS`] of stepping, have been timed (at most [`MAX_REPEATS`] times), so that a median
/// of a few microseconds is not a median of five samples. The metrics come from the first run.
const MIN_TIMED_STEPS: usize = 1000;
/// See [`MIN_TIMED_STEPS`].
const ENOUGH_MS: f64 = 300.0;
/// See [`MIN_TIMED_STEPS`].
const MAX_REPEATS: usize = 20;

/// Runs `scene` (bodies `spec`) for its duration on the engine of `config`.
pub fn run(scene: &Scene, spec: &SceneSpec, config: &RunConfig) -> RunResult {
    let dt = config.dt().as_secs_f32();
    let steps = ((scene.duration / dt).round() as usize).max(1);
    let skip = warm_up(steps);
    let dense = spec.dynamic().count() <= SAMPLE_ABOVE;
    let mut probe = Probe::new(scene, spec);
    let mut states = Vec::new();
    let mut times = Vec::with_capacity(steps.max(MIN_TIMED_STEPS));
    let mut stopped = false;
    for repeat in 0..MAX_REPEATS {
        if stopped
            || repeat > 0
                && (times.len() >= MIN_TIMED_STEPS || times.iter().sum::<f64>() >= ENOUGH_MS)
        {
            break;
        }
        let mut engine = engines::build(scene, spec, config);
        for k in 1..=steps {
            let start = Instant::now();
            engine.step();
            let elapsed = start.elapsed().as_secs_f64() * 1e3;
            if k > skip {
                times.push(elapsed);
            }
            if repeat == 0 && (dense || k % SAMPLE_EVERY == 0 || k == steps) {
                engine.read(&mut states);
                probe.observe(k as f32 * dt, &states);
                // A run that blew up is stopped: its error is already decided, and a blown-up
                // pile's steps grow without bound (issue 8: 2.7 s a step at 409,000 contacts).
                if probe.hopeless() {
                    stopped = true;
                    break;
                }
            }
        }
    }
    RunResult {
        ms_per_step: median(&mut times),
        steps,
        metrics: probe.finish(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(&mut []), 0.0);
    }

    #[test]
    fn warm_up_is_short() {
        assert_eq!(warm_up(5), 0);
        assert_eq!(warm_up(60), 6);
        assert_eq!(warm_up(1000), 10);
    }
}
