//! Checkpoints: the whole state of a [`World`] in a versioned, checksummed binary file, so that a
//! long run can be stopped and resumed with the same bits as if it had never stopped.
//!
//! A checkpoint holds everything a step reads that is not derived: the agents in storage order
//! with their ids, wander angles, overrides and own targets; the groups' profiles (the plans'
//! inputs); paths, formations with their members, assigned slots and dirty flags; obstacles;
//! gravity points where they are now; fields with their grids, goals, dirty flags, shuffle
//! settings, walkers and arrival flags; the seed, the frame counter (which keys the per-agent
//! random streams and every periodic event: reordering, goal shuffles, formation reassignment)
//! and the simulated time. Derived data (the neighbour index, compiled plans, cell-ordered copies,
//! the obstacles' broad phase, the fields' potentials and flows, scratch buffers) is rebuilt on
//! loading, each from the same inputs as in the running world, so a resumed world steps to the
//! same bits as the uninterrupted one on any number of threads.
//!
//! # File format
//! ```text
//! offset  size  what
//!      0     8  magic "THRONGCK"
//!      8     4  format version, little endian (FORMAT_VERSION)
//!     12     8  payload length in bytes, little endian
//!     20     4  CRC-32 (IEEE) of bytes 0..20 and of the payload, little endian
//!     24     n  payload: the state as CBOR (RFC 8949)
//! ```
//! The payload is encoded with `ciborium`, a maintained serde implementation of CBOR. CBOR is
//! self-describing, which the profiles need: they are the scenario files' serde types
//! (internally tagged behaviours, flattened parameter sets, defaults), which formats without
//! type information such as postcard or bincode cannot decode; bincode also stopped being
//! developed in 2025. CRC-32 detects every error burst of up to 32 bits, so any single damaged
//! byte, in the header or the payload, is found before decoding.
//!
//! Invariant: loading never panics and never puts a value into the world that its builder and
//! mutators would reject. Every decoded value goes through the same validation as the API (and
//! the references between parts are checked); anything wrong is a [`CheckpointError`] that says
//! what.
//!
//! Files are written crash-safe by [`write_atomic`]: into a temporary file in the same
//! directory, flushed to disk, then renamed over the old one, so that a kill at any moment
//! leaves either the old checkpoint or the new one, whole. A symbolic link is followed and the
//! file it names replaced; a character device or a pipe is written directly; a folder, a block
//! device or a socket is refused (the rule of [`crate::output`]).

mod state;

use std::io::{Read, Write};
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::ped::Cfsm;
use crate::world::World;

/// The first eight bytes of every checkpoint.
pub const MAGIC: [u8; 8] = *b"THRONGCK";
/// The version of the format this build writes (and the newest it reads).
///
/// Version 2 added the speed model's `pressed_anisotropy`. A version 1 file has none, and its
/// worlds stepped as if it equalled `anisotropy`: they are read so, and resume as they would
/// have. Version 3 added its `path_width`, whose default is not 1: files before it are read
/// with 1, the strip those worlds stepped with. Such keys are filled in by presence
/// ([`crate::ped::Cfsm::absent_keys`]): `reference_speed`, absent from the first
/// version 1 files, reads as 0.
pub const FORMAT_VERSION: u32 = 3;

/// The oldest version this build reads.
pub const OLDEST_VERSION: u32 = 1;
/// Bytes before the payload.
pub const HEADER_LEN: usize = 24;
/// The largest payload a checkpoint may declare (64 GiB, far above [`crate::error::MAX_AGENTS`]
/// agents' state), so that a damaged length is rejected before anything is read.
pub const MAX_PAYLOAD: u64 = 1 << 36;

/// The most agent ids a checkpointed world may have handed out (live and removed agents):
/// [`crate::error::MAX_AGENTS`], the most a scenario may spawn. Loading allocates a table entry
/// per id, as the running world holds one, so a damaged count must not reach the allocator.
pub const MAX_IDS_ISSUED: usize = crate::error::MAX_AGENTS;

pub use crate::error::CheckpointError;

/// How a run that wrote a checkpoint was set up, so that `throng resume` can go on with it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunInfo {
    /// The scenario's name.
    pub scenario: String,
    /// The time step, seconds.
    pub dt: f32,
    /// The frame the run is to end at.
    pub steps: u64,
    /// Frames between checkpoints (0: none).
    pub checkpoint_every: u64,
}

impl RunInfo {
    fn validate(&self) -> Result<()> {
        if !(self.dt.is_finite() && self.dt > 0.0 && self.dt <= crate::error::MAX_DT) {
            return Err(invalid(
                "run.dt",
                format!("{} is not a valid time step", self.dt),
            ));
        }
        Ok(())
    }
}

/// A [`CheckpointError::Invalid`] as an [`Error`].
pub(crate) fn invalid(part: impl Into<String>, reason: impl Into<String>) -> Error {
    Error::Checkpoint(CheckpointError::Invalid {
        part: part.into(),
        reason: reason.into(),
    })
}

