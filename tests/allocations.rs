//! A steady physics step allocates nothing (issue 11): every buffer the step needs is kept
//! between steps, so a scene whose bodies and contacts do not change makes no allocation call
//! in [`PhysicsSchedule`].
//!
//! A counting global allocator counts the calls (`alloc`, `alloc_zeroed`, `realloc`) made on
//! the thread that runs the physics schedule, between a system at its start and one at its end
//! (the schedule runs its systems one after another on one thread). Bevy's compute pool is
//! given one thread.
//!
//! With feature `parallel` (the default) the narrow phase hands its manifold pass to the task
//! pool in chunks, and Bevy's scope allocates for every task it spawns (about 8 calls a step,
//! however many bodies): the narrow phase is then left out of the count. Without it
//! (`cargo test --no-default-features --test allocations`, which CI runs) the pass runs on the
//! schedule's thread and the whole step is counted, but for the pile: a pile awake keeps a few
//! pairs moving in and out of contact range, and parry builds a pair's manifold anew when it
//! comes into range (about one call a step in the pile of 400 spheres).
//!
//! `Propagation` is not counted in the wall: its cubes never come to rest there (they move by
//! more than the contact margin in a step), so the sweep that stops a fast body at its first
//! impact runs every step, and parry's penetration depth (EPA) allocates at every call (about
//! 80 calls a step).

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use bevy::app::{TaskPoolOptions, TaskPoolPlugin};
use bevy::prelude::*;
use impact3d::prelude::*;
use impact3d::scenes::{self, Pour, PourBodies};

thread_local! {
    /// Counting on this thread (between the schedule's first and last system).
    static ARMED: Cell<bool> = const { Cell::new(false) };
    /// Allocation calls counted on this thread.
    static CALLS: Cell<u64> = const { Cell::new(0) };
}

/// [`System`], counting the calls made on an armed thread.
struct Counting;

fn count() {
    // `try_with`: a thread being torn down has no locals left; it is not the step's.
    let _ = ARMED.try_with(|armed| {
        if armed.get() {
            let _ = CALLS.try_with(|c| c.set(c.get() + 1));
        }
    });
}

// SAFETY: every call is forwarded unchanged to `System`; counting touches only thread-local
// cells, which do not allocate (const-initialised, no destructor).
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        // SAFETY: forwarded with the caller's layout.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count();
        // SAFETY: forwarded with the caller's layout.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `System` with `layout`.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        // SAFETY: forwarded with the caller's pointer, layout and size.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Allocation calls made in the physics schedule since the app was built.
#[derive(Resource, Default)]
struct Counted(u64);

fn arm() {
    CALLS.with(|c| c.set(0));
    ARMED.with(|a| a.set(true));
}

fn disarm(mut counted: ResMut<Counted>) {
    ARMED.with(|a| a.set(false));
    counted.0 += CALLS.with(Cell::get);
}

/// Stops counting for a while (the narrow phase), keeping what was counted.
fn pause() {
    ARMED.with(|a| a.set(false));
}

/// Counts again after [`pause`].
fn resume() {
    ARMED.with(|a| a.set(true));
}

/// A headless app at 60 Hz with `method`, sleeping off, one compute thread, and the counting
/// systems around the physics schedule; `narrow_phase`: the narrow phase is counted too
/// (never with feature `parallel`: see the module's doc).
fn counted_app(method: SolverMethod, narrow_phase: bool) -> App {
    let mut app = scenes::headless_app_with(
        60.0,
        (
            MinimalPlugins.set(TaskPoolPlugin {
                task_pool_options: TaskPoolOptions::with_num_threads(1),
            }),
            PhysicsPlugins::default(),
        ),
    );
    app.insert_resource(SolverConfig::for_method(method))
        .insert_resource(SleepConfig {
            enabled: false,
            ..default()
        })
        .init_resource::<Counted>()
        .add_systems(
            PhysicsSchedule,
            (
                arm.before(PhysicsSystems::Prepare),
                disarm.after(PhysicsSystems::SpatialQuery),
            ),
        );
    if cfg!(feature = "parallel") || !narrow_phase {
        app.add_systems(
            PhysicsSchedule,
            (
                pause
                    .after(PhysicsSystems::BroadPhase)
                    .before(PhysicsSystems::NarrowPhase),
                resume
                    .after(PhysicsSystems::NarrowPhase)
                    .before(PhysicsSystems::Solve),
            ),
        );
    }
    app
}

/// Runs `warm_up` steps, then `steps` more; returns the allocation calls of those.
fn calls_in_steady_steps(app: &mut App, warm_up: u32, steps: u32) -> u64 {
    scenes::run_steps(app, warm_up);
    let before = app.world().resource::<Counted>().0;
    scenes::run_steps(app, steps);
    app.world().resource::<Counted>().0 - before
}

/// The counter sees the schedule's allocations: a system in it that allocates once a step
/// adds one call a step to what the same app counts without it (so a zero below is a
/// measurement, not a counter that never runs).
#[test]
fn the_counter_counts_the_schedules_allocations() {
    let counted = |allocating: bool| {
        let mut app = counted_app(SolverMethod::Hybrid, true);
        if allocating {
            app.add_systems(
                PhysicsSchedule,
                (|| {
                    std::hint::black_box(vec![1u8; 16]);
                })
                .in_set(PhysicsSystems::Solve),
            );
        }
        scenes::sparse_flight(app.world_mut(), 8);
        calls_in_steady_steps(&mut app, 10, 20)
    };
    assert_eq!(counted(true), counted(false) + 20);
}

/// Free flight (1,000 spheres on a grid, gravity 0, no contact), a resting wall of cubes with
/// friction (base 10, 55 cubes) and a settled pile of spheres with friction (400 in the walled
/// box): after the scene has settled, 30 steps make no allocation call at all, under every
/// method (`Propagation` not in the wall: see the module's doc). The pile's warm-up is long
/// enough for the last impacts of the pour to be over.
#[test]
fn a_steady_step_allocates_nothing() {
    type Build = fn(&mut World);
    let cases: [(&str, Build, u32); 3] = [
        (
            "free flight",
            |w| {
                scenes::sparse_flight(w, 1000);
            },
            // The broad phase's tree grows its optimisation buffers over the first steps.
            30,
        ),
        (
            "wall",
            |w| {
                scenes::pyramid_with(w, 10, false, 0.5);
            },
            120,
        ),
        (
            "pile",
            |w| {
                scenes::pour_into(w, &Pour::walled_box(400, PourBodies::Spheres, 1.0, 0.5));
            },
            400,
        ),
    ];
    let mut failures = Vec::new();
    for method in [
        SolverMethod::Hybrid,
        SolverMethod::SoftStep,
        SolverMethod::SequentialImpulses,
        SolverMethod::Jacobi,
        SolverMethod::Propagation,
    ] {
        for (name, build, warm_up) in cases {
            if method == SolverMethod::Propagation && name == "wall" {
                continue;
            }
            let mut app = counted_app(method, name != "pile");
            build(app.world_mut());
            let calls = calls_in_steady_steps(&mut app, warm_up, 30);
            if calls != 0 {
                failures.push(format!(
                    "{name} under {method:?}: {calls} calls in 30 steps"
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
