//! Points that follow a sampled flow field through continuous space reach a goal cell and never
//! enter a wall cell.

use glam::Vec2;
use proptest::prelude::*;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use throng::field::{
    DistanceField, FlowField, IntegrationField, Neighbourhood, OccupancyGrid, PotentialField,
    random_free_cells,
};

/// Integrates `p += h * sample(p)` from `start`; returns the number of steps to a goal cell.
fn follow(
    grid: &OccupancyGrid,
    flow: &FlowField,
    start: Vec2,
    h: f32,
    max_steps: usize,
) -> Result<usize, String> {
    let mut p = start;
    for n in 0..max_steps {
        let Some((x, y)) = grid.world_to_cell(p) else {
            return Err(format!("left the grid at {p} after {n} steps"));
        };
        if !grid.is_free(x, y) {
            return Err(format!(
                "entered the wall cell ({x}, {y}) at {p} after {n} steps"
            ));
        }
        if flow.is_goal(x, y) {
            return Ok(n);
        }
        let d = flow.sample(p);
        if d == Vec2::ZERO {
            return Err(format!("zero flow at {p} in ({x}, {y})"));
        }
        assert!(
            (d.length() - 1.0).abs() < 1e-4,
            "sample {d} is not a unit vector"
        );
        p += h * d;
    }
    Err(format!("no goal within {max_steps} steps from {start}"))
}

fn check_cave(
    w: u32,
    h: u32,
    fraction: f32,
    seed: u64,
    goals: usize,
    points: usize,
    n: Neighbourhood,
) -> Result<(), String> {
    let grid = OccupancyGrid::caves(w, h, fraction, seed)
        .unwrap()
        .with_geometry(2.0, Vec2::new(-30.0, 7.5))
        .unwrap();
    let goals = random_free_cells(&grid, goals.min(grid.free_count()), seed ^ 0x55).unwrap();
    let potential = PotentialField::bfs(&grid, &goals, 0.97, n).unwrap();
    let integration = IntegrationField::dijkstra(&grid, &goals, n, None).unwrap();
    let distance = DistanceField::fast_marching(&grid, &goals).unwrap();
    let starts = random_free_cells(&grid, points.min(grid.free_count()), seed ^ 0xaa).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    for (name, flow) in [
        ("potential", FlowField::from_potential(&potential)),
        ("integration", FlowField::from_integration(&integration)),
        ("distance", FlowField::from_distance(&distance)),
    ] {
        for &(x, y) in &starts {
            // Anywhere in the start cell, edges included.
            let jitter = Vec2::new(rng.random_range(0.0..1.0), rng.random_range(0.0..1.0));
            let start = grid.origin() + (Vec2::new(x as f32, y as f32) + jitter) * grid.cell_size();
            let bound = 8 * (potential.steps(x, y).unwrap() as usize + 2) + 64;
            for step in [0.3, 0.9] {
                follow(&grid, &flow, start, step * grid.cell_size(), bound)
                    .map_err(|e| format!("{name} {n:?} step {step}: {e}"))?;
            }
        }
    }
    Ok(())
}

#[test]
fn notes_cave_points_reach_goals() {
    for n in [Neighbourhood::Four, Neighbourhood::Eight] {
        check_cave(400, 400, 0.85, 2024, 4, 500, n).unwrap();
    }
}

#[test]
fn open_rooms_points_reach_goals() {
    let map = OccupancyGrid::parse_ascii(
        "..........#.........\n\
         ..####....#....##...\n\
         ..#.......#.....#...\n\
         ..#...#####..G..#...\n\
         ..#.............#...\n\
         ..########...####...\n\
         ....................\n",
        "<map>",
    )
    .unwrap();
    let goals = map.require_goals().unwrap();
    for n in [Neighbourhood::Four, Neighbourhood::Eight] {
        let flow =
            FlowField::from_potential(&PotentialField::bfs(&map.grid, goals, 0.9, n).unwrap());
        let flow_i = FlowField::from_integration(
            &IntegrationField::dijkstra(&map.grid, goals, n, None).unwrap(),
        );
        let flow_d =
            FlowField::from_distance(&DistanceField::fast_marching(&map.grid, goals).unwrap());
        for y in 0..map.grid.height() {
            for x in 0..map.grid.width() {
                if !map.grid.is_free(x, y) {
                    assert_eq!(flow.sample(map.grid.cell_center(x, y)), Vec2::ZERO);
                    continue;
                }
                for f in [&flow, &flow_i, &flow_d] {
                    for corner in [
                        Vec2::ZERO,
                        Vec2::new(0.999, 0.0),
                        Vec2::new(0.0, 0.999),
                        Vec2::splat(0.999),
                        Vec2::splat(0.5),
                    ] {
                        follow(
                            &map.grid,
                            f,
                            Vec2::new(x as f32, y as f32) + corner,
                            0.45,
                            500,
                        )
                        .unwrap();
                    }
                }
            }
        }
    }
}

#[test]
fn samples_outside_and_on_goals_are_zero() {
    let map = OccupancyGrid::parse_ascii("G..\n", "<map>").unwrap();
    let flow = FlowField::from_potential(
        &PotentialField::bfs(&map.grid, &map.goals, 0.5, Neighbourhood::Four).unwrap(),
    );
    assert_eq!(flow.sample(Vec2::new(0.5, 0.5)), Vec2::ZERO);
    assert_eq!(flow.sample(Vec2::new(-0.5, 0.5)), Vec2::ZERO);
    assert_eq!(flow.sample(Vec2::new(f32::NAN, 0.5)), Vec2::ZERO);
    assert_eq!(flow.sample(Vec2::new(2.5, 0.5)), Vec2::NEG_X);
    assert_eq!(flow.next_cell(2, 0), Some((1, 0)));
    assert_eq!(flow.next_cell(0, 0), None);
}

/// In open ground the distance flow heads straight at the goal, where the step flows can only
/// take one of eight directions.
#[test]
fn distance_flow_heads_straight_at_the_goal() {
    let grid = OccupancyGrid::new(64, 64).unwrap();
    let goal = (10, 10);
    let flow = FlowField::from_distance(&DistanceField::fast_marching(&grid, &[goal]).unwrap());
    let steps = FlowField::from_potential(
        &PotentialField::bfs(&grid, &[goal], 0.9, Neighbourhood::Eight).unwrap(),
    );
    let (mut worst, mut worst_steps) = (0.0f32, 0.0f32);
    for (x, y) in [(60, 30), (40, 12), (25, 63), (11, 50), (63, 63), (50, 20)] {
        let p = grid.cell_center(x, y);
        let to_goal = (grid.cell_center(goal.0, goal.1) - p).normalize();
        worst = worst.max(flow.sample(p).angle_to(to_goal).abs());
        worst_steps = worst_steps.max(steps.sample(p).angle_to(to_goal).abs());
    }
    assert!(worst < 0.06, "{worst} rad");
    assert!(worst_steps > 0.3, "{worst_steps} rad");
    assert_eq!(flow.next_cell(12, 10), Some((11, 10)));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    #[test]
    fn random_caves_points_reach_goals(
        w in 2u32..40, h in 2u32..40, fraction in 0.0f32..0.8, seed in any::<u64>(), goals in 1usize..4, eight in any::<bool>(),
    ) {
        let n = if eight { Neighbourhood::Eight } else { Neighbourhood::Four };
        check_cave(w, h, fraction, seed, goals, 40, n).map_err(TestCaseError::fail)?;
    }
}
