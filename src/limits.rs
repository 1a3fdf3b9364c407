//! Resource ceilings: how large a scenario, a map file or a world may be, checked before the
//! work is done, and what the machine has.
//!
//! Every count a scenario file can hold has a ceiling here (documented next to its key in
//! `docs/SCENARIOS.md` and gathered in `docs/RELIABILITY.md`); files are read through a bounded
//! reader, so a huge or endless input (`/dev/zero`) is an error after at most the ceiling's
//! bytes; [`Scenario::memory_estimate`](crate::scenario::Scenario::memory_estimate) is compared
//! with [`available_memory`] before a world is built.

use std::io::Read;
use std::path::Path;

use crate::error::{Error, Result};

/// The largest scenario file, bytes (16 MiB).
pub const MAX_SCENARIO_BYTES: u64 = 16 << 20;
/// The largest ASCII map file, bytes: a map of [`MAX_CELLS`] cells with its line ends fits.
pub const MAX_MAP_BYTES: u64 = 300_000_000;
/// The most cells a field grid may have (2^28, a 16384 x 16384 map).
pub const MAX_CELLS: u64 = 1 << 28;
/// The most random circles (`obstacles.random_circles.count`).
pub const MAX_RANDOM_CIRCLES: usize = 1_000_000;
/// The most gravity points (`gravity.points` and `gravity.random.count` together).
pub const MAX_GRAVITY_POINTS: usize = 100_000;
/// The most goal channels of a field.
pub const MAX_CHANNELS: usize = 64;
/// The longest period of a quickest-path field's reroutes, frames (`field.reroute_every`).
pub const MAX_REROUTE_EVERY: u64 = 1 << 40;
/// The most goals a channel may draw at random (`{ random = n }`, `shuffle_goals`).
pub const MAX_RANDOM_GOALS: usize = 1_000_000;
/// The most measurement lines (`measurements.lines`) and the most measurement areas
/// (`measurements.areas`) a scenario may have, each.
pub const MAX_MEASUREMENTS: usize = 256;
/// The most vertices of a measurement area's polygon (its simplicity check is quadratic in
/// them: about half a million edge pairs at the ceiling).
pub const MAX_POLYGON_VERTICES: usize = 1024;
/// The longest name of a measurement line or area, bytes.
pub const MAX_MEASUREMENT_NAME: usize = 64;
/// The smallest time step, seconds: with cells and speeds at their ceilings a step's velocity
/// (distance over `dt`) stays finite.
pub const MIN_DT: f32 = 1e-6;
/// The largest magnitude of any number in a scenario file other than `seed` (coordinates,
/// sizes, masses, weights, strengths): offsets between two such values have finite squares.
pub const MAX_NUMBER: f64 = 1e18;
/// The largest world side that `density` or `agents_per_area` may derive: at 1e6 an `f32`
/// position still resolves 1/16 of a unit, so agents do not silently stand still.
pub const MAX_DERIVED_SIDE: f32 = 1e6;
/// Bytes of state per agent assumed by the memory estimate (agent buffers, the neighbour
/// index, cell-ordered copies and steering outputs; 160 bytes measured for a flock).
pub const BYTES_PER_AGENT: u64 = 200;
/// Bytes per group assumed by the memory estimate and by a tiling's check before it lays its
/// copies (the group's table, its copy while tiling and the world's group with its plans).
pub const BYTES_PER_GROUP: u64 = 2048;
/// Bytes of a field cell assumed by the memory estimate: the occupancy, the costs (set and
/// with a clearance's, and the clearance's mask) and the quickest paths' density tables
/// (8-byte fixed-point weights and their summed areas).
pub const BYTES_PER_CELL: u64 = 32;
/// Bytes per cell and channel (potential, step counts and flow).
pub const BYTES_PER_CHANNEL_CELL: u64 = 16;
/// Memory a run needs besides its world (program, thread stacks, output buffers).
pub const BASE_BYTES: u64 = 32 << 20;

/// The most worker threads a pool may have on any machine (see [`max_threads`]).
pub const MAX_THREADS: usize = 1024;

