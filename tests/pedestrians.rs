//! Pedestrian models (social force, collision-free speed) in whole worlds: free walking at the
//! desired speed (RiMEA test 1's window), no wall crossed in the bottleneck at any step, the
//! room empties, thread-count independence, checkpoints, and finite results at overlap.

use throng::obstacles::Wall;
use throng::ped::{Cfsm, DesiredSpeed, Model, ModelParams, Pedestrian};
use throng::prelude::*;
use throng::profile::Profile;
use throng::scenario::{Scenario, builtin};

#[path = "support/bits.rs"]
mod bits;

/// A pedestrian group walking to `target` (kinematic, radius 0.2 m).
fn walkers(model: Model, speed: DesiredSpeed, target: Vec2) -> Profile {
    let mut p = Profile::kinematic(SteeringProfile::single(Behaviour::Seek {
        target: Target::Point(target),
        threshold: 0.0,
    }));
    p.model = MovementModel::Kinematic;
    p.max_speed = 2.5;
    p.radius = 0.2;
    p.pedestrian = Some(Pedestrian {
        desired_speed: speed,
        ..Pedestrian::new(model)
    });
    p
}

/// RiMEA test 1: one pedestrian at 1.33 m/s covers a corridor 40 m long and 2 m wide in
/// 26 to 34 s; here it must also keep its desired speed within 1% once it has started.
#[test]
fn a_lone_pedestrian_keeps_its_desired_speed_along_a_corridor() {
    for model in Model::ALL {
        let mut w = World::builder()
            .group(walkers(
                model,
                DesiredSpeed::fixed(1.33),
                Vec2::new(1000.0, 1.0),
            ))
            .wall(Wall {
                a: Vec2::new(0.0, 0.0),
                b: Vec2::new(40.0, 0.0),
            })
            .wall(Wall {
                a: Vec2::new(0.0, 2.0),
                b: Vec2::new(40.0, 2.0),
            })
            .agent(AgentInit::at(Vec2::new(0.0, 1.0), 0))
            .build()
            .unwrap();
        let dt = 0.01;
        let mut t = 0.0;
        while w.agents().position(0).x < 40.0 {
            w.step(dt).unwrap();
            t += dt;
            assert!(t < 60.0, "{model:?}: not through after 60 s");
            let v = w.agents().velocity(0).length();
            if t > 3.0 {
                assert!((v - 1.33).abs() < 0.0133, "{model:?}: speed {v} at {t} s");
            }
            let y = w.agents().position(0).y;
            assert!((y - 1.0).abs() < 1e-3, "{model:?}: drifted to y = {y}");
        }
        assert!((26.0..=34.0).contains(&t), "{model:?}: {t} s for 40 m");
    }
}

/// Inside the bottleneck's room or its exit corridor (centres stay at least the radius from
/// the walls, up to a small tolerance).
fn inside_bottleneck(p: Vec2, width: f32) -> bool {
    let (y0, y1) = (5.0 - width / 2.0, 5.0 + width / 2.0);
    let room = (0.0..=10.0).contains(&p.x) && (0.0..=10.0).contains(&p.y);
    let corridor = (10.0..=14.0).contains(&p.x) && (y0..=y1).contains(&p.y);
    room || corridor
}

#[test]
fn nobody_leaves_the_bottleneck_through_a_wall_and_the_room_empties() {
    for model in Model::ALL {
        let mut s = builtin("bottleneck").unwrap();
        for g in &mut s.groups {
            g.params.pedestrian.as_mut().unwrap().set_model(model);
        }
        let mut w = s.build().unwrap();
        assert_eq!(w.len(), 200);
        let mut steps = 0;
        while !w.is_empty() {
            w.step(s.dt).unwrap();
            steps += 1;
            let a = w.agents();
            for i in 0..a.len() {
                let p = a.position(i);
                assert!(
                    inside_bottleneck(p, 1.2),
                    "{model:?}: agent {} at {p} after {steps} steps",
                    a.id(i)
                );
                assert!(a.velocity(i).is_finite());
            }
            if steps == 30_000 {
                break;
            }
        }
        // Both models empty the room (the social force model at the 2000 paper's repulsion
        // clogged it, arches of agents pressed together; under its calibrated repulsion the
        // last is out at 127 s).
        let left = w.len();
        assert_eq!(left, 0, "{model:?}: {left} agents left after 300 s");
    }
}

