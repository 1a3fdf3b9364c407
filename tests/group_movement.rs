//! Group movement: path following stays on the path and advances, formations settle on their
//! slots and re-form after turns and removals, slot assignment is optimal, jumps reach the launch
//! point with the take-off velocity or are reported impossible, and bad parameters are errors.

use proptest::prelude::*;
use throng::group::{
    FollowParams, FormationId, FormationParams, FormationShape, JumpParams, Path, PathFollowParams,
    PathId, SlotParams, assign_min_cost, assign_slots, assignment_cost,
};
use throng::prelude::*;

const DT: f32 = 1.0 / 30.0;

fn ellipse(n: usize, radius: f32) -> Path {
    let points = (0..n)
        .map(|k| {
            let a = std::f32::consts::TAU * k as f32 / n as f32;
            Vec2::new(200.0 + 150.0 * a.cos(), 200.0 + 100.0 * a.sin())
        })
        .collect();
    Path::new(points, radius, true).unwrap()
}

#[test]
fn path_followers_stay_inside_the_radius_and_advance_around_the_loop() {
    let path = ellipse(24, 8.0);
    let len = path.length();
    let follow = SteeringProfile::single(Behaviour::FollowPath {
        path: PathId(0),
        params: PathFollowParams {
            lead_distance: 6.0,
            ..PathFollowParams::default()
        },
    });
    let mut b = World::builder()
        .bounds(Bounds::bounded(400.0, 400.0).unwrap())
        .path(path.clone())
        .group(Profile {
            max_speed: 12.0,
            max_acceleration: 30.0,
            ..Profile::dynamic(follow.clone())
        })
        .group(Profile {
            max_speed: 10.0,
            ..Profile::kinematic(follow)
        });
    for k in 0..200 {
        let f = k as f32;
        b = b.agent(AgentInit::at(
            Vec2::new((f * 37.3) % 400.0, (f * 91.7) % 400.0),
            k % 2,
        ));
    }
    let mut w = b.build().unwrap();
    // Settle: everyone reaches the path (the farthest start is ~200 units away).
    for _ in 0..900 {
        w.step(DT).unwrap();
    }
    let n = w.len();
    let arc = |w: &World, i: usize| path.project(w.agents().position(i)).arc;
    let mut last: Vec<f32> = (0..n).map(|i| arc(&w, i)).collect();
    let mut travelled = vec![0.0_f32; n];
    let mut window = vec![-1.0_f32; n];
    let mut worst = 0.0_f32;
    // 80 s: one lap at 10 units/s.
    for step in 1..=2400 {
        if step % 30 == 0 {
            for i in 0..n {
                assert!(travelled[i] > window[i], "agent {i} stalled");
                window[i] = travelled[i];
            }
        }
        w.step(DT).unwrap();
        for i in 0..n {
            let p = w.agents().position(i);
            worst = worst.max(path.project(p).distance);
            let a = arc(&w, i);
            // Unwrap across the loop's seam.
            let mut d = a - last[i];
            if d < -len / 2.0 {
                d += len;
            } else if d > len / 2.0 {
                d -= len;
            }
            // Projections onto a vertex from outside a convex corner keep the arc for a frame
            // or two: never backwards, and forwards over every second (below).
            assert!(d >= 0.0, "agent {i} went backwards by {d}");
            travelled[i] += d;
            last[i] = a;
        }
    }
    // Tolerance: 1 unit beyond the radius of 8 (dynamic agents at 12 units/s swing out a little
    // at the corners of the 24-gon).
    assert!(worst <= 8.0 + 1.0, "worst distance {worst}");
    let least = travelled.iter().copied().fold(f32::INFINITY, f32::min);
    assert!(
        least > len,
        "every agent goes round at least once: {least} < {len}"
    );
}

