//! The trajectory writers behind `Simulation.record` and `Simulation.close`: the library's
//! writers ([`throng::output::Trajectories`], the ones the command line uses), each writing the
//! simulation's frame when it starts and every `every` steps after.
//!
//! Invariants: a file is complete once `close()` (or the simulation's garbage collection) has
//! finished it, and absent until then (the writers go through a temporary file renamed into
//! place); a writer that fails is dropped, its temporary file removed, and the error raised. No
//! two open writers of the process write the same file (their temporary files would collide).
//! The text and SQLite formats number their frames 0, 1, 2, ... at `1 / (dt every)` frames per
//! second, so a frame's time in PedPy is the simulation's time at `record` plus
//! `frame / framerate`.

use std::path::{Path, PathBuf};
use std::sync::{Mutex, PoisonError};

use throng::output::{Destination, Format, Sampling, Trajectories};
use throng::{Error, Result, World};

/// The file every open writer of the process writes, so that a second writer of one file is
/// refused.
static OPEN: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// What `path` names, as an absolute path without symbolic links where it can be told (the
/// file if it exists, else its folder joined with its name).
fn identity(dest: &Destination) -> PathBuf {
    let p = dest.path();
    if let Ok(c) = p.canonicalize() {
        return c;
    }
    let dir = match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    match (dir.canonicalize(), p.file_name()) {
        (Ok(d), Some(name)) => d.join(name),
        _ => p.to_path_buf(),
    }
}

/// One open trajectory file.
#[derive(Debug)]
struct Recorder {
    out: Trajectories,
    /// Steps between written frames.
    every: u64,
    /// The world's frame when recording started.
    start: u64,
    /// The file as [`identity`] names it, in [`OPEN`].
    file: PathBuf,
    /// The path as given, for messages.
    shown: String,
}

impl Recorder {
    /// Flushes, closes and moves the file into place.
    fn finish(self) -> Result<()> {
        let Recorder {
            out, file, shown, ..
        } = self;
        let done = out.finish();
        release(&file);
        done.map_err(|e| named(&shown, e))
    }
}

/// Takes `file` out of the open files.
fn release(file: &Path) {
    let mut open = OPEN.lock().unwrap_or_else(PoisonError::into_inner);
    if let Some(k) = open.iter().position(|f| f == file) {
        open.swap_remove(k);
    }
}

/// `e` with its parameter named `path` (the argument of `record`).
fn named(shown: &str, e: Error) -> Error {
    match e {
        Error::Invalid { reason, .. } => Error::Invalid {
            name: "path".into(),
            reason,
        },
        Error::Io { source, .. } => Error::Io {
            path: shown.to_string(),
            source,
        },
        other => other,
    }
}

/// The open trajectory writers of one simulation. Dropping it finishes them (see
/// [`Recorders::finish_on_drop`]).
#[derive(Debug, Default)]
pub(crate) struct Recorders {
    open: Mutex<Vec<Recorder>>,
}

impl Recorders {
    /// The writers, for a caller that holds the simulation mutably (no lock is waited for).
    fn list(&mut self) -> &mut Vec<Recorder> {
        self.open.get_mut().unwrap_or_else(PoisonError::into_inner)
    }

    /// Starts writing `path` in the format its extension names, `world`'s current frame first
    /// and then one frame every `every` steps of `dt` seconds.
    ///
    /// # Errors
    /// [`Error::NotPositive`] for `every` 0; [`Error::Invalid`] naming `path` for an extension
    /// of a format throng does not write, a path that is a folder or a socket (or, for SQLite,
    /// anything but a regular file), or a file another writer of this process is writing;
    /// [`Error::Io`] naming `path` when it cannot be created or written.
    pub(crate) fn open(&mut self, path: &Path, every: u64, dt: f32, world: &World) -> Result<()> {
        let shown = path.display().to_string();
        if every == 0 {
            return Err(Error::NotPositive {
                name: "every",
                value: 0.0,
            });
        }
        let format = Format::of(path).map_err(|e| named(&shown, e))?;
        let dest = throng::output::destination(path).map_err(|e| named(&shown, e))?;
        let file = identity(&dest);
        {
            let mut open = OPEN.lock().unwrap_or_else(PoisonError::into_inner);
            if open.contains(&file) {
                return Err(Error::Invalid {
                    name: "path".into(),
                    reason: format!(
                        "{shown}: is being recorded already (close() the simulation writing it \
                         first)"
                    ),
                });
            }
            open.push(file.clone());
        }
        let sampling = Sampling {
            dt,
            every,
            scenario: "throng.Simulation".into(),
            seed: world.seed(),
        };
        let started = Trajectories::create(path, format, &sampling, world).and_then(|mut out| {
            out.frame(world)?;
            Ok(out)
        });
        match started {
            Ok(out) => {
                self.list().push(Recorder {
                    out,
                    every,
                    start: world.frame(),
                    file,
                    shown,
                });
                Ok(())
            }
            Err(e) => {
                release(&file);
                Err(named(&shown, e))
            }
        }
    }

    /// Writes `world`'s frame to every writer it is due for (called after each step).
    ///
    /// # Errors
    /// [`Error::Io`] naming the file of the first writer that fails; that writer is dropped
    /// (its file left as it was before `record`), the others go on.
    pub(crate) fn after_step(&mut self, world: &World) -> Result<()> {
        let list = self.list();
        if list.is_empty() {
            return Ok(());
        }
        let frame = world.frame();
        for k in 0..list.len() {
            let r = &mut list[k];
            if (frame - r.start).is_multiple_of(r.every)
                && let Err(e) = r.out.frame(world)
            {
                let r = list.remove(k);
                release(&r.file);
                return Err(named(&r.shown, e));
            }
        }
        Ok(())
    }

    /// Finishes every writer: each file flushed, closed and moved into place. Nothing is left
    /// open afterwards, even after an error.
    ///
    /// # Errors
    /// The first writer's error ([`Error::Io`] naming its file); the others are finished all
    /// the same.
    pub(crate) fn close(&mut self) -> Result<()> {
        let mut first = Ok(());
        for r in self.list().drain(..) {
            let done = r.finish();
            if first.is_ok() {
                first = done;
            }
        }
        first
    }

    /// Finishes every writer when the simulation is dropped without `close()`; an error is
    /// reported as Python reports one in `__del__` ("Exception ignored in ...").
    fn finish_on_drop(&mut self) {
        if self.list().is_empty() {
            return;
        }
        if let Err(e) = self.close() {
            pyo3::Python::attach(|py| crate::error::raise(&e).write_unraisable(py, None));
        }
    }
}

impl Drop for Recorders {
    fn drop(&mut self) {
        self.finish_on_drop();
    }
}
