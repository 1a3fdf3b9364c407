//! numpy arrays out of the world's buffers: fresh copies, or a caller's `out=` array filled in
//! place.
//!
//! No array ever views the world's own memory: the buffers move and grow when agents are added,
//! removed or reordered, so a view would dangle. A fresh array is a `Vec` moved into numpy
//! without a second copy; an `out=` array is checked (dtype, shape, writeable) and written
//! through, C-contiguous arrays as one slice, strided ones element by element.

use numpy::ndarray::{Array1, Array2};
use numpy::{Element, IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use throng::{AgentId, Agents};

use crate::error::invalid;

/// The order of an array's rows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Order {
    /// The world's storage order (changes when agents are reordered, added or removed).
    Storage,
    /// Ascending agent id.
    Id,
}

impl Order {
    /// Parses `"storage"` or `"id"`.
    pub(crate) fn parse(s: &str) -> PyResult<Self> {
        match s {
            "storage" => Ok(Order::Storage),
            "id" => Ok(Order::Id),
            other => Err(invalid(
                "order",
                format!("expected \"storage\" or \"id\", got {other:?}"),
            )),
        }
    }

    /// The storage index of each row, or `None` for storage order.
    pub(crate) fn rows(self, agents: &Agents) -> Option<Vec<usize>> {
        match self {
            Order::Storage => None,
            Order::Id => Some(
                (0..agents.ids_issued() as u32)
                    .filter_map(|id| agents.index_of(AgentId(id)))
                    .collect(),
            ),
        }
    }
}

/// What an argument is, for error messages: `float64 array of shape (3, 2)` or a type name.
fn describe(obj: &Bound<'_, PyAny>) -> String {
    let attr =
        |name: &str| -> Option<String> { Some(obj.getattr(name).ok()?.str().ok()?.to_string()) };
    match (attr("dtype"), attr("shape")) {
        (Some(dtype), Some(shape)) => format!("a {dtype} array of shape {shape}"),
        _ => obj
            .get_type()
            .name()
            .map_or_else(|_| "an object".to_string(), |n| format!("a {n}")),
    }
}

/// The storage index of row `k`.
#[inline]
fn row(rows: Option<&[usize]>, k: usize) -> usize {
    rows.map_or(k, |r| r[k])
}

/// An `(n, 2)` float32 array of `get(i)` for the storage index `i` of each row, fresh or
/// written into `out`.
pub(crate) fn pairs<'py>(
    py: Python<'py>,
    n: usize,
    rows: Option<&[usize]>,
    get: impl Fn(usize) -> [f32; 2],
    out: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let Some(out) = out else {
        let mut v = Vec::with_capacity(2 * n);
        for k in 0..n {
            v.extend_from_slice(&get(row(rows, k)));
        }
        let a = Array2::from_shape_vec((n, 2), v).expect("2n values make n rows of two");
        return Ok(a.into_pyarray(py).into_any());
    };
    let expected = || format!("expected a float32 array of shape ({n}, 2)");
    let arr = out
        .cast::<PyArray2<f32>>()
        .map_err(|_| invalid("out", format!("{}, got {}", expected(), describe(out))))?;
    if arr.shape() != [n, 2] {
        return Err(invalid(
            "out",
            format!("{}, got {}", expected(), describe(out)),
        ));
    }
    let contiguous = arr.is_c_contiguous();
    let mut rw = arr.try_readwrite().map_err(|_| not_writeable())?;
    if contiguous && let Ok(s) = rw.as_slice_mut() {
        for (k, pair) in s.chunks_exact_mut(2).enumerate() {
            pair.copy_from_slice(&get(row(rows, k)));
        }
    } else {
        let mut a = rw.as_array_mut();
        for k in 0..n {
            let [x, y] = get(row(rows, k));
            a[[k, 0]] = x;
            a[[k, 1]] = y;
        }
    }
    Ok(out.clone())
}

/// An `(n,)` array of `get(i)` for the storage index `i` of each row, fresh or written into
/// `out` (whose dtype must be `T`'s, named `dtype` in errors).
pub(crate) fn column<'py, T: Element + Copy>(
    py: Python<'py>,
    n: usize,
    rows: Option<&[usize]>,
    dtype: &str,
    get: impl Fn(usize) -> T,
    out: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let Some(out) = out else {
        let v: Vec<T> = (0..n).map(|k| get(row(rows, k))).collect();
        return Ok(Array1::from_vec(v).into_pyarray(py).into_any());
    };
    let expected = || format!("expected a {dtype} array of shape ({n},)");
    let arr = out
        .cast::<PyArray1<T>>()
        .map_err(|_| invalid("out", format!("{}, got {}", expected(), describe(out))))?;
    if arr.shape() != [n] {
        return Err(invalid(
            "out",
            format!("{}, got {}", expected(), describe(out)),
        ));
    }
    let mut rw = arr.try_readwrite().map_err(|_| not_writeable())?;
    let mut a = rw.as_array_mut();
    for (k, slot) in a.iter_mut().enumerate() {
        *slot = get(row(rows, k));
    }
    Ok(out.clone())
}