fn formation_world(shape: FormationShape, members: usize) -> (World, FormationId) {
    // The anchor is kinematic and seeks its own target at speed 3.
    let anchor = Profile {
        max_speed: 3.0,
        ..Profile::kinematic(SteeringProfile::single(Behaviour::Seek {
            target: Target::Own,
            threshold: 0.5,
        }))
    };
    let keep = Profile {
        max_speed: 8.0,
        max_acceleration: 30.0,
        ..Profile::dynamic(SteeringProfile::single(Behaviour::KeepFormation {
            params: SlotParams::default(),
        }))
    };
    let mut w = World::builder()
        .group(anchor)
        .group(keep)
        .agent(AgentInit::at(Vec2::ZERO, 0))
        .agents((0..members).map(|k| {
            AgentInit::at(
                Vec2::new(-5.0 - (k % 3) as f32 * 3.0, k as f32 * 1.7 - 6.0),
                1,
            )
        }))
        .build()
        .unwrap();
    w.set_target(AgentId(0), Vec2::new(1000.0, 0.0)).unwrap();
    let ids: Vec<AgentId> = (1..=members as u32).map(AgentId).collect();
    let f = w
        .add_formation(
            AgentId(0),
            FormationParams {
                shape,
                spacing: 2.0,
                offset: Vec2::new(-3.0, 0.0),
                reassign_every: 0,
            },
            &ids,
        )
        .unwrap();
    (w, f)
}

/// A lone `keep_formation` runs as a plan of its own; with an angular-only behaviour beside it
/// the same request goes through the general loop. Both give the same bits, through a right
/// angle turn of the anchor and in both movement models.
#[test]
fn the_keep_formation_plan_equals_the_general_loop_bit_for_bit() {
    for kinematic in [false, true] {
        let run = |general: bool| {
            let (mut w, _) = formation_world(FormationShape::Wedge, 9);
            if general || kinematic {
                let mut profile = SteeringProfile::single(Behaviour::KeepFormation {
                    params: SlotParams::default(),
                });
                if general {
                    profile = profile.with(
                        Behaviour::LookWhereYouAreGoing {
                            params: Default::default(),
                        },
                        1.0,
                    );
                }
                let mut g = w.groups()[1].clone();
                g.steering = profile;
                if kinematic {
                    g.model = MovementModel::Kinematic;
                }
                w.set_group_params(1, g).unwrap();
            }
            let mut states = Vec::new();
            for step in 0..150 {
                if step == 60 {
                    w.set_target(AgentId(0), Vec2::new(100.0, 1000.0)).unwrap();
                }
                w.step(DT).unwrap();
                states.extend((0..w.len()).map(|i| {
                    let s = w.agent(w.agents().id(i)).unwrap();
                    [s.position, s.velocity].map(|v| v.to_array().map(f32::to_bits))
                }));
            }
            let ran = if general { "general" } else { "keep_formation" };
            assert_eq!(w.last_plans()[1], ran, "the plan that ran");
            states
        };
        assert!(run(false) == run(true), "kinematic {kinematic}");
    }
}

