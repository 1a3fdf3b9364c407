//! Checkpoints: a world saved after N steps and loaded again (the command-line round trip is in
//! `cli/tests/checkpoint_cli.rs`) steps to the same bits as the world that never stopped, for every built-in
//! scenario and on 1 and 2 threads; a damaged checkpoint (cut at any byte, any byte changed) is
//! rejected with an error; a crafted one cannot put bad values into the world; files are
//! replaced whole or not at all.

use std::io::Write;
use std::path::PathBuf;

use throng::checkpoint::{
    CheckpointError, FORMAT_VERSION, HEADER_LEN, OLDEST_VERSION, RunInfo, write_atomic,
};
use throng::field::{FlowMetric, GoalChannels, OccupancyGrid, WalkPolicy};
use throng::gravity::{GravityPoint, Motion};
use throng::group::{FormationParams, Path, PathFollowParams, PathId};
use throng::obstacles::{Circle, Wall};
use throng::prelude::*;
use throng::scenario;

const N: u64 = 21;
const AGENTS: usize = 120;

#[path = "support/checkpoint.rs"]
mod support;
use support::{bits, saved};

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
}

fn steps(w: &mut World, n: u64, dt: f32) {
    for _ in 0..n {
        w.step(dt).unwrap();
    }
}

/// Runs 2N steps, and N steps + save + load + N steps, on `threads`; asserts the same bits and
/// the same saved state.
fn assert_resumes(name: &str, mut world: World, dt: f32, threads: usize) {
    let pool = pool(threads);
    let mut resumed = pool.install(|| {
        steps(&mut world, N, dt);
        World::load(&saved(&world)[..]).unwrap()
    });
    assert_eq!(
        saved(&resumed),
        saved(&world),
        "{name}: what is loaded saves the same"
    );
    assert_eq!(resumed.arrived_count(), world.arrived_count(), "{name}");
    pool.install(|| {
        steps(&mut world, N, dt);
        steps(&mut resumed, N, dt);
    });
    assert_eq!(world.frame(), 2 * N);
    assert_eq!(resumed.frame(), 2 * N, "{name}");
    assert_eq!(bits(&world), bits(&resumed), "{name} on {threads} threads");
    assert_eq!(
        saved(&world),
        saved(&resumed),
        "{name} on {threads} threads: the whole state"
    );
}

#[test]
fn every_builtin_scenario_resumes_bit_for_bit_on_one_and_two_threads() {
    for name in scenario::builtin_names() {
        let s = scenario::builtin(name)
            .unwrap()
            .with_agents(AGENTS)
            .unwrap();
        for threads in [1, 2] {
            assert_resumes(name, s.build().unwrap(), s.dt, threads);
        }
    }
}

