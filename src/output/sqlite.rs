//! JuPedSim's SQLite trajectory database, schema version 2: what JuPedSim 1.4 (the released
//! version) writes and reads back (`jupedsim.Recording` accepts version 2 only), and what PedPy
//! 1.5 reads with `load_trajectory_from_jupedsim_sqlite` and `load_walkable_area_from_jupedsim_sqlite`
//! (versions 1 and 2). JuPedSim's next schema, version 3, only drops `ori_x` and `ori_y`, and its
//! reader upgrades a version 2 file in place.
//!
//! Tables: `trajectory_data(frame INTEGER, id INTEGER, pos_x REAL, pos_y REAL, ori_x REAL, ori_y
//! REAL)` (the orientation as a unit vector) with the index `frame_id_idx` on `(frame, id)`;
//! `metadata(key TEXT PRIMARY KEY, value TEXT)` holding `version` (2), `fps` and the geometry's
//! bounds `xmin`, `xmax`, `ymin`, `ymax`; `geometry(hash INTEGER UNIQUE, wkt TEXT)` holding the
//! walkable area; `frame_data(frame INTEGER, geometry_hash INTEGER)` with one row per written
//! frame.
//!
//! Invariants: rows go in through one prepared statement, in a transaction per batch of frames
//! (at most 100 frames or 2^20 rows); the index is built once at the end.
//! The database is a temporary file (no journal, no syncs while it is written) that
//! [`SqliteTrajectories::finish`] closes, syncs and renames into place, so a failed or killed run
//! leaves no partial database under the target's name.

use std::path::Path;

use rusqlite::{Connection, params};

use super::AtomicOutput;
use super::wkt::{walkable_bounds, walkable_wkt};
use crate::error::{Error, Result};
use crate::world::World;

/// The schema version JuPedSim's readers check (`metadata` key `version`).
pub const DATABASE_VERSION: u32 = 2;
/// Frames per transaction.
const BATCH_FRAMES: u32 = 100;
/// Rows per transaction (a frame is never split).
const BATCH_ROWS: u64 = 1 << 20;

const SCHEMA: &str = "
    PRAGMA journal_mode = OFF;
    PRAGMA synchronous = OFF;
    BEGIN;
    CREATE TABLE trajectory_data (
        frame INTEGER NOT NULL,
        id INTEGER NOT NULL,
        pos_x REAL NOT NULL,
        pos_y REAL NOT NULL,
        ori_x REAL NOT NULL,
        ori_y REAL NOT NULL);
    CREATE TABLE metadata (key TEXT NOT NULL UNIQUE PRIMARY KEY, value TEXT NOT NULL);
    CREATE TABLE geometry (hash INTEGER NOT NULL, wkt TEXT NOT NULL);
    CREATE UNIQUE INDEX geometry_hash ON geometry (hash);
    CREATE TABLE frame_data (frame INTEGER NOT NULL, geometry_hash INTEGER NOT NULL);
";

const INSERT_ROW: &str = "INSERT INTO trajectory_data VALUES (?1, ?2, ?3, ?4, ?5, ?6)";
const INSERT_FRAME: &str = "INSERT INTO frame_data VALUES (?1, ?2)";

/// An open trajectory database.
#[derive(Debug)]
pub struct SqliteTrajectories {
    /// Declared before `file` so that it is closed before an unfinished file is removed.
    db: Connection,
    file: AtomicOutput,
    geometry_hash: i64,
    batch_frames: u32,
    batch_rows: u64,
}

