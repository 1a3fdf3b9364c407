//! Behaviours as data: what a group profile or a scenario file names.

use crate::field::ChannelSet;
use glam::Vec2;
use serde::{Deserialize, Serialize};

use super::align::AlignParams;
use crate::agents::AgentId;
use crate::error::{Error, Result, finite, finite_vec, non_negative, positive};

/// What a behaviour steers relative to.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Target {
    /// A fixed point in world coordinates.
    Point(Vec2),
    /// Another agent (its position and velocity at the start of the frame). When that agent has
    /// been removed the behaviour yields nothing.
    Agent(AgentId),
    /// Each agent's own target point, set with `World::set_target`.
    Own,
    /// One of the world's shared target slots (`World::add_target`), moved with
    /// `World::set_target_point`; pursuit and evasion predict with the slot's velocity. In
    /// scenario files: `{ slot = N }`, the index in `[[targets]]`.
    Slot(crate::targets::TargetSlot),
    /// The nearest agent of `group` within `within` (found through a neighbour index of that
    /// group); nothing when none is that close.
    Nearest {
        /// The group to look in.
        group: usize,
        /// Search radius (> 0).
        within: f32,
    },
}

impl Target {
    fn validate(&self, name: &'static str) -> Result<()> {
        match self {
            Target::Point(p) => {
                crate::error::coordinate(name, *p)?;
            }
            Target::Nearest { within, .. } => {
                positive("target.within", *within)?;
            }
            Target::Agent(_) | Target::Own | Target::Slot(_) => {}
        }
        Ok(())
    }
}

/// Parameters of arrive.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ArriveParams {
    /// Distance within which the agent counts as arrived and comes to rest. Default: 0.25.
    pub target_radius: f32,
    /// Distance within which the agent slows down. Default: 3.0.
    pub slow_radius: f32,
    /// Seconds over which the wanted velocity is reached. Default: 0.1.
    pub time_to_target: f32,
}

impl Default for ArriveParams {
    fn default() -> Self {
        ArriveParams {
            target_radius: 0.25,
            slow_radius: 3.0,
            time_to_target: 0.1,
        }
    }
}

impl ArriveParams {
    /// Checks the numbers.
    ///
    /// # Errors
    /// [`Error::Negative`], [`Error::NotPositive`] or [`Error::NonFinite`].
    pub fn validate(&self) -> Result<()> {
        non_negative("arrive.target_radius", self.target_radius)?;
        positive("arrive.slow_radius", self.slow_radius)?;
        positive("arrive.time_to_target", self.time_to_target)?;
        Ok(())
    }
}

/// Parameters of Reynolds' wander circle (dynamic model). The kinematic model's wander uses the
/// group's maximum rotation instead.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WanderParams {
    /// Radius of the wander circle. Default: 1.0.
    pub radius: f32,
    /// Distance of the circle's centre ahead of the agent. Default: 2.0.
    pub distance: f32,
    /// Largest change of the wander angle per second, radians. Default: 4.0.
    pub jitter: f32,
}

impl Default for WanderParams {
    fn default() -> Self {
        WanderParams {
            radius: 1.0,
            distance: 2.0,
            jitter: 4.0,
        }
    }
}

/// The default `switch_gain` of [`Behaviour::ChooseExit`].
pub const DEFAULT_SWITCH_GAIN: f32 = 0.25;

fn default_switch_gain() -> f32 {
    DEFAULT_SWITCH_GAIN
}

