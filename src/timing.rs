//! Step timings of a run: frame lines, run summaries and the benchmark report.
//!
//! [`Timings`] collects the [`StepStats`] of each step; [`Timings::report`] condenses them into a
//! [`BenchReport`], the object that `throng bench --json` prints and that the Python bindings
//! return from `throng.bench`. Its serialised keys are a public interface: keys are added, never
//! renamed. The fields are declared in alphabetical order so that any serialiser writes the keys
//! in the same order.
//!
//! Quantiles are nearest-rank over the per-step totals; the median of an even count is the mean
//! of the two middle values. Every statistic of an empty record is 0.

use std::collections::BTreeMap;
use std::time::Duration;

use serde::Serialize;

use crate::measure::{MeasurementReport, Measurements};
use crate::world::{PhaseTimes, StepStats};

/// Per-step measurements of a run.
#[derive(Clone, Debug, Default)]
pub struct Timings {
    total_ms: Vec<f64>,
    phase_ms: Vec<[f64; PhaseTimes::COUNT]>,
    neighbours: Vec<f64>,
    polarisation: Vec<f64>,
    agent_steps: u64,
    arrivals: Arrivals,
}

/// Arrivals over a run: the latest counts and the first frame at which every agent with a
/// goal had arrived.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Arrivals {
    /// Agents at their goal after the latest step.
    pub arrived: usize,
    /// Agents with a goal (in groups with an arrival radius) after the latest step.
    pub with_goal: usize,
    /// The first frame after which every agent with a goal was at it.
    pub all_arrived_frame: Option<u64>,
}

impl Arrivals {
    /// Records one step.
    pub fn push(&mut self, s: &StepStats) {
        self.arrived = s.arrived;
        self.with_goal = s.with_goal;
        if self.all_arrived_frame.is_none() && s.with_goal > 0 && s.arrived == s.with_goal {
            self.all_arrived_frame = Some(s.frame);
        }
    }

    /// Whether every agent with a goal has arrived (false when none has a goal).
    #[must_use]
    pub fn all(&self) -> bool {
        self.with_goal > 0 && self.arrived == self.with_goal
    }

    /// The summary's arrival part, empty when no agent has a goal.
    fn describe(&self) -> String {
        if self.with_goal == 0 {
            return String::new();
        }
        match self.all_arrived_frame {
            Some(f) => format!(
                " | arrived {}/{} (all at frame {f})",
                self.arrived, self.with_goal
            ),
            None => format!(
                " | arrived {}/{} ({} left)",
                self.arrived,
                self.with_goal,
                self.with_goal - self.arrived
            ),
        }
    }
}

/// Milliseconds per step over a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct StepMs {
    /// The slowest step.
    pub max: f64,
    /// The mean step.
    pub mean: f64,
    /// The median step.
    pub median: f64,
    /// The fastest step.
    pub min: f64,
    /// The 95th percentile (nearest rank).
    pub p95: f64,
    /// The 99th percentile (nearest rank).
    pub p99: f64,
}

/// The benchmark report of `throng bench --json` (and of Python's `throng.bench`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct BenchReport {
    /// Agents stepped per second of step time, summed over the timed steps.
    pub agent_steps_per_sec: f64,
    /// Agents in the world at the end.
    pub agents: usize,
    /// The first frame at which every agent with a goal had arrived (`null` when not all
    /// arrived, or no agent has a goal).
    pub all_arrived_step: Option<u64>,
    /// Agents at their goal at the end (0 when no group has an arrival radius).
    pub arrived: usize,
    /// The world time at which the last agent left through an exit (`null` when the world has
    /// no exits or did not empty); see [`Measurements::evacuation_time`].
    pub evacuation_time: Option<f64>,
    /// The neighbour-index backend.
    pub index: String,
    /// Mean over the timed steps of the mean neighbours per agent.
    pub mean_neighbours: f64,
    /// The scenario's measurement lines and areas over the whole run, warm-up included (empty
    /// lists when it has none).
    pub measurements: MeasurementReport,
    /// Milliseconds per step.
    pub ms_per_step: StepMs,
    /// The process's peak resident memory, MiB (see [`peak_rss_mb`]).
    pub peak_rss_mb: f64,
    /// The median milliseconds of each phase, by the names of [`PhaseTimes::NAMES`].
    pub phases_ms: BTreeMap<&'static str, f64>,
    /// Mean over the timed steps of the polarisation after each step (the order parameter,
    /// `World::polarisation`); 0 when it was not recorded.
    pub polarisation: f64,
    /// The scenario's name.
    pub scenario: String,
    /// Timed steps.
    pub steps: u64,
    /// Worker threads.
    pub threads: usize,
}

