//! `throng.ThrongError`: every validation error of the library, raised with the Rust message.
//!
//! The exception is a `ValueError` subclass. Its `parameter` attribute names the offending
//! parameter where the Rust error names one (`"dt"`, `"agents"`, `"out"`, ...), else `None`.

use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use throng::Error;

create_exception!(
    throng,
    ThrongError,
    PyValueError,
    "A bad argument or scenario: the message is the Rust library's and names the parameter, \
     which the `parameter` attribute also holds (None where no single parameter is at fault)."
);

/// The name of the parameter an error is about, where it names one.
fn parameter(e: &Error) -> Option<String> {
    match e {
        Error::NonFinite { name, .. }
        | Error::Negative { name, .. }
        | Error::NotPositive { name, .. }
        | Error::OutOfRange { name, .. } => Some((*name).to_string()),
        Error::Invalid { name, .. } => Some(name.clone()),
        Error::ZeroMass { .. } => Some("mass".into()),
        Error::InvalidTimeStep { .. } => Some("dt".into()),
        Error::UnknownAgent { .. } => Some("ids".into()),
        Error::UnknownGroup { .. } => Some("group".into()),
        Error::UnknownJourneyStage { .. } => Some("journey".into()),
        Error::Io { .. } => Some("path".into()),
        _ => None,
    }
}

/// `e` as a `ThrongError` whose message is `context: e` (or just `e` without context).
pub(crate) fn raise_in(context: Option<&str>, e: &Error) -> PyErr {
    let message = match context {
        Some(c) => format!("{c}: {e}"),
        None => e.to_string(),
    };
    let err = ThrongError::new_err(message);
    Python::attach(
        |py| match err.value(py).setattr("parameter", parameter(e)) {
            Ok(()) => err,
            Err(other) => other,
        },
    )
}

/// Runs `f`; a Rust panic inside it becomes a `ThrongError` carrying the panic's message
/// (pyo3 would raise its `PanicException`, a `BaseException` that `except Exception` does not
/// catch). Every call of the module that builds or steps a world, or changes one, runs through
/// here.
pub(crate) fn guarded<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).unwrap_or_else(|payload| {
        let message = payload
            .downcast_ref::<&str>()
            .map(|s| (*s).to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "a panic without a message".into());
        Err(ThrongError::new_err(format!(
            "internal error (a bug of throng; please report it): {message}"
        )))
    })
}

/// `e` as a `ThrongError`.
pub(crate) fn raise(e: &Error) -> PyErr {
    raise_in(None, e)
}

/// A `ThrongError` for a parameter that is invalid for `reason`.
pub(crate) fn invalid(name: &str, reason: impl Into<String>) -> PyErr {
    raise(&Error::Invalid {
        name: name.to_string(),
        reason: reason.into(),
    })
}

/// Turns a library result into a Python one.
pub(crate) trait OrRaise<T> {
    /// `Ok` as it is, `Err` as a `ThrongError`.
    fn or_raise(self) -> PyResult<T>;
}

impl<T> OrRaise<T> for throng::Result<T> {
    fn or_raise(self) -> PyResult<T> {
        self.map_err(|e| raise(&e))
    }
}

/// A Python integer argument as an unsigned count or seed, `ThrongError` when it does not fit.
pub(crate) fn unsigned<T: TryFrom<i128>>(name: &'static str, value: i128) -> PyResult<T> {
    T::try_from(value).map_err(|_| {
        raise(&if value < 0 {
            Error::Negative {
                name,
                value: value as f64,
            }
        } else {
            Error::OutOfRange {
                name,
                value: value as f64,
                range: "the range of a 64-bit unsigned integer",
            }
        })
    })
}
