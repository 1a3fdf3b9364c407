//! Potential and integration fields against independent oracles: a plain BFS over `(x, y)`
//! coordinates for step counts, potentials as repeated multiplication by `decay`, and a plain
//! relaxation for Dijkstra costs.

use std::collections::VecDeque;

use proptest::prelude::*;
use throng::field::{
    DIRECTIONS, IntegrationField, Neighbourhood, OccupancyGrid, PotentialField, random_free_cells,
};

/// Neighbours `(x, y)` may step to, in any order, with the no-corner-cutting rule.
fn moves(grid: &OccupancyGrid, x: u32, y: u32, n: Neighbourhood) -> Vec<(u32, u32, bool)> {
    let free = |x: i64, y: i64| x >= 0 && y >= 0 && grid.is_free(x as u32, y as u32);
    let mut out = Vec::new();
    for &(dx, dy) in &DIRECTIONS[..n.count()] {
        let (nx, ny) = (i64::from(x) + i64::from(dx), i64::from(y) + i64::from(dy));
        let diagonal = dx != 0 && dy != 0;
        if !free(nx, ny) {
            continue;
        }
        if diagonal
            && !(free(i64::from(x) + i64::from(dx), i64::from(y))
                && free(i64::from(x), i64::from(y) + i64::from(dy)))
        {
            continue;
        }
        out.push((nx as u32, ny as u32, diagonal));
    }
    out
}

/// Plain BFS distances from the goals; `None` where unreachable.
fn oracle_steps(grid: &OccupancyGrid, goals: &[(u32, u32)], n: Neighbourhood) -> Vec<Option<u32>> {
    let w = grid.width() as usize;
    let mut dist = vec![None; grid.len()];
    let mut queue = VecDeque::new();
    for &(x, y) in goals {
        if dist[y as usize * w + x as usize].is_none() {
            dist[y as usize * w + x as usize] = Some(0);
            queue.push_back((x, y));
        }
    }
    while let Some((x, y)) = queue.pop_front() {
        let d = dist[y as usize * w + x as usize].unwrap();
        for (nx, ny, _) in moves(grid, x, y, n) {
            let slot = &mut dist[ny as usize * w + nx as usize];
            if slot.is_none() {
                *slot = Some(d + 1);
                queue.push_back((nx, ny));
            }
        }
    }
    dist
}

/// `decay` multiplied by itself `steps` times, as the BFS does step by step.
fn repeated(decay: f32, steps: u32) -> f32 {
    let mut v = 1.0_f32;
    for _ in 0..steps {
        v *= decay;
    }
    v
}

fn check_against_oracle(
    grid: &OccupancyGrid,
    goals: &[(u32, u32)],
    decay: f32,
    n: Neighbourhood,
) -> PotentialField {
    let field = PotentialField::bfs(grid, goals, decay, n).unwrap();
    let oracle = oracle_steps(grid, goals, n);
    let w = grid.width();
    let mut reachable = 0;
    for (i, d) in oracle.iter().enumerate() {
        let (x, y) = (i as u32 % w, i as u32 / w);
        assert_eq!(field.steps(x, y), *d, "steps at ({x}, {y})");
        match d {
            Some(d) => {
                reachable += 1;
                let p = field.potential(x, y).unwrap();
                assert_eq!(
                    p.to_bits(),
                    repeated(decay, *d).to_bits(),
                    "potential at ({x}, {y}), {d} steps"
                );
                let powi = decay.powi(*d as i32);
                if powi > 1e-30 {
                    assert!(
                        (p - powi).abs() <= powi * 1e-5 * (*d as f32 + 1.0),
                        "{p} vs powi {powi}"
                    );
                }
                assert_eq!(field.row(y)[x as usize], p);
            }
            None => {
                assert_eq!(field.potential(x, y), None);
                assert!(!field.is_reachable(x, y));
                assert_eq!(field.row(y)[x as usize], PotentialField::UNREACHABLE);
            }
        }
    }
    assert_eq!(field.reachable_count(), reachable);
    field
}