/// One steering behaviour with its parameters.
///
/// Every behaviour works in both movement models: the world calls the dynamic function (a force)
/// or the kinematic one (a desired velocity) according to the group's model.
#[non_exhaustive]
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Behaviour {
    /// Full speed towards the target; nothing within `threshold`.
    Seek {
        /// What to seek.
        target: Target,
        /// Distance at which seeking stops. Default: 0.
        #[serde(default)]
        threshold: f32,
    },
    /// Full speed away from the target while it is within `panic_distance`.
    Flee {
        /// What to flee.
        target: Target,
        /// Distance beyond which the target is ignored. Default: infinite.
        #[serde(default = "infinite")]
        panic_distance: f32,
    },
    /// Slow down and stop at the target.
    Arrive {
        /// Where to stop.
        target: Target,
        /// Radii and timing.
        #[serde(flatten)]
        params: ArriveParams,
    },
    /// Random, smooth motion: the kinematic random binomial or the dynamic wander circle.
    Wander {
        /// Circle parameters (dynamic model).
        #[serde(flatten)]
        params: WanderParams,
    },
    /// Seek where the target agent will be.
    Pursue {
        /// The agent to catch.
        target: Target,
        /// Longest look-ahead, seconds. Default: 1.
        #[serde(default = "one")]
        max_prediction: f32,
    },
    /// Flee where the pursuer will be, while it is within `panic_distance`.
    Evade {
        /// The agent to escape.
        target: Target,
        /// Longest look-ahead, seconds. Default: 1.
        #[serde(default = "one")]
        max_prediction: f32,
        /// Distance beyond which the pursuer is ignored. Default: infinite.
        #[serde(default = "infinite")]
        panic_distance: f32,
    },
    /// Turn to face the target (angular only).
    Face {
        /// What to face.
        target: Target,
        /// Angular radii and timing.
        #[serde(flatten)]
        params: AlignParams,
    },
    /// Turn to face the direction of motion (angular only).
    LookWhereYouAreGoing {
        /// Angular radii and timing.
        #[serde(flatten)]
        params: AlignParams,
    },
    /// Match the target agent's velocity.
    MatchVelocity {
        /// The agent whose velocity to match.
        target: Target,
        /// Seconds over which to match. Default: 0.1.
        #[serde(default = "tenth")]
        time_to_target: f32,
    },
    /// Reynolds' separation: steer away from neighbours within `radius`, each pushing with
    /// weight 1 / distance.
    Separation {
        /// Neighbourhood.
        #[serde(flatten)]
        hood: Neighbourhood,
    },
    /// Reynolds' alignment: steer towards the mean velocity of neighbours within `radius`.
    Alignment {
        /// Neighbourhood.
        #[serde(flatten)]
        hood: Neighbourhood,
    },
    /// Reynolds' cohesion: steer towards the centre of neighbours within `radius`.
    Cohesion {
        /// Neighbourhood.
        #[serde(flatten)]
        hood: Neighbourhood,
    },
    /// Reynolds' obstacle avoidance of circles with a detection box `box_length * (1 + speed /
    /// max_speed)` long and as wide as the agent.
    AvoidObstacles {
        /// Box length at rest (> 0). Default: 4.
        #[serde(default = "four")]
        box_length: f32,
    },
    /// Wall avoidance with three feelers.
    AvoidWalls {
        /// Length of the forward feeler (> 0). Default: 4.
        #[serde(default = "four")]
        feeler_length: f32,
    },
    /// Stay inside a walled world: push back when the position `lookahead` seconds ahead comes
    /// within `margin` of an edge.
    Containment {
        /// Margin (> 0). Default: 5.
        #[serde(default = "five")]
        margin: f32,
        /// Seconds to look ahead (>= 0). Default: 0.5.
        #[serde(default = "half")]
        lookahead: f32,
    },
    /// The total force of the world's anti-gravity points, as a steering force.
    AntiGravity,
    /// The anti-gravity seek: full speed along `normalize(normalize(target - p) + total force)`.
    AntiGravitySeek {
        /// Where to go.
        target: Target,
    },
    /// Other agents as repelling gravity points: each neighbour within `radius`
    /// pushes with `strength / distance^exponent` along the bearing away from it.
    Repulsion {
        /// Force at distance 1 (> 0).
        strength: f32,
        /// The `n` of `strength / distance^n` (>= 0). Default: 2.
        #[serde(default = "two")]
        exponent: f32,
        /// Cut-off radius (> 0): farther agents are ignored.
        radius: f32,
    },
    // -- group movement (crate::group) --
    /// Reynolds' path following along a path added to the world.
    FollowPath {
        /// The path (`World::add_path`; in scenario files its index in `[[paths]]`).
        path: crate::group::PathId,
        /// Prediction, lead and direction.
        #[serde(flatten)]
        params: crate::group::PathFollowParams,
    },
    /// Follow a leader agent: offset pursuit of a slot in its local frame, out of its way.
    FollowLeader {
        /// The leader (must be an agent: `{ agent = N }`).
        leader: Target,
        /// Slot, spread, keep-out area and approach.
        #[serde(flatten)]
        params: crate::group::FollowParams,
    },
    /// Keep the slot assigned to this agent in its formation (`World::add_formation`); nothing
    /// when the agent belongs to no formation.
    KeepFormation {
        /// Approach to the slot.
        #[serde(flatten)]
        params: crate::group::SlotParams,
    },
    /// Run up to `launch` with the take-off velocity that lands on `landing`, then coast.
    Jump {
        /// The launch point.
        launch: Vec2,
        /// The landing point.
        landing: Vec2,
        /// Gravity, take-off speed, height, run-up.
        #[serde(flatten)]
        params: crate::group::JumpParams,
    },
    /// Follow a world field's flow towards its goals: the desired velocity is the
    /// bilinearly sampled flow direction at full speed; an agent on a goal cell of its channel,
    /// or one that has arrived since the channel's goals last changed, brakes to rest. Yields
    /// nothing when the field or channel does not exist.
    FollowField {
        /// The field, as numbered by `World::add_field`. Default: 0.
        #[serde(default)]
        field: usize,
        /// The goal channel of that field. Default: 0.
        #[serde(default)]
        channel: usize,
    },
    /// Follow, of several goal channels of a field (typically one per exit, see the `exit`
    /// channels of a scenario's `[field]`), the one with the shortest estimated travel time, and
    /// keep that choice unless another becomes quicker by more than `switch_gain`: the exit
    /// choice of a crowd with inertia. Each agent chooses when it first steers and again at each
    /// reroute of a quickest-path field (whose travel times include the crowd's jams), from the
    /// travel time of its cell to each channel's goals; then it moves as `follow_field` does on
    /// the chosen channel. Yields nothing when the field does not exist.
    ChooseExit {
        /// The field, as numbered by `World::add_field`. Default: 0.
        #[serde(default)]
        field: usize,
        /// The channels to choose among. Default: every channel of the field.
        #[serde(default, skip_serializing_if = "ChannelSet::is_all")]
        channels: ChannelSet,
        /// An agent leaves its channel for another only when the other's travel time is below
        /// `(1 - switch_gain)` times its own; in `[0, 1)`. Default: 0.25.
        #[serde(default = "default_switch_gain")]
        switch_gain: f32,
    },
    /// The Vicsek model (kinematic agents at constant speed): the new heading is the direction
    /// of the sum of the unit velocities of every agent within `radius`, itself included, turned
    /// by a uniform random angle in `[-noise / 2, noise / 2]` from the agent's counter-based
    /// stream; the request is that heading at full speed. Agents at rest count with their
    /// orientation.
    Vicsek {
        /// Interaction radius (> 0). Default: 1.
        #[serde(default = "one")]
        radius: f32,
        /// Width of the uniform noise, radians, in `[0, 2 pi]`. Default: 0.
        #[serde(default)]
        noise: f32,
    },
}

