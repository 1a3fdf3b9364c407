//! `--trajectories` in each format the extension names, read back: JuPedSim's SQLite database
//! (schema version 2, JuPedSim 1.4's: tables, column types, metadata, geometry, one row per agent per written
//! frame) and PedPy's text format hold the CSV's positions frame for frame, complete on an
//! `--until-arrived` stop and after `resume`; bad extensions and unwritable paths are one-line
//! errors before the run.

use std::collections::BTreeMap;
use std::path::Path;

use rusqlite::Connection;

mod common;
use common::{assert_one_line_failure, stderr, throng, tmp};

/// Runs `demo` with `args` and `--trajectories path`; panics unless it succeeds.
fn demo_to(path: &Path, args: &[&str]) {
    let mut all = vec!["demo"];
    all.extend_from_slice(args);
    all.extend(["--quiet", "--trajectories", path.to_str().unwrap()]);
    let o = throng(&all);
    assert!(o.status.success(), "{all:?}: {}", stderr(&o));
}

/// Positions by (written frame index, id), and the frames as written.
type Positions = BTreeMap<(u64, u32), (f32, f32)>;

/// The CSV's rows: positions and headings keyed by the index of their frame among the written
/// frames and the id, and the world frames written.
struct Csv {
    positions: Positions,
    headings: BTreeMap<(u64, u32), f32>,
    frames: Vec<u64>,
}

fn read_csv(path: &Path) -> Csv {
    let text = std::fs::read_to_string(path).unwrap();
    let mut csv = Csv {
        positions: Positions::new(),
        headings: BTreeMap::new(),
        frames: Vec::new(),
    };
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let frame: u64 = f[0].parse().unwrap();
        if csv.frames.last() != Some(&frame) {
            csv.frames.push(frame);
        }
        let key = (csv.frames.len() as u64 - 1, f[2].parse().unwrap());
        let p = (f[3].parse().unwrap(), f[4].parse().unwrap());
        csv.positions.insert(key, p);
        csv.headings.insert(key, f[7].parse().unwrap());
    }
    csv
}

fn read_sqlite(path: &Path) -> Positions {
    sqlite_pairs(path, "pos_x", "pos_y")
}

/// Columns `a` and `b` of `trajectory_data` as float32, keyed by frame and id.
fn sqlite_pairs(path: &Path, a: &str, b: &str) -> Positions {
    let db = Connection::open(path).unwrap();
    let mut q = db
        .prepare(&format!("SELECT frame, id, {a}, {b} FROM trajectory_data"))
        .unwrap();
    let rows = q
        .query_map([], |r| {
            let (frame, id): (i64, i64) = (r.get(0)?, r.get(1)?);
            let (x, y): (f64, f64) = (r.get(2)?, r.get(3)?);
            Ok(((frame as u64, id as u32), (x as f32, y as f32)))
        })
        .unwrap();
    rows.map(Result::unwrap).collect()
}

/// PedPy's text format: the framerate (the first number on the first header line naming it),
/// the unit line, and the rows `id frame x y z`.
fn read_text(path: &Path) -> (f64, String, Positions) {
    let text = std::fs::read_to_string(path).unwrap();
    let header: Vec<&str> = text.lines().take_while(|l| l.starts_with('#')).collect();
    let fps = header
        .iter()
        .find(|l| l.contains("framerate"))
        .and_then(|l| l.split_whitespace().find_map(|w| w.parse::<f64>().ok()))
        .expect("a framerate line");
    let unit = header
        .iter()
        .rev()
        .find(|l| l.contains("x/m") || l.contains("x/cm") || l.contains("in cm"))
        .expect("a unit line")
        .to_string();
    let mut out = Positions::new();
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        let f: Vec<&str> = line.split_whitespace().collect();
        assert_eq!(f.len(), 5, "{line}");
        assert_eq!(f[4], "0", "z is 0: {line}");
        let key = (f[1].parse().unwrap(), f[0].parse().unwrap());
        out.insert(key, (f[2].parse().unwrap(), f[3].parse().unwrap()));
    }
    (fps, unit, out)
}

/// `(name, declared type)` of each column of `table`.
fn columns(db: &Connection, table: &str) -> Vec<(String, String)> {
    let mut q = db
        .prepare(&format!(
            "SELECT name, type FROM pragma_table_info('{table}')"
        ))
        .unwrap();
    q.query_map([], |r| Ok((r.get(0)?, r.get(1)?)))
        .unwrap()
        .map(Result::unwrap)
        .collect()
}

fn metadata(db: &Connection, key: &str) -> Option<String> {
    db.query_row("SELECT value FROM metadata WHERE key = ?1", [key], |r| {
        r.get(0)
    })
    .ok()
}

const RUN: [&str; 10] = [
    "wander", "--agents", "30", "--steps", "23", "--every", "5", "--seed", "4", "--dt",
];

