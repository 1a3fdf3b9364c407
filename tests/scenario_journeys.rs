//! Stages and journeys in scenario files: a file-built world behaves as the same world built
//! through the Rust API (the same positions, bit for bit, and the same exit counts), the keys
//! survive a write and a read, the agent count scales, and every bad input is an error naming
//! its key with the path into the file, never a panic.

use throng::journey::{Journey, Stage, StageId, Transition};
use throng::ped::Model;
use throng::prelude::*;
use throng::profile::Profile;
use throng::scenario::{JourneySpec, Scenario, StageSpec, builtin_text};

fn concourse() -> &'static str {
    builtin_text("concourse").unwrap()
}

/// The concourse built through the Rust API, with the agents of `file` (same ids, positions,
/// headings and velocities as the scenario spawned them).
fn api_world(s: &Scenario, file: &World) -> World {
    let mut w = World::builder()
        .bounds(s.bounds().unwrap())
        .seed(s.seed)
        .build()
        .unwrap();
    w.set_walkable(
        Walkable::from_wkt(
            "POLYGON ((0 0, 40 0, 40 20, 0 20, 0 0), (18 3, 22 3, 22 7, 18 7, 18 3), \
             (18 13, 22 13, 22 17, 18 17, 18 13))",
        )
        .unwrap(),
    )
    .unwrap();
    let waypoint = w
        .add_stage(Stage::Waypoint {
            position: Vec2::new(20.0, 10.0),
            distance: 2.0,
        })
        .unwrap();
    let north = w
        .add_stage(Stage::Exit {
            area: Walkable::rectangle(Vec2::new(37.0, 16.0), Vec2::new(40.0, 20.0)).unwrap(),
        })
        .unwrap();
    let south = w
        .add_stage(Stage::Exit {
            area: Walkable::from_wkt("POLYGON ((37 0, 40 0, 40 4, 37 4, 37 0))").unwrap(),
        })
        .unwrap();
    let journey = w
        .add_journey(
            Journey::new([waypoint, north, south])
                .with_transition(waypoint, Transition::round_robin([(north, 1), (south, 3)])),
        )
        .unwrap();
    let group = w.add_group(walkers(Model::Cfsm)).unwrap();
    let a = file.agents();
    let mut rows: Vec<usize> = (0..a.len()).collect();
    rows.sort_by_key(|&i| a.id(i));
    for i in rows {
        let id = w
            .add_agent(AgentInit {
                position: a.position(i),
                velocity: a.velocity(i),
                orientation: a.orientations()[i],
                group,
                ..AgentInit::default()
            })
            .unwrap();
        assert_eq!(id, a.id(i));
        w.set_journey(id, journey, None).unwrap();
    }
    w
}

/// The concourse's group: journey walkers named `passengers`.
fn walkers(model: Model) -> Profile {
    Profile {
        name: "passengers".into(),
        ..Profile::journey_walkers(model)
    }
}

/// Positions by id, as bits.
fn positions(w: &World) -> Vec<(u32, u32, u32)> {
    let a = w.agents();
    let mut out: Vec<_> = (0..a.len())
        .map(|i| {
            let p = a.position(i);
            (a.id(i).0, p.x.to_bits(), p.y.to_bits())
        })
        .collect();
    out.sort_unstable();
    out
}

#[test]
fn a_file_built_concourse_walks_as_the_api_built_one() {
    let s = Scenario::from_toml(concourse(), "concourse.toml").unwrap();
    let mut file = s.build().unwrap();
    assert_eq!(file.stage_count(), 3);
    assert_eq!(file.groups()[0], walkers(Model::Cfsm));
    let mut api = api_world(&s, &file);
    for id in 0..200 {
        assert_eq!(
            file.journey_of(AgentId(id)),
            Some((throng::journey::JourneyId(0), StageId(0)))
        );
    }
    for _ in 0..400 {
        file.step(s.dt).unwrap();
        api.step(s.dt).unwrap();
    }
    assert_eq!(positions(&file), positions(&api), "after 400 steps");
    let mut steps = 400;
    while !(file.is_empty() && api.is_empty()) && steps < 20_000 {
        file.step(s.dt).unwrap();
        api.step(s.dt).unwrap();
        assert_eq!(file.len(), api.len(), "at step {steps}");
        steps += 1;
    }
    assert!(
        file.is_empty(),
        "{} agents left after {steps} steps",
        file.len()
    );
    let left = |w: &World| w.stage_counts().iter().map(|c| c.left).collect::<Vec<_>>();
    assert_eq!(left(&file), left(&api));
    // Round robin 1:3 over 200 agents: exactly 50 and 150.
    assert_eq!(left(&file), vec![0, 50, 150]);
}

