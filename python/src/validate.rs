//! `throng.validate`: one case of the validation suite (`throng validate CASE --json`'s case
//! object), with pedestrian parameters set for a calibration sweep.

use pyo3::prelude::*;
use pyo3::types::PyDict;
use throng::Error;
use throng::validate::{Options, Size, case as find_case, run_case};

use crate::convert;
use crate::error::{OrRaise, guarded, raise};
use crate::world::pool;

/// Runs validation case `case` and returns its report as a dict: {"id", "title", "pass",
/// "steps", "agent_steps", "checks": [{"name", "criterion", "value", "unit", "pass"}],
/// "series", "errors": [{"quantity", "lo", "hi", "reference", "reference_samples",
/// "measured", "samples", "relative_error"}]}; a value that could not be measured is absent
/// from its dict. `model` is "cfsm" or "social_force" (default: the scenarios' own); `params`
/// maps dotted keys inside the pedestrian table (`"cfsm.time_gap"`) to values, set in every
/// pedestrian group, as `throng validate --param` does. The GIL is released while it runs.
#[pyfunction]
#[pyo3(signature = (case, *, quick=false, model=None, seed_offset=0, threads=None, params=None))]
pub(crate) fn validate<'py>(
    py: Python<'py>,
    case: &str,
    quick: bool,
    model: Option<&str>,
    seed_offset: u64,
    threads: Option<i128>,
    params: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let case = find_case(case).or_raise()?;
    let model = match model {
        Some(name) => Some(throng::ped::Model::parse(name).ok_or_else(|| {
            raise(&Error::Invalid {
                name: "model".into(),
                reason: format!(
                    "unknown pedestrian model {name} (the models: {})",
                    throng::ped::Model::names().collect::<Vec<_>>().join(", ")
                ),
            })
        })?),
        None => None,
    };
    let mut list = Vec::new();
    if let Some(params) = params {
        for (k, v) in params.iter() {
            let key: String = k.extract()?;
            list.push((key.clone(), convert::to_toml(&key, &v)?));
        }
    }
    let options = Options {
        size: if quick { Size::Quick } else { Size::Full },
        model,
        seed_offset,
        params: list,
    };
    let threads = threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get() as i128));
    let pool = pool(Some(threads))?.expect("a thread count was given");
    let report = guarded(|| {
        py.detach(|| pool.install(|| run_case(case, &options)))
            .or_raise()
    })?;
    let dict = convert::serialize_to_py(py, &report, false)?;
    Ok(dict)
}
