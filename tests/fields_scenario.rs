//! The built-in `fields` scenarios (document 001's setup): every agent that starts in the goals'
//! connected component reaches a goal, with flow-field steering and with grid walkers; no agent
//! ever stands inside a wall; 1 and 2 threads agree bit for bit; re-randomised goals trigger a
//! rebuild that the agents then follow.

use throng::World;
use throng::scenario::{Scenario, builtin};

/// Steps within which every agent of `fields` must arrive (at 8 cells/s and 30 steps/s).
const FLOW_STEPS: u64 = 6000;
/// Steps within which every walker of `fields-walkers` must arrive (one cell per step at most).
const WALKER_STEPS: u64 = 4000;

fn no_shuffle(name: &str) -> Scenario {
    let mut s = builtin(name).unwrap();
    s.field.as_mut().unwrap().shuffle_every = 0;
    s
}

fn assert_no_agent_in_wall(world: &World, step: u64) {
    for i in 0..world.len() {
        let p = world.agents().position(i);
        assert!(
            !world.in_field_wall(p),
            "agent {} inside a wall at {p} after step {step}",
            world.agents().id(i)
        );
    }
}

/// Steps `world` until every agent that starts where a goal is reachable has arrived, checking
/// walls every step; returns the number of steps taken.
fn run_until_arrived(world: &mut World, dt: f32, limit: u64) -> u64 {
    world.step(dt).unwrap(); // builds the field
    let flow = world.field(0).unwrap().flow(0).unwrap();
    let reachable: Vec<_> = (0..world.len())
        .filter(|&i| {
            flow.world_to_cell(world.agents().position(i))
                .is_some_and(|(x, y)| flow.is_reachable(x, y))
        })
        .map(|i| world.agents().id(i))
        .collect();
    assert!(!reachable.is_empty());
    let mut ever = std::collections::HashSet::new();
    for step in 1..limit {
        assert_no_agent_in_wall(world, step);
        for &id in &reachable {
            if world.has_arrived(id) {
                ever.insert(id);
            }
        }
        if ever.len() == reachable.len() {
            return step;
        }
        world.step(dt).unwrap();
    }
    panic!(
        "{} of {} agents arrived within {limit} steps",
        ever.len(),
        reachable.len()
    );
}

#[test]
fn every_flow_follower_reaches_a_goal_and_never_enters_a_wall() {
    let s = no_shuffle("fields");
    let mut world = s.build().unwrap();
    assert_eq!(world.len(), 1000);
    let steps = run_until_arrived(&mut world, s.dt, FLOW_STEPS);
    assert!(steps > 10);
}

#[test]
fn every_walker_reaches_a_goal_and_never_enters_a_wall() {
    let s = builtin("fields-walkers").unwrap();
    let mut world = s.build().unwrap();
    assert_eq!(world.walkers(0, 0).unwrap().len(), 1000);
    run_until_arrived(&mut world, s.dt, WALKER_STEPS);
    assert_eq!(world.walkers(0, 0).unwrap().active_count(), 0);
}

fn snapshot(world: &World) -> Vec<(u32, [u32; 4], bool)> {
    let mut v: Vec<_> = (0..world.len())
        .map(|i| {
            let a = world.agents();
            let (p, v) = (a.position(i), a.velocity(i));
            let id = a.id(i);
            (
                id.0,
                [p.x.to_bits(), p.y.to_bits(), v.x.to_bits(), v.y.to_bits()],
                world.has_arrived(id),
            )
        })
        .collect();
    v.sort_unstable();
    v
}

#[test]
fn one_and_two_threads_agree_bit_for_bit() {
    for name in ["fields", "fields-walkers"] {
        let mut s = builtin(name).unwrap();
        s.field.as_mut().unwrap().shuffle_every = 50;
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let mut world = s.build().unwrap();
            pool.install(|| {
                for _ in 0..120 {
                    world.step(s.dt).unwrap();
                }
            });
            (snapshot(&world), world.field_rebuilds())
        };
        let (one, two) = (run(1), run(2));
        assert_eq!(one.1, 3, "{name}: initial build and two shuffles");
        assert!(one == two, "{name}: 1 and 2 threads differ");
    }
}

#[test]
fn rerandomised_goals_are_rebuilt_and_followed() {
    let s = no_shuffle("fields");
    let mut world = s.build().unwrap();
    run_until_arrived(&mut world, s.dt, FLOW_STEPS);
    let before = world.field_rebuilds();
    let old = world.field(0).unwrap().goals(0).unwrap().to_vec();
    world.randomize_field_goals(0, 0, 4, 99).unwrap();
    let new = world.field(0).unwrap().goals(0).unwrap().to_vec();
    assert_ne!(old, new);
    world.step(s.dt).unwrap();
    assert_eq!(world.field_rebuilds(), before + 1);
    // Arrival flags were reset by the rebuild; everyone reaches the new goals.
    assert!(world.arrived_count() < world.len());
    run_until_arrived(&mut world, s.dt, FLOW_STEPS);
    for i in 0..world.len() {
        let id = world.agents().id(i);
        assert!(world.has_arrived(id));
    }
}

