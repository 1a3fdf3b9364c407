//! Stages and journeys: routes through a building, as a pedestrian study describes them.
//!
//! A **stage** is a place an agent goes to and what happens there ([`Stage`]): a waypoint it
//! passes within a distance, an exit it leaves the world through, a queue whose slots it waits
//! in until released in order ([`World::pop_queue`](crate::World::pop_queue)), a waiting set
//! that holds everyone while it is active, or a target steered from outside. A **journey**
//! ([`Journey`]) chains stages by **transitions** ([`Transition`]): fixed, weighted round robin
//! or least targeted. An agent on a journey knows its journey and its current stage; when it
//! completes the stage, its stage's transition names the next.
//!
//! Agents on a journey steer towards their own target point ([`Target::Own`]); the journey
//! system writes it at the start of every step. Where the world has a walkable area, every
//! stage has a routing channel: a geodesic distance field on the area's raster whose goal cells
//! are the stage's place, so that an agent's way goes round every hole of the area; the target
//! is then a point two metres down the field's flow, and the stage's own point once the agent
//! stands on one of its goal cells. Without a walkable area the target is the stage's point.
//!
//! The same system keeps the agents **driven from outside**
//! ([`World::set_external`](crate::World::set_external)): a robot, a vehicle, a player, whose
//! position and velocity are written between steps. The step moves them not at all (they are
//! put back where they were written at its end), and every other agent sees them as
//! neighbours and avoids them as its model avoids anyone.
//!
//! Invariants: every step's journey update (slot assignment, completion, transitions, exit
//! removal) visits agents in ascending id order and breaks every tie by id, so its outcome
//! depends on neither the agents' storage order nor the thread count; stages and journeys are
//! never removed, so a [`StageId`] or [`JourneyId`] stays valid for the world's life; a
//! journey is accepted only when every stage reachable in it either has a transition or ends
//! the journey (an exit or a direct steering stage), and an exit is reachable from each stage.
//!
//! [`Target::Own`]: crate::steering::Target::Own

mod routes;
mod system;

use glam::Vec2;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::geometry::Walkable;

pub(crate) use routes::CELL_SIZE as ROUTE_CELL_SIZE;
pub(crate) use system::Journeys;
pub use system::{QueueState, StageCounts};

/// The most slots a queue or waiting set may have.
pub const MAX_SLOTS: usize = 1_000_000;

/// A handle to one of a world's stages (its index in the order stages were added).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(transparent)]
pub struct StageId(pub u32);

/// A handle to one of a world's journeys (its index in the order journeys were added).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(transparent)]
pub struct JourneyId(pub u32);

/// A stage: a place and what happens to the agents that reach it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Stage {
    /// A point passed within `distance`: the stage is complete when the agent's centre comes
    /// within `distance` of `position`.
    Waypoint {
        /// The point.
        position: Vec2,
        /// How close counts as reached, m (> 0).
        distance: f32,
    },
    /// An area agents leave the world through: an agent whose current stage it is leaves when
    /// its centre ends a step inside the area (agents on other stages walk through it).
    Exit {
        /// The area.
        area: Walkable,
    },
    /// Ordered slots. An agent that reaches the back of the queue (within 2 m of the first free
    /// slot, in sight of it) takes that slot; [`World::pop_queue`](crate::World::pop_queue)
    /// releases the first `n` in the queue to their next stage and everyone behind moves up a
    /// slot. Agents beyond the last slot wait at it.
    Queue {
        /// The slots, the front first.
        slots: Vec<Vec2>,
    },
    /// Slots that hold everyone while the set is active: an arriving agent (within 2 m of the
    /// first free slot, in sight of it) takes it and waits. Deactivated
    /// ([`World::set_waiting_set_active`](crate::World::set_waiting_set_active)), it releases
    /// everyone in it, and agents still coming complete it within 1 m of its first slot.
    WaitingSet {
        /// The slots, filled in this order.
        slots: Vec<Vec2>,
        /// Whether the set holds its agents from the start. Default: true.
        #[serde(default = "yes")]
        active: bool,
    },
    /// A target point per agent, set from outside
    /// ([`World::set_direct_target`](crate::World::set_direct_target)); never completes.
    DirectSteering,
}