/// A small world with one of everything a checkpoint holds: groups of both models with wander
/// and paths, a formation, removed agents (so ids and storage order differ), obstacles, moving
/// gravity points (one riding on an agent), a field with a dirty channel, goal shuffles, walkers
/// and arrivals.
fn everything_world(agents: usize) -> (World, f32) {
    let wander = Profile::dynamic(
        SteeringProfile::single(Behaviour::Wander {
            params: WanderParams::default(),
        })
        .with(
            Behaviour::FollowPath {
                path: PathId(0),
                params: PathFollowParams::default(),
            },
            1.0,
        ),
    );
    let flock = Profile::dynamic(
        SteeringProfile::single(Behaviour::Separation {
            hood: Neighbourhood::radius(3.0),
        })
        .with(
            Behaviour::Cohesion {
                hood: Neighbourhood::radius(6.0),
            },
            0.5,
        )
        .with(
            Behaviour::Wander {
                params: WanderParams::default(),
            },
            0.5,
        ),
    );
    let follow = Profile {
        max_speed: 3.0,
        ..Profile::kinematic(SteeringProfile::single(Behaviour::FollowField {
            field: 0,
            channel: 0,
        }))
    };
    let keep = Profile::dynamic(SteeringProfile::single(Behaviour::KeepFormation {
        params: Default::default(),
    }));
    let walk = Profile::kinematic(SteeringProfile::single(Behaviour::FollowField {
        field: 0,
        channel: 1,
    }));
    let mut b = World::builder()
        .bounds(Bounds::torus(32.0, 32.0).unwrap())
        .seed(99)
        .path(
            Path::new(
                vec![
                    Vec2::new(2.0, 2.0),
                    Vec2::new(28.0, 4.0),
                    Vec2::new(20.0, 28.0),
                ],
                1.5,
                true,
            )
            .unwrap(),
        )
        .group(wander)
        .group(flock)
        .group(follow)
        .group(keep)
        .group(walk);
    for i in 0..agents {
        let f = i as f32;
        let g = i % 5;
        b = b.agent(AgentInit {
            position: Vec2::new((f * 7.31 + 0.5) % 32.0, (f * 3.17 + 0.5) % 32.0),
            velocity: Vec2::new((f * 0.37).sin(), (f * 0.91).cos()),
            orientation: f * 0.1,
            max_speed: (i % 7 == 0).then_some(2.5),
            ..AgentInit::at(Vec2::ZERO, g)
        });
    }
    let mut w = b.build().unwrap();
    let keepers: Vec<AgentId> = (0..agents)
        .filter(|i| i % 5 == 3)
        .map(|i| AgentId(i as u32))
        .collect();
    w.add_formation(AgentId(0), FormationParams::default(), &keepers)
        .unwrap();
    for i in (0..agents).step_by(11).skip(1) {
        let _ = w.remove_agent(AgentId(i as u32));
    }
    w.add_circle(Circle {
        center: Vec2::new(16.2, 16.3),
        radius: 0.4,
    })
    .unwrap_or(());
    w.add_wall(Wall {
        a: Vec2::new(5.1, 20.2),
        b: Vec2::new(9.3, 24.4),
    })
    .unwrap();
    w.add_gravity_point(GravityPoint {
        motion: Motion::Orbit {
            center: Vec2::new(16.0, 16.0),
            orbit_radius: 6.0,
            angular_speed: 0.7,
        },
        ..GravityPoint::fixed(Vec2::new(16.0, 16.0), 5.0, 2.0, 4.0)
    })
    .unwrap();
    w.add_gravity_point(GravityPoint {
        motion: Motion::Agent { agent: AgentId(1) },
        ..GravityPoint::fixed(Vec2::ZERO, -3.0, 1.0, 5.0)
    })
    .unwrap();
    let grid = OccupancyGrid::new(16, 16)
        .unwrap()
        .with_geometry(2.0, Vec2::ZERO)
        .unwrap();
    let mut channels = GoalChannels::new(grid, 0.9, throng::field::Neighbourhood::Eight).unwrap();
    channels.add_channel(&[(3, 3)]).unwrap();
    channels.add_channel(&[(12, 12), (2, 13)]).unwrap();
    w.add_field(channels).unwrap();
    w.set_reorder_every(3);
    w.set_index(throng::IndexKind::Grid);
    w.shuffle_field_goals_every(0, 25, 2).unwrap();
    // Followers on their goal: arrived from the first step on.
    for p in [Vec2::new(7.0, 7.0), Vec2::new(6.5, 7.5)] {
        w.add_agent(AgentInit::at(p, 2)).unwrap();
    }
    w.add_walkers(0, 4, 1, WalkPolicy::Queue).unwrap();
    w.set_field_blocked(0, 8, 1, true).unwrap();
    (w, 0.05)
}

#[test]
fn a_world_with_everything_resumes_bit_for_bit() {
    for threads in [1, 2] {
        let (w, dt) = everything_world(60);
        assert_resumes("everything", w, dt, threads);
    }
    let (mut w, dt) = everything_world(60);
    steps(&mut w, N, dt);
    assert!(w.arrived_count() >= 2, "arrivals are part of the test");
}

#[test]
fn a_checkpoint_taken_before_the_first_step_resumes_too() {
    let (mut w, dt) = everything_world(40);
    let mut r = World::load(&saved(&w)[..]).unwrap();
    steps(&mut w, 13, dt);
    steps(&mut r, 13, dt);
    assert_eq!(saved(&w), saved(&r));
}

#[test]
fn run_settings_round_trip() {
    let (w, _) = everything_world(10);
    let run = RunInfo {
        scenario: "everything".into(),
        dt: 0.05,
        steps: 1000,
        checkpoint_every: 100,
    };
    let mut bytes = Vec::new();
    w.save_run(&run, &mut bytes).unwrap();
    let (_, back) = World::load_run(&bytes[..]).unwrap();
    assert_eq!(back, Some(run));
    assert_eq!(World::load_run(&saved(&w)[..]).unwrap().1, None);
}

