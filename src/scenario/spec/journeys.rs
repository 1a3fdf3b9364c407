//! The checks and the build of a scenario's stages and journeys, and of the groups that walk
//! them: every name resolved, every point in the world and the walkable area, every journey
//! checked as [`Journey::validate_named`](crate::journey::Journey::validate_named) checks it,
//! with the stages named as the file names them.
//!
//! Invariants: a name error names its key with the path into the file
//! (`journeys[1].transitions[0].to`, `groups[2].stage`); stages and journeys are added to the
//! world in file order, so stage `stages[i]` is `StageId(i)` and journey `journeys[j]` is
//! `JourneyId(j)`; a scenario with stages or journeys does not scale by tiles.

use crate::error::{Error, Result};
use crate::journey::{JourneyId, Stage, StageId};
use crate::steering::Target;
use crate::world::World;

use super::stages::TransitionKind;
use super::validate::at_path;
use super::{GroupSpec, Scenario, WorldScale};

/// An error naming the key at `path`.
fn bad(path: impl Into<String>, reason: impl Into<String>) -> Error {
    Error::Invalid {
        name: path.into(),
        reason: reason.into(),
    }
}

/// `e`, an error of a key below `path` named relative to it (`min`), named from the top.
fn below(path: &str, e: Error) -> Error {
    match e {
        Error::Invalid { name, reason } => bad(format!("{path}.{name}"), reason),
        other => bad(path, other.to_string()),
    }
}

/// `names` as a list for an error message.
fn listed<'a>(names: impl Iterator<Item = &'a str>) -> String {
    let all: Vec<String> = names.map(|n| format!("{n:?}")).collect();
    if all.is_empty() {
        "none".into()
    } else {
        all.join(", ")
    }
}

impl Scenario {
    /// The index of the stage named `name`.
    pub(super) fn stage_index(&self, name: &str) -> Option<usize> {
        self.stages.iter().position(|s| s.name() == name)
    }

    /// The index of the journey named `name`.
    pub(super) fn journey_index(&self, name: &str) -> Option<usize> {
        self.journeys.iter().position(|j| j.name == name)
    }

    /// The journey and start stage (`None`: the journey's first) of group `g`'s agents, once
    /// the scenario validated.
    pub(super) fn journey_of(&self, g: &GroupSpec) -> Option<(JourneyId, Option<StageId>)> {
        let j = self.journey_index(g.journey.as_deref()?)?;
        let stage = g
            .stage
            .as_deref()
            .and_then(|s| self.stage_index(s))
            .map(|s| StageId(s as u32));
        Some((JourneyId(j as u32), stage))
    }

