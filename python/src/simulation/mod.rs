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
//!
//! The class's methods sit in child modules, one `#[pymethods]` block each: [`stages`] (the
//! stage and journey types and the methods that add them) and [`agents`] (adding agents, their
//! arrays and per-agent setters, agents driven from outside); this file holds the simulation
//! itself (construction, stepping, counts, checkpoints, geometry, recording).

mod agents;
mod stages;

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use throng::journey::{Stage, StageId};
use throng::ped::{Model, ModelParams, Pedestrian, PedestrianTable};
use throng::profile::Profile;
use throng::{AgentId, Bounds, Error, Walkable, World};

use crate::arrays::{self, Order};
use crate::convert;
use crate::error::{OrRaise, guarded, invalid, raise, raise_in, unsigned};
use crate::record::Recorders;

pub use stages::{PyJourney, PyQueue, PyTransition, PyWaitingSet};

pub(crate) fn area(name: &str, obj: &Bound<'_, PyAny>) -> PyResult<Walkable> {
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

/// Agent ids read as Python ints, each checked to be one.
pub(crate) fn agent_ids(ids: &[i64]) -> PyResult<Vec<AgentId>> {
    ids.iter()
        .map(|&i| {
            u32::try_from(i)
                .map(AgentId)
                .map_err(|_| invalid("ids", format!("{i} is not an agent id")))
        })
        .collect()
}

/// How a simulation's checkpoint names itself in its run settings (then its default model).
const SAVED_AS: &str = "throng.Simulation:";

/// At rest.
pub(crate) fn glam_zero() -> throng::prelude::Vec2 {
    throng::prelude::Vec2::ZERO
}

/// A stage given as its id or as a stage handle (anything with an `id` attribute).
pub(crate) fn stage_id(obj: &Bound<'_, PyAny>) -> PyResult<StageId> {
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
pub(crate) fn model(name: &str) -> PyResult<Model> {
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

/// A pedestrian simulation on a walkable area (WKT text or a shapely polygon), with stages,
/// journeys and agents added from Python; `iterate()` advances it by `dt` seconds per step.
#[pyclass(name = "Simulation", module = "throng")]
#[derive(Debug)]
pub struct PySimulation {
    world: World,
    dt: f32,
    model: Model,
    /// The pedestrian parameters every model's group starts from (`params=`), every model's
    /// table.
    pedestrian: PedestrianTable,
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
        let mut profile = Profile::journey_walkers(model);
        profile.pedestrian = Some(Pedestrian::from(PedestrianTable {
            model,
            ..self.pedestrian
        }));
        let g = self.world.add_group(profile).or_raise()?;
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
    /// `threads` workers (default: all cores). `params` sets the models' parameters: the keys
    /// of a scenario file's `[pedestrian]` table other than `model` (`{"cfsm": {"time_gap":
    /// 1.0}}`, `"social_force"`, `"desired_speed"`, `"premovement"`), missing keys at their
    /// defaults.
    #[new]
    #[pyo3(signature = (geometry, *, model="cfsm", dt=0.01, seed=1, threads=None, params=None))]
    fn new(
        geometry: &Bound<'_, PyAny>,
        model: &str,
        dt: f32,
        seed: i128,
        threads: Option<i128>,
        params: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        guarded(|| {
            let m = self::model(model)?;
            let pedestrian = match params {
                Some(p) => {
                    if p.cast::<PyDict>()
                        .is_ok_and(|d| d.contains("model").unwrap_or(false))
                    {
                        return Err(invalid(
                            "params",
                            "the model is chosen by model= (and by add_agents' model=)",
                        ));
                    }
                    let ped: PedestrianTable = convert::deserialize_from_py("params", p)?;
                    ped.validate().or_raise()?;
                    ped
                }
                None => PedestrianTable::default(),
            };
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
                pedestrian,
                groups: Vec::new(),
                external: None,
                pool: crate::world::pool(threads)?,
                recorders: Recorders::default(),
            })
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
    /// Saves the whole simulation (agents, stages with their queues, journeys, the current
    /// walkable area, external agents, the time step) to a checkpoint file at `path`, written
    /// crash-safe; `Simulation.load(path)` resumes it bit for bit.
    fn save(&self, path: std::path::PathBuf) -> PyResult<()> {
        // The model's name, then every model's table of `params=` (also of models no group
        // uses yet), which the world's groups alone would not keep.
        let table = toml::to_string(&self.pedestrian)
            .map_err(|e| invalid("params", format!("cannot be written: {e}")))?;
        let run = throng::checkpoint::RunInfo {
            scenario: format!("{SAVED_AS}{}\n{table}", self.model.name()),
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
            let (name, table) = run.scenario[SAVED_AS.len()..]
                .split_once('\n')
                .unwrap_or((&run.scenario[SAVED_AS.len()..], ""));
            let model = Model::parse(name).unwrap_or_default();
            let mut groups = Vec::new();
            let mut external = None;
            for (g, p) in world.groups().iter().enumerate() {
                match p.pedestrian {
                    Some(ped) if !groups.iter().any(|&(m, _)| m == ped.model()) => {
                        groups.push((ped.model(), g));
                    }
                    None if p.steering.behaviours.is_empty() && external.is_none() => {
                        external = Some(g);
                    }
                    _ => {}
                }
            }
            let pedestrian = if table.is_empty() {
                from_groups(&world)
            } else {
                let unreadable = |e: String| {
                    invalid("path", format!("the checkpoint's params= do not read: {e}"))
                };
                let mut raw: toml::Table =
                    toml::from_str(table).map_err(|e| unreadable(e.to_string()))?;
                // A table saved by an older build steps with the values it had then.
                if let Some(toml::Value::Table(cf)) = raw.get_mut("cfsm") {
                    throng::ped::Cfsm::fill_absent_keys(cf);
                }
                let t: PedestrianTable = raw.try_into().map_err(|e| unreadable(e.to_string()))?;
                t.validate().or_raise()?;
                t
            };
            Ok(PySimulation {
                world,
                dt: run.dt,
                model,
                pedestrian,
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

    /// The ids (a uint32 array, ascending) of the agents whose current stage they cannot reach
    /// from where they stand: after `switch_geometry` closed them off from it (they head
    /// straight for it, held by the walls, until given another journey).
    fn stranded_agents<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        let ids: Vec<u32> = self.world.stranded_agents().iter().map(|id| id.0).collect();
        numpy::IntoPyArray::into_pyarray(ids, py).into_any()
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
            let ids = agent_ids(&ids)?;
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

/// The table of `params=` of a checkpoint written without it: every model's table from the
/// group of that model, the speeds and pre-movement times, which all groups share, from the
/// first.
fn from_groups(world: &World) -> PedestrianTable {
    let mut pedestrian = PedestrianTable::default();
    for (k, ped) in world
        .groups()
        .iter()
        .filter_map(|p| p.pedestrian)
        .enumerate()
    {
        if k == 0 {
            pedestrian.desired_speed = ped.desired_speed;
            pedestrian.premovement = ped.premovement;
        }
        match ped.params {
            ModelParams::Cfsm(c) => pedestrian.cfsm = c,
            ModelParams::SocialForce(f) => pedestrian.social_force = f,
        }
    }
    pedestrian
}