fn checkpoint_error(bytes: &[u8]) -> CheckpointError {
    match World::load(bytes) {
        Err(Error::Checkpoint(e)) => e,
        Err(other) => panic!("not a checkpoint error: {other}"),
        Ok(_) => panic!("accepted"),
    }
}

/// The small world of the corruption tests (every byte of it is tried).
fn tiny() -> Vec<u8> {
    let (mut w, dt) = everything_world(12);
    steps(&mut w, 3, dt);
    saved(&w)
}

#[test]
fn a_checkpoint_cut_at_any_byte_is_rejected() {
    let bytes = tiny();
    assert!(World::load(&bytes[..]).is_ok());
    for cut in 0..bytes.len() {
        let e = checkpoint_error(&bytes[..cut]);
        assert!(
            matches!(e, CheckpointError::Truncated { .. }),
            "cut at {cut} of {}: {e}",
            bytes.len()
        );
    }
}

#[test]
fn a_checkpoint_with_any_byte_changed_is_rejected() {
    let bytes = tiny();
    for i in 0..bytes.len() {
        for flip in [0x01u8, 0x80, 0xff] {
            let mut b = bytes.clone();
            b[i] ^= flip;
            let e = checkpoint_error(&b);
            assert!(
                !matches!(
                    e,
                    CheckpointError::Invalid { .. } | CheckpointError::Decode(_)
                ),
                "byte {i} ^ {flip:#x} got past the checksum: {e}"
            );
        }
    }
}

#[test]
fn trailing_bytes_another_version_and_other_files_are_named() {
    let mut bytes = tiny();
    let mut longer = bytes.clone();
    longer.push(0);
    assert!(matches!(
        checkpoint_error(&longer),
        CheckpointError::TrailingBytes { extra: 1 }
    ));
    for version in [OLDEST_VERSION - 1, FORMAT_VERSION + 1] {
        bytes[8..12].copy_from_slice(&version.to_le_bytes());
        let e = checkpoint_error(&bytes);
        assert!(
            matches!(e, CheckpointError::UnsupportedVersion { found, .. } if found == version),
            "{e}"
        );
        assert!(e.to_string().contains(&format!("version {version}")), "{e}");
        let range = format!("versions {OLDEST_VERSION} to {FORMAT_VERSION}");
        assert!(e.to_string().contains(&range), "{e}");
    }
    let e = checkpoint_error(b"[world]\nsize = [10, 10]\n");
    assert!(matches!(e, CheckpointError::NotACheckpoint), "{e}");
    assert!(matches!(
        checkpoint_error(b""),
        CheckpointError::Truncated { .. }
    ));
}

/// Re-encodes a checkpoint's payload after `edit`, with a correct checksum: what a hostile file
/// looks like once it is past the integrity check.
fn crafted(bytes: &[u8], edit: impl FnOnce(&mut ciborium::Value)) -> Vec<u8> {
    let mut v: ciborium::Value = ciborium::from_reader(&bytes[HEADER_LEN..]).unwrap();
    edit(&mut v);
    let mut payload = Vec::new();
    ciborium::into_writer(&v, &mut payload).unwrap();
    let mut out = bytes[..HEADER_LEN].to_vec();
    out[12..20].copy_from_slice(&(payload.len() as u64).to_le_bytes());
    let mut c = crc32fast::Hasher::new();
    c.update(&out[..20]);
    c.update(&payload);
    out[20..24].copy_from_slice(&c.finalize().to_le_bytes());
    out.extend_from_slice(&payload);
    out
}

/// The value under `path` (map keys) of a decoded payload.
fn entry<'a>(v: &'a mut ciborium::Value, path: &[&str]) -> &'a mut ciborium::Value {
    let mut v = v;
    for key in path {
        let map = v.as_map_mut().expect("a map");
        v = &mut map
            .iter_mut()
            .find(|(k, _)| k.as_text() == Some(key))
            .unwrap_or_else(|| panic!("no key {key}"))
            .1;
    }
    v
}