/// The time at which the `k`th pedestrian (counted from 0) of the built-in bottleneck (b = 1.2
/// m) leaves, with the speed model's pressure from behind on or off.
fn bottleneck_exit_time(pressure: bool, k: usize) -> f32 {
    let mut s = builtin("bottleneck").unwrap();
    for g in &mut s.groups {
        let ModelParams::Cfsm(cf) = &mut g.params.pedestrian.as_mut().unwrap().params else {
            panic!("the bottleneck walks by the speed model");
        };
        if !pressure {
            cf.pressed_time_gap = cf.time_gap;
        }
    }
    let mut w = s.build().unwrap();
    let start = w.len();
    for step in 1..=30_000u32 {
        w.step(s.dt).unwrap();
        if start - w.len() > k {
            return step as f32 * s.dt;
        }
    }
    panic!("{k} did not leave in 300 s (pressure {pressure})");
}

#[test]
fn pressure_from_behind_lets_more_through_the_bottleneck() {
    // Pedestrians 20 to 170 leave at the door's steady flow: about 1.7 1/s without pressure,
    // about 2.1 1/s with it (the experiments give 1.9 to 2.4 at 1.2 m, docs/VALIDATION.md).
    let flow = |pressure| {
        150.0 / (bottleneck_exit_time(pressure, 170) - bottleneck_exit_time(pressure, 20))
    };
    let (on, off) = (flow(true), flow(false));
    eprintln!("flow with pressure {on} 1/s, without {off} 1/s");
    assert!(off > 1.0 && off < 1.9, "without pressure: {off} 1/s");
    assert!(
        on > 1.2 * off && on < 2.6,
        "with pressure {on} 1/s, without {off} 1/s"
    );
}

#[test]
fn same_bits_on_one_two_and_four_threads() {
    let run = |s: &Scenario, threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let mut w = s.build().unwrap();
        pool.install(|| {
            for _ in 0..400 {
                w.step(s.dt).unwrap();
            }
        });
        bits::by_id(&w)
    };
    for model in Model::ALL {
        let mut s = builtin("corridor").unwrap().with_agents(3000).unwrap();
        for g in &mut s.groups {
            g.params.pedestrian.as_mut().unwrap().set_model(model);
        }
        let one = run(&s, 1);
        assert_eq!(one, run(&s, 2), "{model:?}");
        assert_eq!(one, run(&s, 4), "{model:?}");
    }
}

#[test]
fn coincident_and_overlapping_agents_stay_finite_and_separate() {
    for model in Model::ALL {
        let mut b = World::builder().group(walkers(
            model,
            DesiredSpeed::default(),
            Vec2::new(1000.0, 0.0),
        ));
        for k in 0..3 {
            // Three pairs on the same spot and three overlapping by 0.3 m.
            let p = Vec2::new(2.0 * k as f32, 0.0);
            b = b.agent(AgentInit::at(p, 0)).agent(AgentInit::at(p, 0));
            let q = p + Vec2::new(0.0, 3.0);
            b = b
                .agent(AgentInit::at(q, 0))
                .agent(AgentInit::at(q + Vec2::new(0.1, 0.0), 0));
        }
        let mut w = b.build().unwrap();
        for _ in 0..200 {
            w.step(0.01).unwrap();
            let a = w.agents();
            for i in 0..a.len() {
                assert!(a.position(i).is_finite() && a.velocity(i).is_finite());
            }
        }
        let a = w.agents();
        let closest = (0..a.len())
            .flat_map(|i| (0..i).map(move |j| (i, j)))
            .map(|(i, j)| a.position(i).distance(a.position(j)))
            .fold(f32::INFINITY, f32::min);
        assert!(closest > 0.05, "{model:?}: closest pair {closest}");
    }
}

