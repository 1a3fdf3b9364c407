//! Every neighbour-index backend returns exactly what brute force returns: the same indices in
//! the same order, bit-identical offsets and squared distances; and k-nearest queries return
//! brute force sorted by `(dist_sq, index)` and cut to `k`.

use glam::Vec2;
use proptest::prelude::*;
use throng::{
    Bounds, BruteIndex, GridIndex, HashGrid, IndexKind, KdTreeIndex, Neighbour, NeighbourIndex,
    SpatialIndex,
};

/// A neighbour list as bits, so that `-0.0` and `0.0` count as different.
fn bits(v: &[Neighbour]) -> Vec<(u32, u32, u32, u32)> {
    v.iter()
        .map(|n| {
            (
                n.index,
                n.offset.x.to_bits(),
                n.offset.y.to_bits(),
                n.dist_sq.to_bits(),
            )
        })
        .collect()
}

/// The expected k-nearest answer, from brute force.
fn k_nearest_reference(
    brute: &BruteIndex,
    p: Vec2,
    k: usize,
    r: f32,
    exclude: Option<usize>,
) -> Vec<Neighbour> {
    let mut all = Vec::new();
    brute.neighbours_at(p, r, &mut all);
    all.retain(|n| Some(n.index as usize) != exclude);
    all.sort_by(|a, b| a.dist_sq.total_cmp(&b.dist_sq).then(a.index.cmp(&b.index)));
    all.truncate(k);
    all
}

/// Checks every backend against brute force for all points, `extra` query points and `radii`.
fn check_all(
    xs: &[f32],
    ys: &[f32],
    bounds: Bounds,
    max_radius: f32,
    radii: &[f32],
    extra: &[Vec2],
) {
    let mut brute = BruteIndex::default();
    brute.rebuild(xs, ys, bounds, max_radius);
    let mut backends: Vec<(String, SpatialIndex)> = Vec::new();
    for kind in [IndexKind::Grid, IndexKind::KdTree] {
        let mut ix = SpatialIndex::new(kind);
        ix.rebuild(xs, ys, bounds, max_radius);
        assert_eq!(ix.len(), xs.len());
        backends.push((kind.to_string(), ix));
    }
    let mut grid = GridIndex::default();
    grid.rebuild(xs, ys, bounds, max_radius);
    backends.push(("grid (direct)".into(), grid.into()));
    let mut tree = KdTreeIndex::default();
    tree.rebuild(xs, ys, bounds, max_radius);
    backends.push(("kdtree (clone)".into(), tree.clone().into()));

    // The hashed grid (open and walled worlds): its runs, filtered by the plain difference.
    let mut hash = HashGrid::default();
    if !bounds.is_torus() {
        hash.rebuild(xs, ys, max_radius.max(1e-3));
    }

    let (mut want, mut got) = (Vec::new(), Vec::new());
    let points: Vec<Vec2> = xs
        .iter()
        .zip(ys)
        .map(|(&x, &y)| Vec2::new(x, y))
        .chain(extra.iter().copied())
        .collect();
    for &r in radii {
        for &p in points.iter().filter(|_| !bounds.is_torus()) {
            brute.neighbours_at(p, r, &mut want);
            got.clear();
            hash.for_each_run(p, r, |run| {
                for k in run {
                    let q = Vec2::new(hash.sorted_x()[k], hash.sorted_y()[k]);
                    let offset = q - p;
                    if offset.length_squared() <= r * r {
                        got.push(Neighbour {
                            index: hash.order()[k],
                            offset,
                            dist_sq: offset.length_squared(),
                        });
                    }
                }
            });
            got.sort_unstable_by_key(|n| n.index);
            assert_eq!(
                bits(&got),
                bits(&want),
                "hash: neighbours_at({p}, {r}) in {bounds:?}"
            );
        }
        for (name, ix) in &backends {
            for i in 0..xs.len() {
                brute.neighbours_of(i, r, &mut want);
                ix.neighbours_of(i, r, &mut got);
                assert_eq!(
                    bits(&got),
                    bits(&want),
                    "{name}: neighbours_of({i}, {r}) in {bounds:?}"
                );
            }
            for (q, &p) in points.iter().enumerate() {
                brute.neighbours_at(p, r, &mut want);
                ix.neighbours_at(p, r, &mut got);
                assert_eq!(
                    bits(&got),
                    bits(&want),
                    "{name}: neighbours_at({p}, {r}) in {bounds:?}"
                );
                let exclude = (q < xs.len()).then_some(q);
                for k in [0, 1, 3, 8] {
                    let want = k_nearest_reference(&brute, p, k, r, exclude);
                    ix.k_nearest_at(p, k, r, exclude, &mut got);
                    assert_eq!(
                        bits(&got),
                        bits(&want),
                        "{name}: k_nearest_at({p}, {k}, {r}, {exclude:?})"
                    );
                }
            }
        }
    }
}