/// Leader following (alone, or with separation after it) runs as a plan in lanes with the
/// leader resolved once per run; with an angular-only behaviour beside it the same requests go
/// through the general loop. Three leaders (seeking a point in the walled world, so that no
/// agent of the plan run turns; wandering on the torus), a squad behind each (the third led by
/// one of its own members, whose lane takes the per-agent path), spread slots, the keep-out
/// area and separation in crowded slots, the second squad's leader removed half-way: the same
/// bits on a torus and in a walled world, with the grid (separation sums from the cell batch)
/// and a k-d tree (sums per agent), in both models and with a mass so small that the requests
/// overflow, on one thread and on two (more agents than one steering task holds).
#[test]
fn the_follow_leader_plan_equals_the_general_loop_bit_for_bit() {
    const SQUAD: u32 = 360;
    let bounded = Bounds::bounded(90.0, 70.0).unwrap();
    let models = [
        (MovementModel::Dynamic, 1.5),
        (MovementModel::Kinematic, 1.5),
        (MovementModel::Dynamic, 1e-20),
    ];
    let worlds = [bounded, Bounds::torus(90.0, 70.0).unwrap()];
    let indices = [throng::IndexKind::Grid, throng::IndexKind::KdTree];
    for (bounds, index) in worlds.into_iter().flat_map(|b| indices.map(|i| (b, i))) {
        for (model, mass) in models {
            let run = |general: bool, threads: usize| {
                let lead = if bounds.is_torus() {
                    Behaviour::wander()
                } else {
                    Behaviour::seek(Target::Point(Vec2::new(45.0, 35.0)))
                };
                let leaders = Profile {
                    max_speed: 4.0,
                    ..Profile::dynamic(SteeringProfile::single(lead))
                };
                let mut b = World::builder().bounds(bounds).seed(21).group(leaders);
                let mut rng = throng::rng::AgentRng::new(21, 0, 0, 5);
                let centres = [
                    Vec2::new(20.0, 20.0),
                    Vec2::new(70.0, 50.0),
                    Vec2::new(2.0, 66.0),
                ];
                for (k, &c) in centres.iter().enumerate() {
                    let v = Vec2::new(1.0, k as f32 - 1.0);
                    b = b.agent(AgentInit {
                        velocity: v,
                        ..AgentInit::at(bounds.wrap(c), 0)
                    });
                }
                // Squads 1 and 2 follow the first two leaders with separation; squad 3 follows
                // its own first member, without separation.
                let own = AgentId(3 + 2 * SQUAD);
                let squads = [(AgentId(0), true), (AgentId(1), true), (own, false)];
                for (s, &(leader, separation)) in squads.iter().enumerate() {
                    let params = FollowParams {
                        offset: Vec2::new(-4.0, 0.5),
                        spread: 2.0,
                        clear_ahead: 5.0,
                        clear_width: 1.5,
                        ..FollowParams::default()
                    };
                    let mut profile =
                        SteeringProfile::single(Behaviour::follow_leader_with(leader, params));
                    profile.behaviours[0].weight = 1.3;
                    if separation {
                        profile = profile.with(Behaviour::separation(1.5), 1.2);
                    }
                    if general {
                        profile = profile.with(Behaviour::look_where_you_are_going(), 1.0);
                    }
                    b = b.group(Profile {
                        model,
                        max_speed: 6.0,
                        max_acceleration: 12.0,
                        mass,
                        ..Profile::dynamic(profile)
                    });
                    for k in 0..SQUAD {
                        // Every tenth follower starts at rest.
                        let speed = if k % 10 == 0 { 0.0 } else { 2.0 };
                        let p = centres[s] + Vec2::new(rng.signed(), rng.signed()) * 12.0;
                        b = b.agent(AgentInit {
                            velocity: Vec2::new(rng.signed(), rng.signed()) * speed,
                            ..AgentInit::at(bounds.wrap(p), s + 1)
                        });
                    }
                }
                let mut w = b.build().unwrap();
                // Without the grid the cell batch does not run: separation sums per agent.
                w.set_index(index);
                assert_eq!(w.agents().ids()[3 + 2 * SQUAD as usize], own);
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let mut states = Vec::new();
                pool.install(|| {
                    for step in 0..90 {
                        if step == 45 {
                            w.remove_agent(AgentId(1)).unwrap();
                        }
                        w.step(DT).unwrap();
                        states.extend((0..w.len()).map(|i| {
                            let s = w.agent(w.agents().id(i)).unwrap();
                            [s.position, s.velocity].map(|v| v.to_array().map(f32::to_bits))
                        }));
                    }
                });
                let ran = if general { "general" } else { "follow_leader" };
                assert_eq!(w.last_plans()[1..], [ran; 3], "the plans that ran");
                states
            };
            let plan = run(false, 2);
            let case = format!("{bounds:?} {index:?} {model:?} mass {mass}");
            assert!(plan == run(true, 2), "{case}");
            assert!(plan == run(false, 1), "{case}: one thread");
        }
    }
}