fn yes() -> bool {
    true
}

impl Stage {
    /// The stage's kind, in words (`"waypoint"`, `"exit"`, `"queue"`, `"waiting set"`,
    /// `"direct steering"`).
    #[must_use]
    pub fn kind(&self) -> &'static str {
        match self {
            Stage::Waypoint { .. } => "waypoint",
            Stage::Exit { .. } => "exit",
            Stage::Queue { .. } => "queue",
            Stage::WaitingSet { .. } => "waiting set",
            Stage::DirectSteering => "direct steering",
        }
    }

    /// Whether an agent may end its journey here (an exit, or a stage steered from outside).
    #[must_use]
    pub fn ends_journey(&self) -> bool {
        matches!(self, Stage::Exit { .. } | Stage::DirectSteering)
    }

    /// Checks the numbers and, when the world has one, that the stage lies in the walkable
    /// area.
    ///
    /// # Errors
    /// [`Error::NonFinite`], [`Error::OutOfRange`] or [`Error::NotPositive`] for a bad number;
    /// [`Error::Invalid`] naming `name` for a queue or waiting set without slots or with more
    /// than [`MAX_SLOTS`], or a point outside `area`.
    pub fn validate(&self, name: &str, area: Option<&Walkable>) -> Result<()> {
        let inside = |what: &str, p: Vec2| -> Result<()> {
            crate::error::coordinate("stage position", p)?;
            match area {
                Some(a) if !a.contains(p) => Err(Error::Invalid {
                    name: name.into(),
                    reason: format!("{what} ({}, {}) lies outside the walkable area", p.x, p.y),
                }),
                _ => Ok(()),
            }
        };
        match self {
            Stage::Waypoint { position, distance } => {
                crate::error::positive("waypoint distance", *distance)?;
                crate::error::in_range(
                    "waypoint distance",
                    *distance,
                    0.0,
                    crate::error::MAX_COORDINATE,
                    "(0, 1e18]",
                )?;
                inside("the waypoint", *position)
            }
            Stage::Exit { area: exit } => {
                if let Some(a) = area
                    && !a.polygons().is_empty()
                    && (exit.max().cmplt(a.min()).any() || exit.min().cmpgt(a.max()).any())
                {
                    return Err(Error::Invalid {
                        name: name.into(),
                        reason: "the exit lies outside the walkable area's bounding box".into(),
                    });
                }
                Ok(())
            }
            Stage::Queue { slots } | Stage::WaitingSet { slots, .. } => {
                if slots.is_empty() || slots.len() > MAX_SLOTS {
                    return Err(Error::Invalid {
                        name: name.into(),
                        reason: format!(
                            "a {} needs 1 to {MAX_SLOTS} slots, got {}",
                            self.kind(),
                            slots.len()
                        ),
                    });
                }
                for (k, &p) in slots.iter().enumerate() {
                    inside(&format!("slot {k}"), p)?;
                }
                Ok(())
            }
            Stage::DirectSteering => Ok(()),
        }
    }
}

/// How an agent that completed a stage chooses its next.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Transition {
    /// Always the same next stage.
    Fixed {
        /// The next stage.
        next: StageId,
    },
    /// Weighted round robin: of every `sum of weights` agents that complete the stage, the
    /// first `w0` go to the first stage, the next `w1` to the second, and so on, in the order
    /// they complete it (ascending id within one step).
    RoundRobin {
        /// The candidates and their weights (each at least 1).
        weighted: Vec<(StageId, u32)>,
    },
    /// The candidate that the fewest agents target at that moment (the first listed on a tie).
    LeastTargeted {
        /// The candidates.
        candidates: Vec<StageId>,
    },
}

impl Transition {
    /// Always `next`.
    #[must_use]
    pub fn fixed(next: StageId) -> Self {
        Transition::Fixed { next }
    }

    /// Weighted round robin over `weighted`.
    #[must_use]
    pub fn round_robin(weighted: impl IntoIterator<Item = (StageId, u32)>) -> Self {
        Transition::RoundRobin {
            weighted: weighted.into_iter().collect(),
        }
    }