#[test]
fn blocked_cells_trigger_a_rebuild_and_agents_stay_out() {
    let s = no_shuffle("fields");
    let mut world = s.build().unwrap();
    world.step(s.dt).unwrap();
    let grid = world.field(0).unwrap().grid().clone();
    let goals = world.field(0).unwrap().goals(0).unwrap().to_vec();
    // Wall off a free cell next to a goal that nobody stands on.
    let (gx, gy) = goals[0];
    let mut blocked = None;
    for (dx, dy) in [(1i64, 0i64), (-1, 0), (0, 1), (0, -1)] {
        let (x, y) = ((gx as i64 + dx) as u32, (gy as i64 + dy) as u32);
        if grid.is_free(x, y) && world.set_field_blocked(0, x, y, true).is_ok() {
            blocked = Some((x, y));
            break;
        }
    }
    let (x, y) = blocked.expect("a free cell beside the goal");
    let before = world.field_rebuilds();
    for step in 0..300 {
        world.step(s.dt).unwrap();
        assert_no_agent_in_wall(&world, step);
    }
    assert_eq!(world.field_rebuilds(), before + 1);
    assert!(!world.field(0).unwrap().field(0).unwrap().is_reachable(x, y));
}

#[test]
fn follow_field_in_a_scenario_file_with_an_inline_map() {
    let text = r#"
name = "corridor"
steps = 10
[world]
kind = "bounded"
size = [8, 3]
[field]
map = { ascii = "........\n.######.\nS......G\n" }
[[groups]]
count = 5
spawn = { kind = "free_cells" }
model = "kinematic"
max_speed = 4
steering = { behaviours = [{ kind = "follow_field" }] }
"#;
    let s = Scenario::from_toml(text, "corridor.toml").unwrap();
    let mut world = s.build().unwrap();
    for _ in 0..200 {
        world.step(s.dt).unwrap();
        assert_no_agent_in_wall(&world, 0);
    }
    assert_eq!(world.arrived_count(), 5);
    let bad = text
        .replace("free_cells", "uniform")
        .replace("[field]", "[nofield]");
    assert!(Scenario::from_toml(&bad, "bad.toml").is_err());
}

#[test]
fn the_follow_only_fast_path_equals_the_general_loop() {
    // A profile of one `follow_field` takes the fast path; adding an angular-only behaviour
    // forces the general loop. Positions and velocities must agree bit for bit.
    assert_eq!(
        follow_field_run(false, false),
        follow_field_run(true, false)
    );
}

#[test]
fn the_follow_field_plan_with_separation_equals_the_general_loop() {
    // The scenario's own profile, `follow_field` then `separation`, is a plan of its own with
    // the separation sums from the cell batch; the angular-only extra behaviour sends the same
    // profile through the general loop.
    let plan = follow_field_run(false, true);
    assert_eq!(plan, follow_field_run(true, true));
    assert_ne!(
        plan,
        follow_field_run(false, false),
        "separation changes the run"
    );
}

/// The `fields` scenario for 60 steps, its profile cut to `follow_field` (or, with
/// `separation`, kept with its separation), with an angular-only behaviour added when `extra`:
/// each agent's id, position and velocity bits, sorted by id.
fn follow_field_run(extra: bool, separation: bool) -> Vec<(throng::AgentId, u32, u32, u32, u32)> {
    {
        let mut s = throng::scenario::builtin("fields").unwrap();
        let keep = |name: &str| name == "follow_field" || (separation && name == "separation");
        s.groups[0]
            .params
            .steering
            .behaviours
            .retain(|w| keep(w.behaviour.name()));
        if extra {
            s.groups[0]
                .params
                .steering
                .behaviours
                .push(throng::steering::Weighted::new(
                    throng::steering::Behaviour::LookWhereYouAreGoing {
                        params: Default::default(),
                    },
                    1.0,
                ));
        }
        let mut w = s.build().unwrap();
        for _ in 0..60 {
            w.step(s.dt).unwrap();
        }
        let ran = if extra { "general" } else { "follow_field" };
        assert_eq!(w.last_plans()[0], ran, "the plan that ran");
        let a = w.agents();
        let mut v: Vec<_> = (0..a.len())
            .map(|i| {
                (
                    a.id(i),
                    a.pos_x()[i].to_bits(),
                    a.pos_y()[i].to_bits(),
                    a.vel_x()[i].to_bits(),
                    a.vel_y()[i].to_bits(),
                )
            })
            .collect();
        v.sort();
        v
    }
}