/// Which neighbours a flocking behaviour sees.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Neighbourhood {
    /// Neighbours farther than this are ignored (> 0).
    pub radius: f32,
    /// Cosine of the half view angle: a neighbour counts when the angle between the agent's
    /// heading and the offset to it is at most `acos(view_cos)`. -1 sees all around. Default: -1.
    #[serde(default = "minus_one")]
    pub view_cos: f32,
    /// Only neighbours of the agent's own group count. Default: true.
    #[serde(default = "yes")]
    pub same_group: bool,
}

impl Neighbourhood {
    /// All-round view of radius `radius`, own group only.
    #[must_use]
    pub fn radius(radius: f32) -> Self {
        Neighbourhood {
            radius,
            view_cos: -1.0,
            same_group: true,
        }
    }

    fn validate(&self, name: &'static str) -> Result<()> {
        positive(name, self.radius)?;
        crate::error::in_range("view_cos", self.view_cos, -1.0, 1.0, "[-1, 1]")?;
        Ok(())
    }
}

fn two() -> f32 {
    2.0
}
fn four() -> f32 {
    4.0
}
fn five() -> f32 {
    5.0
}
fn half() -> f32 {
    0.5
}
fn minus_one() -> f32 {
    -1.0
}
fn yes() -> bool {
    true
}

fn infinite() -> f32 {
    f32::INFINITY
}
fn one() -> f32 {
    1.0
}
fn tenth() -> f32 {
    0.1
}

fn align_validate(p: &AlignParams) -> Result<()> {
    non_negative("align.target_radius", p.target_radius)?;
    positive("align.slow_radius", p.slow_radius)?;
    positive("align.time_to_target", p.time_to_target)?;
    Ok(())
}

fn non_negative_or_inf(name: &'static str, v: f32) -> Result<f32> {
    if v == f32::INFINITY {
        Ok(v)
    } else {
        non_negative(name, v)
    }
}

