//! Grid walkers on the notes' setup (400x400 cells, 85% obstacles, 1,000 walkers, 4 goals): all
//! arrive, none stands in a wall, no two share a cell, and 1 and 2 threads agree step by step.

use std::collections::HashSet;

use throng::field::{
    GoalChannels, GridWalkers, Neighbourhood, OccupancyGrid, PotentialField, WalkPolicy, WalkStats,
    random_free_cells,
};

struct Run {
    /// A hash of every walker's cell after every step.
    trace: Vec<u64>,
    stats: Vec<WalkStats>,
    final_positions: Vec<(u32, u32)>,
}

fn hash(positions: &[(u32, u32)], walkers: &GridWalkers) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325_u64;
    for (i, &(x, y)) in positions.iter().enumerate() {
        for v in [x, y, u32::from(walkers.is_arrived(i))] {
            h = (h ^ u64::from(v)).wrapping_mul(0x0100_0000_01b3);
        }
    }
    h
}

fn check_invariants(grid: &OccupancyGrid, walkers: &GridWalkers) {
    let mut seen = HashSet::new();
    for i in 0..walkers.len() {
        let (x, y) = walkers.position(i);
        assert!(
            grid.is_free(x, y),
            "walker {i} stands in a wall at ({x}, {y})"
        );
        if !walkers.is_arrived(i) {
            assert!(seen.insert((x, y)), "two walkers share ({x}, {y})");
            assert_eq!(walkers.occupant(x, y), Some(i));
        }
    }
}

fn run(
    grid: &OccupancyGrid,
    field: &PotentialField,
    starts: &[(u32, u32)],
    policy: WalkPolicy,
    threads: usize,
) -> Run {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let mut walkers = GridWalkers::new(grid, starts).unwrap();
        let mut run = Run {
            trace: Vec::new(),
            stats: Vec::new(),
            final_positions: Vec::new(),
        };
        // Each step moves at least the walker nearest a goal, so the summed steps bound the run.
        let bound: u64 = starts
            .iter()
            .map(|&(x, y)| u64::from(field.steps(x, y).unwrap_or(0)))
            .sum::<u64>()
            + 2;
        let mut n = 0;
        let reachable = starts
            .iter()
            .filter(|&&(x, y)| field.is_reachable(x, y))
            .count();
        while walkers.len() - walkers.active_count() < reachable {
            let stats = walkers.step(field, policy).unwrap();
            if stats.moved == 0 && stats.arrived == 0 {
                panic!("no walker moved in step {n}: {stats:?}");
            }
            check_invariants(grid, &walkers);
            let positions = walkers.positions();
            run.trace.push(hash(&positions, &walkers));
            run.stats.push(stats);
            n += 1;
            assert!(n <= bound, "walkers did not arrive within {bound} steps");
        }
        run.final_positions = walkers.positions();
        for (i, &(x, y)) in starts.iter().enumerate() {
            assert_eq!(
                walkers.is_arrived(i),
                field.is_reachable(x, y),
                "walker {i}"
            );
            if walkers.is_arrived(i) {
                let (gx, gy) = walkers.position(i);
                assert!(field.is_goal(gx, gy));
            }
        }
        run
    })
}

#[test]
fn notes_setup_all_walkers_arrive_on_1_and_2_threads() {
    let grid = OccupancyGrid::caves(400, 400, 0.85, 2024).unwrap();
    let goals = random_free_cells(&grid, 4, 1).unwrap();
    let starts = random_free_cells(&grid, 1004, 2)
        .unwrap()
        .into_iter()
        .filter(|s| !goals.contains(s))
        .take(1000)
        .collect::<Vec<_>>();
    assert_eq!(starts.len(), 1000);
    for n in [Neighbourhood::Four, Neighbourhood::Eight] {
        let field = PotentialField::bfs(&grid, &goals, 0.99, n).unwrap();
        assert_eq!(field.reachable_count(), grid.free_count());
        for policy in [WalkPolicy::Queue, WalkPolicy::NextBest] {
            let one = run(&grid, &field, &starts, policy, 1);
            let two = run(&grid, &field, &starts, policy, 2);
            assert_eq!(one.trace, two.trace, "{n:?} {policy:?}");
            assert_eq!(one.stats, two.stats);
            assert_eq!(one.final_positions, two.final_positions);
            let arrived: usize = one.stats.iter().map(|s| s.arrived).sum();
            assert_eq!(arrived, 1000);
            if policy == WalkPolicy::Queue {
                assert!(
                    one.stats.iter().any(|s| s.waited > 0),
                    "1,000 walkers and 4 goals should queue"
                );
            }
        }
    }
}