fn worst_slot_error(w: &World, f: FormationId) -> f32 {
    w.formation(f)
        .unwrap()
        .members()
        .iter()
        .map(|&m| {
            w.agent(m)
                .unwrap()
                .position
                .distance(w.slot_position(m).unwrap())
        })
        .fold(0.0, f32::max)
}

/// Members settle within 0.1 of their slots on a straight run; after the anchor turns 90 degrees
/// they are back within 0.1 in at most 150 steps (5 s).
#[test]
fn formations_settle_and_re_form_after_a_right_angle_turn() {
    let shapes = [
        FormationShape::Line,
        FormationShape::Column,
        FormationShape::Wedge,
        FormationShape::Circle,
        FormationShape::Box,
        FormationShape::Custom(vec![
            Vec2::new(0.0, 2.0),
            Vec2::new(0.0, -2.0),
            Vec2::new(-2.0, 0.0),
            Vec2::new(-4.0, 2.0),
            Vec2::new(-4.0, -2.0),
            Vec2::new(-6.0, 0.0),
            Vec2::new(-8.0, 2.0),
            Vec2::new(-8.0, -2.0),
        ]),
    ];
    for shape in shapes {
        let (mut w, f) = formation_world(shape.clone(), 8);
        for _ in 0..300 {
            w.step(DT).unwrap();
        }
        let settled = worst_slot_error(&w, f);
        assert!(settled < 0.1, "{shape:?}: straight run error {settled}");
        let here = w.agent(AgentId(0)).unwrap().position;
        w.set_target(AgentId(0), here + Vec2::new(0.0, 1000.0))
            .unwrap();
        let mut steps = 0;
        loop {
            w.step(DT).unwrap();
            steps += 1;
            if worst_slot_error(&w, f) < 0.1 {
                break;
            }
            assert!(steps < 150, "{shape:?}: not re-formed after 150 steps");
        }
        eprintln!("{shape:?}: re-formed in {steps} steps");
    }
}

#[test]
fn removing_a_member_closes_the_gap() {
    let (mut w, f) = formation_world(FormationShape::Line, 5);
    for _ in 0..200 {
        w.step(DT).unwrap();
    }
    // Remove the member in the middle slot (lateral offset 0).
    let middle = *w
        .formation(f)
        .unwrap()
        .members()
        .iter()
        .find(|&&m| w.formation(f).unwrap().slot(m).unwrap().y == 0.0)
        .unwrap();
    w.remove_agent(middle).unwrap();
    for _ in 0..200 {
        w.step(DT).unwrap();
    }
    let form = w.formation(f).unwrap();
    assert_eq!(form.members().len(), 4);
    let mut ys: Vec<f32> = form
        .members()
        .iter()
        .map(|&m| w.agent(m).unwrap().position.y)
        .collect();
    ys.sort_by(f32::total_cmp);
    for pair in ys.windows(2) {
        let gap = pair[1] - pair[0];
        assert!((gap - 2.0).abs() < 0.15, "gap {gap} in {ys:?}");
    }
    assert!(worst_slot_error(&w, f) < 0.1);
    // Leaving without being removed from the world works the same way.
    let leaver = form.members()[0];
    w.remove_formation_member(f, leaver).unwrap();
    assert!(w.slot_position(leaver).is_none());
    for _ in 0..200 {
        w.step(DT).unwrap();
    }
    assert_eq!(w.formation(f).unwrap().members().len(), 3);
    assert!(worst_slot_error(&w, f) < 0.1);
    // Joining again.
    w.add_formation_member(f, leaver).unwrap();
    for _ in 0..200 {
        w.step(DT).unwrap();
    }
    assert!(worst_slot_error(&w, f) < 0.1);
}