#[test]
fn stages_and_journeys_survive_a_write_and_a_read() {
    #[derive(serde::Serialize, serde::Deserialize)]
    struct Part {
        stages: Vec<StageSpec>,
        journeys: Vec<JourneySpec>,
    }
    let s = Scenario::from_toml(concourse(), "concourse.toml").unwrap();
    let part = Part {
        stages: s.stages.clone(),
        journeys: s.journeys.clone(),
    };
    let text = toml::to_string(&part).unwrap();
    let again: Part = toml::from_str(&text).unwrap();
    assert_eq!(
        (again.stages, again.journeys),
        (s.stages, s.journeys),
        "{text}"
    );
    let group = toml::to_string(&s.groups[0]).unwrap();
    assert!(group.contains("journey = \"to_the_trains\""), "{group}");
}

#[test]
fn the_concourse_scales_by_counts_and_keeps_its_split() {
    let s = Scenario::from_toml(concourse(), "concourse.toml")
        .unwrap()
        .with_agents(300)
        .unwrap();
    let mut w = s.build().unwrap();
    assert_eq!(w.len(), 300);
    for _ in 0..40_000 {
        if w.is_empty() {
            break;
        }
        w.step(s.dt).unwrap();
    }
    assert!(w.is_empty(), "{} agents left", w.len());
    let left: Vec<u64> = w.stage_counts().iter().map(|c| c.left).collect();
    assert_eq!(left, vec![0, 75, 225]);
}

#[test]
fn a_group_on_a_journey_starts_from_the_journey_walkers_and_keeps_its_own_keys() {
    let text = concourse().replace(
        "pedestrian = { model = \"cfsm\" }",
        "pedestrian = { model = \"social_force\" }\nradius = 0.25",
    );
    let s = Scenario::from_toml(&text, "c.toml").unwrap();
    let mut expected = walkers(Model::SocialForce);
    expected.radius = 0.25;
    assert_eq!(s.groups[0].params, expected);
}

#[test]
fn a_group_may_start_at_a_later_stage() {
    let text = concourse().replace(
        "journey = \"to_the_trains\"",
        "journey = \"to_the_trains\"\nstage = \"south\"",
    );
    let s = Scenario::from_toml(&text, "c.toml").unwrap();
    let w = s.build().unwrap();
    assert_eq!(
        w.journey_of(AgentId(0)),
        Some((throng::journey::JourneyId(0), StageId(2)))
    );
}

