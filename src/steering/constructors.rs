//! Constructors for every [`Behaviour`] with its documented defaults, and the modifiers that
//! change one optional parameter.
//!
//! ```
//! use throng::prelude::*;
//!
//! let flock = SteeringProfile::default()
//!     .with(Behaviour::separation(2.0), 1.5)
//!     .with(Behaviour::alignment(Neighbourhood::radius(5.0).view(-0.5)), 1.0)
//!     .with(Behaviour::cohesion(Neighbourhood::radius(5.0).view(-0.5)), 0.8);
//! let chase = Behaviour::seek(Target::Point(Vec2::new(10.0, 0.0))).with_threshold(0.5);
//! assert_eq!(chase, Behaviour::Seek { target: Target::Point(Vec2::new(10.0, 0.0)), threshold: 0.5 });
//! # let _ = flock;
//! ```
//!
//! A modifier applies to the behaviours that have its parameter (each says which); on any other
//! behaviour it changes nothing, and debug builds stop at the mistake.

use glam::Vec2;

use super::align::AlignParams;
use super::behaviour::{ArriveParams, Behaviour, Neighbourhood, Target, WanderParams};
use crate::agents::AgentId;
use crate::group::{FollowParams, JumpParams, PathFollowParams, PathId, SlotParams};

impl From<f32> for Neighbourhood {
    /// [`Neighbourhood::radius`]: all round, own group only.
    fn from(radius: f32) -> Self {
        Neighbourhood::radius(radius)
    }
}

impl Neighbourhood {
    /// The same neighbourhood seeing only within `acos(view_cos)` of the heading.
    #[must_use]
    pub fn view(self, view_cos: f32) -> Self {
        Neighbourhood { view_cos, ..self }
    }

    /// The same neighbourhood counting the agents of every group, not only the agent's own.
    #[must_use]
    pub fn any_group(self) -> Self {
        Neighbourhood {
            same_group: false,
            ..self
        }
    }
}

impl Behaviour {
    /// Seek `target` at full speed, with no threshold.
    #[must_use]
    pub fn seek(target: Target) -> Self {
        Behaviour::Seek {
            target,
            threshold: 0.0,
        }
    }

    /// Flee `target` at full speed, from any distance.
    #[must_use]
    pub fn flee(target: Target) -> Self {
        Behaviour::Flee {
            target,
            panic_distance: f32::INFINITY,
        }
    }

    /// Arrive at `target` with the default radii and timing ([`ArriveParams::default`]).
    #[must_use]
    pub fn arrive(target: Target) -> Self {
        Behaviour::arrive_with(target, ArriveParams::default())
    }

    /// Arrive at `target` with the given radii and timing.
    #[must_use]
    pub fn arrive_with(target: Target, params: ArriveParams) -> Self {
        Behaviour::Arrive { target, params }
    }

    /// Wander with the default circle ([`WanderParams::default`]).
    #[must_use]
    pub fn wander() -> Self {
        Behaviour::wander_with(WanderParams::default())
    }

    /// Wander with the given circle.
    #[must_use]
    pub fn wander_with(params: WanderParams) -> Self {
        Behaviour::Wander { params }
    }

    /// Pursue `target`, predicting at most one second ahead.
    #[must_use]
    pub fn pursue(target: Target) -> Self {
        Behaviour::Pursue {
            target,
            max_prediction: 1.0,
        }
    }

    /// Evade `target`, predicting at most one second ahead, from any distance.
    #[must_use]
    pub fn evade(target: Target) -> Self {
        Behaviour::Evade {
            target,
            max_prediction: 1.0,
            panic_distance: f32::INFINITY,
        }
    }

    /// Turn to face `target` with the default angular radii ([`AlignParams::default`]).
    #[must_use]
    pub fn face(target: Target) -> Self {
        Behaviour::Face {
            target,
            params: AlignParams::default(),
        }
    }

    /// Turn to face the direction of motion with the default angular radii.
    #[must_use]
    pub fn look_where_you_are_going() -> Self {
        Behaviour::LookWhereYouAreGoing {
            params: AlignParams::default(),
        }
    }

