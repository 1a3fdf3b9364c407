//! ORCA among walls of any planar arrangement: junctions where three or more wall ends meet, a
//! polygon through one vertex twice, boxes touching at a corner, a wall from a room's corner,
//! and random arrangements of segments whose ends share grid points. Checked against brute
//! force: no step panics and no agent's move from one frame to the next crosses any wall.

use std::collections::HashMap;

use throng::obstacles::Wall;
use throng::orca::Orca;
use throng::prelude::*;

#[path = "support/orca.rs"]
mod support;

/// A small deterministic generator (SplitMix64), so every arrangement can be rebuilt from its seed.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }

    fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
}

const RADIUS: f32 = 0.3;

fn wall(a: (f32, f32), b: (f32, f32)) -> Wall {
    Wall {
        a: Vec2::new(a.0, a.1),
        b: Vec2::new(b.0, b.1),
    }
}

/// The closed polygon through `pts`.
fn polygon(pts: &[(f32, f32)]) -> Vec<Wall> {
    (0..pts.len())
        .map(|i| wall(pts[i], pts[(i + 1) % pts.len()]))
        .collect()
}

/// The arrangements named in the report, each with three or more wall ends at one point.
fn named_arrangements() -> Vec<(&'static str, Vec<Wall>)> {
    let room = [(0.0, 0.0), (16.0, 0.0), (16.0, 16.0), (0.0, 16.0)];
    let mut corner_wall = polygon(&room);
    corner_wall.push(wall((0.0, 0.0), (8.0, 8.0)));
    let mut boxes = polygon(&[(2.0, 2.0), (8.0, 2.0), (8.0, 8.0), (2.0, 8.0)]);
    boxes.extend(polygon(&[
        (8.0, 8.0),
        (14.0, 8.0),
        (14.0, 14.0),
        (8.0, 14.0),
    ]));
    let mut spur = polygon(&[(3.0, 3.0), (13.0, 3.0), (8.0, 12.0)]);
    spur.push(wall((3.0, 3.0), (0.0, 0.0)));
    let twice = polygon(&[
        (8.0, 8.0),
        (14.0, 4.0),
        (14.0, 12.0),
        (8.0, 8.0),
        (2.0, 12.0),
        (2.0, 4.0),
    ]);
    // The same junction, with another chain pushed after it.
    let mut twice_then_box = twice.clone();
    twice_then_box.extend(polygon(&[
        (20.0, 2.0),
        (24.0, 2.0),
        (24.0, 6.0),
        (20.0, 6.0),
    ]));
    vec![
        ("a wall from a corner of the room", corner_wall),
        ("two boxes touching at a corner", boxes),
        ("a triangle with a spur", spur),
        ("a polygon through one vertex twice", twice),
        ("that polygon, then a box", twice_then_box),
    ]
}

/// Random segments between points of a coarse grid, so that ends coincide often; now and then
/// closed polygons through grid points as well.
fn random_arrangement(rng: &mut Rng) -> Vec<Wall> {
    let point = |rng: &mut Rng| (rng.below(6) as f32 * 3.0, rng.below(6) as f32 * 3.0);
    let mut walls: Vec<Wall> = Vec::new();
    let segments = 2 + rng.below(10);
    for _ in 0..segments {
        let (a, b) = (point(rng), point(rng));
        if a != b {
            walls.push(wall(a, b));
        }
    }
    if rng.below(2) == 0 {
        let n = 3 + rng.below(3) as usize;
        let pts: Vec<(f32, f32)> = (0..n).map(|_| point(rng)).collect();
        walls.extend(
            polygon(&pts)
                .into_iter()
                .filter(|w| w.a != w.b)
                .collect::<Vec<_>>(),
        );
    }
    walls
}

/// Whether the segments `p q` and `a b` share a point (touching counts).
fn crosses(p: Vec2, q: Vec2, a: Vec2, b: Vec2) -> bool {
    let orient = |o: Vec2, s: Vec2, t: Vec2| {
        let (s, t) = ((s - o).as_dvec2(), (t - o).as_dvec2());
        s.perp_dot(t)
    };
    let on = |o: Vec2, s: Vec2, t: Vec2| {
        // `t` is collinear with `o s`: is it within the box of the segment?
        t.x >= o.x.min(s.x) && t.x <= o.x.max(s.x) && t.y >= o.y.min(s.y) && t.y <= o.y.max(s.y)
    };
    let (d1, d2) = (orient(a, b, p), orient(a, b, q));
    let (d3, d4) = (orient(p, q, a), orient(p, q, b));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    (d1 == 0.0 && on(a, b, p))
        || (d2 == 0.0 && on(a, b, q))
        || (d3 == 0.0 && on(p, q, a))
        || (d4 == 0.0 && on(p, q, b))
}

