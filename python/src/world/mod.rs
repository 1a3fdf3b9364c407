//! `throng.World`: a world built from a scenario, stepped with the GIL released, read out as
//! numpy arrays. This file owns the class, its constructors and its scalar properties; the
//! methods sit in child modules by what they touch:
//!
//! - `run`: `step` and `trajectories`, in slices with the GIL released;
//! - `columns`: the agents' columns as numpy arrays, and aggregates over them;
//! - `agents`: adding, removing and editing agents, all or nothing;
//! - `groups`: the groups' profiles as dicts;
//! - `obstacles`: circles, walls, polygons and gravity points;
//! - `fields`: the grid fields' goals and walls.
//!
//! Invariants: a call changes the world wholly or not at all (an error restores what it had
//! changed); the state after n steps does not depend on the slicing or the thread count: it is
//! the CLI's, bit for bit.

mod agents;
mod columns;
mod fields;
mod groups;
mod obstacles;
mod run;

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use throng::scenario::Scenario;
use throng::{Error, IndexKind, World};

use crate::convert;
use crate::error::{OrRaise, guarded, invalid, raise, raise_in, unsigned};
use crate::scenario::{Changes, Source, load};

/// A simulated world: agents, groups, bounds, obstacles, gravity points and fields.
///
/// Build one with `World.from_scenario` or `World.from_toml`. Array methods return fresh numpy
/// arrays (or fill `out=`), in storage order unless `order="id"`: rows are reordered every few
/// frames for speed, so use `ids()` (or `order="id"`) to follow an agent. A world is not to be
/// used from two Python threads at once (the second call raises RuntimeError while a step runs).
#[pyclass(name = "World", module = "throng")]
#[derive(Debug)]
pub struct PyWorld {
    world: World,
    name: String,
    dt: f32,
    steps: u64,
    pool: Option<rayon::ThreadPool>,
    /// The scenario's measurements (and the exits), observed at the build and after every
    /// step.
    measure: throng::measure::Measurements,
}

/// A rayon pool of `threads` workers, or none for rayon's global pool.
pub(crate) fn pool(threads: Option<i128>) -> PyResult<Option<rayon::ThreadPool>> {
    let Some(t) = threads else {
        return Ok(None);
    };
    let t: usize = unsigned("threads", t)?;
    // The CLI's ceiling: 2000 workers on 2 cores only add fork-join cost to every step.
    let t = throng::limits::check_threads(t).or_raise()?;
    rayon::ThreadPoolBuilder::new()
        .num_threads(t)
        .build()
        .map(Some)
        .map_err(|e| invalid("threads", e.to_string()))
}

/// Builds a scenario's world; an error names the scenario, as the CLI's do.
pub(crate) fn build(s: &Scenario) -> PyResult<World> {
    guarded(|| {
        s.build().map_err(|e| match e {
            Error::Scenario { .. } | Error::Io { .. } => raise(&e),
            other => raise_in(Some(&s.name), &other),
        })
    })
}

/// The changes a Python call asks for: `agents`, `seed` and keyword overrides.
pub(crate) fn changes(
    agents: Option<i128>,
    seed: Option<i128>,
    overrides: Option<&Bound<'_, PyDict>>,
) -> PyResult<Changes> {
    let mut c = Changes {
        agents: agents.map(|a| unsigned("agents", a)).transpose()?,
        seed: seed.map(|s| unsigned("seed", s)).transpose()?,
        overrides: Vec::new(),
    };
    if let Some(o) = overrides {
        for (k, v) in o.iter() {
            let key: String = k.extract()?;
            let value = convert::to_toml(&key, &v)?;
            c.overrides.push((key, value));
        }
    }
    Ok(c)
}

/// A TOML path, a `pathlib.Path`, or TOML text.
fn toml_source(obj: &Bound<'_, PyAny>) -> PyResult<Source> {
    if let Ok(s) = obj.cast::<PyString>() {
        let s: String = s.extract()?;
        return Ok(if s.contains('\n') || s.contains('=') {
            Source::Text(s)
        } else {
            Source::File(s)
        });
    }
    let os = obj.py().import("os")?;
    let path = os.call_method1("fspath", (obj,)).map_err(|_| {
        invalid(
            "path_or_text",
            "expected TOML text, a path string or a path-like object",
        )
    })?;
    Ok(Source::File(path.extract()?))
}

impl PyWorld {
    fn new(s: &Scenario, threads: Option<i128>) -> PyResult<Self> {
        let pool = pool(threads)?;
        let world = build(s)?;
        let mut measure = throng::measure::Measurements::new(&s.measurements).or_raise()?;
        measure.observe(&world);
        Ok(PyWorld {
            world,
            name: s.name.clone(),
            dt: s.dt,
            steps: s.steps,
            pool,
            measure,
        })
    }

    fn dt_or_default(&self, dt: Option<f32>) -> PyResult<f32> {
        let dt = dt.unwrap_or(self.dt);
        if !(dt.is_finite() && dt > 0.0 && dt <= throng::error::MAX_DT) {
            return Err(raise(&Error::InvalidTimeStep { dt: f64::from(dt) }));
        }
        Ok(dt)
    }
}

