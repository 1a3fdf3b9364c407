//! Conversions between Python values and the TOML values of scenario files, and between Python
//! sequences and `Vec2`s.
//!
//! Scenario overrides, group profiles and gravity motions cross the boundary as TOML values, so
//! that Python dicts take exactly the keys of a scenario file (`docs/SCENARIOS.md`) and the
//! library's own deserialisers validate them.

use glam::Vec2;
use pyo3::IntoPyObjectExt;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::error::invalid;

/// How deeply lists and dicts may nest in a value handed to a scenario (overrides, group
/// profiles, gravity motions, sweep runs). The deepest key of a scenario file sits about eight
/// levels down (`groups[0].steering.behaviours[0].target.point[0]`); a list that contains
/// itself, or one nested 10,000 deep, overflowed the stack and killed the interpreter.
pub(crate) const MAX_DEPTH: usize = 64;

/// A Python value (bool, int, float, str, sequence, dict, numpy scalar or array) as TOML, nested
/// at most [`MAX_DEPTH`] levels; errors name `name`.
pub(crate) fn to_toml(name: &str, obj: &Bound<'_, PyAny>) -> PyResult<toml::Value> {
    to_toml_at(name, obj, 0)
}

fn to_toml_at(name: &str, obj: &Bound<'_, PyAny>, depth: usize) -> PyResult<toml::Value> {
    if depth > MAX_DEPTH {
        return Err(invalid(
            name,
            format!(
                "lists and dicts nest more than {MAX_DEPTH} levels deep (or a list contains itself)"
            ),
        ));
    }
    if obj.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(obj.extract()?));
    }
    if obj.is_instance_of::<PyInt>() {
        let v: i64 = obj
            .extract()
            .map_err(|_| invalid(name, "the integer does not fit in 64 bits"))?;
        return Ok(toml::Value::Integer(v));
    }
    if obj.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(obj.extract()?));
    }
    if let Ok(s) = obj.cast::<PyString>() {
        return Ok(toml::Value::String(s.extract()?));
    }
    if let Ok(d) = obj.cast::<PyDict>() {
        let mut table = toml::Table::new();
        for (k, v) in d.iter() {
            let key: String = k
                .extract()
                .map_err(|_| invalid(name, "dictionary keys must be strings"))?;
            let value = to_toml_at(&format!("{name}.{key}"), &v, depth + 1)?;
            table.insert(key, value);
        }
        return Ok(toml::Value::Table(table));
    }
    if obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>() {
        let items = obj
            .try_iter()?
            .map(|item| to_toml_at(name, &item?, depth + 1))
            .collect::<PyResult<Vec<_>>>()?;
        return Ok(toml::Value::Array(items));
    }
    // numpy scalars and arrays: `item()` / `tolist()` give Python numbers and lists.
    for method in ["tolist", "item"] {
        if obj.hasattr(method)? {
            let plain = obj.call_method0(method)?;
            if !plain.is(obj) {
                return to_toml_at(name, &plain, depth + 1);
            }
        }
    }
    Err(invalid(
        name,
        format!(
            "a {} cannot go into a scenario (use numbers, strings, booleans, lists or dicts)",
            obj.get_type().name()?
        ),
    ))
}

/// A TOML value as a Python object (tables become dicts, arrays lists).
pub(crate) fn to_py<'py>(py: Python<'py>, v: &toml::Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        toml::Value::String(s) => s.into_bound_py_any(py)?,
        toml::Value::Integer(i) => i.into_bound_py_any(py)?,
        toml::Value::Float(f) => f.into_bound_py_any(py)?,
        toml::Value::Boolean(b) => b.into_bound_py_any(py)?,
        toml::Value::Datetime(d) => d.to_string().into_bound_py_any(py)?,
        toml::Value::Array(a) => {
            let items = a
                .iter()
                .map(|x| to_py(py, x))
                .collect::<PyResult<Vec<_>>>()?;
            PyList::new(py, items)?.into_any()
        }
        toml::Value::Table(t) => {
            let d = PyDict::new(py);
            for (k, x) in t {
                d.set_item(k, to_py(py, x)?)?;
            }
            d.into_any()
        }
    })
}

/// An `f32` as the float64 of its shortest decimal form (`0.4`, not `0.4000000059604645`),
/// which rounds back to the same `f32`.
pub(crate) fn f32_to_f64(v: f32) -> f64 {
    v.to_string().parse().unwrap_or(f64::from(v))
}

/// Floats that are exactly `f32`s take their shortest decimal form (see [`f32_to_f64`]).
fn shortest_f32(v: &mut toml::Value) {
    match v {
        toml::Value::Float(x) if f64::from(*x as f32) == *x => *x = f32_to_f64(*x as f32),
        toml::Value::Array(a) => a.iter_mut().for_each(shortest_f32),
        toml::Value::Table(t) => t.iter_mut().for_each(|(_, x)| shortest_f32(x)),
        _ => {}
    }
}

/// A library value (a group profile, a report) as a Python object, through its TOML form;
/// with `f32_fields`, its floats are `f32`s shown in their shortest form.
pub(crate) fn serialize_to_py<'py, T: Serialize>(
    py: Python<'py>,
    value: &T,
    f32_fields: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let mut v = toml::Value::try_from(value)
        .map_err(|e| invalid("value", format!("cannot be converted: {e}")))?;
    if f32_fields {
        shortest_f32(&mut v);
    }
    to_py(py, &v)
}

/// A Python value (a dict in scenario-file form) as a library value, validated by its
/// deserialiser; errors name `name`.
pub(crate) fn deserialize_from_py<T: DeserializeOwned>(
    name: &str,
    obj: &Bound<'_, PyAny>,
) -> PyResult<T> {
    let v = to_toml(name, obj)?;
    T::deserialize(v).map_err(|e| invalid(name, e.message().trim().to_string()))
}

/// A pair of numbers as a `Vec2`.
pub(crate) fn vec2(name: &str, obj: &Bound<'_, PyAny>) -> PyResult<Vec2> {
    let pair: Vec<f32> = obj
        .extract()
        .map_err(|_| invalid(name, "expected two numbers (x, y)"))?;
    match pair[..] {
        [x, y] => Ok(Vec2::new(x, y)),
        _ => Err(invalid(
            name,
            format!("expected two numbers (x, y), got {}", pair.len()),
        )),
    }
}

/// Puts back the `None`s of a measurement report converted through TOML (which has no null):
/// every optional key of its lines and areas.
pub(crate) fn restore_nones(measurements: &Bound<'_, PyAny>) -> PyResult<()> {
    let py = measurements.py();
    for (list, keys) in [
        ("lines", &throng::measure::LineReport::OPTIONAL_KEYS[..]),
        ("areas", &throng::measure::AreaReport::OPTIONAL_KEYS[..]),
    ] {
        for entry in measurements.get_item(list)?.try_iter()? {
            let entry = entry?;
            let entry = entry.cast::<PyDict>()?;
            for &key in keys {
                if !entry.contains(key)? {
                    entry.set_item(key, py.None())?;
                }
            }
        }
    }
    Ok(())
}
