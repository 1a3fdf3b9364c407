//! Pedestrian measurements: crossings counted once per direction and not along a line, the flow
//! of a constant stream, the density of a known arrangement, agents counted on their way out
//! through an exit, the minimum image on a torus, the time window, counts independent of agent
//! order and thread count, and the scenario keys with their errors.

use glam::Vec2;
use proptest::prelude::*;
use throng::measure::{
    LineReport, MeasurementArea, MeasurementLine, MeasurementSpec, Measurements,
};
use throng::prelude::*;
use throng::scenario::Scenario;
use throng::world::Exit;

/// A world whose agents stand still unless moved (kinematic, no behaviours).
fn still_world(bounds: Bounds, positions: &[Vec2]) -> World {
    let mut b = World::builder().bounds(bounds).group(Profile {
        max_speed: 10.0,
        ..Profile::kinematic(SteeringProfile::default())
    });
    for &p in positions {
        b = b.agent(AgentInit::at(p, 0));
    }
    b.build().unwrap()
}

fn line(name: &str, from: [f32; 2], to: [f32; 2]) -> MeasurementLine {
    MeasurementLine::new(name, Vec2::from(from), Vec2::from(to)).unwrap()
}

fn spec(lines: Vec<MeasurementLine>, areas: Vec<MeasurementArea>) -> MeasurementSpec {
    MeasurementSpec {
        lines,
        areas,
        window: None,
        voronoi: false,
    }
}

/// Moves agent `k` to `frames[f][k]` and steps, observing every frame (the first one before
/// any step).
fn walk(world: &mut World, rec: &mut Measurements, frames: &[Vec<Vec2>], dt: f32) {
    for (f, positions) in frames.iter().enumerate() {
        walk_one(world, rec, positions, (f > 0).then_some(dt));
    }
}

/// Steps by `dt` when given, then moves the agents to `frame` and observes.
fn walk_one(w: &mut World, rec: &mut Measurements, frame: &[Vec2], dt: Option<f32>) {
    if let Some(dt) = dt {
        w.step(dt).unwrap();
    }
    let ids: Vec<AgentId> = w.agents().ids().to_vec();
    for (id, &p) in ids.iter().zip(frame) {
        w.set_position(*id, p).unwrap();
    }
    rec.observe(w);
}

#[test]
fn a_crossing_counts_once_per_direction() {
    let mut w = still_world(Bounds::Open, &[Vec2::new(-1.0, 1.0)]);
    let mut rec =
        Measurements::new(&spec(vec![line("l", [0.0, 0.0], [0.0, 2.0])], vec![])).unwrap();
    // Over, a step on the far side, back, and a stop on the line before crossing again.
    let xs = [-1.0, 1.0, 1.5, -0.5, 0.0, 0.0, 0.7];
    let frames: Vec<Vec<Vec2>> = xs.iter().map(|&x| vec![Vec2::new(x, 1.0)]).collect();
    walk(&mut w, &mut rec, &frames, 0.1);
    let r = rec.report();
    let l = &r.lines[0];
    assert_eq!((l.positive, l.negative, l.net, l.total), (2, 1, 1, 3));
    assert_eq!(rec.line_counts().collect::<Vec<_>>(), [(2, 1)]);
    // The N-t diagram counts the agent once, at its first crossing.
    assert_eq!((l.nt_count, l.nt_flow), (1, None));
}

/// A stream through a line where every third agent steps back over it and crosses again: the
/// crossings' flow counts the returns (three crossings for each such agent), the N-t flow counts
/// each agent once, at its first crossing, and equals the stream's rate.
#[test]
fn the_n_t_flow_counts_each_agent_once() {
    let n = 9;
    // Agents 0, 3, 6 go 0.4 m back over the line once they are 0.3 to 0.5 m past it.
    let l = stream_across_a_line(n, |k, x| {
        if k % 3 == 0 && (0.3..0.5).contains(&x) {
            x - 0.4
        } else {
            x
        }
    });
    assert_eq!((l.positive, l.negative), (n + 3, 3), "{l:?}");
    assert_eq!(l.nt_count, n, "{l:?}");
    // First crossings every 0.5 s: 8 gaps over 4 s.
    assert!((l.nt_flow.unwrap() - 2.0).abs() < 1e-4, "{l:?}");
    assert!(
        l.flow.unwrap() > 2.5,
        "the crossings' flow counts the returns: {l:?}"
    );
}