impl BenchReport {
    /// The report with the measurements' summary and evacuation time.
    #[must_use]
    pub fn measured(mut self, m: &Measurements) -> Self {
        self.evacuation_time = m.evacuation_time();
        self.measurements = m.report();
        self
    }
}

/// One line per reported frame: frame number, ms for the step and each phase, agents.
#[must_use]
pub fn frame_line(s: &StepStats) -> String {
    let phases: Vec<String> = PhaseTimes::NAMES
        .iter()
        .zip(s.phases.as_ms())
        .map(|(n, ms)| format!("{n} {ms:7.3}"))
        .collect();
    format!(
        "frame {:6}  step {:8.3} ms  [{}]  agents {}",
        s.frame,
        s.total_ms(),
        phases.join("  "),
        s.agents
    )
}

/// The `q` quantile (0..=1) of sorted values, nearest rank.
fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let rank = ((q * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len());
    sorted[rank - 1]
}

fn median(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        0.0
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn mean(values: &[f64]) -> f64 {
    if values.is_empty() {
        0.0
    } else {
        values.iter().sum::<f64>() / values.len() as f64
    }
}

impl Timings {
    /// Records one step.
    pub fn push(&mut self, s: &StepStats) {
        self.total_ms.push(s.total_ms());
        self.phase_ms.push(s.phases.as_ms());
        self.neighbours.push(s.mean_neighbours);
        self.agent_steps += s.agents as u64;
        self.arrivals.push(s);
    }

    /// Arrivals over the recorded steps.
    #[must_use]
    pub fn arrivals(&self) -> Arrivals {
        self.arrivals
    }

    /// Records one step and the world's polarisation after it (measured outside the step's
    /// time).
    pub fn push_world(&mut self, s: &StepStats, world: &crate::World) {
        self.push(s);
        self.polarisation.push(f64::from(world.polarisation()));
    }

    /// Steps recorded.
    #[must_use]
    pub fn len(&self) -> usize {
        self.total_ms.len()
    }

    /// Whether no step was recorded.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.total_ms.is_empty()
    }

    fn sorted(&self) -> Vec<f64> {
        let mut v = self.total_ms.clone();
        v.sort_by(f64::total_cmp);
        v
    }

    fn agent_steps_per_sec(&self) -> f64 {
        let secs: f64 = self.total_ms.iter().sum::<f64>() / 1e3;
        if secs > 0.0 {
            self.agent_steps as f64 / secs
        } else {
            0.0
        }
    }

    /// Milliseconds per step: median, mean, quantiles and extremes.
    #[must_use]
    pub fn step_ms(&self) -> StepMs {
        let s = self.sorted();
        StepMs {
            max: s.last().copied().unwrap_or(0.0),
            mean: mean(&self.total_ms),
            median: median(&s),
            min: s.first().copied().unwrap_or(0.0),
            p95: quantile(&s, 0.95),
            p99: quantile(&s, 0.99),
        }
    }

    /// The median milliseconds of each phase, in the order of [`PhaseTimes::NAMES`].
    #[must_use]
    pub fn phase_medians(&self) -> [f64; PhaseTimes::COUNT] {
        std::array::from_fn(|k| {
            let v: Vec<f64> = self.phase_ms.iter().map(|p| p[k]).collect();
            median(&v)
        })
    }

    /// The closing summary line of a run that took `wall` in all.
    #[must_use]
    pub fn summary(&self, wall: Duration) -> String {
        summary_line(
            self.len() as u64,
            wall,
            self.step_ms(),
            self.agent_steps_per_sec(),
            mean(&self.neighbours),
            mean(&self.polarisation),
        ) + &self.arrivals.describe()
    }

    /// The benchmark report of the recorded steps.
    #[must_use]
    pub fn report(
        &self,
        scenario: &str,
        agents: usize,
        threads: usize,
        index: &str,
        steps: u64,
    ) -> BenchReport {
        BenchReport {
            agent_steps_per_sec: self.agent_steps_per_sec(),
            agents,
            all_arrived_step: self.arrivals.all_arrived_frame,
            arrived: self.arrivals.arrived,
            evacuation_time: None,
            index: index.to_string(),
            mean_neighbours: mean(&self.neighbours),
            measurements: MeasurementReport::default(),
            ms_per_step: self.step_ms(),
            peak_rss_mb: peak_rss_mb(),
            phases_ms: PhaseTimes::NAMES
                .into_iter()
                .zip(self.phase_medians())
                .collect(),
            polarisation: mean(&self.polarisation),
            scenario: scenario.to_string(),
            steps,
            threads,
        }
    }
}