#[test]
fn desired_speeds_are_drawn_per_agent_and_survive_a_checkpoint() {
    let s = builtin("bottleneck").unwrap();
    let mut w = s.build().unwrap();
    let speeds = w.agents().desired_speeds().to_vec();
    let d = DesiredSpeed::default();
    assert!(speeds.iter().all(|v| (d.min..=d.max).contains(v)));
    let distinct = speeds
        .iter()
        .map(|v| v.to_bits())
        .collect::<std::collections::BTreeSet<_>>();
    assert!(distinct.len() > 150, "{} distinct speeds", distinct.len());
    for _ in 0..100 {
        w.step(s.dt).unwrap();
    }
    let mut bytes = Vec::new();
    w.save(&mut bytes).unwrap();
    let mut r = World::load(&bytes[..]).unwrap();
    for _ in 0..300 {
        w.step(s.dt).unwrap();
        r.step(s.dt).unwrap();
    }
    let a = w.agents();
    let b = r.agents();
    assert_eq!(a.ids(), b.ids());
    assert_eq!(a.pos_x(), b.pos_x());
    assert_eq!(a.desired_speeds(), b.desired_speeds());
}

#[test]
fn bad_pedestrian_values_are_errors_naming_the_key() {
    let cases = [
        (
            "pedestrian = { model = \"cfsm\", cfsm = { time_gap = 0 } }",
            "time_gap",
        ),
        (
            "pedestrian = { model = \"social_force\", social_force = { tau = -1 } }",
            "tau",
        ),
        (
            "pedestrian = { desired_speed = { mean = 1.0, min = 2.0 } }",
            "desired_speed",
        ),
        ("pedestrian = { model = \"magic\" }", "magic"),
        (
            "pedestrian = { model = \"social_force\", social_force = { lambda = 2 } }",
            "lambda",
        ),
        (
            "pedestrian = { cfsm = { speed_function = \"cubic\" } }",
            "cubic",
        ),
        ("pedestrian = { cfsm = { spacing = \"edge\" } }", "edge"),
        (
            "pedestrian = { cfsm = { time_gap = 0.5, pressed_time_gap = 0.6 } }",
            "pressed_time_gap",
        ),
        (
            "pedestrian = { cfsm = { pressure_onset = -0.1 } }",
            "pressure_onset",
        ),
        (
            "pedestrian = { cfsm = { pressure_span = 0 } }",
            "pressure_span",
        ),
        ("pedestrian = { cfsm = { anisotropy = 1.5 } }", "anisotropy"),
        ("pedestrian = { cfsm = { anisotropy = nan } }", "anisotropy"),
    ];
    for (line, key) in cases {
        let text = format!(
            "name = \"t\"\n[world]\nkind = \"open\"\n[[groups]]\nspawn = {{ kind = \"disc\", center = [0, 0], radius = 1 }}\n{line}\n"
        );
        let e = Scenario::from_toml(&text, "t.toml")
            .and_then(|s| s.build().map(|_| ()))
            .unwrap_err()
            .to_string();
        assert!(e.contains(key), "{line}: {e}");
    }
    let layouts = [
        "[layout]\nkind = \"bottleneck\"\nwidth = 20",
        "[layout]\nkind = \"corridor\"\nwidth = -1",
        "[layout]\nkind = \"corridor\"\nmargin = 0.5",
    ];
    for l in layouts {
        let text = format!("name = \"t\"\n{l}\n[[groups]]\nspawn = {{ kind = \"layout\" }}\n");
        let r = Scenario::from_toml(&text, "t.toml").and_then(|s| s.build().map(|_| ()));
        assert!(r.is_err(), "{l}");
    }
    let text = "name = \"t\"\n[[groups]]\nspawn = { kind = \"layout\" }\n";
    let e = Scenario::from_toml(text, "t.toml")
        .and_then(|s| s.build().map(|_| ()))
        .unwrap_err()
        .to_string();
    assert!(e.contains("layout"), "{e}");
    // More agents than the room holds at 0.45 m: an error, not a hang.
    let text = "name = \"t\"\n[layout]\nkind = \"bottleneck\"\n[[groups]]\ncount = 2000\nspawn = { kind = \"layout\" }\n";
    let e = Scenario::from_toml(text, "t.toml")
        .and_then(|s| s.build().map(|_| ()))
        .unwrap_err()
        .to_string();
    assert!(e.contains("no room"), "{e}");
    // The walkable raster's clearance and the flow's metric.
    for (line, key) in [
        ("clearance = -0.1", "clearance"),
        ("clearance = nan", "clearance"),
        ("clearance = 100", "clearance"),
        ("clearance = 0.5\nclearance_cost = 4", "distance metric"),
        (
            "metric = \"euclidean\"\nclearance_cost = 4",
            "clearance above 0",
        ),
        (
            "metric = \"euclidean\"\nclearance = 0.5\nclearance_cost = 0.5",
            "field.clearance_cost",
        ),
        (
            "metric = \"euclidean\"\nclearance = 0.5\nclearance_cost = nan",
            "field.clearance_cost",
        ),
        (
            "metric = \"euclidean\"\nclearance = 0.5\nclearance_cost = 21",
            "field.clearance_cost",
        ),
        (
            "metric = \"euclidean\"\nclearance = 100\nclearance_cost = 4",
            "field.clearance / field.cell_size",
        ),
        ("metric = \"manhattan\"", "manhattan"),
        ("metric = \"euclidean\"\nreroute_every = 5", "quickest"),
        ("density_radius = 1", "quickest"),
        (
            "metric = \"quickest\"\ndensity_radius = -1",
            "density_radius",
        ),
        (
            "metric = \"quickest\"\ndensity_radius = 100",
            "density_radius",
        ),
        ("metric = \"quickest\"\nreroute_every = -1", "t.toml:7:17"),
    ] {
        let text = format!(
            "name = \"t\"\n[geometry]\nwalkable = \"POLYGON ((0 0, 10 0, 10 4, 0 4, 0 0))\"\n[field]\ncell_size = 0.5\n{line}\n[[exits]]\nmin = [9.5, 0]\nmax = [10, 4]\n[[groups]]\ncount = 3\nspawn = {{ kind = \"disc\", center = [2, 2], radius = 1 }}\n"
        );
        let e = Scenario::from_toml(&text, "t.toml")
            .and_then(|s| s.build().map(|_| ()))
            .unwrap_err()
            .to_string();
        assert!(e.contains(key), "{line}: {e}");
    }
    // The clearance's cost applies to the walkable raster only.
    let text = "name = \"t\"\n[field]\nmap = { ascii = \".....\\n.....\\n\" }\nmetric = \"euclidean\"\nclearance = 0.5\nclearance_cost = 4\n[[groups]]\ncount = 1\n";
    let e = Scenario::from_toml(text, "t.toml")
        .and_then(|s| s.build().map(|_| ()))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("field.clearance_cost") && e.contains("walkable"),
        "{e}"
    );
}