fn group() -> Profile {
    let orca = Orca {
        pref_speed: Some(1.5),
        neighbour_dist: 5.0,
        time_horizon: 3.0,
        time_horizon_obst: 2.0,
        ..Orca::default()
    };
    support::arriving_orca_group(RADIUS, 2.0, orca, 0.2)
}

/// A point in the arrangement's box clear of every wall and of `taken`.
fn free_point(rng: &mut Rng, walls: &[Wall], taken: &[Vec2]) -> Option<Vec2> {
    for _ in 0..1000 {
        let p = Vec2::new(rng.unit() * 28.0 - 2.0, rng.unit() * 20.0 - 2.0);
        let clear = walls
            .iter()
            .all(|w| w.closest_point(p).distance(p) > RADIUS + 0.05)
            && taken.iter().all(|q| q.distance(p) > 2.0 * RADIUS + 0.05);
        if clear {
            return Some(p);
        }
    }
    None
}

/// Runs `agents` ORCA agents between random free points among `walls` for `steps` steps and
/// fails when a move crosses a wall.
fn walk_through(name: &str, walls: &[Wall], rng: &mut Rng, agents: usize, steps: usize) {
    let mut builder = World::builder().group(group());
    for &w in walls {
        builder = builder.wall(w);
    }
    let mut starts = Vec::new();
    while starts.len() < agents {
        let Some(p) = free_point(rng, walls, &starts) else {
            break;
        };
        starts.push(p);
    }
    for &p in &starts {
        builder = builder.agent(AgentInit::at(p, 0));
    }
    let mut world = builder.build().unwrap();
    for (i, &start) in starts.iter().enumerate() {
        let target = free_point(rng, walls, &[]).unwrap_or(start);
        world.set_target(AgentId(i as u32), target).unwrap();
    }
    let by_id = |w: &World| -> HashMap<AgentId, Vec2> {
        let a = w.agents();
        (0..a.len()).map(|i| (a.id(i), a.position(i))).collect()
    };
    let mut before = by_id(&world);
    for frame in 0..steps {
        world.step(0.1).unwrap();
        let after = by_id(&world);
        for (id, &q) in &after {
            let p = before[id];
            for (k, w) in walls.iter().enumerate() {
                assert!(
                    !crosses(p, q, w.a, w.b),
                    "{name}: agent {id:?} crossed wall {k} ({} -> {}) from {p} to {q} at step {frame}; walls {walls:?}",
                    w.a,
                    w.b
                );
            }
        }
        before = after;
    }
}

#[test]
fn junctions_of_three_or_more_wall_ends_neither_panic_nor_let_agents_through() {
    let mut rng = Rng(57);
    for (name, walls) in named_arrangements() {
        walk_through(name, &walls, &mut rng, 12, 300);
    }
}

#[test]
fn no_agent_crosses_a_wall_of_a_random_arrangement() {
    for seed in 0..300 {
        let mut rng = Rng(seed);
        let walls = random_arrangement(&mut rng);
        walk_through(&format!("seed {seed}"), &walls, &mut rng, 10, 300);
    }
}

#[test]
fn crossing_test_sees_crossings_and_touches() {
    let (a, b) = (Vec2::new(0.0, -1.0), Vec2::new(0.0, 1.0));
    assert!(crosses(Vec2::new(-1.0, 0.0), Vec2::new(1.0, 0.0), a, b));
    assert!(crosses(Vec2::new(-1.0, 0.0), Vec2::new(0.0, 0.5), a, b));
    assert!(!crosses(Vec2::new(-1.0, 0.0), Vec2::new(-0.1, 0.5), a, b));
    assert!(!crosses(Vec2::new(-1.0, 2.0), Vec2::new(1.0, 2.0), a, b));
}

#[test]
fn the_regression_scenario_builds_and_runs() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/orca_walls_meeting_at_one_point.toml"
    );
    let text = std::fs::read_to_string(path).unwrap();
    let s = throng::scenario::Scenario::from_toml(&text, path).unwrap();
    let mut world = s.build().unwrap();
    assert!(world.obstacles().walls().len() >= 20);
    for _ in 0..s.steps {
        world.step(s.dt).unwrap();
    }
}
