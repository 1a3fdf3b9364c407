//! `throng.Simulation`: a pedestrian study built in Python without scenario files, in the terms
//! of JuPedSim (a walkable area, stages, journeys with transitions, agents added with their own
//! parameters, `iterate`), with `throng.Journey`, `throng.Transition` and the handles of queue
//! and waiting set stages.
//!
//! A simulation owns a [`World`] with the walkable area set; each pedestrian model used gets
//! one group ([`Profile::journey_walkers`]), made when the first agent of that model is added.
//! Stages are named by their ids (ints) or by the handles `add_queue_stage` and
//! `add_waiting_set_stage` return. Every argument is checked by the library's own validation,
//! and every error is a `ThrongError`. `record` and `close` write trajectory files as it goes
//! ([`crate::record`]).

use numpy::IntoPyArray;
use numpy::ndarray::Array1;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use throng::journey::{Journey, Stage, StageId, Transition};
use throng::ped::Model;
use throng::profile::Profile;
use throng::{AgentId, AgentInit, Bounds, Error, Walkable, World};

use crate::arrays::{self, Order};
use crate::error::{OrRaise, guarded, invalid, raise, raise_in, unsigned};
use crate::record::Recorders;

/// A walkable area or polygon given as WKT text, a shapely geometry (its `wkt`), or a sequence
/// of `(x, y)` points (one ring).
fn area(name: &str, obj: &Bound<'_, PyAny>) -> PyResult<Walkable> {
    if let Ok(s) = obj.cast::<PyString>() {
        let text: String = s.extract()?;
        return Walkable::from_wkt(&text).map_err(|e| raise_in(Some(name), &e));
    }
    if let Ok(wkt) = obj.getattr("wkt")
        && let Ok(text) = wkt.extract::<String>()
    {
        return Walkable::from_wkt(&text).map_err(|e| raise_in(Some(name), &e));
    }
    let ring = arrays::read_pairs(name, obj)?;
    Walkable::from_rings(ring.into_iter().map(Into::into).collect(), Vec::new())
        .map_err(|e| raise_in(Some(name), &e))
}

/// How a simulation's checkpoint names itself in its run settings (then its default model).
const SAVED_AS: &str = "throng.Simulation:";

/// At rest.
fn glam_zero() -> throng::prelude::Vec2 {
    throng::prelude::Vec2::ZERO
}

/// A stage given as its id or as a stage handle (anything with an `id` attribute).
fn stage_id(obj: &Bound<'_, PyAny>) -> PyResult<StageId> {
    let raw = match obj.extract::<i128>() {
        Ok(v) => v,
        Err(_) => obj
            .getattr("id")
            .and_then(|v| v.extract::<i128>())
            .map_err(|_| invalid("stage", "expected a stage id (int) or a stage handle"))?,
    };
    Ok(StageId(unsigned("stage", raw)?))
}

/// A pedestrian model by name (`"cfsm"`, `"social_force"`, `"sfm"`).
fn model(name: &str) -> PyResult<Model> {
    Model::parse(name).ok_or_else(|| {
        invalid(
            "model",
            format!(
                "unknown pedestrian model {name:?} (known: {})",
                Model::names().collect::<Vec<_>>().join(", ")
            ),
        )
    })
}

/// How an agent that completed a stage chooses its next: `Transition.fixed(stage)`,
/// `Transition.round_robin([(stage, weight), ...])`, `Transition.least_targeted([stage, ...])`.
#[pyclass(name = "Transition", module = "throng", frozen, from_py_object)]
#[derive(Clone, Debug)]
pub struct PyTransition {
    inner: Transition,
}

#[pymethods]
impl PyTransition {
    /// Always `stage`.
    #[staticmethod]
    fn fixed(stage: &Bound<'_, PyAny>) -> PyResult<Self> {
        Ok(PyTransition {
            inner: Transition::fixed(stage_id(stage)?),
        })
    }