#[derive(Clone, Copy, Debug)]
enum Layout {
    Uniform,
    OneSpot,
    Collinear,
    /// On multiples of a step: cell edges, the seam at 0 and half the world.
    Lattice,
    /// A mix of the above.
    Mixed,
}

fn world(mode: u8, w: f32, h: f32) -> Bounds {
    match mode {
        0 => Bounds::Open,
        1 => Bounds::bounded(w, h).unwrap(),
        _ => Bounds::torus(w, h).unwrap(),
    }
}

/// Maps unit samples to positions of the given layout inside `bounds`.
fn place(units: &[(f32, f32)], layout: Layout, bounds: Bounds, step: f32) -> (Vec<f32>, Vec<f32>) {
    let size = bounds.size().unwrap_or(Vec2::splat(60.0));
    let origin = if bounds.size().is_some() {
        Vec2::ZERO
    } else {
        Vec2::splat(-30.0)
    };
    let n = units.len().max(1) as f32;
    let pts = units.iter().enumerate().map(|(i, &(u, v))| {
        let layout = match layout {
            Layout::Mixed => [
                Layout::Uniform,
                Layout::OneSpot,
                Layout::Collinear,
                Layout::Lattice,
            ][i % 4],
            l => l,
        };
        let p = match layout {
            Layout::Uniform | Layout::Mixed => origin + Vec2::new(u, v) * size,
            Layout::OneSpot => origin + size * 0.5,
            Layout::Collinear => origin + Vec2::new(size.x * 0.25, size.y * i as f32 / n),
            Layout::Lattice => {
                let k = |t: f32, s: f32| ((t * 8.0).floor() - 1.0) * step.max(s / 8.0);
                match i % 3 {
                    0 => origin + Vec2::new(k(u, size.x), k(v, size.y)),
                    1 => origin + Vec2::new(0.0, k(v, size.y)),
                    _ => origin + Vec2::new(size.x * 0.5, k(v, size.y)),
                }
            }
        };
        bounds.wrap(p)
    });
    pts.map(|p| (p.x, p.y)).unzip()
}

fn layout() -> impl Strategy<Value = Layout> {
    prop_oneof![
        Just(Layout::Uniform),
        Just(Layout::OneSpot),
        Just(Layout::Collinear),
        Just(Layout::Lattice),
        Just(Layout::Mixed)
    ]
}

fn side() -> impl Strategy<Value = f32> {
    prop_oneof![
        Just(1.0_f32),
        Just(3.0),
        Just(10.0),
        Just(37.5),
        Just(100.0),
        0.5_f32..150.0
    ]
}

fn radius() -> impl Strategy<Value = f32> {
    prop_oneof![
        Just(0.0_f32),
        Just(0.5),
        Just(1.0),
        Just(2.5),
        Just(5.0),
        Just(50.0),
        Just(1e4),
        0.0_f32..20.0
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(192))]

    #[test]
    fn backends_match_brute_force(
        mode in 0u8..3,
        w in side(),
        h in side(),
        layout in layout(),
        units in prop::collection::vec((0.0_f32..1.0, 0.0_f32..1.0), 0..90),
        max_radius in radius(),
        radii in prop::collection::vec(radius(), 1..4),
        extra in prop::collection::vec((-0.1_f32..1.1, -0.1_f32..1.1), 0..4),
    ) {
        let bounds = world(mode, w, h);
        let (xs, ys) = place(&units, layout, bounds, max_radius);
        let size = bounds.size().unwrap_or(Vec2::splat(60.0));
        // Query points from anywhere on an open plane; inside the world otherwise.
        let extra: Vec<Vec2> = extra.iter().map(|&(u, v)| bounds.wrap(Vec2::new(u, v) * size)).collect();
        check_all(&xs, &ys, bounds, max_radius, &radii, &extra);
    }
}

