use std::time::Duration;

/// Wall-clock time of each phase of a step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PhaseTimes {
    /// Rebuilding the neighbour index (and reordering agents by cell when due).
    pub index: Duration,
    /// The parallel steering pass.
    pub steer: Duration,
    /// The vectorised integrator.
    pub integrate: Duration,
    /// Wrap-around, containment and obstacle non-penetration.
    pub bounds: Duration,
}

impl PhaseTimes {
    /// Phase names, in pipeline order, as used in frame timings and `bench --json`.
    pub const NAMES: [&'static str; 4] = ["index", "steer", "integrate", "bounds"];

    /// Each phase in milliseconds, in the order of [`PhaseTimes::NAMES`].
    #[must_use]
    pub fn as_ms(&self) -> [f64; 4] {
        [self.index, self.steer, self.integrate, self.bounds].map(|d| d.as_secs_f64() * 1e3)
    }
}

/// What one call of `World::step` did and how long it took.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepStats {
    /// The frame number the step produced (1 after the first step).
    pub frame: u64,
    /// Agents stepped.
    pub agents: usize,
    /// Time of the whole step.
    pub total: Duration,
    /// Time of each phase.
    pub phases: PhaseTimes,
    /// Mean number of neighbours found per agent within the largest query radius (0 when no
    /// behaviour queries neighbours).
    pub mean_neighbours: f64,
}

impl StepStats {
    /// The whole step in milliseconds.
    #[must_use]
    pub fn total_ms(&self) -> f64 {
        self.total.as_secs_f64() * 1e3
    }
}