    /// Weighted round robin over `(stage, weight)` pairs (weights at least 1).
    #[staticmethod]
    fn round_robin(weighted: Vec<(Bound<'_, PyAny>, i128)>) -> PyResult<Self> {
        let mut w = Vec::with_capacity(weighted.len());
        for (s, weight) in weighted {
            w.push((stage_id(&s)?, unsigned("weight", weight)?));
        }
        Ok(PyTransition {
            inner: Transition::round_robin(w),
        })
    }

    /// The least targeted of `stages` when an agent completes the stage (the first on a tie).
    #[staticmethod]
    fn least_targeted(stages: Vec<Bound<'_, PyAny>>) -> PyResult<Self> {
        let s = stages.iter().map(stage_id).collect::<PyResult<Vec<_>>>()?;
        Ok(PyTransition {
            inner: Transition::least_targeted(s),
        })
    }

    fn __repr__(&self) -> String {
        format!("Transition({:?})", self.inner)
    }
}

/// A journey: stages (ids or handles), and a transition out of each stage that is not its end.
#[pyclass(name = "Journey", module = "throng", from_py_object)]
#[derive(Clone, Debug)]
pub struct PyJourney {
    inner: Journey,
}

#[pymethods]
impl PyJourney {
    /// A journey through `stages`; with `chain=True`, a fixed transition from each to the next.
    #[new]
    #[pyo3(signature = (stages, *, chain=false))]
    fn new(stages: Vec<Bound<'_, PyAny>>, chain: bool) -> PyResult<Self> {
        let s = stages.iter().map(stage_id).collect::<PyResult<Vec<_>>>()?;
        Ok(PyJourney {
            inner: if chain {
                Journey::chain(s)
            } else {
                Journey::new(s)
            },
        })
    }

    /// Sets the transition out of `stage` (replacing any it had).
    fn set_transition(
        &mut self,
        stage: &Bound<'_, PyAny>,
        transition: &PyTransition,
    ) -> PyResult<()> {
        let s = stage_id(stage)?;
        self.inner = std::mem::take(&mut self.inner).with_transition(s, transition.inner.clone());
        Ok(())
    }

    /// JuPedSim's name for `set_transition`.
    fn set_transition_for_stage(
        &mut self,
        stage: &Bound<'_, PyAny>,
        transition: &PyTransition,
    ) -> PyResult<()> {
        self.set_transition(stage, transition)
    }

    /// The stage ids, in the order given.
    #[getter]
    fn stages(&self) -> Vec<u32> {
        self.inner.stages.iter().map(|s| s.0).collect()
    }

    fn __repr__(&self) -> String {
        format!("Journey(stages={:?})", self.stages())
    }
}

/// The ids of the agents in the slots of queue or waiting set `id`, in slot order.
fn slot_holders(sim: &Py<PySimulation>, py: Python<'_>, id: u32) -> PyResult<Vec<u32>> {
    let sim = sim.borrow(py);
    let q = sim.world.queue(StageId(id)).or_raise()?;
    Ok(q.occupants.iter().map(|a| a.0).collect())
}

/// A queue stage of a simulation: `pop(n)` releases the first `n` in its slots.
#[pyclass(name = "QueueStage", module = "throng")]
#[derive(Debug)]
pub struct PyQueue {
    sim: Py<PySimulation>,
    id: u32,
}

#[pymethods]
impl PyQueue {
    /// The stage's id.
    #[getter]
    fn id(&self) -> u32 {
        self.id
    }

    /// Releases the first `n` agents in the queue's slots to their next stage (at the next
    /// iteration); ThrongError when fewer than `n` are in it.
    fn pop(&self, py: Python<'_>, n: i128) -> PyResult<()> {
        let n: usize = unsigned("n", n)?;
        let mut sim = self.sim.borrow_mut(py);
        sim.world.pop_queue(StageId(self.id), n).or_raise()
    }

    /// The ids of the agents in the queue's slots, the front first.
    fn enqueued(&self, py: Python<'_>) -> PyResult<Vec<u32>> {
        slot_holders(&self.sim, py, self.id)
    }

    /// How many agents are in the queue's slots.
    fn count_enqueued(&self, py: Python<'_>) -> PyResult<usize> {
        Ok(self.enqueued(py)?.len())
    }