impl Behaviour {
    /// The behaviour's name as written in scenario files.
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            Behaviour::Seek { .. } => "seek",
            Behaviour::Flee { .. } => "flee",
            Behaviour::Arrive { .. } => "arrive",
            Behaviour::Wander { .. } => "wander",
            Behaviour::Pursue { .. } => "pursue",
            Behaviour::Evade { .. } => "evade",
            Behaviour::Face { .. } => "face",
            Behaviour::LookWhereYouAreGoing { .. } => "look_where_you_are_going",
            Behaviour::MatchVelocity { .. } => "match_velocity",
            Behaviour::Separation { .. } => "separation",
            Behaviour::Alignment { .. } => "alignment",
            Behaviour::Cohesion { .. } => "cohesion",
            Behaviour::Repulsion { .. } => "repulsion",
            Behaviour::AvoidObstacles { .. } => "avoid_obstacles",
            Behaviour::AvoidWalls { .. } => "avoid_walls",
            Behaviour::Containment { .. } => "containment",
            Behaviour::AntiGravity => "anti_gravity",
            Behaviour::AntiGravitySeek { .. } => "anti_gravity_seek",
            Behaviour::FollowPath { .. } => "follow_path",
            Behaviour::FollowLeader { .. } => "follow_leader",
            Behaviour::KeepFormation { .. } => "keep_formation",
            Behaviour::Jump { .. } => "jump",
            Behaviour::FollowField { .. } => "follow_field",
            Behaviour::ChooseExit { .. } => "choose_exit",
            Behaviour::Vicsek { .. } => "vicsek",
        }
    }

    /// The behaviour's target, if it has one.
    #[must_use]
    pub fn target(&self) -> Option<Target> {
        self.clone().target_mut().copied()
    }

    /// The behaviour's target, if it has one, to change in place (a scenario's tiles move
    /// each copy's targets to its own tile).
    pub fn target_mut(&mut self) -> Option<&mut Target> {
        match self {
            Behaviour::Seek { target, .. }
            | Behaviour::Flee { target, .. }
            | Behaviour::Arrive { target, .. }
            | Behaviour::Pursue { target, .. }
            | Behaviour::Evade { target, .. }
            | Behaviour::Face { target, .. }
            | Behaviour::MatchVelocity { target, .. }
            | Behaviour::AntiGravitySeek { target } => Some(target),
            Behaviour::FollowLeader { leader, .. } => Some(leader),
            Behaviour::Wander { .. }
            | Behaviour::LookWhereYouAreGoing { .. }
            | Behaviour::Separation { .. }
            | Behaviour::Alignment { .. }
            | Behaviour::Cohesion { .. }
            | Behaviour::Repulsion { .. }
            | Behaviour::AvoidObstacles { .. }
            | Behaviour::AvoidWalls { .. }
            | Behaviour::Containment { .. }
            | Behaviour::AntiGravity
            | Behaviour::FollowPath { .. }
            | Behaviour::KeepFormation { .. }
            | Behaviour::Jump { .. }
            | Behaviour::FollowField { .. }
            | Behaviour::ChooseExit { .. }
            | Behaviour::Vicsek { .. } => None,
        }
    }

    /// Checks every parameter.
    ///
    /// # Errors
    /// The variant naming the first bad parameter.
    pub fn validate(&self) -> Result<()> {
        if let Some(t) = self.target() {
            t.validate("target")?;
        }
        match self {
            Behaviour::Seek { threshold, .. } => {
                non_negative("seek.threshold", *threshold)?;
            }
            Behaviour::Flee { panic_distance, .. } => {
                non_negative_or_inf("flee.panic_distance", *panic_distance)?;
            }
            Behaviour::Arrive { params, .. } => params.validate()?,
            Behaviour::Wander { params } => {
                non_negative("wander.radius", params.radius)?;
                non_negative("wander.distance", params.distance)?;
                non_negative("wander.jitter", params.jitter)?;
                if params.radius == 0.0 && params.distance == 0.0 {
                    return Err(Error::Invalid {
                        name: "wander".into(),
                        reason: "radius and distance cannot both be zero".into(),
                    });
                }
            }
            Behaviour::Pursue { max_prediction, .. } => {
                positive("pursue.max_prediction", *max_prediction)?;
            }
            Behaviour::Evade {
                max_prediction,
                panic_distance,
                ..
            } => {
                positive("evade.max_prediction", *max_prediction)?;
                non_negative_or_inf("evade.panic_distance", *panic_distance)?;
            }
            Behaviour::Face { params, .. } | Behaviour::LookWhereYouAreGoing { params } => {
                align_validate(params)?
            }
            Behaviour::MatchVelocity { time_to_target, .. } => {
                positive("match_velocity.time_to_target", *time_to_target)?;
            }
            Behaviour::Separation { hood } => hood.validate("separation.radius")?,
            Behaviour::Alignment { hood } => hood.validate("alignment.radius")?,
            Behaviour::Cohesion { hood } => hood.validate("cohesion.radius")?,
            Behaviour::Repulsion {
                strength,
                exponent,
                radius,
            } => {
                positive("repulsion.strength", *strength)?;
                non_negative("repulsion.exponent", *exponent)?;
                positive("repulsion.radius", *radius)?;
            }
            Behaviour::AvoidObstacles { box_length } => {
                positive("avoid_obstacles.box_length", *box_length)?;
            }
            Behaviour::AvoidWalls { feeler_length } => {
                positive("avoid_walls.feeler_length", *feeler_length)?;
            }
            Behaviour::Containment { margin, lookahead } => {
                positive("containment.margin", *margin)?;
                non_negative("containment.lookahead", *lookahead)?;
            }
            Behaviour::AntiGravity | Behaviour::AntiGravitySeek { .. } => {}
            Behaviour::FollowPath { params, .. } => params.validate()?,
            Behaviour::FollowLeader { leader, params } => {
                if !matches!(leader, Target::Agent(_)) {
                    return Err(Error::Invalid {
                        name: "follow_leader.leader".into(),
                        reason: "the leader must be an agent: `{ agent = N }`".into(),
                    });
                }
                params.validate()?;
            }
            Behaviour::KeepFormation { params } => params.validate()?,
            Behaviour::Jump {
                launch,
                landing,
                params,
            } => {
                finite_vec("jump.launch", *launch)?;
                finite_vec("jump.landing", *landing)?;
                params.validate()?;
                if launch == landing {
                    return Err(Error::Invalid {
                        name: "jump".into(),
                        reason: "launch and landing points coincide".into(),
                    });
                }
            }
            Behaviour::FollowField { .. } => {}
            Behaviour::ChooseExit { switch_gain, .. } => {
                crate::error::in_range(
                    "choose_exit.switch_gain",
                    *switch_gain,
                    0.0,
                    1.0,
                    "[0, 1)",
                )?;
                if *switch_gain == 1.0 {
                    return Err(Error::OutOfRange {
                        name: "choose_exit.switch_gain",
                        value: 1.0,
                        range: "[0, 1)",
                    });
                }
            }
            Behaviour::Vicsek { radius, noise } => {
                positive("vicsek.radius", *radius)?;
                crate::error::in_range(
                    "vicsek.noise",
                    *noise,
                    0.0,
                    std::f32::consts::TAU,
                    "[0, 2 pi]",
                )?;
            }
        }
        Ok(())
    }
}

