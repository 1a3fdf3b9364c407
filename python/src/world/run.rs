//! Stepping a `throng.World` from Python: `step` and `trajectories`, and the measurements
//! every step observes (`measurements`, `evacuation_time`).
//!
//! Steps run on the world's own rayon pool when it was built with `threads=`, else on rayon's
//! global pool (all cores). A long run goes in slices of at most [`SLICE`] with the GIL
//! released; between slices it takes the GIL back only to let Python handle signals, so Ctrl-C
//! stops it between two steps. Invariant: the state after n steps does not depend on the
//! slicing or the thread count: it is the CLI's, bit for bit, and a trajectory table holds the
//! values of the CLI's `--trajectories` CSV, bit for bit.

use std::time::{Duration, Instant};

use numpy::IntoPyArray;
use numpy::ndarray::Array1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use throng::world::PhaseTimes;
use throng::{Error, StepStats, World};

use super::PyWorld;
use crate::error::{OrRaise, guarded, raise, unsigned};

/// The longest stretch of steps run without looking at Python's signals.
const SLICE: Duration = Duration::from_millis(200);

/// The dict `step` returns: the keys of the CLI's frame line, times in milliseconds.
fn stats_dict<'py>(py: Python<'py>, s: &StepStats) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("frame", s.frame)?;
    d.set_item("step", s.total_ms())?;
    for (name, ms) in PhaseTimes::NAMES.iter().zip(s.phases.as_ms()) {
        d.set_item(name, ms)?;
    }
    d.set_item("agents", s.agents)?;
    d.set_item("mean_neighbours", s.mean_neighbours)?;
    Ok(d)
}

impl PyWorld {
    /// Runs `n` steps of `dt` with the GIL released, calling `each` after every step; returns
    /// the last step's stats.
    pub(crate) fn run(
        &mut self,
        py: Python<'_>,
        dt: f32,
        n: u64,
        mut each: impl FnMut(&World, &StepStats) + Send,
    ) -> PyResult<Option<StepStats>> {
        let mut done = 0;
        let mut last = None;
        while done < n {
            let world = &mut self.world;
            let measure = &mut self.measure;
            let pool = self.pool.as_ref();
            let each = &mut each;
            let (k, stats, result) = guarded(|| {
                Ok(py.detach(|| {
                    let mut slice = || {
                        let start = Instant::now();
                        let (mut k, mut stats) = (0, None);
                        while done + k < n {
                            match world.step(dt) {
                                Ok(s) => {
                                    measure.observe(world);
                                    each(world, &s);
                                    stats = Some(s);
                                    k += 1;
                                }
                                Err(e) => return (k, stats, Err(e)),
                            }
                            if start.elapsed() >= SLICE {
                                break;
                            }
                        }
                        (k, stats, Ok(()))
                    };
                    match pool {
                        Some(p) => p.install(slice),
                        None => slice(),
                    }
                }))
            })?;
            result.or_raise()?;
            done += k;
            last = stats.or(last);
            py.check_signals()?;
        }
        Ok(last)
    }
}

