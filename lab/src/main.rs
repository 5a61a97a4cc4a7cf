//! `cargo run --release -p impact3d-lab [-- --quick] [--out DIR] [--no-peers] [--scenes A,B]
//! [--sleeping] [--queries] [--scaling]`: runs the speed-vs-accuracy sweep and writes CSV and SVG
//! files (default folder `lab/results`). The binary installs the counting allocator
//! ([`impact3d_lab::alloc`]) for `--scaling`'s memory figures.

use std::path::PathBuf;
use std::process::ExitCode;

use impact3d_lab::{Mode, Options, alloc, queries, run, scaling};

#[global_allocator]
static ALLOCATOR: alloc::Counting = alloc::Counting;

const USAGE: &str =
    "usage: impact3d-lab [--quick] [--out DIR] [--no-peers] [--scenes A,B] [--sleeping] [--queries] [--scaling]
  --quick        a few scenes, small and short, reduced sweep (under two minutes); with
                 --scaling, smaller sizes
  --out DIR      output folder (default: lab/results)
  --no-peers     measure impact3d only
  --scenes A,B   run only these scenes (names as in the CSV files)
  --sleeping     time only the sleeping pair (10,000 spheres asleep vs awake)
  --queries      time only ray casts (10,000 rays into 10,000 static bodies)
  --scaling      time and memory per body against N, each engine at its defaults: spheres in
                 free flight (10,000, 40,000, 100,000) and poured into the walled box (1,000,
                 4,000, 16,000); writes scaling.csv and scaling.md (three rounds, about 15 minutes)";

fn main() -> ExitCode {
    let mut options = Options {
        mode: Mode::Full,
        peers: true,
        out: PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/results")),
        verbose: true,
        only: Vec::new(),
        sleeping_only: false,
    };
    let mut queries = false;
    let mut scaling = false;
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--quick" => options.mode = Mode::Quick,
            "--no-peers" => options.peers = false,
            "--sleeping" => options.sleeping_only = true,
            "--queries" => queries = true,
            "--scaling" => scaling = true,
            "--scenes" => match args.next() {
                Some(names) => options.only = names.split(',').map(str::to_string).collect(),
                None => {
                    eprintln!("--scenes needs a comma-separated list\n{USAGE}");
                    return ExitCode::FAILURE;
                }
            },
            "--out" => match args.next() {
                Some(dir) => options.out = PathBuf::from(dir),
                None => {
                    eprintln!("--out needs a folder\n{USAGE}");
                    return ExitCode::FAILURE;
                }
            },
            "-h" | "--help" => {
                println!("{USAGE}");
                return ExitCode::SUCCESS;
            }
            other => {
                eprintln!("unknown argument {other}\n{USAGE}");
                return ExitCode::FAILURE;
            }
        }
    }
    if options.peers && !cfg!(feature = "peers") {
        eprintln!("built without the `peers` feature: measuring impact3d only");
    }
    if cfg!(debug_assertions) {
        eprintln!("warning: debug build; timings are only meaningful with --release");
    }
    if queries {
        let rays = 10_000;
        let rows = queries::run(rays, 3, options.peers && cfg!(feature = "peers"));
        println!("{}", queries::table(&rows, rays));
        return match queries::write(&options.out, &rows, rays) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("writing results failed: {e}");
                ExitCode::FAILURE
            }
        };
    }
    if scaling {
        return run_scaling(&options);
    }
    match run(&options) {
        Ok(_) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("writing results failed: {e}");
            ExitCode::FAILURE
        }
    }
}

/// `--scaling`: runs [`scaling::run`] with progress on stderr, prints the table and writes
/// `scaling.csv` and `scaling.md`.
fn run_scaling(options: &Options) -> ExitCode {
    let plan = scaling::Plan::for_mode(options.mode);
    let peers = options.peers && cfg!(feature = "peers");
    let args: Vec<String> = std::env::args().skip(1).collect();
    let command = format!(
        "cargo run --release -p impact3d-lab{} -- {}",
        if cfg!(feature = "peers") {
            ""
        } else {
            " --no-default-features"
        },
        args.join(" ")
    );
    let counted = alloc::installed();
    let started = std::time::Instant::now();
    let rows = scaling::run(&plan, peers, |round, r| {
        eprintln!(
            "[{:6.1} s] round {round}/{}: {} {} N = {}: {:.3} ms/step, {:.0} bytes/body, {:.1} allocs/step",
            started.elapsed().as_secs_f64(),
            plan.rounds,
            r.family.name(),
            r.engine,
            r.n,
            r.ms_per_step,
            r.bytes_per_body,
            r.allocs_per_step
        );
    });
    println!("{}", scaling::table(&plan, &rows, &command, counted));
    eprintln!("scaling run: {:.0} s", started.elapsed().as_secs_f64());
    match scaling::write(&options.out, &plan, &rows, &command, counted) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("writing results failed: {e}");
            ExitCode::FAILURE
        }
    }
}
