//! What an output path is decides how it is written, for every output flag: a regular file is
//! replaced whole, a symbolic link is followed (the link stays), a character device or a FIFO is
//! written directly and stays what it was, and a folder or a socket is refused with one line
//! naming the path.

use std::io::Read;
use std::os::unix::fs::FileTypeExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

mod common;
use common::{stderr, throng, tmp};

/// An empty scratch folder `name`.
fn tmp_dir(name: &str) -> PathBuf {
    let d = tmp(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A short demo writing `flag` to `path`.
fn demo(flag: &str, path: &Path) -> Output {
    let p = path.to_str().unwrap();
    throng(&[
        "demo", "wander", "--agents", "20", "--steps", "3", "--quiet", flag, p,
    ])
}

fn ok(o: &Output, what: &str) {
    assert!(o.status.success(), "{what}: {:?} {}", o.status, stderr(o));
}

const MAGIC: &[u8] = b"THRONGCK";

#[test]
fn every_output_through_a_symbolic_link_replaces_the_file_it_names_and_keeps_the_link() {
    let d = tmp_dir("links");
    for (flag, ext, start) in [
        ("--checkpoint", "ckpt", MAGIC),
        ("--trajectories", "csv", &b"frame,t,id"[..]),
        ("--measurements", "csv", &b"frame,t,agents"[..]),
        ("--render", "png", &b"\x89PNG"[..]),
    ] {
        let name = flag.trim_start_matches('-');
        let real = d.join(format!("{name}-real.{ext}"));
        let link = d.join(format!("{name}-link.{ext}"));
        std::fs::write(&real, "old").unwrap();
        std::os::unix::fs::symlink(&real, &link).unwrap();
        ok(&demo(flag, &link), flag);
        let kind = std::fs::symlink_metadata(&link).unwrap().file_type();
        assert!(kind.is_symlink(), "{flag}: the link was replaced");
        let bytes = std::fs::read(&real).unwrap();
        assert!(
            bytes.starts_with(start),
            "{flag}: the target kept {bytes:?}"
        );
        // A dangling link: the file is created where it points.
        let later = d.join(format!("{name}-later.{ext}"));
        let dangling = d.join(format!("{name}-dangling.{ext}"));
        std::os::unix::fs::symlink(&later, &dangling).unwrap();
        ok(&demo(flag, &dangling), flag);
        assert!(std::fs::symlink_metadata(&dangling).unwrap().is_symlink());
        assert!(std::fs::read(&later).unwrap().starts_with(start), "{flag}");
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_checkpoint_into_a_fifo_is_written_into_it_and_the_fifo_stays() {
    let d = tmp_dir("fifo");
    let fifo = d.join("run.ckpt");
    let made = Command::new("mkfifo").arg(&fifo).status().expect("mkfifo");
    assert!(made.success());
    // Open for reading and writing, so that the run's writer never waits for a reader and what
    // it writes stays in the pipe's buffer (a small checkpoint fits).
    let mut reader = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(&fifo)
        .unwrap();
    ok(&demo("--checkpoint", &fifo), "fifo");
    let kind = std::fs::symlink_metadata(&fifo).unwrap().file_type();
    assert!(kind.is_fifo(), "the FIFO was replaced by {kind:?}");
    let mut buf = vec![0; 1 << 16];
    let n = reader.read(&mut buf).unwrap();
    assert!(buf[..n].starts_with(MAGIC), "{:?}", &buf[..n.min(16)]);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_checkpoint_into_a_character_device_is_written_into_it_and_the_device_stays() {
    let d = tmp_dir("device");
    // A symbolic link to /dev/null: before the rule the link was replaced, never /dev/null.
    let link = d.join("null.ckpt");
    std::os::unix::fs::symlink("/dev/null", &link).unwrap();
    ok(&demo("--checkpoint", &link), "link to /dev/null");
    assert!(std::fs::symlink_metadata(&link).unwrap().is_symlink());
    // A copy of /dev/null made with mknod (where that is allowed: as root).
    let copy = d.join("copy-of-null");
    let made = Command::new("mknod")
        .arg(&copy)
        .args(["c", "1", "3"])
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if made {
        ok(&demo("--checkpoint", &copy), "mknod copy of /dev/null");
        let kind = std::fs::symlink_metadata(&copy).unwrap().file_type();
        assert!(kind.is_char_device(), "the device became {kind:?}");
    }
    // /dev/null itself, only once the rule says it is written directly (never renamed over).
    let null = Path::new("/dev/null");
    assert_eq!(
        throng::output::destination(null).unwrap(),
        throng::output::Destination::Direct(null.into())
    );
    ok(&demo("--checkpoint", null), "/dev/null");
    let kind = std::fs::symlink_metadata(null).unwrap().file_type();
    assert!(kind.is_char_device());
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn sockets_and_folders_are_refused_with_one_line_naming_the_path() {
    let d = tmp_dir("refused");
    let sock = d.join("out.sock");
    let _listener = std::os::unix::net::UnixListener::bind(&sock).unwrap();
    let folder = d.join("folder");
    std::fs::create_dir(&folder).unwrap();
    let to_folder = d.join("to-folder");
    std::os::unix::fs::symlink(&folder, &to_folder).unwrap();
    for flag in [
        "--checkpoint",
        "--trajectories",
        "--measurements",
        "--render",
    ] {
        for (path, what) in [
            (&sock, "socket"),
            (&folder, "folder"),
            (&to_folder, "folder"),
        ] {
            let o = demo(flag, path);
            assert_eq!(o.status.code(), Some(1), "{flag} {}", path.display());
            let err = stderr(&o);
            assert_eq!(err.lines().count(), 1, "{err}");
            assert!(
                err.contains(&*path.to_string_lossy()) && err.contains(what),
                "{flag}: {err}"
            );
        }
        assert!(
            std::fs::symlink_metadata(&sock)
                .unwrap()
                .file_type()
                .is_socket()
        );
        assert!(std::fs::symlink_metadata(&to_folder).unwrap().is_symlink());
    }
    let _ = std::fs::remove_dir_all(&d);
}