    /// How many live agents have the queue as their current stage.
    fn count_targeting(&self, py: Python<'_>) -> usize {
        self.sim.borrow(py).world.stage_counts()[self.id as usize].targeting
    }

    fn __repr__(&self) -> String {
        format!("QueueStage(id={})", self.id)
    }
}

/// A waiting set stage of a simulation: holds everyone in its slots while `active`.
#[pyclass(name = "WaitingSetStage", module = "throng")]
#[derive(Debug)]
pub struct PyWaitingSet {
    sim: Py<PySimulation>,
    id: u32,
}

#[pymethods]
impl PyWaitingSet {
    /// The stage's id.
    #[getter]
    fn id(&self) -> u32 {
        self.id
    }

    /// Whether the set holds its agents. Set it to False to release everyone in it.
    #[getter]
    fn get_active(&self, py: Python<'_>) -> PyResult<bool> {
        let sim = self.sim.borrow(py);
        Ok(sim.world.queue(StageId(self.id)).or_raise()?.active)
    }

    #[setter]
    fn set_active(&self, py: Python<'_>, active: bool) -> PyResult<()> {
        let mut sim = self.sim.borrow_mut(py);
        sim.world
            .set_waiting_set_active(StageId(self.id), active)
            .or_raise()
    }

    /// The ids of the agents in its slots, in slot order.
    fn waiting(&self, py: Python<'_>) -> PyResult<Vec<u32>> {
        slot_holders(&self.sim, py, self.id)
    }

    /// How many agents are in its slots.
    fn count_waiting(&self, py: Python<'_>) -> PyResult<usize> {
        Ok(self.waiting(py)?.len())
    }

    /// How many live agents have it as their current stage.
    fn count_targeting(&self, py: Python<'_>) -> usize {
        self.sim.borrow(py).world.stage_counts()[self.id as usize].targeting
    }

    fn __repr__(&self) -> String {
        format!("WaitingSetStage(id={})", self.id)
    }
}

/// A pedestrian simulation on a walkable area (WKT text or a shapely polygon), with stages,
/// journeys and agents added from Python; `iterate()` advances it by `dt` seconds per step.
#[pyclass(name = "Simulation", module = "throng")]
#[derive(Debug)]
pub struct PySimulation {
    world: World,
    dt: f32,
    model: Model,
    /// The group of each pedestrian model used so far.
    groups: Vec<(Model, usize)>,
    /// The group of agents driven from outside, once one was added.
    external: Option<usize>,
    pool: Option<rayon::ThreadPool>,
    /// The trajectory files `record` opened and `close` finishes.
    recorders: Recorders,
}

impl PySimulation {
    /// The group of `model`, made on first use.
    fn group(&mut self, model: Model) -> PyResult<usize> {
        if let Some(&(_, g)) = self.groups.iter().find(|(m, _)| *m == model) {
            return Ok(g);
        }
        let g = self
            .world
            .add_group(Profile::journey_walkers(model))
            .or_raise()?;
        self.groups.push((model, g));
        Ok(g)
    }

    /// The group of agents driven from outside, made on first use: no behaviour, no model.
    fn external_group(&mut self) -> PyResult<usize> {
        if let Some(g) = self.external {
            return Ok(g);
        }
        let mut p = Profile::kinematic(throng::steering::SteeringProfile::default());
        p.radius = 0.2;
        p.max_speed = 100.0;
        let g = self.world.add_group(p).or_raise()?;
        self.external = Some(g);
        Ok(g)
    }