const MAPS: &[&str] = &[
    "G....\n.....\n.....\n",
    "G.#..\n..#..\n..#..\n.....\n",
    "....#....\n.##.#.##.\n.#G.#.#..\n.####.#.#\n......#.G\n",
    // A walled-off pocket (right) that no goal reaches, and a corner only a diagonal would cut.
    "G..#...\n.#.#.#.\n...#...\n####...\n",
    "G#.\n#..\n...\n",
    "..........\n.########.\n.#......#.\n.#.####.#.\n.#.#G.#.#.\n.#.#..#.#.\n.#....#...\n.######.#.\n..........\n",
];

#[test]
fn hand_made_maps_match_the_oracle() {
    for text in MAPS {
        let map = OccupancyGrid::parse_ascii(text, "<map>").unwrap();
        for n in [Neighbourhood::Four, Neighbourhood::Eight] {
            for decay in [0.5, 0.9, 0.99, 0.1234] {
                check_against_oracle(&map.grid, map.require_goals().unwrap(), decay, n);
            }
        }
    }
}

#[test]
fn unreachable_cells_are_reported_not_zero() {
    let map = OccupancyGrid::parse_ascii("G..#...\n.#.#.#.\n...#...\n####...\n", "<map>").unwrap();
    let field = PotentialField::bfs(&map.grid, &map.goals, 0.5, Neighbourhood::Eight).unwrap();
    for y in 0..4 {
        for x in 4..7 {
            assert!(!field.is_reachable(x, y));
            assert_eq!(field.potential(x, y), None);
            assert_eq!(field.row(y)[x as usize], PotentialField::UNREACHABLE);
        }
    }
    const { assert!(PotentialField::UNREACHABLE < 0.0) };
    // Corner cutting: (1, 0) -> (0, 1) is fine, but the map "G#/#." never reaches (1, 1).
    let map = OccupancyGrid::parse_ascii("G#\n#.\n", "<map>").unwrap();
    let field = PotentialField::bfs(&map.grid, &map.goals, 0.5, Neighbourhood::Eight).unwrap();
    assert!(!field.is_reachable(1, 1));
}

#[test]
fn multi_goal_fields_are_the_maximum_of_single_goal_fields() {
    let grid = OccupancyGrid::caves(60, 45, 0.55, 11).unwrap();
    let goals = random_free_cells(&grid, 4, 5).unwrap();
    for n in [Neighbourhood::Four, Neighbourhood::Eight] {
        let all = check_against_oracle(&grid, &goals, 0.93, n);
        let singles: Vec<_> = goals
            .iter()
            .map(|g| PotentialField::bfs(&grid, &[*g], 0.93, n).unwrap())
            .collect();
        for y in 0..grid.height() {
            for x in 0..grid.width() {
                let max = singles
                    .iter()
                    .filter_map(|f| f.potential(x, y))
                    .fold(None, |m: Option<f32>, p| Some(m.map_or(p, |m| m.max(p))));
                assert_eq!(all.potential(x, y), max, "({x}, {y})");
            }
        }
    }
}

#[test]
fn bad_goals_and_decays_get_the_right_errors() {
    use throng::Error;
    let g = OccupancyGrid::parse_ascii("..#\n...\n", "<map>")
        .unwrap()
        .grid;
    let bfs = |goals: &[(u32, u32)], d: f32| PotentialField::bfs(&g, goals, d, Neighbourhood::Four);
    assert!(matches!(bfs(&[], 0.5), Err(Error::Invalid { .. })));
    assert!(matches!(bfs(&[(3, 0)], 0.5), Err(Error::Invalid { .. })));
    assert!(matches!(bfs(&[(2, 0)], 0.5), Err(Error::Invalid { .. })));
    for d in [0.0, 1.0, -1.0, 2.0] {
        assert!(
            matches!(
                bfs(&[(0, 0)], d),
                Err(Error::OutOfRange { name: "decay", .. })
            ),
            "{d}"
        );
    }
    for d in [f32::NAN, f32::INFINITY] {
        assert!(
            matches!(
                bfs(&[(0, 0)], d),
                Err(Error::NonFinite { name: "decay", .. })
            ),
            "{d}"
        );
    }
    assert!(matches!(
        IntegrationField::dijkstra(&g, &[], Neighbourhood::Four, None),
        Err(Error::Invalid { .. })
    ));
}

