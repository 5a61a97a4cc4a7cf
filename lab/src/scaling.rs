//! Issue 11, "fast at scale": how the cost of a step grows with the number of bodies, and what
//! a body and a steady step cost in memory. Each engine at its defaults at 60 Hz (impact3d's
//! default `SolverConfig`, avian3d and Rapier as the lab sets them up for every scene),
//! sleeping off in all three, on two scenes at three sizes each:
//!
//! - free flight: the lab's sparse scene ([`impact3d::scenes::sparse_flight`]: spheres of
//!   radius 0.25 m on a 3D grid 2 m apart, moving slowly, no gravity, no contact in the run);
//! - a pour: issue 8's walled box ([`impact3d::scenes::Pour::walled_box`]: spheres of radius
//!   0.5 m, density 1, friction 0.5, dropped in layers into a 21 m box), timed over a window
//!   that starts one second after the top layer would have fallen to the floor.
//!
//! Per run: the median wall time of a physics step over the timed steps (one thread, as the
//! whole lab; [`crate::measure`]'s definition of a step), that per body, the bytes the engine
//! holds per body after it was built and run through the warm-up, and the allocation calls of
//! a timed step, averaged. The memory figures need the counting allocator ([`crate::alloc`]),
//! which the lab binary installs. Written to `scaling.csv` and `scaling.md`.

use std::collections::HashMap;
use std::io;
use std::path::Path;
use std::time::Instant;

use bevy::math::{IVec3, Vec3};
use impact3d::prelude::SolverConfig;
use impact3d::scenes as shared;

use crate::Mode;
use crate::alloc;
use crate::engines;
use crate::measure::median;
use crate::report::machine_and_date;
use crate::scenes::{BodyState, Check, Kind, Scene, Shape};
use crate::sweep::{AVIAN_DEFAULT_SUBSTEPS, EngineKind, RAPIER_DEFAULT_ITERATIONS, RunConfig};

mod chart;

/// The step rate of every run.
const HZ: u32 = 60;
/// Free fall, m/s^2, for the pour's landing time.
const G: f32 = 9.81;

/// Which of the two scenes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    /// Spheres in free flight.
    Flight,
    /// Spheres poured into the walled box.
    Pour,
}

impl Family {
    /// The name in the CSV file.
    pub fn name(self) -> &'static str {
        match self {
            Family::Flight => "flight",
            Family::Pour => "pour",
        }
    }
}

/// What runs: sizes and step counts.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// Free-flight sizes.
    pub flight: Vec<usize>,
    /// Free-flight warm-up steps (not timed; the memory is read after them).
    pub flight_warm_up: usize,
    /// Free-flight timed steps.
    pub flight_steps: usize,
    /// Pour sizes.
    pub pour: Vec<usize>,
    /// Seconds after the top layer's free fall to the floor (`sqrt(2 top / g)`) at which the
    /// pour's timed window starts; the steps before it are its warm-up.
    pub pour_settle: f32,
    /// Pour timed steps.
    pub pour_steps: usize,
    /// How many times the whole plan is timed (each row keeps its fastest round).
    pub rounds: usize,
}

impl Plan {
    /// The plan of `mode`: the sizes in the full mode, smaller ones otherwise.
    pub fn for_mode(mode: Mode) -> Self {
        match mode {
            Mode::Full => Plan {
                flight: vec![10_000, 40_000, 100_000],
                flight_warm_up: 10,
                flight_steps: 60,
                pour: vec![1000, 4000, 16_000],
                pour_settle: 2.0,
                pour_steps: 60,
                rounds: 3,
            },
            Mode::Quick => Plan {
                flight: vec![1000, 4000, 10_000],
                flight_warm_up: 10,
                flight_steps: 30,
                pour: vec![250, 1000],
                pour_settle: 2.0,
                pour_steps: 30,
                rounds: 1,
            },
            Mode::Smoke => Plan {
                flight: vec![100, 400],
                flight_warm_up: 2,
                flight_steps: 4,
                pour: vec![50, 200],
                pour_settle: 0.0,
                pour_steps: 4,
                rounds: 1,
            },
        }
    }