/// The most worker threads a pool may have on a machine with `cores` cores: four per core, at
/// least 16 and at most [`MAX_THREADS`]. Rayon's fork-join cost grows with the pool, so a pool
/// far larger than the machine only slows each step (docs/PERFORMANCE.md, "Tuning
/// constants"), and each worker reserves a stack.
#[must_use]
pub fn max_threads(cores: usize) -> usize {
    cores.saturating_mul(4).clamp(16, MAX_THREADS)
}

/// Checks a worker count asked for (`--threads`, Python's `threads=`) against this machine's
/// [`max_threads`].
///
/// # Errors
/// [`Error::NotPositive`] for 0, [`Error::Invalid`] naming `threads` above the ceiling.
pub fn check_threads(threads: usize) -> Result<usize> {
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    if threads == 0 {
        return Err(Error::NotPositive {
            name: "threads",
            value: 0.0,
        });
    }
    if threads > max_threads(cores) {
        return Err(Error::Invalid {
            name: "threads".into(),
            reason: format!(
                "{threads} is more than {} (four per core of this machine's {cores}, at least 16, at most {MAX_THREADS}): workers beyond the cores only add fork-join cost to every step",
                max_threads(cores)
            ),
        });
    }
    Ok(threads)
}

/// Reads a UTF-8 text file of at most `limit` bytes. A regular file larger than that is
/// refused before anything is read; other files (pipes, devices) are read up to the limit.
///
/// # Errors
/// [`Error::Io`] naming the file when it cannot be read, is not UTF-8, is a folder, or is
/// larger than `limit` (`what` names the ceiling).
pub fn read_text(path: &Path, limit: u64, what: &str) -> Result<String> {
    let shown = path.display().to_string();
    let err = |source: std::io::Error| Error::Io {
        path: shown.clone(),
        source,
    };
    let too_big = || {
        err(std::io::Error::new(
            std::io::ErrorKind::FileTooLarge,
            format!("larger than {limit} bytes, the ceiling of {what}"),
        ))
    };
    let file = std::fs::File::open(path).map_err(err)?;
    let meta = file.metadata().map_err(err)?;
    if meta.is_dir() {
        return Err(err(std::io::Error::new(
            std::io::ErrorKind::IsADirectory,
            "is a folder",
        )));
    }
    if meta.is_file() && meta.len() > limit {
        return Err(too_big());
    }
    let mut bytes = Vec::new();
    file.take(limit + 1).read_to_end(&mut bytes).map_err(err)?;
    if bytes.len() as u64 > limit {
        return Err(too_big());
    }
    String::from_utf8(bytes).map_err(|e| {
        err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("not UTF-8 text (byte {})", e.utf8_error().valid_up_to()),
        ))
    })
}

/// The memory a run may still take, bytes; `None` where nothing is known. The least of
/// [`memory_ceiling`]'s bounds.
#[must_use]
pub fn available_memory() -> Option<u64> {
    memory_ceiling().map(|c| c.bytes)
}

/// A bound on the memory a run may take, and what sets it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryCeiling {
    /// The bytes still available under the bound.
    pub bytes: u64,
    /// What sets it, in words for an error message.
    pub source: &'static str,
}

impl MemoryCeiling {
    /// A bound the user gave (`--max-memory`, [`crate::scenario::Scenario::build_within`]).
    #[must_use]
    pub fn given(bytes: u64) -> MemoryCeiling {
        MemoryCeiling {
            bytes,
            source: "the limit given",
        }
    }
}

