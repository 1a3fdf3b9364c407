//! Python bindings of throng: the `throng._throng` extension module behind the `throng`
//! package (`python/throng/`), built by maturin as an abi3 wheel for CPython 3.9 and later.
//!
//! - [`world`]: `throng.World`, stepped with the GIL released and read out as numpy arrays;
//! - [`simulation`]: `throng.Simulation`, a pedestrian study with stages and journeys, no TOML;
//! - [`record`]: the trajectory files `Simulation.record` writes (the library's writers);
//! - [`bench`]: `throng.bench`, the CLI's benchmark object as a dict;
//! - [`validate`]: `throng.validate`, one validation case's report as a dict;
//! - [`scenario`]: built-in names, files and TOML text, with keyword overrides;
//! - [`arrays`]: fresh arrays and `out=` arrays, never views of the world's buffers;
//! - [`convert`]: Python values to and from the TOML values of scenario files;
//! - [`error`]: `throng.ThrongError`, a `ValueError` carrying the Rust message.
//!
//! Sweeps (`throng.sweep`) are plain Python over these, in `python/throng/_sweep.py`.

mod arrays;
mod bench;
mod convert;
mod error;
mod record;
mod scenario;
mod simulation;
mod validate;
mod world;

use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The built-in scenarios: {name: description}, in listing order (`throng list`).
#[pyfunction]
fn scenarios(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let d = PyDict::new(py);
    for (name, _) in throng::scenario::BUILTIN {
        let s = throng::scenario::builtin(name).map_err(|e| error::raise(&e))?;
        d.set_item(name, s.description)?;
    }
    Ok(d)
}

/// Panics with `message` inside the module's panic guard: the test suite's way of checking that
/// a Rust panic reaches Python as a `ThrongError` (private; not part of the API).
#[pyfunction]
fn _panic(message: &str) -> PyResult<()> {
    error::guarded(|| panic!("{message}"))
}

/// The native part of the `throng` package; import `throng` instead.
#[pymodule]
fn _throng(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let throng_error = m.py().get_type::<error::ThrongError>();
    // Instances raised without a parameter (from Python code, say) read None.
    throng_error.setattr("parameter", m.py().None())?;
    m.add("ThrongError", throng_error)?;
    m.add_class::<world::PyWorld>()?;
    m.add_class::<simulation::PySimulation>()?;
    m.add_class::<simulation::PyJourney>()?;
    m.add_class::<simulation::PyTransition>()?;
    m.add_class::<simulation::PyQueue>()?;
    m.add_class::<simulation::PyWaitingSet>()?;
    m.add_function(wrap_pyfunction!(bench::bench, m)?)?;
    m.add_function(wrap_pyfunction!(validate::validate, m)?)?;
    m.add_function(wrap_pyfunction!(scenarios, m)?)?;
    // Private: set as an attribute, so it stays out of `__all__`.
    m.setattr("_panic", wrap_pyfunction!(_panic, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
