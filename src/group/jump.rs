//! Jumps (Millington): the take-off velocity a jump needs, and the run-up that reaches the launch
//! point with it.
//!
//! The world is a plane; a jump adds a height axis only for the flight. With take-off vertical
//! speed `jump_speed`, gravity `gravity` and a landing `height` above the launch point, the
//! flight lasts the larger root `t` of `height = jump_speed * t - gravity * t^2 / 2` (landing on
//! the way down), and the planar velocity must be `(landing - launch) / t`. A faster vertical
//! take-off only lengthens the flight, so `jump_speed` is the agent's best and the jump is
//! impossible when that planar speed exceeds its maximum speed (or the height is out of reach).
//! During the flight the planar velocity is constant: the agent coasts.

use glam::Vec2;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result, finite, non_negative, positive};

/// A jump's physical parameters and run-up.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct JumpParams {
    /// Downward acceleration during the flight (> 0). Default: 9.81.
    pub gravity: f32,
    /// The agent's largest vertical take-off speed (> 0). Default: 5.
    pub jump_speed: f32,
    /// Height of the landing point above the launch point (may be negative). Default: 0.
    pub height: f32,
    /// Length of the straight run-up before the launch point (>= 0; 0: twice the braking distance
    /// `v^2 / (2 max_acceleration)` plus one unit). Default: 0.
    pub run_up: f32,
    /// Half-width of the run-up and flight corridors (> 0). Default: 0.5.
    pub tolerance: f32,
    /// Seconds over which the wanted velocity is reached, dynamic model (> 0). Default: 0.1.
    pub time_to_target: f32,
}

impl Default for JumpParams {
    fn default() -> Self {
        JumpParams {
            gravity: 9.81,
            jump_speed: 5.0,
            height: 0.0,
            run_up: 0.0,
            tolerance: 0.5,
            time_to_target: 0.1,
        }
    }
}

impl JumpParams {
    /// Checks the numbers.
    ///
    /// # Errors
    /// [`Error::NotPositive`], [`Error::Negative`] or [`Error::NonFinite`].
    pub fn validate(&self) -> Result<()> {
        positive("jump.gravity", self.gravity)?;
        positive("jump.jump_speed", self.jump_speed)?;
        finite("jump.height", self.height)?;
        non_negative("jump.run_up", self.run_up)?;
        positive("jump.tolerance", self.tolerance)?;
        positive("jump.time_to_target", self.time_to_target)?;
        Ok(())
    }
}

/// A feasible jump: the planar take-off velocity and the flight time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JumpPlan {
    /// Planar velocity needed at the launch point.
    pub velocity: Vec2,
    /// Seconds in the air.
    pub flight_time: f32,
}

/// The velocity an agent needs at `launch` to land on `landing`.
///
/// # Examples
/// ```
/// use throng::group::{JumpParams, jump_plan};
/// use glam::Vec2;
/// # fn main() -> throng::Result<()> {
/// let p = JumpParams { gravity: 10.0, jump_speed: 5.0, ..JumpParams::default() };
/// let plan = jump_plan(Vec2::ZERO, Vec2::new(4.0, 0.0), &p, 8.0)?;
/// assert_eq!(plan.flight_time, 1.0);
/// assert_eq!(plan.velocity, Vec2::new(4.0, 0.0));
/// assert!(jump_plan(Vec2::ZERO, Vec2::new(40.0, 0.0), &p, 8.0).is_err());
/// # Ok(())
/// # }
/// ```
///
/// # Errors
/// [`Error::Impossible`] when the landing is out of reach for `max_speed` (or too high for
/// `jump_speed`); [`Error::Invalid`] when launch and landing coincide; the variant naming a bad
/// parameter.
pub fn jump_plan(launch: Vec2, landing: Vec2, p: &JumpParams, max_speed: f32) -> Result<JumpPlan> {
    p.validate()?;
    crate::error::finite_vec("jump.launch", launch)?;
    crate::error::finite_vec("jump.landing", landing)?;
    positive("max_speed", max_speed)?;
    let delta = landing - launch;
    if delta.length_squared() == 0.0 {
        return Err(Error::Invalid {
            name: "jump".into(),
            reason: "launch and landing points coincide".into(),
        });
    }
    let disc = p.jump_speed * p.jump_speed - 2.0 * p.gravity * p.height;
    if disc < 0.0 {
        return Err(Error::Impossible {
            reason: format!(
                "a landing {} high needs a take-off speed of at least {:.3}, the agent has {}",
                p.height,
                (2.0 * p.gravity * p.height).sqrt(),
                p.jump_speed
            ),
        });
    }
    let flight_time = (p.jump_speed + disc.sqrt()) / p.gravity;
    let velocity = delta / flight_time;
    let speed = velocity.length();
    if speed > max_speed {
        return Err(Error::Impossible {
            reason: format!(
                "the jump from ({}, {}) to ({}, {}) needs a speed of {speed:.3} at take-off, the \
                 agent's maximum is {max_speed}",
                launch.x, launch.y, landing.x, landing.y
            ),
        });
    }
    Ok(JumpPlan {
        velocity,
        flight_time,
    })
}