/// `n` agents a metre apart walking at 2 m/s towards a 2 m line at x = 0 (one every 0.5 s),
/// observed every 0.1 s, agent `k` drawn at `x(k, x)` instead of `x`; the line's report.
fn stream_across_a_line(n: u64, x: impl Fn(usize, f32) -> f32) -> LineReport {
    let start: Vec<Vec2> = (0..n).map(|k| Vec2::new(-0.25 - k as f32, 1.0)).collect();
    let mut w = still_world(Bounds::Open, &start);
    let mut rec =
        Measurements::new(&spec(vec![line("l", [0.0, 0.0], [0.0, 2.0])], vec![])).unwrap();
    let dt = 0.1f32;
    let frames: Vec<Vec<Vec2>> = (0..80)
        .map(|f| {
            let t = f as f32 * dt;
            start
                .iter()
                .enumerate()
                .map(|(k, p)| Vec2::new(x(k, p.x + 2.0 * t), p.y))
                .collect()
        })
        .collect();
    walk(&mut w, &mut rec, &frames, dt);
    rec.report().lines[0].clone()
}

#[test]
fn a_move_along_the_line_is_not_counted() {
    let mut w = still_world(Bounds::Open, &[Vec2::ZERO]);
    let mut rec =
        Measurements::new(&spec(vec![line("l", [0.0, 0.0], [0.0, 10.0])], vec![])).unwrap();
    let frames: Vec<Vec<Vec2>> = (0..10).map(|k| vec![Vec2::new(0.0, k as f32)]).collect();
    walk(&mut w, &mut rec, &frames, 0.1);
    // Beside the line's end, across its extension: not a crossing either.
    let mut rec2 =
        Measurements::new(&spec(vec![line("l", [0.0, 0.0], [0.0, 1.0])], vec![])).unwrap();
    let frames: Vec<Vec<Vec2>> = [-1.0, 1.0]
        .iter()
        .map(|&x| vec![Vec2::new(x, 2.0)])
        .collect();
    walk(&mut w, &mut rec2, &frames, 0.1);
    assert_eq!(rec.report().lines[0].total, 0);
    assert_eq!(rec2.report().lines[0].total, 0);
}

#[test]
fn a_constant_stream_gives_its_flow_and_time_gaps() {
    // Ten agents a metre apart walk at 2 m/s across a 2 m line: one every 0.5 s.
    let n = 10;
    let l = &stream_across_a_line(n, |_, x| x);
    assert_eq!(l.total, n);
    assert!((l.first_time.unwrap() - 0.125).abs() < 1e-5, "{l:?}");
    assert!((l.last_time.unwrap() - 4.625).abs() < 1e-5, "{l:?}");
    assert!((l.flow.unwrap() - 2.0).abs() < 1e-4, "{l:?}");
    assert!((l.specific_flow.unwrap() - 1.0).abs() < 1e-4, "{l:?}");
    assert!((l.time_gap_mean.unwrap() - 0.5).abs() < 1e-5, "{l:?}");
    assert!(l.time_gap_sd.unwrap() < 1e-4, "{l:?}");
    assert_eq!(l.length, 2.0);
}