    /// Warm-up steps of a run of `family` with `n` bodies.
    pub fn warm_up(&self, family: Family, n: usize) -> usize {
        match family {
            Family::Flight => self.flight_warm_up,
            Family::Pour => {
                let top = pour(n).top();
                (((2.0 * top / G).sqrt() + self.pour_settle) * HZ as f32).ceil() as usize
            }
        }
    }

    /// Timed steps of a run of `family`.
    pub fn steps(&self, family: Family) -> usize {
        match family {
            Family::Flight => self.flight_steps,
            Family::Pour => self.pour_steps,
        }
    }

    /// The sizes of `family`.
    pub fn sizes(&self, family: Family) -> &[usize] {
        match family {
            Family::Flight => &self.flight,
            Family::Pour => &self.pour,
        }
    }
}

/// The walled-box pour of `n` spheres, density 1, friction 0.5 (issue 8's
/// `spheres*_friction`).
fn pour(n: usize) -> shared::Pour {
    shared::Pour::walled_box(n, shared::PourBodies::Spheres, 1.0, 0.5)
}

/// The lab scene of `family` with `n` bodies.
fn scene(family: Family, n: usize) -> Scene {
    match family {
        Family::Flight => Scene {
            name: "flight",
            kind: Kind::Throughput,
            description: format!("{n} spheres in free flight, 2 m apart"),
            build: Box::new(move |w| {
                shared::sparse_flight(w, n);
            }),
            duration: 0.0,
            check: Check::FreeFlight,
            tolerance: 1e-3,
            unit: "m",
        },
        Family::Pour => {
            let pour = pour(n);
            Scene {
                name: "pour",
                kind: Kind::Throughput,
                description: format!("{n} spheres poured into the walled box, friction 0.5"),
                build: Box::new(move |w| {
                    shared::pour_into(w, &pour);
                }),
                duration: 0.0,
                check: Check::Penetration,
                tolerance: 0.01,
                unit: "m",
            }
        }
    }
}

/// The engines' default configurations at 60 Hz: impact3d's default method, then the peers.
pub fn configs(peers: bool) -> Vec<RunConfig> {
    let usual = SolverConfig::default();
    let mut out = vec![RunConfig {
        engine: EngineKind::Impact3d(usual.method),
        iterations: usual.iterations,
        substeps: usual.substeps,
        hz: HZ,
        default_settings: true,
    }];
    if peers {
        out.push(RunConfig {
            engine: EngineKind::Avian,
            iterations: 1,
            substeps: AVIAN_DEFAULT_SUBSTEPS,
            hz: HZ,
            default_settings: true,
        });
        out.push(RunConfig {
            engine: EngineKind::Rapier,
            iterations: RAPIER_DEFAULT_ITERATIONS,
            substeps: 1,
            hz: HZ,
            default_settings: true,
        });
    }
    out
}

/// One engine on one scene at one size.
#[derive(Clone, Debug, PartialEq)]
pub struct ScaleRow {
    /// The scene.
    pub family: Family,
    /// "impact3d", "avian3d" or "rapier3d".
    pub engine: &'static str,
    /// Threads at work in the engine's process ([`crate::threads::at_work`]; 1 for Rapier,
    /// which the lab builds without its `parallel` feature).
    pub threads: usize,
    /// Dynamic bodies.
    pub n: usize,
    /// Steps run before the timed ones.
    pub warm_up: usize,
    /// Timed steps.
    pub steps: usize,
    /// Median wall time of a timed step, ms (the fastest round's).
    pub ms_per_step: f64,
    /// Slowest round's median over the fastest's, minus 1 (0 for one round).
    pub spread: f64,
    /// Live bytes the engine added (built and run through the warm-up), per body; 0 when the
    /// counting allocator is not installed.
    pub bytes_per_body: f64,
    /// Allocation calls per timed step, averaged; 0 when the counting allocator is not
    /// installed.
    pub allocs_per_step: f64,
    /// The largest body speed after the last timed step, m/s (for the pour: has it landed?).
    pub max_speed: f32,
    /// How many other spheres a sphere touches (centres closer than two radii plus 1 cm)
    /// after the last timed step, on average: the pile's contact density, which grows with its
    /// depth (walls and floor not counted).
    pub neighbours: f64,
}