/// The tightest of the bounds this process runs under: the machine's available memory
/// (`MemAvailable` of `/proc/meminfo`), the address-space limit (`RLIMIT_AS`, `ulimit -v`)
/// less the address space in use, and the memory limit of its control group (cgroup v2
/// `memory.max` of its group and every parent, or v1 `memory.limit_in_bytes`) less the memory
/// the group uses. `None` where none of them can be read (not Linux).
#[must_use]
pub fn memory_ceiling() -> Option<MemoryCeiling> {
    let read = |path: &str| std::fs::read_to_string(path).ok();
    [
        read("/proc/meminfo")
            .and_then(|t| meminfo_available(&t))
            .map(|bytes| MemoryCeiling {
                bytes,
                source: "the machine's available memory",
            }),
        read("/proc/self/limits")
            .zip(read("/proc/self/status"))
            .and_then(|(limits, status)| address_space_left(&limits, &status))
            .map(|bytes| MemoryCeiling {
                bytes,
                source: "the address-space limit (ulimit -v)",
            }),
        cgroup_left().map(|bytes| MemoryCeiling {
            bytes,
            source: "the control group's memory limit",
        }),
    ]
    .into_iter()
    .flatten()
    .min_by_key(|c| c.bytes)
}

/// `MemAvailable` of a `/proc/meminfo` text, bytes.
fn meminfo_available(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kb.checked_mul(1024)
}

/// The address space left under the soft `Max address space` limit of a `/proc/self/limits`
/// text, less `VmSize` of a `/proc/self/status` text; `None` when unlimited.
fn address_space_left(limits: &str, status: &str) -> Option<u64> {
    let line = limits
        .lines()
        .find(|l| l.starts_with("Max address space"))?;
    let soft: u64 = line
        .trim_start_matches("Max address space")
        .split_whitespace()
        .next()?
        .parse()
        .ok()?;
    let size = status.lines().find(|l| l.starts_with("VmSize:"))?;
    let kb: u64 = size.split_whitespace().nth(1)?.parse().ok()?;
    Some(soft.saturating_sub(kb.saturating_mul(1024)))
}

/// The memory left under the control group's limit: the least over the process's cgroup v2
/// group and its parents of `memory.max - memory.current`, or cgroup v1's
/// `memory.limit_in_bytes - memory.usage_in_bytes`; `None` when unlimited or unknown.
fn cgroup_left() -> Option<u64> {
    let number =
        |path: String| -> Option<u64> { std::fs::read_to_string(path).ok()?.trim().parse().ok() };
    let cgroups = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    if let Some(path) = cgroups.lines().find_map(|l| l.strip_prefix("0::")) {
        let mut dir = std::path::PathBuf::from("/sys/fs/cgroup").join(path.trim_start_matches('/'));
        let mut least: Option<u64> = None;
        loop {
            let d = dir.display();
            if let (Some(max), Some(current)) = (
                number(format!("{d}/memory.max")),
                number(format!("{d}/memory.current")),
            ) {
                let left = max.saturating_sub(current);
                least = Some(least.map_or(left, |l| l.min(left)));
            }
            if dir.as_os_str() == "/sys/fs/cgroup" || !dir.pop() {
                break;
            }
        }
        return least;
    }
    let limit = number("/sys/fs/cgroup/memory/memory.limit_in_bytes".into())?;
    let usage = number("/sys/fs/cgroup/memory/memory.usage_in_bytes".into())?;
    // An unlimited v1 group reports a page-rounded i64::MAX.
    (limit < 1 << 62).then(|| limit.saturating_sub(usage))
}

/// Parses a memory size: bytes, or a number with a `K`, `M`, `G` or `T` suffix (powers of
/// 1024; an optional `B` or `iB` after it), like `512M` or `4GiB`.
///
/// # Errors
/// [`Error::Invalid`] for anything else, or a size beyond `u64`.
pub fn parse_size(text: &str) -> Result<u64> {
    let bad = || Error::Invalid {
        name: "max-memory".into(),
        reason: format!(
            "{}: expected bytes or a size like 512M or 4G",
            crate::error::escaped(text)
        ),
    };
    let t = text.trim();
    let t = t
        .strip_suffix("iB")
        .or_else(|| t.strip_suffix('B'))
        .unwrap_or(t);
    let (digits, shift) = match t.chars().last().map(|c| c.to_ascii_uppercase()) {
        Some('K') => (&t[..t.len() - 1], 10),
        Some('M') => (&t[..t.len() - 1], 20),
        Some('G') => (&t[..t.len() - 1], 30),
        Some('T') => (&t[..t.len() - 1], 40),
        _ => (t, 0),
    };
    let value: f64 = digits.trim().parse().map_err(|_| bad())?;
    let bytes = value * f64::from(1u32 << (shift / 2)) * f64::from(1u32 << (shift - shift / 2));
    if !(bytes.is_finite() && bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(bad());
    }
    Ok(bytes as u64)
}