    /// Match the velocity of `target` over 0.1 s.
    #[must_use]
    pub fn match_velocity(target: Target) -> Self {
        Behaviour::MatchVelocity {
            target,
            time_to_target: 0.1,
        }
    }

    /// Reynolds' separation within `hood` (a radius, or a [`Neighbourhood`]).
    #[must_use]
    pub fn separation(hood: impl Into<Neighbourhood>) -> Self {
        Behaviour::Separation { hood: hood.into() }
    }

    /// Reynolds' alignment within `hood`.
    #[must_use]
    pub fn alignment(hood: impl Into<Neighbourhood>) -> Self {
        Behaviour::Alignment { hood: hood.into() }
    }

    /// Reynolds' cohesion within `hood`.
    #[must_use]
    pub fn cohesion(hood: impl Into<Neighbourhood>) -> Self {
        Behaviour::Cohesion { hood: hood.into() }
    }

    /// Avoid circle obstacles with a detection box 4 long at rest.
    #[must_use]
    pub fn avoid_obstacles() -> Self {
        Behaviour::AvoidObstacles { box_length: 4.0 }
    }

    /// Avoid walls with feelers 4 long.
    #[must_use]
    pub fn avoid_walls() -> Self {
        Behaviour::AvoidWalls { feeler_length: 4.0 }
    }

    /// Stay inside a walled world: margin 5, looking 0.5 s ahead.
    #[must_use]
    pub fn containment() -> Self {
        Behaviour::Containment {
            margin: 5.0,
            lookahead: 0.5,
        }
    }

    /// The world's anti-gravity points as a steering force.
    #[must_use]
    pub fn anti_gravity() -> Self {
        Behaviour::AntiGravity
    }

    /// The anti-gravity seek of `target`.
    #[must_use]
    pub fn anti_gravity_seek(target: Target) -> Self {
        Behaviour::AntiGravitySeek { target }
    }

    /// Other agents within `radius` as repelling points of force `strength / distance^2`.
    #[must_use]
    pub fn repulsion(strength: f32, radius: f32) -> Self {
        Behaviour::Repulsion {
            strength,
            exponent: 2.0,
            radius,
        }
    }

    /// Follow path `path` forwards with the default prediction and lead.
    #[must_use]
    pub fn follow_path(path: PathId) -> Self {
        Behaviour::FollowPath {
            path,
            params: PathFollowParams::default(),
        }
    }

    /// Follow path `path` with the given prediction, lead and direction.
    #[must_use]
    pub fn follow_path_with(path: PathId, params: PathFollowParams) -> Self {
        Behaviour::FollowPath { path, params }
    }

    /// Follow the leader agent `leader` in the default slot (3 behind it).
    #[must_use]
    pub fn follow_leader(leader: AgentId) -> Self {
        Behaviour::follow_leader_with(leader, FollowParams::default())
    }

    /// Follow the leader agent `leader` with the given slot, spread and keep-out area.
    #[must_use]
    pub fn follow_leader_with(leader: AgentId, params: FollowParams) -> Self {
        Behaviour::FollowLeader {
            leader: Target::Agent(leader),
            params,
        }
    }

    /// Keep the agent's formation slot with the default approach.
    #[must_use]
    pub fn keep_formation() -> Self {
        Behaviour::KeepFormation {
            params: SlotParams::default(),
        }
    }

    /// Run up to `launch` and jump to `landing` with the default gravity and take-off.
    #[must_use]
    pub fn jump(launch: Vec2, landing: Vec2) -> Self {
        Behaviour::Jump {
            launch,
            landing,
            params: JumpParams::default(),
        }
    }

    /// Follow channel `channel` of field `field` (as numbered by `World::add_field`).
    #[must_use]
    pub fn follow_field(field: usize, channel: usize) -> Self {
        Behaviour::FollowField { field, channel }
    }

