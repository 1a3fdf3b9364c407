//! Checkpoints through the command line, in new processes: `demo` with `--checkpoint` then
//! `throng resume` steps to the same bits as the run that never stopped, for every built-in
//! scenario and on 1 and 2 threads; checkpoints every K frames; a damaged checkpoint is a
//! one-line error.

use std::path::PathBuf;
use std::process::{Command, Output};

use throng::World;
use throng::scenario;

const N: u64 = 21;
const AGENTS: usize = 120;

#[path = "../../tests/support/checkpoint.rs"]
mod support;
use support::{bits, saved};

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("throng-ckpt-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn throng(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_throng"))
        .args(args)
        .output()
        .expect("run throng")
}

fn ok(o: &Output) -> String {
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        o.status.success(),
        "{out}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    out
}

/// Through the CLI, in new processes: `demo` 2N steps with a final checkpoint equals `demo` N
/// steps with a checkpoint, then `resume` for the rest, for every built-in scenario.
#[test]
fn the_cli_resumes_every_builtin_scenario_in_a_new_process() {
    let dir = tmp_dir("cli");
    let agents = AGENTS.to_string();
    let (n, n2) = (N.to_string(), (2 * N).to_string());
    for name in scenario::builtin_names() {
        for threads in ["1", "2"] {
            let full = dir.join(format!("{name}-full.ckpt"));
            let half = dir.join(format!("{name}-half.ckpt"));
            let common = ["--agents", &agents, "--threads", threads, "--quiet"];
            let full_s = full.to_str().unwrap();
            let half_s = half.to_str().unwrap();
            ok(&throng(
                &[
                    &["demo", name, "--steps", &n2, "--checkpoint", full_s],
                    &common[..],
                ]
                .concat(),
            ));
            ok(&throng(
                &[
                    &["demo", name, "--steps", &n, "--checkpoint", half_s],
                    &common[..],
                ]
                .concat(),
            ));
            ok(&throng(&[
                "resume",
                half_s,
                "--steps",
                &n,
                "--threads",
                threads,
                "--quiet",
            ]));
            let (a, _) = World::load_file(&full).unwrap();
            let (b, _) = World::load_file(&half).unwrap();
            assert_eq!(a.frame(), 2 * N);
            assert_eq!(bits(&a), bits(&b), "{name} on {threads} threads");
            assert_eq!(saved(&a), saved(&b), "{name}: the whole state");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `throng demo flock` for `steps` steps, checkpointing to `file` every 20 frames.
fn flock_with_checkpoints(steps: &str, file: &str) {
    ok(&throng(&[
        "demo",
        "flock",
        "--agents",
        "200",
        "--steps",
        steps,
        "--checkpoint",
        file,
        "--checkpoint-every",
        "20",
        "--quiet",
    ]));
}

#[test]
fn the_cli_checkpoints_every_k_frames_and_resume_goes_on_to_the_planned_end() {
    let dir = tmp_dir("every");
    let ckpt = dir.join("flock.ckpt");
    let c = ckpt.to_str().unwrap();
    flock_with_checkpoints("50", c);
    let (w, run) = World::load_file(&ckpt).unwrap();
    assert_eq!(w.frame(), 50, "the last frame is always checkpointed");
    let run = run.unwrap();
    assert_eq!((run.steps, run.checkpoint_every), (50, 20));
    // A checkpoint of frame 40 resumed without --steps runs to frame 50 and ends equal.
    flock_with_checkpoints("40", c);
    let mut b = std::fs::read(&ckpt).unwrap();
    let (w40, mut run40) = World::load_run(&b[..]).unwrap();
    assert_eq!(w40.frame(), 40);
    run40.as_mut().unwrap().steps = 50;
    b.clear();
    w40.save_run(run40.as_ref().unwrap(), &mut b).unwrap();
    std::fs::write(&ckpt, &b).unwrap();
    let out = ok(&throng(&["resume", c, "--quiet"]));
    assert!(out.contains("summary: 10 steps"), "{out}");
    let (r, _) = World::load_file(&ckpt).unwrap();
    assert_eq!(r.frame(), 50);
    assert_eq!(bits(&r), bits(&w));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_cli_rejects_a_damaged_checkpoint_in_one_line() {
    let dir = tmp_dir("damaged");
    let ckpt = dir.join("x.ckpt");
    let c = ckpt.to_str().unwrap();
    ok(&throng(&[
        "demo",
        "seek",
        "--agents",
        "20",
        "--steps",
        "3",
        "--checkpoint",
        c,
        "--quiet",
    ]));
    let mut b = std::fs::read(&ckpt).unwrap();
    let k = b.len() / 2;
    b[k] ^= 4;
    std::fs::write(&ckpt, &b).unwrap();
    let o = throng(&["resume", c]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("checksum mismatch"), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    let o = throng(&["resume", dir.join("missing.ckpt").to_str().unwrap()]);
    assert!(!o.status.success());
    let o = throng(&["demo", "seek", "--checkpoint-every", "5", "--steps", "3"]);
    assert!(!o.status.success(), "--checkpoint-every needs --checkpoint");
    let _ = std::fs::remove_dir_all(&dir);
}