#[path = "support/two_doors.rs"]
mod support;

/// The two-door room, one channel with both doors as goals; 150 pedestrians start close to
/// the left door. `metric` is the field's.
fn two_doors(metric: &str) -> String {
    support::two_doors(
        metric,
        "",
        150,
        ([0.5, 1.5], [6.0, 8.5]),
        "{ kind = \"follow_field\", field = 0, channel = 0 }",
    )
}

/// How many pedestrians left through the far (right) door within `steps` steps, and how many
/// are left inside.
fn far_door_use(metric: &str, steps: u64) -> (usize, usize) {
    let s = Scenario::from_toml(&two_doors(metric), "t.toml").unwrap();
    let mut world = s.build().unwrap();
    let mut right = std::collections::HashSet::new();
    for _ in 0..steps {
        for i in 0..world.len() {
            if world.agents().position(i).x > 10.0 {
                right.insert(world.agents().id(i));
            }
        }
        world.step(s.dt).unwrap();
    }
    (right.len(), world.len())
}

#[test]
fn quickest_routing_sends_part_of_a_jam_to_the_far_door() {
    // Everyone's nearest door is the left one. Following the distance alone they all queue
    // there; routed by travel time through the crowd, some walk to the free door instead, and
    // the room empties sooner.
    let (far_euclidean, left_euclidean) = far_door_use("euclidean", 4000);
    let (far_quickest, left_quickest) = far_door_use("quickest", 4000);
    assert_eq!(far_euclidean, 0);
    assert!(far_quickest >= 10, "{far_quickest} took the far door");
    assert!(
        left_quickest < left_euclidean,
        "{left_quickest} vs {left_euclidean} still inside after 40 s"
    );
}

