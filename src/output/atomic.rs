//! [`AtomicOutput`]: one output file that is complete or absent, written by the rule of
//! [`destination`](super::destination).
//!
//! Invariants: an output to a regular file (or a new one) is written to a temporary file in the
//! same folder and renamed over the target only by [`AtomicOutput::commit`], so a failed or
//! killed run leaves the previous file (or none) in place; the temporary file is removed when
//! the output is dropped without being committed. A symbolic link is followed and never
//! replaced. Outputs to character devices and pipes are written directly; folders, block
//! devices and sockets are refused before anything is created.

use std::path::{Path, PathBuf};

use super::Destination;
use crate::error::{Error, Result};

/// One output file being written: to a temporary sibling, renamed over the target by
/// [`AtomicOutput::commit`] and removed when dropped uncommitted (a character device or a pipe
/// is written directly).
#[derive(Debug)]
pub struct AtomicOutput {
    /// The path as given, for messages.
    target: PathBuf,
    /// Where the output goes: the target, or the file its symbolic links name.
    dest: Destination,
    /// The temporary file, or `None` when the target is written directly (a device or a pipe).
    temp: Option<PathBuf>,
}

impl AtomicOutput {
    /// Prepares to write `target`: creates the (empty) temporary file, which checks that the
    /// folder exists and is writable, and returns it open for writing.
    ///
    /// # Errors
    /// As [`destination`](super::destination); [`Error::Io`] naming `target` when the file
    /// cannot be created.
    pub fn create(target: &Path) -> Result<(Self, std::fs::File)> {
        let dest = super::destination(target)?;
        let out = AtomicOutput {
            target: target.to_path_buf(),
            temp: dest.temp_path(),
            dest,
        };
        let file = std::fs::File::create(out.write_path()).map_err(|source| out.io(source))?;
        Ok((out, file))
    }

    /// The path to write to (the temporary file, or the target itself).
    #[must_use]
    pub fn write_path(&self) -> &Path {
        self.temp.as_deref().unwrap_or(self.dest.path())
    }

    /// An I/O error naming the target.
    #[must_use]
    pub fn io(&self, source: std::io::Error) -> Error {
        Error::Io {
            path: self.target.display().to_string(),
            source,
        }
    }

    /// `e` with the temporary file's name replaced by the target's.
    #[must_use]
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