fn io_error(path: &str, source: std::io::Error) -> Error {
    Error::Io {
        path: path.to_string(),
        source,
    }
}

/// The payload: the world's state and, when a run wrote it, the run's settings.
#[derive(Serialize, Deserialize)]
struct Payload {
    run: Option<RunInfo>,
    world: state::WorldState,
}

fn header(len: u64) -> [u8; HEADER_LEN] {
    let mut h = [0u8; HEADER_LEN];
    h[..8].copy_from_slice(&MAGIC);
    h[8..12].copy_from_slice(&FORMAT_VERSION.to_le_bytes());
    h[12..20].copy_from_slice(&len.to_le_bytes());
    h
}

fn checksum(head: &[u8], payload: &[u8]) -> u32 {
    let mut c = crc32fast::Hasher::new();
    c.update(&head[..20]);
    c.update(payload);
    c.finalize()
}

/// Encodes `world` (and the run's settings) as a checkpoint into `writer`.
fn save(world: &World, run: Option<&RunInfo>, mut writer: impl Write) -> Result<()> {
    if world.agents.ids_issued() > MAX_IDS_ISSUED {
        return Err(Error::Invalid {
            name: "checkpoint".into(),
            reason: format!(
                "the world has handed out {} agent ids; a checkpoint holds at most {MAX_IDS_ISSUED}",
                world.agents.ids_issued()
            ),
        });
    }
    let payload = Payload {
        run: run.cloned(),
        world: state::WorldState::capture(world),
    };
    let mut bytes = Vec::new();
    ciborium::into_writer(&payload, &mut bytes)
        .map_err(|e| Error::Checkpoint(CheckpointError::Decode(format!("encoding: {e}"))))?;
    let mut head = header(bytes.len() as u64);
    let crc = checksum(&head, &bytes);
    head[20..24].copy_from_slice(&crc.to_le_bytes());
    let io = |e| io_error("<checkpoint>", e);
    writer.write_all(&head).map_err(io)?;
    writer.write_all(&bytes).map_err(io)?;
    writer.flush().map_err(io)
}

/// Reads at most `limit` bytes into `buf`, returning how many were read.
fn read_up_to(reader: &mut impl Read, buf: &mut Vec<u8>, limit: u64) -> Result<u64> {
    reader
        .take(limit)
        .read_to_end(buf)
        .map(|n| n as u64)
        .map_err(|e| io_error("<checkpoint>", e))
}

/// Checks the header and the checksum and returns the format version and the payload's bytes.
fn read_payload(mut reader: impl Read) -> Result<(u32, Vec<u8>)> {
    let bad = |e: CheckpointError| Err(Error::Checkpoint(e));
    let mut head = Vec::with_capacity(HEADER_LEN);
    let got = read_up_to(&mut reader, &mut head, HEADER_LEN as u64)?;
    if head.len() < 8 || head[..8] != MAGIC {
        // A prefix of the magic is a checkpoint cut short; anything else is not one.
        if MAGIC.starts_with(&head) {
            return bad(CheckpointError::Truncated {
                what: "header",
                expected: HEADER_LEN as u64,
                found: got,
            });
        }
        return bad(CheckpointError::NotACheckpoint);
    }
    let mut version = FORMAT_VERSION;
    if head.len() >= 12 {
        version = u32::from_le_bytes(head[8..12].try_into().expect("four bytes"));
        if !(OLDEST_VERSION..=FORMAT_VERSION).contains(&version) {
            return bad(CheckpointError::UnsupportedVersion {
                found: version,
                supported: FORMAT_VERSION,
                oldest: OLDEST_VERSION,
            });
        }
    }
    if head.len() < HEADER_LEN {
        return bad(CheckpointError::Truncated {
            what: "header",
            expected: HEADER_LEN as u64,
            found: got,
        });
    }
    let len = u64::from_le_bytes(head[12..20].try_into().expect("eight bytes"));
    let stored = u32::from_le_bytes(head[20..24].try_into().expect("four bytes"));
    if len > MAX_PAYLOAD {
        return bad(CheckpointError::TooLarge {
            length: len,
            limit: MAX_PAYLOAD,
        });
    }
    // Read at most one byte more than declared (never allocating by the declared length).
    let mut payload = Vec::new();
    let got = read_up_to(&mut reader, &mut payload, len + 1)?;
    if got < len {
        return bad(CheckpointError::Truncated {
            what: "payload",
            expected: len,
            found: got,
        });
    }
    if got > len {
        return bad(CheckpointError::TrailingBytes { extra: got - len });
    }
    let computed = checksum(&head, &payload);
    if computed != stored {
        return bad(CheckpointError::ChecksumMismatch { stored, computed });
    }
    Ok((version, payload))
}