#[test]
fn all_points_at_one_spot() {
    for bounds in [
        Bounds::Open,
        Bounds::bounded(10.0, 10.0).unwrap(),
        Bounds::torus(10.0, 10.0).unwrap(),
    ] {
        let xs = vec![4.0; 70];
        let ys = vec![4.0; 70];
        check_all(
            &xs,
            &ys,
            bounds,
            1.0,
            &[0.0, 0.5, 100.0],
            &[Vec2::new(4.0, 4.0), Vec2::new(4.5, 4.0)],
        );
    }
}

#[test]
fn collinear_points_on_cell_edges_and_the_seam() {
    let bounds = Bounds::torus(12.0, 12.0).unwrap();
    // 48 points on the seam x = 0 and on cell edges y = k * 0.25 (cells of side 1.5 and 1.0).
    let xs: Vec<f32> = (0..48)
        .map(|k| if k % 2 == 0 { 0.0 } else { 6.0 })
        .collect();
    let ys: Vec<f32> = (0..48).map(|k| k as f32 * 0.25).collect();
    for max_radius in [1.0, 1.5, 3.0, 4.0, 6.0, 12.0] {
        check_all(
            &xs,
            &ys,
            bounds,
            max_radius,
            &[0.0, 0.25, 1.0, 1.5, 3.0, 6.0, 30.0],
            &[Vec2::new(11.999, 0.0)],
        );
    }
}

#[test]
fn radius_larger_than_a_torus_reports_each_point_once() {
    // Fewer than three cells per axis: the wrap must not produce duplicates.
    let bounds = Bounds::torus(2.0, 3.0).unwrap();
    let xs = [0.0, 0.5, 1.0, 1.5, 1.999];
    let ys = [0.0, 2.9, 1.5, 0.1, 1.0];
    check_all(&xs, &ys, bounds, 1.0, &[0.9, 1.0, 1.5, 10.0], &[]);
    let mut grid = GridIndex::default();
    grid.rebuild(&xs, &ys, bounds, 1.0);
    let mut out = Vec::new();
    grid.neighbours_of(0, 100.0, &mut out);
    assert_eq!(
        out.iter().map(|n| n.index).collect::<Vec<_>>(),
        [1, 2, 3, 4]
    );
    assert!(
        out.iter()
            .all(|n| n.offset.x.abs() <= 1.0 && n.offset.y.abs() <= 1.5)
    );
}

#[test]
fn empty_index_finds_nothing() {
    for kind in IndexKind::ALL {
        let mut ix = SpatialIndex::new(kind);
        let mut out = vec![Neighbour {
            index: 9,
            offset: Vec2::ZERO,
            dist_sq: 0.0,
        }];
        ix.neighbours_at(Vec2::ZERO, 5.0, &mut out);
        assert!(out.is_empty() && ix.is_empty());
        ix.rebuild(&[], &[], Bounds::torus(5.0, 5.0).unwrap(), 1.0);
        ix.k_nearest_at(Vec2::ONE, 3, 5.0, None, &mut out);
        assert!(out.is_empty() && ix.is_empty());
    }
}

#[test]
fn many_points_rebuilt_in_parallel_match_brute_force() {
    // Enough points for the grid's parallel rebuild; a sample of queries.
    let n = 40_000;
    let bounds = Bounds::torus(200.0, 150.0).unwrap();
    let mut s = 0x9e37_79b9_u32;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 17;
        s ^= s << 5;
        (s >> 8) as f32 / (1 << 24) as f32
    };
    let (xs, ys): (Vec<f32>, Vec<f32>) = (0..n).map(|_| (next() * 200.0, next() * 150.0)).unzip();
    let mut brute = BruteIndex::default();
    brute.rebuild(&xs, &ys, bounds, 2.0);
    let mut grid = GridIndex::default();
    grid.rebuild(&xs, &ys, bounds, 2.0);
    let mut tree = KdTreeIndex::default();
    tree.rebuild(&xs, &ys, bounds, 2.0);
    let (mut want, mut got) = (Vec::new(), Vec::new());
    for i in (0..n).step_by(97) {
        for r in [1.0, 2.0, 5.0] {
            brute.neighbours_of(i, r, &mut want);
            grid.neighbours_of(i, r, &mut got);
            assert_eq!(bits(&got), bits(&want));
            tree.neighbours_of(i, r, &mut got);
            assert_eq!(bits(&got), bits(&want));
        }
    }
}