impl ScaleRow {
    /// The engine, with its thread count when more than one ("impact3d x2").
    pub fn label(&self) -> String {
        if self.threads > 1 {
            format!("{} x{}", self.engine, self.threads)
        } else {
            self.engine.to_string()
        }
    }

    /// Microseconds of a step per body.
    pub fn us_per_body(&self) -> f64 {
        self.ms_per_step * 1e3 / self.n as f64
    }
}

/// Runs `plan` on impact3d and, with `peers` (and the `peers` feature), avian3d and Rapier;
/// `progress` is told of each run as it ends. The whole plan runs [`Plan::rounds`] times, one
/// round after the other; a row keeps its fastest round's median (the memory figures, the
/// allocation count and the speed are the first round's) and the spread between rounds.
pub fn run(plan: &Plan, peers: bool, mut progress: impl FnMut(usize, &ScaleRow)) -> Vec<ScaleRow> {
    let configs = configs(peers && cfg!(feature = "peers"));
    let mut rows: Vec<ScaleRow> = Vec::new();
    let mut slowest: Vec<f64> = Vec::new();
    for round in 1..=plan.rounds.max(1) {
        let mut k = 0;
        for family in [Family::Flight, Family::Pour] {
            for &n in plan.sizes(family) {
                let scene = scene(family, n);
                let spec = scene.spec();
                for config in &configs {
                    let row = run_one(plan, family, n, &scene, &spec, config);
                    progress(round, &row);
                    if round == 1 {
                        slowest.push(row.ms_per_step);
                        rows.push(row);
                    } else {
                        let kept = &mut rows[k];
                        kept.ms_per_step = kept.ms_per_step.min(row.ms_per_step);
                        slowest[k] = slowest[k].max(row.ms_per_step);
                    }
                    k += 1;
                }
            }
        }
    }
    for (row, slowest) in rows.iter_mut().zip(slowest) {
        row.spread = slowest / row.ms_per_step - 1.0;
    }
    rows
}

/// One run: build, warm up, read the memory, time the steps.
fn run_one(
    plan: &Plan,
    family: Family,
    n: usize,
    scene: &Scene,
    spec: &crate::scenes::SceneSpec,
    config: &RunConfig,
) -> ScaleRow {
    let warm_up = plan.warm_up(family, n);
    let steps = plan.steps(family);
    let mut times = Vec::with_capacity(steps);
    let mut states = Vec::with_capacity(n);
    let before = alloc::live_bytes();
    let mut engine = engines::build(scene, spec, config);
    for _ in 0..warm_up {
        engine.step();
    }
    let held = alloc::live_bytes().saturating_sub(before);
    let mut calls = 0;
    for _ in 0..steps {
        let first = alloc::calls();
        let start = Instant::now();
        engine.step();
        let elapsed = start.elapsed().as_secs_f64() * 1e3;
        calls += alloc::calls() - first;
        times.push(elapsed);
    }
    engine.read(&mut states);
    assert_eq!(states.len(), n, "every body is read");
    let max_speed = states.iter().map(|s| s.linvel.length()).fold(0.0, f32::max);
    let radius = match spec.dynamic().next().map(|b| &b.shape) {
        Some(&Shape::Ball(r)) => r,
        _ => unreachable!("both scenes are spheres"),
    };
    let neighbours = 2.0 * touching_pairs(&states, 2.0 * radius + 0.01) as f64 / n as f64;
    drop(engine);
    ScaleRow {
        family,
        engine: config.engine_name(),
        threads: match config.engine {
            EngineKind::Rapier => 1,
            _ => crate::threads::at_work(),
        },
        n,
        warm_up,
        steps,
        ms_per_step: median(&mut times),
        spread: 0.0,
        bytes_per_body: held as f64 / n as f64,
        allocs_per_step: calls as f64 / steps.max(1) as f64,
        max_speed,
        neighbours,
    }
}

