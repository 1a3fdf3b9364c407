//! Malformed maps and bad numbers get clear errors of the right kind, with 1-based positions.

use glam::Vec2;
use throng::Error;
use throng::field::{Cell, OccupancyGrid, random_free_cells};

fn parse_error(text: &str) -> (usize, usize, String) {
    match OccupancyGrid::parse_ascii(text, "maps/test.txt") {
        Err(Error::MapParse {
            source_name,
            line,
            column,
            message,
        }) => {
            assert_eq!(source_name, "maps/test.txt");
            (line, column, message)
        }
        other => panic!("expected MapParse for {text:?}, got {other:?}"),
    }
}

#[test]
fn unknown_characters_name_line_and_column() {
    assert_eq!(parse_error("x").0, 1);
    assert_eq!(parse_error("x").1, 1);
    let (line, column, message) = parse_error("....\n..#.\n.#?.\n");
    assert_eq!((line, column), (3, 3));
    assert!(message.contains('?'), "{message}");
    // Columns count characters, not bytes.
    let (line, column, _) = parse_error("..\n.é\n");
    assert_eq!((line, column), (2, 2));
    let (line, column, _) = parse_error("..\r\n.g\r\n");
    assert_eq!((line, column), (2, 2));
}

#[test]
fn ragged_rows_are_rejected_where_they_go_wrong() {
    let (line, column, message) = parse_error("....\n...\n....\n");
    assert_eq!((line, column), (2, 4));
    assert!(message.contains('3') && message.contains('4'), "{message}");
    let (line, column, _) = parse_error("...\n....\n");
    assert_eq!((line, column), (2, 4));
    // An empty line inside the map is a ragged row.
    assert_eq!(parse_error("..\n\n..\n").0, 2);
}

#[test]
fn empty_maps_are_rejected() {
    for text in ["", "\n", "\n\n\r\n"] {
        let (line, column, message) = parse_error(text);
        assert_eq!((line, column), (1, 1));
        assert!(message.contains("empty"), "{message}");
    }
}

#[test]
fn maps_without_goals_fail_only_when_goals_are_required() {
    let map = OccupancyGrid::parse_ascii("S..\n.#.\n", "level.txt").unwrap();
    assert_eq!(map.spawns, vec![(0, 0)]);
    let err = map.require_goals().unwrap_err();
    assert!(matches!(err, Error::Invalid { .. }));
    let text = err.to_string();
    assert!(
        text.contains("level.txt") && text.contains("goal"),
        "{text}"
    );
    assert!(
        OccupancyGrid::parse_ascii("G..\n", "<map>")
            .unwrap()
            .require_spawns()
            .is_err()
    );
}

#[test]
fn missing_files_are_io_errors() {
    assert!(matches!(
        OccupancyGrid::load_ascii("/nonexistent/map.txt"),
        Err(Error::Io { .. })
    ));
}

#[test]
fn bad_numbers_get_the_right_variant() {
    let g = OccupancyGrid::new(4, 4).unwrap();
    assert!(matches!(
        g.clone().with_geometry(0.0, Vec2::ZERO),
        Err(Error::NotPositive { .. })
    ));
    assert!(matches!(
        g.clone().with_geometry(-1.0, Vec2::ZERO),
        Err(Error::NotPositive { .. })
    ));
    assert!(matches!(
        g.clone().with_geometry(f32::NAN, Vec2::ZERO),
        Err(Error::NonFinite { .. })
    ));
    assert!(matches!(
        g.clone().with_geometry(1.0, Vec2::new(f32::INFINITY, 0.0)),
        Err(Error::NonFinite { .. })
    ));
    assert!(matches!(
        OccupancyGrid::new(0, 3),
        Err(Error::Invalid { .. })
    ));
    assert!(matches!(
        OccupancyGrid::new(u32::MAX, u32::MAX),
        Err(Error::Invalid { .. })
    ));
    assert!(matches!(
        OccupancyGrid::from_cells(2, 2, vec![Cell::Free; 3]),
        Err(Error::Invalid { .. })
    ));
    for f in [1.0, 1.5, -0.1] {
        assert!(
            matches!(
                OccupancyGrid::caves(8, 8, f, 1),
                Err(Error::OutOfRange { .. })
            ),
            "{f}"
        );
        assert!(
            matches!(
                OccupancyGrid::scattered(8, 8, f, 1),
                Err(Error::OutOfRange { .. })
            ),
            "{f}"
        );
    }
    assert!(matches!(
        OccupancyGrid::caves(8, 8, f32::NAN, 1),
        Err(Error::NonFinite { .. })
    ));
    let mut small = OccupancyGrid::new(2, 1).unwrap();
    small.set(0, 0, Cell::Wall).unwrap();
    assert!(matches!(
        small.set(2, 0, Cell::Wall),
        Err(Error::Invalid { .. })
    ));
    assert!(matches!(
        random_free_cells(&small, 2, 0),
        Err(Error::Invalid { .. })
    ));
}

#[test]
fn geometry_maps_world_points_to_cells() {
    let g = OccupancyGrid::new(4, 3)
        .unwrap()
        .with_geometry(2.0, Vec2::new(-4.0, 10.0))
        .unwrap();
    assert_eq!(g.world_to_cell(Vec2::new(-4.0, 10.0)), Some((0, 0)));
    assert_eq!(g.world_to_cell(Vec2::new(3.99, 15.99)), Some((3, 2)));
    // The far edge belongs to the last column (an agent clamped onto it stays on the grid).
    assert_eq!(g.world_to_cell(Vec2::new(4.0, 12.0)), Some((3, 1)));
    assert_eq!(g.world_to_cell(Vec2::new(4.01, 12.0)), None);
    assert_eq!(g.world_to_cell(Vec2::new(-4.01, 12.0)), None);
    assert_eq!(g.world_to_cell(Vec2::new(f32::NAN, 12.0)), None);
    assert_eq!(g.cell_center(1, 2), Vec2::new(-1.0, 15.0));
    assert_eq!(g.world_to_cell(g.cell_center(3, 1)), Some((3, 1)));
}

#[test]
fn generators_are_seeded() {
    let a = OccupancyGrid::caves(64, 48, 0.85, 42).unwrap();
    assert_eq!(a, OccupancyGrid::caves(64, 48, 0.85, 42).unwrap());
    assert_ne!(a, OccupancyGrid::caves(64, 48, 0.85, 43).unwrap());
    assert_eq!(a.free_count(), (64.0f32 * 48.0 * 0.15).round() as usize);
    let s = OccupancyGrid::scattered(100, 100, 0.2, 1).unwrap();
    let walls = s.len() - s.free_count();
    assert!((1600..2400).contains(&walls), "{walls}");
    assert_eq!(
        random_free_cells(&a, 5, 3).unwrap(),
        random_free_cells(&a, 5, 3).unwrap()
    );
    let cells = random_free_cells(&a, a.free_count(), 3).unwrap();
    let mut sorted = cells.clone();
    sorted.sort_unstable();
    sorted.dedup();
    assert_eq!(sorted.len(), a.free_count());
}
