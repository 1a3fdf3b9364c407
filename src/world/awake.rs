//! Workers kept awake through a step.
//!
//! A step runs several short parallel loops with a little serial work between them (the ORCA
//! pass alone: the requests, the hashed grid's refresh, the filter, the integrator). Between two
//! loops rayon's idle workers look for work a few dozen rounds and then sleep, and waking one
//! costs microseconds to tens of microseconds on a virtual machine, which the next loop waits
//! for; how long varies from run to run, so short steps varied with it. [`with_awake_workers`]
//! does what OpenMP's workers do between parallel regions: each other worker of the pool runs a
//! task that, until the step returns, takes whatever parallel work appears
//! ([`rayon::yield_now`], which steals from the step's thread), and otherwise spins a little and
//! now and then yields its core, without sleeping. docs/PERFORMANCE.md has the measurements.
//!
//! It is off by default ([`crate::World::set_workers_awake`]): the waiting workers occupy
//! their cores through the step, which other processes sharing those cores then miss
//! (docs/PERFORMANCE.md, "Workers kept awake"). The command line, which owns its process, turns
//! it on.
//!
//! Invariants: which thread runs a piece of work never changes a result (every parallel loop of
//! the step is deterministic by construction), so this changes timings only; the waiting task
//! never runs on the step's own thread (it would wait for itself); it ends when the step
//! returns or unwinds; a pool with more threads than the machine has cores is left as it is
//! (waiting threads would take cores from working ones).

use std::sync::atomic::{AtomicBool, Ordering};

/// The agents for which a step keeps the pool's workers awake. Below, a step runs its loops on
/// one thread or in few pieces, and waiting would only occupy the other cores; from the end on,
/// its loops are long enough that a wake-up is a small part of them, and the waiting workers'
/// looks for work would only contend with the step's thread (docs/PERFORMANCE.md, "Workers kept
/// awake").
pub(super) const AWAKE: std::ops::Range<usize> = 4096..65_536;

/// Spin hints between two looks for work: short against a loop, long enough that the looks do
/// not contend with the step's thread for its queue.
const SPINS: u32 = 64;

/// Idle looks after which a waiting worker yields its core once.
const LOOKS_PER_YIELD: u32 = 64;

/// Sets the flag when dropped: the waiting tasks end however the body ends.
struct Done<'a>(&'a AtomicBool);

impl Drop for Done<'_> {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Release);
    }
}

/// The machine's cores, asked once (the question reads files and allocates).
fn cores() -> usize {
    static CORES: std::sync::OnceLock<usize> = std::sync::OnceLock::new();
    *CORES.get_or_init(|| std::thread::available_parallelism().map_or(1, usize::from))
}

/// Runs `body` on the current rayon pool with every other worker of the pool awake until it
/// returns (on pools of at most as many threads as the machine has cores). Allocates nothing:
/// the waiting tasks are `rayon::join`'s stack jobs.
pub(super) fn with_awake_workers<R: Send>(body: impl FnOnce() -> R + Send) -> R {
    let threads = rayon::current_num_threads();
    if threads < 2 || threads > cores() {
        return body();
    }
    let done = AtomicBool::new(false);
    let runner = rayon::current_thread_index();
    // The waiting jobs are pushed before any of the body's work: other workers steal the
    // oldest job of a queue first, so each takes a waiting job before the body's work, and
    // the body's work then reaches them through `yield_now`.
    let (out, ()) = rayon::join(
        || {
            let _done = Done(&done);
            body()
        },
        || wait(&done, runner, threads - 1),
    );
    out
}

/// `count` waiting tasks: this one, and the rest pushed for other workers to take.
fn wait(done: &AtomicBool, runner: Option<usize>, count: usize) {
    if count > 1 {
        rayon::join(|| wait(done, runner, 1), || wait(done, runner, count - 1));
        return;
    }
    // Taken by the step's own thread (when it waits for its stolen work, or at the end): the
    // step has no use for it there.
    if rayon::current_thread_index() == runner {
        return;
    }
    let mut idle = 0u32;
    while !done.load(Ordering::Acquire) {
        if rayon::yield_now() == Some(rayon::Yield::Executed) {
            continue;
        }
        idle += 1;
        if idle.is_multiple_of(LOOKS_PER_YIELD) {
            std::thread::yield_now();
        } else {
            for _ in 0..SPINS {
                std::hint::spin_loop();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The body's value comes back with work shared among the threads; a panicking body ends
    /// the waiting tasks and its panic reaches the caller instead of a hang; the pool runs
    /// work afterwards.
    #[test]
    fn the_body_returns_and_a_panic_ends_the_wait() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let sum: u64 = pool.install(|| {
            with_awake_workers(|| {
                use rayon::prelude::*;
                (0..100_000u64).into_par_iter().sum()
            })
        });
        assert_eq!(sum, 100_000 * 99_999 / 2);
        let caught = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            pool.install(|| with_awake_workers(|| panic!("a step that fails")))
        }));
        assert!(caught.is_err());
        assert_eq!(pool.install(|| with_awake_workers(|| 7)), 7);
    }
}
