//! Walkable areas from WKT in scenario files: agents never leave the area (checked every step),
//! a flow field rasterised from an L-shaped corridor leads an agent to its end, polygon exits,
//! the derived world bounds, errors that name the key and the spawn, and checkpoints that keep
//! the area (and load without it when written before areas existed).

use throng::Walkable;
use throng::prelude::*;
use throng::scenario::Scenario;
use throng::world::Exit;

const ROOM: &str = "POLYGON ((0 0, 10 0, 10 10, 0 10, 0 0), (4 3, 6 3, 6 7, 4 7, 4 3))";

fn room_with_hole(extra: &str) -> String {
    format!(
        r#"
seed = 7
dt = 0.05
steps = 400
[geometry]
walkable = "{ROOM}"

[[groups]]
name = "seekers"
count = 40
spawn = {{ kind = "rect", min = [0.5, 0.5], max = [3, 9.5] }}
model = "dynamic"
max_speed = 1.34
max_acceleration = 3
radius = 0.2
steering = {{ behaviours = [{{ kind = "seek", target = {{ point = [9.5, 5] }} }}] }}

[[groups]]
name = "orca"
count = 20
spawn = {{ kind = "rect", min = [7, 0.5], max = [9.5, 9.5] }}
model = "kinematic"
max_speed = 1.34
radius = 0.2
steering = {{ behaviours = [{{ kind = "seek", target = {{ point = [0.5, 5] }} }}] }}
orca = {{ neighbour_dist = 3, time_horizon = 2, time_horizon_obst = 1, contact = true }}
{extra}
"#
    )
}

#[test]
fn agents_seeking_through_a_room_with_a_hole_never_leave_the_walkable_area() {
    let s = Scenario::from_toml(&room_with_hole(""), "room.toml").unwrap();
    let mut world = s.build().unwrap();
    let area = world.walkable().unwrap().clone();
    assert_eq!(world.obstacles().walls().len(), 8);
    assert_eq!(world.len(), 60);
    let start: Vec<Vec2> = (0..world.len())
        .map(|i| world.agents().position(i))
        .collect();
    for step in 0..400 {
        world.step(s.dt).unwrap();
        for i in 0..world.len() {
            let p = world.agents().position(i);
            assert!(
                area.contains(p),
                "step {step}: agent {} at {p} is outside the walkable area",
                world.agents().id(i)
            );
        }
    }
    // They did move (around the hole): the seekers' mean x grew a lot.
    let moved = (0..world.len())
        .filter(|&i| world.agents().position(i).distance(start[i]) > 2.0)
        .count();
    assert!(moved > 30, "only {moved} agents moved more than 2 m");
}

#[test]
fn the_area_gives_walls_and_a_walled_world_to_its_bounding_box() {
    let s = Scenario::from_toml(&room_with_hole(""), "room.toml").unwrap();
    assert_eq!(s.bounds().unwrap(), Bounds::bounded(10.0, 10.0).unwrap());
    // Away from the origin, the plane (the area's walls hold the agents).
    let shifted = room_with_hole("").replace(ROOM, "POLYGON ((-5 -5, 5 -5, 5 5, -5 5, -5 -5))");
    let shifted = shifted
        .replace(
            "min = [0.5, 0.5], max = [3, 9.5]",
            "min = [-4, -4], max = [-2, 4]",
        )
        .replace(
            "min = [7, 0.5], max = [9.5, 9.5]",
            "min = [2, -4], max = [4, 4]",
        );
    let s = Scenario::from_toml(&shifted, "shifted.toml").unwrap();
    assert_eq!(s.bounds().unwrap(), Bounds::Open);
    assert_eq!(s.build().unwrap().len(), 60);
}

/// An L-shaped corridor 2 m wide: along x from (10, 1) to the corner, then up to y = 10.
const CORRIDOR: &str = "POLYGON ((0 0, 10 0, 10 2, 2 2, 2 10, 0 10, 0 0))";