/// The summary line of [`Timings::summary`] and [`RunningTimings::summary`].
fn summary_line(
    steps: u64,
    wall: Duration,
    ms: StepMs,
    agent_steps_per_sec: f64,
    neighbours: f64,
    polarisation: f64,
) -> String {
    format!(
        "summary: {steps} steps in {:.2} s | ms/step mean {:.3} median {:.3} p95 {:.3} p99 {:.3} max {:.3} | {:.3e} agent-steps/s | mean neighbours {:.2} | polarisation {:.4}",
        wall.as_secs_f64(),
        ms.mean,
        ms.median,
        ms.p95,
        ms.p99,
        ms.max,
        agent_steps_per_sec,
        neighbours,
        polarisation
    )
}

/// Histogram buckets per factor of ten of [`RunningTimings`] (each about 1.2% wide).
const BUCKETS_PER_DECADE: f64 = 200.0;
/// The lower edge of the first bucket, ms; everything below counts in it.
const HISTOGRAM_MIN_MS: f64 = 1e-4;
/// Buckets: ten decades, from 0.1 us to 1000 s per step (slower steps count in the last).
const HISTOGRAM_BUCKETS: usize = 2000;

/// Running statistics of a run's steps in constant memory (a long `run` or `demo` keeps these,
/// not one sample per step): exact count, mean, minimum, maximum and means of the neighbours
/// and the polarisation; median and quantiles from a histogram of logarithmic buckets, each
/// reported as its bucket's upper edge (within 1.2% of the nearest-rank value, and never
/// outside the exact minimum and maximum).
#[derive(Clone, Debug)]
pub struct RunningTimings {
    steps: u64,
    sum_ms: f64,
    min_ms: f64,
    max_ms: f64,
    histogram: Vec<u64>,
    neighbours: f64,
    polarisation: f64,
    agent_steps: u64,
    arrivals: Arrivals,
}

impl Default for RunningTimings {
    fn default() -> Self {
        RunningTimings {
            steps: 0,
            sum_ms: 0.0,
            min_ms: f64::INFINITY,
            max_ms: 0.0,
            histogram: vec![0; HISTOGRAM_BUCKETS],
            neighbours: 0.0,
            polarisation: 0.0,
            agent_steps: 0,
            arrivals: Arrivals::default(),
        }
    }
}

impl RunningTimings {
    /// Records one step and the world's polarisation after it.
    pub fn push_world(&mut self, s: &StepStats, world: &crate::World) {
        let ms = s.total_ms();
        self.steps += 1;
        self.sum_ms += ms;
        self.min_ms = self.min_ms.min(ms);
        self.max_ms = self.max_ms.max(ms);
        let k = if ms > HISTOGRAM_MIN_MS {
            ((ms / HISTOGRAM_MIN_MS).log10() * BUCKETS_PER_DECADE) as usize
        } else {
            0
        };
        self.histogram[k.min(HISTOGRAM_BUCKETS - 1)] += 1;
        self.neighbours += s.mean_neighbours;
        self.polarisation += f64::from(world.polarisation());
        self.agent_steps += s.agents as u64;
        self.arrivals.push(s);
    }

    /// Arrivals over the recorded steps.
    #[must_use]
    pub fn arrivals(&self) -> Arrivals {
        self.arrivals
    }

    /// Steps recorded.
    #[must_use]
    pub fn len(&self) -> u64 {
        self.steps
    }