    /// Checks the stages, the journeys and the groups' `journey` and `stage` keys.
    ///
    /// # Errors
    /// [`Error::Invalid`] naming the first bad key with its path.
    pub(super) fn check_journeys(&self) -> Result<()> {
        if self.stages.is_empty() && self.journeys.is_empty() {
            return self.check_group_journeys();
        }
        if self.world.scale == WorldScale::Tiles {
            return Err(bad(
                "world.scale",
                "a scenario with stages or journeys cannot scale by tiles: the copies would \
                 share their stages, and every exit count would mix them (use scale = \"counts\")",
            ));
        }
        let built = self.check_stages()?;
        let stage_name = |s: StageId| format!("stage {:?}", self.stages[s.0 as usize].name());
        let stage_names = || listed(self.stages.iter().map(super::StageSpec::name));
        for (j, js) in self.journeys.iter().enumerate() {
            let path = format!("journeys[{j}]");
            if js.name.is_empty() {
                return Err(bad(format!("{path}.name"), "a journey needs a name"));
            }
            if let Some(k) = self.journeys[..j].iter().position(|o| o.name == js.name) {
                return Err(bad(
                    format!("{path}.name"),
                    format!("{:?} already names journeys[{k}]", js.name),
                ));
            }
            if js.stages.is_empty() {
                return Err(bad(
                    format!("{path}.stages"),
                    "a journey needs at least one stage",
                ));
            }
            for (k, name) in js.stages.iter().enumerate() {
                if self.stage_index(name).is_none() {
                    return Err(bad(
                        format!("{path}.stages[{k}]"),
                        format!("unknown stage {name:?} (stages: {})", stage_names()),
                    ));
                }
                if js.stages[..k].contains(name) {
                    return Err(bad(
                        format!("{path}.stages[{k}]"),
                        format!("stage {name:?} is listed twice"),
                    ));
                }
            }
            for (t, tr) in js.transitions.iter().flatten().enumerate() {
                let tp = format!("{path}.transitions[{t}]");
                let member = |key: String, name: &str| -> Result<()> {
                    if self.stage_index(name).is_none() {
                        return Err(bad(
                            key,
                            format!("unknown stage {name:?} (stages: {})", stage_names()),
                        ));
                    }
                    if !js.stages.iter().any(|s| s == name) {
                        return Err(bad(
                            key,
                            format!(
                                "stage {name:?} is not one of the journey's stages ({})",
                                listed(js.stages.iter().map(String::as_str))
                            ),
                        ));
                    }
                    Ok(())
                };
                member(format!("{tp}.from"), &tr.from)?;
                let earlier = js.transitions.iter().flatten().take(t);
                if let Some(k) = earlier.into_iter().position(|o| o.from == tr.from) {
                    return Err(bad(
                        format!("{tp}.from"),
                        format!(
                            "stage {:?} already has a transition ({path}.transitions[{k}])",
                            tr.from
                        ),
                    ));
                }
                match (tr.kind, tr.to.len()) {
                    (_, 0) => return Err(bad(format!("{tp}.to"), "names no stage")),
                    (TransitionKind::Fixed, n) if n > 1 => {
                        return Err(bad(
                            format!("{tp}.to"),
                            format!(
                                "a fixed transition names one stage, not {n} (for a choice, \
                                 kind = \"round_robin\" or \"least_targeted\")"
                            ),
                        ));
                    }
                    _ => {}
                }
                for (k, name) in tr.to.iter().enumerate() {
                    let key = if tr.to.len() == 1 {
                        format!("{tp}.to")
                    } else {
                        format!("{tp}.to[{k}]")
                    };
                    member(key, name)?;
                }
                if !tr.weights.is_empty() {
                    if tr.kind != TransitionKind::RoundRobin {
                        return Err(bad(
                            format!("{tp}.weights"),
                            "only a round robin (kind = \"round_robin\") has weights",
                        ));
                    }
                    if tr.weights.len() != tr.to.len() {
                        return Err(bad(
                            format!("{tp}.weights"),
                            format!(
                                "{} weights for {} stages in `to`: one each",
                                tr.weights.len(),
                                tr.to.len()
                            ),
                        ));
                    }
                    if let Some(k) = tr.weights.iter().position(|&w| w == 0) {
                        return Err(bad(
                            format!("{tp}.weights[{k}]"),
                            "a weight of 0 (each is at least 1)",
                        ));
                    }
                }
            }
            let journey = js
                .to_journey(|n| self.stage_index(n).map(|i| StageId(i as u32)))
                .map_err(|e| below(&path, e))?;
            journey.validate_named(&path, &built, &stage_name)?;
        }
        self.check_group_journeys()
    }

