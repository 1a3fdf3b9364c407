//! The crate's error types: [`Error`], and [`CheckpointError`] which it wraps.
//!
//! Every builder, mutator, loader and parser validates its input at the boundary and returns a
//! [`Error`] that names the offending parameter and its value. The hot path (`World::step`) never
//! fails on data that passed validation, so nothing invalid ever enters the agent buffers.
//!
//! The bottom of the crate's module graph: it names only [`AgentId`] (a leaf), so every other
//! module may return its errors (`tests/module_cycles.rs` holds the graph acyclic).

use crate::id::AgentId;

/// Errors returned by throng's builders, mutators and loaders.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A number was NaN or infinite.
    #[error("{name} must be a finite number, got {value}")]
    NonFinite {
        /// The parameter's name.
        name: &'static str,
        /// The value given.
        value: f64,
    },
    /// A number that must not be negative was negative.
    #[error("{name} must not be negative, got {value}")]
    Negative {
        /// The parameter's name.
        name: &'static str,
        /// The value given.
        value: f64,
    },
    /// A number that must be strictly positive was zero or negative.
    #[error("{name} must be greater than zero, got {value}")]
    NotPositive {
        /// The parameter's name.
        name: &'static str,
        /// The value given.
        value: f64,
    },
    /// A mass of zero (or less) was given.
    #[error("mass must be greater than zero, got {value}")]
    ZeroMass {
        /// The value given.
        value: f64,
    },
    /// A time step was below [`MIN_DT`](crate::limits::MIN_DT), larger than [`MAX_DT`] or not
    /// finite.
    #[error("dt must be a number in [1e-6, 1e6] seconds, got {dt}")]
    InvalidTimeStep {
        /// The value given.
        dt: f64,
    },
    /// A number lay outside the range it must lie in (a value read as `f32` is printed as
    /// its shortest `f32` form: 0.3, not 0.30000001192092896).
    #[error("{name} must lie in {range}, got {}", shortest(*value))]
    OutOfRange {
        /// The parameter's name.
        name: &'static str,
        /// The value given.
        value: f64,
        /// The allowed range, in words (`"[0, 1]"`).
        range: &'static str,
    },
    /// An [`AgentId`] that names no live agent.
    #[error("unknown agent id {id}")]
    UnknownAgent {
        /// The id given.
        id: AgentId,
    },
    /// A group index that names no group.
    #[error("unknown group {group} (the world has {count} groups)")]
    UnknownGroup {
        /// The group index given.
        group: usize,
        /// How many groups the world has.
        count: usize,
    },
    /// A behaviour names a field, or a channel of a field, that the world does not have.
    #[error(
        "group {group}: follow_field names field {field} channel {channel}, which does not exist (the world has {fields} fields)"
    )]
    UnknownField {
        /// The group whose profile names it.
        group: usize,
        /// The field named.
        field: usize,
        /// The channel named.
        channel: usize,
        /// How many fields the world has.
        fields: usize,
    },
    /// A path id that names no path.
    #[error("no path {path} (the world has {count})")]
    UnknownPath {
        /// The path id given.
        path: u32,
        /// How many paths the world has.
        count: usize,
    },
    /// A target slot that names no slot of the world.
    #[error("no target slot {slot} (the world has {count})")]
    UnknownTarget {
        /// The slot given.
        slot: u32,
        /// How many target slots the world has.
        count: usize,
    },
    /// A formation id that names no formation.
    #[error("no formation {formation} (the world has {count})")]
    UnknownFormation {
        /// The formation id given.
        formation: u32,
        /// How many formations the world has.
        count: usize,
    },
    /// A stage id that names no stage of the world's journeys.
    #[error("no stage {stage} (the world has {count})")]
    UnknownStage {
        /// The stage id given.
        stage: u32,
        /// How many stages the world has.
        count: usize,
    },
    /// A journey (being added or checked) names a stage, in its stage list or in one of its
    /// transitions, that the world does not have.
    #[error("{} names no stage {stage} (the world has {stages})", escaped(journey))]
    UnknownJourneyStage {
        /// The journey, as the error names it (`"journey 2"`, or a scenario file's
        /// `journeys[0]`).
        journey: String,
        /// The stage id it names.
        stage: u32,
        /// How many stages the world has.
        stages: usize,
    },
    /// A journey id that names no journey of the world.
    #[error("no journey {journey} (the world has {count})")]
    UnknownJourney {
        /// The journey id given.
        journey: u32,
        /// How many journeys the world has.
        count: usize,
    },
    /// A parameter was invalid for a reason other than its numeric range.
    #[error("invalid {}: {}", escaped(name), escaped(reason))]
    Invalid {
        /// The parameter's name.
        name: String,
        /// Why it is invalid.
        reason: String,
    },
    /// A text map (occupancy grid) could not be parsed.
    #[error("{}:{line}:{column}: {}", escaped(source_name), escaped(message))]
    MapParse {
        /// The file name, or `<map>` for text given in code.
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// 1-based column number.
        column: usize,
        /// What is wrong there.
        message: String,
    },
    /// A scenario file could not be read or is invalid.
    #[error("{}{}: {}", escaped(source_name), location.map(|(l, c)| format!(":{l}:{c}")).unwrap_or_default(), escaped(message))]
    Scenario {
        /// The file name, or the built-in scenario's name.
        source_name: String,
        /// 1-based line and column, where known.
        location: Option<(usize, usize)>,
        /// What is wrong.
        message: String,
    },
    /// A requested movement is impossible for the agent's limits (for example a jump).
    #[error("impossible: {}", escaped(reason))]
    Impossible {
        /// Why it cannot be done.
        reason: String,
    },
    /// A buffer could not be allocated, or a scenario needs more memory than may be used.
    #[error("not enough memory for {}: {}", escaped(what), escaped(reason))]
    OutOfMemory {
        /// What was being built (`"agents"`, `"field cells"`, a scenario's name).
        what: String,
        /// How much was needed against what is available, in words.
        reason: String,
    },
    /// A copy of the agents' data in storage order (the neighbour index, the grid kernel's
    /// copies, a nearest-agent index) was about to be read for another arrangement of the
    /// agents than the one it was built for ([`crate::agents::AgentOrder`]). A defect of
    /// throng, never of the input: the step stops before it reads the stale copy, and the world
    /// is left as the prepare phases made it.
    #[error("internal error: the {copy} was built for another order of the agents")]
    StaleOrder {
        /// Which copy was stale.
        copy: &'static str,
    },
    /// A checkpoint could not be read: not a checkpoint, another format version, damaged, or
    /// holding a value that fails the world's validation.
    #[error("checkpoint: {0}")]
    Checkpoint(#[from] CheckpointError),
    /// An input or output operation failed.
    #[error("{}: {source}", escaped(path))]
    Io {
        /// The file involved.
        path: String,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}

/// The largest time step a world accepts, seconds.
pub const MAX_DT: f32 = 1e6;
/// The largest maximum speed a group or agent may have, units per second. With [`MAX_DT`] it
/// keeps one step's displacement far below `f32::MAX`.
pub const MAX_SPEED: f32 = 1e12;
/// The largest maximum acceleration, angular acceleration or rotation. With [`MAX_DT`] one
/// step's change of velocity stays small enough that its square is finite.
pub const MAX_RATE: f32 = 1e12;
/// The largest coordinate a position may have, and the largest world side: offsets between any
/// two points then have finite squares.
pub const MAX_COORDINATE: f32 = 1e18;
/// The most agents a scenario may spawn (about 15 GB of state at 146 bytes per agent).
pub const MAX_AGENTS: usize = 100_000_000;

/// `text` with every control character (newlines, escape codes) written as a Rust escape, so
/// that an error message stays one line and cannot drive the terminal.
#[must_use]
pub fn escaped(text: &str) -> std::borrow::Cow<'_, str> {
    if !text.chars().any(char::is_control) {
        return std::borrow::Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        if c.is_control() {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    std::borrow::Cow::Owned(out)
}

/// Reserves room for `additional` more elements in `v`, as an error instead of an abort when
/// the allocator cannot give it.
///
/// # Errors
/// [`Error::OutOfMemory`] naming `what`.
pub fn try_reserve<T>(v: &mut Vec<T>, additional: usize, what: &str) -> Result<()> {
    v.try_reserve(additional).map_err(|e| Error::OutOfMemory {
        what: what.to_string(),
        reason: format!(
            "{additional} more elements of {} bytes: {e}",
            std::mem::size_of::<T>()
        ),
    })
}

/// The crate's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Checks that `value` is finite.
///
/// # Errors
/// [`Error::NonFinite`] when it is NaN or infinite.
pub fn finite(name: &'static str, value: f32) -> Result<f32> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(Error::NonFinite {
            name,
            value: f64::from(value),
        })
    }
}

