//! Output files: where one goes, one rule for every file throng writes (checkpoints through
//! [`write_atomic`], trajectories, and in the command line pictures and measurements), and the
//! trajectory writers shared by the command line and the Python bindings.
//!
//! - [`trajectory`]: trajectory files in the format their extension names (throng's CSV,
//!   PedPy's text, and with the `sqlite` feature JuPedSim's SQLite database);
//! - [`wkt`]: a world's walkable area as WKT, for the files that carry their geometry;
//! - [`AtomicOutput`]: one output file, complete or absent.
//!
//! [`destination`] looks at what the path is before anything is written:
//!
//! - **nothing yet, or a regular file**: the output is written to a temporary file in the same
//!   folder and renamed over the path when complete ([`Destination::Replace`]), so the path
//!   holds its old content or the whole new one;
//! - **a symbolic link** is followed, through any number of links, and the same rule applies to
//!   what it points to: a link to a regular file (or to a path that does not exist yet) keeps
//!   the link and replaces the file it names;
//! - **a character device or a pipe** (`/dev/null`, `/dev/stdout`, a FIFO) is written directly
//!   ([`Destination::Direct`]): it is never replaced by a file, and a FIFO's writer waits for
//!   its reader as any writer does;
//! - **anything else** (a folder, a block device, a socket) is refused with
//!   [`Error::Invalid`] naming the path and what it is.
//!
//! Invariants: nothing but a regular file (or nothing) is ever renamed over; no symbolic link
//! is replaced.

mod atomic;
#[cfg(feature = "sqlite")]
pub mod sqlite;
pub mod trajectory;
pub mod wkt;

pub use atomic::AtomicOutput;
pub use trajectory::{Format, Sampling, Trajectories};

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// How an output path is written (see the [module documentation](self)).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Destination {
    /// Written to a temporary file beside this path and renamed over it when complete: the path
    /// given, or the file its symbolic links name.
    Replace(PathBuf),
    /// Written directly: a character device or a pipe.
    Direct(PathBuf),
}

impl Destination {
    /// The file the output ends up in.
    #[must_use]
    pub fn path(&self) -> &Path {
        match self {
            Destination::Replace(p) | Destination::Direct(p) => p,
        }
    }

    /// The temporary file to write before the rename (`.NAME.PID.tmp` in the same folder), or
    /// `None` for a direct write.
    #[must_use]
    pub fn temp_path(&self) -> Option<PathBuf> {
        match self {
            Destination::Replace(p) => {
                let name = p
                    .file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default();
                Some(p.with_file_name(format!(".{name}.{}.tmp", std::process::id())))
            }
            Destination::Direct(_) => None,
        }
    }
}

/// What a file that is neither regular, a character device nor a pipe is, for the refusal.
fn refused_kind(kind: std::fs::FileType) -> Option<&'static str> {
    use std::os::unix::fs::FileTypeExt;
    if kind.is_file() || kind.is_char_device() || kind.is_fifo() {
        None
    } else if kind.is_dir() {
        Some("a folder")
    } else if kind.is_block_device() {
        Some("a block device")
    } else if kind.is_socket() {
        Some("a socket")
    } else {
        Some("not a regular file, a character device or a pipe")
    }
}

/// The most symbolic links followed to find where a dangling link points (as Linux's limit).
const MAX_LINKS: usize = 40;

/// Decides how `path` is written (see the [module documentation](self)). Nothing is created.
///
/// # Errors
/// [`Error::Invalid`] naming the path when it is a folder, a block device, a socket or another
/// kind of file that is not written to; [`Error::Io`] naming the path when it cannot be
/// inspected (a loop of symbolic links, a folder that cannot be read).
pub fn destination(path: &Path) -> Result<Destination> {
    let io = |source: std::io::Error| Error::Io {
        path: path.display().to_string(),
        source,
    };
    let refuse = |what: &str| Error::Invalid {
        name: "output".into(),
        reason: format!(
            "{}: is {what}; outputs are written to regular files, character devices and pipes",
            path.display()
        ),
    };
    let own = match std::fs::symlink_metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Ok(Destination::Replace(path.to_path_buf()));
        }
        Err(e) => return Err(io(e)),
    };
    if !own.file_type().is_symlink() {
        if let Some(what) = refused_kind(own.file_type()) {
            return Err(refuse(what));
        }
        return Ok(if own.is_file() {
            Destination::Replace(path.to_path_buf())
        } else {
            Destination::Direct(path.to_path_buf())
        });
    }
    // A symbolic link: the kernel follows it (also `/dev/stdout`'s links into `/proc`).
    match std::fs::metadata(path) {
        Ok(m) => {
            if let Some(what) = refused_kind(m.file_type()) {
                return Err(refuse(&format!("a symbolic link to {what}")));
            }
            if m.is_file() {
                Ok(Destination::Replace(path.canonicalize().map_err(io)?))
            } else {
                Ok(Destination::Direct(path.to_path_buf()))
            }
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            // A dangling link: the file is created where the last link points.
            let mut at = path.to_path_buf();
            for _ in 0..MAX_LINKS {
                match std::fs::read_link(&at) {
                    Ok(to) => {
                        at = match at.parent() {
                            Some(dir) if to.is_relative() => dir.join(to),
                            _ => to,
                        };
                    }
                    Err(_) => return Ok(Destination::Replace(at)),
                }
            }
            Err(io(std::io::Error::other(
                "too many levels of symbolic links",
            )))
        }
        Err(e) => Err(io(e)),
    }
}

