//! A counting global allocator for the lab's memory figures ([`crate::scaling`]): it wraps
//! [`System`] and keeps two process-wide atomic counters, the bytes currently allocated and the
//! number of allocation calls (`alloc`, `alloc_zeroed` and `realloc`; frees are not counted as
//! calls). The lab binary installs it (`#[global_allocator]` in `main.rs`, as must any test that
//! wants the figures); a program that does not install it reads zeros, and [`installed`] says so.
//!
//! The counters are global: every thread's allocations count. The lab runs one thread (no
//! progress bar in the scaling mode), so between two reads they are the engine's.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

/// Bytes allocated and not yet freed.
static LIVE: AtomicUsize = AtomicUsize::new(0);
/// Allocation calls so far (`alloc`, `alloc_zeroed`, `realloc`).
static CALLS: AtomicUsize = AtomicUsize::new(0);

/// [`System`] with counters; install it with
/// `#[global_allocator] static A: impact3d_lab::alloc::Counting = impact3d_lab::alloc::Counting;`.
pub struct Counting;

// SAFETY: every call is forwarded unchanged to `System`, which upholds `GlobalAlloc`'s
// contract; the counters are only updated beside it, on success.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: forwarded with the caller's layout.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            LIVE.fetch_add(layout.size(), Ordering::Relaxed);
            CALLS.fetch_add(1, Ordering::Relaxed);
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: forwarded with the caller's layout.
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            LIVE.fetch_add(layout.size(), Ordering::Relaxed);
            CALLS.fetch_add(1, Ordering::Relaxed);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` was allocated by this allocator (so by `System`) with `layout`.
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: forwarded with the caller's pointer, layout and size.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            LIVE.fetch_add(new_size, Ordering::Relaxed);
            LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
            CALLS.fetch_add(1, Ordering::Relaxed);
        }
        p
    }
}

/// Bytes allocated and not yet freed (0 when [`Counting`] is not installed).
pub fn live_bytes() -> usize {
    LIVE.load(Ordering::Relaxed)
}

/// Allocation calls so far (0 when [`Counting`] is not installed).
pub fn calls() -> usize {
    CALLS.load(Ordering::Relaxed)
}

/// Whether [`Counting`] is the global allocator: an allocation moves its call counter.
pub fn installed() -> bool {
    let before = calls();
    let probe = std::hint::black_box(vec![0u8; 64]);
    drop(probe);
    calls() > before
}