fn not_writeable() -> PyErr {
    invalid(
        "out",
        "the array is not writeable (read-only, or borrowed elsewhere)",
    )
}

/// `obj` as a C-contiguous numpy array of `dtype` (`"float32"` or `"int64"`); `"int64"` takes
/// only integer input, never floats that would be truncated silently.
fn as_numpy<'py>(name: &str, obj: &Bound<'py, PyAny>, dtype: &str) -> PyResult<Bound<'py, PyAny>> {
    let np = obj.py().import("numpy")?;
    let what = || describe(obj);
    let arr = np
        .call_method1("asarray", (obj,))
        .map_err(|_| invalid(name, format!("expected numbers, got {}", what())))?;
    let kind: String = arr.getattr("dtype")?.getattr("kind")?.extract()?;
    let ok = match dtype {
        "int64" => matches!(kind.as_str(), "i" | "u"),
        _ => matches!(kind.as_str(), "i" | "u" | "f"),
    };
    if !ok {
        let expected = if dtype == "int64" {
            "integers"
        } else {
            "numbers"
        };
        return Err(invalid(
            name,
            format!("expected {expected}, got {}", what()),
        ));
    }
    np.call_method1("ascontiguousarray", (arr, dtype))
}

/// The rows an `(m, 2)` array-like holds (1 for one pair), read from its shape before any
/// copy is made, so that a request beyond a ceiling (a broadcast view of 10^8 rows, say) is
/// refused before it allocates.
pub(crate) fn pair_rows(name: &str, obj: &Bound<'_, PyAny>) -> PyResult<usize> {
    let np = obj.py().import("numpy")?;
    let shape: Vec<usize> = np
        .call_method1("shape", (obj,))
        .and_then(|s| s.extract())
        .map_err(|_| {
            invalid(
                name,
                format!("expected an (m, 2) array of numbers, got {}", describe(obj)),
            )
        })?;
    Ok(match shape.as_slice() {
        [] | [_] => 1,
        [m, ..] => *m,
    })
}

/// An `(m, 2)` array-like of numbers as pairs (one pair alone counts as `m = 1`).
pub(crate) fn read_pairs(name: &str, obj: &Bound<'_, PyAny>) -> PyResult<Vec<[f32; 2]>> {
    let arr = as_numpy(name, obj, "float32")?;
    let arr = match arr.getattr("ndim")?.extract::<usize>()? {
        1 => arr.call_method1("reshape", ((1, -1),))?,
        _ => arr,
    };
    let bad = || {
        invalid(
            name,
            format!("expected an (m, 2) array of numbers, got {}", describe(obj)),
        )
    };
    let arr = arr.cast::<PyArray2<f32>>().map_err(|_| bad())?;
    if arr.shape()[1] != 2 {
        return Err(bad());
    }
    let ro = arr.readonly();
    let s = ro.as_slice().map_err(|_| bad())?;
    Ok(s.chunks_exact(2).map(|c| [c[0], c[1]]).collect())
}

/// A 1-D array-like (or one value) as values of `dtype`.
fn read_1d<'py, T: Element + Copy>(
    name: &str,
    obj: &Bound<'py, PyAny>,
    dtype: &str,
) -> PyResult<Vec<T>> {
    let arr = as_numpy(name, obj, dtype)?.call_method0("ravel")?;
    let arr = arr.cast::<PyArray1<T>>().map_err(|_| {
        invalid(
            name,
            format!("expected {dtype} values, got {}", describe(obj)),
        )
    })?;
    Ok(arr.readonly().as_array().to_vec())
}

/// Integers: a 1-D array-like or one integer.
pub(crate) fn read_ints(name: &str, obj: &Bound<'_, PyAny>) -> PyResult<Vec<i64>> {
    read_1d(name, obj, "int64")
}

/// One value for each of `m` rows: `m` values, or one value repeated.
pub(crate) fn broadcast<T: Copy>(name: &str, values: Vec<T>, m: usize) -> PyResult<Vec<T>> {
    match values.len() {
        n if n == m => Ok(values),
        1 => Ok(vec![values[0]; m]),
        n => Err(invalid(
            name,
            format!("expected one value or {m} values, got {n}"),
        )),
    }
}

/// An optional per-agent column: absent, or one number (given to every agent) or `m` numbers,
/// as float32.
pub(crate) fn optional_floats(
    name: &str,
    v: Option<&Bound<'_, PyAny>>,
    m: usize,
) -> PyResult<Option<Vec<f32>>> {
    v.map(|v| broadcast(name, read_floats(name, v)?, m))
        .transpose()
}

/// Numbers: a 1-D array-like or one number, as float32.
pub(crate) fn read_floats(name: &str, obj: &Bound<'_, PyAny>) -> PyResult<Vec<f32>> {
    read_1d(name, obj, "float32")
}
