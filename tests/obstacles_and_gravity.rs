//! Obstacles are never entered or crossed, document 000's anti-gravity seek reaches its target
//! around repelling points, repulsion summed by the cell batch agrees with each agent's own
//! neighbour query, and nearest-of-group targets find the nearest agent.

use throng::IndexKind;
use throng::gravity::GravityPoint;
use throng::obstacles::{Circle, Wall};
use throng::prelude::*;
use throng::scenario;

#[path = "support/bits.rs"]
mod bits;

const DT: f32 = 1.0 / 30.0;

#[test]
fn no_centre_enters_a_circle_and_no_move_crosses_a_wall_over_2000_steps() {
    let mut w = scenario::builtin("obstacles")
        .unwrap()
        .with_agents(1500)
        .unwrap()
        .build()
        .unwrap();
    let circles: Vec<Circle> = w.obstacles().circles().to_vec();
    let walls: Vec<Wall> = w.obstacles().walls().to_vec();
    assert!(circles.len() > 100 && walls.len() >= 7);
    let positions = |w: &World| -> Vec<(AgentId, Vec2)> {
        let a = w.agents();
        let mut v: Vec<_> = (0..a.len()).map(|i| (a.id(i), a.position(i))).collect();
        v.sort_by_key(|(id, _)| *id);
        v
    };
    let mut before = positions(&w);
    let mut corrected = 0usize;
    for step in 0..2000 {
        w.step(DT).unwrap();
        let after = positions(&w);
        for ((id, p0), (_, p1)) in before.iter().zip(&after) {
            for c in &circles {
                assert!(
                    c.center.distance_squared(*p1) >= c.radius * c.radius,
                    "step {step}: agent {id} at {p1} inside circle {c:?}"
                );
            }
            for wall in &walls {
                let crossed =
                    throng::obstacles::segment_intersection(*p0, *p1, wall.a, wall.b).is_some();
                // Touching a wall is allowed; passing from one side to the other is not.
                if crossed {
                    let side = |p: Vec2| (wall.b - wall.a).perp_dot(p - wall.a);
                    assert!(
                        side(*p0) * side(*p1) >= 0.0,
                        "step {step}: agent {id} crossed {wall:?} from {p0} to {p1}"
                    );
                    corrected += 1;
                }
            }
            assert!(p1.x >= 0.0 && p1.y >= 0.0 && p1.x <= 300.0 && p1.y <= 300.0);
        }
        before = after;
    }
    eprintln!("touches of a wall without crossing: {corrected}");
}

#[test]
fn resolve_stops_an_agent_driven_into_a_wall_and_a_circle() {
    // Seek straight through a wall and a circle: steering has no avoidance, the hard step must hold.
    let seek = SteeringProfile::single(Behaviour::Seek {
        target: Target::Point(Vec2::new(90.0, 50.0)),
        threshold: 0.0,
    });
    let mut w = World::builder()
        .bounds(Bounds::bounded(100.0, 100.0).unwrap())
        .group(Profile {
            max_speed: 20.0,
            max_acceleration: 100.0,
            ..Profile::dynamic(seek)
        })
        .agent(AgentInit::at(Vec2::new(10.0, 50.0), 0))
        .agent(AgentInit::at(Vec2::new(10.0, 20.0), 0))
        .build()
        .unwrap();
    w.add_wall(Wall {
        a: Vec2::new(50.0, 40.0),
        b: Vec2::new(50.0, 60.0),
    })
    .unwrap();
    w.add_circle(Circle {
        center: Vec2::new(50.0, 25.0),
        radius: 5.0,
    })
    .unwrap();
    for _ in 0..300 {
        w.step(DT).unwrap();
        let a = w.agents();
        for i in 0..a.len() {
            assert!(a.position(i).distance(Vec2::new(50.0, 25.0)) >= 5.0);
        }
        let blocked = w.agent(AgentId(0)).unwrap().position;
        assert!(blocked.x <= 50.0, "crossed the wall: {blocked}");
    }
    assert!(
        matches!(
            w.add_circle(Circle {
                center: w.agent(AgentId(0)).unwrap().position,
                radius: 1.0
            }),
            Err(Error::Invalid { .. })
        ),
        "a circle over an agent is refused"
    );
}

