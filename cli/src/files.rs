//! Output files that are complete or absent, and the checks made on output paths before a run.
//!
//! Invariants: what a path is decides how it is written, by the library's one rule
//! ([`throng::output::destination`]): an output to a regular file (or a new one) is written to a
//! temporary file in the same folder and renamed over the target only when it is complete, so a
//! failed or killed run leaves the previous file (or none) in place; the temporary file is
//! removed when the output is dropped without being committed. A symbolic link is followed and
//! never replaced. Outputs to character devices and pipes are written directly; folders, block
//! devices and sockets are refused before the run. No output path names an input file, and no
//! two outputs name the same file.

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

/// One output file being written: to a temporary sibling, renamed over the target by
/// [`AtomicOutput::commit`].
#[derive(Debug)]
pub struct AtomicOutput {
    /// The path as given, for messages.
    target: PathBuf,
    /// Where the output goes: the target, or the file its symbolic links name.
    dest: throng::output::Destination,
    /// The temporary file, or `None` when the target is written directly (a device or a pipe).
    temp: Option<PathBuf>,
}

impl AtomicOutput {
    /// Prepares to write `target`: creates the (empty) temporary file, which checks that the
    /// folder exists and is writable.
    ///
    /// # Errors
    /// As [`throng::output::destination`]; [`Error::Io`] naming `target` when the file cannot
    /// be created.
    pub fn create(target: &Path) -> Result<(Self, std::fs::File)> {
        let dest = throng::output::destination(target)?;
        let out = AtomicOutput {
            target: target.to_path_buf(),
            temp: dest.temp_path(),
            dest,
        };
        let file = std::fs::File::create(out.write_path()).map_err(|source| out.io(source))?;
        Ok((out, file))
    }

    /// The path to write to (the temporary file, or the target itself).
    pub fn write_path(&self) -> &Path {
        self.temp.as_deref().unwrap_or(self.dest.path())
    }

    /// An I/O error naming the target.
    pub fn io(&self, source: std::io::Error) -> Error {
        Error::Io {
            path: self.target.display().to_string(),
            source,
        }
    }

    /// `e` with the temporary file's name replaced by the target's.
    pub fn named(&self, e: Error) -> Error {
        match e {
            Error::Io { source, .. } => self.io(source),
            other => other,
        }
    }

    /// Syncs the complete temporary file to disk and renames it over the target.
    ///
    /// # Errors
    /// [`Error::Io`] naming the target.
    pub fn commit(mut self) -> Result<()> {
        if let Some(temp) = self.temp.take() {
            let synced = std::fs::File::open(&temp).and_then(|f| f.sync_all());
            let result = synced.and_then(|()| std::fs::rename(&temp, self.dest.path()));
            if let Err(source) = result {
                let _ = std::fs::remove_file(&temp);
                return Err(self.io(source));
            }
        }
        Ok(())
    }
}

impl Drop for AtomicOutput {
    fn drop(&mut self) {
        if let Some(temp) = &self.temp {
            let _ = std::fs::remove_file(temp);
        }
    }
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
