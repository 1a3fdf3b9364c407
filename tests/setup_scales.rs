//! Setup is linear (or close) in what it builds: random circles build the obstacle broad phase
//! once, large formations assign their slots in local blocks, tunnel and cave maps carve from
//! a frontier. Each bound is far above the time the linear code takes (even on a loaded machine) and below what the
//! quadratic or cubic code took.

use std::time::{Duration, Instant};

use throng::field::OccupancyGrid;
use throng::group::{FormationParams, FormationShape, assign_slots, assignment_cost};
use throng::prelude::*;
use throng::scenario::Scenario;

fn timed<T>(f: impl FnOnce() -> T) -> (T, Duration) {
    let t = Instant::now();
    let out = f();
    (out, t.elapsed())
}

#[test]
fn a_hundred_thousand_random_circles_load_in_seconds() {
    let text = r#"
[world]
kind = "bounded"
size = [20000, 20000]
[obstacles]
random_circles = { count = 100000, min_radius = 1, max_radius = 3, min = [0, 0], max = [20000, 20000] }
[[groups]]
count = 10
"#;
    let s = Scenario::from_toml(text, "circles.toml").unwrap();
    let (world, took) = timed(|| s.build().unwrap());
    assert_eq!(world.obstacles().circles().len(), 100_000);
    assert!(took < Duration::from_secs(10), "took {took:?}");
}

#[test]
fn world_add_circles_refuses_a_circle_over_an_agent_and_changes_nothing() {
    let mut world = World::builder()
        .bounds(Bounds::bounded(100.0, 100.0).unwrap())
        .group(Profile::default())
        .agent(AgentInit::at(Vec2::new(50.0, 50.0), 0))
        .build()
        .unwrap();
    let circles = [
        throng::obstacles::Circle {
            center: Vec2::new(10.0, 10.0),
            radius: 2.0,
        },
        throng::obstacles::Circle {
            center: Vec2::new(51.0, 50.0),
            radius: 2.0,
        },
    ];
    assert!(world.add_circles(&circles).is_err());
    assert!(world.obstacles().circles().is_empty());
    world.add_circles(&circles[..1]).unwrap();
    assert_eq!(world.obstacles().circles().len(), 1);
    assert!(world.obstacles().inside_circle(Vec2::new(10.5, 10.0)));
}

fn squad(n: usize) -> (World, Vec<AgentId>) {
    let keep = SteeringProfile::single(Behaviour::KeepFormation {
        params: throng::group::SlotParams::default(),
    });
    let side = (n as f32).sqrt().ceil() as usize;
    let world = World::builder()
        .bounds(Bounds::bounded(4000.0, 4000.0).unwrap())
        .group(Profile::default())
        .group(Profile::dynamic(keep))
        .agent(AgentInit::at(Vec2::new(2000.0, 2000.0), 0))
        .agents((0..n).map(|k| {
            let (x, y) = ((k % side) as f32, (k / side) as f32);
            AgentInit::at(Vec2::new(1000.0 + 1.7 * x, 1000.0 + 1.3 * y), 1)
        }))
        .build()
        .unwrap();
    let ids = (1..=n as u32).map(AgentId).collect();
    (world, ids)
}

#[test]
fn a_squad_of_twenty_thousand_takes_its_slots_in_seconds() {
    let (mut world, ids) = squad(20_000);
    let params = FormationParams {
        shape: FormationShape::Box,
        ..FormationParams::default()
    };
    let (f, took) = timed(|| world.add_formation(AgentId(0), params, &ids).unwrap());
    assert!(took < Duration::from_secs(5), "took {took:?}");
    // Every member has a slot of its own.
    let form = world.formation(f).unwrap();
    let mut slots: Vec<(u32, u32)> = form
        .slots()
        .iter()
        .map(|s| (s.x.to_bits(), s.y.to_bits()))
        .collect();
    slots.sort_unstable();
    slots.dedup();
    assert_eq!(slots.len(), 20_000);
}

#[test]
fn block_assignment_stays_close_to_the_exact_optimum() {
    // Members scattered over a disc, slots on a box grid: the block method's total distance is
    // within a few percent of the Hungarian method's.
    for n in [300, 1000] {
        let members: Vec<Vec2> = (0..n)
            .map(|k| {
                let a = k as f32 * 2.399_963;
                Vec2::from_angle(a) * (k as f32).sqrt() * 1.5 + Vec2::new(40.0, -20.0)
            })
            .collect();
        let side = (n as f32).sqrt().ceil() as usize;
        let slots: Vec<Vec2> = (0..n)
            .map(|k| Vec2::new((k % side) as f32 * 2.0, (k / side) as f32 * 2.0))
            .collect();
        let exact = assign_slots(&members, &slots).unwrap();
        let local = throng::group::assign_slots_local(&members, &slots).unwrap();
        let mut seen = local.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..n).collect::<Vec<_>>(), "a permutation");
        let cost: Vec<f64> = members
            .iter()
            .flat_map(|m| slots.iter().map(move |s| f64::from(m.distance(*s))))
            .collect();
        let (e, l) = (
            assignment_cost(&cost, n, &exact),
            assignment_cost(&cost, n, &local),
        );
        assert!(l <= e * 1.10, "n {n}: block {l} against exact {e}");
    }
}

#[test]
fn tunnels_and_caves_carve_large_grids_in_seconds() {
    let (g, took) = timed(|| OccupancyGrid::tunnels(8192, 8192, 0.85, 1).unwrap());
    let free = |n: f64| ((1.0 - f64::from(0.85_f32)) * n).round() as usize;
    assert_eq!(g.free_count(), free(8192.0 * 8192.0));
    assert!(took < Duration::from_secs(30), "tunnels took {took:?}");
    let (g, took) = timed(|| OccupancyGrid::caves(4096, 4096, 0.85, 1).unwrap());
    assert_eq!(g.free_count(), free(4096.0 * 4096.0));
    assert!(took < Duration::from_secs(30), "caves took {took:?}");
}