/// What the jump behaviour wants this frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum JumpPhase {
    /// Go to the start of the run-up: arrive there (a desired velocity).
    Approach(Vec2),
    /// On the run-up: match the take-off velocity, correcting sideways drift (a desired velocity).
    RunUp(Vec2),
    /// Past the launch point inside the flight corridor: coast (no steering).
    Flight,
}

/// The phase and desired velocity of an agent at `position` moving at `velocity` heading for the
/// jump `plan` from `launch` to `landing`, with the agent's limits (`max_acceleration` is
/// `f32::INFINITY` in the kinematic model).
///
/// The run-up is the segment of length [`run_up_length`] ending at `launch`, along the take-off
/// velocity. An agent in that corridor (within `tolerance` of the line) and not moving backwards
/// runs up: its desired velocity is the take-off velocity minus a correction of its sideways
/// offset (velocity matching). Past the launch point and within `tolerance` of the line up to the
/// landing point it is in flight. Anywhere else it arrives at the start of the run-up, no faster
/// than it can brake in the distance left (arrive).
#[must_use]
#[allow(clippy::too_many_arguments)]
pub fn jump_phase(
    position: Vec2,
    velocity: Vec2,
    launch: Vec2,
    landing: Vec2,
    plan: &JumpPlan,
    max_speed: f32,
    max_acceleration: f32,
    p: &JumpParams,
) -> JumpPhase {
    let tolerance = p.tolerance;
    let run_up = run_up_length(p, plan, max_acceleration);
    let speed = plan.velocity.length();
    let dir = plan.velocity / speed;
    let r = position - launch;
    let along = r.dot(dir);
    let side = r - dir * along;
    let length = (landing - launch).length();
    if along >= 0.0 && along <= length + tolerance && side.length() <= tolerance {
        return JumpPhase::Flight;
    }
    if along < 0.0
        && along >= -run_up - tolerance
        && side.length() <= tolerance
        && velocity.dot(dir) >= 0.0
    {
        // Remove the sideways offset over about a quarter of the run-up time.
        let gain = 4.0 * speed / run_up.max(tolerance);
        return JumpPhase::RunUp(crate::vector::truncate(
            plan.velocity - side * gain,
            max_speed,
        ));
    }
    let start = launch - dir * run_up;
    let to = start - position;
    let dist = to.length();
    if dist == 0.0 {
        return JumpPhase::Approach(Vec2::ZERO);
    }
    // Arrive: no faster than braking at half the maximum acceleration allows, slowing to rest
    // over `time_to_target` at the end.
    let approach = max_speed
        .min((max_acceleration * dist).sqrt())
        .min(dist / p.time_to_target);
    JumpPhase::Approach(to * (approach / dist))
}

/// The run-up length to use: `p.run_up`, or when that is 0 three times the distance needed to
/// reach the take-off speed from rest at `max_acceleration`, plus one unit (in the kinematic
/// model, pass `f32::INFINITY` as the acceleration).
#[must_use]
pub fn run_up_length(p: &JumpParams, plan: &JumpPlan, max_acceleration: f32) -> f32 {
    if p.run_up > 0.0 {
        p.run_up
    } else {
        1.5 * plan.velocity.length_squared() / max_acceleration + 1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn height_changes_the_flight_time() {
        let p = JumpParams {
            gravity: 10.0,
            jump_speed: 5.0,
            height: 1.25,
            ..JumpParams::default()
        };
        // 1.25 = 5 t - 5 t^2 -> t = 0.5 (double root).
        let plan = jump_plan(Vec2::ZERO, Vec2::new(1.0, 0.0), &p, 10.0).unwrap();
        assert!((plan.flight_time - 0.5).abs() < 1e-5);
        let too_high = JumpParams { height: 1.3, ..p };
        assert!(matches!(
            jump_plan(Vec2::ZERO, Vec2::X, &too_high, 10.0),
            Err(Error::Impossible { .. })
        ));
        assert!(matches!(
            jump_plan(Vec2::ONE, Vec2::ONE, &p, 10.0),
            Err(Error::Invalid { .. })
        ));
    }

    #[test]
    fn phases_follow_the_geometry() {
        let plan = JumpPlan {
            velocity: Vec2::new(4.0, 0.0),
            flight_time: 1.0,
        };
        let (l, d) = (Vec2::ZERO, Vec2::new(4.0, 0.0));
        let p = JumpParams {
            run_up: 5.0,
            ..JumpParams::default()
        };
        let phase = |at: Vec2, v: Vec2| jump_phase(at, v, l, d, &plan, 8.0, 10.0, &p);
        assert_eq!(phase(Vec2::new(2.0, 0.1), plan.velocity), JumpPhase::Flight);
        assert!(matches!(
            phase(Vec2::new(-3.0, 0.0), Vec2::ZERO),
            JumpPhase::RunUp(v) if v == plan.velocity
        ));
        assert!(matches!(
            phase(Vec2::new(0.0, 10.0), Vec2::ZERO),
            JumpPhase::Approach(v) if v.x < 0.0 && v.y < 0.0
        ));
    }
}
