//! The built-in `city` scene: it builds and runs at small counts and at the count of several
//! tiles, gives the same bits (and the same checkpoint) on 1, 2 and 4 threads, keeps every agent out of the buildings, and
//! its groups do what they are for: the field followers come closer to their goals and the
//! police to the thieves.

use std::time::{Duration, Instant};

use glam::Vec2;
use throng::World;
use throng::scenario::{Scenario, builtin};
use throng::steering::{Behaviour, Weighted};

#[path = "support/checkpoint.rs"]
mod support;
use support::{bits, saved};

const COMMUTERS: u32 = 0;
const SHOPPERS: u32 = 1;
const THIEVES: u32 = 3;
const POLICE: u32 = 4;

fn city(agents: usize) -> Scenario {
    builtin("city").unwrap().with_agents(agents).unwrap()
}

/// Storage indices of the agents of group `g`.
fn members(w: &World, g: u32) -> Vec<usize> {
    (0..w.len())
        .filter(|&i| w.agents().groups()[i] == g)
        .collect()
}

/// Whether `p` lies strictly inside one of the scenario's buildings (its closed polygons, each
/// an axis-aligned rectangle).
fn in_building(s: &Scenario, p: Vec2) -> bool {
    s.obstacles.polygons.iter().any(|poly| {
        let (mut lo, mut hi) = (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN));
        for &q in &poly.points {
            lo = lo.min(q);
            hi = hi.max(q);
        }
        p.x > lo.x && p.x < hi.x && p.y > lo.y && p.y < hi.y
    })
}

fn assert_outside_buildings(s: &Scenario, w: &World, step: usize) {
    for i in 0..w.len() {
        let p = w.agents().position(i);
        assert!(
            !in_building(s, p) && !w.in_field_wall(p),
            "agent {:?} inside a building at {p} after step {step}",
            w.agents().id(i)
        );
    }
}

/// The mean travel cost of group `g`'s agents to the goals of channel `channel`, over the
/// agents from which a goal is reached.
fn mean_cost(w: &World, g: u32, channel: usize) -> f64 {
    let f = w.field(0).unwrap();
    let costs: Vec<f64> = members(w, g)
        .into_iter()
        .filter_map(|i| f.travel_cost(channel, w.agents().position(i)))
        .map(f64::from)
        .collect();
    assert!(!costs.is_empty());
    costs.iter().sum::<f64>() / costs.len() as f64
}

/// The mean distance from each police officer to the nearest thief.
fn mean_chase_distance(w: &World) -> f64 {
    let thieves: Vec<Vec2> = members(w, THIEVES)
        .into_iter()
        .map(|i| w.agents().position(i))
        .collect();
    let police = members(w, POLICE);
    police
        .iter()
        .map(|&i| {
            let p = w.agents().position(i);
            thieves
                .iter()
                .map(|&q| f64::from(p.distance(q)))
                .fold(f64::INFINITY, f64::min)
        })
        .sum::<f64>()
        / police.len() as f64
}

#[test]
fn city_runs_with_every_group_and_keeps_agents_out_of_the_buildings() {
    let s = city(2_000);
    let mut w = s.build().unwrap();
    assert_eq!(w.len(), 2_000);
    for g in 0..5 {
        assert!(!members(&w, g).is_empty(), "group {g} is empty");
    }
    assert_outside_buildings(&s, &w, 0);
    for step in 1..=300 {
        w.step(s.dt).unwrap();
        if step % 10 == 0 {
            assert_outside_buildings(&s, &w, step);
        }
    }
}

#[test]
fn city_is_bit_identical_on_one_two_and_four_threads() {
    let s = city(3_000);
    let run = |threads: usize| {
        let mut w = s.build().unwrap();
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                for _ in 0..60 {
                    w.step(s.dt).unwrap();
                }
            });
        (bits(&w), saved(&w))
    };
    let one = run(1);
    assert!(one == run(2), "1 vs 2 threads differ");
    assert!(one == run(4), "1 vs 4 threads differ");
}

#[test]
fn city_field_followers_come_closer_to_their_goals() {
    let s = city(2_000);
    let mut w = s.build().unwrap();
    w.step(s.dt).unwrap(); // builds the channels
    let before = [mean_cost(&w, COMMUTERS, 0), mean_cost(&w, SHOPPERS, 1)];
    for _ in 0..300 {
        w.step(s.dt).unwrap();
    }
    let after = [mean_cost(&w, COMMUTERS, 0), mean_cost(&w, SHOPPERS, 1)];
    for (k, name) in ["commuters", "shoppers"].iter().enumerate() {
        // 10 s at 2 to 2.5 units/s: a crowd that follows its flow gains well over 5 units.
        assert!(
            after[k] < before[k] - 5.0,
            "{name}: mean travel cost {:.1} before, {:.1} after 10 s",
            before[k],
            after[k]
        );
    }
}

#[test]
fn city_police_come_closer_to_the_thieves() {
    let s = city(2_000);
    let mut w = s.build().unwrap();
    let before = mean_chase_distance(&w);
    let mut later = 0.0;
    for step in 1..=300 {
        w.step(s.dt).unwrap();
        if step > 200 {
            later += mean_chase_distance(&w) / 100.0;
        }
    }
    assert!(
        later < 0.5 * before,
        "police to the nearest thief: {before:.1} at the start, {later:.1} on average over steps 200 to 300"
    );
}

#[test]
fn city_grows_by_tiles_with_its_buildings_and_field() {
    let one = builtin("city").unwrap();
    let base = one.agent_count();
    let t = Instant::now();
    let s = city(base * 10);
    let mut w = s.build().unwrap();
    w.step(s.dt).unwrap();
    let took = t.elapsed();
    assert_eq!(w.len(), base * 10);
    assert_eq!(
        s.obstacles.polygons.len(),
        one.obstacles.polygons.len() * 10
    );
    let grid = w.field(0).unwrap().grid();
    // Ten tiles on a 4 x 3 grid of 100 x 100 cells, the two tiles without a copy walled.
    assert_eq!((grid.width(), grid.height()), (400, 300));
    let free = grid.free_count();
    let one_free = one.build().unwrap().field(0).unwrap().grid().free_count();
    assert_eq!(free, one_free * 10);
    assert_outside_buildings(&s, &w, 1);
    assert!(took < Duration::from_secs(60), "took {took:?}");
}

#[test]
fn city_field_followers_plan_equals_the_general_loop() {
    // Commuters and shoppers (`follow_field`, `separation`, `avoid_walls`) run in the field
    // lanes; an angular-only behaviour appended sends the same profiles through the general
    // loop, which samples the flow with the scalar `FlowField::sample`. Bits must agree.
    let run = |extra: bool| {
        let mut s = city(3_000);
        let look = Weighted::new(Behaviour::look_where_you_are_going(), 1.0);
        for g in [COMMUTERS, SHOPPERS].into_iter().filter(|_| extra) {
            s.groups[g as usize]
                .params
                .steering
                .behaviours
                .push(look.clone());
        }
        let mut w = s.build().unwrap();
        for _ in 0..60 {
            w.step(s.dt).unwrap();
        }
        let ran = if extra { "general" } else { "follow_field" };
        assert_eq!(w.last_plans()[..2], [ran; 2], "the plans that ran");
        // The orientations face the velocities: the angular requests leave them alone.
        bits(&w)
    };
    assert_eq!(run(false), run(true));
}