/// The speed model at a door two bodies wide (the bottleneck at 0.8 m) empties the room at
/// every seed, as real crowds pass 0.8 m at about 1.4 persons/s. While a wall's corner was
/// counted twice (once by each wall meeting at a jamb), at seeds 2 and 4 of these six the last
/// two, one at each jamb, held each other for good (docs/VALIDATION.md, "The narrow door";
/// before the calibration of the time gap and the path's width, at all six).
#[test]
fn a_door_two_bodies_wide_empties_at_every_seed() {
    let stuck: Vec<(u64, usize)> = (1..=6)
        .map(|s| (s, left_at_a_door_two_bodies_wide(s, |_| {})))
        .filter(|p| p.1 > 0)
        .collect();
    assert!(stuck.is_empty(), "(seed, left inside): {stuck:?}");
}

/// How many of the built-in bottleneck's 200 pedestrians are still inside after 200 s at a
/// door 0.8 m wide, with the speed model's defaults changed by `tweak`.
fn left_at_a_door_two_bodies_wide(seed: u64, tweak: fn(&mut Cfsm)) -> usize {
    let mut s = builtin("bottleneck").unwrap();
    s.seed = seed;
    s.layout.as_mut().unwrap().set_width(0.8);
    for g in &mut s.groups {
        let ModelParams::Cfsm(cf) = &mut g.params.pedestrian.as_mut().unwrap().params else {
            panic!("the bottleneck walks by the speed model");
        };
        tweak(cf);
    }
    let mut w = s.build().unwrap();
    for _ in 0..20_000 {
        w.step(s.dt).unwrap();
        if w.is_empty() {
            break;
        }
    }
    w.len()
}

#[test]
fn a_door_two_bodies_wide_holds_at_most_the_last_two() {
    // Under the defaults all but at most the last two (held by each other at the jambs, open)
    // leave; with the paper's isotropic repulsion under pressure too and its strip (the
    // anisotropy under pressure and the path's width both off), an arch of four holds the
    // crowd at one seed at least, so that this can fail.
    let seeds = 1..=3;
    let default: Vec<usize> = seeds
        .clone()
        .map(|s| left_at_a_door_two_bodies_wide(s, |_| {}))
        .collect();
    assert!(
        default.iter().all(|&left| left <= 2),
        "left inside: {default:?}"
    );
    let isotropic: Vec<usize> = seeds
        .map(|s| {
            left_at_a_door_two_bodies_wide(s, |cf| {
                cf.pressed_anisotropy = 1.0;
                cf.path_width = 1.0;
            })
        })
        .collect();
    assert!(
        isotropic.iter().any(|&left| left > 100),
        "left inside: {isotropic:?}"
    );
}