fn corridor(cell_size: f32) -> String {
    format!(
        r#"
dt = 0.05
steps = 2000
[geometry]
walkable = "{CORRIDOR}"

[field]
cell_size = {cell_size}

[[exits]]
polygon = "POLYGON ((0 9, 2 9, 2 10, 0 10, 0 9))"

[[groups]]
spawn = {{ kind = "points", points = [[9.5, 1]] }}
model = "kinematic"
max_speed = 1.34
radius = 0.2
steering = {{ behaviours = [{{ kind = "follow_field", field = 0, channel = 0 }}] }}
"#
    )
}

#[test]
fn a_field_following_agent_reaches_the_end_of_an_l_shaped_corridor() {
    for cell_size in [1.0, 0.25] {
        let s = Scenario::from_toml(&corridor(cell_size), "corridor.toml").unwrap();
        let mut world = s.build().unwrap();
        let grid = world.field(0).unwrap().grid();
        // The raster: the corridor's cells free, the rest of the bounding box blocked.
        let area = world.walkable().unwrap().clone();
        assert_eq!(
            grid.free_count() as f64 * f64::from(cell_size * cell_size),
            area.area()
        );
        let mut left_at = None;
        for step in 0..2000 {
            let stats = world.step(s.dt).unwrap();
            for i in 0..world.len() {
                assert!(area.contains(world.agents().position(i)), "step {step}");
            }
            if stats.left > 0 {
                left_at = Some(step);
                break;
            }
        }
        // About 8.5 m + 8.5 m at 1.34 m/s, 13 s: 254 steps; allow for the corner.
        let step = left_at.unwrap_or_else(|| panic!("cell size {cell_size}: never arrived"));
        assert!(step < 400, "cell size {cell_size}: took {step} steps");
        assert!(world.is_empty());
    }
}

#[test]
fn polygon_exits_remove_agents_inside_the_polygon_only() {
    let mut world = World::builder()
        .group(Profile::default())
        .agent(AgentInit::at(Vec2::new(0.2, 0.2), 0))
        .agent(AgentInit::at(Vec2::new(0.8, 0.8), 0))
        .build()
        .unwrap();
    let triangle = Walkable::from_wkt("POLYGON ((0 0, 1 0, 0 1, 0 0))").unwrap();
    world.add_exit(Exit::polygon(triangle)).unwrap();
    let stats = world.step(0.01).unwrap();
    assert_eq!(stats.left, 1);
    assert_eq!(world.len(), 1);
    assert!(world.agents().position(0).x > 0.5);
}

fn error_of(text: &str) -> String {
    Scenario::from_toml(text, "bad.toml")
        .and_then(|s| s.build().map(|_| ()))
        .unwrap_err()
        .to_string()
}

#[test]
fn bad_wkt_names_the_key_and_its_line_and_column() {
    let text = room_with_hole("").replace(
        ROOM,
        "POLYGON ((0 0, 10 0, 10 10, 0 0), (20 20, 21 20, 21 21, 20 20))",
    );
    let msg = error_of(&text);
    assert!(msg.starts_with("bad.toml:6:12"), "{msg}");
    assert!(msg.contains("geometry.walkable"), "{msg}");
    assert!(
        msg.contains("hole 0 lies outside its exterior ring"),
        "{msg}"
    );

    let text = corridor(1.0).replace("POLYGON ((0 9,", "POLYGON ((0 9.5,");
    let msg = error_of(&text);
    assert!(
        msg.contains("exits.polygon") && msg.contains("not closed"),
        "{msg}"
    );
    assert!(msg.starts_with("bad.toml:"), "{msg}");
    let text = corridor(1.0).replace("[[exits]]\n", "[[exits]]\nmin = [0, 0]\n");
    assert!(error_of(&text).contains("not both"));
}

