//! Once a world is warm, a step allocates nothing: every per-frame buffer is reused. (A frame
//! that moves a field's goals or rebuilds its channels may allocate; none of the measured
//! frames does.) Only the threads of the pool the steps run on are counted: the test harness's
//! own threads allocate when they report another test's result, at any moment.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use throng::scenario;

struct Counting;

static COUNTING: AtomicBool = AtomicBool::new(false);
static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    /// Whether this thread is one of a counting pool's (read inside the allocator: a constant
    /// initialiser and no destructor, so reading it never allocates).
    static COUNTED: Cell<bool> = const { Cell::new(false) };
}

/// Whether an allocation now is to be counted.
fn counts() -> bool {
    COUNTING.load(Ordering::Relaxed) && COUNTED.with(Cell::get)
}

// SAFETY: forwards to the system allocator unchanged; only counts calls.
#[allow(unsafe_code)]
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if counts() {
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
        if counts() {
            ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        }
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// The tests count allocations process-wide: one at a time.
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// This test's turn to count, and a pool of `threads` made before counting (rayon's pool
/// setup is not part of a step), whose threads are counted.
fn counting_with(threads: usize) -> (std::sync::MutexGuard<'static, ()>, rayon::ThreadPool) {
    let turn = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .start_handler(|_| COUNTED.with(|c| c.set(true)))
        .build()
        .unwrap();
    (turn, pool)
}

#[test]
fn warm_steps_do_not_allocate() {
    let (_one, pool) = counting_with(1);
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
        warm_threads(&pool, &s);
        let mut w = s.build().unwrap();
        let n = warm_allocations(&pool, &mut w, s.dt);
        assert_eq!(n, 0, "{name}: {n} allocations in 8 warm steps");
    }
}

/// Every thread of `pool` steps a world of its own from `s` first (at once, so each runs tasks
/// of its own world): the scratch some passes keep per thread is then made on every thread, and
/// sized for this scenario's tasks. (Without it, a thread that took no task of some pass during
/// the warm-up made its scratch in a measured step, at random. A thread that later meets a
/// denser neighbourhood than any it met here could still grow its scratch once.)
fn warm_threads(pool: &rayon::ThreadPool, s: &scenario::Scenario) {
    pool.broadcast(|_| {
        let mut w = s.build().unwrap();
        for _ in 0..8 {
            w.step(s.dt).unwrap();
        }
    });
}

/// The allocations of 8 steps after 8 warm-up steps (a full reordering period), on `pool`.
fn warm_allocations(pool: &rayon::ThreadPool, w: &mut throng::World, dt: f32) -> usize {
    pool.install(|| {
        for _ in 0..8 {
            w.step(dt).unwrap();
        }
        ALLOCATIONS.store(0, Ordering::SeqCst);
        COUNTING.store(true, Ordering::SeqCst);
        for _ in 0..8 {
            w.step(dt).unwrap();
        }
        COUNTING.store(false, Ordering::SeqCst);
    });
    ALLOCATIONS.load(Ordering::SeqCst)
}

/// Two threads, with the workers kept awake through the step (5,000 agents, within the range
/// where they are): the waiting tasks allocate nothing either.
#[test]
fn warm_steps_with_workers_awake_do_not_allocate() {
    let (_one, pool) = counting_with(2);
    for name in ["circle", "flock"] {
        let s = scenario::builtin(name).unwrap().with_agents(5000).unwrap();
        warm_threads(&pool, &s);
        let mut w = s.build().unwrap();
        w.set_workers_awake(true);
        let n = warm_allocations(&pool, &mut w, s.dt);
        assert_eq!(n, 0, "{name}: {n} allocations in 8 warm steps");
    }
}

/// A journey world: a queue popped now and then, a round robin to two exits, a waiting set,
/// routes round a pillar, an agent driven from outside.
fn journey_world() -> throng::World {
    use throng::journey::{Journey, Stage, Transition};
    use throng::prelude::*;
    let area = Walkable::from_wkt(
        "POLYGON ((0 0, 30 0, 30 20, 0 20, 0 0), (14 8, 16 8, 16 12, 14 12, 14 8))",
    )
    .unwrap();
    let mut w = World::builder()
        .seed(3)
        .group(throng::profile::Profile::journey_walkers(
            throng::ped::Model::Cfsm,
        ))
        .build()
        .unwrap();
    w.set_walkable(area).unwrap();
    let slots = (0..6)
        .map(|k| Vec2::new(20.0 - k as f32 * 0.6, 4.0))
        .collect();
    let queue = w.add_stage(Stage::Queue { slots }).unwrap();
    let wait = w
        .add_stage(Stage::WaitingSet {
            slots: vec![Vec2::new(22.0, 16.0), Vec2::new(23.0, 16.0)],
            active: false,
        })
        .unwrap();
    let exit = |w: &mut throng::World, y: f32| {
        w.add_stage(Stage::Exit {
            area: Walkable::rectangle(Vec2::new(28.0, y), Vec2::new(30.0, y + 3.0)).unwrap(),
        })
        .unwrap()
    };
    let (a, b) = (exit(&mut w, 1.0), exit(&mut w, 15.0));
    let j = w
        .add_journey(
            Journey::new([queue, wait, a, b])
                .with_transition(queue, Transition::round_robin([(a, 1), (wait, 2)]))
                .with_transition(wait, Transition::least_targeted([b, a])),
        )
        .unwrap();
    for k in 0..600 {
        let p = Vec2::new(1.0 + (k % 20) as f32 * 0.6, 1.0 + (k / 20) as f32 * 0.6);
        let id = w.add_agent(AgentInit::at(p, 0)).unwrap();
        w.set_journey(id, j, None).unwrap();
    }
    w
}

#[test]
fn warm_journey_steps_do_not_allocate() {
    let (_one, pool) = counting_with(1);
    let mut w = journey_world();
    pool.install(|| {
        // Past the first pops, seats and departures, whose lists grow to their size once.
        for k in 0..1600 {
            if k % 100 == 99 {
                let _ = w.pop_queue(throng::journey::StageId(0), 1);
            }
            w.step(0.01).unwrap();
        }
        ALLOCATIONS.store(0, Ordering::SeqCst);
        COUNTING.store(true, Ordering::SeqCst);
        for _ in 0..16 {
            w.step(0.01).unwrap();
        }
        COUNTING.store(false, Ordering::SeqCst);
    });
    let n = ALLOCATIONS.load(Ordering::SeqCst);
    assert_eq!(n, 0, "{n} allocations in 16 warm journey steps");
    assert!(
        w.stage_counts()[2].left > 0,
        "agents left through the round robin's exit"
    );
}