#[test]
fn antigravity_seek_reaches_the_target_without_entering_exclusion_radii() {
    // Document 000: strength 2000, n = 2; the exclusion radius is where the push equals the pull
    // of the unit direction to the target: sqrt(2000) ~ 44.7. Points are spaced so that paths exist.
    let strength = 2000.0_f32;
    let exclusion = strength.sqrt();
    let target = Vec2::new(950.0, 500.0);
    let g = Profile {
        model: MovementModel::Kinematic,
        max_speed: 30.0,
        ..Profile::kinematic(SteeringProfile::single(Behaviour::AntiGravitySeek {
            target: Target::Point(target),
        }))
    };
    let mut w = World::builder()
        .bounds(Bounds::bounded(1000.0, 1000.0).unwrap())
        .group(g)
        .agent(AgentInit::at(Vec2::new(50.0, 480.0), 0))
        .build()
        .unwrap();
    let mut points = Vec::new();
    for (k, x) in [250.0_f32, 450.0, 650.0].into_iter().enumerate() {
        for j in 0..5 {
            let y = 300.0 + 100.0 * j as f32 + if k % 2 == 1 { 50.0 } else { 0.0 };
            let p = Vec2::new(x, y);
            w.add_gravity_point(GravityPoint::fixed(p, strength, 2.0, 400.0))
                .unwrap();
            points.push(p);
        }
    }
    let mut closest = f32::INFINITY;
    let mut reached = None;
    for step in 0..2000 {
        w.step(DT).unwrap();
        let p = w.agents().position(0);
        for q in &points {
            closest = closest.min(p.distance(*q));
        }
        if p.distance(target) <= 2.0 {
            reached = Some(step);
            break;
        }
    }
    assert!(
        reached.is_some(),
        "never reached the target; ended at {}",
        w.agents().position(0)
    );
    assert!(
        closest > 0.5 * exclusion,
        "came within {closest} of a point (exclusion radius {exclusion})"
    );
}

#[test]
fn repulsion_from_the_cell_batch_equals_the_scalar_traversal_to_rounding() {
    // Anti-gravity seek beside repulsion of every whole exponent the batch's kernel serves, and
    // of one it leaves to each agent's own query: on the grid the cell batch sums repulsion (in
    // the grid's order), on the k-d tree each agent queries its neighbours (in ascending index
    // order, the scalar reference). One step from the same state agrees to rounding.
    for bounds in [
        Bounds::bounded(60.0, 40.0).unwrap(),
        Bounds::torus(60.0, 40.0).unwrap(),
    ] {
        for (exponent, batched) in [
            (0.0, true),
            (1.0, true),
            (2.0, true),
            (3.0, true),
            (4.0, true),
            (2.5, false),
        ] {
            let run = |index: IndexKind| {
                let steering = SteeringProfile::single(Behaviour::anti_gravity_seek(
                    Target::Point(Vec2::new(55.0, 20.0)),
                ))
                .with(
                    Behaviour::Repulsion {
                        strength: 4.0,
                        exponent,
                        radius: 3.0,
                    },
                    1.0,
                );
                let g = Profile {
                    max_speed: 6.0,
                    max_acceleration: 1e6,
                    ..Profile::dynamic(steering)
                };
                let mut b = World::builder()
                    .bounds(bounds)
                    .seed(5)
                    .group(g)
                    .gravity_point(GravityPoint::fixed(Vec2::new(30.0, 20.0), 60.0, 2.0, 15.0));
                // A jittered lattice: neighbours at 0.7 to 4 units, a few dozen within reach.
                let mut rng = throng::rng::AgentRng::new(5, 0, 0, 3);
                for k in 0..900 {
                    let (i, j) = ((k % 40) as f32, (k / 40) as f32);
                    let p = Vec2::new(
                        1.0 + 1.5 * i + 0.4 * rng.signed(),
                        2.0 + 1.5 * j + 0.4 * rng.signed(),
                    );
                    b = b.agent(AgentInit {
                        velocity: Vec2::new(rng.signed(), rng.signed()),
                        ..AgentInit::at(p, 0)
                    });
                }
                let mut w = b.build().unwrap();
                w.set_index(index);
                w.step(DT).unwrap();
                let a = w.agents();
                let v: Vec<(u32, Vec2)> =
                    (0..a.len()).map(|i| (a.id(i).0, a.velocity(i))).collect();
                (v, w.last_summed()[0])
            };
            let (mut grid, summed) = run(IndexKind::Grid);
            let (mut tree, queried) = run(IndexKind::KdTree);
            assert_eq!(
                summed, batched,
                "exponent {exponent}: the batch summed repulsion"
            );
            assert!(!queried, "no batch without the grid");
            grid.sort_by_key(|e| e.0);
            tree.sort_by_key(|e| e.0);
            for ((id, g), (_, t)) in grid.iter().zip(&tree) {
                // The change of velocity is the force times dt: rounding of the summed terms.
                assert!(
                    (*g - *t).length() <= 1e-5 * g.length().max(1.0),
                    "{bounds:?}, exponent {exponent}, agent {id}: {g} vs {t}"
                );
            }
        }
    }
}