#[test]
fn spawns_outside_the_area_in_a_hole_or_on_a_wall_are_errors_naming_the_spawn() {
    for (point, want) in [
        ("[11, 1]", "outside the world"),
        ("[5, 5]", "outside the walkable area"),
        ("[5, 8]", "outside the walkable area"),
        ("[9.9, 1]", "within the agent radius 0.2 of a wall"),
    ] {
        let text = corridor(1.0).replace("[[9.5, 1]]", &format!("[{point}]"));
        let msg = error_of(&text);
        assert!(msg.contains("groups[0].spawn"), "{point}: {msg}");
        assert!(msg.contains(want), "{point}: {msg}");
    }
    // Random spawns are drawn again until they fit; a region with no room is an error.
    let text = room_with_hole("").replace(
        "min = [0.5, 0.5], max = [3, 9.5]",
        "min = [4.2, 3.2], max = [5.8, 6.8]",
    );
    let msg = error_of(&text);
    assert!(
        msg.contains("groups[0].spawn") && msg.contains("no free spot"),
        "{msg}"
    );
    let s = Scenario::from_toml(
        &room_with_hole("").replace(
            "min = [0.5, 0.5], max = [3, 9.5]",
            "min = [0, 0], max = [10, 10]",
        ),
        "room.toml",
    )
    .unwrap();
    let w = s.build().unwrap();
    let area = w.walkable().unwrap();
    for i in 0..w.len() {
        let p = w.agents().position(i);
        assert!(
            area.contains(p) && area.distance_to_boundary(p) >= 0.2,
            "{p}"
        );
    }
}

#[test]
fn a_field_without_a_map_needs_a_geometry_and_an_exit_inside_it() {
    let text = corridor(1.0).replace(&format!("[geometry]\nwalkable = \"{CORRIDOR}\"\n"), "");
    let msg = error_of(&text);
    assert!(
        msg.contains("field.map") && msg.contains("[geometry] walkable"),
        "{msg}"
    );
    let text = corridor(1.0).replace(
        "POLYGON ((0 9, 2 9, 2 10, 0 10, 0 9))",
        "POLYGON ((20 20, 21 20, 21 21, 20 20))",
    );
    let msg = error_of(&text);
    assert!(
        msg.contains("field.channels") && msg.contains("inside an exit"),
        "{msg}"
    );
    let text = format!(
        "{}\n[world]\nkind = \"torus\"\nsize = [20, 20]\n",
        corridor(1.0)
    );
    let msg = error_of(&text);
    assert!(msg.contains("torus"), "{msg}");
    let text = format!(
        "{}\n[world]\nkind = \"bounded\"\nsize = [5, 20]\n",
        corridor(1.0)
    );
    let msg = error_of(&text);
    assert!(msg.contains("does not fit"), "{msg}");
}

#[test]
fn checkpoints_keep_the_area_and_polygon_exits() {
    let s = Scenario::from_toml(&corridor(0.5), "corridor.toml").unwrap();
    let mut world = s.build().unwrap();
    world.step(s.dt).unwrap();
    let mut bytes = Vec::new();
    world.save(&mut bytes).unwrap();
    let back = World::load(&bytes[..]).unwrap();
    assert_eq!(back.walkable(), world.walkable());
    assert_eq!(back.exits(), world.exits());
    assert!(back.exits()[0].polygon.is_some());
}

#[test]
fn set_walkable_adds_closed_wall_chains_once() {
    let mut world = World::builder()
        .group(Profile::default())
        .agent(AgentInit::at(Vec2::new(1.0, 1.0), 0))
        .build()
        .unwrap();
    let outside = Walkable::from_wkt("POLYGON ((5 5, 6 5, 6 6, 5 6, 5 5))").unwrap();
    assert!(world.set_walkable(outside).is_err());
    assert!(world.obstacles().walls().is_empty());
    let area = Walkable::from_wkt(ROOM).unwrap();
    world.set_walkable(area.clone()).unwrap();
    assert_eq!(world.obstacles().walls(), area.walls().as_slice());
    assert!(world.set_walkable(area).is_err(), "only one area");
}