    fn rows(&self) -> Vec<usize> {
        Order::Id.rows(self.world.agents()).unwrap_or_default()
    }
}

#[pymethods]
impl PySimulation {
    /// A simulation on `geometry` (WKT text, a shapely polygon, or a sequence of points),
    /// with agents of `model` (`"cfsm"`, the default, or `"social_force"`) unless
    /// `add_agents` says otherwise, stepped by `dt` seconds, random draws from `seed`, on
    /// `threads` workers (default: all cores).
    #[new]
    #[pyo3(signature = (geometry, *, model="cfsm", dt=0.01, seed=1, threads=None))]
    fn new(
        geometry: &Bound<'_, PyAny>,
        model: &str,
        dt: f32,
        seed: i128,
        threads: Option<i128>,
    ) -> PyResult<Self> {
        guarded(|| {
            let m = self::model(model)?;
            if !(dt.is_finite() && dt > 0.0 && dt <= throng::error::MAX_DT) {
                return Err(raise(&Error::InvalidTimeStep { dt: f64::from(dt) }));
            }
            let walkable = area("geometry", geometry)?;
            let mut world = World::builder()
                .bounds(Bounds::Open)
                .seed(unsigned("seed", seed)?)
                .build()
                .or_raise()?;
            world.set_walkable(walkable).or_raise()?;
            Ok(PySimulation {
                world,
                dt,
                model: m,
                groups: Vec::new(),
                external: None,
                pool: crate::world::pool(threads)?,
                recorders: Recorders::default(),
            })
        })
    }

    /// A waypoint stage at `position`, reached within `distance` m; returns its id.
    fn add_waypoint_stage(&mut self, position: (f32, f32), distance: f32) -> PyResult<u32> {
        guarded(|| {
            let s = Stage::Waypoint {
                position: position.into(),
                distance,
            };
            Ok(self.world.add_stage(s).or_raise()?.0)
        })
    }

    /// An exit stage on `polygon` (WKT, shapely, or points): agents whose stage it is leave the
    /// simulation when they reach it. Returns its id.
    fn add_exit_stage(&mut self, polygon: &Bound<'_, PyAny>) -> PyResult<u32> {
        guarded(|| {
            let s = Stage::Exit {
                area: area("polygon", polygon)?,
            };
            Ok(self.world.add_stage(s).or_raise()?.0)
        })
    }

    /// A queue stage with slots at `positions` (the front first); returns its handle.
    fn add_queue_stage(slf: &Bound<'_, Self>, positions: &Bound<'_, PyAny>) -> PyResult<PyQueue> {
        guarded(|| {
            let slots = arrays::read_pairs("positions", positions)?;
            let s = Stage::Queue {
                slots: slots.into_iter().map(Into::into).collect(),
            };
            let id = slf.borrow_mut().world.add_stage(s).or_raise()?.0;
            Ok(PyQueue {
                sim: slf.clone().unbind(),
                id,
            })
        })
    }

    /// A waiting set stage with slots at `positions`, active from the start; returns its
    /// handle.
    fn add_waiting_set_stage(
        slf: &Bound<'_, Self>,
        positions: &Bound<'_, PyAny>,
    ) -> PyResult<PyWaitingSet> {
        guarded(|| {
            let slots = arrays::read_pairs("positions", positions)?;
            let s = Stage::WaitingSet {
                slots: slots.into_iter().map(Into::into).collect(),
                active: true,
            };
            let id = slf.borrow_mut().world.add_stage(s).or_raise()?.0;
            Ok(PyWaitingSet {
                sim: slf.clone().unbind(),
                id,
            })
        })
    }

    /// A direct steering stage: each agent on it walks to the point `set_direct_target` gives
    /// it. Returns its id.
    fn add_direct_steering_stage(&mut self) -> PyResult<u32> {
        guarded(|| Ok(self.world.add_stage(Stage::DirectSteering).or_raise()?.0))
    }

    /// Adds `journey` (checked: every stage exists, each has a transition or ends it, an exit
    /// is reachable) and returns its id.
    fn add_journey(&mut self, journey: &PyJourney) -> PyResult<u32> {
        guarded(|| Ok(self.world.add_journey(journey.inner.clone()).or_raise()?.0))
    }

