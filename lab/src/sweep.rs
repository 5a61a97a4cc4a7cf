//! The configurations each scene runs on: every impact3d method over a grid of substeps and
//! iterations at each time step, and the peers at their defaults and at 1, 2, 4, 8 substeps
//! (avian3d) or solver iterations (Rapier); see [`configs`] for what each mode runs.

use std::time::Duration;

use impact3d::prelude::{SolverConfig, SolverMethod};

use crate::Mode;
use crate::scenes::{Kind, Scene};

/// Which engine a run uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum EngineKind {
    /// impact3d with this solver method.
    Impact3d(SolverMethod),
    /// avian3d 0.7.
    Avian,
    /// Rapier 0.36.
    Rapier,
}

/// avian3d's default substep count.
pub const AVIAN_DEFAULT_SUBSTEPS: u32 = 6;
/// Rapier's default solver iteration count (each one is a substep of its soft TGS solver).
pub const RAPIER_DEFAULT_ITERATIONS: u32 = 4;

/// One run's settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RunConfig {
    /// Engine (and impact3d method).
    pub engine: EngineKind,
    /// Iterations per substep (impact3d), or Rapier's solver iterations; 1 for avian3d.
    pub iterations: u32,
    /// Substeps per step (impact3d, avian3d); 1 for Rapier.
    pub substeps: u32,
    /// Steps per second: dt = 1 / hz.
    pub hz: u32,
    /// The engine's (or method's) own substeps and iterations.
    pub default_settings: bool,
}

impl RunConfig {
    /// The time step.
    pub fn dt(&self) -> Duration {
        Duration::from_secs_f64(1.0 / self.hz as f64)
    }

    /// "impact3d", "avian3d" or "rapier3d".
    pub fn engine_name(&self) -> &'static str {
        match self.engine {
            EngineKind::Impact3d(_) => "impact3d",
            EngineKind::Avian => "avian3d",
            EngineKind::Rapier => "rapier3d",
        }
    }

    /// The impact3d method, or "default" for a peer.
    pub fn method(&self) -> String {
        match self.engine {
            EngineKind::Impact3d(m) => format!("{m:?}"),
            _ => "default".into(),
        }
    }

    /// The chart series: the impact3d method, or the peer's name.
    pub fn series(&self) -> String {
        match self.engine {
            EngineKind::Impact3d(m) => format!("impact3d {m:?}"),
            _ => self.engine_name().into(),
        }
    }

    /// A short label, e.g. `Hybrid 4x1 @60Hz`.
    pub fn label(&self) -> String {
        let knobs = match self.engine {
            EngineKind::Impact3d(_) => format!("{}x{}", self.substeps, self.iterations),
            EngineKind::Avian => format!("{} substeps", self.substeps),
            EngineKind::Rapier => format!("{} iterations", self.iterations),
        };
        let name = match self.engine {
            EngineKind::Impact3d(m) => format!("{m:?}"),
            _ => self.engine_name().into(),
        };
        format!("{name} {knobs} @{}Hz", self.hz)
    }
}

fn impact3d(method: SolverMethod, substeps: u32, iterations: u32, hz: u32) -> RunConfig {
    let usual = SolverConfig::for_method(method);
    RunConfig {
        engine: EngineKind::Impact3d(method),
        iterations,
        substeps,
        hz,
        default_settings: usual.substeps == substeps && usual.iterations == iterations,
    }
}

fn avian(substeps: Option<u32>, hz: u32) -> RunConfig {
    RunConfig {
        engine: EngineKind::Avian,
        iterations: 1,
        substeps: substeps.unwrap_or(AVIAN_DEFAULT_SUBSTEPS),
        hz,
        default_settings: substeps.is_none(),
    }
}

fn rapier(iterations: Option<u32>, hz: u32) -> RunConfig {
    RunConfig {
        engine: EngineKind::Rapier,
        iterations: iterations.unwrap_or(RAPIER_DEFAULT_ITERATIONS),
        substeps: 1,
        hz,
        default_settings: iterations.is_none(),
    }
}

