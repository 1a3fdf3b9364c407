//! A crate that depends on `throng` gets the simulation core alone: the command line's crates
//! (clap, indicatif, serde_json) belong to the `throng-cli` package, the image crates (gif, png)
//! to the opt-in `render` feature and SQLite (rusqlite) to the opt-in `sqlite` feature, so none
//! of them is among the library's default normal or build dependencies. Asked of `cargo tree` on this workspace, offline and with the lock file
//! as it is.

use std::collections::BTreeSet;
use std::path::Path;
use std::process::Command;

/// Crates that only the `throng` command (or `render`, or `sqlite`) may bring in.
const NOT_IN_THE_CORE: [&str; 6] = ["clap", "indicatif", "serde_json", "gif", "png", "rusqlite"];

/// The names of every package in the normal and build dependency tree of `package`.
fn dependency_names(package: &str, extra: &[&str]) -> BTreeSet<String> {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml");
    let out = Command::new(env!("CARGO"))
        .args(["tree", "--offline", "--locked", "--manifest-path"])
        .arg(&manifest)
        .args(["-p", package, "-e", "normal,build", "--prefix", "none"])
        .args(["--format", "{p}"])
        .args(extra)
        .output()
        .expect("run cargo tree");
    assert!(
        out.status.success(),
        "cargo tree -p {package} {extra:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout)
        .expect("cargo tree prints UTF-8")
        .lines()
        .filter_map(|line| line.split_whitespace().next())
        .map(str::to_owned)
        .collect()
}

#[test]
fn the_library_by_default_depends_on_no_command_line_or_image_crate() {
    let core = dependency_names("throng", &[]);
    for needed in ["throng", "glam", "rayon", "serde", "toml"] {
        assert!(core.contains(needed), "{needed} missing from {core:?}");
    }
    let found: Vec<_> = NOT_IN_THE_CORE
        .iter()
        .filter(|name| core.contains(**name))
        .collect();
    assert!(found.is_empty(), "the core pulls in {found:?}");
}

#[test]
fn render_brings_only_the_image_crates_and_the_command_brings_the_rest() {
    let render = dependency_names("throng", &["--features", "render"]);
    assert!(
        render.contains("gif") && render.contains("png"),
        "{render:?}"
    );
    for name in ["clap", "indicatif", "serde_json", "rusqlite"] {
        assert!(!render.contains(name), "render pulls in {name}");
    }
    let sqlite = dependency_names("throng", &["--features", "sqlite"]);
    assert!(sqlite.contains("rusqlite"), "{sqlite:?}");
    for name in ["clap", "indicatif", "serde_json", "gif", "png"] {
        assert!(!sqlite.contains(name), "sqlite pulls in {name}");
    }
    let cli = dependency_names("throng-cli", &[]);
    for name in NOT_IN_THE_CORE {
        assert!(
            cli.contains(name),
            "{name} missing from the command's tree {cli:?}"
        );
    }
}