#[pymethods]
impl PyWorld {
    /// A built-in scenario (see `throng.scenarios()`), as `throng demo NAME` builds it.
    ///
    /// agents: total agents, shared among the scalable groups (`--agents`).
    /// seed: the seed of all randomness (`--seed`).
    /// threads: rayon workers for this world's steps (default: all cores).
    /// overrides: scenario keys to set, as dotted paths into the TOML file: `dt=0.05`,
    ///     `steps=100`, `index="kdtree"`, `**{"groups.boids.max_speed": 5}`,
    ///     `**{"groups.boids.steering.behaviours.alignment.weight": 2.0}`; `__` also
    ///     separates steps (`groups__boids__max_speed=5`). List elements are chosen by
    ///     index, by `name` or `kind`, or `*` for all.
    #[staticmethod]
    #[pyo3(signature = (name, *, agents=None, seed=None, threads=None, **overrides))]
    fn from_scenario(
        name: &str,
        agents: Option<i128>,
        seed: Option<i128>,
        threads: Option<i128>,
        overrides: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let s = load(
            &Source::Builtin(name.to_string()),
            &changes(agents, seed, overrides)?,
        )
        .or_raise()?;
        Self::new(&s, threads)
    }

    /// A scenario file (a path string or path-like object) or TOML text (any string with a
    /// newline or `=`), as `throng run FILE` builds it; the keywords are those of
    /// `from_scenario`. The keys are documented in docs/SCENARIOS.md.
    #[staticmethod]
    #[pyo3(signature = (path_or_text, *, agents=None, seed=None, threads=None, **overrides))]
    fn from_toml(
        path_or_text: &Bound<'_, PyAny>,
        agents: Option<i128>,
        seed: Option<i128>,
        threads: Option<i128>,
        overrides: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let source = toml_source(path_or_text)?;
        let s = load(&source, &changes(agents, seed, overrides)?).or_raise()?;
        Self::new(&s, threads)
    }

    fn __repr__(&self) -> String {
        format!(
            "<throng.World {:?}: {} agents in {} groups, frame {}, t = {:.3} s, {:?}>",
            self.name,
            self.world.len(),
            self.world.groups().len(),
            self.world.frame(),
            self.world.time(),
            self.world.bounds()
        )
    }

    fn __len__(&self) -> usize {
        self.world.len()
    }

    /// The scenario's name.
    #[getter]
    fn name(&self) -> &str {
        &self.name
    }

    /// Frames stepped so far.
    #[getter]
    fn frame(&self) -> u64 {
        self.world.frame()
    }

    /// Simulated seconds so far.
    #[getter]
    fn time(&self) -> f64 {
        self.world.time()
    }

    /// The seed all randomness derives from.
    #[getter]
    fn seed(&self) -> u64 {
        self.world.seed()
    }

    /// The scenario's step count (`steps` in the file): `world.step(n=world.steps)` runs it.
    #[getter]
    fn steps(&self) -> u64 {
        self.steps
    }

    /// The default time step of `step()`, seconds (the scenario's `dt`).
    #[getter]
    fn get_dt(&self) -> f64 {
        convert::f32_to_f64(self.dt)
    }

    #[setter]
    fn set_dt(&mut self, dt: f32) -> PyResult<()> {
        self.dt = self.dt_or_default(Some(dt))?;
        Ok(())
    }

    /// rayon workers that step this world.
    #[getter]
    fn threads(&self) -> usize {
        self.pool.as_ref().map_or_else(
            rayon::current_num_threads,
            rayon::ThreadPool::current_num_threads,
        )
    }

    /// The neighbour-index backend: "grid", "kdtree" or "brute".
    #[getter]
    fn get_index(&self) -> String {
        self.world.index_kind().to_string()
    }

    #[setter]
    fn set_index(&mut self, index: &str) -> PyResult<()> {
        let kind: IndexKind = index.parse().or_raise()?;
        self.world.set_index(kind);
        Ok(())
    }

    /// Reorder agents by grid cell every this many frames (0: never).
    #[getter]
    fn get_reorder_every(&self) -> u32 {
        self.world.reorder_every()
    }

    #[setter]
    fn set_reorder_every(&mut self, frames: u32) {
        self.world.set_reorder_every(frames);
    }

    /// The bounds: {"kind": "torus" | "bounded" | "open", "size": (w, h) or None}.
    #[getter]
    fn bounds<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let b = self.world.bounds();
        let d = PyDict::new(py);
        let kind = match b {
            throng::Bounds::Open => "open",
            throng::Bounds::Bounded { .. } => "bounded",
            throng::Bounds::Torus { .. } => "torus",
        };
        d.set_item("kind", kind)?;
        d.set_item(
            "size",
            b.size()
                .map(|s| (convert::f32_to_f64(s.x), convert::f32_to_f64(s.y))),
        )?;
        Ok(d)
    }

    /// The groups' names, in group order.
    #[getter]
    fn group_names(&self) -> Vec<String> {
        self.world.groups().iter().map(|g| g.name.clone()).collect()
    }
}