#[test]
fn walkers_outside_the_goal_component_stay_put() {
    let map = OccupancyGrid::parse_ascii("S.S.G#S.\n", "<map>").unwrap();
    let field = PotentialField::bfs(&map.grid, &map.goals, 0.5, Neighbourhood::Four).unwrap();
    let mut walkers = GridWalkers::new(&map.grid, &map.spawns).unwrap();
    for _ in 0..10 {
        walkers.step(&field, WalkPolicy::Queue).unwrap();
    }
    assert!(walkers.is_arrived(0) && walkers.is_arrived(1));
    assert!(!walkers.is_arrived(2));
    assert_eq!(walkers.position(2), (6, 0));
    assert_eq!(walkers.active_count(), 1);
}

#[test]
fn queueing_walkers_wait_and_next_best_walkers_step_aside() {
    // Walker 0 at (2, 1) has a walker (1) on its best cell (1, 1), which itself is blocked by
    // walker 2 on the goal's neighbour... a short queue in a 3-wide room.
    let map = OccupancyGrid::parse_ascii("G...\n....\n", "<map>").unwrap();
    let field = PotentialField::bfs(&map.grid, &map.goals, 0.5, Neighbourhood::Four).unwrap();
    let starts = [(2, 0), (1, 0)];
    let mut q = GridWalkers::new(&map.grid, &starts).unwrap();
    let s = q.step(&field, WalkPolicy::Queue).unwrap();
    // Walker 1 reaches the goal; walker 0's best cell (1, 0) was taken at the start: it waits.
    assert_eq!((s.moved, s.waited, s.arrived), (1, 1, 1));
    assert_eq!(q.position(0), (2, 0));
    let mut nb = GridWalkers::new(&map.grid, &starts).unwrap();
    let s = nb.step(&field, WalkPolicy::NextBest).unwrap();
    // The next best higher cell of (2, 0) is... none: (2, 1) is farther. So it waits too.
    assert_eq!((s.moved, s.waited), (1, 1));
    // From (2, 1) the best cell is (1, 1) (first in order among the 2-step cells); when it is
    // taken, NextBest takes (2, 0).
    let starts = [(2, 1), (1, 1)];
    let mut nb = GridWalkers::new(&map.grid, &starts).unwrap();
    nb.step(&field, WalkPolicy::NextBest).unwrap();
    assert_eq!(nb.position(0), (2, 0));
    let mut q = GridWalkers::new(&map.grid, &starts).unwrap();
    q.step(&field, WalkPolicy::Queue).unwrap();
    assert_eq!(q.position(0), (2, 1));
}

#[test]
fn conflicts_go_to_the_lowest_index() {
    // A plus-shaped room: three walkers around the goal all want it.
    let map = OccupancyGrid::parse_ascii("#.#\n.G.\n#.#\n", "<map>").unwrap();
    let field = PotentialField::bfs(&map.grid, &map.goals, 0.5, Neighbourhood::Four).unwrap();
    let mut w = GridWalkers::new(&map.grid, &[(2, 1), (0, 1), (1, 0)]).unwrap();
    let s = w.step(&field, WalkPolicy::Queue).unwrap();
    assert_eq!((s.moved, s.waited, s.arrived, s.active), (1, 2, 1, 2));
    assert!(w.is_arrived(0) && !w.is_arrived(1) && !w.is_arrived(2));
    let s = w.step(&field, WalkPolicy::Queue).unwrap();
    assert_eq!((s.moved, s.arrived), (1, 1));
    assert!(w.is_arrived(1));
    // Ties between equally good neighbours go to the first in neighbour order: +x first.
    let map = OccupancyGrid::parse_ascii("...\n...\n.G.\n", "<map>").unwrap();
    let field = PotentialField::bfs(&map.grid, &map.goals, 0.5, Neighbourhood::Four).unwrap();
    assert_eq!(field.best_neighbour(0, 0), Some((1, 0)));
}