#[test]
fn classic_density_and_mean_speed_of_a_known_arrangement() {
    // A 4 x 4 block at 1 m spacing inside a 4 m x 4 m square, two agents outside.
    let mut pos: Vec<Vec2> = (0..16)
        .map(|k| Vec2::new(0.5 + (k % 4) as f32, 0.5 + (k / 4) as f32))
        .collect();
    pos.extend([Vec2::new(10.0, 10.0), Vec2::new(-3.0, 1.0)]);
    let mut w = still_world(Bounds::Open, &pos);
    for (k, id) in w.agents().ids().to_vec().into_iter().enumerate() {
        // Speeds 1 m/s inside (half of them 3-4-5 diagonals scaled to 1), 9 m/s outside.
        let v = if k < 16 {
            if k % 2 == 0 {
                Vec2::new(1.0, 0.0)
            } else {
                Vec2::new(0.6, 0.8)
            }
        } else {
            Vec2::new(9.0, 0.0)
        };
        w.set_velocity(id, v).unwrap();
    }
    let square = MeasurementArea::new(
        "sq",
        [[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]]
            .map(Vec2::from)
            .to_vec(),
    )
    .unwrap();
    let empty = MeasurementArea::new(
        "empty",
        [[20.0, 20.0], [21.0, 20.0], [20.0, 21.0]]
            .map(Vec2::from)
            .to_vec(),
    )
    .unwrap();
    let mut rec = Measurements::new(&spec(vec![], vec![square, empty])).unwrap();
    rec.observe(&w);
    let f = rec.area_frames()[0];
    assert_eq!(f.count, 16);
    assert_eq!(f.density, 1.0);
    assert!((f.mean_speed.unwrap() - 1.0).abs() < 1e-6, "{f:?}");
    let r = rec.report();
    assert_eq!(r.areas[0].mean_density, Some(1.0));
    assert_eq!(r.areas[0].frames, 1);
    assert_eq!(r.areas[1].mean_density, Some(0.0));
    assert_eq!(r.areas[1].mean_speed, None, "nobody inside: no speed");
    assert_eq!(rec.area_frames()[1].count, 0);
}

#[test]
fn an_agent_removed_by_an_exit_is_counted_when_it_crossed() {
    // The agent is put beyond the door line, inside the exit: the step removes it, and the
    // recorder sees its last move through the world's departures.
    let mut w = still_world(Bounds::Open, &[Vec2::new(1.0, 0.5), Vec2::new(2.0, 0.5)]);
    w.add_exit(Exit::rect(Vec2::new(-5.0, -5.0), Vec2::new(-1.0, 5.0)))
        .unwrap();
    let door = line("door", [0.0, 1.0], [0.0, 0.0]);
    let mut rec = Measurements::new(&spec(vec![door], vec![])).unwrap();
    rec.observe(&w);
    let first = w.agents().id(0);
    w.set_position(first, Vec2::new(-2.0, 0.5)).unwrap();
    w.step(0.1).unwrap();
    assert_eq!(w.len(), 1, "the exit removed the first agent");
    assert_eq!(w.departures().len(), 1);
    rec.observe(&w);
    let r = rec.report();
    assert_eq!(r.lines[0].positive, 1, "{r:?}");
    assert_eq!(r.left, 1);
    assert_eq!(rec.evacuation_time(), None, "one agent is still inside");
    // The second leaves too: the world is empty, and the evacuation time is that step's.
    let second = w.agents().id(0);
    w.set_position(second, Vec2::new(-2.0, 0.5)).unwrap();
    w.step(0.1).unwrap();
    rec.observe(&w);
    assert_eq!(rec.report().lines[0].positive, 2);
    assert!((rec.evacuation_time().unwrap() - 0.2).abs() < 1e-6);
    // Observing the same frame again changes nothing.
    rec.observe(&w);
    assert_eq!(rec.report().lines[0].positive, 2);
    assert_eq!(rec.left(), 2);
}

#[test]
fn torus_moves_take_the_minimum_image() {
    let bounds = Bounds::torus(10.0, 10.0).unwrap();
    let mut w = still_world(bounds, &[Vec2::new(9.8, 5.0)]);
    let seam = line("seam", [0.5, 0.0], [0.5, 10.0]);
    let middle = line("middle", [5.0, 0.0], [5.0, 10.0]);
    let mut rec = Measurements::new(&spec(vec![seam, middle], vec![])).unwrap();
    let frames = vec![vec![Vec2::new(9.8, 5.0)], vec![Vec2::new(0.8, 5.0)]];
    walk(&mut w, &mut rec, &frames, 0.1);
    let r = rec.report();
    assert_eq!(
        r.lines[0].positive, 1,
        "the short hop over the seam crosses x = 0.5"
    );
    assert_eq!(
        r.lines[1].total, 0,
        "it does not sweep back across the world"
    );
}

