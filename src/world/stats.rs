//! What a step reports: the time spent in each of its phases ([`PhaseTimes`]) and its counts
//! ([`StepStats`]: the frame, agents, arrivals, departures through exits, mean neighbours).

use std::time::Duration;

/// Wall-clock time of each phase of a step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PhaseTimes {
    /// Gravity points moved and reindexed, the neighbour index rebuilt (and agents reordered by
    /// cell when due), the nearest-agent indices built.
    pub index: Duration,
    /// The parallel steering pass.
    pub steer: Duration,
    /// The vectorised integrator (in a parallel step without contact resolution, the world's
    /// wrap-around or containment too, applied to each task's agents right after it).
    pub integrate: Duration,
    /// Contact resolution, wrap-around or containment (when the integrator did not apply them)
    /// and obstacle non-penetration.
    pub bounds: Duration,
    /// The fields' work: goal shuffles and channel rebuilds before steering; wall
    /// non-penetration, grid walkers and arrivals after the move.
    pub fields: Duration,
    /// Formation slot assignment (the Hungarian method, when membership changed).
    pub formations: Duration,
    /// The scenario's measurement lines and areas observed after the step: added by
    /// [`Measurements::observe_step`](crate::measure::Measurements::observe_step), 0 where
    /// nothing is measured.
    pub measure: Duration,
}

impl PhaseTimes {
    /// Number of phases.
    pub const COUNT: usize = 7;

    /// Phase names, as used in frame timings and `bench --json`: the four of the pipeline, the
    /// subsystems' hooks, then the measurements.
    pub const NAMES: [&'static str; Self::COUNT] = [
        "index",
        "steer",
        "integrate",
        "bounds",
        "fields",
        "formations",
        "measure",
    ];

    /// Each phase in milliseconds, in the order of [`PhaseTimes::NAMES`].
    #[must_use]
    pub fn as_ms(&self) -> [f64; Self::COUNT] {
        [
            self.index,
            self.steer,
            self.integrate,
            self.bounds,
            self.fields,
            self.formations,
            self.measure,
        ]
        .map(|d| d.as_secs_f64() * 1e3)
    }
}

/// What one call of `World::step` did and how long it took.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepStats {
    /// The frame number the step produced (1 after the first step).
    pub frame: u64,
    /// Agents stepped.
    pub agents: usize,
    /// Time of the whole step, measurements included (the sum of the phases and the pipeline's
    /// own bookkeeping).
    pub total: Duration,
    /// Time of each phase.
    pub phases: PhaseTimes,
    /// Mean number of neighbours found per agent within the largest query radius (0 when no
    /// behaviour queries neighbours).
    pub mean_neighbours: f64,
    /// Agents within their group's arrival radius of their own target after the step.
    pub arrived: usize,
    /// Agents of groups with an arrival radius (0 when no group has one).
    pub with_goal: usize,
    /// Agents that left the world through an exit in this step (they are not in `agents`).
    pub left: usize,
}

impl StepStats {
    /// The whole step in milliseconds.
    #[must_use]
    pub fn total_ms(&self) -> f64 {
        self.total.as_secs_f64() * 1e3
    }

    /// The whole step in milliseconds, under the name the command line's `step` column and
    /// Python's `"step"` key give it (the same value as [`StepStats::total_ms`]).
    #[must_use]
    pub fn step_ms(&self) -> f64 {
        self.total_ms()
    }
}