#[test]
fn the_anti_gravity_seek_plan_equals_the_general_loop_bit_for_bit() {
    // Anti-gravity seek alone, and followed by repulsion the cell batch sums (exponent 2) or
    // each agent's own query sums (exponent 2.5): its own plan, and through the general loop
    // (a seek of weight 0 beside it adds a zero to the sum), the same bits over 40 steps, walled
    // and on a torus, dynamic and kinematic, among repelling and attracting points.
    let target = Target::Point(Vec2::new(70.0, 30.0));
    for bounds in [
        Bounds::bounded(80.0, 60.0).unwrap(),
        Bounds::torus(80.0, 60.0).unwrap(),
    ] {
        for model in [MovementModel::Dynamic, MovementModel::Kinematic] {
            for repulsion in [None, Some(2.0), Some(2.5)] {
                let run = |general: bool| {
                    let mut steering =
                        SteeringProfile::single(Behaviour::anti_gravity_seek(target));
                    steering.behaviours[0].weight = 1.5;
                    if let Some(exponent) = repulsion {
                        let repel = Behaviour::Repulsion {
                            strength: 4.0,
                            exponent,
                            radius: 3.0,
                        };
                        steering = steering.with(repel, 0.8);
                    }
                    if general {
                        steering = steering.with(Behaviour::seek(Target::Point(Vec2::ZERO)), 0.0);
                    }
                    let g = Profile {
                        model,
                        max_speed: 6.0,
                        max_acceleration: 9.0,
                        ..Profile::dynamic(steering)
                    };
                    let mut b = World::builder().bounds(bounds).seed(4).group(g);
                    for (k, strength) in [60.0_f32, -20.0, 40.0, 80.0].into_iter().enumerate() {
                        let p = Vec2::new(20.0 + 12.0 * k as f32, 15.0 + 9.0 * k as f32);
                        b = b.gravity_point(GravityPoint::fixed(p, strength, 2.0, 18.0));
                    }
                    let mut rng = throng::rng::AgentRng::new(4, 0, 0, 3);
                    for _ in 0..300 {
                        let p = Vec2::new(rng.unit() * 80.0, rng.unit() * 60.0);
                        b = b.agent(AgentInit {
                            velocity: Vec2::new(rng.signed(), rng.signed()) * 3.0,
                            ..AgentInit::at(p, 0)
                        });
                    }
                    let mut w = b.build().unwrap();
                    for _ in 0..40 {
                        w.step(DT).unwrap();
                    }
                    let ran = if general {
                        "general"
                    } else {
                        "anti_gravity_seek"
                    };
                    assert_eq!(w.last_plans(), [ran], "the plan that ran");
                    let summed = repulsion == Some(2.0);
                    assert_eq!(w.last_summed(), [summed], "the batch summed repulsion");
                    bits::by_id(&w)
                };
                assert!(
                    run(false) == run(true),
                    "{bounds:?} {model:?} repulsion {repulsion:?}"
                );
            }
        }
    }
}

