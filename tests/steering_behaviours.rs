//! Single-agent behaviours reach, flee, catch and wander as the reference notes say they should.

use throng::prelude::*;

const DT: f32 = 1.0 / 30.0;

fn group(model: MovementModel, steering: SteeringProfile) -> Profile {
    Profile {
        model,
        max_speed: 5.0,
        max_acceleration: 10.0,
        steering,
        ..Profile::default()
    }
}

fn open_world(groups: Vec<Profile>, agents: Vec<AgentInit>) -> World {
    let mut b = World::builder().seed(11);
    for g in groups {
        b = b.group(g);
    }
    b.agents(agents).build().unwrap()
}

fn pos(w: &World, id: AgentId) -> Vec2 {
    w.agent(id).unwrap().position
}

#[test]
fn seek_reaches_a_static_target_in_both_models() {
    let target = Vec2::new(40.0, -25.0);
    for model in [MovementModel::Dynamic, MovementModel::Kinematic] {
        let seek = SteeringProfile::single(Behaviour::Seek {
            target: Target::Point(target),
            threshold: 0.1,
        });
        let mut w = open_world(
            vec![group(model, seek)],
            vec![AgentInit::at(Vec2::new(-10.0, 5.0), 0)],
        );
        let id = w.agents().id(0);
        let mut best = f32::INFINITY;
        for _ in 0..1000 {
            w.step(DT).unwrap();
            best = best.min(pos(&w, id).distance(target));
        }
        assert!(best < 0.5, "{model:?}: closest approach {best}");
    }
}

#[test]
fn arrive_stops_inside_the_radius_without_overshoot_or_jitter() {
    let target = Vec2::new(30.0, 20.0);
    let start = Vec2::new(0.0, 0.0);
    let approach = (target - start).normalize();
    let params = ArriveParams {
        target_radius: 0.25,
        slow_radius: 4.0,
        time_to_target: 0.1,
    };
    for model in [MovementModel::Dynamic, MovementModel::Kinematic] {
        let arrive = SteeringProfile::single(Behaviour::Arrive {
            target: Target::Point(target),
            params,
        });
        let mut w = open_world(vec![group(model, arrive)], vec![AgentInit::at(start, 0)]);
        let id = w.agents().id(0);
        let mut max_overshoot = f32::NEG_INFINITY;
        for _ in 0..600 {
            w.step(DT).unwrap();
            max_overshoot = max_overshoot.max((pos(&w, id) - target).dot(approach));
        }
        let rest = pos(&w, id);
        assert!(
            rest.distance(target) <= params.target_radius,
            "{model:?}: rests at {rest}, {} away",
            rest.distance(target)
        );
        assert!(
            max_overshoot <= 0.05,
            "{model:?}: overshot the target by {max_overshoot}"
        );
        for _ in 0..200 {
            w.step(DT).unwrap();
            let s = w.agent(id).unwrap();
            assert!(
                s.velocity.length() < 1e-3,
                "{model:?}: moving at {} while at rest",
                s.velocity.length()
            );
            assert!(
                s.position.distance(rest) < 1e-3,
                "{model:?}: drifted from {rest} to {}",
                s.position
            );
        }
        // At rest means zero, not a speed decaying into subnormal numbers.
        let s = w.agent(id).unwrap();
        assert_eq!(s.velocity, Vec2::ZERO, "{model:?}");
    }
}

#[test]
fn flee_acts_only_inside_the_panic_distance() {
    let threat = Vec2::ZERO;
    for model in [MovementModel::Dynamic, MovementModel::Kinematic] {
        let flee = SteeringProfile::single(Behaviour::Flee {
            target: Target::Point(threat),
            panic_distance: 10.0,
        });
        let mut w = open_world(
            vec![group(model, flee)],
            vec![
                AgentInit::at(Vec2::new(3.0, 4.0), 0),
                AgentInit::at(Vec2::new(30.0, 0.0), 0),
            ],
        );
        let (near, far) = (w.agents().id(0), w.agents().id(1));
        let mut last = pos(&w, near).length();
        let mut steps = 0;
        while last < 9.5 {
            w.step(DT).unwrap();
            steps += 1;
            let d = pos(&w, near).length();
            // The dynamic model moves by the pre-update velocity, so its first step starts from rest.
            let grew = if model == MovementModel::Dynamic && steps == 1 {
                d >= last
            } else {
                d > last
            };
            assert!(grew, "{model:?}: distance went from {last} to {d}");
            last = d;
            assert_eq!(
                pos(&w, far),
                Vec2::new(30.0, 0.0),
                "{model:?}: an agent outside the panic distance moved"
            );
        }
    }
}

