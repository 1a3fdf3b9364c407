//! The fast field builds against the simple ones: [`PotentialField::bfs`] and
//! [`PotentialField::rebuild`] against [`PotentialField::bfs_reference`] (the notes' literal
//! algorithm), bit for bit, on scattered maps (several components, so unreachable cells occur)
//! and caves; and the flow built from a field against [`PotentialField::best_neighbour`].

use proptest::prelude::*;
use throng::field::{
    Cell, FlowField, Neighbourhood, OccupancyGrid, PotentialField, random_free_cells,
};

fn neighbourhood() -> impl Strategy<Value = Neighbourhood> {
    prop_oneof![Just(Neighbourhood::Four), Just(Neighbourhood::Eight)]
}

fn grid(w: u32, h: u32, fraction: f32, seed: u64, caves: bool) -> OccupancyGrid {
    if caves {
        OccupancyGrid::caves(w, h, fraction, seed).unwrap()
    } else {
        OccupancyGrid::scattered(w, h, fraction, seed).unwrap()
    }
}

/// Equal cell by cell in everything the public API shows, potentials compared by bits.
fn assert_same(a: &PotentialField, b: &PotentialField) {
    assert_eq!((a.width(), a.height()), (b.width(), b.height()));
    assert_eq!(a.reachable_count(), b.reachable_count());
    for y in 0..a.height() {
        let (ra, rb) = (a.row(y), b.row(y));
        for x in 0..a.width() {
            assert_eq!(
                ra[x as usize].to_bits(),
                rb[x as usize].to_bits(),
                "({x}, {y})"
            );
            assert_eq!(a.steps(x, y), b.steps(x, y), "({x}, {y})");
        }
    }
    assert_eq!(a, b);
}

/// The flow's next cell is the field's best neighbour everywhere.
fn assert_flow_matches(field: &PotentialField, flow: &FlowField) {
    for y in 0..field.height() {
        for x in 0..field.width() {
            assert_eq!(
                flow.next_cell(x, y),
                field.best_neighbour(x, y),
                "({x}, {y})"
            );
            assert_eq!(flow.is_goal(x, y), field.is_goal(x, y));
            assert_eq!(flow.is_reachable(x, y), field.is_reachable(x, y));
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn fast_bfs_and_rebuild_equal_the_reference(
        w in 1u32..80, h in 1u32..80, fraction in 0.0f32..0.6, seed in any::<u64>(),
        goals in 1usize..6, decay in 0.3f32..0.999, n in neighbourhood(), caves in any::<bool>(),
        w2 in 1u32..80, h2 in 1u32..80,
    ) {
        let g = grid(w, h, fraction, seed, caves);
        // A generated grid can be all wall; a field needs a free cell for its goal.
        prop_assume!(g.free_count() > 0);
        let goals = random_free_cells(&g, goals.min(g.free_count()), seed ^ 1).unwrap();
        let reference = PotentialField::bfs_reference(&g, &goals, decay, n).unwrap();
        let mut fast = PotentialField::bfs(&g, &goals, decay, n).unwrap();
        assert_same(&fast, &reference);
        let mut flow = FlowField::from_potential(&fast);
        assert_flow_matches(&fast, &flow);

        // Rebuild in place on another grid (other size and walls), then back on the first.
        let g2 = grid(w2, h2, fraction, seed ^ 7, !caves);
        prop_assume!(g2.free_count() > 0);
        let goals2 = random_free_cells(&g2, 3.min(g2.free_count()), seed ^ 2).unwrap();
        fast.rebuild(&g2, &goals2).unwrap();
        assert_same(&fast, &PotentialField::bfs_reference(&g2, &goals2, decay, n).unwrap());
        flow.rebuild_from_potential(&fast);
        assert_flow_matches(&fast, &flow);
        assert_eq!(&flow, &FlowField::from_potential(&fast));
        fast.rebuild(&g, &goals).unwrap();
        assert_same(&fast, &reference);
    }
}

#[test]
fn long_corridors_need_many_levels_and_a_growing_queue() {
    // A 300x300 open grid from one corner (a wide frontier) and a serpentine (many levels).
    let open = OccupancyGrid::new(300, 300).unwrap();
    for n in [Neighbourhood::Four, Neighbourhood::Eight] {
        let goals = [(0, 0), (299, 299), (150, 0)];
        let fast = PotentialField::bfs(&open, &goals, 0.999, n).unwrap();
        assert_same(
            &fast,
            &PotentialField::bfs_reference(&open, &goals, 0.999, n).unwrap(),
        );
    }
    let mut text = String::new();
    for y in 0..61 {
        for x in 0..61 {
            let wall = y % 2 == 1 && if (y / 2) % 2 == 0 { x != 60 } else { x != 0 };
            text.push(if wall { '#' } else { '.' });
        }
        text.push('\n');
    }
    let map = OccupancyGrid::parse_ascii(&text, "<serpentine>").unwrap();
    for n in [Neighbourhood::Four, Neighbourhood::Eight] {
        let fast = PotentialField::bfs(&map.grid, &[(0, 0)], 0.99, n).unwrap();
        assert_same(
            &fast,
            &PotentialField::bfs_reference(&map.grid, &[(0, 0)], 0.99, n).unwrap(),
        );
        assert!(fast.steps(0, 60).unwrap() > 1800);
    }
}

/// A serpentine of `width` columns and `rows` free rows, joined at alternate ends.
fn serpentine(width: u32, rows: u32) -> OccupancyGrid {
    let h = 2 * rows - 1;
    let mut g = OccupancyGrid::new(width, h).unwrap();
    for y in (1..h).step_by(2) {
        let gap = if (y / 2) % 2 == 0 { width - 1 } else { 0 };
        for x in (0..width).filter(|&x| x != gap) {
            g.set(x, y, Cell::Wall).unwrap();
        }
    }
    g
}

#[test]
fn more_levels_than_two_bytes_hold_still_match() {
    // 160 rows of 500 cells: about 80,000 levels, past the 65,533 a two-byte count holds.
    let long = serpentine(500, 160);
    let short = serpentine(50, 10);
    for n in [Neighbourhood::Four, Neighbourhood::Eight] {
        let reference = PotentialField::bfs_reference(&long, &[(0, 0)], 0.9999, n).unwrap();
        assert!(reference.steps(0, 318).unwrap() > 70_000);
        let mut fast = PotentialField::bfs(&long, &[(0, 0)], 0.9999, n).unwrap();
        assert_same(&fast, &reference);
        // In place to a short search and back.
        fast.rebuild(&short, &[(3, 0)]).unwrap();
        assert_same(
            &fast,
            &PotentialField::bfs_reference(&short, &[(3, 0)], 0.9999, n).unwrap(),
        );
        fast.rebuild(&long, &[(0, 0)]).unwrap();
        assert_same(&fast, &reference);
    }
}

#[test]
fn rebuild_rejects_bad_goals_and_keeps_the_field() {
    let g = OccupancyGrid::new(4, 4).unwrap();
    let mut f = PotentialField::bfs(&g, &[(0, 0)], 0.5, Neighbourhood::Four).unwrap();
    let before = f.clone();
    assert!(f.rebuild(&g, &[]).is_err());
    assert!(f.rebuild(&g, &[(9, 9)]).is_err());
    assert_eq!(f, before);
}