#[test]
fn sqlite_holds_jupedsims_version_2_schema_and_the_csv_positions() {
    let dir = tmp("schema");
    std::fs::create_dir_all(&dir).unwrap();
    let (csv, db_path) = (dir.join("s.csv"), dir.join("s.sqlite"));
    let args: Vec<&str> = RUN.iter().copied().chain(["0.05"]).collect();
    demo_to(&csv, &args);
    demo_to(&db_path, &args);
    let db = Connection::open(&db_path).unwrap();
    let t = |cols: &[(&str, &str)]| -> Vec<(String, String)> {
        cols.iter()
            .map(|(n, t)| (n.to_string(), t.to_string()))
            .collect()
    };
    assert_eq!(
        columns(&db, "trajectory_data"),
        t(&[
            ("frame", "INTEGER"),
            ("id", "INTEGER"),
            ("pos_x", "REAL"),
            ("pos_y", "REAL"),
            ("ori_x", "REAL"),
            ("ori_y", "REAL")
        ])
    );
    assert_eq!(
        columns(&db, "metadata"),
        t(&[("key", "TEXT"), ("value", "TEXT")])
    );
    assert_eq!(
        columns(&db, "geometry"),
        t(&[("hash", "INTEGER"), ("wkt", "TEXT")])
    );
    assert_eq!(
        columns(&db, "frame_data"),
        t(&[("frame", "INTEGER"), ("geometry_hash", "INTEGER")])
    );
    let index: String = db
        .query_row(
            "SELECT tbl_name FROM sqlite_master WHERE type = 'index' AND name = 'frame_id_idx'",
            [],
            |r| r.get(0),
        )
        .unwrap();
    assert_eq!(index, "trajectory_data");
    assert_eq!(metadata(&db, "version").as_deref(), Some("2"));
    // dt 0.05 s, every 5th step: 4 frames per second.
    assert_eq!(metadata(&db, "fps").as_deref(), Some("4"));

    // Frames 0, 5, 10, 15, 20 and the last, 23: six written frames numbered 0 to 5.
    let Csv {
        positions: from_csv,
        headings,
        frames,
    } = read_csv(&csv);
    assert_eq!(frames, [0, 5, 10, 15, 20, 23]);
    let from_db = read_sqlite(&db_path);
    assert_eq!(from_db.len(), 30 * 6);
    assert_eq!(from_db, from_csv, "the CSV's positions, frame for frame");
    // The orientation is the CSV's heading as a unit vector.
    let oris = sqlite_pairs(&db_path, "ori_x", "ori_y");
    assert_eq!(oris.len(), headings.len());
    for (key, ori) in oris {
        let (sin, cos) = headings[&key].sin_cos();
        assert_eq!(ori, (cos, sin), "{key:?}");
    }
    let listed: Vec<i64> = db
        .prepare("SELECT frame FROM frame_data ORDER BY frame")
        .unwrap()
        .query_map([], |r| r.get(0))
        .unwrap()
        .map(Result::unwrap)
        .collect();
    assert_eq!(listed, [0, 1, 2, 3, 4, 5]);

    // One geometry, named by every frame: the world's rectangle, with the bounds in metadata.
    let (hash, wkt): (i64, String) = db
        .query_row("SELECT hash, wkt FROM geometry", [], |r| {
            Ok((r.get(0)?, r.get(1)?))
        })
        .unwrap();
    let named: i64 = db
        .query_row(
            "SELECT count(*) FROM frame_data WHERE geometry_hash = ?1",
            [hash],
            |r| r.get(0),
        )
        .unwrap();
    assert_eq!(named, 6);
    let world = throng::scenario::builtin("wander")
        .and_then(|s| s.with_agents(30))
        .and_then(|s| s.build())
        .unwrap();
    let size = world.bounds().size().expect("wander is a rectangle");
    let (w, h) = (size.x, size.y);
    assert_eq!(wkt, format!("POLYGON ((0 0, {w} 0, {w} {h}, 0 {h}, 0 0))"));
    assert_eq!(metadata(&db, "xmin").as_deref(), Some("0"));
    assert_eq!(metadata(&db, "xmax"), Some(w.to_string()));
    assert_eq!(metadata(&db, "ymax"), Some(h.to_string()));
    let tmp_left = std::fs::read_dir(db_path.parent().unwrap())
        .unwrap()
        .any(|e| e.unwrap().file_name().to_string_lossy().ends_with(".tmp"));
    assert!(!tmp_left, "the temporary file was renamed into place");
}

#[test]
fn pedpy_text_has_the_header_pedpy_reads_and_the_csv_positions() {
    let (csv, txt) = (tmp("p.csv"), tmp("p.txt"));
    let args: Vec<&str> = RUN.iter().copied().chain(["0.1"]).collect();
    demo_to(&csv, &args);
    demo_to(&txt, &args);
    let (fps, unit, from_txt) = read_text(&txt);
    assert_eq!(fps, 2.0, "dt 0.1 s, every 5th step");
    assert!(unit.contains("x/m"), "metres: {unit}");
    let from_csv = read_csv(&csv).positions;
    assert_eq!(from_txt.len(), 30 * 6);
    assert_eq!(from_txt, from_csv);
}