/// Checks that both components of `v` are finite.
///
/// # Errors
/// [`Error::NonFinite`] naming the first bad component.
pub fn finite_vec(name: &'static str, v: glam::Vec2) -> Result<glam::Vec2> {
    finite(name, v.x)?;
    finite(name, v.y)?;
    Ok(v)
}

/// Checks that `p` is a point of the plane throng works in: both coordinates finite and of a
/// magnitude of at most [`MAX_COORDINATE`] (1e18). Every entry point that takes a position or a
/// target (scenario files, the world's setters and builders, checkpoints, Python, `throng
/// serve`) goes through this one check, so a target at 1e20 is refused wherever it comes from.
///
/// # Errors
/// [`Error::NonFinite`] or [`Error::OutOfRange`] naming the first bad component.
pub fn coordinate(name: &'static str, p: glam::Vec2) -> Result<glam::Vec2> {
    for c in [p.x, p.y] {
        in_range(name, c, -MAX_COORDINATE, MAX_COORDINATE, "[-1e18, 1e18]")?;
    }
    Ok(p)
}

/// Checks that `value` is finite and not negative.
///
/// # Errors
/// [`Error::NonFinite`] or [`Error::Negative`].
pub fn non_negative(name: &'static str, value: f32) -> Result<f32> {
    finite(name, value)?;
    if value < 0.0 {
        Err(Error::Negative {
            name,
            value: f64::from(value),
        })
    } else {
        Ok(value)
    }
}

