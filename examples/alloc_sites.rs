//! Where a step allocates: a global allocator that, while the physics schedule runs, takes a
//! backtrace of every allocation call and prints the call sites that make them, most first
//! (per step). The scene settles for `WARM` steps (300 unless given), then `STEPS` steps (5)
//! are counted. `tests/allocations.rs` asserts the count; this finds what to fix when it fails.
//! The backtraces' own allocations make the first line's total large: read the sites.
//!
//! ```sh
//! cargo run --release --example alloc_sites [flight|flight8|wall|pour] [hybrid|soft|si|jacobi|prop]
//! WARM=400 STEPS=30 cargo run --release --no-default-features --example alloc_sites pour
//! ```
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::collections::HashMap;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use bevy::prelude::*;
use impact3d::prelude::*;
use impact3d::scenes::{self, Pour, PourBodies};

static ARMED: AtomicBool = AtomicBool::new(false);
static CALLS: AtomicUsize = AtomicUsize::new(0);
static SITES: Mutex<Option<HashMap<String, usize>>> = Mutex::new(None);
thread_local! { static INSIDE: Cell<bool> = const { Cell::new(false) }; }

/// [`System`], noting each allocation call made on an armed thread.
struct Probe;

// SAFETY: every call is forwarded unchanged to `System`; noting a call allocates only with the
// thread's `INSIDE` flag set, and such nested calls are counted but not traced.
unsafe impl GlobalAlloc for Probe {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        note();
        unsafe { System.alloc(l) }
    }
    unsafe fn alloc_zeroed(&self, l: Layout) -> *mut u8 {
        note();
        unsafe { System.alloc_zeroed(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        unsafe { System.dealloc(p, l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, n: usize) -> *mut u8 {
        note();
        unsafe { System.realloc(p, l, n) }
    }
}
#[global_allocator]
static A: Probe = Probe;

thread_local! { static T_ARMED: Cell<bool> = const { Cell::new(false) }; }
fn arm() {
    T_ARMED.with(|a| a.set(ARMED.load(Ordering::Relaxed)));
}
fn disarm() {
    T_ARMED.with(|a| a.set(false));
}
fn note() {
    if !T_ARMED.try_with(|a| a.get()).unwrap_or(false) {
        return;
    }
    CALLS.fetch_add(1, Ordering::Relaxed);
    if INSIDE.with(|i| i.replace(true)) {
        return;
    }
    let bt = format!("{:?}", std::backtrace::Backtrace::force_capture());
    let frames: Vec<&str> = bt
        .split("fn: \"")
        .skip(1)
        .map(|s| s.split('"').next().unwrap_or(""))
        .collect();
    let start = frames
        .iter()
        .position(|f| f.contains("alloc_probe::note"))
        .map_or(0, |i| i + 1);
    let rest: Vec<&str> = frames[start..]
        .iter()
        .copied()
        .filter(|f| {
            !f.contains("alloc::")
                && !f.contains("__rust")
                && !f.contains("GlobalAlloc")
                && !f.contains("Probe")
        })
        .collect();
    let mut key: Vec<&str> = rest.iter().copied().take(2).collect();
    if let Some(f) = rest.iter().find(|f| f.contains("impact3d"))
        && !key.contains(f)
    {
        key.push(f);
    }
    let key = if key.is_empty() {
        "(other)".to_string()
    } else {
        key.join(" < ")
    };
    if let Ok(mut g) = SITES.lock() {
        *g.get_or_insert_with(HashMap::new).entry(key).or_default() += 1;
    }
    INSIDE.with(|i| i.set(false));
}

fn main() {
    let scene = std::env::args().nth(1).unwrap_or("pour".into());
    let method = match std::env::args().nth(2).as_deref() {
        Some("soft") => SolverMethod::SoftStep,
        Some("si") => SolverMethod::SequentialImpulses,
        Some("jacobi") => SolverMethod::Jacobi,
        Some("prop") => SolverMethod::Propagation,
        _ => SolverMethod::Hybrid,
    };
    let mut app = scenes::headless_app_with(
        60.0,
        (
            MinimalPlugins.set(bevy::app::TaskPoolPlugin {
                task_pool_options: bevy::app::TaskPoolOptions::with_num_threads(1),
            }),
            PhysicsPlugins::default(),
        ),
    );
    app.insert_resource(SolverConfig::for_method(method));
    app.add_systems(
        PhysicsSchedule,
        (
            arm.before(PhysicsSystems::Prepare),
            disarm.after(PhysicsSystems::SpatialQuery),
        ),
    );
    app.insert_resource(SleepConfig {
        enabled: false,
        ..default()
    });
    match scene.as_str() {
        "flight" => {
            scenes::sparse_flight(app.world_mut(), 1000);
        }
        "flight8" => {
            scenes::sparse_flight(app.world_mut(), 8);
        }
        "wall" => {
            scenes::pyramid_with(app.world_mut(), 10, false, 0.5);
        }
        _ => {
            scenes::pour_into(
                app.world_mut(),
                &Pour::walled_box(400, PourBodies::Spheres, 1.0, 0.5),
            );
        }
    }
    let warm: usize = std::env::var("WARM")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(300);
    for _ in 0..warm {
        app.update();
    }
    ARMED.store(true, Ordering::Relaxed);
    let steps: usize = std::env::var("STEPS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(5);
    for _ in 0..steps {
        app.update();
    }
    ARMED.store(false, Ordering::Relaxed);
    println!(
        "{scene}: {} allocation calls a step",
        CALLS.load(Ordering::Relaxed) / steps
    );
    let sites = SITES.lock().unwrap().take().unwrap_or_default();
    let mut v: Vec<_> = sites.into_iter().collect();
    v.sort_by_key(|entry| std::cmp::Reverse(entry.1));
    for (k, n) in v.iter().take(25) {
        println!("{:6.1}  {k}", *n as f32 / steps as f32);
    }
}
