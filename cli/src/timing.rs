//! Frame timing lines, run summaries and the `bench --json` object: the library's
//! [`throng::timing`], with the benchmark report printed as JSON.

pub use throng::timing::{BenchReport, Timings, frame_line};

/// The `bench --json` object of a report.
pub fn json(report: &BenchReport) -> String {
    serde_json::to_string(report).expect("a report of numbers and strings always serialises")
}
