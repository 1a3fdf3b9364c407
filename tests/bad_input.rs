//! Every kind of bad value gets its own error variant, and nothing invalid enters the world.

use throng::prelude::*;

fn world() -> World {
    World::builder()
        .bounds(Bounds::bounded(10.0, 10.0).unwrap())
        .group(Profile::default())
        .agent(AgentInit::at(Vec2::new(1.0, 1.0), 0))
        .build()
        .unwrap()
}

#[test]
fn nan_and_infinite_numbers_are_rejected() {
    let mut w = world();
    let err = w
        .add_agent(AgentInit::at(Vec2::new(f32::NAN, 1.0), 0))
        .unwrap_err();
    assert!(
        matches!(
            err,
            Error::NonFinite {
                name: "position",
                ..
            }
        ),
        "{err}"
    );
    let err = w
        .add_agent(AgentInit {
            velocity: Vec2::new(0.0, f32::INFINITY),
            ..AgentInit::at(Vec2::ONE, 0)
        })
        .unwrap_err();
    assert!(
        matches!(
            err,
            Error::NonFinite {
                name: "velocity",
                ..
            }
        ),
        "{err}"
    );
    let err = w
        .set_target(AgentId(0), Vec2::new(f32::NEG_INFINITY, 0.0))
        .unwrap_err();
    assert!(matches!(err, Error::NonFinite { .. }));
    let g = Profile {
        max_speed: f32::NAN,
        ..Profile::default()
    };
    assert!(matches!(
        w.add_group(g),
        Err(Error::NonFinite {
            name: "max_speed",
            ..
        })
    ));
    let seek = SteeringProfile::single(Behaviour::Seek {
        target: Target::Point(Vec2::new(f32::NAN, 0.0)),
        threshold: 0.0,
    });
    assert!(matches!(
        w.add_group(Profile::dynamic(seek)),
        Err(Error::NonFinite { name: "target", .. })
    ));
    assert_eq!(w.len(), 1, "nothing was added");
}

#[test]
fn negative_radii_and_distances_are_rejected() {
    let mut w = world();
    let g = Profile {
        radius: -1.0,
        ..Profile::default()
    };
    let err = w.add_group(g).unwrap_err();
    assert!(
        matches!(err, Error::Negative { name: "radius", .. }),
        "{err}"
    );
    assert!(
        err.to_string().contains("radius") && err.to_string().contains("-1"),
        "message names parameter and value: {err}"
    );
    let err = w
        .add_agent(AgentInit {
            radius: Some(-0.5),
            ..AgentInit::at(Vec2::ONE, 0)
        })
        .unwrap_err();
    assert!(matches!(err, Error::Negative { name: "radius", .. }));
    let flee = SteeringProfile::single(Behaviour::Flee {
        target: Target::Point(Vec2::ZERO),
        panic_distance: -3.0,
    });
    assert!(matches!(
        w.add_group(Profile::dynamic(flee)),
        Err(Error::Negative {
            name: "flee.panic_distance",
            ..
        })
    ));
}

#[test]
fn zero_or_negative_limits_are_rejected() {
    let mut w = world();
    assert!(matches!(
        w.add_group(Profile {
            max_speed: 0.0,
            ..Profile::default()
        }),
        Err(Error::NotPositive {
            name: "max_speed",
            ..
        })
    ));
    assert!(matches!(
        w.add_group(Profile {
            max_acceleration: -1.0,
            ..Profile::default()
        }),
        Err(Error::NotPositive {
            name: "max_acceleration",
            ..
        })
    ));
    assert!(matches!(
        w.set_max_speed(AgentId(0), -2.0),
        Err(Error::NotPositive { .. })
    ));
    assert!(matches!(
        Bounds::torus(-5.0, 5.0),
        Err(Error::NotPositive { .. })
    ));
}

#[test]
fn zero_mass_is_rejected() {
    let mut w = world();
    assert!(matches!(
        w.add_group(Profile {
            mass: 0.0,
            ..Profile::default()
        }),
        Err(Error::ZeroMass { .. })
    ));
    let err = World::builder()
        .group(Profile {
            mass: -1.0,
            ..Profile::default()
        })
        .build()
        .unwrap_err();
    assert!(matches!(err, Error::ZeroMass { .. }), "{err}");
}

#[test]
fn non_positive_time_steps_are_rejected_and_change_nothing() {
    let mut w = world();
    for dt in [0.0, -0.1, f32::NAN, f32::INFINITY] {
        let err = w.step(dt).unwrap_err();
        assert!(matches!(err, Error::InvalidTimeStep { .. }), "{err}");
    }
    assert_eq!(w.frame(), 0);
}