    /// Adds agents at `positions` (one `(x, y)`, which returns an int id, or an (m, 2)
    /// array-like, which returns a uint32 array) on `journey` at `stage` (its first stage by
    /// default), with `desired_speed` and `radius` per agent or for all (default: Weidmann's
    /// speeds and 0.2 m) and pedestrian `model` (default: the simulation's). On an error no
    /// agent is added.
    #[expect(
        clippy::too_many_arguments,
        reason = "the Python signature: one keyword per per-agent parameter"
    )]
    #[pyo3(signature = (positions, *, journey=None, stage=None, desired_speed=None, radius=None, model=None))]
    fn add_agents<'py>(
        &mut self,
        py: Python<'py>,
        positions: &Bound<'py, PyAny>,
        journey: Option<i128>,
        stage: Option<&Bound<'py, PyAny>>,
        desired_speed: Option<&Bound<'py, PyAny>>,
        radius: Option<&Bound<'py, PyAny>>,
        model: Option<&str>,
    ) -> PyResult<Bound<'py, PyAny>> {
        guarded(|| {
            let single = positions.extract::<(f32, f32)>().is_ok();
            let pos = if single {
                let (x, y) = positions.extract::<(f32, f32)>()?;
                vec![[x, y]]
            } else {
                let rows = arrays::pair_rows("positions", positions)?;
                let room = throng::error::MAX_AGENTS.saturating_sub(self.world.len());
                if rows > room {
                    return Err(invalid(
                        "positions",
                        format!(
                            "{rows} rows, more than the {room} agents the ceiling leaves room for"
                        ),
                    ));
                }
                arrays::read_pairs("positions", positions)?
            };
            let m = pos.len();
            let external = model == Some("external");
            let journey = match (journey, external) {
                (Some(j), false) => {
                    let j = throng::journey::JourneyId(unsigned("journey", j)?);
                    self.world.journey(j).or_raise()?;
                    Some(j)
                }
                (None, true) => None,
                (Some(_), true) => {
                    return Err(invalid(
                        "journey",
                        "external agents follow no journey: they go where set_external puts them",
                    ));
                }
                (None, false) => {
                    return Err(invalid(
                        "journey",
                        "a pedestrian needs a journey (model=\"external\" agents need none)",
                    ));
                }
            };
            let stage = stage.map(stage_id).transpose()?;
            let floats =
                |name: &str, v: Option<&Bound<'py, PyAny>>| -> PyResult<Option<Vec<f32>>> {
                    v.map(|v| arrays::broadcast(name, arrays::read_floats(name, v)?, m))
                        .transpose()
                };
            let speeds = floats("desired_speed", desired_speed)?;
            let radii = floats("radius", radius)?;
            let group = if external {
                self.external_group()?
            } else {
                self.group(model.map(self::model).transpose()?.unwrap_or(self.model))?
            };
            let mut ids: Vec<u32> = Vec::with_capacity(m);
            let mut add = |k: usize| -> PyResult<u32> {
                let init = AgentInit {
                    position: pos[k].into(),
                    group,
                    radius: radii.as_ref().map(|r| r[k]),
                    desired_speed: speeds.as_ref().map(|s| s[k]),
                    ..AgentInit::default()
                };
                let context = format!("row {k}");
                let id = self
                    .world
                    .add_agent(init)
                    .map_err(|e| raise_in(Some(&context), &e))?;
                let placed = match journey {
                    Some(j) => self.world.set_journey(id, j, stage),
                    None => self.world.set_external(id, pos[k].into(), glam_zero()),
                };
                if let Err(e) = placed {
                    let _ = self.world.remove_agent(id);
                    return Err(raise_in(Some(&context), &e));
                }
                if let Some(area) = self.world.walkable()
                    && !area.contains(pos[k].into())
                {
                    let _ = self.world.remove_agent(id);
                    return Err(invalid(
                        "positions",
                        format!(
                            "row {k}: ({}, {}) lies outside the walkable area",
                            pos[k][0], pos[k][1]
                        ),
                    ));
                }
                Ok(id.0)
            };
            for k in 0..m {
                match add(k) {
                    Ok(id) => ids.push(id),
                    Err(e) => {
                        for &id in ids.iter().rev() {
                            let _ = self.world.remove_agent(AgentId(id));
                        }
                        return Err(e);
                    }
                }
            }
            if single {
                Ok(ids[0].into_pyobject(py)?.into_any())
            } else {
                Ok(Array1::from_vec(ids).into_pyarray(py).into_any())
            }
        })
    }

    /// Advances the simulation by `n` steps of `dt` (the GIL released).
    #[pyo3(signature = (n=1))]
    fn iterate(&mut self, py: Python<'_>, n: i128) -> PyResult<()> {
        let n: u64 = unsigned("n", n)?;
        guarded(|| {
            let (world, dt, pool) = (&mut self.world, self.dt, &self.pool);
            let recorders = &mut self.recorders;
            py.detach(|| {
                let mut run = || -> throng::Result<()> {
                    for _ in 0..n {
                        world.step(dt)?;
                        recorders.after_step(world)?;
                    }
                    Ok(())
                };
                match pool {
                    Some(p) => p.install(run),
                    None => run(),
                }
            })
            .or_raise()
        })
    }

    /// How many agents are in the simulation.
    fn agent_count(&self) -> usize {
        self.world.len()
    }

    /// Simulated seconds since the start.
    fn elapsed_time(&self) -> f64 {
        self.world.time()
    }

    /// Steps taken since the start.
    fn iteration_count(&self) -> u64 {
        self.world.frame()
    }

    /// The time step, seconds.
    #[getter]
    fn dt(&self) -> f32 {
        self.dt
    }

    /// `{exit stage id: agents that left through it}` for every exit stage.
    fn exit_counts<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (k, c) in self.world.stage_counts().iter().enumerate() {
            if matches!(self.world.stage(StageId(k as u32)), Ok(Stage::Exit { .. })) {
                d.set_item(k, c.left)?;
            }
        }
        Ok(d)
    }

    /// The ids of the agents, ascending (the row order of every array method).
    fn ids<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let rows = self.rows();
        let a = self.world.agents();
        arrays::column(py, rows.len(), Some(&rows), "uint32", |i| a.id(i).0, None)
    }

    /// Positions, an (n, 2) float32 array by ascending id.
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let rows = self.rows();
        let a = self.world.agents();
        arrays::pairs(py, rows.len(), Some(&rows), |i| a.position(i).into(), None)
    }

    /// Velocities, an (n, 2) float32 array by ascending id.
    fn velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let rows = self.rows();
        let a = self.world.agents();
        arrays::pairs(py, rows.len(), Some(&rows), |i| a.velocity(i).into(), None)
    }

    /// Desired speeds, m/s, by ascending id.
    fn desired_speeds<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let rows = self.rows();
        let a = self.world.agents();
        arrays::column(
            py,
            rows.len(),
            Some(&rows),
            "float32",
            |i| a.desired_speeds()[i],
            None,
        )
    }

    /// Radii, m, by ascending id.
    fn radii<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let rows = self.rows();
        let a = self.world.agents();
        arrays::column(
            py,
            rows.len(),
            Some(&rows),
            "float32",
            |i| a.radii()[i],
            None,
        )
    }

    /// Sets the desired speeds of agents `ids` (one value or one per id); on an error nothing
    /// changes.
    fn set_desired_speeds(
        &mut self,
        ids: &Bound<'_, PyAny>,
        values: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        self.set_per_agent(
            "desired_speed",
            ids,
            values,
            |v| {
                throng::error::in_range(
                    "desired_speed",
                    v,
                    0.0,
                    throng::ped::MAX_DESIRED_SPEED,
                    "[0, 100] m/s",
                )
                .map(|_| ())
            },
            |w, id, v| w.set_desired_speed(id, v),
        )
    }

    /// Sets the radii of agents `ids` (one value or one per id); on an error nothing changes.
    fn set_radii(&mut self, ids: &Bound<'_, PyAny>, values: &Bound<'_, PyAny>) -> PyResult<()> {
        self.set_per_agent(
            "radius",
            ids,
            values,
            |v| throng::error::non_negative("radius", v).map(|_| ()),
            |w, id, v| w.set_radius(id, v),
        )
    }

    /// Agent `id`'s `(journey, stage)`, or None when it is on none.
    fn agent_journey(&self, id: i128) -> PyResult<Option<(u32, u32)>> {
        let id = AgentId(unsigned("id", id)?);
        Ok(self.world.journey_of(id).map(|(j, s)| (j.0, s.0)))
    }

    /// Moves agent `id` to `stage` of `journey` (its first stage by default).
    #[pyo3(signature = (id, journey, stage=None))]
    fn switch_agent_journey(
        &mut self,
        id: i128,
        journey: i128,
        stage: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let id = AgentId(unsigned("id", id)?);
        let j = throng::journey::JourneyId(unsigned("journey", journey)?);
        let s = stage.map(stage_id).transpose()?;
        guarded(|| self.world.set_journey(id, j, s).or_raise())
    }

    /// Sets the point agent `id` walks to while on a direct steering stage.
    fn set_direct_target(&mut self, id: i128, position: (f32, f32)) -> PyResult<()> {
        let id = AgentId(unsigned("id", id)?);
        guarded(|| self.world.set_direct_target(id, position.into()).or_raise())
    }

    /// Removes agent `id`.
    fn remove_agent(&mut self, id: i128) -> PyResult<()> {
        let id = AgentId(unsigned("id", id)?);
        guarded(|| self.world.remove_agent(id).or_raise())
    }

    /// Puts agents `ids` (added with `model="external"`, or any agent) at `positions` with
    /// `velocities` (default: at rest); call it between iterations. The step moves them not at
    /// all; every pedestrian sees and avoids them. On an error nothing changes.
    #[pyo3(signature = (ids, positions, velocities=None))]
    fn set_external(
        &mut self,
        ids: &Bound<'_, PyAny>,
        positions: &Bound<'_, PyAny>,
        velocities: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        guarded(|| {
            let ids = arrays::read_ints("ids", ids)?;
            let pos = arrays::read_pairs("positions", positions)?;
            let vel = match velocities {
                Some(v) => arrays::read_pairs("velocities", v)?,
                None => vec![[0.0; 2]; pos.len()],
            };
            if pos.len() != ids.len() || vel.len() != ids.len() {
                return Err(invalid(
                    "positions",
                    format!(
                        "{} ids, {} positions and {} velocities: one of each per agent",
                        ids.len(),
                        pos.len(),
                        vel.len()
                    ),
                ));
            }
            let ids = ids
                .iter()
                .map(|&i| {
                    u32::try_from(i)
                        .map(AgentId)
                        .map_err(|_| invalid("ids", format!("{i} is not an agent id")))
                })
                .collect::<PyResult<Vec<_>>>()?;
            // Checked in full first, so that an error changes nothing.
            for (k, &id) in ids.iter().enumerate() {
                self.world
                    .check_external(id, pos[k].into(), vel[k].into())
                    .map_err(|e| raise_in(Some(&format!("row {k} (agent {})", id.0)), &e))?;
            }
            for (k, &id) in ids.iter().enumerate() {
                self.world
                    .set_external(id, pos[k].into(), vel[k].into())
                    .or_raise()?;
            }
            Ok(())
        })
    }

    /// Saves the whole simulation (agents, stages with their queues, journeys, the current
    /// walkable area, external agents, the time step) to a checkpoint file at `path`, written
    /// crash-safe; `Simulation.load(path)` resumes it bit for bit.
    fn save(&self, path: std::path::PathBuf) -> PyResult<()> {
        let run = throng::checkpoint::RunInfo {
            scenario: format!("{SAVED_AS}{}", self.model.name()),
            dt: self.dt,
            steps: self.world.frame(),
            checkpoint_every: 0,
        };
        guarded(|| self.world.save_file(&path, Some(&run)).or_raise())
    }

    /// A simulation resumed from a checkpoint written by `save` (on `threads` workers).
    #[staticmethod]
    #[pyo3(signature = (path, *, threads=None))]
    fn load(path: std::path::PathBuf, threads: Option<i128>) -> PyResult<Self> {
        guarded(|| {
            let (world, run) = World::load_file(&path).or_raise()?;
            let run = run
                .filter(|r| r.scenario.starts_with(SAVED_AS))
                .ok_or_else(|| {
                    invalid(
                        "path",
                        "not a checkpoint of a throng.Simulation (World.from_toml and the \
                         command line resume the others)",
                    )
                })?;
            let model = Model::parse(&run.scenario[SAVED_AS.len()..]).unwrap_or_default();
            let mut groups = Vec::new();
            let mut external = None;
            for (g, p) in world.groups().iter().enumerate() {
                match p.pedestrian {
                    Some(ped) if !groups.iter().any(|&(m, _)| m == ped.model) => {
                        groups.push((ped.model, g));
                    }
                    None if p.steering.behaviours.is_empty() && external.is_none() => {
                        external = Some(g);
                    }
                    _ => {}
                }
            }
            Ok(PySimulation {
                world,
                dt: run.dt,
                model,
                groups,
                external,
                pool: crate::world::pool(threads)?,
                recorders: Recorders::default(),
            })
        })
    }

    /// Replaces the walkable area (WKT, shapely, or points): a door closed or opened. Refused
    /// (ThrongError naming the agent, nothing changed) while an agent stands outside the new
    /// area; stages it cuts off keep no route.
    fn switch_geometry(&mut self, geometry: &Bound<'_, PyAny>) -> PyResult<()> {
        guarded(|| {
            let a = area("geometry", geometry)?;
            self.world.switch_walkable(a).or_raise()
        })
    }

    /// The walkable area as WKT text (or, with `shapely=True`, a shapely geometry).
    #[pyo3(signature = (*, shapely=false))]
    fn walkable_area<'py>(&self, py: Python<'py>, shapely: bool) -> PyResult<Bound<'py, PyAny>> {
        let wkt = self
            .world
            .walkable()
            .map(Walkable::to_wkt)
            .unwrap_or_default();
        if shapely {
            let module = py.import("shapely")?;
            return module.call_method1("from_wkt", (wkt,));
        }
        Ok(PyString::new(py, &wkt).into_any())
    }

    fn __repr__(&self) -> String {
        format!(
            "Simulation(agents={}, stages={}, time={:.2} s)",
            self.world.len(),
            self.world.stage_count(),
            self.world.time()
        )
    }

    /// Starts writing trajectories to `path`, in the format its extension names: `.sqlite`
    /// (also `.sqlite3`, `.db`) JuPedSim's SQLite database (version 2) with the walkable area
    /// as its geometry, `.txt` PedPy's text format, anything else (`.csv`) throng's CSV. The
    /// current frame is written now and then one every `every` steps; the file is complete
    /// (and readable by PedPy) once `close()` has finished it, absent until then.
    #[pyo3(signature = (path, every=1))]
    fn record(&mut self, path: std::path::PathBuf, every: i128) -> PyResult<()> {
        let every: u64 = unsigned("every", every)?;
        guarded(|| {
            self.recorders
                .open(&path, every, self.dt, &self.world)
                .or_raise()
        })
    }

    /// Finishes every trajectory file `record` opened: flushed, closed and moved into place.
    /// A second call does nothing; the simulation can go on and record again. Garbage
    /// collection finishes files that were not closed.
    fn close(&mut self) -> PyResult<()> {
        guarded(|| self.recorders.close().or_raise())
    }
}

