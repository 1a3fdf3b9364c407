//! Pedestrian measurements as the analysis tools of pedestrian dynamics make them (PedPy,
//! JPSreport): flow through measurement lines, density and speed in measurement areas, and the
//! evacuation time.
//!
//! A [`Measurements`] recorder is built from a [`MeasurementSpec`] (the scenario's
//! `[measurements]` table) and fed the world after every step with
//! [`Measurements::observe`]; [`Measurements::report`] condenses what it saw into a
//! [`MeasurementReport`], which the CLI prints at the end of a run and `throng bench --json`
//! includes.
//!
//! Definitions (units are the world's: metres and seconds for pedestrians):
//! - **Crossing**: the straight move of an agent between two observed frames meets a line
//!   ([`MeasurementLine`] says which way is positive and how touching is treated). Its time is
//!   interpolated along the move. Every crossing counts, in each direction (PedPy's N-t diagram
//!   keeps only each pedestrian's first one; with one-way traffic the two agree).
//! - **Flow** `J = (N - 1) / (t_N - t_1)` over the `N` crossings (both directions) in the time
//!   window: the number of time gaps over their total duration, i.e. one over the mean time gap.
//!   An agent that crosses back and forth counts each time, so with counterflow or oscillation
//!   at the line it is not the flow a researcher reports: that is the **N-t flow**.
//! - **N-t diagram** (PedPy's `compute_n_t`): each agent counts once, at its first crossing in
//!   either direction; `nt_count` is the number of first crossings in the window and the **N-t
//!   flow** `(N - 1) / (t_N - t_1)` is taken over their times.
//!   PedPy's `compute_flow` divides the crossings of each interval by the time from the previous
//!   interval's last crossing, the same estimator, except that its first interval counts the first
//!   pedestrian too (`N / (t_N - t_1)`). The **specific flow** is `J / b`, `b` the line's length.
//! - **Time gaps** (time headways): the differences between consecutive crossing times; their
//!   mean and sample standard deviation.
//! - **Classic density** of an area in a frame: agents inside over the polygon's area (PedPy's
//!   `compute_classic_density`); its **mean speed**: the mean of the speeds `|v|` of the agents
//!   inside (frames with nobody inside have none). Over a window, both are means over frames.
//! - **Voronoi density and speed** of an area in a frame (with `voronoi = true`; PedPy's
//!   `compute_voronoi_density` and `compute_voronoi_speed`): each agent owns the part of the
//!   walkable area nearer to it than to any other; the density is the sum over agents of the
//!   share of their cell inside the area, over the area's size, the speed the sum of `|v|`
//!   times the cell's part inside, over the size ([`voronoi`]).
//! - **Evacuation time**: the world time of the step in which the last agent left through an
//!   exit, when the world has exits and is empty.
//!
//! Invariants: results depend only on the sequence of observed worlds, never on the thread
//! count (the world itself is bit-identical for any count) or on storage order: each frame's
//! crossings are sorted by time, then agent id, and counts and crossing times are per agent.
//! Agents that an exit removes in a step are measured through [`World::departures`], so a
//! crossing on the way out is counted. Memory is constant in the run's length: statistics are
//! kept as running sums.

mod geometry;
mod recorder;
pub mod voronoi;

pub use geometry::{MeasurementArea, MeasurementLine};
pub use recorder::{AreaFrame, AreaReport, Crossing, LineReport, MeasurementReport, Measurements};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
#[cfg(doc)]
use crate::world::World;

/// The scenario's `[measurements]` table: lines, areas and the time window of the summary.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, try_from = "SpecFields")]
pub struct MeasurementSpec {
    /// Counting lines (`[[measurements.lines]]`). Default: none.
    pub lines: Vec<MeasurementLine>,
    /// Areas (`[[measurements.areas]]`). Default: none.
    pub areas: Vec<MeasurementArea>,
    /// The summary's time window `[t0, t1]`, seconds of world time (both ends included).
    /// Default: the whole run.
    pub window: Option<[f64; 2]>,
    /// Whether areas also measure the Voronoi density and speed (PedPy's definitions,
    /// [`voronoi`]); the cells need the world's walkable area (`[geometry]`) or its walled
    /// bounds, and cost about `N` cell clippings per observed frame. Default: false.
    pub voronoi: bool,
}

/// The unchecked fields of a [`MeasurementSpec`].
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SpecFields {
    #[serde(default)]
    lines: Vec<MeasurementLine>,
    #[serde(default)]
    areas: Vec<MeasurementArea>,
    /// Any length, so that `[0, 1, 2]` is an error instead of `[0, 1]`.
    #[serde(default)]
    window: Option<Vec<f64>>,
    #[serde(default)]
    voronoi: bool,
}

impl TryFrom<SpecFields> for MeasurementSpec {
    type Error = Error;
    fn try_from(f: SpecFields) -> Result<Self> {
        let window = match f.window.as_deref() {
            None => None,
            Some(&[t0, t1]) => Some([t0, t1]),
            Some(other) => {
                return Err(Error::Invalid {
                    name: "measurements.window".into(),
                    reason: format!("expected two times [t0, t1], got {} numbers", other.len()),
                });
            }
        };
        let spec = MeasurementSpec {
            lines: f.lines,
            areas: f.areas,
            window,
            voronoi: f.voronoi,
        };
        spec.validate()?;
        Ok(spec)
    }
}

impl MeasurementSpec {
    /// Whether there is nothing to measure (no line, no area).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.lines.is_empty() && self.areas.is_empty()
    }

    /// Checks every line and area, that names are unique, and the window.
    ///
    /// # Errors
    /// As [`MeasurementLine::validate`] and [`MeasurementArea::validate`];
    /// [`Error::OutOfRange`] for more than [`MAX_MEASUREMENTS`](crate::limits::MAX_MEASUREMENTS)
    /// lines or areas; [`Error::Invalid`] for a name used twice or a window that is not two
    /// finite times with `t0 <= t1`.
    pub fn validate(&self) -> Result<()> {
        let max = crate::limits::MAX_MEASUREMENTS;
        for (name, count) in [
            ("measurements.lines", self.lines.len()),
            ("measurements.areas", self.areas.len()),
        ] {
            if count > max {
                return Err(Error::OutOfRange {
                    name,
                    value: count as f64,
                    range: "[0, 256] entries",
                });
            }
        }
        for l in &self.lines {
            l.validate()?;
        }
        for a in &self.areas {
            a.validate()?;
        }
        let mut names: Vec<&str> = self
            .lines
            .iter()
            .map(|l| l.name.as_str())
            .chain(self.areas.iter().map(|a| a.name.as_str()))
            .collect();
        names.sort_unstable();
        if let Some(w) = names.windows(2).find(|w| w[0] == w[1]) {
            return Err(Error::Invalid {
                name: "measurements".into(),
                reason: format!(
                    "the name `{}` is used twice (lines and areas share names)",
                    w[0]
                ),
            });
        }
        if let Some([t0, t1]) = self.window
            && !(t0.is_finite() && t1.is_finite() && t0 <= t1)
        {
            return Err(Error::Invalid {
                name: "measurements.window".into(),
                reason: format!("[{t0}, {t1}] must be two finite times with t0 <= t1"),
            });
        }
        Ok(())
    }
}
