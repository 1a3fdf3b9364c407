//! Steering behaviours, as pure functions and as data.
//!
//! Each behaviour is a pure function in the OpenSteer manner, usable on its own: it reads the
//! agent's state and a target and returns a steering request, zero when it has nothing to do.
//! Two families exist, one per movement model of the reference notes:
//!
//! - *dynamic* (steering) functions return a **force** (for the built-in ones, the classic
//!   `desired_velocity - velocity`); the world divides it by the mass and clamps the resulting
//!   acceleration to the group's maximum;
//! - *kinematic* functions (`kinematic_*`) return a **desired velocity** (and a rotation), which the
//!   integrator sets directly, clamped to the maximum speed.
//!
//! [`Behaviour`] describes a behaviour as data (an enum with parameters) for group profiles and
//! scenario files; [`Combine`] says how the weighted behaviours of a profile are merged: a
//! weighted sum, or Reynolds' prioritised, truncated running sum ([`priority_sum`]).
//!
//! Angles are radians, counter-clockwise from +x; `dt` is seconds; squared quantities end in `_sq`.

mod align;
mod behaviour;
mod combine;
mod constructors;
mod flocking;
mod pursuit;
mod seek;
pub(crate) mod trig;
mod wander;

pub use crate::field::ChannelSet;
pub use crate::vector::{Basis, predict_position, truncate, truncate_robust};
pub use align::{
    AlignParams, align, face, kinematic_face, look_where_you_are_going, velocity_match, wrap_angle,
};
pub use behaviour::{
    ArriveParams, Behaviour, Combine, DEFAULT_SWITCH_GAIN, Neighbourhood, SteeringProfile, Target,
    WanderParams, Weighted,
};
pub use combine::{PrioritySum, priority_sum, weighted_sum};
pub use flocking::{
    NeighbourSums, alignment, cohesion, desired, polarisation, separation, vicsek_heading,
};
pub use pursuit::{evade, pursue};
pub use seek::{arrive, flee, kinematic_arrive, kinematic_flee, kinematic_seek, seek};
pub use wander::{kinematic_wander, wander};

use glam::Vec2;

/// A steering request: a linear part and an angular part.
///
/// In the dynamic model `linear` is a force and `angular` an angular acceleration; in the kinematic
/// model `linear` is a desired velocity and `angular` a rotation (angular velocity).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Steering {
    /// Force (dynamic) or desired velocity (kinematic).
    pub linear: Vec2,
    /// Angular acceleration (dynamic) or rotation (kinematic), radians per second (squared).
    pub angular: f32,
}

impl Steering {
    /// No steering at all.
    pub const ZERO: Steering = Steering {
        linear: Vec2::ZERO,
        angular: 0.0,
    };

    /// A purely linear request.
    #[must_use]
    pub const fn linear(linear: Vec2) -> Self {
        Steering {
            linear,
            angular: 0.0,
        }
    }

    /// A purely angular request.
    #[must_use]
    pub const fn angular(angular: f32) -> Self {
        Steering {
            linear: Vec2::ZERO,
            angular,
        }
    }

    /// Both parts scaled by `w`.
    #[must_use]
    pub fn scaled(self, w: f32) -> Self {
        Steering {
            linear: self.linear * w,
            angular: self.angular * w,
        }
    }
}

impl std::ops::Add for Steering {
    type Output = Steering;
    fn add(self, o: Steering) -> Steering {
        Steering {
            linear: self.linear + o.linear,
            angular: self.angular + o.angular,
        }
    }
}

impl std::ops::AddAssign for Steering {
    fn add_assign(&mut self, o: Steering) {
        self.linear += o.linear;
        self.angular += o.angular;
    }
}
