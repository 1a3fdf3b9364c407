//! The stages and journeys of `throng.Simulation`: `Transition`, `Journey`, the handles of queue
//! and waiting set stages, and the simulation's methods that add stages and journeys.

use pyo3::prelude::*;
use throng::journey::{Journey, Stage, StageId, Transition};

use super::{PySimulation, area, stage_id};
use crate::arrays;
use crate::error::{OrRaise, guarded, unsigned};

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

#[pymethods]
impl PySimulation {
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
}