#[test]
fn the_window_limits_the_summary_but_not_the_cumulative_counts() {
    let mut w = still_world(Bounds::Open, &[Vec2::new(-1.0, 1.0)]);
    let mut s = spec(vec![line("l", [0.0, 0.0], [0.0, 2.0])], vec![]);
    s.window = Some([0.22, 10.0]);
    let mut rec = Measurements::new(&s).unwrap();
    // Crossings at about 0.15 s (outside the window), then 0.25, 0.35, 0.45 and 0.55 s.
    let xs = [-1.0, -0.5, 0.5, -0.5, 0.5, -0.5, 0.5];
    let frames: Vec<Vec<Vec2>> = xs.iter().map(|&x| vec![Vec2::new(x, 1.0)]).collect();
    walk(&mut w, &mut rec, &frames, 0.1);
    let l = &rec.report().lines[0];
    assert_eq!(l.total, 4, "{l:?}");
    assert!(l.first_time.unwrap() >= 0.22);
    assert_eq!(rec.line_counts().collect::<Vec<_>>(), [(3, 2)]);
    let mut bad = s.clone();
    bad.window = Some([2.0, 1.0]);
    assert!(Measurements::new(&bad).is_err());
}

/// Line counts, per-frame area counts and the sorted crossing times of agents walking the
/// given paths, with the agents added in `order`.
fn measure_paths(paths: &[Vec<Vec2>], order: &[usize]) -> (Vec<(u64, u64)>, Vec<usize>, Vec<u64>) {
    let start: Vec<Vec2> = order.iter().map(|&k| paths[k][0]).collect();
    let mut w = still_world(Bounds::Open, &start);
    let area = MeasurementArea::new(
        "a",
        [[-2.0, -2.0], [2.0, -1.0], [1.0, 2.0], [-1.0, 1.5]]
            .map(Vec2::from)
            .to_vec(),
    )
    .unwrap();
    let s = spec(
        vec![
            line("x", [0.0, -3.0], [0.0, 3.0]),
            line("d", [-3.0, -3.0], [3.0, 3.0]),
        ],
        vec![area],
    );
    let mut rec = Measurements::new(&s).unwrap();
    let mut counts = Vec::new();
    let mut times = Vec::new();
    let frames = (0..paths[0].len()).map(|f| order.iter().map(|&k| paths[k][f]).collect());
    for (f, frame) in frames.enumerate() {
        let frame: Vec<Vec2> = frame;
        walk_one(&mut w, &mut rec, &frame, (f > 0).then_some(0.1));
        counts.push(rec.area_frames()[0].count);
        times.extend(rec.crossings().iter().map(|c| c.time.to_bits()));
    }
    times.sort_unstable();
    (rec.line_counts().collect(), counts, times)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn counts_do_not_depend_on_the_order_of_agents(
        paths in proptest::collection::vec(
            proptest::collection::vec((-3.0f32..3.0, -3.0f32..3.0), 6),
            1..12,
        ),
        seed in any::<u64>(),
    ) {
        let paths: Vec<Vec<Vec2>> = paths
            .into_iter()
            .map(|p| p.into_iter().map(|(x, y)| Vec2::new(x, y)).collect())
            .collect();
        let forward: Vec<usize> = (0..paths.len()).collect();
        let mut shuffled = forward.clone();
        // A seeded Fisher-Yates shuffle.
        let mut s = seed | 1;
        for i in (1..shuffled.len()).rev() {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            shuffled.swap(i, (s % (i as u64 + 1)) as usize);
        }
        prop_assert_eq!(measure_paths(&paths, &forward), measure_paths(&paths, &shuffled));
    }
}

