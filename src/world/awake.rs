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
//! Invariants: which thread runs a piece of work never changes a result (every parallel loop of
//! the step is deterministic by construction), so this changes timings only; the waiting task
//! never runs on the step's own thread (it would wait for itself); it ends when the step
//! returns or unwinds; a pool with more threads than the machine has cores is left as it is
//! (waiting threads would take cores from working ones).

use std::sync::atomic::{AtomicBool, Ordering};

/// The agents for which a step keeps the pool's workers awake. Below, a step runs its loops on
/// one thread or in few pieces, and waiting would only occupy the other cores; from the end on,
/// its loops are long enough that a wake-up is a small part of them, and the waiting workers'
/// looks for work would only contend with the step's thread (the 100,000-agent flock measured
/// 1% slower with them).
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

/// Runs `body` on the current rayon pool with every other worker of the pool awake until it
/// returns (on pools of at most as many threads as the machine has cores).
pub(super) fn with_awake_workers<R: Send>(body: impl FnOnce() -> R + Send) -> R {
    let threads = rayon::current_num_threads();
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    if threads < 2 || threads > cores {
        return body();
    }
    let done = AtomicBool::new(false);
    rayon::scope(|s| {
        let runner = rayon::current_thread_index();
        for _ in 1..threads {
            let done = &done;
            s.spawn(move |_| {
                // Taken by the step's own thread (at a join, or when the scope ends): the step
                // has no use for it there.
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
            });
        }
        let _done = Done(&done);
        body()
    })
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
