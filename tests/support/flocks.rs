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

/// `n` agents of two flocking groups with view cones on `bounds` (60 x 40): the first sees its
/// own group within 4 in a narrow cone, the second every group within 3 in a wide one and also
/// seeks (30, 20) (a general plan, which reads the batch's sums per agent). The groups mix in
/// every cell, or with `halves` keep to the two halves of the world (cells of one group, and
/// mixed cells between). Every fifth agent rests, looking along its orientation; with
/// `own_speeds` every agent has a speed limit of its own (an output filed for the wrong agent
/// shows).
#[allow(dead_code)]
pub fn two_flocks(bounds: Bounds, halves: bool, n: usize, own_speeds: bool) -> World {
    let profile = |same_group: bool, view_cos: f32, r: f32, seek: bool| {
        let mut steering = SteeringProfile::default();
        if seek {
            steering = steering.with(
                Behaviour::Seek {
                    target: Target::Point(Vec2::new(30.0, 20.0)),
                    threshold: 0.0,
                },
                0.5,
            );
        }
        flocking_group(steering, same_group, view_cos, r)
    };
    let mut b = World::builder()
        .bounds(bounds)
        .seed(8)
        .group(profile(true, 0.3, 4.0, false))
        .group(profile(false, -0.6, 3.0, true));
    let mut rng = throng::rng::AgentRng::new(8, 0, 0, 5);
    for k in 0..n {
        let p = Vec2::new(rng.unit() * 60.0, rng.unit() * 40.0);
        let heading = rng.unit() * std::f32::consts::TAU;
        let speed = if k % 5 == 0 { 0.0 } else { 2.0 };
        let group = if halves {
            usize::from(p.x > 30.0)
        } else {
            k % 2
        };
        b = b.agent(AgentInit {
            velocity: Vec2::from_angle(heading) * speed,
            orientation: heading,
            max_speed: own_speeds.then_some(2.5 + (k % 4) as f32 * 0.5),
            ..AgentInit::at(p, group)
        });
    }
    b.build().unwrap()
}
