//! One step of each movement model equals the reference notes' update computed by hand, and the
//! limits hold for any behaviour mix (property test).

use proptest::prelude::*;
use throng::prelude::*;

#[test]
fn dynamic_step_matches_newton_euler_by_hand() {
    // Seek straight along +x from rest: force = desired - v = (max_speed, 0) - v.
    let target = Vec2::new(100.0, 0.0);
    let g = Profile {
        max_speed: 3.0,
        max_acceleration: 100.0,
        mass: 2.0,
        orientation: OrientationMode::Integrate,
        ..Profile::dynamic(SteeringProfile::single(Behaviour::Seek {
            target: Target::Point(target),
            threshold: 0.0,
        }))
    };
    let p0 = Vec2::new(1.0, 0.0);
    let v0 = Vec2::new(0.5, 0.0);
    let (o0, r0) = (0.25_f32, 0.5_f32);
    let mut w = World::builder()
        .group(g)
        .agent(AgentInit {
            position: p0,
            velocity: v0,
            orientation: o0,
            rotation: r0,
            ..AgentInit::default()
        })
        .build()
        .unwrap();
    let dt = 0.1_f32;
    w.step(dt).unwrap();
    let s = w.agent(AgentId(0)).unwrap();
    // By hand, in the notes' order.
    let force = Vec2::new(3.0, 0.0) - v0;
    let linear = force / 2.0;
    let position = p0 + v0 * dt;
    let orientation = o0 + r0 * dt;
    let mut velocity = v0 + linear * dt;
    if velocity.length() > 3.0 {
        velocity *= 3.0 / velocity.length();
    }
    let rotation = r0; // no angular steering
    assert_eq!(s.position, position);
    assert_eq!(s.velocity, velocity);
    assert!((s.orientation - orientation).abs() < 1e-6);
    assert_eq!(s.rotation, rotation);
}

#[test]
fn dynamic_speed_is_clamped_as_in_the_notes() {
    let g = Profile {
        max_speed: 1.0,
        max_acceleration: 1000.0,
        ..Profile::dynamic(SteeringProfile::single(Behaviour::Seek {
            target: Target::Point(Vec2::new(0.0, 50.0)),
            threshold: 0.0,
        }))
    };
    let mut w = World::builder()
        .group(g)
        .agent(AgentInit::at(Vec2::ZERO, 0))
        .build()
        .unwrap();
    w.step(0.5).unwrap();
    let s = w.agent(AgentId(0)).unwrap();
    // v = 0 + a * dt = (0, 1 - 0) / 1 * 0.5 ... a = force / mass = (0, 1): v = (0, 0.5), under the limit.
    assert_eq!(s.velocity, Vec2::new(0.0, 0.5));
    assert_eq!(
        s.position,
        Vec2::ZERO,
        "position moves by the pre-update velocity"
    );
    w.step(0.5).unwrap();
    let s = w.agent(AgentId(0)).unwrap();
    // force = (0, 1) - (0, 0.5) = (0, 0.5); v = 0.5 + 0.25 = 0.75.
    assert_eq!(s.velocity, Vec2::new(0.0, 0.75));
    assert_eq!(s.position, Vec2::new(0.0, 0.25));
}

#[test]
fn kinematic_step_matches_the_notes_by_hand() {
    // Kinematic seek: velocity = normalize(target - p) * max_speed; position += velocity * dt;
    // orientation from the new velocity.
    let target = Vec2::new(3.0, 4.0);
    let g = Profile {
        max_speed: 2.0,
        ..Profile::kinematic(SteeringProfile::single(Behaviour::Seek {
            target: Target::Point(target),
            threshold: 0.0,
        }))
    };
    let mut w = World::builder()
        .group(g)
        .agent(AgentInit::at(Vec2::ZERO, 0))
        .build()
        .unwrap();
    let dt = 0.2;
    w.step(dt).unwrap();
    let s = w.agent(AgentId(0)).unwrap();
    let v = target * (2.0 / 5.0);
    assert_eq!(s.velocity, v);
    assert_eq!(s.position, v * dt);
    assert!((s.orientation - 4.0_f32.atan2(3.0)).abs() < 1e-6);

    // Kinematic wander: velocity = max_speed * orientation vector; orientation += rotation * dt.
    let g = Profile {
        max_speed: 2.0,
        max_rotation: 1.5,
        orientation: OrientationMode::Integrate,
        ..Profile::kinematic(SteeringProfile::single(Behaviour::Wander {
            params: WanderParams::default(),
        }))
    };
    let o0 = 0.75_f32;
    let mut w = World::builder()
        .group(g)
        .agent(AgentInit {
            orientation: o0,
            ..AgentInit::default()
        })
        .build()
        .unwrap();
    w.step(dt).unwrap();
    let s = w.agent(AgentId(0)).unwrap();
    assert_eq!(s.velocity, Vec2::new(o0.cos(), o0.sin()) * 2.0);
    assert!(s.rotation.abs() <= 1.5);
    assert!((s.orientation - (o0 + s.rotation * dt)).abs() < 1e-6);
}

