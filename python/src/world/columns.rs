//! The agents' columns read out of a `throng.World` (positions, velocities, orientations, ids,
//! groups, arrivals) and aggregates over them (mean speed, polarisation).
//!
//! Invariants: every array is fresh or the caller's `out=` array, never a view of the world's
//! buffers; rows are in storage order, or by ascending id with `order="id"`; aggregates are
//! summed in float64 in storage order.

use pyo3::prelude::*;
use throng::World;

use super::PyWorld;
use crate::arrays::{self, Order};

/// Agent `i`'s velocity and speed in float64.
fn speed(a: &throng::Agents, i: usize) -> (f64, f64, f64) {
    let (vx, vy) = (f64::from(a.vel_x()[i]), f64::from(a.vel_y()[i]));
    (vx, vy, vx.hypot(vy))
}

impl PyWorld {
    fn rows(&self, order: &str) -> PyResult<Option<Vec<usize>>> {
        Ok(Order::parse(order)?.rows(self.world.agents()))
    }

    /// The `(N, 2)` array of two agent columns (see [`arrays::pairs`]).
    fn pairs_of<'py>(
        &self,
        py: Python<'py>,
        out: Option<&Bound<'py, PyAny>>,
        order: &str,
        columns: fn(&throng::Agents) -> (&[f32], &[f32]),
    ) -> PyResult<Bound<'py, PyAny>> {
        let rows = self.rows(order)?;
        let a = self.world.agents();
        let (x, y) = columns(a);
        arrays::pairs(py, a.len(), rows.as_deref(), |i| [x[i], y[i]], out)
    }

    /// The `(N,)` array of `get(world, i)` over storage indices (see [`arrays::column`]).
    fn column_of<'py, T: numpy::Element + Copy>(
        &self,
        py: Python<'py>,
        out: Option<&Bound<'py, PyAny>>,
        order: &str,
        dtype: &str,
        get: fn(&World, usize) -> T,
    ) -> PyResult<Bound<'py, PyAny>> {
        let rows = self.rows(order)?;
        let w = &self.world;
        arrays::column(py, w.len(), rows.as_deref(), dtype, |i| get(w, i), out)
    }
}

#[pymethods]
impl PyWorld {
    /// Positions as a fresh (N, 2) float32 array, or written into `out` (an (N, 2) float32
    /// array, returned). Rows in storage order (as `ids()`), or by ascending id with
    /// `order="id"`.
    #[pyo3(signature = (out=None, *, order="storage"))]
    fn positions<'py>(
        &self,
        py: Python<'py>,
        out: Option<&Bound<'py, PyAny>>,
        order: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        self.pairs_of(py, out, order, |a| (a.pos_x(), a.pos_y()))
    }

    /// Velocities as an (N, 2) float32 array; `out` and `order` as for `positions`.
    #[pyo3(signature = (out=None, *, order="storage"))]
    fn velocities<'py>(
        &self,
        py: Python<'py>,
        out: Option<&Bound<'py, PyAny>>,
        order: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        self.pairs_of(py, out, order, |a| (a.vel_x(), a.vel_y()))
    }

    /// Orientations (headings), radians in [0, 2 pi), as an (N,) float32 array.
    #[pyo3(signature = (out=None, *, order="storage"))]
    fn orientations<'py>(
        &self,
        py: Python<'py>,
        out: Option<&Bound<'py, PyAny>>,
        order: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        self.column_of(py, out, order, "float32", |w, i| {
            w.agents().orientations()[i]
        })
    }

    /// Agent ids as an (N,) uint32 array: row k of every array belongs to agent ids()[k].
    #[pyo3(signature = (out=None, *, order="storage"))]
    fn ids<'py>(
        &self,
        py: Python<'py>,
        out: Option<&Bound<'py, PyAny>>,
        order: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        self.column_of(py, out, order, "uint32", |w, i| w.agents().ids()[i].0)
    }

    /// Group indices as an (N,) uint32 array (names in `group_names`).
    #[pyo3(signature = (out=None, *, order="storage"))]
    fn groups<'py>(
        &self,
        py: Python<'py>,
        out: Option<&Bound<'py, PyAny>>,
        order: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        self.column_of(py, out, order, "uint32", |w, i| w.agents().groups()[i])
    }

    /// Whether each agent has reached a goal of the field channel it follows, as an (N,) bool
    /// array (all False in a world without fields).
    #[pyo3(signature = (out=None, *, order="storage"))]
    fn arrived<'py>(
        &self,
        py: Python<'py>,
        out: Option<&Bound<'py, PyAny>>,
        order: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        self.column_of(py, out, order, "bool", |w, i| {
            w.has_arrived(w.agents().ids()[i])
        })
    }

    /// Number of agents that have arrived (see `arrived`).
    fn arrived_count(&self) -> usize {
        self.world.arrived_count()
    }

    /// Mean speed over the agents (0 for an empty world), summed in float64 in storage order.
    fn mean_speed(&self) -> f64 {
        let a = self.world.agents();
        let n = a.len().max(1) as f64;
        (0..a.len()).map(|i| speed(a, i).2).sum::<f64>() / n
    }

    /// Polarisation (the Vicsek order parameter): |mean of the agents' unit velocities|, in
    /// [0, 1]; agents at rest count as zero vectors. Summed in float64 in storage order.
    fn polarisation(&self) -> f64 {
        let a = self.world.agents();
        let (mut sx, mut sy) = (0.0f64, 0.0f64);
        for i in 0..a.len() {
            let (vx, vy, len) = speed(a, i);
            if len > 0.0 {
                sx += vx / len;
                sy += vy / len;
            }
        }
        let n = a.len().max(1) as f64;
        (sx / n).hypot(sy / n)
    }
}
