//! Frame timing lines, run summaries and the `bench --json` object.

use std::time::Duration;

use throng::StepStats;
use throng::world::PhaseTimes;

/// Per-step measurements of a run.
#[derive(Debug, Default)]
pub struct Timings {
    total_ms: Vec<f64>,
    phase_ms: Vec<[f64; PhaseTimes::COUNT]>,
    neighbours: Vec<f64>,
    agent_steps: u64,
}

/// One line per reported frame: frame number, ms for the step and each phase, agents.
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

impl Timings {
    /// Records one step.
    pub fn push(&mut self, s: &StepStats) {
        self.total_ms.push(s.total_ms());
        self.phase_ms.push(s.phases.as_ms());
        self.neighbours.push(s.mean_neighbours);
        self.agent_steps += s.agents as u64;
    }

    fn sorted(&self) -> Vec<f64> {
        let mut v = self.total_ms.clone();
        v.sort_by(f64::total_cmp);
        v
    }

    fn mean(&self) -> f64 {
        if self.total_ms.is_empty() {
            0.0
        } else {
            self.total_ms.iter().sum::<f64>() / self.total_ms.len() as f64
        }
    }

    fn agent_steps_per_sec(&self) -> f64 {
        let secs: f64 = self.total_ms.iter().sum::<f64>() / 1e3;
        if secs > 0.0 {
            self.agent_steps as f64 / secs
        } else {
            0.0
        }
    }

    fn mean_neighbours(&self) -> f64 {
        if self.neighbours.is_empty() {
            0.0
        } else {
            self.neighbours.iter().sum::<f64>() / self.neighbours.len() as f64
        }
    }

    /// The closing summary of a run.
    pub fn summary(&self, wall: Duration) -> String {
        let s = self.sorted();
        format!(
            "summary: {} steps in {:.2} s | ms/step mean {:.3} median {:.3} p95 {:.3} p99 {:.3} max {:.3} | {:.3e} agent-steps/s | mean neighbours {:.2}",
            s.len(),
            wall.as_secs_f64(),
            self.mean(),
            median(&s),
            quantile(&s, 0.95),
            quantile(&s, 0.99),
            s.last().copied().unwrap_or(0.0),
            self.agent_steps_per_sec(),
            self.mean_neighbours()
        )
    }

    /// The `bench --json` object.
    pub fn json(
        &self,
        scenario: &str,
        agents: usize,
        threads: usize,
        index: &str,
        steps: u64,
    ) -> String {
        let s = self.sorted();
        let mut phases = serde_json::Map::new();
        for (k, name) in PhaseTimes::NAMES.iter().enumerate() {
            let v: Vec<f64> = self.phase_ms.iter().map(|p| p[k]).collect();
            phases.insert((*name).to_string(), serde_json::json!(median(&v)));
        }
        serde_json::json!({
            "scenario": scenario,
            "agents": agents,
            "threads": threads,
            "index": index,
            "steps": steps,
            "ms_per_step": {
                "median": median(&s),
                "mean": self.mean(),
                "p95": quantile(&s, 0.95),
                "p99": quantile(&s, 0.99),
                "min": s.first().copied().unwrap_or(0.0),
                "max": s.last().copied().unwrap_or(0.0),
            },
            "phases_ms": phases,
            "agent_steps_per_sec": self.agent_steps_per_sec(),
            "mean_neighbours": self.mean_neighbours(),
            "peak_rss_mb": peak_rss_mb(),
        })
        .to_string()
    }
}

/// The process's peak resident memory in MiB (Linux `VmHWM`; 0 where unavailable).
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
