//! Standard output as a fallible printer, and the checks made on output paths before a run.
//!
//! Invariants: what a path is decides how it is written, by the library's one rule
//! ([`throng::output::destination`], and [`throng::output::AtomicOutput`] for files that are
//! complete or absent); folders, block devices and sockets are refused before the run. No
//! output path names an input file, and no two outputs name the same file.

use std::io::Write;
use std::path::{Path, PathBuf};

use throng::{Error, Result};

/// Standard output as a fallible line printer: a failure is an [`Error::Io`] naming `stdout`
/// (a closed pipe is recognised by [`is_closed_stdout`]).
pub fn say(line: &str) -> Result<()> {
    let mut out = std::io::stdout().lock();
    writeln!(out, "{line}")
        .and_then(|()| out.flush())
        .map_err(|source| Error::Io {
            path: STDOUT.into(),
            source,
        })
}

const STDOUT: &str = "stdout";

/// Whether `e` is a write to standard output whose reader has gone (`throng list | head -1`).
pub fn is_closed_stdout(e: &Error) -> bool {
    matches!(e, Error::Io { path, source }
        if path == STDOUT && source.kind() == std::io::ErrorKind::BrokenPipe)
}

/// Where a path points: the canonical form of the file if it exists, otherwise of its folder
/// joined with its name.
fn identity(path: &Path) -> Option<PathBuf> {
    if let Ok(p) = path.canonicalize() {
        return Some(p);
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    Some(dir.canonicalize().ok()?.join(path.file_name()?))
}

/// Checks every output path before anything is computed: its folder exists, it is not a
/// folder, not one of `inputs`, and not the same file as another output. `outputs` pairs each
/// path with the flag that named it.
///
/// # Errors
/// [`Error::Invalid`] naming the flag and the path.
pub fn check_outputs(outputs: &[(&'static str, &Path)], inputs: &[PathBuf]) -> Result<()> {
    let bad = |flag: &str, path: &Path, reason: String| Error::Invalid {
        name: flag.trim_start_matches('-').to_string(),
        reason: format!("{}: {reason}", path.display()),
    };
    let mut seen: Vec<(&str, PathBuf)> = Vec::new();
    for &(flag, path) in outputs {
        if path.is_dir() {
            return Err(bad(flag, path, "is a folder, not a file".into()));
        }
        if let Err(e) = throng::output::destination(path) {
            return Err(match e {
                Error::Invalid { reason, .. } => Error::Invalid {
                    name: flag.trim_start_matches('-').to_string(),
                    reason,
                },
                other => other,
            });
        }
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        if !dir.is_dir() {
            return Err(bad(
                flag,
                path,
                format!("the folder {} does not exist", dir.display()),
            ));
        }
        let Some(id) = identity(path) else {
            return Err(bad(flag, path, "not a file path".into()));
        };
        if inputs.iter().any(|i| identity(i).as_ref() == Some(&id)) {
            return Err(bad(
                flag,
                path,
                "is an input file of this run; refusing to overwrite it".into(),
            ));
        }
        if let Some((other, _)) = seen.iter().find(|(_, p)| *p == id) {
            return Err(bad(
                flag,
                path,
                format!("is the same file as the {other} output"),
            ));
        }
        seen.push((flag, id));
    }
    Ok(())
}
