//! Field walls on a torus: a move across the seam is the short hop it is, so it is checked
//! against the walls it really passes, and a wall just across the seam still stops it.

use throng::field::{GoalChannels, Neighbourhood, OccupancyGrid};
use throng::prelude::*;

/// A 10 x 4 torus with the field's grid covering it; `map` rows top to bottom.
fn world(map: &str, x: f32, vx: f32) -> World {
    let grid = OccupancyGrid::parse_ascii(map, "<map>").unwrap().grid;
    let mut channels = GoalChannels::new(grid, 0.9, Neighbourhood::Eight).unwrap();
    channels.add_channel(&[(2, 1)]).unwrap();
    let coast = Profile {
        max_speed: 5.0,
        ..Profile::dynamic(SteeringProfile::default())
    };
    let mut w = World::builder()
        .bounds(Bounds::torus(10.0, 4.0).unwrap())
        .group(coast)
        .agent(AgentInit {
            velocity: Vec2::new(vx, 0.0),
            ..AgentInit::at(Vec2::new(x, 1.5), 0)
        })
        .build()
        .unwrap();
    w.add_field(channels).unwrap();
    w
}

#[test]
fn crossing_the_seam_is_not_a_move_across_the_world() {
    // A wall column in the middle of the world, far from the seam the agent crosses.
    let map = ".....#....\n.....#....\n.....#....\n.....#....\n";
    let mut w = world(map, 9.8, 3.0);
    for _ in 0..3 {
        w.step(0.1).unwrap();
    }
    let s = w.agent(AgentId(0)).unwrap();
    assert!(
        s.position.x > 0.0 && s.position.x < 1.0,
        "crossed the seam to {}",
        s.position
    );
    assert_eq!(s.velocity, Vec2::new(3.0, 0.0), "nothing stopped it");
}

#[test]
fn a_wall_just_across_the_seam_stops_the_agent() {
    // The first column is a wall: moving right from x = 9.8 runs into it across the seam.
    let map = "#.........\n#.........\n#.........\n#.........\n";
    let mut w = world(map, 9.8, 3.0);
    for _ in 0..3 {
        w.step(0.1).unwrap();
    }
    let s = w.agent(AgentId(0)).unwrap();
    assert!(
        s.position.x > 9.0 && s.position.x < 10.0,
        "stopped before the wall at {}",
        s.position
    );
    assert_eq!(s.velocity.x, 0.0, "the velocity into the wall is removed");
    assert!(!w.in_field_wall(s.position));
}