/// Checks that `value` is finite and strictly positive.
///
/// # Errors
/// [`Error::NonFinite`] or [`Error::NotPositive`].
pub fn positive(name: &'static str, value: f32) -> Result<f32> {
    finite(name, value)?;
    if value <= 0.0 {
        Err(Error::NotPositive {
            name,
            value: f64::from(value),
        })
    } else {
        Ok(value)
    }
}

/// `value` as written: the shortest form of the `f32` it is exactly, else of the `f64`; with
/// an exponent beyond 1e16 and below 1e-6 (1e300, not three hundred digits).
fn shortest(value: f64) -> String {
    let narrow = value as f32;
    let exact = f64::from(narrow) == value;
    let huge_or_tiny = value != 0.0 && !(1e-6..1e16).contains(&value.abs());
    match (exact, huge_or_tiny) {
        (true, false) => narrow.to_string(),
        (true, true) => format!("{narrow:e}"),
        (false, false) => value.to_string(),
        (false, true) => format!("{value:e}"),
    }
}

/// Checks that `value` is finite and lies in `[lo, hi]`.
///
/// # Errors
/// [`Error::NonFinite`] or [`Error::OutOfRange`].
pub fn in_range(
    name: &'static str,
    value: f32,
    lo: f32,
    hi: f32,
    range: &'static str,
) -> Result<f32> {
    finite(name, value)?;
    if value < lo || value > hi {
        Err(Error::OutOfRange {
            name,
            value: f64::from(value),
            range,
        })
    } else {
        Ok(value)
    }
}

/// What is wrong with a checkpoint.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    /// The data does not start with [`MAGIC`](crate::checkpoint::MAGIC).
    #[error("not a throng checkpoint (the file does not start with \"THRONGCK\")")]
    NotACheckpoint,
    /// The file was written in another format version.
    #[error(
        "format version {found} is not supported (this build reads versions {oldest} to {supported})"
    )]
    UnsupportedVersion {
        /// The version in the file.
        found: u32,
        /// The newest version this build reads (the one it writes).
        supported: u32,
        /// The oldest version this build reads.
        oldest: u32,
    },
    /// The data ends early.
    #[error("truncated: {what} needs {expected} bytes, only {found} present")]
    Truncated {
        /// The part that is cut short (`header` or `payload`).
        what: &'static str,
        /// Bytes it needs.
        expected: u64,
        /// Bytes present.
        found: u64,
    },
    /// The header declares a payload larger than [`MAX_PAYLOAD`](crate::checkpoint::MAX_PAYLOAD).
    #[error("the header declares a payload of {length} bytes, more than the {limit} allowed")]
    TooLarge {
        /// The declared length.
        length: u64,
        /// The largest allowed.
        limit: u64,
    },
    /// Bytes follow the payload.
    #[error("{extra} unexpected bytes after the payload")]
    TrailingBytes {
        /// How many (at least).
        extra: u64,
    },
    /// The checksum does not match: the file is damaged.
    #[error(
        "checksum mismatch (stored {stored:#010x}, computed {computed:#010x}): the file is damaged"
    )]
    ChecksumMismatch {
        /// The checksum in the header.
        stored: u32,
        /// The checksum of the data read.
        computed: u32,
    },
    /// The payload is not the state this version writes.
    #[error("payload cannot be decoded: {0}")]
    Decode(String),
    /// A decoded value fails the world's validation, or parts refer to each other wrongly.
    #[error("{part}: {reason}")]
    Invalid {
        /// Where in the state (`agents`, `groups[2]`, `fields[0].walkers[1]`, ...).
        part: String,
        /// What is wrong.
        reason: String,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn out_of_range_values_print_as_written() {
        let msg = |value: f64| {
            Error::OutOfRange {
                name: "k",
                value,
                range: "[0.5, 1]",
            }
            .to_string()
        };
        // An f32 read from a file: its shortest form, not its f64 expansion.
        assert_eq!(msg(f64::from(0.3f32)), "k must lie in [0.5, 1], got 0.3");
        assert!(
            in_range("k", 0.3, 0.5, 1.0, "[0.5, 1]")
                .unwrap_err()
                .to_string()
                .ends_with("got 0.3")
        );
        // An f64 that no f32 equals keeps its own form.
        assert_eq!(msg(0.1), "k must lie in [0.5, 1], got 0.1");
        assert_eq!(msg(1e300), "k must lie in [0.5, 1], got 1e300");
        assert_eq!(msg(2.5), "k must lie in [0.5, 1], got 2.5");
        assert_eq!(msg(f64::from(1e20f32)), "k must lie in [0.5, 1], got 1e20");
        assert_eq!(msg(-3e-9), "k must lie in [0.5, 1], got -3e-9");
    }
}
