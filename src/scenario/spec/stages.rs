//! The schema of a scenario's stages and journeys (`[[stages]]`, `[[journeys]]`): stages and
//! journeys named by strings, which a group's `journey` and `stage` keys refer to, and their
//! conversion to the world's [`Stage`] and [`Journey`] once every name is resolved.
//!
//! Invariant: every table rejects unknown keys; a stage's id in the built world is its index
//! in `stages`, a journey's its index in `journeys`.

use glam::Vec2;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::geometry::Walkable;
use crate::journey::{Journey, Stage, StageId, Transition};

/// One stage of a scenario file (`[[stages]]`): its name and kind, with the kind's keys.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum StageSpec {
    /// A point passed within `distance` ([`Stage::Waypoint`]).
    Waypoint {
        /// The name journeys and groups use.
        name: String,
        /// The point.
        position: Vec2,
        /// How close counts as reached, m (> 0).
        distance: f32,
    },
    /// An area agents leave the world through ([`Stage::Exit`]): the rectangle `min`, `max`
    /// or a WKT `polygon`.
    Exit {
        /// The name journeys and groups use.
        name: String,
        /// The rectangle's lower corner.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        min: Option<Vec2>,
        /// The rectangle's upper corner.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        max: Option<Vec2>,
        /// The area as a WKT `POLYGON` or `MULTIPOLYGON`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        polygon: Option<String>,
    },
    /// Ordered slots released from the front by a program ([`Stage::Queue`]).
    Queue {
        /// The name journeys and groups use.
        name: String,
        /// The slots, the front first.
        slots: Vec<Vec2>,
    },
    /// Slots that hold everyone while the set is active ([`Stage::WaitingSet`]).
    WaitingSet {
        /// The name journeys and groups use.
        name: String,
        /// The slots, filled in this order.
        slots: Vec<Vec2>,
        /// Whether the set holds its agents from the start. Default: true.
        #[serde(default = "yes")]
        active: bool,
    },
    /// A target per agent, set by a program ([`Stage::DirectSteering`]).
    DirectSteering {
        /// The name journeys and groups use.
        name: String,
    },
}

fn yes() -> bool {
    true
}

impl StageSpec {
    /// The stage's name.
    #[must_use]
    pub fn name(&self) -> &str {
        match self {
            StageSpec::Waypoint { name, .. }
            | StageSpec::Exit { name, .. }
            | StageSpec::Queue { name, .. }
            | StageSpec::WaitingSet { name, .. }
            | StageSpec::DirectSteering { name } => name,
        }
    }

    /// The world's stage.
    ///
    /// # Errors
    /// [`Error::Invalid`] for an exit that is not one rectangle or one polygon, or whose
    /// rectangle or polygon is not an area; the error names the key below the stage
    /// (`min`, `polygon`), to be prefixed with the stage's path.
    pub fn to_stage(&self) -> Result<Stage> {
        Ok(match self {
            StageSpec::Waypoint {
                position, distance, ..
            } => Stage::Waypoint {
                position: *position,
                distance: *distance,
            },
            StageSpec::Exit {
                min, max, polygon, ..
            } => Stage::Exit {
                area: exit_area(*min, *max, polygon.as_deref())?,
            },
            StageSpec::Queue { slots, .. } => Stage::Queue {
                slots: slots.clone(),
            },
            StageSpec::WaitingSet { slots, active, .. } => Stage::WaitingSet {
                slots: slots.clone(),
                active: *active,
            },
            StageSpec::DirectSteering { .. } => Stage::DirectSteering,
        })
    }

    /// The stage's points with their keys: a waypoint's `position`, the `slots[k]` of a queue
    /// or waiting set.
    pub(crate) fn points(&self) -> Vec<(String, Vec2)> {
        match self {
            StageSpec::Waypoint { position, .. } => vec![("position".into(), *position)],
            StageSpec::Queue { slots, .. } | StageSpec::WaitingSet { slots, .. } => slots
                .iter()
                .enumerate()
                .map(|(k, &p)| (format!("slots[{k}]"), p))
                .collect(),
            StageSpec::Exit { .. } | StageSpec::DirectSteering { .. } => Vec::new(),
        }
    }

    /// Moves every coordinate of the stage by `f` (an exit's polygon is written out anew).
    ///
    /// # Errors
    /// As [`StageSpec::to_stage`] for a bad exit.
    pub(crate) fn map(&mut self, f: impl Fn(Vec2) -> Vec2) -> Result<()> {
        match self {
            StageSpec::Waypoint { position, .. } => *position = f(*position),
            StageSpec::Queue { slots, .. } | StageSpec::WaitingSet { slots, .. } => {
                slots.iter_mut().for_each(|p| *p = f(*p));
            }
            StageSpec::Exit {
                min, max, polygon, ..
            } => {
                let area = exit_area(*min, *max, polygon.as_deref())?.mapped(&f)?;
                (*min, *max, *polygon) = (None, None, Some(area.to_wkt()));
            }
            StageSpec::DirectSteering { .. } => {}
        }
        Ok(())
    }
}