/// The concourse with `from` replaced by `to` (which must occur), parsed: the error's text.
fn error_of(from: &str, to: &str) -> String {
    let text = concourse();
    assert!(text.contains(from), "{from:?} is not in the concourse");
    let text = text.replacen(from, to, 1);
    match Scenario::from_toml(&text, "c.toml").and_then(|s| s.build_within(None)) {
        Ok(_) => panic!("accepted: {from:?} -> {to:?}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_stages_journeys_and_groups_are_errors_naming_their_key() {
    let journey = "transitions = [\n  { from = \"between_pillars\", kind = \"round_robin\", to = [\"north\", \"south\"], weights = [1, 3] },\n]";
    let cases: Vec<(&str, String, &str)> = vec![
        // An unknown key in a stage, with its line.
        ("distance = 2", "distance = 2\nbogus = 1".into(), "bogus"),
        (
            "position = [20, 10]",
            "position = [nan, 10]".into(),
            "stages[0].position",
        ),
        (
            "position = [20, 10]",
            "position = [20, 5]".into(),
            "stages[0].position: (20, 5) lies outside the walkable area",
        ),
        (
            "position = [20, 10]",
            "position = [50, 10]".into(),
            "stages[0].position: (50, 10) lies outside the world",
        ),
        ("distance = 2", "distance = 0".into(), "stages[0].distance"),
        (
            "name = \"north\"",
            "name = \"between_pillars\"".into(),
            "stages[1].name",
        ),
        (
            "max = [40, 20]",
            "max = [40, 20]\npolygon = \"POLYGON ((37 16, 40 16, 40 20, 37 16))\"".into(),
            "stages[1].polygon",
        ),
        (
            "min = [37, 16]",
            "min = [41, 16]".into(),
            "stages[1].min",
        ),
        (
            "to = [\"north\", \"south\"]",
            "to = [\"north\", \"nowhere\"]".into(),
            "journeys[0].transitions[0].to[1]: unknown stage \"nowhere\"",
        ),
        (
            journey,
            "transitions = [{ from = \"between_pillars\", to = \"nowhere\" }]".into(),
            "journeys[0].transitions[0].to: unknown stage \"nowhere\"",
        ),
        (
            journey,
            "transitions = [{ from = \"between_pillars\", to = [\"north\", \"south\"] }]".into(),
            "journeys[0].transitions[0].to: a fixed transition names one stage",
        ),
        (
            "weights = [1, 3]",
            "weights = [1, 3, 1]".into(),
            "journeys[0].transitions[0].weights",
        ),
        (
            "weights = [1, 3]",
            "weights = [1, 0]".into(),
            "journeys[0].transitions[0].weights[1]",
        ),
        (
            "kind = \"round_robin\"",
            "kind = \"least_targeted\"".into(),
            "journeys[0].transitions[0].weights: only a round robin",
        ),
        (
            "kind = \"round_robin\"",
            "kind = \"most_targeted\"".into(),
            "most_targeted",
        ),
        (
            "{ from = \"between_pillars\",",
            "{ from = \"platform\",".into(),
            "journeys[0].transitions[0].from: unknown stage \"platform\"",
        ),
        (
            "stages = [\"between_pillars\", \"north\", \"south\"]",
            "stages = [\"between_pillars\", \"north\", \"south\", \"gate\"]".into(),
            "journeys[0].stages[3]: unknown stage \"gate\"",
        ),
        (
            journey,
            "transitions = []".into(),
            "journeys[0]: stage \"between_pillars\" (a waypoint) has no transition",
        ),
        (
            "journey = \"to_the_trains\"",
            "journey = \"to_the_buses\"".into(),
            "groups[0].journey: unknown journey \"to_the_buses\"",
        ),
        (
            "journey = \"to_the_trains\"",
            "journey = \"to_the_trains\"\nstage = \"gate\"".into(),
            "groups[0].stage",
        ),
        (
            "journey = \"to_the_trains\"",
            "stage = \"north\"".into(),
            "groups[0].stage: a start stage needs a `journey`",
        ),
        (
            "journey = \"to_the_trains\"",
            "journey = \"to_the_trains\"\ngoal = { kind = \"point\", point = [1, 1] }".into(),
            "groups[0].goal",
        ),
        (
            "journey = \"to_the_trains\"",
            "journey = \"to_the_trains\"\nsteering = { behaviours = [{ kind = \"wander\", weight = 1 }] }"
                .into(),
            "groups[0].steering",
        ),
        (
            "[geometry]",
            "[world]\nscale = \"tiles\"\nsize = [40, 20]\n\n[geometry]".into(),
            "world.scale: a scenario with stages or journeys cannot scale by tiles",
        ),
    ];
    for (from, to, expected) in &cases {
        let e = error_of(from, to);
        assert!(e.contains(expected), "{from:?} -> {to:?}: {e}");
    }
}

#[test]
fn a_journey_cycle_with_no_exit_is_refused_naming_the_journey() {
    let loop_ = r#"
[[stages]]
name = "a"
kind = "waypoint"
position = [5, 5]
distance = 1

[[stages]]
name = "b"
kind = "waypoint"
position = [10, 10]
distance = 1

[[journeys]]
name = "round"
stages = ["a", "b"]
transitions = [{ from = "a", to = "b" }, { from = "b", to = "a" }]

[[groups]]"#;
    let text = concourse().replacen("[[groups]]", loop_, 1);
    let e = Scenario::from_toml(&text, "c.toml")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("journeys[1]: from stage \"a\" no exit or direct steering stage can be reached"),
        "{e}"
    );
}

#[test]
fn the_routing_raster_counts_in_the_memory_estimate() {
    let s = Scenario::from_toml(concourse(), "concourse.toml").unwrap();
    let mut bare = s.clone();
    bare.stages.clear();
    bare.journeys.clear();
    bare.groups[0].journey = None;
    // 40 x 20 m in cells of 0.2 m, 16 bytes a cell and 16 for each of the three stages' channels.
    let cells = 200 * 100;
    assert!(
        s.memory_estimate() >= bare.memory_estimate() + cells * 64,
        "{} vs {}",
        s.memory_estimate(),
        bare.memory_estimate()
    );
    // A 100 km square concourse is refused before anything is built.
    let huge = concourse().replace(
        "(0 0, 40 0, 40 20, 0 20, 0 0)",
        "(0 0, 100000 0, 100000 100000, 0 100000, 0 0)",
    );
    let s = Scenario::from_toml(&huge, "huge.toml").unwrap();
    let e = s.build_within(Some(1 << 30)).unwrap_err();
    assert!(matches!(e, throng::Error::OutOfMemory { .. }), "{e}");
}

#[test]
fn the_measurements_time_the_evacuation_through_exit_stages() {
    let s = Scenario::from_toml(concourse(), "concourse.toml").unwrap();
    let mut w = s.build().unwrap();
    let mut rec = throng::measure::Measurements::new(&s.measurements).unwrap();
    rec.observe(&w);
    let mut last_removal = None;
    while !w.is_empty() && w.frame() < 20_000 {
        let stats = w.step(s.dt).unwrap();
        rec.observe(&w);
        if stats.left > 0 {
            last_removal = Some(w.time());
        }
        if !w.is_empty() {
            assert_eq!(rec.evacuation_time(), None, "agents remain");
        }
    }
    assert!(w.is_empty());
    assert_eq!(rec.evacuation_time(), last_removal);
    assert_eq!(rec.left(), 200);
}

#[test]
fn every_stage_kind_and_transition_kind_builds_as_the_rust_api_states_it() {
    let text = r#"
[geometry]
walkable = "POLYGON ((0 0, 30 0, 30 10, 0 10, 0 0))"

[[stages]]
name = "gate"
kind = "queue"
slots = [[10, 5], [9, 5], [8, 5]]

[[stages]]
name = "hall"
kind = "waiting_set"
slots = [[15, 4], [15, 6]]
active = false

[[stages]]
name = "guide"
kind = "direct_steering"

[[stages]]
name = "left"
kind = "exit"
min = [28, 0]
max = [30, 4]

[[stages]]
name = "right"
kind = "exit"
polygon = "POLYGON ((28 6, 30 6, 30 10, 28 10, 28 6))"

[[journeys]]
name = "through"
stages = ["gate", "hall", "left", "right"]
transitions = [
  { from = "gate", to = "hall" },
  { from = "hall", kind = "least_targeted", to = ["left", "right"] },
]

[[journeys]]
name = "led"
stages = ["guide"]

[[groups]]
count = 4
spawn = { kind = "grid", origin = [2, 3], spacing = [1, 1], columns = 2 }
journey = "through"

[[groups]]
count = 1
spawn = { kind = "points", points = [[3, 8]] }
journey = "led"
"#;
    let s = Scenario::from_toml(text, "kinds.toml").unwrap();
    let w = s.build().unwrap();
    let stage = |k: u32| w.stage(StageId(k)).unwrap().clone();
    assert_eq!(
        stage(0),
        Stage::Queue {
            slots: vec![
                Vec2::new(10.0, 5.0),
                Vec2::new(9.0, 5.0),
                Vec2::new(8.0, 5.0)
            ]
        }
    );
    assert_eq!(
        stage(1),
        Stage::WaitingSet {
            slots: vec![Vec2::new(15.0, 4.0), Vec2::new(15.0, 6.0)],
            active: false
        }
    );
    assert_eq!(stage(2), Stage::DirectSteering);
    assert_eq!(
        stage(3),
        Stage::Exit {
            area: Walkable::rectangle(Vec2::new(28.0, 0.0), Vec2::new(30.0, 4.0)).unwrap()
        }
    );
    assert_eq!(
        stage(4),
        Stage::Exit {
            area: Walkable::from_wkt("POLYGON ((28 6, 30 6, 30 10, 28 10, 28 6))").unwrap()
        }
    );
    let (gate, hall, left, right) = (StageId(0), StageId(1), StageId(3), StageId(4));
    let through = w.journey(throng::journey::JourneyId(0)).unwrap();
    assert_eq!(through.transition(gate), Some(&Transition::fixed(hall)));
    assert_eq!(
        through.transition(hall),
        Some(&Transition::least_targeted([left, right]))
    );
    let led = w.journey(throng::journey::JourneyId(1)).unwrap();
    assert_eq!(led, &Journey::chain([StageId(2)]));
    assert_eq!(
        w.journey_of(AgentId(4)),
        Some((throng::journey::JourneyId(1), StageId(2)))
    );
}