#[test]
fn crafted_values_are_rejected_by_the_worlds_validation() {
    let bytes = tiny();
    assert!(World::load(&crafted(&bytes, |_| {}) as &[u8]).is_ok());
    type Edit = fn(&mut ciborium::Value);
    let cases: [(&str, Edit); 9] = [
        ("position", |v| {
            entry(v, &["world", "agents", "pos_x"])
                .as_array_mut()
                .unwrap()[0] = ciborium::Value::Float(f64::NAN);
        }),
        ("position", |v| {
            entry(v, &["world", "agents", "pos_y"])
                .as_array_mut()
                .unwrap()[1] = ciborium::Value::Float(1e9);
        }),
        ("max_speed", |v| {
            entry(v, &["world", "agents", "max_speed"])
                .as_array_mut()
                .unwrap()[2] = ciborium::Value::Float(-1.0);
        }),
        ("group", |v| {
            entry(v, &["world", "agents", "group"])
                .as_array_mut()
                .unwrap()[0] = ciborium::Value::Integer(77.into());
        }),
        ("listed twice", |v| {
            let ids = entry(v, &["world", "agents", "ids"])
                .as_array_mut()
                .unwrap();
            ids[1] = ids[0].clone();
        }),
        ("buffer", |v| {
            entry(v, &["world", "agents", "wander"])
                .as_array_mut()
                .unwrap()
                .pop();
        }),
        ("ids_issued", |v| {
            *entry(v, &["world", "ids_issued"]) = ciborium::Value::Integer(u32::MAX.into());
        }),
        // A target past the coordinate ceiling froze every agent that sought it.
        ("target", |v| {
            entry(v, &["world", "agents", "target_x"])
                .as_array_mut()
                .unwrap()[0] = ciborium::Value::Float(1e20);
        }),
        ("decay", |v| {
            let f = &mut entry(v, &["world", "fields"]).as_array_mut().unwrap()[0];
            *entry(f, &["decay"]) = ciborium::Value::Float(1.5);
        }),
    ];
    for (needle, edit) in cases {
        let e = checkpoint_error(&crafted(&bytes, edit));
        assert!(
            matches!(
                e,
                CheckpointError::Invalid { .. } | CheckpointError::Decode(_)
            ),
            "{e}"
        );
        assert!(e.to_string().contains(needle), "{needle}: {e}");
    }
}

/// A file whose agent carries a maximum speed other than its group's without the flag of an
/// own speed (a file no world writes) loads as if the agent had been given that speed: it
/// steers as in a world where it was (a speed above the group's, so that giving it truncates
/// no velocity).
#[test]
fn a_speed_other_than_the_groups_in_a_file_is_the_agents_own() {
    let flock = |n| {
        scenario::builtin("flock")
            .unwrap()
            .with_agents(n)
            .unwrap()
            .build()
            .unwrap()
    };
    let dt = 1.0 / 30.0;
    let mut w = flock(400);
    steps(&mut w, 2, dt);
    let bytes = saved(&w);
    let edited = crafted(&bytes, |v| {
        entry(v, &["world", "agents", "max_speed"])
            .as_array_mut()
            .unwrap()[5] = ciborium::Value::Float(5.5);
    });
    let mut loaded = World::load(&edited as &[u8]).unwrap();
    let id = w.agents().id(5);
    w.set_max_speed(id, 5.5).unwrap();
    steps(&mut w, 10, dt);
    steps(&mut loaded, 10, dt);
    assert_eq!(bits(&loaded), bits(&w));
}