    /// The least targeted of `candidates`.
    #[must_use]
    pub fn least_targeted(candidates: impl IntoIterator<Item = StageId>) -> Self {
        Transition::LeastTargeted {
            candidates: candidates.into_iter().collect(),
        }
    }

    /// The stages the transition may lead to.
    #[must_use]
    pub fn targets(&self) -> Vec<StageId> {
        match self {
            Transition::Fixed { next } => vec![*next],
            Transition::RoundRobin { weighted } => weighted.iter().map(|w| w.0).collect(),
            Transition::LeastTargeted { candidates } => candidates.clone(),
        }
    }
}

/// A journey: its stages and, for each stage that has one, the transition to the next.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Journey {
    /// The stages, in the order given (the first is where agents start unless told otherwise).
    pub stages: Vec<StageId>,
    /// The transitions: `(from, how)`, at most one per stage.
    #[serde(default)]
    pub transitions: Vec<(StageId, Transition)>,
}

impl Journey {
    /// A journey through `stages`, with no transitions yet.
    #[must_use]
    pub fn new(stages: impl IntoIterator<Item = StageId>) -> Self {
        Journey {
            stages: stages.into_iter().collect(),
            transitions: Vec::new(),
        }
    }

    /// A journey through `stages` in this order: a fixed transition from each to the next.
    #[must_use]
    pub fn chain(stages: impl IntoIterator<Item = StageId>) -> Self {
        let stages: Vec<StageId> = stages.into_iter().collect();
        let transitions = stages
            .windows(2)
            .map(|w| (w[0], Transition::fixed(w[1])))
            .collect();
        Journey {
            stages,
            transitions,
        }
    }

    /// The same journey with `transition` out of `from` (replacing any it had).
    #[must_use]
    pub fn with_transition(mut self, from: StageId, transition: Transition) -> Self {
        self.transitions.retain(|(s, _)| *s != from);
        self.transitions.push((from, transition));
        self
    }

    /// The transition out of `stage`, if it has one.
    #[must_use]
    pub fn transition(&self, stage: StageId) -> Option<&Transition> {
        self.transitions
            .iter()
            .find(|(s, _)| *s == stage)
            .map(|(_, t)| t)
    }

    /// Checks the journey against the world's stages (`stages`): every stage it names exists
    /// and belongs to it; transitions have candidates, weights of at least 1 and come from a
    /// stage of the journey once; each stage has a transition or ends the journey; from every
    /// stage, an exit or a direct steering stage is reachable.
    ///
    /// # Errors
    /// [`Error::UnknownJourneyStage`] or [`Error::Invalid`] naming the journey and the stage.
    pub fn validate(&self, name: &str, stages: &[Stage]) -> Result<()> {
        self.validate_named(name, stages, &|s| format!("stage {}", s.0))
    }

