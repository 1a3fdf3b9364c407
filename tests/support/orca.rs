//! The ORCA group the wall suites share.

use throng::orca::Orca;
use throng::prelude::*;

/// A kinematic group of `radius` and `max_speed` whose agents arrive at their own targets
/// (within `arrival_radius`) through the ORCA filter `orca`.
pub fn arriving_orca_group(
    radius: f32,
    max_speed: f32,
    orca: Orca,
    arrival_radius: f32,
) -> Profile {
    let arrive = Behaviour::Arrive {
        target: Target::Own,
        params: ArriveParams {
            target_radius: 0.0,
            slow_radius: 1.0,
            time_to_target: 1.0,
        },
    };
    Profile {
        model: MovementModel::Kinematic,
        max_speed,
        radius,
        orca: Some(orca),
        arrival_radius: Some(arrival_radius),
        ..Profile::kinematic(SteeringProfile::single(arrive))
    }
}