fn brute_force(cost: &[f64], n: usize) -> f64 {
    fn go(cost: &[f64], n: usize, row: usize, used: &mut [bool], sum: f64, best: &mut f64) {
        if row == n {
            *best = best.min(sum);
            return;
        }
        for c in 0..n {
            if !used[c] {
                used[c] = true;
                go(cost, n, row + 1, used, sum + cost[row * n + c], best);
                used[c] = false;
            }
        }
    }
    let mut best = f64::INFINITY;
    go(cost, n, 0, &mut vec![false; n], 0.0, &mut best);
    best
}

fn point() -> impl Strategy<Value = Vec2> {
    prop_oneof![
        (-50.0f32..50.0, -50.0f32..50.0).prop_map(|(x, y)| Vec2::new(x, y)),
        // Nasty cases: points on a small lattice (ties, coincident points).
        (-2i32..2, -2i32..2).prop_map(|(x, y)| Vec2::new(x as f32, y as f32)),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// The Hungarian assignment has the brute-force optimum's total distance, for up to 8
    /// members, and is a permutation; running it twice gives the same answer.
    #[test]
    fn assignment_matches_brute_force(
        (members, slots) in (1usize..=8).prop_flat_map(|n| {
            (prop::collection::vec(point(), n), prop::collection::vec(point(), n))
        })
    ) {
        let n = members.len();
        let a = assign_slots(&members, &slots).unwrap();
        let mut sorted = a.clone();
        sorted.sort_unstable();
        prop_assert_eq!(sorted, (0..n).collect::<Vec<_>>());
        let cost: Vec<f64> = members
            .iter()
            .flat_map(|m| slots.iter().map(move |s| f64::from(m.distance(*s))))
            .collect();
        let got = assignment_cost(&cost, n, &a);
        let best = brute_force(&cost, n);
        prop_assert!((got - best).abs() <= 1e-4 * (1.0 + best), "{} vs {}", got, best);
        prop_assert_eq!(assign_slots(&members, &slots).unwrap(), a);
        let direct = assign_min_cost(&cost, n, n).unwrap();
        prop_assert!((assignment_cost(&cost, n, &direct) - best).abs() <= 1e-4 * (1.0 + best));
    }
}

fn jump_world(model: MovementModel, start: Vec2) -> (World, Vec2, Vec2, JumpParams) {
    let launch = Vec2::new(50.0, 50.0);
    let landing = Vec2::new(56.0, 58.0);
    let params = JumpParams {
        gravity: 10.0,
        jump_speed: 5.0,
        ..JumpParams::default()
    };
    let jump = SteeringProfile::single(Behaviour::Jump {
        launch,
        landing,
        params,
    });
    let g = Profile {
        model,
        max_speed: 12.0,
        max_acceleration: 20.0,
        ..Profile::dynamic(jump)
    };
    let w = World::builder()
        .group(g)
        .agent(AgentInit::at(start, 0))
        .build()
        .unwrap();
    (w, launch, landing, params)
}

/// The agent crosses the launch point (within the corridor's tolerance) with a velocity within
/// 0.1 units/s of the take-off velocity, then coasts onto the landing point (within 0.5).
#[test]
fn jump_reaches_the_launch_point_with_the_take_off_velocity() {
    for (model, start) in [
        (MovementModel::Dynamic, Vec2::new(10.0, 80.0)),
        (MovementModel::Dynamic, Vec2::new(70.0, 70.0)),
        (MovementModel::Kinematic, Vec2::new(30.0, 20.0)),
    ] {
        let (mut w, launch, landing, params) = jump_world(model, start);
        let plan = w.jump_plan(AgentId(0), launch, landing, &params).unwrap();
        assert!((plan.flight_time - 1.0).abs() < 1e-5);
        let dir = plan.velocity.normalize();
        let mut crossed = None;
        for step in 0..2000 {
            let before = w.agent(AgentId(0)).unwrap();
            w.step(DT).unwrap();
            let after = w.agent(AgentId(0)).unwrap();
            if (before.position - launch).dot(dir) < 0.0
                && (after.position - launch).dot(dir) >= 0.0
            {
                crossed = Some((step, after));
                break;
            }
        }
        let (step, at) = crossed.unwrap_or_else(|| panic!("{model:?}: never launched"));
        let side = (at.position - launch).perp_dot(dir).abs();
        assert!(side < params.tolerance, "{model:?}: {side} off the line");
        let err = (at.velocity - plan.velocity).length();
        assert!(
            err < 0.1,
            "{model:?}: velocity {} vs {}",
            at.velocity,
            plan.velocity
        );
        // Coast through the flight.
        let frames = (plan.flight_time / DT).round() as usize;
        let launched = at.position;
        for _ in 0..frames {
            w.step(DT).unwrap();
        }
        let land = w.agent(AgentId(0)).unwrap().position;
        assert!(
            land.distance(landing + (launched - launch)) < 0.5,
            "{model:?}: landed at {land}, launched at step {step}"
        );
    }
}

#[test]
fn impossible_jumps_are_reported_not_attempted() {
    let jump = Behaviour::Jump {
        launch: Vec2::ZERO,
        landing: Vec2::new(30.0, 0.0),
        params: JumpParams {
            gravity: 10.0,
            jump_speed: 5.0,
            ..JumpParams::default()
        },
    };
    // 30 units in 1 s needs speed 30; the group has 8.
    let g = Profile {
        max_speed: 8.0,
        ..Profile::dynamic(SteeringProfile::single(jump.clone()))
    };
    let err = World::builder().group(g.clone()).build().unwrap_err();
    assert!(matches!(err, Error::Impossible { .. }), "{err}");
    let mut w = World::builder().build().unwrap();
    assert!(matches!(w.add_group(g), Err(Error::Impossible { .. })));
    // Possible for the group, impossible for an agent with a lower own maximum speed: reported
    // by `jump_plan`, and the agent is not steered.
    let fast = Profile {
        max_speed: 40.0,
        ..Profile::dynamic(SteeringProfile::single(jump))
    };
    let gi = w.add_group(fast).unwrap();
    let id = w
        .add_agent(AgentInit {
            max_speed: Some(8.0),
            ..AgentInit::at(Vec2::new(-20.0, 5.0), gi)
        })
        .unwrap();
    assert!(matches!(
        w.jump_plan(
            id,
            Vec2::ZERO,
            Vec2::new(30.0, 0.0),
            &JumpParams {
                gravity: 10.0,
                jump_speed: 5.0,
                ..JumpParams::default()
            }
        ),
        Err(Error::Impossible { .. })
    ));
    w.step(DT).unwrap();
    assert_eq!(w.agent(id).unwrap().velocity, Vec2::ZERO);
}

#[test]
fn bad_group_parameters_are_errors() {
    assert!(matches!(
        Path::new(vec![Vec2::ZERO, Vec2::X], -1.0, false),
        Err(Error::Negative { .. })
    ));
    assert!(matches!(
        Path::new(vec![], 1.0, true),
        Err(Error::Invalid { .. })
    ));
    // A path id that names no path.
    let follow = Profile::dynamic(SteeringProfile::single(Behaviour::FollowPath {
        path: PathId(3),
        params: PathFollowParams::default(),
    }));
    let err = World::builder().group(follow).build().unwrap_err();
    assert!(
        matches!(err, Error::UnknownPath { path: 3, count: 0 }),
        "{err}"
    );
    assert!(err.to_string().contains("no path 3"), "{err}");
    // Formations: no slots, bad spacing, anchor as member, duplicates, too many for a custom shape.
    let mut w = World::builder()
        .group(Profile::default())
        .agents((0..4).map(|k| AgentInit::at(Vec2::new(k as f32, 0.0), 0)))
        .build()
        .unwrap();
    let no_slots = FormationParams {
        shape: FormationShape::Custom(vec![]),
        ..FormationParams::default()
    };
    assert!(matches!(
        w.add_formation(AgentId(0), no_slots, &[AgentId(1)]),
        Err(Error::Invalid { .. })
    ));
    let bad_spacing = FormationParams {
        spacing: 0.0,
        ..FormationParams::default()
    };
    assert!(matches!(
        w.add_formation(AgentId(0), bad_spacing, &[]),
        Err(Error::NotPositive { .. })
    ));
    let line = FormationParams::default();
    assert!(
        w.add_formation(AgentId(0), line.clone(), &[AgentId(0)])
            .is_err()
    );
    assert!(
        w.add_formation(AgentId(0), line.clone(), &[AgentId(1), AgentId(1)])
            .is_err()
    );
    assert!(matches!(
        w.add_formation(AgentId(9), line.clone(), &[]),
        Err(Error::UnknownAgent { .. })
    ));
    let two = FormationParams {
        shape: FormationShape::Custom(vec![Vec2::X, Vec2::Y]),
        ..FormationParams::default()
    };
    assert!(
        w.add_formation(AgentId(0), two, &[AgentId(1), AgentId(2), AgentId(3)])
            .is_err()
    );
    // Failed calls left nothing behind: a valid formation still takes all three.
    let f = w
        .add_formation(AgentId(0), line, &[AgentId(1), AgentId(2), AgentId(3)])
        .unwrap();
    assert_eq!(w.formation(f).unwrap().members().len(), 3);
    assert_eq!(w.formations().len(), 1);
    // Leader following needs an agent as the leader.
    let follow = Behaviour::FollowLeader {
        leader: Target::Point(Vec2::ZERO),
        params: FollowParams::default(),
    };
    assert!(matches!(follow.validate(), Err(Error::Invalid { .. })));
    let neg = Behaviour::FollowLeader {
        leader: Target::Agent(AgentId(0)),
        params: FollowParams {
            spread: -1.0,
            ..FollowParams::default()
        },
    };
    assert!(matches!(neg.validate(), Err(Error::Negative { .. })));
}

#[test]
fn bad_scenario_keys_are_errors() {
    let base = throng::scenario::builtin("formation").unwrap();
    let text = toml::to_string(&base).unwrap();
    let neg = text.replacen("radius = 1.0", "radius = -1.0", 1);
    assert_ne!(neg, text);
    let msg = throng::scenario::Scenario::from_toml(&neg, "f.toml")
        .unwrap_err()
        .to_string();
    assert!(msg.contains("path.radius"), "{msg}");
    let empty = text.replacen("shape = \"line\"", "shape = { custom = [] }", 1);
    assert_ne!(empty, text);
    let msg = throng::scenario::Scenario::from_toml(&empty, "f.toml")
        .unwrap_err()
        .to_string();
    assert!(msg.contains("at least one slot"), "{msg}");
}

/// Followers of a wandering leader end up behind it and out of the area in front of it.
#[test]
fn leader_followers_stay_behind_and_out_of_the_way() {
    let s = throng::scenario::builtin("leader").unwrap();
    let mut w = s.build().unwrap();
    for _ in 0..300 {
        w.step(s.dt).unwrap();
    }
    let mut in_front = 0;
    let mut behind = 0;
    let mut total = 0;
    for _ in 0..300 {
        w.step(s.dt).unwrap();
        let l = w.agent(AgentId(0)).unwrap();
        let basis = throng::steering::Basis::from_orientation(l.position, l.orientation);
        for i in 0..w.len() {
            let id = w.agents().id(i);
            if id == AgentId(0) {
                continue;
            }
            let p = w.agent(id).unwrap().position;
            let local = basis.to_local(l.position + w.bounds().offset(l.position, p));
            total += 1;
            if local.x > 0.0 && local.x < 6.0 && local.y.abs() < 2.0 {
                in_front += 1;
            }
            if local.x < 0.0 {
                behind += 1;
            }
        }
    }
    eprintln!("in front {in_front}, behind {behind} of {total}");
    assert!(in_front * 200 < total, "{in_front} of {total} in front");
    assert!(behind * 10 > total * 9, "{behind} of {total} behind");
}
