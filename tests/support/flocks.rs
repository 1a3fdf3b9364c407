//! The flocking groups shared by the suites that compare the cell batch with its references.

use throng::prelude::*;

/// A dynamic group (maximum speed 3, acceleration 6) steering by `steering` followed by
/// separation within `0.4 r`, alignment within `r` and cohesion within `0.8 r` (weights 1.5, 1
/// and 0.7), all with the view cone `view_cos` and, with `same_group`, of its own group only.
pub fn flocking_group(
    steering: SteeringProfile,
    same_group: bool,
    view_cos: f32,
    r: f32,
) -> Profile {
    let hood = |radius: f32| Neighbourhood {
        radius,
        view_cos,
        same_group,
    };
    Profile {
        max_speed: 3.0,
        max_acceleration: 6.0,
        ..Profile::dynamic(
            steering
                .with(
                    Behaviour::Separation {
                        hood: hood(0.4 * r),
                    },
                    1.5,
                )
                .with(Behaviour::Alignment { hood: hood(r) }, 1.0)
                .with(
                    Behaviour::Cohesion {
                        hood: hood(0.8 * r),
                    },
                    0.7,
                ),
        )
    }
}
