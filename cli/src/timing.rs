//! Frame timing lines, run summaries and the `bench --json` object: the library's
//! [`throng::timing`], with the benchmark report printed as JSON.

pub use throng::timing::{Timings, frame_line};

/// The `bench --json` object of the recorded steps.
pub fn json(
    timings: &Timings,
    scenario: &str,
    agents: usize,
    threads: usize,
    index: &str,
    steps: u64,
) -> String {
    let report = timings.report(scenario, agents, threads, index, steps);
    serde_json::to_string(&report).expect("a report of numbers and strings always serialises")
}
