use glam::Vec2;
use proptest::prelude::*;

use super::*;
use crate::field::Cell;

const ROOM: &str = "POLYGON ((0 0, 10 0, 10 10, 0 10, 0 0), (4 4, 6 4, 6 6, 4 6, 4 4))";
/// The same room with the exterior clockwise and the hole counter-clockwise.
const ROOM_CW: &str = "POLYGON ((0 0, 0 10, 10 10, 10 0, 0 0), (4 4, 4 6, 6 6, 6 4, 4 4))";

fn reason(text: &str) -> String {
    match Walkable::from_wkt(text) {
        Err(Error::Invalid { reason, .. }) => reason,
        other => panic!("{text}: expected an error, got {other:?}"),
    }
}

#[test]
fn parses_a_polygon_with_a_hole() {
    let a = Walkable::from_wkt(ROOM).unwrap();
    assert_eq!(a.polygons().len(), 1);
    assert_eq!(a.polygons()[0].exterior().len(), 4);
    assert_eq!(a.polygons()[0].holes().len(), 1);
    assert_eq!((a.min(), a.max()), (Vec2::ZERO, Vec2::splat(10.0)));
    assert!((a.area() - 96.0).abs() < 1e-9);
    assert!(a.contains(Vec2::new(1.0, 1.0)));
    assert!(a.contains(Vec2::new(7.0, 5.0)));
    assert!(!a.contains(Vec2::new(5.0, 5.0)), "inside the hole");
    assert!(!a.contains(Vec2::new(-1.0, 5.0)));
    assert!(!a.contains(Vec2::new(11.0, 5.0)));
    assert!((a.distance_to_boundary(Vec2::new(3.0, 5.0)) - 1.0).abs() < 1e-6);
}

#[test]
fn clockwise_input_gives_the_same_rings_and_walls() {
    let ccw = Walkable::from_wkt(ROOM).unwrap();
    let cw = Walkable::from_wkt(ROOM_CW).unwrap();
    assert_eq!(ccw, cw);
    assert_eq!(ccw.walls(), cw.walls());
    // Exterior counter-clockwise, hole clockwise.
    assert!(twice_area(ccw.polygons()[0].exterior()) > 0.0);
    assert!(twice_area(&ccw.polygons()[0].holes()[0]) < 0.0);
}

#[test]
fn walls_form_one_closed_chain_per_ring() {
    let a = Walkable::from_wkt(ROOM).unwrap();
    let walls = a.walls();
    assert_eq!(walls.len(), 8);
    for ring in walls.chunks(4) {
        for k in 0..4 {
            assert_eq!(ring[k].b, ring[(k + 1) % 4].a, "the chain is closed");
        }
    }
    let chains = crate::orca::WallChains::new(&walls);
    assert!(!chains.is_empty());
}

#[test]
fn writes_wkt_that_reads_back_the_same() {
    for text in [
        ROOM,
        ROOM_CW,
        "MULTIPOLYGON (((0 0, 1 0, 1 1, 0 0)), ((2 0, 3 0, 3 1.5, 2 0)))",
        "POLYGON ((0.1 0.2, 3.3 0.2, 3.3 7.77, 0.1 0.2))",
        "polygon z ((0 0 1, 4 0 1, 4 3 1, 0 0 1))",
    ] {
        let a = Walkable::from_wkt(text).unwrap();
        let back = Walkable::from_wkt(&a.to_wkt()).unwrap();
        assert_eq!(a, back, "{text} -> {}", a.to_wkt());
    }
    let m = Walkable::from_wkt("MULTIPOLYGON (((0 0, 1 0, 1 1, 0 0)), ((2 0, 3 0, 3 1, 2 0)))")
        .unwrap();
    assert!(m.to_wkt().starts_with("MULTIPOLYGON ((("), "{}", m.to_wkt());
}

#[test]
fn an_island_in_a_hole_is_walkable() {
    let a = Walkable::from_wkt(
        "MULTIPOLYGON (((0 0, 10 0, 10 10, 0 10, 0 0), (2 2, 8 2, 8 8, 2 8, 2 2)), ((4 4, 6 4, 6 6, 4 6, 4 4)))",
    )
    .unwrap();
    assert!(a.contains(Vec2::new(1.0, 1.0)));
    assert!(!a.contains(Vec2::new(3.0, 3.0)));
    assert!(a.contains(Vec2::new(5.0, 5.0)));
}