#[test]
fn pedestrians_stand_until_their_premovement_time_and_bad_times_are_errors() {
    let text = r#"
name = "wait"
seed = 3
dt = 0.05
[[groups]]
count = 20
spawn = { kind = "grid", origin = [0, 0], spacing = [1, 1], columns = 5 }
model = "kinematic"
max_speed = 2
radius = 0.2
steering = { behaviours = [{ kind = "seek", target = { point = [100, 2] } }] }
pedestrian = { premovement = { min = 1, max = 4 } }
"#;
    let s = Scenario::from_toml(text, "t.toml").unwrap();
    let pm = s.groups[0].params.pedestrian.unwrap().premovement.unwrap();
    let mut w = s.build().unwrap();
    // Start and drawn time by id (storage order changes as the world reorders its agents).
    let by_id: std::collections::HashMap<AgentId, (Vec2, f32)> = (0..w.len())
        .map(|i| {
            let id = w.agents().id(i);
            (id, (w.agents().position(i), pm.draw(s.seed, id.0)))
        })
        .collect();
    let times: Vec<f32> = by_id.values().map(|v| v.1).collect();
    assert!(times.iter().all(|t| (1.0..=4.0).contains(t)));
    assert!(times.iter().any(|&t| t < 2.0) && times.iter().any(|&t| t > 3.0));
    for _ in 0..100 {
        let now = w.time() as f32;
        w.step(s.dt).unwrap();
        for i in 0..w.len() {
            let id = w.agents().id(i);
            let (start, t) = by_id[&id];
            let moved = w.agents().position(i).distance(start) > 1e-4;
            // The step taken at `now` moves an agent exactly when its time has come.
            if now < t {
                assert!(!moved, "{id:?} moved at {now} s before its {t} s");
            } else {
                assert!(moved, "{id:?} still stands at {now} s after its {t} s");
            }
        }
    }
    for (line, key) in [
        ("premovement = { min = -1, max = 4 }", "premovement.min"),
        ("premovement = { min = 5, max = 4 }", "premovement.max"),
        ("premovement = { min = 1, max = inf }", "premovement.max"),
        ("premovement = { min = nan, max = 4 }", "premovement.min"),
        ("premovement = { min = 1 }", "max"),
    ] {
        let bad = text.replace("premovement = { min = 1, max = 4 }", line);
        let e = Scenario::from_toml(&bad, "t.toml")
            .and_then(|s| s.build())
            .unwrap_err()
            .to_string();
        assert!(e.contains(key), "{line}: {e}");
    }
}

/// Under the social force model a waiting pedestrian has no social repulsion of its own: nine
/// standing 0.8 m apart (0.4 m between bodies, where the repulsion is 16 N: 29 N weighted by
/// 0.55 for an agent with no direction) do not move before their time, and two whose bodies
/// overlap are still pushed apart by the body force.
#[test]
fn waiting_pedestrians_are_moved_only_by_contact_under_the_social_force_model() {
    let scene = |spacing: f32, count: usize| {
        format!(
            r#"
name = "wait"
seed = 3
dt = 0.01
[[groups]]
count = {count}
spawn = {{ kind = "grid", origin = [0, 0], spacing = [{spacing}, {spacing}], columns = 3 }}
model = "kinematic"
max_speed = 2
radius = 0.2
steering = {{ behaviours = [{{ kind = "seek", target = {{ point = [100, 0] }} }}] }}
pedestrian = {{ model = "social_force", premovement = {{ min = 50, max = 50 }} }}
"#
        )
    };
    let largest_move = |text: &str| {
        let mut w = Scenario::from_toml(text, "t.toml")
            .unwrap()
            .build()
            .unwrap();
        let start: std::collections::HashMap<AgentId, Vec2> = (0..w.len())
            .map(|i| (w.agents().id(i), w.agents().position(i)))
            .collect();
        for _ in 0..200 {
            w.step(0.01).unwrap();
        }
        (0..w.len())
            .map(|i| w.agents().position(i).distance(start[&w.agents().id(i)]))
            .fold(0.0f32, f32::max)
    };
    let apart = largest_move(&scene(0.8, 9));
    assert!(apart == 0.0, "a waiting pedestrian moved {apart} m");
    let touching = largest_move(&scene(0.3, 2));
    assert!(
        touching > 0.02,
        "overlapping bodies moved only {touching} m"
    );
}
