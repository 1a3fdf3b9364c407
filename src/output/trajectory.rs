//! Trajectory files in the format their extension names: throng's long-format CSV, PedPy's
//! text format (`.txt`) and JuPedSim's SQLite database (`.sqlite`, `.sqlite3`, `.db`; written
//! with the `sqlite` feature, refused with [`Error::Invalid`] without it).
//!
//! Invariants: every format holds the same written frames (those its caller passes: the command
//! line's run writes its first frame, every `K`th and the last) with the same agents in storage
//! order. The CSV numbers a row by the world's frame; the text and SQLite formats, whose readers
//! take time as `frame / framerate`, number the written frames 0, 1, 2, ... and state the
//! framerate `1 / (dt K)`. Files are written through
//! [`AtomicOutput`]: complete when [`Trajectories::finish`] returns, absent otherwise.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use super::AtomicOutput;
#[cfg(feature = "sqlite")]
use super::sqlite::SqliteTrajectories;
use crate::error::{Error, Result};
use crate::world::World;

/// A trajectory file format, chosen by the file's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// `frame,t,id,x,y,vx,vy,heading,group` rows (any extension not named below).
    Csv,
    /// PedPy's (and PeTrack's) text format: `# framerate:` and unit header, `id frame x y z`.
    PedPyText,
    /// JuPedSim's SQLite trajectory database, schema version 2 (JuPedSim 1.4's).
    JupedsimSqlite,
}

/// Extensions of formats throng does not write; naming one is refused rather than filled with
/// CSV under a misleading name.
const REFUSED: [&str; 6] = ["h5", "hdf5", "parquet", "json", "gif", "png"];
/// Extensions of compressed files: `x.csv.gz` was written as plain CSV.
const COMPRESSED: [&str; 8] = ["gz", "bz2", "xz", "zst", "lz4", "zip", "7z", "z"];

impl Format {
    /// The format of a trajectory file named `path`.
    ///
    /// # Errors
    /// [`Error::Invalid`] naming `trajectories` for an extension of a format throng does not
    /// write.
    pub fn of(path: &Path) -> Result<Format> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("txt") => Ok(Format::PedPyText),
            Some("sqlite" | "sqlite3" | "db") => Ok(Format::JupedsimSqlite),
            Some(e) if REFUSED.contains(&e) => Err(Error::Invalid {
                name: "trajectories".into(),
                reason: format!(
                    "{}: throng writes trajectories as .csv (or any other extension), .txt \
                     (PedPy text) or .sqlite/.sqlite3/.db (JuPedSim SQLite), not .{e}",
                    path.display()
                ),
            }),
            Some(e) if COMPRESSED.contains(&e) => Err(Error::Invalid {
                name: "trajectories".into(),
                reason: format!(
                    "{}: throng does not compress trajectories (a .{e} file would hold plain \
                     text); write .csv, .txt or .sqlite and compress it afterwards",
                    path.display()
                ),
            }),
            _ => Ok(Format::Csv),
        }
    }
}

/// How the run samples its frames, for the formats that state a framerate.
#[derive(Clone, Debug)]
pub struct Sampling {
    /// Seconds per step.
    pub dt: f32,
    /// Steps between written frames.
    pub every: u64,
    /// The scenario's name, for the text format's header.
    pub scenario: String,
    /// The run's seed, for the text format's header.
    pub seed: u64,
}

impl Sampling {
    /// Written frames per second, `1 / (dt every)`, with `dt` taken as the decimal number it
    /// prints as (so `--dt 0.05` gives 20, not 19.9999997).
    #[must_use]
    pub fn framerate(&self) -> f64 {
        let dt: f64 = self.dt.to_string().parse().unwrap_or(f64::from(self.dt));
        1.0 / (dt * self.every as f64)
    }
}

/// An open trajectory file and the number of frames written to it.
#[derive(Debug)]
pub struct Trajectories {
    sink: Sink,
    written: u64,
}

#[derive(Debug)]
enum Sink {
    Csv(BufWriter<File>, AtomicOutput),
    PedPyText(BufWriter<File>, AtomicOutput),
    #[cfg(feature = "sqlite")]
    Sqlite(Box<SqliteTrajectories>),
}

impl Trajectories {
    /// Creates the file at `path` in `format` and writes its header (the SQLite schema and
    /// metadata, with `world`'s walkable area as geometry).
    ///
    /// # Errors
    /// [`Error::Io`] naming `path` when it cannot be created or written; [`Error::Invalid`] for
    /// a SQLite database on a path that is not a regular file.
    pub fn create(path: &Path, format: Format, sampling: &Sampling, world: &World) -> Result<Self> {
        let sink = match format {
            Format::Csv => {
                let (file, mut w) = text_file(path)?;
                writeln!(w, "frame,t,id,x,y,vx,vy,heading,group").map_err(|e| file.io(e))?;
                Sink::Csv(w, file)
            }
            Format::PedPyText => {
                let (file, mut w) = text_file(path)?;
                pedpy_header(&mut w, sampling).map_err(|e| file.io(e))?;
                Sink::PedPyText(w, file)
            }
            #[cfg(feature = "sqlite")]
            Format::JupedsimSqlite => Sink::Sqlite(Box::new(SqliteTrajectories::create(
                path,
                sampling.framerate(),
                world,
            )?)),
            #[cfg(not(feature = "sqlite"))]
            Format::JupedsimSqlite => {
                let _ = world;
                return Err(Error::Invalid {
                    name: "trajectories".into(),
                    reason: format!(
                        "{}: this build of throng writes no SQLite (the `sqlite` feature is off)",
                        path.display()
                    ),
                });
            }
        };
        Ok(Trajectories { sink, written: 0 })
    }