    /// Choose among every channel of field `field` by travel time, with the default switching
    /// gain ([`DEFAULT_SWITCH_GAIN`](crate::steering::DEFAULT_SWITCH_GAIN)).
    #[must_use]
    pub fn choose_exit(field: usize) -> Self {
        Behaviour::ChooseExit {
            field,
            channels: crate::field::ChannelSet::ALL,
            switch_gain: super::behaviour::DEFAULT_SWITCH_GAIN,
        }
    }

    /// The Vicsek model with interaction radius `radius` and noise width `noise` (radians).
    #[must_use]
    pub fn vicsek(radius: f32, noise: f32) -> Self {
        Behaviour::Vicsek { radius, noise }
    }

    /// Sets the distance at which seeking stops. Applies to `seek`.
    #[must_use]
    pub fn with_threshold(mut self, value: f32) -> Self {
        match &mut self {
            Behaviour::Seek { threshold, .. } => *threshold = value,
            other => misapplied("with_threshold", other),
        }
        self
    }

    /// Sets the distance beyond which the target is ignored. Applies to `flee` and `evade`.
    #[must_use]
    pub fn with_panic_distance(mut self, value: f32) -> Self {
        match &mut self {
            Behaviour::Flee { panic_distance, .. } | Behaviour::Evade { panic_distance, .. } => {
                *panic_distance = value;
            }
            other => misapplied("with_panic_distance", other),
        }
        self
    }

    /// Sets the longest look-ahead, seconds. Applies to `pursue` and `evade`.
    #[must_use]
    pub fn with_max_prediction(mut self, value: f32) -> Self {
        match &mut self {
            Behaviour::Pursue { max_prediction, .. } | Behaviour::Evade { max_prediction, .. } => {
                *max_prediction = value;
            }
            other => misapplied("with_max_prediction", other),
        }
        self
    }

    /// Sets the seconds over which the wanted velocity or rotation is reached. Applies to
    /// `arrive`, `match_velocity`, `face`, `look_where_you_are_going`, `follow_path`,
    /// `follow_leader` and `keep_formation`.
    #[must_use]
    pub fn with_time_to_target(mut self, value: f32) -> Self {
        match &mut self {
            Behaviour::MatchVelocity { time_to_target, .. } => *time_to_target = value,
            Behaviour::Arrive { params, .. } => params.time_to_target = value,
            Behaviour::Face { params, .. } | Behaviour::LookWhereYouAreGoing { params } => {
                params.time_to_target = value;
            }
            Behaviour::FollowPath { params, .. } => params.time_to_target = value,
            Behaviour::FollowLeader { params, .. } => params.time_to_target = value,
            Behaviour::KeepFormation { params } => params.time_to_target = value,
            other => misapplied("with_time_to_target", other),
        }
        self
    }

    /// Sets the radius within which the agent slows down. Applies to `arrive`, `face`,
    /// `look_where_you_are_going`, `follow_leader` and `keep_formation`.
    #[must_use]
    pub fn with_slow_radius(mut self, value: f32) -> Self {
        match &mut self {
            Behaviour::Arrive { params, .. } => params.slow_radius = value,
            Behaviour::Face { params, .. } | Behaviour::LookWhereYouAreGoing { params } => {
                params.slow_radius = value;
            }
            Behaviour::FollowLeader { params, .. } => params.slow_radius = value,
            Behaviour::KeepFormation { params } => params.slow_radius = value,
            other => misapplied("with_slow_radius", other),
        }
        self
    }
}

