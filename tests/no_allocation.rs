//! Once a world is warm, a step allocates nothing: every per-frame buffer is reused. (A frame
//! that moves a field's goals or rebuilds its channels may allocate; none of the measured
//! frames does.)

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use throng::scenario;

struct Counting;

static COUNTING: AtomicBool = AtomicBool::new(false);
static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards to the system allocator unchanged; only counts calls.
#[allow(unsafe_code)]
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if COUNTING.load(Ordering::Relaxed) {
            ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        }
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if COUNTING.load(Ordering::Relaxed) {
            ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        }
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn warm_steps_do_not_allocate() {
    // One thread: rayon's pool setup is not part of a step.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    for name in [
        "flock",
        "pursuit",
        "obstacles",
        "antigravity",
        "wander",
        "path",
        "leader",
        "formation",
        "vicsek",
        "seek",
        "arrive",
        "fields",
        "fields-large",
        "fields-walkers",
        "circle",
        "blocks",
    ] {
        // Scenarios whose agents are tied to a map keep their own count.
        let s = scenario::builtin(name).unwrap();
        let s = if name.starts_with("fields") {
            s
        } else {
            s.with_agents(3000).unwrap()
        };
        let mut w = s.build().unwrap();
        pool.install(|| {
            // Warm up through a full reordering period.
            for _ in 0..8 {
                w.step(s.dt).unwrap();
            }
            ALLOCATIONS.store(0, Ordering::SeqCst);
            COUNTING.store(true, Ordering::SeqCst);
            for _ in 0..8 {
                w.step(s.dt).unwrap();
            }
            COUNTING.store(false, Ordering::SeqCst);
        });
        let n = ALLOCATIONS.load(Ordering::SeqCst);
        assert_eq!(n, 0, "{name}: {n} allocations in 8 warm steps");
    }
}
