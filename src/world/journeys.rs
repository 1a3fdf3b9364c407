//! The world's stages and journeys ([`crate::journey`]): adding them, putting agents on them,
//! and the queue, waiting set and direct steering controls a study drives between steps.

use glam::Vec2;

use super::state::World;
use crate::agents::AgentId;
use crate::error::{Error, Result};
use crate::journey::{Journey, JourneyId, QueueState, Stage, StageCounts, StageId};

impl World {
    /// Adds a stage and returns its id. Where the world has a walkable area, the stage must lie
    /// in it and its routing channel is built at once.
    ///
    /// # Errors
    /// As [`Stage::validate`]; [`Error::Invalid`] when no cell of the walkable area's routing
    /// raster lies in the stage.
    ///
    /// # Examples
    /// ```
    /// # fn main() -> throng::Result<()> {
    /// use throng::prelude::*;
    /// use throng::journey::{Journey, Stage};
    /// let mut world = World::builder().build()?;
    /// world.set_walkable(Walkable::from_wkt("POLYGON ((0 0, 20 0, 20 10, 0 10, 0 0))")?)?;
    /// let door = world.add_stage(Stage::Waypoint { position: Vec2::new(10.0, 5.0), distance: 1.0 })?;
    /// let out = world.add_stage(Stage::Exit {
    ///     area: Walkable::rectangle(Vec2::new(18.0, 4.0), Vec2::new(20.0, 6.0))?,
    /// })?;
    /// let journey = world.add_journey(Journey::chain([door, out]))?;
    /// # let _ = journey;
    /// # Ok(()) }
    /// ```
    pub fn add_stage(&mut self, stage: Stage) -> Result<StageId> {
        self.journeys.add_stage(stage, self.walkable.as_ref())
    }

    /// Adds a journey and returns its id.
    ///
    /// # Errors
    /// As [`Journey::validate`]: an unknown stage, a transition that leaves the journey, a
    /// stage with no transition that does not end it, a cycle with no way out.
    pub fn add_journey(&mut self, journey: Journey) -> Result<JourneyId> {
        self.journeys.add_journey(journey)
    }

    /// Stage `s`.
    ///
    /// # Errors
    /// [`Error::UnknownStage`].
    pub fn stage(&self, s: StageId) -> Result<&Stage> {
        self.journeys.stage(s)
    }

    /// How many stages the world has.
    #[must_use]
    pub fn stage_count(&self) -> usize {
        self.journeys.stage_count()
    }

    /// Journey `j`.
    ///
    /// # Errors
    /// [`Error::UnknownJourney`].
    pub fn journey(&self, j: JourneyId) -> Result<&Journey> {
        self.journeys.journey(j)
    }

    /// Puts agent `id` on journey `journey` at `stage` (its first stage when `None`). Its
    /// profile should steer towards its own target (`arrive` or `seek` with
    /// [`Target::Own`](crate::steering::Target::Own)), which the journey system sets every step.
    ///
    /// # Errors
    /// [`Error::UnknownAgent`], [`Error::UnknownJourney`], [`Error::UnknownStage`], or
    /// [`Error::Invalid`] when the stage is not one of the journey's.
    pub fn set_journey(
        &mut self,
        id: AgentId,
        journey: JourneyId,
        stage: Option<StageId>,
    ) -> Result<()> {
        if !self.agents.contains(id) {
            return Err(Error::UnknownAgent { id });
        }
        let issued = self.agents.ids_issued();
        self.journeys.assign(id, issued, journey, stage)
    }

    /// Agent `id`'s journey and current stage (`None` for an agent on none, or not live).
    #[must_use]
    pub fn journey_of(&self, id: AgentId) -> Option<(JourneyId, StageId)> {
        if self.agents.contains(id) {
            self.journeys.of(id)
        } else {
            None
        }
    }

    /// Releases the first `n` agents of queue `stage`: at the next step they move on to their
    /// next stage, and everyone behind them moves up `n` slots.
    ///
    /// # Errors
    /// [`Error::UnknownStage`]; [`Error::Invalid`] when the stage is not a queue or holds
    /// fewer than `n` agents in its slots.
    pub fn pop_queue(&mut self, stage: StageId, n: usize) -> Result<()> {
        self.journeys.pop(stage, n)
    }

    /// Activates or deactivates waiting set `stage`. Deactivated, it releases everyone in it;
    /// activated again, it starts with empty slots.
    ///
    /// # Errors
    /// [`Error::UnknownStage`]; [`Error::Invalid`] when the stage is not a waiting set.
    pub fn set_waiting_set_active(&mut self, stage: StageId, active: bool) -> Result<()> {
        self.journeys.set_active(stage, active)
    }

    /// Queue or waiting set `stage`: its agents in slot order, those released, whether active.
    ///
    /// # Errors
    /// [`Error::UnknownStage`]; [`Error::Invalid`] for another kind of stage.
    pub fn queue(&self, stage: StageId) -> Result<QueueState> {
        self.journeys.queue(stage)
    }

    /// Sets the point agent `id` walks to while its stage is a direct steering stage.
    ///
    /// # Errors
    /// [`Error::UnknownAgent`], or an error for a point that is not finite or beyond the
    /// coordinate ceiling.
    pub fn set_direct_target(&mut self, id: AgentId, target: Vec2) -> Result<()> {
        crate::error::coordinate("direct target", target)?;
        if !self.agents.contains(id) {
            return Err(Error::UnknownAgent { id });
        }
        let issued = self.agents.ids_issued();
        self.journeys.set_direct(id, issued, target);
        Ok(())
    }

    /// Per stage (by id), how many live agents target it and how many left through it.
    #[must_use]
    pub fn stage_counts(&self) -> Vec<StageCounts> {
        self.journeys.counts(&self.agents)
    }

    /// The cells of the routing raster (0 without a walkable area or stages).
    #[must_use]
    pub fn route_cells(&self) -> usize {
        self.journeys.route_cells()
    }
}