/// A world with a walkable area and a rectangle and a polygon exit, saved: the file written
/// before walkable areas and polygon exits existed is this one without the `walkable` key and
/// with only rectangle exits, `{ min, max }`; it still loads, with no area.
#[test]
fn a_checkpoint_written_before_walkable_areas_and_polygon_exits_loads() {
    let mut world = World::builder()
        .group(Profile::default())
        .agent(AgentInit::at(Vec2::new(1.0, 1.0), 0))
        .build()
        .unwrap();
    let area = throng::Walkable::from_wkt("POLYGON ((0 0, 4 0, 4 4, 0 4, 0 0))").unwrap();
    world.set_walkable(area.clone()).unwrap();
    let rect = throng::world::Exit::rect(Vec2::new(3.0, 3.0), Vec2::new(4.0, 4.0));
    world.add_exit(rect.clone()).unwrap();
    world
        .add_exit(throng::world::Exit::polygon(
            throng::Walkable::from_wkt("POLYGON ((0 3, 1 3, 0 4, 0 3))").unwrap(),
        ))
        .unwrap();
    let bytes = saved(&world);
    let back = World::load(&bytes[..]).unwrap();
    assert_eq!(back.walkable(), Some(&area));
    assert_eq!(back.exits(), world.exits());
    let old = crafted(&bytes, |v| {
        let state = entry(v, &["world"]).as_map_mut().unwrap();
        state.retain(|(k, _)| k.as_text() != Some("walkable"));
        entry(v, &["world", "exits"]).as_array_mut().unwrap().pop();
    });
    let back = World::load(&old[..]).unwrap();
    assert_eq!(back.walkable(), None);
    assert_eq!(back.exits(), &[rect]);
    assert_eq!(back.obstacles().walls().len(), 4);
    // A damaged area is rejected by the same checks as a scenario's.
    let bad = crafted(&bytes, |v| {
        *entry(v, &["world", "walkable"]) =
            ciborium::Value::Text("POLYGON ((0 0, 4 0, 0 0))".into());
    });
    let e = checkpoint_error(&bad);
    assert!(e.to_string().contains("distinct points"), "{e}");
}

/// Every single-byte change of the payload, re-sealed with a valid checksum: loading gives an
/// error or a world whose buffers are finite and that steps without trouble.
#[test]
fn resealed_corruptions_never_panic_nor_load_bad_values() {
    let bytes = tiny();
    for i in HEADER_LEN..bytes.len() {
        let mut b = bytes.clone();
        b[i] ^= 0x5a;
        let b = crafted_raw(&b);
        if let Ok(mut w) = World::load(&b[..]) {
            let a = w.agents();
            let all = [a.pos_x(), a.pos_y(), a.vel_x(), a.vel_y(), a.orientations()];
            assert!(
                all.iter().all(|s| s.iter().all(|x| x.is_finite())),
                "byte {i}"
            );
            for _ in 0..2 {
                let _ = w.step(0.05);
            }
        }
    }
}

/// `bytes` with the header's length and checksum made to match its payload.
fn crafted_raw(bytes: &[u8]) -> Vec<u8> {
    let mut out = bytes.to_vec();
    let len = (out.len() - HEADER_LEN) as u64;
    out[12..20].copy_from_slice(&len.to_le_bytes());
    let mut c = crc32fast::Hasher::new();
    c.update(&out[..20]);
    c.update(&out[HEADER_LEN..]);
    out[20..24].copy_from_slice(&c.finalize().to_le_bytes());
    out
}

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("throng-ckpt-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A writer that fails after `left` bytes, as a full disk does.
struct FailingWriter<'a> {
    inner: &'a mut dyn Write,
    left: usize,
}

impl Write for FailingWriter<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.left == 0 {
            return Err(std::io::Error::other("disk full"));
        }
        let n = buf.len().min(self.left);
        self.left -= n;
        self.inner.write(&buf[..n])
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