#[test]
fn unknown_ids_and_groups_are_rejected() {
    let mut w = world();
    assert!(matches!(
        w.remove_agent(AgentId(7)),
        Err(Error::UnknownAgent { id: AgentId(7) })
    ));
    w.remove_agent(AgentId(0)).unwrap();
    assert!(
        matches!(
            w.set_position(AgentId(0), Vec2::ONE),
            Err(Error::UnknownAgent { .. })
        ),
        "a removed id stays unknown"
    );
    assert!(matches!(
        w.add_agent(AgentInit::at(Vec2::ONE, 3)),
        Err(Error::UnknownGroup { group: 3, count: 1 })
    ));
    assert!(matches!(
        w.set_group_params(9, Profile::default()),
        Err(Error::UnknownGroup { .. })
    ));
}

#[test]
fn positions_outside_the_world_are_rejected() {
    let mut w = world();
    let err = w
        .add_agent(AgentInit::at(Vec2::new(11.0, 1.0), 0))
        .unwrap_err();
    assert!(matches!(err, Error::Invalid { .. }), "{err}");
    assert_eq!(w.len(), 1);
}

#[test]
fn bad_behaviour_parameters_are_rejected() {
    let mut w = world();
    let arrive = SteeringProfile::single(Behaviour::Arrive {
        target: Target::Own,
        params: ArriveParams {
            time_to_target: 0.0,
            ..ArriveParams::default()
        },
    });
    assert!(matches!(
        w.add_group(Profile::dynamic(arrive)),
        Err(Error::NotPositive {
            name: "arrive.time_to_target",
            ..
        })
    ));
    let weight = SteeringProfile {
        behaviours: vec![Weighted::new(
            Behaviour::Wander {
                params: WanderParams::default(),
            },
            f32::NAN,
        )],
        combine: Combine::WeightedSum,
    };
    assert!(matches!(
        w.add_group(Profile::dynamic(weight)),
        Err(Error::NonFinite { name: "weight", .. })
    ));
}

/// `set_group_params` on a built world took a profile naming a field the world does not have,
/// and every later step failed; now the call is refused and the world steps on.
#[test]
fn set_group_params_refuses_a_field_or_group_the_world_does_not_have() {
    let mut w = world();
    for behaviour in [
        Behaviour::FollowField {
            field: 3,
            channel: 0,
        },
        Behaviour::Seek {
            target: Target::Nearest {
                group: 7,
                within: 1.0,
            },
            threshold: 0.0,
        },
    ] {
        let p = Profile::dynamic(SteeringProfile::single(behaviour));
        let err = w.set_group_params(0, p).unwrap_err();
        assert!(
            matches!(err, Error::UnknownField { .. } | Error::UnknownGroup { .. }),
            "{err}"
        );
    }
    w.step(0.1).unwrap();
    assert_eq!(w.frame(), 1);
}

/// A group added to a built world is checked as `set_group_params` checks one: a profile
/// naming a field the world does not have is refused before the group is added.
#[test]
fn check_group_params_refuses_a_field_the_world_does_not_have() {
    let w = world();
    let p = Profile::dynamic(SteeringProfile::single(Behaviour::FollowField {
        field: 3,
        channel: 0,
    }));
    let err = w.check_group_params(&p).unwrap_err();
    assert!(matches!(err, Error::UnknownField { .. }), "{err}");
    let seek_own_group = Profile::dynamic(SteeringProfile::single(Behaviour::Seek {
        target: Target::Nearest {
            group: w.groups().len(),
            within: 1.0,
        },
        threshold: 0.0,
    }));
    w.check_group_params(&seek_own_group).unwrap();
}

