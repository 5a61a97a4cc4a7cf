//! Same inputs give bit-identical results whatever the number of threads: the narrow phase
//! computes its manifolds on Bevy's compute task pool (feature `parallel`, on by default;
//! serially on a pool of one thread), and its results must not depend on how the pairs were
//! split between threads.
//!
//! Bevy's task pools are process-wide and created once, so each thread count runs in a child
//! process: this test binary again, running the ignored `threaded_pour` with
//! `IMPACT3D_THREADS` set, which prints a hash of every body's pose.

mod common;

use std::process::Command;

use bevy::app::{TaskPoolOptions, TaskPoolPlugin};
use bevy::prelude::*;
use common::mixed_pour;
use impact3d::prelude::*;
use impact3d::scenes;

/// Runs a 300-body mixed pour with friction (spheres, boxes, capsules, hulls; many contact
/// pairs a step) for 120 steps at 60 Hz, sleeping off, on a task pool of `threads` threads,
/// and hashes every body's position and rotation bits. `threads` is the compute pool's size
/// (Bevy's `with_num_threads` would give the compute pool one thread of 2, the rest going to
/// the IO and async pools, and one thread runs the narrow phase serially).
fn pour_hash(threads: usize) -> u64 {
    let mut options = TaskPoolOptions::default();
    options.compute.min_threads = threads;
    options.compute.max_threads = threads;
    let (mut app, bodies) = mixed_pour((
        MinimalPlugins.set(TaskPoolPlugin {
            task_pool_options: options,
        }),
        PhysicsPlugins::default(),
    ));
    scenes::run_steps(&mut app, 120);
    scenes::pose_hash(app.world(), &bodies)
}

/// The child process's part: with `IMPACT3D_THREADS=n`, prints `HASH <hash>` of the pour on
/// `n` threads.
#[test]
#[ignore = "run by same_results_on_any_number_of_threads in a child process"]
fn threaded_pour() {
    if let Some(n) = std::env::var("IMPACT3D_THREADS")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
    {
        println!("HASH {:016x}", pour_hash(n));
    }
}

/// The pour's pose hash is the same on compute pools of 1, 2 and 4 threads (each in its own
/// process) and in this process: exact equality, the promise is bit-identical results.
#[test]
fn same_results_on_any_number_of_threads() {
    let exe = std::env::current_exe().unwrap();
    let hashes: Vec<String> = [1, 2, 4]
        .iter()
        .map(|n| {
            let out = Command::new(&exe)
                .args(["--exact", "threaded_pour", "--ignored", "--nocapture"])
                .env("IMPACT3D_THREADS", n.to_string())
                .output()
                .unwrap();
            let stdout = String::from_utf8_lossy(&out.stdout);
            stdout
                .lines()
                .find_map(|l| l.strip_prefix("HASH ").map(str::to_owned))
                .unwrap_or_else(|| panic!("{n} threads: no hash in {stdout}"))
        })
        .collect();
    let here = format!("{:016x}", pour_hash(2));
    assert!(
        hashes.iter().all(|h| *h == here),
        "1, 2, 4 threads: {hashes:?}; this process: {here}"
    );
}
