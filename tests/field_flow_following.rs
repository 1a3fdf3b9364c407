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

/// `sample`'s open-area path gives the bits of the general path with every wall rule checked
/// (`sample_general`), at random points and at cell edges and corners, in caves sparse and
/// dense, for every kind of flow; and the open-area path is taken at many of the points.
#[test]
fn sample_matches_the_general_path_bit_for_bit() {
    let mut open_points = 0;
    let mut points = 0;
    for (fraction, seed) in [(0.1, 3), (0.3, 5), (0.6, 7)] {
        let grid = OccupancyGrid::caves(80, 60, fraction, seed)
            .unwrap()
            .with_geometry(0.2, Vec2::new(-3.0, 1.5))
            .unwrap();
        let goals = random_free_cells(&grid, 3, seed ^ 0x55).unwrap();
        let flows = [
            FlowField::from_potential(
                &PotentialField::bfs(&grid, &goals, 0.97, Neighbourhood::Eight).unwrap(),
            ),
            FlowField::from_integration(
                &IntegrationField::dijkstra(&grid, &goals, Neighbourhood::Four, None).unwrap(),
            ),
            FlowField::from_distance(&DistanceField::fast_marching(&grid, &goals).unwrap()),
        ];
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let (w, h) = (grid.width() as f32, grid.height() as f32);
        let mut at: Vec<Vec2> = (0..4000)
            .map(|_| {
                Vec2::new(
                    rng.random_range(-1.0..w + 1.0),
                    rng.random_range(-1.0..h + 1.0),
                )
            })
            .collect();
        // Cell edges and corners, where the blend's weights are 0 or 1.
        at.extend((0..400).map(|k| Vec2::new((k % 80) as f32, (k / 80 * 7) as f32)));
        at.extend((0..400).map(|k| Vec2::new((k % 80) as f32 + 0.5, (k / 80 * 7) as f32)));
        for flow in &flows {
            for &c in &at {
                let p = grid.origin() + c * grid.cell_size();
                let (fast, general) = (flow.sample(p), flow.sample_general(p));
                assert_eq!(
                    fast.to_array().map(f32::to_bits),
                    general.to_array().map(f32::to_bits),
                    "at {p}: {fast} against {general}"
                );
                points += 1;
                let Some((x, y)) = grid.world_to_cell(p) else {
                    continue;
                };
                let open = (-1i64..=1).all(|dy| {
                    (-1i64..=1).all(|dx| {
                        let (nx, ny) = (i64::from(x) + dx, i64::from(y) + dy);
                        nx >= 0 && ny >= 0 && flow.is_reachable(nx as u32, ny as u32)
                    })
                });
                if open && general != Vec2::ZERO {
                    open_points += 1;
                }
            }
        }
    }
    assert!(
        open_points * 4 > points,
        "{open_points} of {points} in open cells"
    );
}