#[test]
fn bad_inputs_are_named_errors() {
    let cases = [
        ("LINESTRING (0 0, 1 1)", "expected a WKT POLYGON"),
        (
            "GEOMETRYCOLLECTION (POLYGON ((0 0, 1 0, 1 1, 0 0)))",
            "expected a WKT POLYGON",
        ),
        ("", "expected a WKT POLYGON"),
        ("POLYGON EMPTY", "empty"),
        ("POLYGON ((0 0, 1 0, 1 1))", "not closed"),
        ("POLYGON ((0 0, 1 0, 0 0))", "at least 3 distinct points"),
        ("POLYGON ((0 0, 1 0, 2 0, 0 0))", "no area"),
        (
            "POLYGON ((0 0, 4 4, 4 0, 0 2, 0 0))",
            "crosses or touches itself",
        ),
        ("POLYGON ((0 0, 2 2, 2 0, 0 2, 0 0))", "no area"),
        (
            "POLYGON ((0 0, 10 0, 10 10, 0 10, 0 0), (20 20, 21 20, 21 21, 20 20))",
            "outside its exterior",
        ),
        (
            "POLYGON ((0 0, 10 0, 10 10, 0 10, 0 0), (0 0, 2 1, 1 2, 0 0))",
            "touches",
        ),
        (
            "POLYGON ((0 0, 10 0, 10 10, 0 10, 0 0), (1 1, 9 1, 9 9, 1 9, 1 1), (2 2, 3 2, 3 3, 2 2))",
            "inside polygon 0, hole 0",
        ),
        (
            "MULTIPOLYGON (((0 0, 10 0, 10 10, 0 10, 0 0)), ((2 2, 3 2, 3 3, 2 2)))",
            "inside the walkable part",
        ),
        ("POLYGON ((0 0, 1e39 0, 1 1, 0 0))", "finite"),
        ("POLYGON ((0 0, 1e30 0, 1 1, 0 0))", "beyond 1e18"),
        ("POLYGON ((0 0, 1 0, 1 1, 0 0)) trailing", "text after"),
        ("POLYGON ((0 0, 1 0, 1 1, 0 0)", "unbalanced"),
        ("POLYGON (((0 0, 1 0, 1 1, 0 0)))", "nested"),
        ("POLYGON ((0 0, 1 0, x 1, 0 0))", "does not parse"),
        (
            "POLYGON ((0 0, 4 0, 4 4, 2 4, 2 0, 0 0))",
            "crosses or touches itself",
        ),
    ];
    for (text, want) in cases {
        let r = reason(text);
        assert!(r.contains(want), "{text}: {r}");
    }
}

#[test]
fn vertex_ceiling_is_enforced() {
    let n = MAX_VERTICES + 1;
    let ring: Vec<Vec2> = (0..n)
        .map(|k| Vec2::from_angle(k as f32 * std::f32::consts::TAU / n as f32) * 100.0)
        .collect();
    let e = Walkable::from_rings(ring, Vec::new()).unwrap_err();
    assert!(e.to_string().contains("vertices"), "{e}");
}

#[test]
fn raster_blocks_outside_holes_and_crossed_cells() {
    let a = Walkable::from_wkt(ROOM).unwrap();
    let g = a.rasterize(1.0, Vec2::ZERO).unwrap();
    assert_eq!((g.width(), g.height()), (10, 10));
    assert_eq!(g.origin(), Vec2::ZERO);
    // Walls along grid lines block nothing: 100 cells less the 4 of the hole.
    assert_eq!(g.free_count(), 96);
    assert!(!g.is_free(4, 4) && !g.is_free(5, 5));
    assert!(g.is_free(3, 4) && g.is_free(6, 5));
    // A diagonal wall blocks the cells it passes through, even with their centre inside.
    let tri = Walkable::from_wkt("POLYGON ((0 0, 4 0, 0 4, 0 0))").unwrap();
    let g = tri.rasterize(1.0, Vec2::ZERO).unwrap();
    for y in 0..4 {
        for x in 0..4 {
            let free = x + y < 3;
            assert_eq!(g.is_free(x, y), free, "({x}, {y})");
        }
    }
    // Off-lattice anchor: the grid's lines pass through it.
    let g = a.rasterize(0.5, Vec2::new(0.25, 0.25)).unwrap();
    assert_eq!(g.origin(), Vec2::new(-0.25, -0.25));
    assert_eq!((g.width(), g.height()), (21, 21));
    assert!(!g.is_free(0, 5), "crossed by the wall x = 0");
}

#[test]
fn raster_keeps_walls_on_decimal_grid_lines_off_the_free_side() {
    // 1.2 / 0.1 is not 12 in floating point; the corridor keeps all 12 columns.
    let a = Walkable::from_wkt("POLYGON ((0 0, 1.2 0, 1.2 3, 0 3, 0 0))").unwrap();
    let g = a.rasterize(0.1, Vec2::ZERO).unwrap();
    assert_eq!(g.width(), 12);
    assert_eq!(g.free_count(), g.len());
}

