//! `throng.World`: a world built from a scenario, stepped with the GIL released, read out as
//! numpy arrays.
//!
//! Steps run on the world's own rayon pool when it was built with `threads=`, else on rayon's
//! global pool (all cores). A long `step(n=...)` runs in slices of at most [`SLICE`] with the
//! GIL released; between slices it takes the GIL back only to let Python handle signals, so
//! Ctrl-C stops it between two steps. The state after n steps does not depend on the slicing or
//! the thread count: it is the CLI's, bit for bit.

use std::time::{Duration, Instant};

use numpy::IntoPyArray;
use numpy::ndarray::Array1;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use throng::gravity::{GravityPoint, Motion};
use throng::obstacles::{Circle, Wall};
use throng::scenario::Scenario;
use throng::world::PhaseTimes;
use throng::{AgentId, AgentInit, Error, GroupParams, IndexKind, StepStats, World};

use crate::arrays::{self, Order};
use crate::convert;
use crate::error::{OrRaise, guarded, invalid, raise, raise_in, unsigned};
use crate::scenario::{Changes, Source, load};

/// The longest stretch of steps run without looking at Python's signals.
const SLICE: Duration = Duration::from_millis(200);

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

fn agent_id(id: i64) -> PyResult<AgentId> {
    u32::try_from(id).map(AgentId).map_err(|_| {
        raise(&Error::Invalid {
            name: "ids".into(),
            reason: format!("{id} is not an agent id (ids are 0 to 2^32 - 1)"),
        })
    })
}

/// Applies `set(id, value)` to each pair; on an error, restores the values `get` read before
/// and raises with the argument's name and row.
fn set_each<V: Copy>(
    name: &str,
    world: &mut World,
    ids: &[AgentId],
    values: &[V],
    get: impl Fn(&World, AgentId) -> Option<V>,
    set: impl Fn(&mut World, AgentId, V) -> throng::Result<()>,
) -> PyResult<()> {
    let mut old = Vec::with_capacity(ids.len());
    for (k, (&id, &v)) in ids.iter().zip(values).enumerate() {
        let before = get(world, id);
        if let Err(e) = set(world, id, v) {
            // A value read from the world passes its own checks, so this restores all; should
            // one not, the error says which agents keep their new values.
            let kept: Vec<u32> = ids[..k]
                .iter()
                .zip(&old)
                .rev()
                .filter_map(|(&id, before)| set(world, id, (*before)?).err().map(|_| id.0))
                .collect();
            let mut context = format!("{name}[{k}] (agent {})", id.0);
            if !kept.is_empty() {
                context += &format!("; agents {kept:?} keep their new values");
            }
            return Err(raise_in(Some(&context), &e));
        }
        old.push(before);
    }
    Ok(())
}

/// Agent `i`'s velocity and speed in float64.
fn speed(a: &throng::Agents, i: usize) -> (f64, f64, f64) {
    let (vx, vy) = (f64::from(a.vel_x()[i]), f64::from(a.vel_y()[i]));
    (vx, vy, vx.hypot(vy))
}

impl PyWorld {
    fn new(s: &Scenario, threads: Option<i128>) -> PyResult<Self> {
        let pool = pool(threads)?;
        Ok(PyWorld {
            world: build(s)?,
            name: s.name.clone(),
            dt: s.dt,
            steps: s.steps,
            pool,
        })
    }

    fn dt_or_default(&self, dt: Option<f32>) -> PyResult<f32> {
        let dt = dt.unwrap_or(self.dt);
        if !(dt.is_finite() && dt > 0.0 && dt <= throng::error::MAX_DT) {
            return Err(raise(&Error::InvalidTimeStep { dt: f64::from(dt) }));
        }
        Ok(dt)
    }

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

