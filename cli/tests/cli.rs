//! The real `throng` binary: every built-in scenario runs, `bench --json` holds every key with
//! sane values, trajectories have one row per agent per written frame, and bad input gets a
//! non-zero exit with a one-line message.

use std::path::PathBuf;
use std::process::{Command, Output};

fn throng(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_throng"))
        .args(args)
        .output()
        .expect("run throng")
}

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("throng-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

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
        "wander",
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
    assert_eq!(lines.next(), Some("frame,t,id,x,y,vx,vy,heading"));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    // Frames 0, 5 and 10.
    assert_eq!(rows.len(), 50 * 3);
    for r in &rows {
        assert_eq!(r.len(), 8);
        for f in r {
            assert!(f.parse::<f64>().is_ok_and(f64::is_finite), "{r:?}");
        }
    }
    let frames: std::collections::BTreeSet<&str> = rows.iter().map(|r| r[0]).collect();
    assert_eq!(frames.into_iter().collect::<Vec<_>>(), ["0", "10", "5"]);
    let ids: std::collections::BTreeSet<&str> = rows.iter().map(|r| r[2]).collect();
    assert_eq!(ids.len(), 50, "stable ids");
}

fn assert_one_line_failure(args: &[&str], needle: &str) {
    let o = throng(args);
    assert!(!o.status.success(), "{args:?} succeeded");
    let err = stderr(&o);
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "{args:?}: one line wanted, got:\n{err}");
    assert!(
        lines[0].contains(needle),
        "{args:?}: {:?} lacks {needle:?}",
        lines[0]
    );
    assert!(
        !err.contains("panicked") && !err.contains("backtrace"),
        "{err}"
    );
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
