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
    /// As [`Journey::validate`]: an unknown stage ([`Error::UnknownJourneyStage`], naming the
    /// journey and the stage), a transition that leaves the journey, a
    /// stage with no transition that does not end it, a cycle with no way out; and, where the
    /// world has a walkable area, [`Error::Invalid`] for a transition to a stage that no path of
    /// free cells of its routing raster joins to the stage it leaves.
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
    /// [`Error::Invalid`] when the stage is not one of the journey's, or when no path of free
    /// cells of the walkable area's routing raster leads from the agent to the stage (the area
    /// has parts that do not touch).
    pub fn set_journey(
        &mut self,
        id: AgentId,
        journey: JourneyId,
        stage: Option<StageId>,
    ) -> Result<()> {
        let Some(i) = self.agents.index_of(id) else {
            return Err(Error::UnknownAgent { id });
        };
        let issued = self.agents.ids_issued();
        let at = self.agents.position(i);
        self.journeys.assign(id, issued, at, journey, stage)
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

    /// The agents on a journey whose current stage they cannot reach from where they stand,
    /// ascending by id: their stage lies in a part of the walkable area that no path of free
    /// routing cells joins to theirs, or the area cuts the stage off altogether. This happens
    /// only after [`World::switch_walkable`] closed a door (or in a checkpoint saved after one):
    /// adding an agent or giving it a journey refuses an unreachable stage. Such agents follow
    /// the switch's rule: no route, straight at their stage's point, held by the walls; give
    /// them a stage they can reach ([`World::set_journey`]) or remove them. Empty without a
    /// walkable area.
    #[must_use]
    pub fn stranded_agents(&self) -> Vec<AgentId> {
        self.journeys.stranded(&self.agents)
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

    /// Whether one of the world's stages is an exit (agents on journeys may leave the world).
    #[must_use]
    pub fn has_exit_stage(&self) -> bool {
        (0..self.stage_count() as u32)
            .any(|k| matches!(self.stage(StageId(k)), Ok(Stage::Exit { .. })))
    }

    /// Per stage (by id), how many live agents target it and how many left through it.
    #[must_use]
    pub fn stage_counts(&self) -> Vec<StageCounts> {
        self.journeys.counts(&self.agents)
    }

    /// Drives agent `id` from outside: puts it at `position` with `velocity` now and after
    /// every step until it is removed. The step does not move it; everyone else sees it as a
    /// neighbour (with that velocity) and avoids it. Call it between steps with the agent's
    /// new state.
    ///
    /// # Errors
    /// [`Error::UnknownAgent`]; [`Error::NonFinite`] or [`Error::OutOfRange`] for a bad
    /// number or a speed above [`MAX_SPEED`](crate::error::MAX_SPEED); [`Error::Invalid`] for
    /// a position outside the walkable area or inside an obstacle. Nothing changes then.
    pub fn set_external(&mut self, id: AgentId, position: Vec2, velocity: Vec2) -> Result<()> {
        self.check_external(id, position, velocity)?;
        let i = self.agents.index_of(id).ok_or(Error::UnknownAgent { id })?;
        self.agents.pos_x[i] = position.x;
        self.agents.pos_y[i] = position.y;
        self.agents.vel_x[i] = velocity.x;
        self.agents.vel_y[i] = velocity.y;
        self.journeys.set_external(id, position, velocity);
        Ok(())
    }

    /// Checks what [`World::set_external`] would check, changing nothing.
    ///
    /// # Errors
    /// As [`World::set_external`].
    pub fn check_external(&self, id: AgentId, position: Vec2, velocity: Vec2) -> Result<()> {
        crate::error::coordinate("external position", position)?;
        let v = crate::error::finite_vec("external velocity", velocity)?;
        crate::error::in_range(
            "external velocity",
            v.length(),
            0.0,
            crate::error::MAX_SPEED,
            "a speed of at most 1e12",
        )?;
        if let Some(area) = &self.walkable
            && !area.contains(position)
        {
            return Err(Error::Invalid {
                name: "external position".into(),
                reason: format!(
                    "agent {id} at ({}, {}) lies outside the walkable area",
                    position.x, position.y
                ),
            });
        }
        if !self.agents.contains(id) {
            return Err(Error::UnknownAgent { id });
        }
        self.bounds.check_point("external position", position)?;
        if self.obstacles.inside_circle(position) {
            return Err(Error::Invalid {
                name: "external position".into(),
                reason: format!(
                    "agent {id} at ({}, {}) lies inside an obstacle",
                    position.x, position.y
                ),
            });
        }
        Ok(())
    }

    /// Whether agent `id` is driven from outside ([`World::set_external`]).
    #[must_use]
    pub fn is_external(&self, id: AgentId) -> bool {
        self.agents.contains(id) && self.journeys.is_external(id)
    }

    /// Replaces the walkable area (a door closed or opened, a train that arrived): the old
    /// area's walls leave the obstacles, the new area's come in, and the stages' routes are
    /// rebuilt on it at once.
    ///
    /// The rule for agents is that none may be left outside the area: when an agent's centre
    /// lies outside the new area (in a doorway being closed, say), the switch is refused with
    /// an error naming the lowest such id, and nothing changes; the caller moves or removes it
    /// and switches again. An agent inside the area whose stage the new area cuts off, or
    /// that stands in a part no longer joined to its stage, has no route: it heads straight
    /// for its stage and the walls hold it; [`World::stranded_agents`] lists them.
    ///
    /// # Errors
    /// [`Error::Invalid`] when the world has no walkable area yet (use
    /// [`World::set_walkable`]), when an agent stands outside the new one, or when a stage
    /// lies outside it or reaches none of its cells; nothing changes then.
    pub fn switch_walkable(&mut self, area: crate::geometry::Walkable) -> Result<()> {
        let Some(old) = &self.walkable else {
            return Err(Error::Invalid {
                name: "walkable area".into(),
                reason: "the world has none to switch from: set one with set_walkable".into(),
            });
        };
        let outside = self
            .agents
            .ids()
            .iter()
            .zip(0..)
            .filter(|&(_, i)| !area.contains(self.agents.position(i)))
            .map(|(&id, _)| id)
            .min();
        if let Some(id) = outside {
            let p = self.agents.position(self.agents.index_of(id).unwrap_or(0));
            return Err(Error::Invalid {
                name: "walkable area".into(),
                reason: format!(
                    "agent {id} stands outside the new area at ({}, {}): move or remove it first",
                    p.x, p.y
                ),
            });
        }
        let routes = self.journeys.routes_on(&area)?;
        // The walls of every other obstacle stay; the old area's go, once each.
        let mut old_walls = old.walls();
        let mut walls = Vec::with_capacity(self.obstacles.walls().len());
        for w in self.obstacles.walls() {
            match old_walls.iter().position(|o| o == w) {
                Some(k) => {
                    old_walls.swap_remove(k);
                }
                None => walls.push(*w),
            }
        }
        walls.extend(area.walls());
        self.obstacles =
            crate::obstacles::Obstacles::from_lists(self.obstacles.circles().to_vec(), walls)?;
        self.walkable = Some(area);
        self.journeys.set_routes(routes);
        Ok(())
    }

    /// The cells of the routing raster (0 without a walkable area or stages).
    #[must_use]
    pub fn route_cells(&self) -> usize {
        self.journeys.route_cells()
    }
}