    /// Writes the world's current frame.
    ///
    /// # Errors
    /// [`Error::Io`] naming the file.
    pub fn frame(&mut self, world: &World) -> Result<()> {
        let a = world.agents();
        let n = self.written;
        match &mut self.sink {
            Sink::Csv(w, file) => {
                let (frame, t) = (world.frame(), world.time());
                for i in 0..a.len() {
                    writeln!(
                        w,
                        "{frame},{t:.6},{},{},{},{},{},{},{}",
                        a.id(i).0,
                        a.pos_x()[i],
                        a.pos_y()[i],
                        a.vel_x()[i],
                        a.vel_y()[i],
                        a.orientations()[i],
                        a.groups()[i]
                    )
                    .map_err(|e| file.io(e))?;
                }
            }
            Sink::PedPyText(w, file) => {
                for i in 0..a.len() {
                    writeln!(
                        w,
                        "{}\t{n}\t{}\t{}\t0",
                        a.id(i).0,
                        a.pos_x()[i],
                        a.pos_y()[i]
                    )
                    .map_err(|e| file.io(e))?;
                }
            }
            #[cfg(feature = "sqlite")]
            Sink::Sqlite(db) => db.frame(n, world)?,
        }
        self.written += 1;
        Ok(())
    }

    /// Flushes and closes the file and moves it into place.
    ///
    /// # Errors
    /// [`Error::Io`] naming the file.
    pub fn finish(self) -> Result<()> {
        match self.sink {
            Sink::Csv(w, file) | Sink::PedPyText(w, file) => {
                w.into_inner().map_err(|e| file.io(e.into_error()))?;
                file.commit()
            }
            #[cfg(feature = "sqlite")]
            Sink::Sqlite(db) => db.finish(),
        }
    }
}

/// A buffered text file written through an [`AtomicOutput`].
fn text_file(path: &Path) -> Result<(AtomicOutput, BufWriter<File>)> {
    let (file, f) = AtomicOutput::create(path)?;
    Ok((file, BufWriter::with_capacity(1 << 16, f)))
}

/// PedPy's header: the framerate first (PedPy takes the first number on the first line that
/// says `framerate`), the unit last (PedPy takes the last line that says `x/m` or `in cm`), so
/// nothing in the scenario's name can change either.
fn pedpy_header(w: &mut impl Write, s: &Sampling) -> std::io::Result<()> {
    writeln!(w, "# framerate: {}", s.framerate())?;
    writeln!(
        w,
        "# throng {}: scenario {}, seed {}, dt {} s, a frame every {} step(s)",
        env!("CARGO_PKG_VERSION"),
        s.scenario.escape_debug(),
        s.seed,
        s.dt,
        s.every
    )?;
    writeln!(
        w,
        "# id: the agent; frame: the written frame, starting at 0 (seconds = frame / fps)"
    )?;
    writeln!(w, "# x/m y/m z/m: the position in metres (z is 0)")?;
    writeln!(w, "# id\tframe\tx\ty\tz")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sampling() -> Sampling {
        Sampling {
            dt: 0.05,
            every: 2,
            scenario: "walk".into(),
            seed: 3,
        }
    }

    #[test]
    fn the_extension_names_the_format() {
        assert_eq!(Format::of(Path::new("a.TXT")).unwrap(), Format::PedPyText);
        assert_eq!(
            Format::of(Path::new("a.db")).unwrap(),
            Format::JupedsimSqlite
        );
        assert_eq!(Format::of(Path::new("a.out")).unwrap(), Format::Csv);
        assert!(Format::of(Path::new("a.parquet")).is_err());
        assert!(Format::of(Path::new("a.csv.gz")).is_err());
        assert_eq!(sampling().framerate(), 10.0);
    }

    #[test]
    fn a_text_file_is_complete_after_finish_and_absent_before() {
        let dir = std::env::temp_dir().join(format!("throng-trajectory-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("walk.txt");
        let world = World::builder()
            .group(crate::Profile::default())
            .agents([crate::AgentInit::at(glam::Vec2::new(1.5, 2.0), 0)])
            .build()
            .unwrap();
        let mut t = Trajectories::create(&path, Format::PedPyText, &sampling(), &world).unwrap();
        t.frame(&world).unwrap();
        assert!(!path.exists());
        t.finish().unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.starts_with("# framerate: 10\n"), "{text}");
        assert!(
            text.ends_with("# id\tframe\tx\ty\tz\n0\t0\t1.5\t2\t0\n"),
            "{text}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[cfg(not(feature = "sqlite"))]
    #[test]
    fn without_the_feature_a_database_is_refused() {
        let world = World::builder().build().unwrap();
        let e = Trajectories::create(
            Path::new("never-written.sqlite"),
            Format::JupedsimSqlite,
            &sampling(),
            &world,
        )
        .unwrap_err();
        assert!(e.to_string().contains("`sqlite` feature"), "{e}");
        assert!(!Path::new("never-written.sqlite").exists());
    }
}