fn io_error(path: &str, source: std::io::Error) -> Error {
    Error::Io {
        path: path.to_string(),
        source,
    }
}

/// Writes a file crash-safe by the rule of [`destination`]: for a regular file (or a new one),
/// `write` fills a temporary file in the same folder, which is flushed to disk and then renamed
/// over the file (and the folder synced), so that the file holds either its old content or the
/// whole new one, whatever happens meanwhile; when `write` or any of these steps fails, the
/// temporary file is removed and the file is left as it was. A character device or a pipe is
/// written directly; anything else is refused before anything is written.
///
/// # Errors
/// As [`destination`]; [`Error::Io`] naming the file, or what `write` returned.
pub fn write_atomic(path: &Path, write: impl FnOnce(&mut dyn Write) -> Result<()>) -> Result<()> {
    let shown = path.display().to_string();
    let dest = destination(path)?;
    let Some(tmp) = dest.temp_path() else {
        let file = std::fs::File::create(dest.path()).map_err(|e| io_error(&shown, e))?;
        let mut out = std::io::BufWriter::new(file);
        write(&mut out)?;
        return out.flush().map_err(|e| io_error(&shown, e));
    };
    let target = dest.path();
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let result = (|| {
        let file = std::fs::File::create(&tmp).map_err(|e| io_error(&shown, e))?;
        let mut out = std::io::BufWriter::new(file);
        write(&mut out)?;
        let file = out
            .into_inner()
            .map_err(|e| io_error(&shown, e.into_error()))?;
        file.sync_all().map_err(|e| io_error(&shown, e))?;
        drop(file);
        std::fs::rename(&tmp, target).map_err(|e| io_error(&shown, e))?;
        // Make the rename itself durable (where folders can be opened and synced).
        if let Ok(d) = std::fs::File::open(&dir) {
            let _ = d.sync_all();
        }
        Ok(())
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("throng-output-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn each_kind_of_path_has_its_destination() {
        let d = dir("kinds");
        let new = d.join("new.txt");
        assert_eq!(
            destination(&new).unwrap(),
            Destination::Replace(new.clone())
        );
        std::fs::write(&new, "old").unwrap();
        assert_eq!(
            destination(&new).unwrap(),
            Destination::Replace(new.clone())
        );
        let link = d.join("link.txt");
        std::os::unix::fs::symlink(&new, &link).unwrap();
        assert_eq!(
            destination(&link).unwrap(),
            Destination::Replace(new.canonicalize().unwrap())
        );
        let dangling = d.join("dangling.txt");
        std::os::unix::fs::symlink("later.txt", &dangling).unwrap();
        assert_eq!(
            destination(&dangling).unwrap(),
            Destination::Replace(d.join("later.txt"))
        );
        // `/dev/null` itself is only looked at here, never written.
        let null = Path::new("/dev/null");
        assert_eq!(destination(null).unwrap(), Destination::Direct(null.into()));
        let to_null = d.join("null");
        std::os::unix::fs::symlink(null, &to_null).unwrap();
        assert_eq!(
            destination(&to_null).unwrap(),
            Destination::Direct(to_null.clone())
        );
        let e = destination(&d).unwrap_err().to_string();
        assert!(
            e.contains("is a folder") && e.contains(&*d.to_string_lossy()),
            "{e}"
        );
        let to_dir = d.join("to-dir");
        std::os::unix::fs::symlink(&d, &to_dir).unwrap();
        let e = destination(&to_dir).unwrap_err().to_string();
        assert!(e.contains("a symbolic link to a folder"), "{e}");
        let sock = d.join("sock");
        let _listener = std::os::unix::net::UnixListener::bind(&sock).unwrap();
        let e = destination(&sock).unwrap_err().to_string();
        assert!(e.contains("is a socket") && e.lines().count() == 1, "{e}");
        let looped = d.join("loop");
        std::os::unix::fs::symlink(&looped, &looped).unwrap();
        assert!(destination(&looped).is_err());
        let _ = std::fs::remove_dir_all(&d);
    }
}