/// Checks that `needed` bytes fit in `limit`, a limit the user gave.
///
/// # Errors
/// [`Error::OutOfMemory`] naming `what` and both sizes.
pub fn check_memory(what: &str, needed: u64, limit: u64) -> Result<()> {
    check_memory_under(what, needed, MemoryCeiling::given(limit))
}

/// Checks that `needed` bytes fit under `ceiling`.
///
/// # Errors
/// [`Error::OutOfMemory`] naming `what`, both sizes and what sets the ceiling.
pub fn check_memory_under(what: &str, needed: u64, ceiling: MemoryCeiling) -> Result<()> {
    if needed > ceiling.bytes {
        return Err(Error::OutOfMemory {
            what: what.to_string(),
            reason: format!(
                "it needs about {} but {} may be used ({})",
                human(needed),
                human(ceiling.bytes),
                ceiling.source
            ),
        });
    }
    Ok(())
}

/// Bytes in binary units, one decimal.
#[must_use]
pub fn human(bytes: u64) -> String {
    let units = ["B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    let mut v = bytes as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < units.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{bytes} B")
    } else {
        format!("{v:.1} {}", units[u])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ceilings_read_from_proc_texts() {
        let meminfo = "MemTotal: 24000000 kB\nMemFree: 100 kB\nMemAvailable:   2048 kB\n";
        assert_eq!(meminfo_available(meminfo), Some(2 << 20));
        assert_eq!(meminfo_available("MemTotal: 1 kB\n"), None);
        let limits = "Limit                     Soft Limit           Hard Limit           Units\n\
                      Max stack size            8388608              unlimited            bytes\n\
                      Max address space         1024000000           unlimited            bytes\n";
        let status = "Name:\tthrong\nVmPeak:\t  9000 kB\nVmSize:\t  1000 kB\n";
        assert_eq!(
            address_space_left(limits, status),
            Some(1_024_000_000 - 1_024_000)
        );
        let unlimited = limits.replace("1024000000 ", "unlimited  ");
        assert_eq!(address_space_left(&unlimited, status), None);
        // More in use than the limit (a limit lowered after start): nothing left, not a wrap.
        let tiny = limits.replace("1024000000 ", "1000       ");
        assert_eq!(address_space_left(&tiny, status), Some(0));
    }

    #[test]
    fn the_ceiling_is_the_least_bound_and_names_it() {
        // This process runs under at least the machine's memory, wherever /proc exists.
        if let Some(c) = memory_ceiling() {
            assert_eq!(available_memory(), Some(c.bytes));
            let e = check_memory_under("x", c.bytes.saturating_add(1 << 30), c)
                .unwrap_err()
                .to_string();
            assert!(e.contains(c.source), "{e}");
        }
    }

    #[test]
    fn sizes_parse_with_binary_suffixes() {
        assert_eq!(parse_size("1024").unwrap(), 1024);
        assert_eq!(parse_size("512M").unwrap(), 512 << 20);
        assert_eq!(parse_size("4GiB").unwrap(), 4 << 30);
        assert_eq!(parse_size("1.5k").unwrap(), 1536);
        for bad in ["", "G", "-1G", "1X", "nan", "0"] {
            assert!(parse_size(bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn memory_beyond_the_limit_is_an_error_naming_both() {
        let e = check_memory("flock", 3 << 30, 1 << 30)
            .unwrap_err()
            .to_string();
        assert!(e.contains("3.0 GiB") && e.contains("1.0 GiB"), "{e}");
        assert!(check_memory("flock", 1, 1).is_ok());
    }
}