#[test]
fn drag_slows_a_coasting_agent() {
    let g = Profile {
        drag: 0.5,
        ..Profile::dynamic(SteeringProfile::default())
    };
    let mut w = World::builder()
        .group(g)
        .agent(AgentInit {
            velocity: Vec2::new(1.0, 0.0),
            ..AgentInit::default()
        })
        .build()
        .unwrap();
    w.step(0.1).unwrap();
    assert_eq!(w.agent(AgentId(0)).unwrap().velocity, Vec2::new(0.95, 0.0));
}

fn behaviour_strategy() -> impl Strategy<Value = Behaviour> {
    let point =
        (-50.0_f32..50.0, -50.0_f32..50.0).prop_map(|(x, y)| Target::Point(Vec2::new(x, y)));
    let agent = (0_u32..6).prop_map(|i| Target::Agent(AgentId(i)));
    let target = prop_oneof![point, agent];
    prop_oneof![
        (target.clone(), 0.0_f32..2.0)
            .prop_map(|(target, threshold)| Behaviour::Seek { target, threshold }),
        (target.clone(), 1.0_f32..100.0).prop_map(|(target, panic_distance)| Behaviour::Flee {
            target,
            panic_distance
        }),
        target.clone().prop_map(|target| Behaviour::Arrive {
            target,
            params: ArriveParams::default()
        }),
        Just(Behaviour::Wander {
            params: WanderParams::default()
        }),
        target.clone().prop_map(|target| Behaviour::Pursue {
            target,
            max_prediction: 1.0
        }),
        target.clone().prop_map(|target| Behaviour::Evade {
            target,
            max_prediction: 1.0,
            panic_distance: f32::INFINITY
        }),
        target.prop_map(|target| Behaviour::MatchVelocity {
            target,
            time_to_target: 0.1
        }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn speed_and_acceleration_never_exceed_their_limits(
        behaviours in prop::collection::vec((behaviour_strategy(), -2.0_f32..4.0), 1..4),
        priority in any::<bool>(),
        kinematic in any::<bool>(),
        max_speed in 0.5_f32..10.0,
        max_acceleration in 0.5_f32..20.0,
        mass in 0.1_f32..5.0,
        starts in prop::collection::vec((-40.0_f32..40.0, -40.0_f32..40.0, -5.0_f32..5.0, -5.0_f32..5.0), 6),
    ) {
        let profile = SteeringProfile {
            behaviours: behaviours.into_iter().map(|(b, w)| Weighted::new(b, w)).collect(),
            combine: if priority { Combine::Priority } else { Combine::WeightedSum },
        };
        let g = Profile {
            model: if kinematic { MovementModel::Kinematic } else { MovementModel::Dynamic },
            max_speed, max_acceleration, mass, steering: profile, ..Profile::default()
        };
        let agents = starts.iter().map(|&(x, y, vx, vy)| AgentInit {
            position: Vec2::new(x, y),
            velocity: Vec2::new(vx, vy).clamp_length_max(max_speed),
            ..AgentInit::default()
        });
        let mut w = World::builder().seed(3).group(g).agents(agents).build().unwrap();
        let dt = 0.05;
        for _ in 0..40 {
            let before: Vec<Vec2> = (0..w.len()).map(|i| w.agents().velocity(i)).collect();
            w.step(dt).unwrap();
            for (i, v0) in before.iter().enumerate() {
                let v = w.agents().velocity(i);
                prop_assert!(v.is_finite());
                prop_assert!(v.length() <= max_speed * (1.0 + 1e-5), "speed {} > {}", v.length(), max_speed);
                if !kinematic {
                    let acc = (v - *v0).length() / dt;
                    prop_assert!(acc <= max_acceleration * (1.0 + 1e-3) + 1e-3, "acceleration {} > {}", acc, max_acceleration);
                }
            }
        }
    }
}