    /// Adds agents and returns their ids (uint32). `positions` is an (m, 2) array-like;
    /// `velocities` likewise (default: at rest); `group`, `orientations`, `max_speed` and
    /// `radius` are one value or m values (`max_speed` and `radius` override the group's).
    /// Every value is checked as the Rust API checks it; on an error no agent is added.
    #[expect(
        clippy::too_many_arguments,
        reason = "the Python signature: one keyword per per-agent column"
    )]
    #[pyo3(signature = (positions, velocities=None, *, group=None, orientations=None, max_speed=None, radius=None))]
    fn add_agents<'py>(
        &mut self,
        py: Python<'py>,
        positions: &Bound<'py, PyAny>,
        velocities: Option<&Bound<'py, PyAny>>,
        group: Option<&Bound<'py, PyAny>>,
        orientations: Option<&Bound<'py, PyAny>>,
        max_speed: Option<&Bound<'py, PyAny>>,
        radius: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        guarded(|| {
            // The ceilings first, from the shape alone: the rows must fit under the agent
            // ceiling and their memory under the process's bound, before anything is copied.
            let rows = arrays::pair_rows("positions", positions)?;
            let room = throng::error::MAX_AGENTS.saturating_sub(self.world.len());
            if rows > room {
                return Err(invalid(
                    "positions",
                    format!(
                        "{rows} rows, more than the {room} agents the ceiling of {} leaves room for",
                        throng::error::MAX_AGENTS
                    ),
                ));
            }
            if let Some(ceiling) = throng::limits::memory_ceiling() {
                // The agent's state and the copies read from the arrays.
                let bytes = (rows as u64).saturating_mul(throng::limits::BYTES_PER_AGENT + 64);
                throng::limits::check_memory_under("agents", bytes, ceiling)
                    .map_err(|e| raise(&e))?;
            }
            let pos = arrays::read_pairs("positions", positions)?;
            let m = pos.len();
            let vel = match velocities {
                Some(v) => arrays::read_pairs("velocities", v)?,
                None => vec![[0.0; 2]; m],
            };
            if vel.len() != m {
                return Err(invalid(
                    "velocities",
                    format!("expected {m} rows, got {}", vel.len()),
                ));
            }
            let floats =
                |name: &str, v: Option<&Bound<'py, PyAny>>| -> PyResult<Option<Vec<f32>>> {
                    v.map(|v| arrays::broadcast(name, arrays::read_floats(name, v)?, m))
                        .transpose()
                };
            let orient = floats("orientations", orientations)?;
            let speeds = floats("max_speed", max_speed)?;
            let radii = floats("radius", radius)?;
            let groups = match group {
                Some(g) => arrays::broadcast("group", arrays::read_ints("group", g)?, m)?,
                None => vec![0; m],
            };
            let mut ids = Vec::with_capacity(m);
            for k in 0..m {
                let group = usize::try_from(groups[k])
                    .map_err(|_| invalid("group", format!("row {k}: {} is negative", groups[k])));
                let init = group.map(|group| AgentInit {
                    position: pos[k].into(),
                    velocity: vel[k].into(),
                    orientation: orient.as_ref().map_or(0.0, |o| o[k]),
                    rotation: 0.0,
                    group,
                    max_speed: speeds.as_ref().map(|s| s[k]),
                    radius: radii.as_ref().map(|r| r[k]),
                    desired_speed: None,
                });
                match init.and_then(|i| {
                    self.world
                        .add_agent(i)
                        .map_err(|e| raise_in(Some(&format!("row {k}")), &e))
                }) {
                    Ok(id) => ids.push(id.0),
                    Err(e) => {
                        // The new agents sit at the end of storage: removing them from the last
                        // moves no other agent.
                        for &id in ids.iter().rev() {
                            self.world
                                .remove_agent(AgentId(id))
                                .expect("an agent added just now is alive");
                        }
                        return Err(e);
                    }
                }
            }
            Ok(Array1::from_vec(ids).into_pyarray(py).into_any())
        })
    }

    /// Removes the agents with these ids (an int or a 1-D array-like); the others keep their
    /// ids. Unknown or repeated ids raise ThrongError and nothing is removed.
    fn remove_agents(&mut self, ids: &Bound<'_, PyAny>) -> PyResult<()> {
        guarded(|| {
            let ids = arrays::read_ints("ids", ids)?;
            let mut seen = std::collections::HashSet::with_capacity(ids.len());
            let mut checked = Vec::with_capacity(ids.len());
            for &id in &ids {
                let id = agent_id(id)?;
                if self.world.agent(id).is_none() {
                    return Err(raise_in(Some("ids"), &Error::UnknownAgent { id }));
                }
                if !seen.insert(id) {
                    return Err(invalid("ids", format!("agent {} is listed twice", id.0)));
                }
                checked.push(id);
            }
            for id in checked {
                self.world
                    .remove_agent(id)
                    .expect("every id was checked alive");
            }
            Ok(())
        })
    }

    /// Moves agents: `positions` is an (m, 2) array-like, one row per id. On an error nothing
    /// changes.
    fn set_positions(
        &mut self,
        ids: &Bound<'_, PyAny>,
        positions: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        guarded(|| {
            let (ids, v) = self.rows_of(ids, positions, "positions")?;
            set_each(
                "positions",
                &mut self.world,
                &ids,
                &v,
                |w, id| w.agent(id).map(|a| a.position.into()),
                |w, id, p: [f32; 2]| w.set_position(id, p.into()),
            )
        })
    }

    /// Sets agents' velocities (clamped to their maximum speed); one (vx, vy) row per id. On an
    /// error nothing changes.
    fn set_velocities(
        &mut self,
        ids: &Bound<'_, PyAny>,
        velocities: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        guarded(|| {
            let (ids, v) = self.rows_of(ids, velocities, "velocities")?;
            set_each(
                "velocities",
                &mut self.world,
                &ids,
                &v,
                |w, id| w.agent(id).map(|a| a.velocity.into()),
                |w, id, p: [f32; 2]| w.set_velocity(id, p.into()),
            )
        })
    }

    /// Sets agents' own goal points, which behaviours with `target = "own"` steer to; one
    /// (x, y) row per id.
    fn set_targets(&mut self, ids: &Bound<'_, PyAny>, targets: &Bound<'_, PyAny>) -> PyResult<()> {
        guarded(|| {
            let (ids, v) = self.rows_of(ids, targets, "targets")?;
            // Checked first (ids are alive already), so that an error changes nothing.
            for (k, p) in v.iter().enumerate() {
                throng::error::finite_vec("target", (*p).into())
                    .map_err(|e| raise_in(Some(&format!("targets[{k}]")), &e))?;
            }
            for (&id, &p) in ids.iter().zip(&v) {
                self.world.set_target(id, p.into()).or_raise()?;
            }
            Ok(())
        })
    }

    /// Gives agents their own maximum speed (one value, or one per id).
    fn set_max_speeds(
        &mut self,
        ids: &Bound<'_, PyAny>,
        max_speed: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        guarded(|| {
            let ids = self.checked_ids(ids)?;
            let v = arrays::broadcast(
                "max_speed",
                arrays::read_floats("max_speed", max_speed)?,
                ids.len(),
            )?;
            // Checked first: a rolled-back agent would keep an override flag it did not have.
            for (k, &s) in v.iter().enumerate() {
                throng::error::positive("max_speed", s)
                    .map_err(|e| raise_in(Some(&format!("max_speed[{k}]")), &e))?;
            }
            set_each(
                "max_speed",
                &mut self.world,
                &ids,
                &v,
                |w, id| w.agents().index_of(id).map(|i| w.agents().max_speeds()[i]),
                |w, id, s| w.set_max_speed(id, s),
            )
        })
    }

    /// Group `group`'s profile as a dict with the keys of a scenario file's group table
    /// (`model`, `max_speed`, `steering`, ...).
    fn group_params<'py>(&self, py: Python<'py>, group: usize) -> PyResult<Bound<'py, PyAny>> {
        let g = self.world.groups().get(group).ok_or_else(|| {
            raise(&Error::UnknownGroup {
                group,
                count: self.world.groups().len(),
            })
        })?;
        convert::serialize_to_py(py, g, true)
    }

    /// Replaces group `group`'s profile with `params`, a dict with the keys of a scenario
    /// file's group table (missing keys take their defaults). Agents without their own maximum
    /// speed or radius take the new ones.
    fn set_group_params(&mut self, group: usize, params: &Bound<'_, PyAny>) -> PyResult<()> {
        guarded(|| {
            let p: GroupParams = convert::deserialize_from_py("params", params)?;
            self.world.set_group_params(group, p).or_raise()
        })
    }

    /// Adds a group with the profile `params` (as for `set_group_params`); returns its index.
    fn add_group(&mut self, params: &Bound<'_, PyAny>) -> PyResult<usize> {
        guarded(|| {
            let p: GroupParams = convert::deserialize_from_py("params", params)?;
            self.world.add_group(p).or_raise()
        })
    }

    /// Adds a circular obstacle; no agent may stand inside it.
    fn add_circle(&mut self, center: &Bound<'_, PyAny>, radius: f32) -> PyResult<()> {
        guarded(|| {
            let center = convert::vec2("center", center)?;
            self.world.add_circle(Circle { center, radius }).or_raise()
        })
    }

    /// Adds a wall: the segment from `a` to `b`, which agents cannot cross.
    fn add_wall(&mut self, a: &Bound<'_, PyAny>, b: &Bound<'_, PyAny>) -> PyResult<()> {
        guarded(|| {
            let wall = Wall {
                a: convert::vec2("a", a)?,
                b: convert::vec2("b", b)?,
            };
            self.world.add_wall(wall).or_raise()
        })
    }

    /// Adds the walls of a polyline through `points` ((m, 2)), closed into a polygon when
    /// `closed`.
    #[pyo3(signature = (points, closed=true))]
    fn add_polygon(&mut self, points: &Bound<'_, PyAny>, closed: bool) -> PyResult<()> {
        guarded(|| {
            let pts: Vec<glam::Vec2> = arrays::read_pairs("points", points)?
                .into_iter()
                .map(Into::into)
                .collect();
            self.world.add_polygon(&pts, closed).or_raise()
        })
    }

    /// Adds a gravity point pushing agents with `strength / distance**exponent` within
    /// `radius` (a positive strength repels, a negative one attracts); returns its index.
    /// `motion` is a dict as in scenario files: {"kind": "linear", "velocity": (vx, vy)},
    /// {"kind": "orbit", "center": (x, y), "orbit_radius": r, "angular_speed": w} or
    /// {"kind": "agent", "agent": id}; default static.
    #[pyo3(signature = (position, strength, radius, *, exponent=2.0, motion=None))]
    fn add_gravity_point(
        &mut self,
        position: &Bound<'_, PyAny>,
        strength: f32,
        radius: f32,
        exponent: f32,
        motion: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<usize> {
        guarded(|| {
            let motion: Motion = match motion {
                Some(m) => convert::deserialize_from_py("motion", m)?,
                None => Motion::Static,
            };
            let point = GravityPoint {
                position: convert::vec2("position", position)?,
                strength,
                exponent,
                radius,
                motion,
            };
            point.validate().or_raise()?;
            self.world.add_gravity_point(point).or_raise()
        })
    }

    /// The gravity points' current positions as a (K, 2) float32 array.
    fn gravity_positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let p = self.world.gravity().points();
        arrays::pairs(py, p.len(), None, |i| p[i].position.into(), None)
    }

    /// Moves gravity point `k`.
    fn set_gravity_position(&mut self, k: usize, position: &Bound<'_, PyAny>) -> PyResult<()> {
        guarded(|| {
            let p = convert::vec2("position", position)?;
            self.world.set_gravity_position(k, p).or_raise()
        })
    }

    /// Number of grid fields.
    #[getter]
    fn field_count(&self) -> usize {
        self.world.field_count()
    }

    /// Moves the goals of one channel of a field to the cells `goals` ((m, 2) integer
    /// (x, y) cells); the channel is rebuilt at the start of the next step.
    fn set_field_goals(
        &mut self,
        field: usize,
        channel: usize,
        goals: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        guarded(|| {
            let flat = arrays::read_ints("goals", goals)?;
            if !flat.len().is_multiple_of(2) {
                return Err(invalid(
                    "goals",
                    "expected (x, y) cells: an (m, 2) integer array",
                ));
            }
            let cells = flat
                .chunks_exact(2)
                .map(|c| {
                    let cell = |v: i64| {
                        u32::try_from(v).map_err(|_| {
                            invalid(
                                "goals",
                                format!("cell coordinate {v} is negative or too large"),
                            )
                        })
                    };
                    Ok((cell(c[0])?, cell(c[1])?))
                })
                .collect::<PyResult<Vec<_>>>()?;
            self.world
                .set_field_goals(field, channel, &cells)
                .or_raise()
        })
    }

    /// Draws `n` distinct free cells with `seed` as the new goals of one channel.
    fn randomize_field_goals(
        &mut self,
        field: usize,
        channel: usize,
        n: usize,
        seed: u64,
    ) -> PyResult<()> {
        guarded(|| {
            self.world
                .randomize_field_goals(field, channel, n, seed)
                .or_raise()
        })
    }

    /// Re-draws every channel's goals of `field` (`count` cells each) every `every` frames
    /// (0 turns it off).
    fn shuffle_field_goals_every(
        &mut self,
        field: usize,
        every: u64,
        count: usize,
    ) -> PyResult<()> {
        guarded(|| {
            self.world
                .shuffle_field_goals_every(field, every, count)
                .or_raise()
        })
    }

    /// Makes cell (x, y) of `field` a wall (or free ground with `blocked=False`).
    #[pyo3(signature = (field, x, y, blocked=true))]
    fn set_field_blocked(&mut self, field: usize, x: u32, y: u32, blocked: bool) -> PyResult<()> {
        guarded(|| {
            self.world
                .set_field_blocked(field, x, y, blocked)
                .or_raise()
        })
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

impl PyWorld {
    /// Ids (checked alive) and one (x, y) row per id.
    fn rows_of(
        &self,
        ids: &Bound<'_, PyAny>,
        values: &Bound<'_, PyAny>,
        name: &str,
    ) -> PyResult<(Vec<AgentId>, Vec<[f32; 2]>)> {
        let ids = self.checked_ids(ids)?;
        let v = arrays::read_pairs(name, values)?;
        if v.len() != ids.len() {
            return Err(invalid(
                name,
                format!("expected {} rows (one per id), got {}", ids.len(), v.len()),
            ));
        }
        Ok((ids, v))
    }

    /// Ids of live agents.
    fn checked_ids(&self, ids: &Bound<'_, PyAny>) -> PyResult<Vec<AgentId>> {
        arrays::read_ints("ids", ids)?
            .into_iter()
            .map(|id| {
                let id = agent_id(id)?;
                match self.world.agent(id) {
                    Some(_) => Ok(id),
                    None => Err(raise_in(Some("ids"), &Error::UnknownAgent { id })),
                }
            })
            .collect()
    }
}