/// The substeps x iterations grid of `method` in the full sweep.
fn grid(method: SolverMethod) -> Vec<(u32, u32)> {
    let (substeps, iterations): (&[u32], &[u32]) = match method {
        SolverMethod::Hybrid | SolverMethod::SoftStep => (&[1, 2, 4, 8], &[1, 2, 4]),
        SolverMethod::SequentialImpulses => (&[1, 4], &[1, 2, 4, 10, 20]),
        SolverMethod::Jacobi => (&[1, 4], &[5, 10, 20, 40]),
        // Propagation sweeps until nothing approaches: it has neither knob.
        SolverMethod::Propagation => (&[1], &[1]),
    };
    substeps
        .iter()
        .flat_map(|&s| iterations.iter().map(move |&i| (s, i)))
        .collect()
}

/// The configurations `scene` runs on in `mode`, with the peers or not.
///
/// - Full: every time step (1/240 to 1/30 s; throughput scenes 1/60 s only) times each
///   method's substeps x iterations grid, and the peers at their defaults and at 1, 2, 4, 8
///   substeps (avian3d) or solver iterations (Rapier).
/// - Quick: 1/60 and 1/30 s at each engine's defaults, plus one knob at a time at 1/60 s
///   (throughput scenes: defaults at 1/60 s).
/// - Smoke: defaults at 1/60 s.
/// - Stress scenes (every mode): each engine's defaults at 1/60 s only.
pub fn configs(scene: &Scene, mode: Mode, peers: bool) -> Vec<RunConfig> {
    if scene.kind == Kind::Stress {
        // Each engine at its defaults at 60 Hz: the stress scenes are 20 s of up to 4,000
        // bodies, and the question is whether the defaults hold.
        let mut out: Vec<RunConfig> = SolverMethod::ALL
            .into_iter()
            .map(|m| {
                let usual = SolverConfig::for_method(m);
                impact3d(m, usual.substeps, usual.iterations, 60)
            })
            .collect();
        if peers {
            out.push(avian(None, 60));
            out.push(rapier(None, 60));
        }
        return out;
    }
    let throughput = scene.kind == Kind::Throughput;
    let rates: &[u32] = match mode {
        Mode::Full if !throughput => &[240, 120, 60, 30],
        Mode::Quick if !throughput => &[60, 30],
        _ => &[60],
    };
    let mut out = Vec::new();
    for &hz in rates {
        for method in SolverMethod::ALL {
            let usual = SolverConfig::for_method(method);
            match mode {
                Mode::Full => out.extend(
                    grid(method)
                        .into_iter()
                        .map(|(s, i)| impact3d(method, s, i, hz)),
                ),
                _ => out.push(impact3d(method, usual.substeps, usual.iterations, hz)),
            }
            if mode == Mode::Quick && hz == 60 && !throughput {
                // One knob at a time around the method's usual setting.
                let (substeps, iterations): (&[u32], &[u32]) = match method {
                    SolverMethod::Hybrid | SolverMethod::SoftStep => (&[1, 8], &[]),
                    SolverMethod::SequentialImpulses => (&[], &[1, 4]),
                    SolverMethod::Jacobi => (&[], &[5]),
                    SolverMethod::Propagation => (&[], &[]),
                };
                out.extend(
                    substeps
                        .iter()
                        .map(|&s| impact3d(method, s, usual.iterations, hz)),
                );
                out.extend(
                    iterations
                        .iter()
                        .map(|&i| impact3d(method, usual.substeps, i, hz)),
                );
            }
        }
        if peers {
            out.push(avian(None, hz));
            out.push(rapier(None, hz));
            let counts: &[u32] = match mode {
                Mode::Full => &[1, 2, 4, 8],
                Mode::Quick if hz == 60 && !throughput => &[1, 2],
                _ => &[],
            };
            out.extend(counts.iter().map(|&n| avian(Some(n), hz)));
            out.extend(
                counts
                    .iter()
                    .filter(|&&n| n != RAPIER_DEFAULT_ITERATIONS)
                    .map(|&n| rapier(Some(n), hz)),
            );
        }
    }
    out
}