#[test]
fn walkers_of_two_channels_meeting_head_on_swap() {
    // A one-cell corridor: channel 0 goes right, channel 1 goes left; they meet in the middle.
    let grid = OccupancyGrid::parse_ascii("........\n", "<map>")
        .unwrap()
        .grid;
    let mut channels = GoalChannels::new(grid.clone(), 0.9, Neighbourhood::Four).unwrap();
    channels.add_channel(&[(7, 0)]).unwrap();
    channels.add_channel(&[(0, 0)]).unwrap();
    channels.rebuild_dirty().unwrap();
    let mut w = GridWalkers::with_channels(&grid, &[(3, 0), (4, 0), (1, 0)], &[0, 1, 0]).unwrap();
    for _ in 0..20 {
        if w.active_count() == 0 {
            break;
        }
        w.step_channels(&channels, WalkPolicy::Queue).unwrap();
        check_invariants(&grid, &w);
    }
    assert_eq!(w.active_count(), 0);
    assert_eq!(w.positions(), vec![(7, 0), (0, 0), (7, 0)]);
}

#[test]
fn groups_follow_their_channels_and_moved_goals_rebuild() {
    let grid = OccupancyGrid::caves(80, 60, 0.6, 8).unwrap();
    let mut channels = GoalChannels::new(grid.clone(), 0.95, Neighbourhood::Eight).unwrap();
    let a = channels
        .add_channel(&random_free_cells(&grid, 2, 1).unwrap())
        .unwrap();
    let b = channels
        .add_channel(&random_free_cells(&grid, 3, 2).unwrap())
        .unwrap();
    assert_eq!(channels.rebuild_dirty().unwrap(), 2);
    let starts = random_free_cells(&grid, 200, 3).unwrap();
    let all_goals: Vec<_> = channels
        .goals(a)
        .unwrap()
        .iter()
        .chain(channels.goals(b).unwrap())
        .copied()
        .collect();
    let starts: Vec<_> = starts
        .into_iter()
        .filter(|s| !all_goals.contains(s))
        .collect();
    let groups: Vec<u32> = (0..starts.len() as u32).map(|i| i % 2).collect();
    let mut walkers = GridWalkers::with_channels(&grid, &starts, &groups).unwrap();
    for step in 0..20_000 {
        if walkers.active_count() == 0 {
            break;
        }
        if step == 30 {
            // The notes' click: new goals for channel b, then a rebuild.
            channels.randomize_goals(b, 3, 99).unwrap();
            assert!(
                walkers.step_channels(&channels, WalkPolicy::Queue).is_err(),
                "a dirty channel must not be followed"
            );
            assert_eq!(channels.rebuild_dirty().unwrap(), 1);
        }
        walkers.step_channels(&channels, WalkPolicy::Queue).unwrap();
        check_invariants(&grid, &walkers);
    }
    assert_eq!(walkers.active_count(), 0);
    for i in 0..walkers.len() {
        let (x, y) = walkers.position(i);
        let ch = walkers.channel(i) as usize;
        assert!(
            channels.goals(ch).unwrap().contains(&(x, y)) || (ch == b),
            "walker {i} of channel {ch} ended at ({x}, {y})"
        );
        assert!(channels.field(ch).unwrap().is_goal(x, y) || ch == b);
    }
}
