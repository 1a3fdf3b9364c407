//! `throng.bench`: the CLI's `throng bench --json`, returned as a dict with the same keys.

use pyo3::prelude::*;
use pyo3::types::PyDict;
use throng::measure::Measurements;
use throng::timing::Timings;
use throng::{Error, IndexKind};

use crate::convert;
use crate::error::{OrRaise, guarded, raise, unsigned};
use crate::scenario::{Source, load};
use crate::world::{build, changes, pool};

/// Times a built-in scenario or a scenario file as `throng bench SCENARIO --json` does
/// (`warmup` untimed steps, then `steps` timed ones, GIL released) and returns the same
/// object: {"scenario", "agents", "threads", "index", "steps", "ms_per_step": {"median",
/// "mean", "p95", "p99", "min", "max"}, "phases_ms", "agent_steps_per_sec",
/// "mean_neighbours", "peak_rss_mb", "polarisation", "arrived", "all_arrived_step",
/// "evacuation_time", "measurements": {"lines", "areas", "left"}}; the measurements cover the
/// warm-up steps too.
/// `threads` defaults to all cores; the other keywords are those of `World.from_scenario`.
#[pyfunction]
#[pyo3(signature = (scenario, *, agents=None, steps=100, warmup=10, threads=None, seed=None, dt=None, index=None, **overrides))]
#[expect(
    clippy::too_many_arguments,
    reason = "the Python signature: the keywords of `throng bench`"
)]
pub(crate) fn bench<'py>(
    py: Python<'py>,
    scenario: &str,
    agents: Option<i128>,
    steps: i128,
    warmup: i128,
    threads: Option<i128>,
    seed: Option<i128>,
    dt: Option<f32>,
    index: Option<&str>,
    overrides: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let steps: u64 = unsigned("steps", steps)?;
    let warmup: u64 = unsigned("warmup", warmup)?;
    if steps == 0 {
        return Err(raise(&Error::NotPositive {
            name: "steps",
            value: 0.0,
        }));
    }
    let mut s = load(
        &Source::name_or_file(scenario),
        &changes(agents, seed, overrides)?,
    )
    .or_raise()?;
    if let Some(index) = index {
        s.world.index = index.parse::<IndexKind>().or_raise()?;
    }
    if let Some(dt) = dt {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(raise(&Error::InvalidTimeStep { dt: f64::from(dt) }));
        }
        s.dt = dt;
    }
    let threads = threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get() as i128));
    let pool = pool(Some(threads))?.expect("a thread count was given");
    let mut world = build(&s)?;
    let dt = s.dt;
    let mut measure = Measurements::new(&s.measurements).or_raise()?;
    let timings = guarded(|| {
        py.detach(|| {
            pool.install(|| -> throng::Result<Timings> {
                measure.observe(&world);
                for _ in 0..warmup {
                    world.step(dt)?;
                    measure.observe(&world);
                }
                let mut timings = Timings::default();
                for _ in 0..steps {
                    let mut stats = world.step(dt)?;
                    measure.observe_step(&world, &mut stats);
                    timings.push_world(&stats, &world);
                }
                Ok(timings)
            })
        })
        .or_raise()
    })?;
    let report = timings
        .report(
            &s.name,
            world.len(),
            pool.current_num_threads(),
            &world.index_kind().to_string(),
            steps,
        )
        .measured(&measure);
    let dict = convert::serialize_to_py(py, &report, false)?;
    // The conversion goes through TOML, which has no null: restore the CLI's `null`s.
    let dict = dict.cast::<PyDict>()?;
    for key in ["all_arrived_step", "evacuation_time"] {
        if !dict.contains(key)? {
            dict.set_item(key, py.None())?;
        }
    }
    let measurements = dict
        .get_item("measurements")?
        .expect("the report has measurements");
    convert::restore_nones(&measurements)?;
    Ok(dict.clone().into_any())
}