#[test]
fn every_format_is_complete_after_an_until_arrived_stop() {
    let csv = tmp("u.csv");
    let args = [
        "circle",
        "--agents",
        "40",
        "--steps",
        "100000",
        "--every",
        "7",
        "--until-arrived",
    ];
    demo_to(&csv, &args);
    let Csv {
        positions: from_csv,
        frames,
        ..
    } = read_csv(&csv);
    let last = *frames.last().unwrap();
    assert!(last < 100_000 && last % 7 != 0, "stopped early, at {last}");
    assert_eq!(frames.len() as u64, last / 7 + 2);
    for (ext, read) in [
        ("sqlite", read_sqlite as fn(&Path) -> Positions),
        ("txt", |p: &Path| read_text(p).2),
    ] {
        let path = tmp(&format!("u.{ext}"));
        demo_to(&path, &args);
        assert_eq!(read(&path), from_csv, "{ext}");
    }
}

#[test]
fn resume_writes_the_resumed_frames() {
    let (ckpt, full, rest) = (tmp("r.ckpt"), tmp("r-full.csv"), tmp("r-rest.sqlite"));
    let run = ["wander", "--agents", "20", "--steps", "12", "--every", "4"];
    demo_to(&full, &run);
    // Stop at frame 8, then resume to 12 from the checkpoint.
    let mut first: Vec<&str> = run.to_vec();
    first[4] = "8";
    first.extend(["--checkpoint", ckpt.to_str().unwrap()]);
    demo_to(&tmp("r-first.csv"), &first);
    let o = throng(&[
        "resume",
        ckpt.to_str().unwrap(),
        "--steps",
        "4",
        "--every",
        "4",
        "--quiet",
        "--trajectories",
        rest.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let Csv {
        positions: from_csv,
        frames,
        ..
    } = read_csv(&full);
    assert_eq!(frames, [0, 4, 8, 12]);
    // Written frames 0 and 1 of the resumed run are frames 8 and 12 of the whole run.
    let expected: Positions = from_csv
        .into_iter()
        .filter(|((f, _), _)| *f >= 2)
        .map(|((f, id), p)| ((f - 2, id), p))
        .collect();
    assert_eq!(read_sqlite(&rest), expected);
    // A trajectory file is never the checkpoint read from.
    let o = throng(&[
        "resume",
        ckpt.to_str().unwrap(),
        "--trajectories",
        ckpt.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("input"), "{}", stderr(&o));
}

/// A run that must fail before its first step with one line on stderr containing `needle`.
fn refused(path: &str, needle: &str) {
    let args = [
        "demo",
        "wander",
        "--agents",
        "20",
        "--steps",
        "3",
        "--trajectories",
        path,
    ];
    let o = assert_one_line_failure(&args, needle);
    assert_eq!(o.status.code(), Some(1), "{path}");
    assert_eq!(o.stdout, b"", "{path}: nothing ran");
}

#[test]
fn bad_extensions_and_unwritable_paths_are_refused_before_the_run() {
    for ext in ["h5", "HDF5", "parquet", "json", "png"] {
        let path = tmp(&format!("bad.{ext}"));
        refused(path.to_str().unwrap(), ".sqlite");
        assert!(!path.exists(), "{ext}");
    }
    // A compressed name was filled with plain CSV.
    for name in ["t.csv.gz", "t.txt.XZ", "t.csv.zst", "t.zip"] {
        let path = tmp(name);
        refused(path.to_str().unwrap(), "does not compress");
        assert!(!path.exists(), "{name}");
    }
    refused("no-such-folder-xyz/t.sqlite", "no-such-folder-xyz");
    refused("no-such-folder-xyz/t.txt", "no-such-folder-xyz");
    // A database cannot be streamed into a device.
    let dev = tmp("dev.sqlite");
    std::os::unix::fs::symlink("/dev/full", &dev).unwrap();
    refused(dev.to_str().unwrap(), "regular file");
    // Any other extension is the CSV, as before.
    let dat = tmp("t.dat");
    demo_to(&dat, &["wander", "--agents", "5", "--steps", "1"]);
    let text = std::fs::read_to_string(&dat).unwrap();
    assert!(text.starts_with("frame,t,id,x,y,"), "{text}");
}

#[test]
fn a_full_disk_under_the_text_format_is_a_one_line_error() {
    let full = tmp("full.txt");
    std::os::unix::fs::symlink("/dev/full", &full).unwrap();
    let path = full.to_str().unwrap();
    let args = [
        "demo",
        "wander",
        "--agents",
        "500",
        "--steps",
        "2",
        "--quiet",
        "--trajectories",
        path,
    ];
    let o = assert_one_line_failure(&args, "No space left");
    assert!(stderr(&o).contains("full.txt"), "{}", stderr(&o));
}