impl SqliteTrajectories {
    /// Creates the database at `path` (as a temporary file beside it): the schema, the metadata
    /// with `fps`, and `world`'s walkable area as its geometry.
    ///
    /// # Errors
    /// [`Error::Invalid`] when `path` exists and is not a regular file (a database cannot be
    /// streamed to a device or a pipe); [`Error::Io`] naming `path` when it cannot be written.
    pub fn create(path: &Path, fps: f64, world: &World) -> Result<Self> {
        if std::fs::metadata(path).is_ok_and(|m| !m.is_file()) {
            return Err(Error::Invalid {
                name: "trajectories".into(),
                reason: format!(
                    "{}: a SQLite database must be a regular file, not a device or a pipe",
                    path.display()
                ),
            });
        }
        let (file, f) = AtomicOutput::create(path)?;
        drop(f);
        let db = Connection::open(file.write_path()).map_err(|e| sql(&file, e))?;
        let wkt = walkable_wkt(world);
        let geometry_hash = fnv1a(wkt.as_bytes());
        let (min, max) = walkable_bounds(world);
        let out = SqliteTrajectories {
            db,
            file,
            geometry_hash,
            batch_frames: 0,
            batch_rows: 0,
        };
        let written = (|| -> rusqlite::Result<()> {
            out.db.execute_batch(SCHEMA)?;
            let mut meta = out.db.prepare("INSERT INTO metadata VALUES (?1, ?2)")?;
            for (key, value) in [
                ("version", DATABASE_VERSION.to_string()),
                ("fps", fps.to_string()),
                ("xmin", min.x.to_string()),
                ("xmax", max.x.to_string()),
                ("ymin", min.y.to_string()),
                ("ymax", max.y.to_string()),
            ] {
                meta.execute(params![key, value])?;
            }
            out.db.execute(
                "INSERT INTO geometry VALUES (?1, ?2)",
                params![geometry_hash, wkt],
            )?;
            out.db.execute_batch("COMMIT")
        })();
        written.map_err(|e| sql(&out.file, e))?;
        Ok(out)
    }

    /// Writes the world's agents as frame `frame`, committing the batch when it is full.
    ///
    /// # Errors
    /// [`Error::Io`] naming the file.
    pub fn frame(&mut self, frame: u64, world: &World) -> Result<()> {
        let a = world.agents();
        let frame = i64::try_from(frame).unwrap_or(i64::MAX);
        let written = (|| -> rusqlite::Result<()> {
            if self.batch_frames == 0 {
                self.db.execute_batch("BEGIN")?;
            }
            let mut row = self.db.prepare_cached(INSERT_ROW)?;
            for i in 0..a.len() {
                let (sin, cos) = a.orientations()[i].sin_cos();
                row.execute(params![
                    frame,
                    a.id(i).0,
                    f64::from(a.pos_x()[i]),
                    f64::from(a.pos_y()[i]),
                    f64::from(cos),
                    f64::from(sin)
                ])?;
            }
            self.db
                .prepare_cached(INSERT_FRAME)?
                .execute(params![frame, self.geometry_hash])?;
            self.batch_frames += 1;
            self.batch_rows += a.len() as u64;
            if self.batch_frames >= BATCH_FRAMES || self.batch_rows >= BATCH_ROWS {
                self.db.execute_batch("COMMIT")?;
                self.batch_frames = 0;
                self.batch_rows = 0;
            }
            Ok(())
        })();
        written.map_err(|e| sql(&self.file, e))
    }

    /// Commits the last batch, builds the `(frame, id)` index, closes the database and moves it
    /// into place.
    ///
    /// # Errors
    /// [`Error::Io`] naming the file.
    pub fn finish(mut self) -> Result<()> {
        let written = (|| -> rusqlite::Result<()> {
            if self.batch_frames == 0 {
                self.db.execute_batch("BEGIN")?;
            }
            self.db.execute_batch(
                "CREATE INDEX frame_id_idx ON trajectory_data (frame, id); COMMIT;",
            )?;
            self.batch_frames = 0;
            Ok(())
        })();
        written.map_err(|e| sql(&self.file, e))?;
        let SqliteTrajectories { db, file, .. } = self;
        db.close().map_err(|(_, e)| sql(&file, e))?;
        file.commit()
    }
}

/// A SQLite error as an I/O error naming the target file.
fn sql(file: &AtomicOutput, e: rusqlite::Error) -> Error {
    file.io(std::io::Error::other(e))
}

/// The 64-bit FNV-1a hash of `bytes`, as SQLite's signed integer (JuPedSim keys its geometries
/// by a hash of their WKT; any stable hash serves).
fn fnv1a(bytes: &[u8]) -> i64 {
    let h = bytes.iter().fold(0xcbf2_9ce4_8422_2325_u64, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    });
    i64::from_ne_bytes(h.to_ne_bytes())
}