#[test]
fn a_failed_write_leaves_the_previous_checkpoint_intact() {
    let dir = tmp_dir("atomic");
    let path = dir.join("run.ckpt");
    let (mut w, dt) = everything_world(30);
    w.save_file(&path, None).unwrap();
    let before = std::fs::read(&path).unwrap();
    steps(&mut w, 5, dt);
    let size = saved(&w).len();
    for left in [0, 1, HEADER_LEN, size / 2, size - 1] {
        let r = write_atomic(&path, |out| w.save(FailingWriter { inner: out, left }));
        assert!(r.is_err(), "{left}");
        assert_eq!(
            std::fs::read(&path).unwrap(),
            before,
            "cut after {left} bytes"
        );
        let names: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
        assert_eq!(names.len(), 1, "the temporary file is removed");
    }
    // The one that succeeds replaces it whole.
    w.save_file(&path, None).unwrap();
    let (r, _) = World::load_file(&path).unwrap();
    assert_eq!(bits(&r), bits(&w));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A walkable corner whose field follows the geodesic distance (`metric = "euclidean"`).
const EUCLIDEAN_CORNER: &str = r#"
name = "corner"
seed = 3
dt = 0.05
[geometry]
walkable = "POLYGON ((0 0, 12 0, 12 12, 8 12, 8 4, 0 4, 0 0))"
[field]
cell_size = 0.5
metric = "euclidean"
[[exits]]
min = [8, 11.5]
max = [12, 12]
[[groups]]
count = 30
spawn = { kind = "grid", origin = [0.5, 0.5], spacing = [0.6, 0.6], columns = 5 }
radius = 0.2
max_speed = 1.5
steering = { behaviours = [{ kind = "follow_field", field = 0, channel = 0 }] }
"#;

#[test]
fn a_euclidean_field_resumes_bit_for_bit_and_older_files_follow_the_steps() {
    let s = scenario::Scenario::from_toml(EUCLIDEAN_CORNER, "corner").unwrap();
    for threads in [1, 2] {
        assert_resumes("corner", s.build().unwrap(), s.dt, threads);
    }
    let world = s.build().unwrap();
    let bytes = saved(&world);
    let back = World::load(&bytes[..]).unwrap();
    assert_eq!(back.field(0).unwrap().metric(), FlowMetric::Euclidean);
    // Files written before the metric existed followed the BFS steps.
    let old = crafted(&bytes, |v| {
        let fields = entry(v, &["world", "fields"]).as_array_mut().unwrap();
        fields[0]
            .as_map_mut()
            .unwrap()
            .retain(|(k, _)| k.as_text() != Some("metric"));
    });
    let back = World::load(&old[..]).unwrap();
    assert_eq!(back.field(0).unwrap().metric(), FlowMetric::Steps);
}

#[test]
fn a_quickest_field_resumes_bit_for_bit_with_its_costs() {
    // Reroutes every 7 frames: the checkpoints fall between reroutes, so the costs in force
    // must come from the file.
    let text = EUCLIDEAN_CORNER.replace(
        "metric = \"euclidean\"",
        "metric = \"quickest\"\nreroute_every = 7\ndensity_radius = 0.75",
    );
    let s = scenario::Scenario::from_toml(&text, "corner").unwrap();
    for threads in [1, 2] {
        assert_resumes("quickest corner", s.build().unwrap(), s.dt, threads);
    }
    let mut world = s.build().unwrap();
    world.step(s.dt).unwrap();
    let costs = world.field(0).unwrap().costs().to_vec();
    assert!(costs.iter().any(|&c| c > 1.0), "the crowd costs something");
    let back = World::load(&saved(&world)[..]).unwrap();
    assert_eq!(back.field(0).unwrap().costs(), &costs[..]);
    // A cost outside [1, 20] in the file is rejected.
    let bad = crafted(&saved(&world), |v| {
        let fields = entry(v, &["world", "fields"]).as_array_mut().unwrap();
        let costs = fields[0]
            .as_map_mut()
            .unwrap()
            .iter_mut()
            .find(|(k, _)| k.as_text() == Some("costs"))
            .unwrap();
        costs.1.as_array_mut().unwrap()[0] = ciborium::Value::Float(0.5);
    });
    assert!(checkpoint_error(&bad).to_string().contains("cost"));
}

#[test]
fn a_clearance_cost_resumes_bit_for_bit_and_older_files_have_none() {
    // The clearance's costs multiply the crowd's, rerouted every 7 frames.
    let text = EUCLIDEAN_CORNER.replace(
        "metric = \"euclidean\"",
        "metric = \"quickest\"\nreroute_every = 7\nclearance = 0.5\nclearance_cost = 4",
    );
    let s = scenario::Scenario::from_toml(&text, "corner").unwrap();
    for threads in [1, 2] {
        assert_resumes("clearance cost", s.build().unwrap(), s.dt, threads);
    }
    let mut world = s.build().unwrap();
    world.step(s.dt).unwrap();
    assert_eq!(world.field(0).unwrap().clearance_cost(), Some((0.5, 4.0)));
    let back = World::load(&saved(&world)[..]).unwrap();
    assert_eq!(back.field(0).unwrap().clearance_cost(), Some((0.5, 4.0)));
    let old = crafted(&saved(&world), |v| {
        let fields = entry(v, &["world", "fields"]).as_array_mut().unwrap();
        fields[0]
            .as_map_mut()
            .unwrap()
            .retain(|(k, _)| k.as_text() != Some("clearance_cost"));
    });
    assert_eq!(
        World::load(&old[..])
            .unwrap()
            .field(0)
            .unwrap()
            .clearance_cost(),
        None
    );
}

#[test]
fn exit_choices_resume_bit_for_bit_and_older_files_have_none() {
    // Two exits, one channel each, chosen with no inertia and rerouted every 7 frames, so that
    // the choices in force at a checkpoint must come from the file.
    let text = EUCLIDEAN_CORNER
        .replace(
            "metric = \"euclidean\"",
            "metric = \"quickest\"\nreroute_every = 7\nchannels = [{ exit = 0 }, { exit = 1 }]",
        )
        .replace(
            "max = [12, 12]\n",
            "max = [12, 12]\n[[exits]]\nmin = [11.5, 0]\nmax = [12, 4]\n",
        )
        .replace(
            "{ kind = \"follow_field\", field = 0, channel = 0 }",
            "{ kind = \"choose_exit\", switch_gain = 0 }",
        );
    let s = scenario::Scenario::from_toml(&text, "corner").unwrap();
    for threads in [1, 2] {
        assert_resumes("exit choice", s.build().unwrap(), s.dt, threads);
    }
    let mut world = s.build().unwrap();
    world.step(s.dt).unwrap();
    let back = World::load(&saved(&world)[..]).unwrap();
    for &id in world.agents().ids() {
        assert!(world.chosen_channel(id).is_some());
        assert_eq!(back.chosen_channel(id), world.chosen_channel(id), "{id:?}");
    }
    let old = crafted(&saved(&world), |v| {
        entry(v, &["world"])
            .as_map_mut()
            .unwrap()
            .retain(|(k, _)| k.as_text() != Some("chosen"));
    });
    let back = World::load(&old[..]).unwrap();
    assert!(
        back.agents()
            .ids()
            .iter()
            .all(|&id| back.chosen_channel(id).is_none())
    );
    // A file naming a channel the field does not have: those agents choose again.
    let odd = crafted(&saved(&world), |v| {
        for pair in entry(v, &["world", "chosen"]).as_array_mut().unwrap() {
            pair.as_array_mut().unwrap()[1] = ciborium::Value::Integer(5.into());
        }
    });
    let mut back = World::load(&odd[..]).unwrap();
    let ids = back.agents().ids().to_vec();
    assert!(ids.iter().all(|&id| back.chosen_channel(id) == Some(5)));
    back.step(s.dt).unwrap();
    for id in ids {
        assert!(back.chosen_channel(id).is_some_and(|c| c < 2), "{id:?}");
    }
}

/// Every `key` taken out of a decoded payload, at any depth.
fn without_key(v: &mut ciborium::Value, key: &str) {
    if let Some(map) = v.as_map_mut() {
        map.retain(|(k, _)| k.as_text() != Some(key));
        map.iter_mut().for_each(|(_, v)| without_key(v, key));
    } else if let Some(items) = v.as_array_mut() {
        items.iter_mut().for_each(|v| without_key(v, key));
    }
}

/// The built-in bottleneck with 60 agents, the speed model's parameters of every group changed
/// by `tweak`, after 40 steps, and its step.
fn bottleneck_of_an_older_version(tweak: fn(&mut throng::ped::Cfsm)) -> (World, f32) {
    let mut s = scenario::builtin("bottleneck")
        .unwrap()
        .with_agents(60)
        .unwrap();
    for g in &mut s.groups {
        let ped = g.params.pedestrian.as_mut().unwrap();
        let throng::ped::ModelParams::Cfsm(cf) = &mut ped.params else {
            panic!("the bottleneck walks by the speed model");
        };
        tweak(cf);
    }
    let mut world = s.build().unwrap();
    steps(&mut world, 40, s.dt);
    (world, s.dt)
}

#[test]
fn a_version_1_file_resumes_without_the_pressed_anisotropy_as_it_would_have() {
    // A version 1 world stepped with the anisotropy the same under pressure as without, and
    // with the strip of every file before version 3.
    let (mut world, dt) = bottleneck_of_an_older_version(|cf| {
        cf.pressed_anisotropy = cf.anisotropy;
        cf.path_width = 1.0;
    });
    let bytes = saved(&world);
    let pressed = |w: &World| match w.groups()[0].pedestrian.unwrap().params {
        throng::ped::ModelParams::Cfsm(cf) => (cf.anisotropy, cf.pressed_anisotropy),
        _ => unreachable!(),
    };
    // A version 2 file without the key takes the default, 0.
    let new = crafted(&bytes, |v| without_key(v, "pressed_anisotropy"));
    assert_eq!(pressed(&World::load(&new[..]).unwrap()), (1.0, 0.0));
    // A version 1 file takes it equal to the anisotropy and steps to the same bits.
    let mut old = bytes.clone();
    old[8..12].copy_from_slice(&1u32.to_le_bytes());
    let old = crafted(&old, |v| without_key(v, "pressed_anisotropy"));
    let mut resumed = World::load(&old[..]).unwrap();
    assert_eq!(pressed(&resumed), (1.0, 1.0));
    steps(&mut world, 60, dt);
    steps(&mut resumed, 60, dt);
    assert_eq!(bits(&world), bits(&resumed));
    // Written again, it is a file of this version that keeps the value.
    let again = saved(&resumed);
    assert_eq!(again[8..12], FORMAT_VERSION.to_le_bytes());
    assert_eq!(pressed(&World::load(&again[..]).unwrap()), (1.0, 1.0));
}

#[test]
fn a_version_2_file_resumes_with_the_strip_it_stepped_with() {
    // A version 2 world stepped with the paper's strip, path width 1, its groups' and the
    // first agent's own parameters (a longer time gap) alike.
    let (mut world, dt) = bottleneck_of_an_older_version(|cf| cf.path_width = 1.0);
    let first = world.agents().id(0);
    let own = match world.agent_model_params(first).unwrap() {
        Some(throng::ped::ModelParams::Cfsm(cf)) => throng::ped::Cfsm {
            time_gap: 1.3,
            ..cf
        },
        _ => unreachable!(),
    };
    world
        .set_agent_model_params(first, Some(throng::ped::ModelParams::Cfsm(own)))
        .unwrap();
    let bytes = saved(&world);
    let width = |w: &World| match w.groups()[0].pedestrian.unwrap().params {
        throng::ped::ModelParams::Cfsm(cf) => cf.path_width,
        _ => unreachable!(),
    };
    // A file of this version without the key takes the default.
    let new = crafted(&bytes, |v| without_key(v, "path_width"));
    assert_eq!(
        width(&World::load(&new[..]).unwrap()),
        throng::ped::Cfsm::default().path_width
    );
    assert_ne!(throng::ped::Cfsm::default().path_width, 1.0);
    // A version 2 file takes the strip and steps to the same bits.
    let mut old = bytes.clone();
    old[8..12].copy_from_slice(&2u32.to_le_bytes());
    let old = crafted(&old, |v| without_key(v, "path_width"));
    let mut resumed = World::load(&old[..]).unwrap();
    assert_eq!(width(&resumed), 1.0);
    assert_eq!(
        resumed.agent_model_params(first).unwrap(),
        Some(throng::ped::ModelParams::Cfsm(own))
    );
    steps(&mut world, 60, dt);
    steps(&mut resumed, 60, dt);
    assert_eq!(bits(&world), bits(&resumed));
}

#[test]
fn an_older_file_without_the_reference_speed_reads_it_as_off() {
    // The first version 1 files had no `reference_speed`: they stepped with the time gaps as
    // given, 0; a file of this version without the key takes the default.
    let (world, _) = bottleneck_of_an_older_version(|_| {});
    let bytes = saved(&world);
    let speed = |w: &World| match w.groups()[0].pedestrian.unwrap().params {
        throng::ped::ModelParams::Cfsm(cf) => cf.reference_speed,
        _ => unreachable!(),
    };
    let default = throng::ped::Cfsm::default().reference_speed;
    assert_ne!(default, 0.0);
    let new = crafted(&bytes, |v| without_key(v, "reference_speed"));
    assert_eq!(speed(&World::load(&new[..]).unwrap()), default);
    for version in [1u32, 2] {
        let mut old = bytes.clone();
        old[8..12].copy_from_slice(&version.to_le_bytes());
        let old = crafted(&old, |v| without_key(v, "reference_speed"));
        assert_eq!(
            speed(&World::load(&old[..]).unwrap()),
            0.0,
            "version {version}"
        );
    }
}