/// An exit stage's area from its keys: `min` and `max`, or `polygon`.
fn exit_area(min: Option<Vec2>, max: Option<Vec2>, polygon: Option<&str>) -> Result<Walkable> {
    let invalid = |name: &str, reason: &str| Error::Invalid {
        name: name.into(),
        reason: reason.into(),
    };
    match (min, max, polygon) {
        (Some(min), Some(max), None) => {
            crate::error::coordinate("min", min)?;
            crate::error::coordinate("max", max)?;
            if min.x >= max.x || min.y >= max.y {
                return Err(invalid(
                    "min",
                    &format!(
                        "the exit's rectangle [{}, {}] x [{}, {}] has no area: `min` must lie below and left of `max`",
                        min.x, max.x, min.y, max.y
                    ),
                ));
            }
            Walkable::rectangle(min, max)
        }
        (None, None, Some(text)) => Walkable::from_wkt(text).map_err(|e| Error::Invalid {
            name: "polygon".into(),
            reason: e.to_string(),
        }),
        (_, _, Some(_)) => Err(invalid(
            "polygon",
            "an exit is `min` and `max` or `polygon`, not both",
        )),
        (Some(_), None, None) => Err(invalid("max", "an exit with `min` needs `max`")),
        (None, Some(_), None) => Err(invalid("min", "an exit with `max` needs `min`")),
        (None, None, None) => Err(invalid(
            "min",
            "an exit needs its area: `min` and `max`, or `polygon`",
        )),
    }
}

/// One journey of a scenario file (`[[journeys]]`): its stages by name and its transitions.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JourneySpec {
    /// The name groups use.
    pub name: String,
    /// The journey's stages by name; the first is where its agents start unless a group says
    /// otherwise.
    pub stages: Vec<String>,
    /// The transitions, at most one out of each stage. Default (the key left out): each stage
    /// to the next in `stages`, a chain.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transitions: Option<Vec<TransitionSpec>>,
}

/// How a transition chooses the next stage.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TransitionKind {
    /// Always the one stage of `to`.
    #[default]
    Fixed,
    /// Weighted round robin over `to` with `weights`.
    RoundRobin,
    /// The stage of `to` that the fewest agents target.
    LeastTargeted,
}

/// One transition of a journey: out of stage `from`, to the stage or stages of `to`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransitionSpec {
    /// The stage the transition leaves.
    pub from: String,
    /// How the next stage is chosen. Default: fixed.
    #[serde(default)]
    pub kind: TransitionKind,
    /// The next stage (a name) or the candidates (a list of names).
    #[serde(deserialize_with = "one_or_many")]
    pub to: Vec<String>,
    /// A round robin's weights, one per candidate of `to`, each at least 1. Default: 1 each.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub weights: Vec<u32>,
}

/// A string or a list of strings, as a list.
fn one_or_many<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> std::result::Result<Vec<String>, D::Error> {
    struct Names;
    impl<'de> serde::de::Visitor<'de> for Names {
        type Value = Vec<String>;
        fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str("a stage name or a list of stage names")
        }
        fn visit_str<E: serde::de::Error>(self, v: &str) -> std::result::Result<Vec<String>, E> {
            Ok(vec![v.to_string()])
        }
        fn visit_seq<A: serde::de::SeqAccess<'de>>(
            self,
            mut seq: A,
        ) -> std::result::Result<Vec<String>, A::Error> {
            let mut out = Vec::new();
            while let Some(s) = seq.next_element::<String>()? {
                out.push(s);
            }
            Ok(out)
        }
    }
    d.deserialize_any(Names)
}

impl JourneySpec {
    /// The world's journey, with every stage name resolved by `id` (which knows them all: the
    /// names are checked first).
    pub(super) fn to_journey(&self, id: impl Fn(&str) -> Option<StageId>) -> Result<Journey> {
        let resolve = |name: &str| {
            id(name).ok_or_else(|| Error::Invalid {
                name: "stages".into(),
                reason: format!("unknown stage {name:?}"),
            })
        };
        let stages = self
            .stages
            .iter()
            .map(|s| resolve(s))
            .collect::<Result<Vec<_>>>()?;
        let Some(transitions) = &self.transitions else {
            return Ok(Journey::chain(stages));
        };
        let mut journey = Journey::new(stages);
        for t in transitions {
            let to =
                t.to.iter()
                    .map(|s| resolve(s))
                    .collect::<Result<Vec<_>>>()?;
            let how = match t.kind {
                TransitionKind::Fixed => match to.as_slice() {
                    [one] => Transition::fixed(*one),
                    _ => {
                        return Err(Error::Invalid {
                            name: "to".into(),
                            reason: "a fixed transition names one stage".into(),
                        });
                    }
                },
                TransitionKind::RoundRobin => Transition::round_robin(
                    to.iter()
                        .enumerate()
                        .map(|(k, &s)| (s, t.weights.get(k).copied().unwrap_or(1))),
                ),
                TransitionKind::LeastTargeted => Transition::least_targeted(to),
            };
            journey.transitions.push((resolve(&t.from)?, how));
        }
        Ok(journey)
    }
}