/// Steps until the chaser is within 0.5 of the runner; returns the number of steps.
fn steps_to_catch(chase: Behaviour) -> usize {
    let runner = group(
        MovementModel::Kinematic,
        SteeringProfile::single(Behaviour::Seek {
            target: Target::Point(Vec2::new(1e6, 0.0)),
            threshold: 0.0,
        }),
    );
    let runner = Profile {
        max_speed: 3.0,
        ..runner
    };
    let chaser = group(MovementModel::Dynamic, SteeringProfile::single(chase));
    let mut w = open_world(
        vec![runner, chaser],
        vec![
            AgentInit::at(Vec2::new(0.0, 20.0), 0),
            AgentInit::at(Vec2::new(0.0, 0.0), 1),
        ],
    );
    let (r, c) = (w.agents().id(0), w.agents().id(1));
    for step in 1..5000 {
        w.step(DT).unwrap();
        if pos(&w, r).distance(pos(&w, c)) < 0.5 {
            return step;
        }
    }
    usize::MAX
}

#[test]
fn pursue_catches_a_straight_runner_sooner_than_seek() {
    let runner = AgentId(0);
    let pursue = steps_to_catch(Behaviour::Pursue {
        target: Target::Agent(runner),
        max_prediction: 2.0,
    });
    let seek = steps_to_catch(Behaviour::Seek {
        target: Target::Agent(runner),
        threshold: 0.0,
    });
    assert!(pursue < usize::MAX, "pursue never caught the runner");
    assert!(pursue < seek, "pursue took {pursue} steps, seek {seek}");
}

#[test]
fn evade_keeps_the_distance_growing_against_an_equal_pursuer() {
    let chaser_id = AgentId(1);
    let runner_id = AgentId(0);
    let evade = group(
        MovementModel::Dynamic,
        SteeringProfile::single(Behaviour::Evade {
            target: Target::Agent(chaser_id),
            max_prediction: 1.0,
            panic_distance: f32::INFINITY,
        }),
    );
    let pursue = group(
        MovementModel::Dynamic,
        SteeringProfile::single(Behaviour::Pursue {
            target: Target::Agent(runner_id),
            max_prediction: 1.0,
        }),
    );
    // The pursuer starts at full speed, but across the line to the runner, so it has to turn.
    let chaser = AgentInit {
        velocity: Vec2::new(0.0, 5.0),
        ..AgentInit::at(Vec2::ZERO, 1)
    };
    let mut w = open_world(
        vec![evade, pursue],
        vec![AgentInit::at(Vec2::new(6.0, 0.0), 0), chaser],
    );
    let start = pos(&w, runner_id).distance(pos(&w, chaser_id));
    let mut min = start;
    let mut last = start;
    for _ in 0..600 {
        w.step(DT).unwrap();
        last = pos(&w, runner_id).distance(pos(&w, chaser_id));
        min = min.min(last);
    }
    // Equal top speeds: once both run flat out the gap holds; it must never close meanwhile.
    assert!(
        min > 0.8 * start,
        "the pursuer closed in to {min} from {start}"
    );
    assert!(last > start, "distance {start} -> {last}");
}

#[test]
fn wander_holds_max_speed_and_turns() {
    // Kinematic: the random-binomial form of the notes (orientation integrates the rotation).
    let kin = Profile {
        orientation: OrientationMode::Integrate,
        max_rotation: 2.0,
        ..group(
            MovementModel::Kinematic,
            SteeringProfile::single(Behaviour::Wander {
                params: WanderParams::default(),
            }),
        )
    };
    // Dynamic: Reynolds' wander circle.
    let dynamic = group(
        MovementModel::Dynamic,
        SteeringProfile::single(Behaviour::Wander {
            params: WanderParams::default(),
        }),
    );
    let mut w = open_world(
        vec![kin, dynamic],
        vec![
            AgentInit::at(Vec2::ZERO, 0),
            AgentInit {
                velocity: Vec2::new(5.0, 0.0),
                ..AgentInit::at(Vec2::ZERO, 1)
            },
        ],
    );
    let (k, d) = (w.agents().id(0), w.agents().id(1));
    let (mut k_turn, mut d_min_dir, mut d_max_dir) = (0.0_f32, f32::INFINITY, f32::NEG_INFINITY);
    let mut k_last = w.agent(k).unwrap().orientation;
    for step in 0..600 {
        w.step(DT).unwrap();
        let ks = w.agent(k).unwrap();
        assert!(
            (ks.velocity.length() - 5.0).abs() < 1e-4,
            "kinematic wander speed {}",
            ks.velocity.length()
        );
        k_turn += throng::steering::wrap_angle(ks.orientation - k_last).abs();
        k_last = ks.orientation;
        let ds = w.agent(d).unwrap();
        if step > 60 {
            assert!(
                ds.velocity.length() > 0.9 * 5.0,
                "dynamic wander slowed to {}",
                ds.velocity.length()
            );
        }
        let dir = ds.velocity.y.atan2(ds.velocity.x);
        d_min_dir = d_min_dir.min(dir);
        d_max_dir = d_max_dir.max(dir);
    }
    assert!(k_turn > 1.0, "kinematic wander turned only {k_turn} rad");
    assert!(
        d_max_dir - d_min_dir > 0.5,
        "dynamic wander heading spanned only {} rad",
        d_max_dir - d_min_dir
    );
}