/// Dijkstra costs by plain repeated relaxation (Bellman-Ford) until nothing changes.
fn oracle_costs(
    grid: &OccupancyGrid,
    goals: &[(u32, u32)],
    n: Neighbourhood,
    costs: &[f32],
) -> Vec<f32> {
    let w = grid.width() as usize;
    let mut c = vec![f32::INFINITY; grid.len()];
    for &(x, y) in goals {
        c[y as usize * w + x as usize] = 0.0;
    }
    loop {
        let mut changed = false;
        for i in 0..grid.len() {
            let (x, y) = ((i % w) as u32, (i / w) as u32);
            if !c[i].is_finite() {
                continue;
            }
            for (nx, ny, diagonal) in moves(grid, x, y, n) {
                let j = ny as usize * w + nx as usize;
                let len = if diagonal {
                    std::f32::consts::SQRT_2
                } else {
                    1.0
                };
                let cand = c[i] + len * costs[j];
                if cand < c[j] {
                    c[j] = cand;
                    changed = true;
                }
            }
        }
        if !changed {
            return c;
        }
    }
}

#[test]
fn dijkstra_matches_relaxation() {
    let grid = OccupancyGrid::caves(40, 30, 0.5, 3).unwrap();
    let goals = random_free_cells(&grid, 3, 9).unwrap();
    let costs: Vec<f32> = (0..grid.len()).map(|i| 1.0 + (i * 7 % 5) as f32).collect();
    for n in [Neighbourhood::Four, Neighbourhood::Eight] {
        for with_costs in [false, true] {
            let unit = vec![1.0; grid.len()];
            let cs = if with_costs { &costs } else { &unit };
            let field =
                IntegrationField::dijkstra(&grid, &goals, n, with_costs.then_some(&costs[..]))
                    .unwrap();
            let oracle = oracle_costs(&grid, &goals, n, cs);
            for (i, &o) in oracle.iter().enumerate() {
                let (x, y) = (i as u32 % grid.width(), i as u32 / grid.width());
                match field.cost(x, y) {
                    None => assert!(o.is_infinite()),
                    // Both sum the same terms along some cheapest path; the order may differ.
                    Some(c) => {
                        assert!((c - o).abs() <= 1e-3 * o.max(1.0), "({x}, {y}): {c} vs {o}")
                    }
                }
            }
            if n == Neighbourhood::Four && !with_costs {
                let bfs = PotentialField::bfs(&grid, &goals, 0.5, n).unwrap();
                for y in 0..grid.height() {
                    for x in 0..grid.width() {
                        assert_eq!(field.cost(x, y), bfs.steps(x, y).map(|s| s as f32));
                    }
                }
            }
        }
    }
}

fn neighbourhood() -> impl Strategy<Value = Neighbourhood> {
    prop_oneof![Just(Neighbourhood::Four), Just(Neighbourhood::Eight)]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Every reachable non-goal cell has a neighbour it may step to with strictly more energy
    /// (while potentials are normal floats) and strictly fewer steps (always): no local maxima
    /// except goals.
    #[test]
    fn no_local_maxima_except_goals(
        w in 1u32..48, h in 1u32..48, fraction in 0.0f32..0.8, seed in any::<u64>(),
        goals in 1usize..5, decay in 0.5f32..0.999, n in neighbourhood(),
    ) {
        let grid = OccupancyGrid::caves(w, h, fraction, seed).unwrap();
        let goals = random_free_cells(&grid, goals.min(grid.free_count()), seed ^ 1).unwrap();
        let field = check_against_oracle(&grid, &goals, decay, n);
        // Caves are connected: every free cell is reachable.
        prop_assert_eq!(field.reachable_count(), grid.free_count());
        for y in 0..h {
            for x in 0..w {
                let Some(s) = field.steps(x, y) else { continue };
                if s == 0 {
                    prop_assert!(field.best_neighbour(x, y).is_none());
                    continue;
                }
                let p = field.potential(x, y).unwrap();
                let best = moves(&grid, x, y, n).into_iter().map(|(nx, ny, _)| (field.steps(nx, ny).unwrap(), field.potential(nx, ny).unwrap())).min_by_key(|&(s, _)| s).unwrap();
                prop_assert!(best.0 < s);
                if p >= f32::MIN_POSITIVE {
                    prop_assert!(best.1 > p);
                }
                let (bx, by) = field.best_neighbour(x, y).unwrap();
                prop_assert_eq!(field.steps(bx, by), Some(s - 1));
            }
        }
    }
}