/// `World::add_group` took a profile naming a field the world does not have, and the error only
/// showed at the first step; now the call is refused, naming the field, and the world steps on.
#[test]
fn add_group_refuses_a_field_the_world_does_not_have() {
    let mut w = world();
    let groups = w.groups().len();
    let follow = Profile::dynamic(SteeringProfile::single(Behaviour::FollowField {
        field: 3,
        channel: 1,
    }));
    let err = w.add_group(follow).unwrap_err();
    assert!(
        matches!(
            err,
            Error::UnknownField {
                group: 1,
                field: 3,
                channel: 1,
                fields: 0,
            }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("field 3"), "{err}");
    let choose = Profile::dynamic(SteeringProfile::single(Behaviour::ChooseExit {
        field: 0,
        channels: throng::steering::ChannelSet::ALL,
        switch_gain: 0.25,
    }));
    let err = w.add_group(choose).unwrap_err();
    assert!(matches!(err, Error::UnknownField { field: 0, .. }), "{err}");
    assert_eq!(w.groups().len(), groups, "nothing was added");
    w.step(0.1).unwrap();

    // A group may still name a group added after it, as a scenario's groups do.
    let ahead = Profile::dynamic(SteeringProfile::single(Behaviour::Seek {
        target: Target::Nearest {
            group: groups + 1,
            within: 1.0,
        },
        threshold: 0.0,
    }));
    w.add_group(ahead).unwrap();
    w.add_group(Profile::default()).unwrap();
    w.step(0.1).unwrap();
}

#[test]
fn references_to_missing_fields_and_groups_are_rejected_at_the_step() {
    let follow = SteeringProfile::single(Behaviour::FollowField {
        field: 0,
        channel: 2,
    });
    let mut w = World::builder()
        .group(Profile::dynamic(follow))
        .agent(AgentInit::default())
        .build()
        .unwrap();
    let err = w.step(0.1).unwrap_err();
    assert!(
        matches!(
            err,
            Error::UnknownField {
                group: 0,
                field: 0,
                channel: 2,
                fields: 0
            }
        ) && err.to_string().contains("field 0 channel 2"),
        "{err}"
    );
    assert_eq!(w.frame(), 0, "nothing stepped");

    let hunt = SteeringProfile::single(Behaviour::Seek {
        target: Target::Nearest {
            group: 5,
            within: 10.0,
        },
        threshold: 0.0,
    });
    let mut w = World::builder()
        .group(Profile::dynamic(hunt))
        .agent(AgentInit::default())
        .build()
        .unwrap();
    assert!(matches!(
        w.step(0.1),
        Err(Error::UnknownGroup { group: 5, count: 1 })
    ));
}

#[test]
fn extreme_but_valid_values_keep_the_buffers_finite() {
    // A repelling point almost exactly on an agent (an overflowing force), a tiny mass, an
    // attracting point at the same spot for a kinematic group, and the largest time step.
    use throng::gravity::GravityPoint;
    let push = Profile {
        mass: 1e-30,
        ..Profile::dynamic(SteeringProfile::single(Behaviour::AntiGravity))
    };
    let pull = Profile::kinematic(SteeringProfile::single(Behaviour::AntiGravity));
    let mut w = World::builder()
        .group(push)
        .group(pull)
        .agent(AgentInit::at(Vec2::new(1.0, 1.0), 0))
        .agent(AgentInit::at(Vec2::new(1.0, 1.0), 1))
        .build()
        .unwrap();
    w.add_gravity_point(GravityPoint::fixed(
        Vec2::new(1.0 + 1e-7, 1.0),
        1e30,
        8.0,
        10.0,
    ))
    .unwrap();
    w.add_gravity_point(GravityPoint::fixed(
        Vec2::new(1.0 - 1e-7, 1.0),
        -1e30,
        8.0,
        10.0,
    ))
    .unwrap();
    for dt in [1e-6, 0.1, 1e6] {
        w.step(dt).unwrap();
        let a = w.agents();
        for s in [
            a.pos_x(),
            a.pos_y(),
            a.vel_x(),
            a.vel_y(),
            a.orientations(),
            a.rotations(),
        ] {
            assert!(s.iter().all(|v| v.is_finite()), "dt {dt}: {s:?}");
        }
    }
    assert!(
        matches!(w.step(2e6), Err(Error::InvalidTimeStep { .. })),
        "beyond the largest dt"
    );
    assert!(matches!(
        w.add_group(Profile {
            max_speed: 1e20,
            ..Profile::default()
        }),
        Err(Error::OutOfRange {
            name: "max_speed",
            ..
        })
    ));
    assert!(matches!(
        w.add_agent(AgentInit::at(Vec2::new(3e38, 0.0), 0)),
        Err(Error::OutOfRange { .. })
    ));
    assert!(matches!(
        Bounds::torus(1e35, 1.0),
        Err(Error::OutOfRange { .. })
    ));
}

#[test]
fn huge_weights_saturate_instead_of_vanishing_or_turning_nan() {
    // Weighted requests whose squares overflow keep their direction at the limit.
    let profile = SteeringProfile::single(Behaviour::Seek {
        target: Target::Point(Vec2::new(10.0, 0.0)),
        threshold: 0.0,
    });
    let profile = SteeringProfile {
        behaviours: vec![Weighted::new(profile.behaviours[0].behaviour.clone(), 3e38)],
        ..profile
    };
    for g in [
        Profile::dynamic(profile.clone()),
        Profile::kinematic(profile),
    ] {
        let mut w = World::builder()
            .group(g)
            .agent(AgentInit::default())
            .build()
            .unwrap();
        for _ in 0..5 {
            w.step(0.1).unwrap();
        }
        let s = w.agent(AgentId(0)).unwrap();
        assert!(s.position.is_finite() && s.velocity.is_finite());
        assert!(
            s.velocity.x > 1.0 && s.velocity.y.abs() < 1e-3,
            "moving towards the target at speed: {:?}",
            s.velocity
        );
    }
}

#[test]
fn truncate_robust_keeps_direction_and_drops_nan() {
    use throng::steering::truncate_robust;
    assert_eq!(
        truncate_robust(Vec2::new(f32::INFINITY, 0.0), 2.0),
        Vec2::new(2.0, 0.0)
    );
    assert_eq!(truncate_robust(Vec2::new(f32::NAN, 1.0), 2.0), Vec2::ZERO);
    let big = truncate_robust(Vec2::new(3e38, 3e38), 1.0);
    assert!((big.length() - 1.0).abs() < 1e-6 && big.x > 0.0 && (big.x - big.y).abs() < 1e-6);
    assert_eq!(
        truncate_robust(Vec2::new(3.0, 4.0), 10.0),
        Vec2::new(3.0, 4.0)
    );
}