#[test]
fn raster_ceilings_are_errors() {
    let a = Walkable::from_wkt(ROOM).unwrap();
    assert!(a.rasterize(1e-4, Vec2::ZERO).is_err());
    assert!(a.rasterize(0.0, Vec2::ZERO).is_err());
    assert!(a.rasterize(f32::NAN, Vec2::ZERO).is_err());
    // Few cells, but 4,000 walls each spanning 10,000 columns.
    let c = Walkable::from_rings(comb(2000, 100.0, 0.002), Vec::new()).unwrap();
    let e = c.rasterize(0.01, Vec2::ZERO).unwrap_err().to_string();
    assert!(e.contains("span"), "{e}");
    assert!(c.rasterize(1.0, Vec2::ZERO).is_ok());
}

#[test]
fn raster_agrees_with_contains_at_free_cell_centres() {
    let a = Walkable::from_wkt(
        "POLYGON ((0 0, 7.3 0.4, 9 6.1, 3.2 9.7, -1.5 4.4, 0 0), (3 3, 4.5 2.5, 5 5, 3 3))",
    )
    .unwrap();
    let g = a.rasterize(0.25, Vec2::ZERO).unwrap();
    let mut free = 0;
    for y in 0..g.height() {
        for x in 0..g.width() {
            let c = g.cell_center(x, y);
            if g.is_free(x, y) {
                free += 1;
                assert!(a.contains(c), "free cell ({x}, {y}) at {c} is outside");
            } else if g.cell(x, y) == Some(Cell::Wall) && a.contains(c) {
                // A blocked cell with its centre inside must be crossed by a wall.
                assert!(a.distance_to_boundary(c) <= 0.25 * std::f32::consts::FRAC_1_SQRT_2 + 1e-4);
            }
        }
    }
    let cell_area = 0.0625;
    assert!((free as f64 * cell_area) < a.area() && (free as f64 * cell_area) > a.area() * 0.8);
}

proptest! {
    #[test]
    fn arbitrary_text_never_panics(text in ".{0,200}") {
        let _ = Walkable::from_wkt(&text);
    }

    #[test]
    fn polygon_like_text_never_panics(
        body in proptest::collection::vec(prop_oneof![
            Just("(".to_string()), Just(")".to_string()), Just(",".to_string()),
            Just(" ".to_string()), Just("EMPTY".to_string()), Just("Z".to_string()),
            (-5i32..5).prop_map(|v| v.to_string()),
            any::<f64>().prop_map(|v| v.to_string()),
        ], 0..60),
        multi in any::<bool>(),
    ) {
        let text = format!("{}{}", if multi { "MULTIPOLYGON" } else { "POLYGON" }, body.concat());
        if let Ok(a) = Walkable::from_wkt(&text) {
            prop_assert_eq!(Walkable::from_wkt(&a.to_wkt()).unwrap(), a);
        }
    }

    #[test]
    fn random_rings_are_valid_or_rejected_never_panic(
        pts in proptest::collection::vec((-10.0f32..10.0, -10.0f32..10.0), 3..12),
    ) {
        let ring: Vec<Vec2> = pts.iter().map(|&(x, y)| Vec2::new(x, y)).collect();
        if let Ok(a) = Walkable::from_rings(ring, Vec::new()) {
            prop_assert!(a.area() > 0.0);
            let g = a.rasterize(0.5, Vec2::ZERO).unwrap();
            for y in 0..g.height() {
                for x in 0..g.width() {
                    if g.is_free(x, y) {
                        prop_assert!(a.contains(g.cell_center(x, y)));
                    }
                }
            }
        }
    }
}

/// A comb of `teeth` teeth `length` long pointing along +x, `pitch` apart, closed by a spine
/// at x = -1: a simple ring whose edges all overlap in x.
fn comb(teeth: usize, length: f32, pitch: f32) -> Vec<Vec2> {
    let mut ring = Vec::with_capacity(2 * teeth + 3);
    for k in 0..teeth {
        ring.push(Vec2::new(0.0, pitch * k as f32));
        ring.push(Vec2::new(length, pitch * (k as f32 + 0.5)));
    }
    let top = pitch * teeth as f32;
    ring.extend([
        Vec2::new(0.0, top),
        Vec2::new(-1.0, top),
        Vec2::new(-1.0, 0.0),
    ]);
    ring
}

/// A comb at the vertex ceiling whose teeth all span the same x range: the crossing sweep's
/// worst case. Run with `cargo test --release -- --ignored comb`.
#[test]
#[ignore = "timing of the worst case; run by hand"]
fn a_comb_at_the_vertex_ceiling_is_checked_within_a_second() {
    let ring = comb((MAX_VERTICES - 3) / 2, 100.0, 1.0);
    let t = std::time::Instant::now();
    let a = Walkable::from_rings(ring, Vec::new()).unwrap();
    let took = t.elapsed();
    eprintln!("{} vertices checked in {took:?}", a.vertex_count());
    assert!(took.as_secs_f64() < 1.0, "{took:?}");
}