/// Pairs of bodies whose centres are closer than `reach` (a grid of cells `reach` wide).
fn touching_pairs(states: &[BodyState], reach: f32) -> usize {
    let cell = |p: Vec3| (p / reach).floor().as_ivec3();
    let mut grid: HashMap<IVec3, Vec<usize>> = HashMap::new();
    for (i, s) in states.iter().enumerate() {
        grid.entry(cell(s.position)).or_default().push(i);
    }
    let mut pairs = 0;
    for (i, s) in states.iter().enumerate() {
        let home = cell(s.position);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let Some(others) = grid.get(&(home + IVec3::new(dx, dy, dz))) else {
                        continue;
                    };
                    pairs += others
                        .iter()
                        .filter(|&&j| j > i && states[j].position.distance(s.position) < reach)
                        .count();
                }
            }
        }
    }
    pairs
}

/// Time per body at the largest size over that at the smallest, per engine (and thread count)
/// and scene, the engine as [`ScaleRow::label`] names it: the criterion is under 1.3.
pub fn ratios(rows: &[ScaleRow]) -> Vec<(Family, String, f64)> {
    let mut out = Vec::new();
    for family in [Family::Flight, Family::Pour] {
        let mut engines: Vec<(&'static str, usize)> = Vec::new();
        for r in rows.iter().filter(|r| r.family == family) {
            if !engines.contains(&(r.engine, r.threads)) {
                engines.push((r.engine, r.threads));
            }
        }
        for (engine, threads) in engines {
            let of = || {
                rows.iter()
                    .filter(|r| r.family == family && r.engine == engine && r.threads == threads)
            };
            let smallest = of().min_by_key(|r| r.n).expect("a row");
            let largest = of().max_by_key(|r| r.n).expect("a row");
            out.push((
                family,
                smallest.label(),
                largest.us_per_body() / smallest.us_per_body(),
            ));
        }
    }
    out
}

/// The scaling report: machine, date, command, plan, the table and the ratios.
pub fn table(plan: &Plan, rows: &[ScaleRow], command: &str, counted: bool) -> String {
    let sizes = |f: Family| {
        plan.sizes(f)
            .iter()
            .map(|n| n.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let method = SolverConfig::default().method;
    let mut out = format!(
        "# Scaling: time and memory per body (issue 11)\n\n\
         {machine}. Command: `{command}`.\n\n\
         Each engine at its defaults at {HZ} Hz, sleeping off in all three: impact3d's default \
         `SolverConfig` ({method:?}, {substeps} substeps x {iterations} iteration(s)), avian3d ({AVIAN_DEFAULT_SUBSTEPS} \
         substeps) and Rapier ({RAPIER_DEFAULT_ITERATIONS} solver iterations) as the lab sets \
         them up for every scene (restitution and friction per body with the `Max` combine rule, \
         avian3d's restitution threshold at impact3d's 0.5 m/s). {threads} The whole plan ran \
         {rounds} time(s), one round after the other; each row keeps its fastest round's median \
         (`spread`: slowest round / fastest - 1).\n\n\
         - **flight**: N spheres (r = 0.25 m) on a 3D grid 2 m apart, moving at 0.1-0.35 m/s, \
         no gravity, no contact (the lab's sparse scene), N = {flight_sizes}: {flight_warm_up} warm-up steps, then {flight_steps} \
         timed steps.\n\
         - **pour**: N spheres (r = 0.5 m, density 1, friction 0.5) dropped in layers into \
         issue 8's 21 m walled box, N = {pour_sizes}: the timed window of {pour_steps} steps starts {settle} s after the \
         top layer would have fallen freely to the floor (`sqrt(2 top / g) + {settle} s`: the \
         warm-up column), when the bodies have landed (`max speed` is the largest body speed \
         after the window: landed spheres can still roll on the pile and the floor; \
         `neighbours` is how many other spheres a sphere touches then, on average). The box \
         is the same at every N, so a larger pour is a deeper pile with more contacts per \
         body.\n\n\
         ms/step is the median wall time of one physics step over the timed steps (as in the \
         rest of the lab: one run of the Bevy schedule the plugin steps in, or one Rapier \
         `PhysicsPipeline::step`); us/body is that divided by N.\n\n",
        machine = machine_and_date(),
        threads = threads_note(rows),
        rounds = plan.rounds,
        substeps = SolverConfig::default().substeps,
        iterations = SolverConfig::default().iterations,
        flight_sizes = sizes(Family::Flight),
        flight_warm_up = plan.flight_warm_up,
        flight_steps = plan.flight_steps,
        pour_sizes = sizes(Family::Pour),
        pour_steps = plan.pour_steps,
        settle = plan.pour_settle,
    );
    if counted {
        out.push_str(
            "**Memory and allocations** are counted by the lab binary's global allocator \
             (`lab/src/alloc.rs`: `std::alloc::System` wrapped with atomic counters of live \
             bytes and of allocation calls, `alloc`, `alloc_zeroed` and `realloc`). bytes/body \
             is the live bytes after building the engine's world and running the warm-up, minus \
             those before building it (the scene's engine-neutral copy is made before), divided \
             by N: it includes each engine's fixed cost (an app, schedules, empty structures) \
             and the lab's own lists of body handles (8 to 24 bytes a body). allocs/step is the \
             allocation calls made inside the timed steps, divided by their number: a steady \
             step that allocates nothing reads 0.\n\n",
        );
    } else {
        out.push_str(
            "**Memory and allocations were not measured**: the counting allocator \
             (`lab/src/alloc.rs`) is not installed in this program, so those columns read 0.\n\n",
        );
    }
    out.push_str(
        "| scene | engine | threads | N | warm-up steps | timed steps | ms/step | spread | us/body | bytes/body | allocs/step | max speed (m/s) | neighbours |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        out.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {:.3} | {:.0} % | {:.3} | {:.0} | {:.1} | {:.2} | {:.2} |\n",
            r.family.name(),
            r.engine,
            r.threads,
            r.n,
            r.warm_up,
            r.steps,
            r.ms_per_step,
            100.0 * r.spread,
            r.us_per_body(),
            r.bytes_per_body,
            r.allocs_per_step,
            r.max_speed,
            r.neighbours,
        ));
    }
    out.push_str(
        "\nTime per body at the largest N over that at the smallest (issue 11: under 1.3):\n\n\
         | scene | engine | us/body ratio | under 1.3 |\n|---|---|---|---|\n",
    );
    for (family, engine, ratio) in ratios(rows) {
        out.push_str(&format!(
            "| {} | {engine} | {ratio:.2} | {} |\n",
            family.name(),
            if ratio < 1.3 { "yes" } else { "no" }
        ));
    }
    let speed_ups = speed_ups(rows);
    if !speed_ups.is_empty() {
        out.push_str(
            "\nimpact3d on more threads: its step time on one thread over its time on N, same \
             scene and size (issue 11: at least 1.6 on two threads for the 4,000-sphere pour \
             and the 10,000-sphere free flight):\n\n\
             | scene | N | threads | ms/step, 1 thread | ms/step | speed-up |\n\
             |---|---|---|---|---|---|\n",
        );
        for (one, many) in speed_ups {
            out.push_str(&format!(
                "| {} | {} | {} | {:.3} | {:.3} | {:.2} |\n",
                one.family.name(),
                one.n,
                many.threads,
                one.ms_per_step,
                many.ms_per_step,
                one.ms_per_step / many.ms_per_step
            ));
        }
    }
    out
}

/// What the report says of threads: one for every engine, or which ran on more.
fn threads_note(rows: &[ScaleRow]) -> String {
    let mut counts: Vec<usize> = rows
        .iter()
        .filter(|r| r.engine == "impact3d")
        .map(|r| r.threads)
        .collect();
    counts.sort_unstable();
    counts.dedup();
    if counts.iter().all(|&t| t == 1) {
        return "One thread.".into();
    }
    let list = counts
        .iter()
        .map(|t| t.to_string())
        .collect::<Vec<_>>()
        .join(", ");
    format!(
        "impact3d on {list} thread(s) (`--threads`: each count in a process of its own; the \
         threads of Bevy's compute pool, see `lab/src/threads.rs`; only the narrow phase runs \
         in parallel so far); avian3d and Rapier on one."
    )
}

/// impact3d's rows on more than one thread, each with its one-thread row of the same scene
/// and size.
pub fn speed_ups(rows: &[ScaleRow]) -> Vec<(&ScaleRow, &ScaleRow)> {
    rows.iter()
        .filter(|r| r.engine == "impact3d" && r.threads > 1)
        .filter_map(|many| {
            rows.iter()
                .find(|one| {
                    one.engine == "impact3d"
                        && one.threads == 1
                        && one.family == many.family
                        && one.n == many.n
                })
                .map(|one| (one, many))
        })
        .collect()
}

/// The CSV header of `scaling.csv`.
pub const CSV_HEADER: &str = "scene,engine,threads,n,warm_up_steps,timed_steps,ms_per_step,ms_spread,us_per_body,bytes_per_body,allocs_per_step,max_speed,neighbours";

/// Writes `scaling.csv` and `scaling.md` into `out`.
pub fn write(
    out: &Path,
    plan: &Plan,
    rows: &[ScaleRow],
    command: &str,
    counted: bool,
) -> io::Result<()> {
    let mut csv = format!("{CSV_HEADER}\n");
    for r in rows {
        csv.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            r.family.name(),
            r.engine,
            r.threads,
            r.n,
            r.warm_up,
            r.steps,
            r.ms_per_step,
            r.spread,
            r.us_per_body(),
            r.bytes_per_body,
            r.allocs_per_step,
            r.max_speed,
            r.neighbours,
        ));
    }
    std::fs::create_dir_all(out)?;
    std::fs::write(out.join("scaling.csv"), csv)?;
    std::fs::write(out.join("scaling.md"), table(plan, rows, command, counted))?;
    chart::draw(&out.join("scaling.svg"), rows).map_err(|e| io::Error::other(e.to_string()))
}

