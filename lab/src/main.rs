//! `cargo run --release -p impact3d-lab [-- --quick] [--out DIR] [--no-peers] [--scenes A,B]
//! [--sleeping] [--queries] [--scaling] [--threads N[,M..]]`: runs the speed-vs-accuracy sweep
//! and writes CSV and SVG files (default folder `lab/results`). The binary installs the counting allocator
//! ([`impact3d_lab::alloc`]) for `--scaling`'s memory figures.

use std::path::PathBuf;
use std::process::{Command, ExitCode};

use impact3d_lab::{Mode, Options, alloc, queries, run, scaling, threads};

#[global_allocator]
static ALLOCATOR: alloc::Counting = alloc::Counting;

const USAGE: &str =
    "usage: impact3d-lab [--quick] [--out DIR] [--no-peers] [--scenes A,B] [--sleeping] [--queries] [--scaling] [--threads N[,M..]]
  --quick        a few scenes, small and short, reduced sweep (under two minutes); with
                 --scaling, smaller sizes
  --out DIR      output folder (default: lab/results)
  --no-peers     measure impact3d only
  --scenes A,B   run only these scenes (names as in the CSV files)
  --sleeping     time only the sleeping pair (10,000 spheres asleep vs awake)
  --queries      time only ray casts (10,000 rays into 10,000 static bodies)
  --scaling      time and memory per body against N, each engine at its defaults: spheres in
                 free flight (10,000, 40,000, 100,000) and poured into the walled box (1,000,
                 4,000, 16,000); writes scaling.csv, scaling.md and scaling.svg (three rounds,
                 about 8 minutes on 2 cores)
  --threads N    the threads of Bevy's compute pool, which impact3d's parallel sections use
                 (default 1: serial; needs the `parallel` feature). With --scaling a list
                 (1,2) runs the plan once per count, each in a process of its own (the peers
                 with the first count only), into one report with impact3d's speed-up per
                 count; other modes take 1 only";

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
    let mut thread_counts = vec![1];
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--quick" => options.mode = Mode::Quick,
            "--no-peers" => options.peers = false,
            "--sleeping" => options.sleeping_only = true,
            "--queries" => queries = true,
            "--scaling" => scaling = true,
            "--threads" => match args.next().as_deref().and_then(threads::parse_list) {
                Some(list) => thread_counts = list,
                None => {
                    eprintln!(
                        "--threads needs a count or a comma-separated list, each >= 1\n{USAGE}"
                    );
                    return ExitCode::FAILURE;
                }
            },
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
    if scaling && thread_counts.len() > 1 {
        return run_scaling_per_thread_count(&options, &thread_counts);
    }
    if !scaling && thread_counts != [1] {
        eprintln!("--threads other than 1 is for --scaling only\n{USAGE}");
        return ExitCode::FAILURE;
    }
    if !threads::set_up(thread_counts[0]) {
        eprintln!(
            "cannot run impact3d on {} thread(s) here (built without the `parallel` feature?)",
            thread_counts[0]
        );
        return ExitCode::FAILURE;
    }
    if queries {
        let rays = 10_000;
        let rows = queries::run(rays, 3, options.peers && cfg!(feature = "peers"));
        println!("{}", queries::table(&rows, rays));
        return written(queries::write(&options.out, &rows, rays));
    }
    if scaling {
        return run_scaling(&options);
    }
    written(run(&options))
}

/// The exit code of a run whose results were written (`Ok`) or not, the error on stderr.
fn written<T>(result: std::io::Result<T>) -> ExitCode {
    match result {
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
    let command = command_line();
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
    written(scaling::write(
        &options.out,
        &plan,
        &rows,
        &command,
        counted,
    ))
}

/// This run's command, as the reports quote it.
fn command_line() -> String {
    let args: Vec<String> = std::env::args().skip(1).collect();
    format!(
        "cargo run --release -p impact3d-lab{} -- {}",
        if cfg!(feature = "peers") {
            ""
        } else {
            " --no-default-features"
        },
        args.join(" ")
    )
}

/// `--scaling --threads 1,2`: Bevy's task pools are set once per process, so each thread
/// count runs the plan in a child process of this program (the peers with the first count
/// only), which writes its files into `out/threads-N`; their rows are then reported together.
fn run_scaling_per_thread_count(options: &Options, counts: &[usize]) -> ExitCode {
    let plan = scaling::Plan::for_mode(options.mode);
    let exe = match std::env::current_exe() {
        Ok(exe) => exe,
        Err(e) => {
            eprintln!("cannot find this program to run it again: {e}");
            return ExitCode::FAILURE;
        }
    };
    let mut rows = Vec::new();
    for (k, &n) in counts.iter().enumerate() {
        let dir = options.out.join(format!("threads-{n}"));
        let mut child = Command::new(&exe);
        child
            .args(["--scaling", "--threads", &n.to_string(), "--out"])
            .arg(&dir);
        if options.mode == Mode::Quick {
            child.arg("--quick");
        }
        if k > 0 || !options.peers {
            child.arg("--no-peers");
        }
        match child.status() {
            Ok(status) if status.success() => {}
            other => {
                eprintln!("the run on {n} thread(s) failed: {other:?}");
                return ExitCode::FAILURE;
            }
        }
        let read = std::fs::read_to_string(dir.join("scaling.csv"))
            .ok()
            .and_then(|text| scaling::read_csv(&text));
        let Some(mut of_n) = read else {
            eprintln!("the run on {n} thread(s) wrote no readable scaling.csv");
            return ExitCode::FAILURE;
        };
        rows.append(&mut of_n);
        let _ = std::fs::remove_dir_all(&dir);
    }
    rows.sort_by_key(|r| (r.family.name(), r.n));
    let command = command_line();
    let counted = alloc::installed();
    println!("{}", scaling::table(&plan, &rows, &command, counted));
    written(scaling::write(
        &options.out,
        &plan,
        &rows,
        &command,
        counted,
    ))
}