#[test]
fn face_turns_towards_the_target() {
    let face = Profile {
        orientation: OrientationMode::Integrate,
        ..group(
            MovementModel::Dynamic,
            SteeringProfile::single(Behaviour::Face {
                target: Target::Point(Vec2::new(0.0, 10.0)),
                params: Default::default(),
            }),
        )
    };
    let mut w = open_world(vec![face], vec![AgentInit::at(Vec2::ZERO, 0)]);
    for _ in 0..300 {
        w.step(DT).unwrap();
    }
    let o = w.agents().orientations()[0];
    assert!(
        (o - std::f32::consts::FRAC_PI_2).abs() < 0.02,
        "orientation {o}"
    );
}

/// Runs 203 agents of one group steering by `behaviour` alone (a lane plan) or with an
/// angular-only extra behaviour (the general loop) for 60 steps, in both models, on a torus and
/// in a walled world, and asserts the same bits of every position and velocity.
fn assert_lane_plan_equals_the_general_loop(behaviour: Behaviour) {
    let extra = Behaviour::LookWhereYouAreGoing {
        params: Default::default(),
    };
    assert_plan_equals_the_general_loop(behaviour, (extra, 1.0), OrientationMode::FaceVelocity);
}

/// As [`assert_lane_plan_equals_the_general_loop`], with `extra` (a behaviour and its weight)
/// beside `behaviour` to send it through the general loop, and kinematic agents orienting
/// themselves by `kinematic_orientation`.
fn assert_plan_equals_the_general_loop(
    behaviour: Behaviour,
    extra: (Behaviour, f32),
    kinematic_orientation: OrientationMode,
) {
    for bounds in [
        Bounds::bounded(80.0, 60.0).unwrap(),
        Bounds::torus(80.0, 60.0).unwrap(),
    ] {
        for model in [MovementModel::Dynamic, MovementModel::Kinematic] {
            let run = |general: bool| {
                let mut profile = SteeringProfile::single(behaviour.clone());
                if general {
                    profile = profile.with(extra.0.clone(), extra.1);
                }
                let orientation = match model {
                    MovementModel::Kinematic => kinematic_orientation,
                    MovementModel::Dynamic => OrientationMode::FaceVelocity,
                };
                let g = Profile {
                    model,
                    orientation,
                    max_speed: 6.0,
                    max_acceleration: 9.0,
                    mass: 1.5,
                    ..Profile::dynamic(profile)
                };
                // A looping path for behaviours that follow one: 30 points on an ellipse,
                // enough segments for the projection's grid of candidates.
                let ellipse = (0..30).map(|k| {
                    let a = k as f32 * std::f32::consts::TAU / 30.0;
                    Vec2::new(40.0 + 30.0 * a.cos(), 30.0 + 20.0 * a.sin())
                });
                let path = throng::group::Path::new(ellipse.collect(), 3.0, true).unwrap();
                let mut b = World::builder().bounds(bounds).seed(4).group(g).path(path);
                let mut rng = throng::rng::AgentRng::new(4, 0, 0, 3);
                for k in 0..203 {
                    let p = Vec2::new(rng.unit() * 80.0, rng.unit() * 60.0);
                    // Every tenth agent starts at rest: the lane plans leave it to the scalar
                    // path where the behaviour has no heading.
                    let speed = if k % 10 == 0 { 0.0 } else { 3.0 };
                    b = b.agent(AgentInit {
                        velocity: Vec2::new(rng.signed(), rng.signed()) * speed,
                        orientation: rng.signed() * 4.0,
                        ..AgentInit::at(p, 0)
                    });
                }
                let mut w = b.build().unwrap();
                // Every agent's own target, for behaviours that name it.
                for i in 0..w.len() {
                    let t = Vec2::new(rng.unit() * 80.0, rng.unit() * 60.0);
                    w.set_target(w.agents().id(i), t).unwrap();
                }
                for _ in 0..60 {
                    w.step(1.0 / 30.0).unwrap();
                }
                // The fast plan of a lone behaviour bears the behaviour's name.
                let ran = if general { "general" } else { behaviour.name() };
                assert_eq!(w.last_plans(), [ran], "the plan that ran");
                (0..w.len())
                    .map(|i| {
                        let s = w.agent(w.agents().id(i)).unwrap();
                        (
                            s.id,
                            s.position.to_array().map(f32::to_bits),
                            s.velocity.to_array().map(f32::to_bits),
                            s.orientation.to_bits(),
                        )
                    })
                    .collect::<std::collections::BTreeSet<_>>()
            };
            assert!(
                run(false) == run(true),
                "{behaviour:?} {bounds:?} {model:?}"
            );
        }
    }
}