/// A modifier used on a behaviour without its parameter: a mistake in the calling program.
fn misapplied(modifier: &str, behaviour: &Behaviour) {
    debug_assert!(false, "{modifier} does not apply to `{}`", behaviour.name());
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every constructor equals the behaviour a scenario file gets from the kind alone, so the
    /// constructors and the documented defaults cannot drift apart.
    #[test]
    fn constructors_equal_the_scenario_defaults() {
        let t = Target::Point(Vec2::new(1.0, 2.0));
        let parse = |s: &str| -> Behaviour { toml::from_str(s).expect(s) };
        let pt = "target = { point = [1, 2] }";
        for (built, text) in [
            (Behaviour::seek(t), format!("kind = 'seek'\n{pt}")),
            (Behaviour::flee(t), format!("kind = 'flee'\n{pt}")),
            (Behaviour::arrive(t), format!("kind = 'arrive'\n{pt}")),
            (Behaviour::wander(), "kind = 'wander'".into()),
            (Behaviour::pursue(t), format!("kind = 'pursue'\n{pt}")),
            (Behaviour::evade(t), format!("kind = 'evade'\n{pt}")),
            (Behaviour::face(t), format!("kind = 'face'\n{pt}")),
            (
                Behaviour::look_where_you_are_going(),
                "kind = 'look_where_you_are_going'".into(),
            ),
            (
                Behaviour::match_velocity(t),
                format!("kind = 'match_velocity'\n{pt}"),
            ),
            (
                Behaviour::separation(2.0),
                "kind = 'separation'\nradius = 2".into(),
            ),
            (
                Behaviour::alignment(Neighbourhood::radius(5.0).view(-0.5).any_group()),
                "kind = 'alignment'\nradius = 5\nview_cos = -0.5\nsame_group = false".into(),
            ),
            (
                Behaviour::cohesion(3.0),
                "kind = 'cohesion'\nradius = 3".into(),
            ),
            (
                Behaviour::avoid_obstacles(),
                "kind = 'avoid_obstacles'".into(),
            ),
            (Behaviour::avoid_walls(), "kind = 'avoid_walls'".into()),
            (Behaviour::containment(), "kind = 'containment'".into()),
            (Behaviour::anti_gravity(), "kind = 'anti_gravity'".into()),
            (
                Behaviour::anti_gravity_seek(t),
                format!("kind = 'anti_gravity_seek'\n{pt}"),
            ),
            (
                Behaviour::repulsion(3.0, 4.0),
                "kind = 'repulsion'\nstrength = 3\nradius = 4".into(),
            ),
            (
                Behaviour::follow_path(PathId(2)),
                "kind = 'follow_path'\npath = 2".into(),
            ),
            (
                Behaviour::follow_leader(AgentId(7)),
                "kind = 'follow_leader'\nleader = { agent = 7 }".into(),
            ),
            (
                Behaviour::keep_formation(),
                "kind = 'keep_formation'".into(),
            ),
            (
                Behaviour::jump(Vec2::ZERO, Vec2::new(5.0, 0.0)),
                "kind = 'jump'\nlaunch = [0, 0]\nlanding = [5, 0]".into(),
            ),
            (
                Behaviour::follow_field(1, 2),
                "kind = 'follow_field'\nfield = 1\nchannel = 2".into(),
            ),
            (Behaviour::vicsek(1.0, 0.0), "kind = 'vicsek'".into()),
            (
                Behaviour::choose_exit(1),
                "kind = 'choose_exit'\nfield = 1".into(),
            ),
        ] {
            assert_eq!(built, parse(&text), "{text}");
            built.validate().expect(&text);
        }
    }

    #[test]
    fn modifiers_set_their_parameter() {
        let t = Target::Agent(AgentId(3));
        assert_eq!(
            Behaviour::evade(t)
                .with_panic_distance(8.0)
                .with_max_prediction(2.0),
            Behaviour::Evade {
                target: t,
                max_prediction: 2.0,
                panic_distance: 8.0
            }
        );
        let Behaviour::Arrive { params, .. } = Behaviour::arrive(t)
            .with_slow_radius(6.0)
            .with_time_to_target(0.3)
        else {
            unreachable!()
        };
        assert_eq!((params.slow_radius, params.time_to_target), (6.0, 0.3));
        assert_eq!(params.target_radius, ArriveParams::default().target_radius);
    }

    #[test]
    #[cfg(debug_assertions)]
    #[should_panic(expected = "with_threshold does not apply to `wander`")]
    fn a_misapplied_modifier_stops_debug_builds() {
        let _ = Behaviour::wander().with_threshold(1.0);
    }
}
