//! Profiles: what the agents of one group share (movement model, limits, behaviours).
//!
//! A [`Profile`] is plain data, validated by [`Profile::validate`] at the boundary (builders,
//! `World::add_group`, scenario loading); the world compiles each profile into a plan for the
//! steering pass. Agents may override the maximum speed and radius one by one.

use std::f32::consts::PI;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result, non_negative, positive};
use crate::movement::{IntegrationParams, MovementModel, OrientationMode};
use crate::steering::SteeringProfile;

/// A group's profile: movement model, limits and behaviours. Agents of a group share it; the
/// maximum speed and radius can be overridden per agent.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Profile {
    /// A name for output and scenario files. Default: `"group"`.
    pub name: String,
    /// Kinematic or dynamic. Default: dynamic.
    pub model: MovementModel,
    /// Whether orientation follows the velocity or integrates the rotation. Default: face velocity.
    pub orientation: OrientationMode,
    /// Largest speed, units per second (> 0). Default: 2.
    pub max_speed: f32,
    /// Largest linear acceleration, units per second squared (> 0; dynamic model). Default: 4.
    pub max_acceleration: f32,
    /// Mass (> 0): acceleration = force / mass. Default: 1.
    pub mass: f32,
    /// Largest rotation, radians per second (> 0). Default: pi.
    pub max_rotation: f32,
    /// Largest angular acceleration, radians per second squared (> 0; dynamic model). Default: 4 pi.
    pub max_angular_acceleration: f32,
    /// Linear drag per second (>= 0; dynamic model): the velocity is scaled by
    /// `max(0, 1 - drag * dt)` each step. Default: 0.
    pub drag: f32,
    /// Agent radius (>= 0), used by separation, obstacles and drawing. Default: 0.5.
    pub radius: f32,
    /// The behaviours and how they combine. Default: none.
    pub steering: SteeringProfile,
    /// Neighbour cap (in the manner of RVO2's `maxNeighbors`): flocking and repulsion consider
    /// only the nearest this many neighbours. Default: none (every neighbour in range).
    pub max_neighbours: Option<u32>,
    /// Collision avoidance by ORCA: the behaviours give the preferred velocity, ORCA the
    /// collision-free velocity closest to it ([`crate::orca`]). Default: none.
    pub orca: Option<crate::orca::Orca>,
    /// A pedestrian model in SI units that replaces the behaviours' request: they give the
    /// preferred direction, the model the acceleration or velocity ([`crate::ped`]). Default:
    /// none.
    pub pedestrian: Option<crate::ped::Pedestrian>,
    /// Agents of this group count as arrived when they are within this distance (>= 0) of
    /// their own target ([`crate::steering::Target::Own`], set with `World::set_target`);
    /// [`crate::world::StepStats::arrived`] counts them. Default: none (not counted).
    pub arrival_radius: Option<f32>,
}

impl Default for Profile {
    fn default() -> Self {
        Profile {
            name: "group".to_string(),
            model: MovementModel::Dynamic,
            orientation: OrientationMode::FaceVelocity,
            max_speed: 2.0,
            max_acceleration: 4.0,
            mass: 1.0,
            max_rotation: PI,
            max_angular_acceleration: 4.0 * PI,
            drag: 0.0,
            radius: 0.5,
            steering: SteeringProfile::default(),
            max_neighbours: None,
            orca: None,
            pedestrian: None,
            arrival_radius: None,
        }
    }
}

impl Profile {
    /// A dynamic group with default limits and the given profile.
    #[must_use]
    pub fn dynamic(steering: SteeringProfile) -> Self {
        Profile {
            steering,
            ..Self::default()
        }
    }

    /// A kinematic group with default limits and the given profile.
    #[must_use]
    pub fn kinematic(steering: SteeringProfile) -> Self {
        Profile {
            model: MovementModel::Kinematic,
            steering,
            ..Self::default()
        }
    }

    /// Pedestrians of `model` that walk their journeys ([`crate::journey`]): kinematic, bodies
    /// of radius 0.2 m, a speed limit of 2.5 m/s, Weidmann's desired speeds, and one behaviour,
    /// `arrive` at their own target (which the journey system sets every step) slowing within
    /// 1 m, so that they stop on a queue's slot and walk at their desired speed elsewhere.
    #[must_use]
    pub fn journey_walkers(model: crate::ped::Model) -> Self {
        let arrive = crate::steering::Behaviour::Arrive {
            target: crate::steering::Target::Own,
            params: crate::steering::ArriveParams {
                target_radius: 0.05,
                slow_radius: 1.0,
                time_to_target: 0.1,
            },
        };
        Profile {
            model: MovementModel::Kinematic,
            steering: SteeringProfile::single(arrive),
            max_speed: 2.5,
            radius: 0.2,
            pedestrian: Some(crate::ped::Pedestrian::new(model)),
            ..Self::default()
        }
    }

    /// Checks every limit and behaviour.
    ///
    /// # Errors
    /// [`Error::ZeroMass`] for a mass <= 0, otherwise the variant naming the first bad parameter.
    pub fn validate(&self) -> Result<()> {
        if !self.mass.is_finite() {
            return Err(Error::NonFinite {
                name: "mass",
                value: f64::from(self.mass),
            });
        }
        if self.mass <= 0.0 {
            return Err(Error::ZeroMass {
                value: f64::from(self.mass),
            });
        }
        positive("max_speed", self.max_speed)?;
        crate::error::in_range(
            "max_speed",
            self.max_speed,
            0.0,
            crate::error::MAX_SPEED,
            "(0, 1e12]",
        )?;
        positive("max_acceleration", self.max_acceleration)?;
        positive("max_rotation", self.max_rotation)?;
        positive("max_angular_acceleration", self.max_angular_acceleration)?;
        for (name, v) in [
            ("max_acceleration", self.max_acceleration),
            ("max_rotation", self.max_rotation),
            ("max_angular_acceleration", self.max_angular_acceleration),
        ] {
            crate::error::in_range(name, v, 0.0, crate::error::MAX_RATE, "(0, 1e12]")?;
        }
        non_negative("drag", self.drag)?;
        if self.model != MovementModel::Kinematic
            && self
                .steering
                .behaviours
                .iter()
                .any(|w| matches!(w.behaviour, crate::steering::Behaviour::Vicsek { .. }))
        {
            return Err(Error::Invalid {
                name: "vicsek".into(),
                reason: "the Vicsek model moves kinematic agents at constant speed: set model = \"kinematic\"".into(),
            });
        }
        non_negative("radius", self.radius)?;
        if self.max_neighbours == Some(0) {
            return Err(Error::NotPositive {
                name: "max_neighbours",
                value: 0.0,
            });
        }
        if let Some(o) = &self.orca {
            o.validate()?;
        }
        if let Some(p) = &self.pedestrian {
            p.validate()?;
        }
        if let Some(r) = self.arrival_radius {
            non_negative("arrival_radius", r)?;
            crate::error::in_range("arrival_radius", r, 0.0, 1e18, "[0, 1e18]")?;
        }
        self.steering.validate()
    }

    pub(crate) fn integration(&self, dt: f32) -> IntegrationParams {
        IntegrationParams {
            kinematic: self.model == MovementModel::Kinematic,
            damp: if self.drag == 0.0 {
                1.0
            } else {
                (1.0 - self.drag * dt).max(0.0)
            },
            max_rotation: self.max_rotation,
            face_velocity: self.orientation == OrientationMode::FaceVelocity,
            max_speed: self.max_speed,
        }
    }
}
