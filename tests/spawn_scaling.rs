//! Spawns that do not grind (issue 57, item 8), on the hostile inputs kept in `tests/data/`:
//! `spread` with `distance = 0` is linear in the count; a `spread` request that cannot fit fails
//! before any agent is placed, saying how many fit; a `spread` draw in a hole of the walkable
//! area is drawn again; `free_cells` on a sparse walkable raster draws from its free cells.
//! The time bounds are loose (several times what the linear spawns take on a loaded machine,
//! a fraction of what the old ones took); the tests are meant for `--release`.

use std::time::{Duration, Instant};

use throng::scenario::Scenario;

fn load(name: &str) -> Scenario {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name);
    Scenario::load(&path).unwrap()
}

fn within<T>(limit: Duration, what: &str, f: impl FnOnce() -> T) -> T {
    let start = Instant::now();
    let out = f();
    let took = start.elapsed();
    assert!(took < limit, "{what} took {took:?} (limit {limit:?})");
    out
}

#[test]
fn spread_with_distance_0_is_linear() {
    // 300,000 agents: about 36 s when every agent was compared with every earlier one.
    let s = load("spread_distance_0.toml");
    let world = within(Duration::from_secs(8), "300,000 spread agents", || {
        s.build().unwrap()
    });
    assert_eq!(world.len(), 300_000);
    let a = world.agents();
    assert!((0..a.len()).all(|i| {
        let p = a.position(i);
        (0.0..=200.0).contains(&p.x) && (0.0..=200.0).contains(&p.y)
    }));
}

#[test]
fn spread_without_room_fails_before_placing_anyone() {
    let name = "spread_no_room_for_a_million.toml";
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name);
    let text = std::fs::read_to_string(&path).unwrap();
    // The file is refused as it is read: no world is built, no agent placed.
    let e = within(Duration::from_secs(2), "the refusal", || {
        Scenario::from_toml(&text, name).unwrap_err()
    });
    let message = e.to_string();
    assert!(
        message.contains("groups[0]")
            && message.contains("no room for 1000000 agents")
            && message.contains("fits about"),
        "{message}"
    );
    // So is a count raised to the same on the command line.
    let fits = text.replace("count = 1000000", "count = 100000");
    let s = Scenario::from_toml(&fits, name).unwrap();
    assert!(
        s.clone()
            .with_agents(1_000_000)
            .and_then(|s| s.build())
            .is_err()
    );
    // The same rectangle takes what fits.
    assert_eq!(s.build().unwrap().len(), 100_000);
}

#[test]
fn spread_draws_in_a_hole_again() {
    let s = load("spread_over_a_hole.toml");
    let world = s.build().unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(world.len(), 150);
    let a = world.agents();
    for i in 0..a.len() {
        let p = a.position(i);
        let in_hole = (5.0..=15.0).contains(&p.x) && (5.0..=15.0).contains(&p.y);
        assert!(!in_hole, "agent {i} at {p} in the hole");
        for j in 0..i {
            assert!(
                p.distance(a.position(j)) >= 0.8,
                "agents {j} and {i} too close"
            );
        }
    }
    // The same seed, the same places.
    let again = s.build().unwrap();
    assert_eq!(again.agents().pos_x(), a.pos_x());
}

#[test]
fn free_cells_on_a_sparse_walkable_raster_are_found_at_once() {
    // 32 free cells among 4.2 million: about 28 s by uniform draws over the grid.
    let s = load("free_cells_sparse_walkable.toml");
    let world = within(
        Duration::from_secs(4),
        "2,000 agents in 32 free cells",
        || s.build().unwrap_or_else(|e| panic!("{e}")),
    );
    assert_eq!(world.len(), 2000);
    let a = world.agents();
    let (mut low, mut high) = (0, 0);
    for i in 0..a.len() {
        let p = a.position(i);
        if p.x <= 1.0 && p.y <= 1.0 {
            low += 1;
        } else if p.x >= 511.0 && p.y >= 511.0 {
            high += 1;
        } else {
            panic!("agent {i} at {p} outside both squares");
        }
    }
    assert!(
        low > 800 && high > 800,
        "{low} and {high}: the free cells are drawn uniformly"
    );
}
