//! The real `throng` binary: every built-in scenario runs, `bench --json` holds every key with
//! sane values, trajectories have one row per agent per written frame, and bad input gets a
//! non-zero exit with a one-line message.

use std::process::{Command, Output};

mod common;
use common::{assert_one_line_failure, stderr, stdout, throng, tmp};

#[test]
fn list_names_every_builtin_scenario() {
    let o = throng(&["list"]);
    assert!(o.status.success());
    let out = stdout(&o);
    for name in [
        "seek",
        "arrive",
        "wander",
        "flock",
        "antigravity",
        "pursuit",
        "obstacles",
        "fields",
        "path",
        "leader",
        "formation",
        "city",
    ] {
        assert!(
            out.lines()
                .any(|l| l.split_whitespace().next() == Some(name)),
            "`throng list` lacks {name}:\n{out}"
        );
    }
}

#[test]
fn every_builtin_scenario_runs_a_few_steps() {
    for (name, _) in throng::scenario::BUILTIN {
        let o = throng(&[
            "demo",
            name,
            "--agents",
            "300",
            "--steps",
            "4",
            "--every",
            "2",
            "--threads",
            "2",
        ]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        let out = stdout(&o);
        let frames = out.lines().filter(|l| l.starts_with("frame")).count();
        assert_eq!(
            frames, 2,
            "{name}: two timing lines for 4 steps every 2:\n{out}"
        );
        assert!(
            out.lines().any(|l| l.starts_with("summary:")
                && l.contains("median")
                && l.contains("p99")
                && l.contains("agent-steps/s")),
            "{name}:\n{out}"
        );
    }
}

#[test]
fn bench_json_has_every_key_with_sane_values() {
    let o = throng(&[
        "bench",
        "flock",
        "--agents",
        "2000",
        "--steps",
        "5",
        "--warmup",
        "2",
        "--threads",
        "2",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).expect("one JSON object");
    assert_eq!(v["scenario"], "flock");
    assert_eq!(v["agents"], 2000);
    assert_eq!(v["threads"], 2);
    assert_eq!(v["index"], "grid");
    assert_eq!(v["steps"], 5);
    let ms = &v["ms_per_step"];
    for k in ["median", "mean", "p95", "min", "max"] {
        assert!(ms[k].as_f64().unwrap() > 0.0, "ms_per_step.{k}");
    }
    assert!(
        ms["min"].as_f64() <= ms["median"].as_f64() && ms["median"].as_f64() <= ms["max"].as_f64()
    );
    for k in ["index", "steer", "integrate", "bounds"] {
        assert!(v["phases_ms"][k].as_f64().unwrap() >= 0.0, "phases_ms.{k}");
    }
    assert!(v["agent_steps_per_sec"].as_f64().unwrap() > 1000.0);
    let nb = v["mean_neighbours"].as_f64().unwrap();
    assert!(
        (10.0..30.0).contains(&nb),
        "flock density gives about 18 neighbours, got {nb}"
    );
    assert!(v["peak_rss_mb"].as_f64().unwrap() > 1.0);

    let kd = throng(&[
        "bench", "flock", "--agents", "500", "--steps", "2", "--index", "kdtree", "--json",
    ]);
    let v: serde_json::Value = serde_json::from_str(stdout(&kd).trim()).unwrap();
    assert_eq!(v["index"], "kdtree");
}

#[test]
fn trajectories_have_one_row_per_agent_per_written_frame() {
    let csv = tmp("traj.csv");
    let o = throng(&[
        "demo",
        "pursuit",
        "--agents",
        "50",
        "--steps",
        "10",
        "--every",
        "5",
        "--quiet",
        "--trajectories",
        csv.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    // The old columns first and unchanged, the group appended last.
    assert_eq!(lines.next(), Some("frame,t,id,x,y,vx,vy,heading,group"));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    // Frames 0, 5 and 10.
    assert_eq!(rows.len(), 50 * 3);
    for r in &rows {
        assert_eq!(r.len(), 9);
        for f in r {
            assert!(f.parse::<f64>().is_ok_and(f64::is_finite), "{r:?}");
        }
    }
    let frames: std::collections::BTreeSet<&str> = rows.iter().map(|r| r[0]).collect();
    assert_eq!(frames.into_iter().collect::<Vec<_>>(), ["0", "10", "5"]);
    let ids: std::collections::BTreeSet<&str> = rows.iter().map(|r| r[2]).collect();
    assert_eq!(ids.len(), 50, "stable ids");
    // Prey and predators told apart by the group column.
    let groups: std::collections::BTreeSet<&str> = rows.iter().map(|r| r[8]).collect();
    assert_eq!(groups.into_iter().collect::<Vec<_>>(), ["0", "1"]);
}

#[test]
fn bad_input_gets_a_non_zero_exit_and_one_line() {
    assert_one_line_failure(&["demo", "no-such-scenario"], "unknown scenario");
    assert_one_line_failure(&["demo", "flock", "--agents", "abc"], "--agents");
    assert_one_line_failure(&["demo", "flock", "--agents", "0"], "agents");
    assert_one_line_failure(&["demo", "flock", "--dt", "-1"], "dt");
    assert_one_line_failure(&["demo", "flock", "--dt", "NaN"], "dt");
    assert_one_line_failure(&["demo", "flock", "--threads", "0"], "threads");
    assert_one_line_failure(&["demo", "flock", "--index", "octree"], "--index");
    assert_one_line_failure(&["demo", "flock", "--every", "0"], "every");
    // Nothing in a flock can arrive: --until-arrived ran every step without a word.
    assert_one_line_failure(
        &["demo", "flock", "--agents", "20", "--until-arrived"],
        "no goal to arrive at",
    );
    assert_one_line_failure(&["run", "/no/such/file.toml"], "/no/such/file.toml");
    assert_one_line_failure(
        &[
            "demo",
            "wander",
            "--steps",
            "2",
            "--trajectories",
            "/no/such/dir/t.csv",
        ],
        "/no/such/dir/t.csv",
    );

    let bad_key = tmp("bad_key.toml");
    std::fs::write(&bad_key, "name = \"x\"\n[world]\nkind = \"torus\"\nsize = [10, 10]\nbogus = 3\n[[groups]]\ncount = 2\n").unwrap();
    assert_one_line_failure(&["run", bad_key.to_str().unwrap()], "bad_key.toml:5:");

    let bad_value = tmp("bad_value.toml");
    std::fs::write(
        &bad_value,
        "[world]\nkind = \"torus\"\nsize = [10, 10]\n[[groups]]\ncount = 2\nmass = 0\n",
    )
    .unwrap();
    assert_one_line_failure(&["run", bad_value.to_str().unwrap()], "mass");

    assert_one_line_failure(&["bench", "flock", "--steps", "0", "--json"], "steps");
    assert_one_line_failure(&["demo", "flock", "--agents", "1000000000000"], "agents");
    assert_one_line_failure(
        &[
            "demo",
            "wander",
            "--steps",
            "2",
            "--size",
            "0",
            "--render",
            tmp("s.png").to_str().unwrap(),
        ],
        "size",
    );

    let fixed = tmp("fixed.toml");
    std::fs::write(&fixed, "[world]\nkind = \"torus\"\nsize = [10, 10]\n[[groups]]\nspawn = { kind = \"points\", points = [[1, 1], [2, 2]] }\n").unwrap();
    assert_one_line_failure(
        &["run", fixed.to_str().unwrap(), "--agents", "100"],
        "fixed count",
    );

    let outside = tmp("outside.toml");
    std::fs::write(&outside, "[world]\nkind = \"bounded\"\nsize = [50, 50]\n[[groups]]\ncount = 5\nspawn = { kind = \"rect\", min = [600, 600], max = [700, 700] }\n").unwrap();
    assert_one_line_failure(&["run", outside.to_str().unwrap()], "outside the world");

    let bad_syntax = tmp("bad_syntax.toml");
    std::fs::write(&bad_syntax, "[world\nkind = 1\n").unwrap();
    assert_one_line_failure(&["run", bad_syntax.to_str().unwrap()], "bad_syntax.toml:1:");
}

#[test]
fn every_builtin_is_a_runnable_file() {
    for (name, text) in throng::scenario::BUILTIN {
        let path = tmp(&format!("{name}.toml"));
        std::fs::write(&path, text).unwrap();
        let o = throng(&[
            "run",
            path.to_str().unwrap(),
            "--agents",
            "200",
            "--steps",
            "2",
            "--quiet",
        ]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
    }
}

#[cfg(feature = "render")]
#[test]
fn render_writes_a_gif_and_a_png_of_the_stated_size_and_frame_count() {
    let gif_path = tmp("run.gif");
    // A square world: 300 x 300 pixels; frames 0, 4, 8 and 12.
    let o = throng(&[
        "demo",
        "wander",
        "--agents",
        "500",
        "--steps",
        "12",
        "--every",
        "4",
        "--size",
        "300",
        "--quiet",
        "--render",
        gif_path.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut options = gif::DecodeOptions::new();
    options.set_color_output(gif::ColorOutput::Indexed);
    let mut decoder = options
        .read_info(std::fs::File::open(&gif_path).unwrap())
        .unwrap();
    assert_eq!((decoder.width(), decoder.height()), (300, 300));
    let mut frames = 0;
    while let Some(frame) = decoder.read_next_frame().unwrap() {
        assert_eq!((frame.width, frame.height), (300, 300));
        frames += 1;
    }
    assert_eq!(frames, 4);

    let png_path = tmp("last.png");
    let o = throng(&[
        "demo",
        "obstacles",
        "--agents",
        "300",
        "--steps",
        "3",
        "--size",
        "240",
        "--quiet",
        "--render",
        png_path.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let decoder = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(&png_path).unwrap(),
    ));
    let reader = decoder.read_info().unwrap();
    let info = reader.info();
    assert_eq!((info.width, info.height), (240, 240));

    assert_one_line_failure(
        &[
            "demo",
            "wander",
            "--steps",
            "2",
            "--render",
            tmp("x.bmp").to_str().unwrap(),
        ],
        ".gif",
    );
}

/// Runs `throng` with its stdout going to `stdout`.
fn throng_to(args: &[&str], stdout: std::process::Stdio) -> Output {
    Command::new(env!("CARGO_BIN_EXE_throng"))
        .args(args)
        .stdout(stdout)
        .stderr(std::process::Stdio::piped())
        .output()
        .expect("run throng")
}

#[test]
fn a_closed_stdout_pipe_ends_quietly_with_status_0() {
    for args in [
        &["list"][..],
        &[
            "demo", "flock", "--agents", "200", "--steps", "6", "--every", "1",
        ][..],
        &[
            "bench", "wander", "--agents", "100", "--steps", "2", "--json",
        ][..],
    ] {
        // The reading end is closed before the program starts, so every write meets a broken pipe.
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        let o = throng_to(args, writer.into());
        assert!(
            o.status.success(),
            "{args:?}: {:?} {}",
            o.status,
            stderr(&o)
        );
        assert_eq!(stderr(&o), "", "{args:?}");
    }
}

#[test]
fn a_full_disk_is_a_one_line_error() {
    let full = || {
        std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap()
    };
    for args in [
        &["list"][..],
        &["demo", "wander", "--agents", "50", "--steps", "2"][..],
    ] {
        let o = throng_to(args, full().into());
        assert_eq!(o.status.code(), Some(1), "{args:?}: {}", stderr(&o));
        let err = stderr(&o);
        assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains("No space left"), "{args:?}: {err}");
    }
    assert_one_line_failure(
        &[
            "demo",
            "wander",
            "--agents",
            "500",
            "--steps",
            "2",
            "--quiet",
            "--trajectories",
            "/dev/full",
        ],
        "/dev/full",
    );
}

#[test]
fn output_paths_are_checked_before_the_run() {
    // A missing folder is found before the first step, not after the last.
    let o = throng(&[
        "demo",
        "wander",
        "--agents",
        "50",
        "--steps",
        "3",
        "--render",
        "no-such-folder-xyz/x.png",
    ]);
    assert!(!o.status.success());
    assert_eq!(stdout(&o), "", "nothing ran");
    assert!(stderr(&o).contains("no-such-folder-xyz"), "{}", stderr(&o));

    // The scenario file itself is never an output.
    let input = tmp("input.toml");
    let text = throng::scenario::BUILTIN[2].1;
    std::fs::write(&input, text).unwrap();
    for flag in ["--trajectories", "--render"] {
        let o = throng(&[
            "run",
            input.to_str().unwrap(),
            "--steps",
            "2",
            flag,
            input.to_str().unwrap(),
        ]);
        assert!(!o.status.success(), "{flag}");
        assert!(stderr(&o).contains("input"), "{flag}: {}", stderr(&o));
        assert_eq!(std::fs::read_to_string(&input).unwrap(), text, "{flag}");
    }

    // Two outputs into one file would interleave into garbage.
    let both = tmp("both.gif");
    let o = throng(&[
        "demo",
        "wander",
        "--agents",
        "50",
        "--steps",
        "2",
        "--render",
        both.to_str().unwrap(),
        "--trajectories",
        both.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("same file"), "{}", stderr(&o));
    assert!(!both.exists());
}

#[test]
fn the_last_frame_is_always_written() {
    let csv = tmp("last_frame.csv");
    let o = throng(&[
        "demo",
        "wander",
        "--agents",
        "20",
        "--steps",
        "7",
        "--every",
        "3",
        "--quiet",
        "--trajectories",
        csv.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&csv).unwrap();
    let frames: std::collections::BTreeSet<u64> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(frames.into_iter().collect::<Vec<_>>(), [0, 3, 6, 7]);
}

#[test]
fn a_killed_run_leaves_the_previous_output_intact() {
    let dir = tmp("killed");
    std::fs::create_dir_all(&dir).unwrap();
    let csv = dir.join("t.csv");
    std::fs::write(&csv, "previous\n").unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_throng"))
        .args([
            "demo",
            "wander",
            "--agents",
            "2000",
            "--steps",
            "100000000",
            "--every",
            "1",
            "--quiet",
            "--trajectories",
            csv.to_str().unwrap(),
        ])
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Wait until the run is writing rows, then kill it.
    let started = std::time::Instant::now();
    let writing = || {
        std::fs::read_dir(&dir).unwrap().any(|e| {
            let e = e.unwrap();
            e.path() != csv && e.metadata().unwrap().len() > 100_000
        }) || std::fs::metadata(&csv).unwrap().len() > 100_000
    };
    while !writing() && started.elapsed().as_secs() < 20 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert_eq!(std::fs::read_to_string(&csv).unwrap(), "previous\n");
}

#[test]
fn thread_counts_beyond_the_ceiling_are_refused() {
    for t in ["5000", "100000", "18446744073709551615"] {
        assert_one_line_failure(&["demo", "flock", "--threads", t], "threads");
    }
}

#[test]
fn orca_runs_report_arrivals_and_stop_when_everyone_arrived() {
    // Not all of a 40-agent circle arrives in 20 steps: `all_arrived_step` is null.
    let o = throng(&[
        "bench", "circle", "--agents", "40", "--steps", "20", "--warmup", "0", "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).expect("one JSON object");
    assert!(v["all_arrived_step"].is_null(), "{v}");
    assert!(v["arrived"].as_u64().unwrap() < 40);
    // Run to completion: the summary names the frame, and the run stops there.
    let o = throng(&[
        "demo",
        "circle",
        "--agents",
        "40",
        "--steps",
        "5000",
        "--until-arrived",
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    let frame: u64 = out
        .split("all at frame ")
        .nth(1)
        .and_then(|r| r.trim_end_matches([')', '\n']).parse().ok())
        .unwrap_or_else(|| panic!("no arrival frame in {out}"));
    assert!(out.contains(&format!("summary: {frame} steps")), "{out}");
    assert!(out.contains("arrived 40/40"), "{out}");
}

/// A small scenario with a door line, an area and an exit beyond the door.
const MEASURED: &str = r#"
name = "measured"
dt = 0.1
steps = 200
[world]
kind = "bounded"
size = [20, 10]
[[groups]]
count = 20
spawn = { kind = "rect", min = [1, 1], max = [6, 9] }
model = "kinematic"
max_speed = 1.3
steering = { behaviours = [{ kind = "seek", target = { point = [19.5, 5] } }] }
[[exits]]
min = [18, 0]
max = [20, 10]
[measurements]
[[measurements.lines]]
name = "door"
from = [15, 0]
to = [15, 10]
[[measurements.areas]]
name = "room"
polygon = [[0, 0], [10, 0], [10, 10], [0, 10]]
"#;

#[test]
fn measurements_write_one_row_per_frame_and_a_summary() {
    let input = tmp("measured.toml");
    std::fs::write(&input, MEASURED).unwrap();
    let csv = tmp("measured.csv");
    let o = throng(&[
        "run",
        input.to_str().unwrap(),
        "--quiet",
        "--every",
        "50",
        "--measurements",
        csv.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(
        out.contains("line door: 20 crossings (+20 / -0, net 20)"),
        "{out}"
    );
    assert!(out.contains("area room:"), "{out}");
    assert!(out.contains("evacuation: the last agent left at"), "{out}");
    let text = std::fs::read_to_string(&csv).unwrap();
    let rows: Vec<&str> = text.lines().collect();
    assert_eq!(
        rows[0],
        "frame,t,agents,left,door_positive,door_negative,room_count,room_density,room_speed"
    );
    // The run stops at the frame at which the last agent left.
    let end: usize = out
        .lines()
        .find_map(|l| l.strip_prefix("stopped at frame "))
        .and_then(|l| l.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("the run did not stop when the world emptied:\n{out}"));
    assert!(end < 200, "{out}");
    assert_eq!(
        rows.len(),
        1 + end + 1,
        "a row for frame 0 and for each step up to the last agent's departure"
    );
    assert!(
        rows[1].starts_with("0,0.000000,20,0,0,0,20,0.200000,"),
        "{}",
        rows[1]
    );
    assert!(
        rows[end + 1].starts_with(&format!("{end},")),
        "{}",
        rows[end + 1]
    );
    // At the end everyone has crossed the door and left.
    let last: Vec<&str> = rows[end + 1].split(',').collect();
    assert_eq!(&last[2..6], ["0", "20", "20", "0"], "{}", rows[end + 1]);

    // The scenario file is never an output.
    let o = throng(&[
        "run",
        input.to_str().unwrap(),
        "--steps",
        "2",
        "--measurements",
        input.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("input"), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(&input).unwrap(), MEASURED);
}

#[test]
fn bench_json_reports_measurements_and_the_evacuation_time() {
    let input = tmp("measured_bench.toml");
    std::fs::write(&input, MEASURED).unwrap();
    let o = throng(&[
        "bench",
        input.to_str().unwrap(),
        "--steps",
        "190",
        "--warmup",
        "10",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    let door = &v["measurements"]["lines"][0];
    assert_eq!(door["name"], "door");
    assert_eq!(door["positive"], 20);
    assert_eq!(door["length"], 10.0);
    assert!(door["flow"].as_f64().unwrap() > 0.0);
    assert_eq!(v["measurements"]["left"], 20);
    assert_eq!(v["measurements"]["areas"][0]["name"], "room");
    assert!(v["evacuation_time"].as_f64().unwrap() > 0.0);

    // Without measurements or exits: empty lists, and a null evacuation time.
    let o = throng(&[
        "bench", "flock", "--agents", "100", "--steps", "2", "--json",
    ]);
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(v["measurements"]["lines"], serde_json::json!([]));
    assert_eq!(v["measurements"]["areas"], serde_json::json!([]));
    assert!(v["evacuation_time"].is_null());
}

/// An address-space limit (`ulimit -v`) bounds the world as the machine's memory does: ten
/// million agents under 1 GB of address space are a one-line error naming the limit, before
/// any allocation can abort the process; `--max-memory` is named when it is the bound.
#[test]
fn an_address_space_limit_is_a_one_line_error_naming_it() {
    let err = one_line_failure_within_1_gb("demo flock --agents 10000000 --steps 1");
    assert!(
        err.contains("ulimit -v") && err.contains("not enough memory"),
        "{err}"
    );
    assert_one_line_failure(
        &[
            "demo",
            "flock",
            "--agents",
            "10000000",
            "--steps",
            "1",
            "--max-memory",
            "100M",
        ],
        "(--max-memory)",
    );
}

#[test]
fn the_concourse_walks_its_journey_to_empty() {
    let o = throng(&["demo", "concourse", "--quiet", "--until-arrived"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(
        out.contains("every agent has left the world"),
        "the concourse did not empty:\n{out}"
    );
    // Every passenger passes between the pillars; one in four takes the north exit (the lines
    // before the exits do not span the whole hall, so a passenger may walk round one).
    let net = |line: &str| -> i64 {
        let l = out
            .lines()
            .find(|l| l.starts_with(&format!("line {line}:")))
            .unwrap_or_else(|| panic!("no line {line}:\n{out}"));
        let at = l.find("net ").unwrap() + 4;
        l[at..].split(')').next().unwrap().parse().unwrap()
    };
    assert_eq!(net("between_pillars"), 200, "{out}");
    assert!(
        (190..=200).contains(&(net("north_exit") + net("south_exit"))),
        "{out}"
    );
    assert!((40..=60).contains(&net("north_exit")), "{out}");
    // The exit stages count as exits: the summary times the evacuation.
    assert!(
        out.contains("evacuation: the last agent left at") && out.contains("200 left, none inside"),
        "{out}"
    );
}

/// The step's reported time includes measuring it: four areas of 1,024 vertices over 2,000
/// agents cost about ten times the step itself, and were in no phase.
#[test]
fn measurement_time_counts_in_the_step_and_its_phase() {
    let file = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/measurement_areas_of_1024_vertices.toml"
    );
    // Wall time on a machine running other tests at once can stretch between steps, where no
    // step counts it: the steps must account for half the run in one of three tries (without
    // the measure phase they accounted for about a tenth, every time).
    let mut tries = Vec::new();
    let counted = (0..3).any(|_| {
        let o = throng(&["run", file, "--steps", "50", "--quiet"]);
        assert!(o.status.success(), "{}", stderr(&o));
        let out = stdout(&o);
        let summary = out.lines().next().expect("a summary line").to_string();
        let number_after = |key: &str| -> f64 {
            let rest = &summary[summary.find(key).expect(key) + key.len()..];
            rest.split_whitespace().next().unwrap().parse().unwrap()
        };
        let wall_s = number_after("steps in ");
        let mean_ms = number_after("ms/step mean ");
        tries.push(summary);
        mean_ms * 50.0 / 1e3 >= 0.5 * wall_s
    });
    assert!(
        counted,
        "50 steps reported in less than half the run: {tries:#?}"
    );
    let o = throng(&["run", file, "--steps", "2", "--every", "1"]);
    let line = stdout(&o)
        .lines()
        .find(|l| l.starts_with("frame"))
        .expect("a frame line")
        .to_string();
    let measure: f64 = line
        .split("measure")
        .nth(1)
        .and_then(|r| r.split_whitespace().next())
        .and_then(|v| v.trim_end_matches(']').parse().ok())
        .unwrap_or_else(|| panic!("no measure phase in {line}"));
    assert!(measure > 0.0, "{line}");
    let o = throng(&["bench", file, "--steps", "5", "--json"]);
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).expect("one JSON object");
    let phase = v["phases_ms"]["measure"]
        .as_f64()
        .expect("phases_ms.measure");
    assert!(
        phase > 0.0 && v["ms_per_step"]["median"].as_f64().unwrap() >= phase,
        "{v}"
    );
}

/// Laying the copies of `scale = "tiles"` is held to the process's memory too: a hundred
/// million one-agent copies under `ulimit -v` are a one-line error, not an abort.
#[test]
fn tiling_past_the_address_space_limit_is_a_one_line_error() {
    let file = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/tiles_of_one_agent.toml"
    );
    let err = one_line_failure_within_1_gb(&format!("run '{file}' --agents 100000000 --steps 1"));
    assert!(err.contains("tiles"), "{err}");
}

/// Runs `throng ARGS` under `ulimit -v 1000000`, asserts exit 1 with one line on stderr and
/// returns that line.
fn one_line_failure_within_1_gb(args: &str) -> String {
    let bin = env!("CARGO_BIN_EXE_throng");
    let o = Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v 1000000 && exec '{bin}' {args}"))
        .output()
        .unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    err
}