    /// Whether no step was recorded.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.steps == 0
    }

    /// The `q` quantile (0..=1), nearest rank, as the upper edge of its bucket clamped to the
    /// exact extremes.
    fn quantile(&self, q: f64) -> f64 {
        if self.steps == 0 {
            return 0.0;
        }
        let rank = ((q * self.steps as f64).ceil() as u64).clamp(1, self.steps);
        let mut seen = 0;
        for (k, &c) in self.histogram.iter().enumerate() {
            seen += c;
            if seen >= rank {
                let edge = HISTOGRAM_MIN_MS * 10f64.powf((k + 1) as f64 / BUCKETS_PER_DECADE);
                return edge.clamp(self.min_ms, self.max_ms);
            }
        }
        self.max_ms
    }

    /// Milliseconds per step (see the type's docs for the precision of the quantiles).
    #[must_use]
    pub fn step_ms(&self) -> StepMs {
        if self.steps == 0 {
            return StepMs::default();
        }
        StepMs {
            max: self.max_ms,
            mean: self.sum_ms / self.steps as f64,
            median: self.quantile(0.5),
            min: self.min_ms,
            p95: self.quantile(0.95),
            p99: self.quantile(0.99),
        }
    }

    /// The closing summary line of a run that took `wall` in all (as [`Timings::summary`]).
    #[must_use]
    pub fn summary(&self, wall: Duration) -> String {
        let n = self.steps.max(1) as f64;
        let secs = self.sum_ms / 1e3;
        let rate = if secs > 0.0 {
            self.agent_steps as f64 / secs
        } else {
            0.0
        };
        summary_line(
            self.steps,
            wall,
            self.step_ms(),
            rate,
            self.neighbours / n,
            self.polarisation / n,
        ) + &self.arrivals.describe()
    }
}

/// The process's peak resident memory in MiB (Linux `VmHWM`; 0 where unavailable).
#[must_use]
pub fn peak_rss_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines().find(|l| l.starts_with("VmHWM:")).and_then(|l| {
                l.split_whitespace()
                    .nth(1)
                    .and_then(|kb| kb.parse::<f64>().ok())
            })
        })
        .map_or(0.0, |kb| kb / 1024.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stats(ms: u64, agents: usize) -> StepStats {
        StepStats {
            frame: 1,
            agents,
            total: Duration::from_millis(ms),
            phases: PhaseTimes {
                steer: Duration::from_millis(ms),
                ..PhaseTimes::default()
            },
            mean_neighbours: 2.0,
            ..StepStats::default()
        }
    }

    #[test]
    fn quantiles_are_nearest_rank_and_the_even_median_averages() {
        let mut t = Timings::default();
        for ms in [4, 1, 3, 2] {
            t.push(&stats(ms, 10));
        }
        let ms = t.step_ms();
        assert_eq!((ms.min, ms.max, ms.median, ms.mean), (1.0, 4.0, 2.5, 2.5));
        assert_eq!((ms.p95, ms.p99), (4.0, 4.0));
        assert_eq!(t.phase_medians(), [0.0, 2.5, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let r = t.report("s", 10, 2, "grid", 4);
        assert_eq!(r.agent_steps_per_sec, 40.0 / 0.010);
        assert_eq!(r.mean_neighbours, 2.0);
        assert_eq!(r.phases_ms.len(), PhaseTimes::COUNT);
        assert_eq!(r.polarisation, 0.0, "not recorded by push");
    }

    #[test]
    fn running_quantiles_stay_within_a_bucket_of_the_exact_ones() {
        let world = crate::World::builder().build().unwrap();
        let mut exact = Timings::default();
        let mut running = RunningTimings::default();
        for k in 0..1000u64 {
            let s = StepStats {
                total: Duration::from_micros(50 + (k * 7919) % 20_000),
                ..stats(0, 3)
            };
            exact.push_world(&s, &world);
            running.push_world(&s, &world);
        }
        let (e, r) = (exact.step_ms(), running.step_ms());
        assert_eq!((r.min, r.max), (e.min, e.max));
        assert!((r.mean - e.mean).abs() < 1e-9 * e.mean);
        for (a, b) in [(r.median, e.median), (r.p95, e.p95), (r.p99, e.p99)] {
            assert!((a - b).abs() <= 0.012 * b, "{a} vs {b}");
        }
        assert_eq!(running.len(), 1000);
        assert_eq!(RunningTimings::default().step_ms(), StepMs::default());
    }

    #[test]
    fn an_empty_record_reports_zeros() {
        let r = Timings::default().report("s", 0, 1, "grid", 0);
        assert_eq!(r.ms_per_step, StepMs::default());
        assert_eq!(r.agent_steps_per_sec, 0.0);
    }
}