/// Reads back the rows of a `scaling.csv` that [`write`] wrote (a child process's, for
/// `--threads 1,2`). `None` for a file in another format.
pub fn read_csv(text: &str) -> Option<Vec<ScaleRow>> {
    let mut lines = text.lines();
    if lines.next()? != CSV_HEADER {
        return None;
    }
    lines
        .map(|line| {
            let f: Vec<&str> = line.split(',').collect();
            if f.len() != 13 {
                return None;
            }
            let family = match f[0] {
                "flight" => Family::Flight,
                "pour" => Family::Pour,
                _ => return None,
            };
            let engine = match f[1] {
                "impact3d" => "impact3d",
                "avian3d" => "avian3d",
                "rapier3d" => "rapier3d",
                _ => return None,
            };
            Some(ScaleRow {
                family,
                engine,
                threads: f[2].parse().ok()?,
                n: f[3].parse().ok()?,
                warm_up: f[4].parse().ok()?,
                steps: f[5].parse().ok()?,
                ms_per_step: f[6].parse().ok()?,
                spread: f[7].parse().ok()?,
                bytes_per_body: f[9].parse().ok()?,
                allocs_per_step: f[10].parse().ok()?,
                max_speed: f[11].parse().ok()?,
                neighbours: f[12].parse().ok()?,
            })
        })
        .collect()
}