/// The built-in evacuation at 300 agents (its file has a counting line in each door and the room
/// as an area), run until the room is empty on a pool of `threads`.
fn evacuation(threads: usize) -> (Measurements, usize) {
    let s = throng::scenario::builtin("evacuation")
        .unwrap()
        .with_agents(300)
        .unwrap();
    assert_eq!(s.measurements.lines.len(), 2, "a line in each door");
    let mut w = s.build().unwrap();
    let n = w.len();
    let mut rec = Measurements::new(&s.measurements).unwrap();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    rec.observe(&w);
    for _ in 0..s.steps {
        pool.install(|| w.step(s.dt)).unwrap();
        rec.observe(&w);
        if w.is_empty() {
            break;
        }
    }
    (rec, n)
}

#[test]
fn evacuation_door_crossings_equal_the_agents_that_left() {
    let (rec, n) = evacuation(2);
    let r = rec.report();
    let out: u64 = r.lines.iter().map(|l| l.positive).sum();
    let back: u64 = r.lines.iter().map(|l| l.negative).sum();
    assert_eq!(back, 0, "nobody walks back in: {r:?}");
    assert_eq!(out, r.left, "{r:?}");
    assert_eq!(r.left as usize, n, "everyone left: {r:?}");
    let t = rec.evacuation_time().expect("the room emptied");
    assert!(r.lines.iter().all(|l| l.last_time.unwrap() <= t));
    assert!(r.lines.iter().all(|l| l.flow.unwrap() > 0.0));
    assert_eq!(rec.inside(), 0);
    let room = &r.areas[0];
    assert!(room.mean_density.unwrap() > 0.0 && room.mean_speed.unwrap() > 0.0);
}

#[test]
fn measurements_do_not_depend_on_the_thread_count() {
    let (one, _) = evacuation(1);
    let (two, _) = evacuation(2);
    assert_eq!(one.report(), two.report());
    assert_eq!(one.evacuation_time(), two.evacuation_time());
}

const KEYS: &str = r#"
[world]
kind = "bounded"
size = [20, 10]
[[groups]]
count = 4
spawn = { kind = "rect", min = [1, 1], max = [3, 9] }
max_speed = 1.3
[measurements]
window = [1, 5]
[[measurements.lines]]
name = "door"
from = [10, 0]
to = [10, 10]
[[measurements.areas]]
name = "room"
polygon = [[0, 0], [10, 0], [10, 10], [0, 10]]
[[measurements.areas]]
name = "wkt"
polygon = "POLYGON ((10 0, 20 0, 20 10, 10 0))"
"#;

#[test]
fn scenario_keys_parse_and_errors_name_file_line_and_column() {
    let s = Scenario::from_toml(KEYS, "m.toml").unwrap();
    assert_eq!(s.measurements.lines[0].name, "door");
    assert_eq!(s.measurements.areas[0].area(), 100.0);
    assert_eq!(s.measurements.areas[1].polygon.len(), 3);
    assert_eq!(s.measurements.window, Some([1.0, 5.0]));
    // A serialised scenario reads back the same.
    let text = toml::to_string(&s).unwrap();
    assert_eq!(Scenario::from_toml(&text, "again.toml").unwrap(), s);

    let cases = [
        (
            KEYS.replace("[[0, 0], [10, 0], [10, 10], [0, 10]]", "[[0, 0], [10, 0]]"),
            "polygon",
        ),
        (
            KEYS.replace("to = [10, 10]", "to = [10, 10]\nwidth = 3"),
            "width",
        ),
        (KEYS.replace("name = \"wkt\"", "name = \"door\""), "twice"),
        (KEYS.replace("window = [1, 5]", "window = [5, 1]"), "window"),
        (
            KEYS.replace("name = \"door\"", "name = \"the door\""),
            "name",
        ),
        (
            KEYS.replace("10 0))", "10 0), (11 1, 12 1, 12 2, 11 1))"),
            "holes",
        ),
    ];
    for (text, needle) in cases {
        let msg = Scenario::from_toml(&text, "m.toml")
            .unwrap_err()
            .to_string();
        assert!(msg.starts_with("m.toml:"), "{needle}: {msg}");
        let location = msg.split(':').nth(1).and_then(|l| l.parse::<usize>().ok());
        assert!(
            location.is_some_and(|l| l >= 9),
            "{needle}: no line in {msg}"
        );
        assert!(msg.contains(needle), "{needle}: {msg}");
    }
}
