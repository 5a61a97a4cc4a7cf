//! What sleeping saves: the same 10,000 spheres (the sparse free-flight scene, 2 m apart, no
//! contact), once awake and once all asleep, stepped by impact3d with sleeping on, each method
//! at its defaults at 60 Hz. A sleeping body should cost nothing per step beyond what detects
//! that something touched it, so the asleep scene's time per step against the awake one's
//! (`ratio`) is the measure; issue 9 asks for under 5 %. Timed as every scene of the lab
//! ([`crate::measure`]), and, as the full sweep, over three rounds keeping each run's fastest
//! median. Written to `sleeping.csv` and `sleeping.md`.

use std::io;
use std::path::Path;

use impact3d::prelude::SolverMethod;

use crate::Mode;
use crate::measure;
use crate::report::machine_and_date;
use crate::scenes::{self, Scene};
use crate::sweep::{EngineKind, RunConfig};

/// One method's pair of runs.
#[derive(Clone, Debug, PartialEq)]
pub struct SleepRow {
    /// The solver method.
    pub method: SolverMethod,
    /// Median ms per step, awake (fastest round).
    pub awake_ms: f64,
    /// Median ms per step, asleep (fastest round).
    pub asleep_ms: f64,
    /// Slowest round / fastest round - 1, awake and asleep.
    pub spread: [f64; 2],
    /// The scenes' free-flight errors (m): awake, and asleep (where nothing may move at all).
    pub error: [f64; 2],
}

impl SleepRow {
    /// Asleep over awake.
    pub fn ratio(&self) -> f64 {
        self.asleep_ms / self.awake_ms
    }
}

/// Times the pair of `mode` ([`scenes::sleeping_pair`]) under every method.
pub fn run(mode: Mode) -> Vec<SleepRow> {
    let pair = scenes::sleeping_pair(mode);
    let specs = [pair[0].spec(), pair[1].spec()];
    let rounds = mode.rounds();
    SolverMethod::ALL
        .into_iter()
        .map(|method| {
            let usual = impact3d::prelude::SolverConfig::for_method(method);
            let config = RunConfig {
                engine: EngineKind::Impact3d(method),
                iterations: usual.iterations,
                substeps: usual.substeps,
                hz: 60,
                default_settings: true,
            };
            let mut times = [Vec::new(), Vec::new()];
            let mut error = [0.0; 2];
            for _ in 0..rounds {
                for (k, (scene, spec)) in pair.iter().zip(&specs).enumerate() {
                    let result = measure::run(scene, spec, &config);
                    times[k].push(result.ms_per_step);
                    error[k] = result.metrics.error;
                }
            }
            let fastest = |t: &[f64]| t.iter().copied().fold(f64::INFINITY, f64::min);
            let slowest = |t: &[f64]| t.iter().copied().fold(0.0, f64::max);
            SleepRow {
                method,
                awake_ms: fastest(&times[0]),
                asleep_ms: fastest(&times[1]),
                spread: [0, 1].map(|k| slowest(&times[k]) / fastest(&times[k]) - 1.0),
                error,
            }
        })
        .collect()
}

/// The pair's names, for the table's heading.
fn names(mode: Mode) -> String {
    let pair: [Scene; 2] = scenes::sleeping_pair(mode);
    format!("{} vs {}", pair[1].name, pair[0].name)
}

/// `rows` as a markdown table, with the machine and date.
pub fn table(mode: Mode, rows: &[SleepRow]) -> String {
    let mut out = format!(
        "Sleeping vs awake: {} (median ms per physics step, fastest of {} rounds; {})\n\n\
         | method | awake ms | asleep ms | asleep / awake | spread awake, asleep | error awake, asleep (m) |\n\
         |---|---|---|---|---|---|\n",
        names(mode),
        mode.rounds(),
        machine_and_date()
    );
    for r in rows {
        out.push_str(&format!(
            "| {:?} | {:.4} | {:.4} | {:.2} % | {:.0} %, {:.0} % | {:.2e}, {:.2e} |\n",
            r.method,
            r.awake_ms,
            r.asleep_ms,
            100.0 * r.ratio(),
            100.0 * r.spread[0],
            100.0 * r.spread[1],
            r.error[0],
            r.error[1],
        ));
    }
    out
}

/// Writes `sleeping.csv` and `sleeping.md` into `out`.
pub fn write(out: &Path, mode: Mode, rows: &[SleepRow]) -> io::Result<()> {
    let mut csv = String::from(
        "method,awake_ms,asleep_ms,ratio,awake_spread,asleep_spread,awake_error,asleep_error\n",
    );
    for r in rows {
        csv.push_str(&format!(
            "{:?},{},{},{},{},{},{},{}\n",
            r.method,
            r.awake_ms,
            r.asleep_ms,
            r.ratio(),
            r.spread[0],
            r.spread[1],
            r.error[0],
            r.error[1]
        ));
    }
    std::fs::create_dir_all(out)?;
    std::fs::write(out.join("sleeping.csv"), csv)?;
    std::fs::write(out.join("sleeping.md"), table(mode, rows))
}