/// Reads a checkpoint from `reader`: the world and the run's settings, if a run wrote it.
fn load(reader: impl Read) -> Result<(World, Option<RunInfo>)> {
    let (version, payload) = read_payload(reader)?;
    let decode = |e: String| Error::Checkpoint(CheckpointError::Decode(e));
    let decoded: Payload = if version < FORMAT_VERSION {
        let mut v: ciborium::Value =
            ciborium::from_reader(&payload[..]).map_err(|e| decode(e.to_string()))?;
        with_older_keys(&mut v);
        v.deserialized().map_err(|e| decode(e.to_string()))?
    } else {
        ciborium::from_reader(&payload[..]).map_err(|e| decode(e.to_string()))?
    };
    if let Some(run) = &decoded.run {
        run.validate()?;
    }
    let world = decoded.world.restore()?;
    Ok((world, decoded.run))
}

/// Fills in the speed model's keys that the tables of an older file lack with the values its
/// worlds stepped with ([`Cfsm::absent_keys`]), so that it resumes as it would have. By
/// presence, not by version: `reference_speed` came within version 1. The decoder's nesting
/// limit bounds the recursion.
fn with_older_keys(v: &mut ciborium::Value) {
    use ciborium::Value;
    match v {
        Value::Map(entries) => {
            let value = |key: &str| entries.iter().find(|(k, _)| k.as_text() == Some(key));
            let anisotropy = value("anisotropy").and_then(|(_, v)| v.as_float());
            let absent = Cfsm::absent_keys(|k| value(k).is_some(), anisotropy.map(|a| a as f32));
            for (key, x) in absent {
                entries.push((Value::Text(key.into()), Value::Float(f64::from(x))));
            }
            entries.iter_mut().for_each(|(_, v)| with_older_keys(v));
        }
        Value::Array(items) => items.iter_mut().for_each(with_older_keys),
        Value::Tag(_, inner) => with_older_keys(inner),
        _ => {}
    }
}

/// Writes a file crash-safe; moved to [`crate::output`], which owns the rule for every output.
pub use crate::output::write_atomic;

impl World {
    /// Writes the world's whole state to `writer` as a checkpoint (see [`crate::checkpoint`]).
    /// [`World::load`] gives back a world that steps to the same bits.
    ///
    /// # Examples
    /// ```
    /// # fn main() -> throng::Result<()> {
    /// let mut world = throng::scenario::builtin("flock")?.with_agents(50)?.build()?;
    /// world.step(0.05)?;
    /// let mut bytes = Vec::new();
    /// world.save(&mut bytes)?;
    /// let mut resumed = throng::World::load(&bytes[..])?;
    /// world.step(0.05)?;
    /// resumed.step(0.05)?;
    /// assert_eq!(world.agents().pos_x(), resumed.agents().pos_x());
    /// # Ok(()) }
    /// ```
    ///
    /// # Errors
    /// [`Error::Io`] when writing fails.
    pub fn save(&self, writer: impl Write) -> Result<()> {
        save(self, None, writer)
    }

    /// As [`World::save`], with the settings of the run that goes on from it.
    ///
    /// # Errors
    /// [`Error::Io`] when writing fails.
    pub fn save_run(&self, run: &RunInfo, writer: impl Write) -> Result<()> {
        save(self, Some(run), writer)
    }

    /// Writes a checkpoint file crash-safe ([`write_atomic`]), with the run's settings if given.
    ///
    /// # Errors
    /// [`Error::Io`] naming the file.
    pub fn save_file(&self, path: &Path, run: Option<&RunInfo>) -> Result<()> {
        write_atomic(path, |w| save(self, run, w))
    }

    /// Reads a world from a checkpoint written by [`World::save`] (or [`World::save_run`]).
    ///
    /// # Errors
    /// [`Error::Checkpoint`] saying what is wrong: not a checkpoint, another format version,
    /// truncated, damaged (checksum), undecodable, or a value the world's validation rejects;
    /// [`Error::Io`] when reading fails.
    pub fn load(reader: impl Read) -> Result<World> {
        load(reader).map(|(w, _)| w)
    }

    /// As [`World::load`], also returning the run's settings when the checkpoint has them.
    ///
    /// # Errors
    /// As [`World::load`].
    pub fn load_run(reader: impl Read) -> Result<(World, Option<RunInfo>)> {
        load(reader)
    }

    /// Reads a checkpoint file (see [`World::load_run`]).
    ///
    /// # Errors
    /// As [`World::load`]; read errors name the file.
    pub fn load_file(path: &Path) -> Result<(World, Option<RunInfo>)> {
        let shown = path.display().to_string();
        let file = std::fs::File::open(path).map_err(|e| io_error(&shown, e))?;
        load(std::io::BufReader::new(file)).map_err(|e| match e {
            Error::Io { source, .. } => io_error(&shown, source),
            other => other,
        })
    }
}