    /// [`Journey::validate`], with each stage named in the errors by `stage_name` (a scenario
    /// file names its stages by strings).
    ///
    /// # Errors
    /// As [`Journey::validate`].
    pub fn validate_named(
        &self,
        name: &str,
        stages: &[Stage],
        stage_name: &dyn Fn(StageId) -> String,
    ) -> Result<()> {
        let invalid = |reason: String| Error::Invalid {
            name: name.into(),
            reason,
        };
        if self.stages.is_empty() {
            return Err(invalid("a journey needs at least one stage".into()));
        }
        let known = |s: StageId| -> Result<()> {
            if (s.0 as usize) < stages.len() {
                Ok(())
            } else {
                Err(Error::UnknownJourneyStage {
                    journey: name.into(),
                    stage: s.0,
                    stages: stages.len(),
                })
            }
        };
        for &s in &self.stages {
            known(s)?;
        }
        let member = |s: StageId| self.stages.contains(&s);
        for (k, (from, t)) in self.transitions.iter().enumerate() {
            known(*from)?;
            if !member(*from) {
                return Err(invalid(format!(
                    "the transition out of {} leaves a stage that is not in the journey",
                    stage_name(*from)
                )));
            }
            if self.transitions[..k].iter().any(|(f, _)| f == from) {
                return Err(invalid(format!(
                    "{} has two transitions",
                    stage_name(*from)
                )));
            }
            let targets = t.targets();
            if targets.is_empty() {
                return Err(invalid(format!(
                    "the transition out of {} has no candidates",
                    stage_name(*from)
                )));
            }
            if let Transition::RoundRobin { weighted } = t
                && let Some((s, _)) = weighted.iter().find(|w| w.1 == 0)
            {
                return Err(invalid(format!(
                    "the round robin out of {} gives {} a weight of 0 (each is at least 1)",
                    stage_name(*from),
                    stage_name(*s)
                )));
            }
            for s in targets {
                known(s)?;
                if !member(s) {
                    return Err(invalid(format!(
                        "the transition out of {} leads to {}, which is not in the journey",
                        stage_name(*from),
                        stage_name(s)
                    )));
                }
            }
        }
        for &s in &self.stages {
            if self.transition(s).is_none() && !stages[s.0 as usize].ends_journey() {
                return Err(invalid(format!(
                    "{} (a {}) has no transition and does not end the journey: give it one, \
                     or end the journey with an exit or a direct steering stage",
                    stage_name(s),
                    stages[s.0 as usize].kind()
                )));
            }
        }
        // Backwards from the stages that end the journey: every stage must reach one.
        let mut reaches: Vec<StageId> = self
            .stages
            .iter()
            .copied()
            .filter(|s| stages[s.0 as usize].ends_journey())
            .collect();
        loop {
            let before = reaches.len();
            for (from, t) in &self.transitions {
                if !reaches.contains(from) && t.targets().iter().any(|s| reaches.contains(s)) {
                    reaches.push(*from);
                }
            }
            if reaches.len() == before {
                break;
            }
        }
        if let Some(s) = self.stages.iter().find(|s| !reaches.contains(s)) {
            return Err(invalid(format!(
                "from {} no exit or direct steering stage can be reached: its agents would \
                 walk the journey's cycle for ever",
                stage_name(*s)
            )));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stages() -> Vec<Stage> {
        vec![
            Stage::Waypoint {
                position: Vec2::ZERO,
                distance: 1.0,
            },
            Stage::Waypoint {
                position: Vec2::X,
                distance: 1.0,
            },
            Stage::Exit {
                area: Walkable::rectangle(Vec2::splat(5.0), Vec2::splat(6.0)).unwrap(),
            },
        ]
    }

    #[test]
    fn a_chain_to_an_exit_is_a_journey() {
        Journey::chain([StageId(0), StageId(1), StageId(2)])
            .validate("journey 0", &stages())
            .unwrap();
    }

    #[test]
    fn a_cycle_without_an_exit_is_refused() {
        let j = Journey::new([StageId(0), StageId(1)])
            .with_transition(StageId(0), Transition::fixed(StageId(1)))
            .with_transition(StageId(1), Transition::fixed(StageId(0)));
        let e = j.validate("journey 0", &stages()).unwrap_err().to_string();
        assert!(e.contains("for ever"), "{e}");
    }

    #[test]
    fn a_dead_end_waypoint_and_unknown_stages_are_refused() {
        let e = Journey::new([StageId(0)])
            .validate("journey 0", &stages())
            .unwrap_err()
            .to_string();
        assert!(e.contains("no transition"), "{e}");
        let e = Journey::chain([StageId(0), StageId(7)]).validate("journey 0", &stages());
        assert!(
            matches!(&e, Err(Error::UnknownJourneyStage { journey, stage: 7, stages: 3 }) if journey == "journey 0"),
            "{e:?}"
        );
        let e = Journey::new([StageId(0), StageId(2)])
            .with_transition(
                StageId(0),
                Transition::least_targeted([StageId(2), StageId(5)]),
            )
            .validate("journey 4", &stages())
            .unwrap_err()
            .to_string();
        assert_eq!(e, "journey 4 names no stage 5 (the world has 3)");
        let e = Journey::new([StageId(0), StageId(2)])
            .with_transition(StageId(0), Transition::round_robin([(StageId(2), 0)]))
            .validate("journey 0", &stages())
            .unwrap_err()
            .to_string();
        assert!(e.contains("weight of 0"), "{e}");
    }
}
