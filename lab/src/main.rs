//! `cargo run --release -p impact3d-lab [-- --quick] [--out DIR] [--no-peers] [--scenes A,B]
//! [--sleeping] [--queries]`: runs the speed-vs-accuracy sweep and writes CSV and SVG files (default folder
//! `lab/results`).

use std::path::PathBuf;
use std::process::ExitCode;

use impact3d_lab::{Mode, Options, queries, run};

const USAGE: &str =
    "usage: impact3d-lab [--quick] [--out DIR] [--no-peers] [--scenes A,B] [--sleeping] [--queries]
  --quick        a few scenes, small and short, reduced sweep (under two minutes)
  --out DIR      output folder (default: lab/results)
  --no-peers     measure impact3d only
  --scenes A,B   run only these scenes (names as in the CSV files)
  --sleeping     time only the sleeping pair (10,000 spheres asleep vs awake)
  --queries      time only ray casts (10,000 rays into 10,000 static bodies)";

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
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--quick" => options.mode = Mode::Quick,
            "--no-peers" => options.peers = false,
            "--sleeping" => options.sleeping_only = true,
            "--queries" => queries = true,
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
    match run(&options) {
        Ok(_) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("writing results failed: {e}");
            ExitCode::FAILURE
        }
    }
}