#[test]
fn the_seek_plan_in_lanes_equals_the_general_loop_bit_for_bit() {
    // A lone seek of a point runs eight agents at a time in lanes; with an angular-only extra
    // behaviour the same seek goes through the general loop.
    assert_lane_plan_equals_the_general_loop(Behaviour::Seek {
        target: Target::Point(Vec2::new(70.0, 5.0)),
        threshold: 2.0,
    });
}

#[test]
fn the_arrive_plan_in_lanes_equals_the_general_loop_bit_for_bit() {
    // Slow radius and target radius both reached within the 60 steps by part of the crowd.
    assert_lane_plan_equals_the_general_loop(Behaviour::Arrive {
        target: Target::Point(Vec2::new(70.0, 5.0)),
        params: ArriveParams {
            target_radius: 1.0,
            slow_radius: 25.0,
            time_to_target: 0.3,
        },
    });
}

#[test]
fn the_arrive_plan_in_lanes_equals_the_general_loop_when_the_slowed_velocity_overflows() {
    // A time to target so short that offset / time overflows inside the slow radius: the
    // kinematic lanes hand those agents to `kinematic_arrive`, whose truncation then takes its
    // robust way (the velocity's direction at full speed).
    assert_lane_plan_equals_the_general_loop(Behaviour::Arrive {
        target: Target::Point(Vec2::new(70.0, 5.0)),
        params: ArriveParams {
            target_radius: 1.0,
            slow_radius: 1e6,
            time_to_target: 1e-38,
        },
    });
}

#[test]
fn the_lane_plans_of_each_agents_own_target_equal_the_general_loop_bit_for_bit() {
    // Seek and arrive of `Target::Own` run in lanes with a target per lane.
    assert_lane_plan_equals_the_general_loop(Behaviour::Seek {
        target: Target::Own,
        threshold: 2.0,
    });
    assert_lane_plan_equals_the_general_loop(Behaviour::Arrive {
        target: Target::Own,
        params: ArriveParams {
            target_radius: 1.0,
            slow_radius: 25.0,
            time_to_target: 0.3,
        },
    });
}

#[test]
fn the_wander_plan_equals_the_general_loop_bit_for_bit() {
    // A lone wander runs without the general loop's dispatch. A seek of weight 0 beside it sends
    // the same wander through the general loop (it draws nothing and adds zeros), so both runs
    // draw the same numbers and turn the same way, kinematic orientations included.
    let seek = Behaviour::Seek {
        target: Target::Point(Vec2::new(70.0, 5.0)),
        threshold: 0.0,
    };
    assert_plan_equals_the_general_loop(
        Behaviour::Wander {
            params: WanderParams {
                radius: 2.0,
                distance: 4.0,
                jitter: 6.0,
            },
        },
        (seek, 0.0),
        // Kinematic wander turns its agents.
        OrientationMode::Integrate,
    );
}

#[test]
fn the_follow_path_plan_equals_the_general_loop_bit_for_bit() {
    // A lone follow_path runs without the general loop's dispatch; half the agents go each
    // way, and those beyond the path's radius seek a point ahead.
    assert_lane_plan_equals_the_general_loop(Behaviour::FollowPath {
        path: throng::group::PathId(0),
        params: throng::group::PathFollowParams {
            predict_time: 0.4,
            lead_distance: 5.0,
            direction: throng::group::PathDirection::Alternate,
            time_to_target: 0.3,
        },
    });
}

