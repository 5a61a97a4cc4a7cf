//! `--threads N`: how many threads do impact3d's parallel work in this process.
//!
//! Bevy's task pools are process-wide and set once, so a thread count is a property of the
//! process: [`set_up`] builds them before the first app does, and a run comparing thread counts
//! (`--scaling --threads 1,2`) runs each count in a child process of its own.
//!
//! N threads are a Bevy compute pool of N threads. impact3d's parallel sections (the narrow
//! phase so far) run serially on a pool of one, as Bevy's `Query::par_iter` does; on more, the
//! pool's threads split the work (the main thread, which runs the step, helps while it waits).
//! The IO and async-compute pools get one thread each (Bevy's minimum: nothing the lab times
//! runs on them). With the `parallel` feature off impact3d runs on one thread whatever N is.
//! avian3d's `par_iter` loops run serially on a pool of one thread too; Rapier is built without
//! its `parallel` feature and always runs on one. (A pool of no threads is not an option: Bevy's
//! `par_splat_map`, which avian3d's broad phase calls, divides by the pool's size.)

use bevy::tasks::{AsyncComputeTaskPool, ComputeTaskPool, IoTaskPool, TaskPoolBuilder};

/// Builds the process's task pools with a compute pool of `threads` threads (at least 1).
/// Returns false when the pools had already been built with another compute pool size (an app
/// was made first), or when `threads` > 1 without the `parallel` feature: the thread count is
/// then not `threads`.
pub fn set_up(threads: usize) -> bool {
    if !cfg!(feature = "parallel") {
        return threads <= 1;
    }
    let threads = threads.max(1);
    let compute = ComputeTaskPool::get_or_init(|| {
        TaskPoolBuilder::new()
            .num_threads(threads)
            .thread_name("lab compute".into())
            .build()
    });
    AsyncComputeTaskPool::get_or_init(|| TaskPoolBuilder::new().num_threads(1).build());
    IoTaskPool::get_or_init(|| TaskPoolBuilder::new().num_threads(1).build());
    compute.thread_num() == threads
}

/// The threads of this process's compute pool, which impact3d's parallel sections use (1
/// without the `parallel` feature).
pub fn at_work() -> usize {
    if cfg!(feature = "parallel") {
        ComputeTaskPool::try_get().map_or(1, |pool| pool.thread_num().max(1))
    } else {
        1
    }
}

/// Parses `--threads`' value: one count or a comma-separated list, each at least 1.
pub fn parse_list(value: &str) -> Option<Vec<usize>> {
    let list: Option<Vec<usize>> = value
        .split(',')
        .map(|s| s.trim().parse().ok().filter(|&n| n >= 1))
        .collect();
    list.filter(|l| !l.is_empty())
}

#[cfg(test)]
mod tests {
    use super::parse_list;

    #[test]
    fn thread_lists_parse() {
        assert_eq!(parse_list("2"), Some(vec![2]));
        assert_eq!(parse_list("1,2"), Some(vec![1, 2]));
        assert_eq!(parse_list("0"), None);
        assert_eq!(parse_list("1,x"), None);
        assert_eq!(parse_list(""), None);
    }
}