impl PySimulation {
    fn set_per_agent(
        &mut self,
        name: &str,
        ids: &Bound<'_, PyAny>,
        values: &Bound<'_, PyAny>,
        check: impl Fn(f32) -> throng::Result<()>,
        set: impl Fn(&mut World, AgentId, f32) -> throng::Result<()>,
    ) -> PyResult<()> {
        guarded(|| {
            let ids = arrays::read_ints("ids", ids)?;
            let values = arrays::broadcast(name, arrays::read_floats(name, values)?, ids.len())?;
            let ids = ids
                .iter()
                .map(|&i| {
                    u32::try_from(i)
                        .map(AgentId)
                        .map_err(|_| invalid("ids", format!("{i} is not an agent id")))
                })
                .collect::<PyResult<Vec<_>>>()?;
            // Checked in full first, so that an error changes nothing.
            for (k, (&id, &v)) in ids.iter().zip(&values).enumerate() {
                let context = format!("{name}[{k}]");
                if !self.world.agents().contains(id) {
                    return Err(raise_in(Some(&context), &Error::UnknownAgent { id }));
                }
                check(v).map_err(|e| raise_in(Some(&context), &e))?;
            }
            for (&id, &v) in ids.iter().zip(&values) {
                set(&mut self.world, id, v).or_raise()?;
            }
            Ok(())
        })
    }
}
