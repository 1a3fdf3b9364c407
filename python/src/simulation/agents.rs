//! The agents of `throng.Simulation`: adding them (pedestrians on journeys, or agents driven
//! from outside), their arrays by ascending id, per-agent parameters, journeys and targets.

use numpy::IntoPyArray;
use numpy::ndarray::Array1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use throng::ped::{Model, ModelParams};
use throng::{AgentId, AgentInit};

use super::{PySimulation, agent_ids, glam_zero, model, stage_id};
use crate::arrays;
use crate::error::{OrRaise, guarded, invalid, raise_in, unsigned};

#[pymethods]
impl PySimulation {
    /// Adds agents at `positions` (one `(x, y)`, which returns an int id, or an (m, 2)
    /// array-like, which returns a uint32 array) on `journey` at `stage` (its first stage by
    /// default), with `desired_speed` and `radius` per agent or for all (default: Weidmann's
    /// speeds and 0.2 m) and pedestrian `model` (default: the simulation's). Further keywords
    /// are numeric parameters of that model (`time_gap=`, `strength_neighbour=`, `tau=`, ...),
    /// one value or one per agent, which the agents then walk by instead of the simulation's
    /// `params=`. On an error no agent is added.
    #[expect(
        clippy::too_many_arguments,
        reason = "the Python signature: one keyword per per-agent parameter"
    )]
    #[pyo3(signature = (positions, *, journey=None, stage=None, desired_speed=None, radius=None, model=None, **params))]
    fn add_agents<'py>(
        &mut self,
        py: Python<'py>,
        positions: &Bound<'py, PyAny>,
        journey: Option<i128>,
        stage: Option<&Bound<'py, PyAny>>,
        desired_speed: Option<&Bound<'py, PyAny>>,
        radius: Option<&Bound<'py, PyAny>>,
        model: Option<&str>,
        params: Option<&Bound<'py, PyDict>>,
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
            let speeds = arrays::optional_floats("desired_speed", desired_speed, m)?;
            let radii = arrays::optional_floats("radius", radius, m)?;
            let group = if external {
                self.external_group()?
            } else {
                self.group(model.map(self::model).transpose()?.unwrap_or(self.model))?
            };
            // Each agent's own model parameters, all checked before any agent is added.
            let own = match params.filter(|p| !p.is_empty()) {
                None => None,
                Some(_) if external => {
                    return Err(invalid(
                        "params",
                        "external agents walk by no model: they take no model parameters",
                    ));
                }
                Some(p) => {
                    let base = self.world.groups()[group]
                        .pedestrian
                        .map(|ped| ped.params)
                        .unwrap_or_default();
                    let mut columns = Vec::new();
                    for (key, value) in p.iter() {
                        let key: String = key.extract()?;
                        let values =
                            arrays::broadcast(&key, arrays::read_floats(&key, &value)?, m)?;
                        columns.push((key, values));
                    }
                    let mut own = Vec::with_capacity(m);
                    for k in 0..m {
                        let mut agent = base;
                        for (key, values) in &columns {
                            agent = agent
                                .with_value(key, values[k])
                                .map_err(|e| raise_in(Some(&format!("row {k}")), &e))?;
                        }
                        own.push(agent);
                    }
                    Some(own)
                }
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
                let placed = placed.and_then(|()| match &own {
                    Some(own) => self.world.set_agent_model_params(id, Some(own[k])),
                    None => Ok(()),
                });
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
        self.by_id(py, throng::Agents::desired_speeds)
    }

    /// Radii, m, by ascending id.
    fn radii<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.by_id(py, throng::Agents::radii)
    }

    /// The model parameter `name` (`time_gap`, `tau`, ...) each agent walks by, its own or
    /// the simulation's, float32 by ascending id; NaN for agents whose model has no such
    /// parameter (external agents, another model's).
    fn agent_params<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        guarded(|| {
            let known = [Model::Cfsm, Model::SocialForce]
                .iter()
                .any(|&m| ModelParams::new(m).value(name).is_some());
            if !known {
                return Err(invalid(
                    "name",
                    format!("{name:?} is a numeric parameter of no pedestrian model"),
                ));
            }
            let rows = self.rows();
            let a = self.world.agents();
            let values: Vec<f32> = rows
                .iter()
                .map(|&i| {
                    self.world
                        .agent_model_params(a.id(i))
                        .ok()
                        .flatten()
                        .and_then(|p| p.value(name))
                        .unwrap_or(f32::NAN)
                })
                .collect();
            arrays::column(py, values.len(), None, "float32", |k| values[k], None)
        })
    }

    /// Sets the model parameter `name` of agents `ids` (one value or one per id), which they
    /// then walk by instead of the simulation's `params=`; on an error nothing changes.
    fn set_agent_params(
        &mut self,
        ids: &Bound<'_, PyAny>,
        name: &str,
        values: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        guarded(|| {
            let ids = arrays::read_ints("ids", ids)?;
            let values = arrays::broadcast(name, arrays::read_floats(name, values)?, ids.len())?;
            let ids = agent_ids(&ids)?;
            // Checked in full first, so that an error changes nothing.
            let mut own = Vec::with_capacity(ids.len());
            for (k, (&id, &v)) in ids.iter().zip(&values).enumerate() {
                let context = format!("{name}[{k}]");
                let p = self
                    .world
                    .agent_model_params(id)
                    .and_then(|p| {
                        p.ok_or_else(|| throng::Error::Invalid {
                            name: "ids".into(),
                            reason: format!("agent {id} walks by no pedestrian model"),
                        })
                    })
                    .and_then(|p| p.with_value(name, v))
                    .map_err(|e| raise_in(Some(&context), &e))?;
                own.push((id, p));
            }
            for (id, p) in own {
                self.world.set_agent_model_params(id, Some(p)).or_raise()?;
            }
            Ok(())
        })
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
            let ids = agent_ids(&ids)?;
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
}

impl PySimulation {
    /// A float32 column of the agents (`column` of the storage), by ascending id.
    fn by_id<'py>(
        &self,
        py: Python<'py>,
        column: impl Fn(&throng::Agents) -> &[f32],
    ) -> PyResult<Bound<'py, PyAny>> {
        let rows = self.rows();
        let values = column(self.world.agents());
        arrays::column(py, rows.len(), Some(&rows), "float32", |i| values[i], None)
    }
}
