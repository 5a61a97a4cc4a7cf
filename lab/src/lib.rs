//! The speed-vs-accuracy lab: every impact3d solver method over a sweep of time steps,
//! substeps and iterations, beside avian3d 0.7 and Rapier 0.36 (cargo feature `peers`), on the
//! same scenes, in one single-threaded run. It writes one CSV per scene, a combined CSV, one
//! SVG chart per scene (time per step against error, both log scales, Pareto front marked), a
//! summary chart, and prints, for each scene, the cheapest configuration of each engine that
//! meets the scene's tolerance.
//!
//! Layout: [`scenes`] defines each scene once (built by impact3d's shared scene builders, then
//! copied body by body for the peers) with its error metric and tolerance; [`engines`] puts each
//! engine behind the [`engines::Engine`] trait; [`measure`] runs one configuration and times only
//! the physics step; [`sweep`] lists the configurations; [`report`] writes CSV, SVG and the end
//! table. Extra modes, each with its own report: [`sleeping`], [`queries`] and [`scaling`]
//! (time and memory per body against the number of bodies, counted by [`alloc`]).

pub mod alloc;
pub mod engines;
pub mod measure;
pub mod queries;
pub mod report;
pub mod scaling;
pub mod scenes;
pub mod sleeping;
pub mod sweep;
pub mod threads;

use std::path::PathBuf;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// How much to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Every scene at full size over the whole sweep (about ten minutes on two cores).
    Full,
    /// A few scenes, smaller and shorter, over a reduced sweep (well under two minutes).
    Quick,
    /// The quick scenes cut down further, for the lab's own test in a debug build.
    Smoke,
}

impl Mode {
    /// How many times the whole sweep is timed. A configuration's time is the fastest of its
    /// rounds' medians: the rounds are minutes apart, so a slow spell of a shared or virtual
    /// machine does not decide the figure (the spread between rounds is reported).
    pub fn rounds(self) -> usize {
        match self {
            Mode::Full => 3,
            Mode::Quick | Mode::Smoke => 1,
        }
    }
}

/// What the lab runs and where it writes.
#[derive(Clone, Debug)]
pub struct Options {
    /// How much to run.
    pub mode: Mode,
    /// Run avian3d and Rapier too (needs the `peers` feature; ignored without it).
    pub peers: bool,
    /// Output folder for the CSV and SVG files.
    pub out: PathBuf,
    /// Draw a progress bar and print the end table.
    pub verbose: bool,
    /// Run only the scenes with these names (all when empty).
    pub only: Vec<String>,
    /// Time only the sleeping pair ([`sleeping`]), writing `sleeping.csv` and `sleeping.md`
    /// and leaving the sweep's files as they are.
    pub sleeping_only: bool,
}

/// Runs every scene on every configuration of the sweep, writes the CSV and SVG files into
/// `options.out`, and returns the rows.
pub fn run(options: &Options) -> std::io::Result<Vec<report::Row>> {
    if options.sleeping_only {
        run_sleeping(options)?;
        return Ok(Vec::new());
    }
    let mut scenes = scenes::all(options.mode);
    if !options.only.is_empty() {
        scenes.retain(|s| options.only.iter().any(|name| name == s.name));
    }
    let peers = options.peers && cfg!(feature = "peers");
    let plan: Vec<(usize, sweep::RunConfig)> = scenes
        .iter()
        .enumerate()
        .flat_map(|(i, scene)| {
            sweep::configs(scene, options.mode, peers)
                .into_iter()
                .map(move |c| (i, c))
        })
        .collect();
    let rounds = options.mode.rounds();
    let total = (plan.len() * rounds) as u64;
    let bar = if options.verbose {
        ProgressBar::new(total)
    } else {
        ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::hidden())
    };
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} eta {eta} {msg}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    let started = Instant::now();
    // A scene's spec (its bodies, for the peers) is made once, the first time it is needed.
    let mut specs: Vec<Option<scenes::SceneSpec>> = scenes.iter().map(|_| None).collect();
    // The first round's results (the simulation is deterministic, so later rounds only add
    // timings) and every round's median time.
    let mut results = Vec::with_capacity(plan.len());
    let mut times = vec![Vec::with_capacity(rounds); plan.len()];
    for round in 1..=rounds {
        for (k, (i, config)) in plan.iter().enumerate() {
            let scene = &scenes[*i];
            bar.set_message(format!(
                "round {round}/{rounds}: {} {}",
                scene.name,
                config.label()
            ));
            if round > 1 && scene.kind == scenes::Kind::Stress {
                // The stress scenes (20 s of up to 4,000 bodies) run once: the question they
                // answer is whether the defaults hold, and one round's median is their cost.
                let first = times[k][0];
                times[k].push(first);
                bar.inc(1);
                continue;
            }
            let spec = specs[*i].get_or_insert_with(|| scene.spec());
            let result = measure::run(scene, spec, config);
            times[k].push(result.ms_per_step);
            if round == 1 {
                results.push(result);
            }
            bar.inc(1);
        }
    }
    let rows: Vec<report::Row> = plan
        .iter()
        .zip(results)
        .zip(&times)
        .map(|(((i, config), result), times)| report::Row::new(&scenes[*i], config, result, times))
        .collect();
    bar.finish_and_clear();
    std::fs::create_dir_all(&options.out)?;
    report::write_all(&options.out, &scenes, &rows)?;
    if options.verbose {
        println!("{}", report::end_table(&scenes, &rows));
        println!(
            "{} runs in {:.1} s; results in {}",
            rows.len(),
            started.elapsed().as_secs_f64(),
            options.out.display()
        );
    }
    if options.mode == Mode::Full && options.only.is_empty() {
        run_sleeping(options)?;
    }
    Ok(rows)
}

/// Times the sleeping pair and writes its files (see [`sleeping`]).
pub fn run_sleeping(options: &Options) -> std::io::Result<Vec<sleeping::SleepRow>> {
    let rows = sleeping::run(options.mode);
    sleeping::write(&options.out, options.mode, &rows)?;
    if options.verbose {
        println!("{}", sleeping::table(options.mode, &rows));
    }
    Ok(rows)
}