/// A behaviour with its weight in the combination. In scenario files the weight sits beside the
/// behaviour's own keys: `{ kind = "seek", target = { point = [1, 2] }, weight = 2 }`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Weighted {
    /// The behaviour.
    #[serde(flatten)]
    pub behaviour: Behaviour,
    /// Its weight. Default: 1.
    #[serde(default = "one")]
    pub weight: f32,
}

impl Weighted {
    /// `behaviour` with weight `weight`.
    #[must_use]
    pub fn new(behaviour: Behaviour, weight: f32) -> Self {
        Weighted { behaviour, weight }
    }
}

/// How the behaviours of a profile are merged.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Combine {
    /// Sum of weighted requests (default).
    #[default]
    WeightedSum,
    /// Prioritised, truncated running sum: behaviours in order, each request first scaled by
    /// its weight, then using what is left of the force budget (maximum force, or maximum
    /// speed in the kinematic model); behaviours after the budget is spent are not evaluated.
    Priority,
}

/// The behaviours of a group and how they combine.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SteeringProfile {
    /// Weighted behaviours, in priority order. Default: none (the agents coast or stop).
    pub behaviours: Vec<Weighted>,
    /// How to combine them. Default: weighted sum.
    pub combine: Combine,
}

impl SteeringProfile {
    /// A profile of one behaviour with weight 1.
    #[must_use]
    pub fn single(behaviour: Behaviour) -> Self {
        SteeringProfile {
            behaviours: vec![Weighted::new(behaviour, 1.0)],
            combine: Combine::WeightedSum,
        }
    }

    /// Adds a weighted behaviour (builder style).
    #[must_use]
    pub fn with(mut self, behaviour: Behaviour, weight: f32) -> Self {
        self.behaviours.push(Weighted::new(behaviour, weight));
        self
    }

    /// Sets the combination mode (builder style).
    #[must_use]
    pub fn combined(mut self, combine: Combine) -> Self {
        self.combine = combine;
        self
    }

    /// Checks every behaviour and weight.
    ///
    /// # Errors
    /// The variant naming the first bad parameter.
    pub fn validate(&self) -> Result<()> {
        for w in &self.behaviours {
            finite("weight", w.weight)?;
            w.behaviour.validate()?;
        }
        Ok(())
    }
}