#[pymethods]
impl PyWorld {
    /// Runs `n` steps of `dt` seconds (default: the scenario's dt) with the GIL released and
    /// returns the last step's stats: {"frame", "step", "index", "steer", "integrate",
    /// "bounds", "agents", "mean_neighbours"}, the keys of the CLI's frame line (times in
    /// milliseconds) and the mean neighbours per agent. Ctrl-C stops it between two steps.
    #[pyo3(signature = (dt=None, n=1))]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        dt: Option<f32>,
        n: i128,
    ) -> PyResult<Bound<'py, PyDict>> {
        let dt = self.dt_or_default(dt)?;
        let n: u64 = unsigned("n", n)?;
        if n == 0 {
            return Err(raise(&Error::NotPositive {
                name: "n",
                value: 0.0,
            }));
        }
        let last = self.run(py, dt, n, |_, _| {})?;
        stats_dict(py, &last.expect("n > 0 steps ran"))
    }

    /// Runs `steps` steps (GIL released) and returns a pandas DataFrame in the long format of
    /// the CLI's `--trajectories` CSV: one row per agent for the current frame, for every
    /// `every`-th frame after it and for the last frame, columns frame (int64), t (float64 seconds), id (uint32),
    /// x, y, vx, vy, heading (float32, bit-identical to the CSV's values), group (uint32).
    #[pyo3(signature = (steps, every=1, *, dt=None))]
    fn trajectories<'py>(
        &mut self,
        py: Python<'py>,
        steps: i128,
        every: i128,
        dt: Option<f32>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let dt = self.dt_or_default(dt)?;
        let steps: u64 = unsigned("steps", steps)?;
        let every: u64 = unsigned("every", every)?;
        if every == 0 {
            return Err(raise(&Error::NotPositive {
                name: "every",
                value: 0.0,
            }));
        }
        let mut t = Trajectory::default();
        t.record(&self.world);
        let start = self.world.frame();
        self.run(py, dt, steps, |w, s| {
            let k = s.frame - start;
            // The last frame too, as the CLI's `--every` writes it.
            if k.is_multiple_of(every) || k == steps {
                t.record(w);
            }
        })?;
        t.into_frame(py)
    }

    /// The scenario's measurements since the world was built (`[measurements]` in the file),
    /// as `bench` reports them: {"lines", "areas", "left"}, with `left` the agents that left
    /// through an exit or an exit stage. Every step observes them, as `throng run` does.
    fn measurements<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let report = crate::convert::serialize_to_py(py, &self.measure.report(), false)?;
        crate::convert::restore_nones(&report)?;
        Ok(report)
    }

    /// The simulated time at which the last agent left through an exit or an exit stage;
    /// `None` while agents remain, and in a world without exits or that nobody left.
    #[getter]
    fn evacuation_time(&self) -> Option<f64> {
        self.measure.evacuation_time()
    }
}

/// The columns of a trajectory table.
#[derive(Debug, Default)]
struct Trajectory {
    frame: Vec<i64>,
    t: Vec<f64>,
    id: Vec<u32>,
    x: Vec<f32>,
    y: Vec<f32>,
    vx: Vec<f32>,
    vy: Vec<f32>,
    heading: Vec<f32>,
    group: Vec<u32>,
}

impl Trajectory {
    /// Appends one row per agent of the world's current frame, in storage order.
    fn record(&mut self, w: &World) {
        let a = w.agents();
        let n = a.len();
        self.frame.extend(std::iter::repeat_n(w.frame() as i64, n));
        self.t.extend(std::iter::repeat_n(w.time(), n));
        self.id.extend(a.ids().iter().map(|id| id.0));
        self.x.extend_from_slice(a.pos_x());
        self.y.extend_from_slice(a.pos_y());
        self.vx.extend_from_slice(a.vel_x());
        self.vy.extend_from_slice(a.vel_y());
        self.heading.extend_from_slice(a.orientations());
        self.group.extend_from_slice(a.groups());
    }

    /// The table as a pandas DataFrame.
    fn into_frame(self, py: Python<'_>) -> PyResult<Bound<'_, PyAny>> {
        let d = PyDict::new(py);
        d.set_item("frame", Array1::from_vec(self.frame).into_pyarray(py))?;
        d.set_item("t", Array1::from_vec(self.t).into_pyarray(py))?;
        d.set_item("id", Array1::from_vec(self.id).into_pyarray(py))?;
        for (name, col) in [
            ("x", self.x),
            ("y", self.y),
            ("vx", self.vx),
            ("vy", self.vy),
            ("heading", self.heading),
        ] {
            d.set_item(name, Array1::from_vec(col).into_pyarray(py))?;
        }
        d.set_item("group", Array1::from_vec(self.group).into_pyarray(py))?;
        let pandas = py.import("pandas")?;
        pandas.getattr("DataFrame")?.call1((d,))
    }
}