#[test]
fn lane_plans_of_interleaved_groups_equal_the_general_loop_bit_for_bit() {
    // Three seek and arrive groups (a point, each agent's own target, a target slot) whose
    // agents alternate in storage order, so that every run of one group breaks off inside a
    // block of lanes; with an angular-only extra behaviour each goes through the general loop.
    let behaviours = [
        Behaviour::Seek {
            target: Target::Point(Vec2::new(70.0, 5.0)),
            threshold: 2.0,
        },
        Behaviour::Arrive {
            target: Target::Own,
            params: ArriveParams {
                target_radius: 1.0,
                slow_radius: 25.0,
                time_to_target: 0.3,
            },
        },
        Behaviour::seek(Target::Own),
    ];
    let pattern = [
        0usize, 0, 0, 1, 0, 2, 2, 0, 1, 1, 2, 2, 2, 2, 2, 2, 2, 2, 2, 0,
    ];
    for bounds in [
        Bounds::bounded(80.0, 60.0).unwrap(),
        Bounds::torus(80.0, 60.0).unwrap(),
    ] {
        for model in [MovementModel::Dynamic, MovementModel::Kinematic] {
            let run = |general: bool| {
                let mut w = World::builder().bounds(bounds).seed(9).build().unwrap();
                let slot = w.add_target(Vec2::new(10.0, 50.0)).unwrap();
                for (g, b) in behaviours.iter().enumerate() {
                    // The third group seeks the slot.
                    let b = if g == 2 {
                        Behaviour::seek(Target::Slot(slot))
                    } else {
                        b.clone()
                    };
                    let mut profile = SteeringProfile::single(b);
                    if general {
                        let look = Behaviour::LookWhereYouAreGoing {
                            params: Default::default(),
                        };
                        profile = profile.with(look, 1.0);
                    }
                    let params = Profile {
                        model,
                        max_speed: 6.0,
                        max_acceleration: 9.0,
                        ..Profile::dynamic(profile)
                    };
                    w.add_group(params).unwrap();
                }
                let mut rng = throng::rng::AgentRng::new(9, 0, 0, 3);
                for k in 0..203 {
                    let p = Vec2::new(rng.unit() * 80.0, rng.unit() * 60.0);
                    let id = w
                        .add_agent(AgentInit {
                            velocity: Vec2::new(rng.signed(), rng.signed()) * 3.0,
                            ..AgentInit::at(p, pattern[k % pattern.len()])
                        })
                        .unwrap();
                    let t = Vec2::new(rng.unit() * 80.0, rng.unit() * 60.0);
                    w.set_target(id, t).unwrap();
                }
                for step in 0..40 {
                    if step == 20 {
                        w.set_target_point(slot, Vec2::new(60.0, 30.0)).unwrap();
                    }
                    w.step(DT).unwrap();
                }
                let ran = if general {
                    ["general"; 3]
                } else {
                    ["seek", "arrive", "seek"]
                };
                assert_eq!(w.last_plans(), ran, "the plans that ran");
                (0..w.len())
                    .map(|i| {
                        let s = w.agent(w.agents().id(i)).unwrap();
                        let (p, v) = (s.position.to_array(), s.velocity.to_array());
                        (s.id, p.map(f32::to_bits), v.map(f32::to_bits))
                    })
                    .collect::<std::collections::BTreeSet<_>>()
            };
            assert!(run(false) == run(true), "{bounds:?} {model:?}");
        }
    }
}

#[test]
fn lane_plans_with_requests_that_overflow_equal_the_general_loop() {
    // A mass so small that force / mass overflows: the lanes hand those agents to the
    // per-agent finish, which keeps the request's direction at the acceleration limit (a
    // lane's scale of zero would leave them standing).
    let run = |general: bool| {
        let mut profile =
            SteeringProfile::single(Behaviour::seek(Target::Point(Vec2::new(70.0, 5.0))));
        if general {
            profile = profile.with(Behaviour::look_where_you_are_going(), 1.0);
        }
        let g = Profile {
            max_speed: 6.0,
            max_acceleration: 9.0,
            mass: 1e-20,
            ..Profile::dynamic(profile)
        };
        let mut b = World::builder().seed(4).group(g);
        for k in 0..40 {
            b = b.agent(AgentInit::at(Vec2::new(k as f32, 30.0), 0));
        }
        let mut w = b.build().unwrap();
        for _ in 0..10 {
            w.step(1.0 / 30.0).unwrap();
        }
        let ran = if general { "general" } else { "seek" };
        assert_eq!(w.last_plans(), [ran], "the plan that ran");
        (0..w.len())
            .map(|i| w.agent(w.agents().id(i)).unwrap().position)
            .collect::<Vec<_>>()
    };
    let lanes = run(false);
    assert_eq!(lanes, run(true));
    assert!(
        lanes
            .iter()
            .enumerate()
            .all(|(k, p)| p.distance(Vec2::new(k as f32, 30.0)) > 0.1),
        "every seeker moves"
    );
}