    /// Checks each stage: a unique name, its numbers, its points inside the world and the
    /// walkable area; returns the world's stages.
    fn check_stages(&self) -> Result<Vec<Stage>> {
        let area = self.geometry.as_ref().map(|g| &g.walkable);
        let bounds = self.bounds()?;
        let mut built = Vec::with_capacity(self.stages.len());
        for (i, s) in self.stages.iter().enumerate() {
            let path = format!("stages[{i}]");
            if s.name().is_empty() {
                return Err(bad(format!("{path}.name"), "a stage needs a name"));
            }
            if let Some(k) = self.stage_index(s.name()).filter(|&k| k < i) {
                return Err(bad(
                    format!("{path}.name"),
                    format!("{:?} already names stages[{k}]", s.name()),
                ));
            }
            if let super::StageSpec::Waypoint { distance, .. } = s {
                crate::error::positive("distance", *distance)
                    .and_then(|d| {
                        crate::error::in_range(
                            "distance",
                            d,
                            0.0,
                            crate::error::MAX_COORDINATE,
                            "(0, 1e18]",
                        )
                    })
                    .map_err(|e| bad(format!("{path}.distance"), e.to_string()))?;
            }
            for (key, p) in s.points() {
                let key = format!("{path}.{key}");
                crate::error::coordinate("position", p).map_err(|e| bad(&key, e.to_string()))?;
                if !bounds.contains(p) {
                    return Err(bad(
                        key,
                        format!("({}, {}) lies outside the world {bounds:?}", p.x, p.y),
                    ));
                }
                if let Some(a) = area
                    && !a.contains(p)
                {
                    return Err(bad(
                        key,
                        format!("({}, {}) lies outside the walkable area", p.x, p.y),
                    ));
                }
            }
            let stage = s.to_stage().map_err(|e| below(&path, e))?;
            stage.validate(&path, area).map_err(|e| match e {
                Error::Invalid { ref name, .. } if name.starts_with(&path) => e,
                other => at_path(path.clone(), other),
            })?;
            built.push(stage);
        }
        Ok(built)
    }

    /// Checks each group's `journey` and `stage`: known names, a stage of the journey, no
    /// `goal` beside them, and a behaviour that steers towards the agent's own target.
    fn check_group_journeys(&self) -> Result<()> {
        for (i, g) in self.groups.iter().enumerate() {
            let path = format!("groups[{i}]");
            let Some(name) = &g.journey else {
                if g.stage.is_some() {
                    return Err(bad(
                        format!("{path}.stage"),
                        "a start stage needs a `journey`",
                    ));
                }
                continue;
            };
            let Some(j) = self.journey_index(name) else {
                return Err(bad(
                    format!("{path}.journey"),
                    format!(
                        "unknown journey {name:?} (journeys: {})",
                        listed(self.journeys.iter().map(|j| j.name.as_str()))
                    ),
                ));
            };
            if let Some(stage) = &g.stage
                && !self.journeys[j].stages.contains(stage)
            {
                return Err(bad(
                    format!("{path}.stage"),
                    format!("stage {stage:?} is not one of journey {name:?}'s stages"),
                ));
            }
            if g.goal.is_some() {
                return Err(bad(
                    format!("{path}.goal"),
                    "a group on a journey takes its targets from the journey's stages: remove `goal`",
                ));
            }
            let own = g
                .params
                .steering
                .behaviours
                .iter()
                .any(|w| w.behaviour.target() == Some(Target::Own));
            if !own {
                return Err(bad(
                    format!("{path}.steering"),
                    "a group on a journey needs a behaviour with `target = \"own\"` (the journey \
                     sets each agent's own target; leave `steering` out for `arrive`)",
                ));
            }
        }
        Ok(())
    }

    /// Adds the stages and journeys to `world`, in file order.
    ///
    /// # Errors
    /// The error of [`World::add_stage`] or [`World::add_journey`], naming the stage or
    /// journey (a stage that no cell of the walkable area's routing raster reaches, say).
    pub(super) fn add_journeys(&self, world: &mut World) -> Result<()> {
        for (i, s) in self.stages.iter().enumerate() {
            let path = format!("stages[{i}]");
            let stage = s.to_stage().map_err(|e| below(&path, e))?;
            world.add_stage(stage).map_err(|e| at_path(path, e))?;
        }
        for (j, js) in self.journeys.iter().enumerate() {
            let path = format!("journeys[{j}]");
            let journey = js
                .to_journey(|n| self.stage_index(n).map(|i| StageId(i as u32)))
                .map_err(|e| below(&path, e))?;
            world.add_journey(journey).map_err(|e| at_path(path, e))?;
        }
        Ok(())
    }
}
