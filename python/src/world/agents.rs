//! Adding, removing and editing agents of a `throng.World` from Python arrays: positions,
//! velocities, own goals and maximum speeds, by id.
//!
//! Invariant: every call is all or nothing: ids and values are checked before anything
//! changes, and an error that only the world's own checks find restores the values already
//! set (agents added by the call are removed again).

use glam::Vec2;
use numpy::IntoPyArray;
use numpy::ndarray::Array1;
use pyo3::prelude::*;
use throng::{AgentId, AgentInit, Error, World};

use super::PyWorld;
use crate::arrays;
use crate::error::{OrRaise, guarded, invalid, raise, raise_in};

/// An agent id from a Python int (ids are 0 to 2^32 - 1).
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

#[pymethods]
impl PyWorld {
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
            let orient = arrays::optional_floats("orientations", orientations, m)?;
            let speeds = arrays::optional_floats("max_speed", max_speed, m)?;
            let radii = arrays::optional_floats("radius", radius, m)?;
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
        self.set_rows(
            "positions",
            (ids, positions),
            |w, id| w.agent(id).map(|a| a.position),
            World::set_position,
        )
    }

    /// Sets agents' velocities (clamped to their maximum speed); one (vx, vy) row per id. On an
    /// error nothing changes.
    fn set_velocities(
        &mut self,
        ids: &Bound<'_, PyAny>,
        velocities: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        self.set_rows(
            "velocities",
            (ids, velocities),
            |w, id| w.agent(id).map(|a| a.velocity),
            World::set_velocity,
        )
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
}

impl PyWorld {
    /// Sets one (x, y) row of `values` per id of `ids` through `set`, all or nothing (as
    /// [`set_each`] restores); `name` names the argument in errors.
    fn set_rows(
        &mut self,
        name: &str,
        (ids, values): (&Bound<'_, PyAny>, &Bound<'_, PyAny>),
        get: fn(&World, AgentId) -> Option<Vec2>,
        set: fn(&mut World, AgentId, Vec2) -> throng::Result<()>,
    ) -> PyResult<()> {
        guarded(|| {
            let (ids, v) = self.rows_of(ids, values, name)?;
            set_each(
                name,
                &mut self.world,
                &ids,
                &v,
                |w, id| get(w, id).map(Into::into),
                |w, id, p: [f32; 2]| set(w, id, p.into()),
            )
        })
    }

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
