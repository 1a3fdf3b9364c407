//! Resource ceilings are checked before work is done, numbers beyond the stated ceilings are
//! refused, and error text cannot carry control characters. The scenario files of
//! `tests/data/` are the inputs that found these bugs.

use std::path::Path;
use std::time::{Duration, Instant};

use throng::prelude::*;
use throng::scenario::{self, Scenario};

fn data(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// Loads and builds, returning the error text; panics if it succeeds or takes over a second.
fn refused(path: &Path) -> String {
    let t = Instant::now();
    let result = Scenario::load(path).and_then(|s| s.build());
    assert!(
        t.elapsed() < Duration::from_secs(1),
        "{path:?} took {:?}",
        t.elapsed()
    );
    match result {
        Ok(_) => panic!("{path:?} was accepted"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn a_huge_gravity_count_is_refused_before_anything_is_built() {
    let e = refused(&data("gravity_count_u64_max.toml"));
    assert!(e.contains("gravity"), "{e}");
}

#[test]
fn a_huge_random_circle_count_is_refused() {
    let text = r#"
[world]
kind = "bounded"
size = [100, 100]
[obstacles]
random_circles = { count = 100000000, min_radius = 1, max_radius = 2, min = [0, 0], max = [100, 100] }
[[groups]]
count = 1
"#;
    let e = Scenario::from_toml(text, "c.toml").unwrap_err().to_string();
    assert!(e.contains("random_circles.count"), "{e}");
}

/// Scaling by tiles draws every copy's random obstacles and points: the ceilings hold for all
/// the copies together, and are checked before any copy is drawn.
#[test]
fn tiled_copies_are_held_to_the_ceilings_before_they_are_drawn() {
    let t = Instant::now();
    let e = Scenario::load(&data("tiles_random_circles_past_the_ceiling.toml"))
        .and_then(|s| s.with_agents(100))
        .unwrap_err()
        .to_string();
    assert!(t.elapsed() < Duration::from_secs(1), "{:?}", t.elapsed());
    assert!(
        e.contains("obstacles.random_circles.count") && e.contains("100 copies"),
        "{e}"
    );
    let tiles = |extra: &str| {
        format!(
            "[world]\nkind = \"bounded\"\nsize = [100, 100]\nscale = \"tiles\"\n[[groups]]\ncount = 1\n{extra}"
        )
    };
    let gravity = tiles(
        "[gravity]\nrandom = { count = 1000, strength = 1, radius = 5, min = [0, 0], max = [100, 100] }\n",
    );
    let e = Scenario::from_toml(&gravity, "g.toml")
        .and_then(|s| s.with_agents(1000))
        .unwrap_err()
        .to_string();
    assert!(e.contains("gravity points"), "{e}");
    // Within the ceiling the copies are drawn as before.
    let s = Scenario::load(&data("tiles_random_circles_past_the_ceiling.toml")).unwrap();
    let mut s = s;
    s.obstacles.random_circles.as_mut().unwrap().count = 1000;
    let tiled = s.with_agents(100).unwrap();
    assert_eq!(tiled.obstacles.circles.len(), 100_000);
}

#[test]
fn endless_and_oversized_files_are_refused_with_bounded_reads() {
    let t = Instant::now();
    let e = Scenario::load(Path::new("/dev/zero"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("16777216"), "{e}");
    let e = throng::field::OccupancyGrid::load_ascii("/dev/zero")
        .unwrap_err()
        .to_string();
    assert!(e.contains("300000000"), "{e}");
    // A sparse file larger than the ceiling is refused from its size alone.
    let big = std::env::temp_dir().join(format!("throng-big-{}.toml", std::process::id()));
    std::fs::File::create(&big)
        .unwrap()
        .set_len(throng::limits::MAX_SCENARIO_BYTES + 1)
        .unwrap();
    let e = Scenario::load(&big).unwrap_err().to_string();
    std::fs::remove_file(&big).unwrap();
    assert!(e.contains("ceiling of scenario files"), "{e}");
    assert!(
        t.elapsed() < Duration::from_secs(5),
        "took {:?}",
        t.elapsed()
    );
}

#[test]
fn a_scenario_beyond_the_memory_limit_is_refused_up_front() {
    let s = scenario::builtin("flock")
        .unwrap()
        .with_agents(100_000_000)
        .unwrap();
    let estimate = s.memory_estimate();
    assert!(
        (14_000_000_000..=30_000_000_000).contains(&estimate),
        "{estimate}"
    );
    let t = Instant::now();
    let e = s.build_within(Some(1 << 30)).unwrap_err();
    assert!(t.elapsed() < Duration::from_secs(1));
    assert!(matches!(e, throng::Error::OutOfMemory { .. }), "{e}");
    assert!(e.to_string().contains("1.0 GiB"), "{e}");
}

#[test]
fn too_many_walkers_are_refused_before_they_spawn() {
    let e = refused(&data("walkers_50m.toml"));
    assert!(e.contains("more walkers than free cells"), "{e}");
}

#[test]
fn time_steps_below_the_floor_are_refused() {
    let e = refused(&data("dt_1e-45.toml"));
    assert!(e.contains("dt"), "{e}");
    let mut w = scenario::builtin("fields-walkers")
        .unwrap()
        .with_agents(20)
        .unwrap()
        .build()
        .unwrap();
    assert!(matches!(
        w.step(1e-45),
        Err(throng::Error::InvalidTimeStep { .. })
    ));
}

#[test]
fn numbers_beyond_the_ceiling_are_refused_naming_the_key() {
    let e = refused(&data("seek_target_1e20.toml"));
    assert!(e.contains("point[0]") && e.contains("1e18"), "{e}");
    let base = "[world]\nkind = \"bounded\"\nsize = [100, 100]\n[[groups]]\ncount = 2\n";
    for (extra, key) in [
        ("mass = 1e30\n", "mass"),
        ("max_speed = 3\ninitial_speed = 1e37\n", "initial_speed"),
        (
            "steering = { behaviours = [{ kind = \"wander\", weight = 1e38 }] }\n",
            "weight",
        ),
        (
            "[obstacles]\ncircles = [{ center = [1e30, 1], radius = 1 }]\n",
            "center",
        ),
    ] {
        let text = format!("{base}{extra}");
        let e = Scenario::from_toml(&text, "n.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains(key), "{extra}: {e}");
    }
}

/// The ceiling of scenario files holds for the world's own setters and builders too (and so for
/// every caller: Python, `throng serve`, checkpoints): a target at 1e20 froze every agent.
#[test]
fn coordinates_beyond_the_ceiling_are_refused_by_every_setter() {
    let text = "[world]\nkind = \"open\"\n[[groups]]\ncount = 2\nspawn = { kind = \"disc\", center = [0, 0], radius = 5 }\n";
    let mut w = Scenario::from_toml(text, "c.toml")
        .unwrap()
        .build()
        .unwrap();
    let id = w.agents().id(0);
    let far = Vec2::new(1e20, 0.0);
    let ok = Vec2::new(1e17, 0.0);
    let refused = |r: throng::Result<()>, what: &str| {
        let e = r.expect_err(what).to_string();
        assert!(e.contains("1e18"), "{what}: {e}");
    };
    refused(w.set_target(id, far), "set_target");
    assert!(w.set_target(id, ok).is_ok());
    refused(w.set_position(id, far), "set_position");
    refused(
        w.add_wall(throng::obstacles::Wall {
            a: Vec2::ZERO,
            b: far,
        }),
        "add_wall",
    );
    refused(
        w.add_polygon(&[Vec2::ZERO, far, Vec2::ONE], true),
        "add_polygon",
    );
    refused(
        w.add_circle(throng::obstacles::Circle::new(far, 1.0)),
        "add_circle",
    );
    refused(
        w.add_gravity_point(throng::gravity::GravityPoint::fixed(far, 1.0, 2.0, 5.0))
            .map(|_| ()),
        "add_gravity_point",
    );
    let k = w
        .add_gravity_point(throng::gravity::GravityPoint::fixed(
            Vec2::ZERO,
            1.0,
            2.0,
            5.0,
        ))
        .unwrap();
    refused(w.set_gravity_position(k, far), "set_gravity_position");
    refused(
        w.add_target_point(TargetPoint::at(far)).map(|_| ()),
        "add_target_point",
    );
    let mut p = w.groups()[0].clone();
    p.steering = SteeringProfile::single(Behaviour::Seek {
        target: Target::Point(far),
        threshold: 0.0,
    });
    refused(w.set_group_params(0, p.clone()), "set_group_params");
    refused(w.add_group(p).map(|_| ()), "add_group");
    for _ in 0..3 {
        w.step(0.1).unwrap();
    }
    assert!((0..w.len()).all(|i| w.agents().position(i).is_finite()));
}

#[test]
fn derived_world_sides_are_capped() {
    let text = "[world]\nkind = \"torus\"\nagents_per_area = 1e-15\n[[groups]]\ncount = 100\n";
    let e = Scenario::from_toml(text, "d.toml")
        .and_then(|s| s.build())
        .unwrap_err()
        .to_string();
    assert!(e.contains("agents_per_area"), "{e}");
}

#[test]
fn error_text_escapes_control_characters() {
    let e = Scenario::load(&data("escape_codes_in_key.toml"))
        .unwrap_err()
        .to_string();
    assert!(!e.chars().any(char::is_control), "{e:?}");
    assert!(e.contains("\\u{1b}") && e.contains("\\n"), "{e}");
}

#[test]
fn an_agent_on_the_far_edge_of_a_walled_world_stays_on_the_field() {
    let map = throng::field::OccupancyGrid::parse_ascii("....\n...G\n", "<map>").unwrap();
    let grid = map.grid;
    assert_eq!(grid.world_to_cell(Vec2::new(4.0, 1.5)), Some((3, 1)));
    assert_eq!(grid.world_to_cell(Vec2::new(4.0, 2.0)), Some((3, 1)));
    assert_eq!(grid.world_to_cell(Vec2::new(4.01, 1.0)), None);
    // The same through a world: an agent clamped onto x == width follows the field.
    let text = r#"
[world]
kind = "bounded"
size = [4, 2]
[field]
map = { ascii = "G...\n....\n" }
[[groups]]
count = 1
spawn = { kind = "points", points = [[4, 2]] }
steering = { behaviours = [{ kind = "follow_field", field = 0, channel = 0 }] }
"#;
    let mut w = Scenario::from_toml(text, "edge.toml")
        .unwrap()
        .build()
        .unwrap();
    for _ in 0..3 {
        w.step(1.0 / 30.0).unwrap();
    }
    let v = Vec2::new(w.agents().vel_x()[0], w.agents().vel_y()[0]);
    assert!(v.x < 0.0 && v.y <= 0.0, "heads for the goal at (0, 0): {v}");
}

/// Inputs that were read as something else without a word: each is now an error naming the
/// key (and the group or exit it belongs to).
#[test]
fn silent_nonsense_is_an_error_naming_the_key() {
    for (file, wanted, unwanted) in [
        (
            "measurements_window_of_three.toml",
            "measurements.window: expected two times [t0, t1], got 3 numbers",
            "",
        ),
        (
            "cfsm_group_with_social_force_table.toml",
            "groups[0].pedestrian.social_force",
            "",
        ),
        ("field_cell_size_0.toml", "field.cell_size", "EiB"),
        (
            "orca_key_without_group_path.toml",
            "groups[1]: orca.time_horizon",
            "",
        ),
        ("exit_min_beyond_max.toml", "exits[1]", ""),
        ("target_slot_beyond_max_speed.toml", "targets[1]", ""),
        ("walkable_bow_tie.toml", "crosses itself", "collinear"),
        (
            "spawn_rect_without_group_path.toml",
            "groups[1]: invalid spawn.rect",
            "",
        ),
        (
            "target_slot_without_group_path.toml",
            "groups[1]: no target slot 3",
            "",
        ),
        // A walkable area in two parts: a journey across them, agents apart from their journey.
        (
            "journey_across_disconnected_area.toml",
            "journeys[0]: invalid journey 0: stage 1 cannot be reached from stage 0",
            "",
        ),
        (
            "journey_start_in_other_part.toml",
            "groups[0].journey: invalid agent #0",
            "",
        ),
    ] {
        let e = refused(&data(file));
        assert!(e.contains(wanted), "{file}: {e}");
        assert!(unwanted.is_empty() || !e.contains(unwanted), "{file}: {e}");
    }
}