#[test]
fn attracting_points_pull_and_moving_points_move() {
    let g = Profile::dynamic(SteeringProfile::single(Behaviour::AntiGravity));
    let mut w = World::builder()
        .group(g)
        .agent(AgentInit::at(Vec2::ZERO, 0))
        .build()
        .unwrap();
    w.add_gravity_point(GravityPoint::fixed(Vec2::new(10.0, 0.0), -50.0, 1.0, 100.0))
        .unwrap();
    let moving = GravityPoint {
        motion: throng::gravity::Motion::Linear {
            velocity: Vec2::new(0.0, 3.0),
        },
        ..GravityPoint::fixed(Vec2::new(-50.0, 0.0), 1.0, 2.0, 1.0)
    };
    w.add_gravity_point(moving).unwrap();
    for _ in 0..30 {
        w.step(DT).unwrap();
    }
    assert!(
        w.agents().position(0).x > 0.5,
        "pulled towards the attracting point"
    );
    let y = w.gravity().points()[1].position.y;
    assert!((y - 3.0).abs() < 1e-3, "moved 3 units in one second: {y}");
}

#[test]
fn nearest_target_picks_the_nearest_agent_of_the_group() {
    let prey = Profile::default();
    let hunter = Profile {
        max_speed: 5.0,
        ..Profile::dynamic(SteeringProfile::single(Behaviour::Seek {
            target: Target::Nearest {
                group: 0,
                within: 100.0,
            },
            threshold: 0.0,
        }))
    };
    let mut w = World::builder()
        .group(prey)
        .group(hunter)
        .agent(AgentInit::at(Vec2::new(-20.0, 0.0), 0))
        .agent(AgentInit::at(Vec2::new(0.0, 8.0), 0))
        .agent(AgentInit::at(Vec2::ZERO, 1))
        .build()
        .unwrap();
    for _ in 0..30 {
        w.step(DT).unwrap();
    }
    let p = w.agent(AgentId(2)).unwrap().position;
    assert!(
        p.y > 1.0 && p.x.abs() < 0.5,
        "went for the prey 8 units north, not the one 20 west: {p}"
    );
    let mut far = World::builder()
        .group(Profile::default())
        .group(Profile::dynamic(SteeringProfile::single(Behaviour::Seek {
            target: Target::Nearest {
                group: 0,
                within: 5.0,
            },
            threshold: 0.0,
        })))
        .agent(AgentInit::at(Vec2::new(50.0, 0.0), 0))
        .agent(AgentInit::at(Vec2::ZERO, 1))
        .build()
        .unwrap();
    far.step(DT).unwrap();
    assert_eq!(
        far.agent(AgentId(1)).unwrap().velocity,
        Vec2::ZERO,
        "nothing within reach: no steering"
    );
}

#[test]
fn obstacle_scenarios_are_deterministic_across_threads() {
    let run = |threads: usize, name: &str| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut w = scenario::builtin(name)
                .unwrap()
                .with_agents(800)
                .unwrap()
                .build()
                .unwrap();
            for _ in 0..40 {
                w.step(DT).unwrap();
            }
            let a = w.agents();
            let mut v: Vec<_> = (0..a.len())
                .map(|i| (a.id(i), a.pos_x()[i].to_bits(), a.pos_y()[i].to_bits()))
                .collect();
            v.sort();
            v
        })
    };
    for name in ["obstacles", "antigravity", "pursuit"] {
        assert_eq!(run(1, name), run(2, name), "{name}");
        assert_eq!(run(1, name), run(4, name), "{name}");
    }
}
