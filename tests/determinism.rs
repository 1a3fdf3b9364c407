//! The same seed gives the same bits on 1, 2 and 4 threads, and the parallel SIMD step equals the
//! sequential scalar reference bit for bit.

use throng::orca::Orca;
use throng::ped::{Model, Pedestrian};
use throng::prelude::*;

#[path = "support/flocks.rs"]
mod flocks;
use flocks::flocking_group;

fn mixed_world(n: usize) -> World {
    let wander = Profile::dynamic(SteeringProfile::single(Behaviour::Wander {
        params: WanderParams::default(),
    }));
    let kin_wander = Profile {
        orientation: OrientationMode::Integrate,
        ..Profile::kinematic(SteeringProfile::single(Behaviour::Wander {
            params: WanderParams::default(),
        }))
    };
    let chase = Profile::dynamic(
        SteeringProfile::single(Behaviour::Pursue {
            target: Target::Agent(AgentId(0)),
            max_prediction: 1.0,
        })
        .with(
            Behaviour::Flee {
                target: Target::Point(Vec2::new(50.0, 50.0)),
                panic_distance: 10.0,
            },
            0.5,
        )
        .combined(Combine::Priority),
    );
    let arrive = Profile {
        drag: 0.3,
        ..Profile::dynamic(SteeringProfile::single(Behaviour::Arrive {
            target: Target::Own,
            params: ArriveParams::default(),
        }))
    };
    let mut b = World::builder()
        .bounds(Bounds::torus(100.0, 100.0).unwrap())
        .seed(42)
        .group(wander)
        .group(kin_wander)
        .group(chase)
        .group(arrive);
    for i in 0..n {
        let f = i as f32;
        b = b.agent(AgentInit {
            position: Vec2::new((f * 7.31) % 100.0, (f * 3.17) % 100.0),
            velocity: Vec2::new((f * 0.37).sin(), (f * 0.91).cos()),
            orientation: f * 0.1,
            ..AgentInit::at(Vec2::ZERO, i % 4)
        });
    }
    let mut w = b.build().unwrap();
    for i in (3..n).step_by(4) {
        let id = w.agents().id(i);
        w.set_target(id, Vec2::new(20.0 + (i % 60) as f32, 30.0))
            .unwrap();
    }
    w
}

fn snapshot(w: &World) -> Vec<u32> {
    let a = w.agents();
    let mut bits = Vec::new();
    for s in [
        a.pos_x(),
        a.pos_y(),
        a.vel_x(),
        a.vel_y(),
        a.orientations(),
        a.rotations(),
    ] {
        bits.extend(s.iter().map(|v| v.to_bits()));
    }
    bits
}

fn run_on(threads: usize, steps: usize) -> Vec<u32> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let mut w = mixed_world(5003);
        for _ in 0..steps {
            w.step(0.05).unwrap();
        }
        snapshot(&w)
    })
}

#[test]
fn bit_identical_on_one_two_and_four_threads() {
    let one = run_on(1, 60);
    assert_eq!(one, run_on(2, 60));
    assert_eq!(one, run_on(4, 60));
}

#[test]
fn parallel_step_equals_the_sequential_reference() {
    let mut a = mixed_world(2001);
    let mut b = mixed_world(2001);
    for _ in 0..40 {
        a.step(0.05).unwrap();
        b.step_sequential(0.05).unwrap();
    }
    assert_eq!(snapshot(&a), snapshot(&b));
}

#[test]
fn parallel_flock_step_equals_the_sequential_reference() {
    // The cell batch (a flock with a view cone) over more agents than one of its parallel tasks
    // takes: the sequential pass runs the same tasks one after another. Beside the flock, in the
    // same cells, a group that also seeks a point (evaluated per agent over sums the batch
    // computed) and a group that wanders (in lanes).
    let flock = || {
        let hood = |radius: f32| Neighbourhood {
            view_cos: -0.5,
            ..Neighbourhood::radius(radius)
        };
        let profile = SteeringProfile::default()
            .with(Behaviour::Separation { hood: hood(2.0) }, 1.5)
            .with(Behaviour::Alignment { hood: hood(5.0) }, 1.0)
            .with(Behaviour::Cohesion { hood: hood(5.0) }, 0.8);
        let seeking = profile.clone().with(
            Behaviour::Seek {
                target: Target::Point(Vec2::new(55.0, 55.0)),
                threshold: 0.0,
            },
            0.5,
        );
        let params = |profile| Profile {
            max_speed: 4.0,
            max_acceleration: 8.0,
            ..Profile::dynamic(profile)
        };
        let mut b = World::builder()
            .bounds(Bounds::torus(110.0, 110.0).unwrap())
            .seed(3)
            .group(params(profile))
            .group(params(seeking))
            .group(params(SteeringProfile::single(Behaviour::wander())));
        for i in 0..5003 {
            let f = i as f32;
            b = b.agent(AgentInit {
                position: Vec2::new((f * 7.31) % 110.0, (f * 3.17) % 110.0),
                velocity: Vec2::new((f * 0.37).sin(), (f * 0.91).cos()) * 3.0,
                orientation: f * 0.1,
                ..AgentInit::at(Vec2::ZERO, [0, 0, 1, 2][i % 4])
            });
        }
        b.build().unwrap()
    };
    let (mut a, mut b) = (flock(), flock());
    for _ in 0..20 {
        a.step(0.05).unwrap();
        b.step_sequential(0.05).unwrap();
    }
    assert_eq!(snapshot(&a), snapshot(&b));
}

/// A flock whose requests the ORCA filter or a pedestrian model then replaces: the batch serves
/// every agent, and the parallel step must still hand those passes the requests.
#[test]
fn a_flock_with_orca_or_a_pedestrian_model_steps_as_the_sequential_reference() {
    let hood = Neighbourhood {
        view_cos: -0.5,
        ..Neighbourhood::radius(5.0)
    };
    let profile = SteeringProfile::default()
        .with(Behaviour::Separation { hood }, 1.5)
        .with(Behaviour::Alignment { hood }, 1.0)
        .with(Behaviour::Cohesion { hood }, 0.8);
    let orca = Profile {
        orca: Some(Orca::default()),
        ..Profile::dynamic(profile.clone())
    };
    let ped = Profile {
        pedestrian: Some(Pedestrian::new(Model::SocialForce)),
        ..Profile::dynamic(profile)
    };
    for (group, bounds) in [
        (orca, Bounds::torus(60.0, 60.0).unwrap()),
        (ped, Bounds::bounded(60.0, 60.0).unwrap()),
    ] {
        let world = || {
            let mut b = World::builder().bounds(bounds).seed(4).group(group.clone());
            for i in 0..600 {
                let f = i as f32;
                b = b.agent(AgentInit {
                    position: Vec2::new((f * 7.31) % 59.0 + 0.5, (f * 3.17) % 59.0 + 0.5),
                    velocity: Vec2::new((f * 0.37).sin(), (f * 0.91).cos()),
                    ..AgentInit::at(Vec2::ZERO, 0)
                });
            }
            b.build().unwrap()
        };
        let (mut a, mut b) = (world(), world());
        for _ in 0..10 {
            a.step(0.05).unwrap();
            b.step_sequential(0.05).unwrap();
        }
        assert_eq!(snapshot(&a), snapshot(&b), "{bounds:?}");
    }
}

#[test]
fn parallel_step_equals_the_sequential_reference_against_walls() {
    // More agents than one integrator task, each heading for the nearest wall: the parallel
    // integrator clamps its tasks' agents at the walls itself, the sequential step afterwards.
    let walled = || {
        let mut b = World::builder()
            .bounds(Bounds::bounded(60.0, 60.0).unwrap())
            .seed(9)
            .group(Profile::dynamic(SteeringProfile::single(
                Behaviour::wander(),
            )))
            .group(Profile::kinematic(SteeringProfile::single(
                Behaviour::wander(),
            )));
        for i in 0..5003 {
            let a = i as f32 * 0.0123;
            let out = Vec2::new(a.cos(), a.sin());
            b = b.agent(AgentInit {
                position: Vec2::new(30.0, 30.0) + out * (27.0 + (i % 5) as f32 * 0.5),
                velocity: out * 4.0,
                ..AgentInit::at(Vec2::ZERO, i % 2)
            });
        }
        b.build().unwrap()
    };
    let (mut a, mut b) = (walled(), walled());
    for _ in 0..30 {
        a.step(0.05).unwrap();
        b.step_sequential(0.05).unwrap();
    }
    let on_wall = a
        .agents()
        .pos_x()
        .iter()
        .chain(a.agents().pos_y())
        .filter(|&&p| p == 0.0 || p == 60.0)
        .count();
    assert!(on_wall > 100, "{on_wall} coordinates on a wall");
    assert_eq!(snapshot(&a), snapshot(&b));
}

#[test]
fn groups_in_halves_give_the_same_bits_on_any_thread_count_and_sequentially() {
    // Two flocking groups in halves of the world (cells of one group's agents, which the cell
    // batch sums straight from the grid's columns, and mixed cells between), a few wanderers
    // among them, per-agent speed limits, over several of the batch's tasks and reorder frames.
    let world = |bounds: Bounds| {
        let profile = |same_group: bool, view_cos: f32, r: f32| {
            flocking_group(SteeringProfile::default(), same_group, view_cos, r)
        };
        let mut b = World::builder()
            .bounds(bounds)
            .seed(8)
            .group(profile(true, 0.3, 4.0))
            .group(profile(false, -0.6, 3.0))
            .group(Profile::dynamic(SteeringProfile::single(
                Behaviour::wander(),
            )));
        let mut rng = throng::rng::AgentRng::new(8, 0, 0, 5);
        for k in 0..6000 {
            let p = Vec2::new(rng.unit() * 120.0, rng.unit() * 80.0);
            let heading = rng.unit() * std::f32::consts::TAU;
            let speed = if k % 5 == 0 { 0.0 } else { 3.0 };
            let g = if k % 23 == 0 {
                2
            } else {
                usize::from(p.x > 60.0)
            };
            b = b.agent(AgentInit {
                velocity: Vec2::from_angle(heading) * speed,
                orientation: heading,
                max_speed: Some(2.5 + (k % 4) as f32 * 0.5),
                ..AgentInit::at(p, g)
            });
        }
        b.build().unwrap()
    };
    for bounds in [
        Bounds::bounded(120.0, 80.0).unwrap(),
        Bounds::torus(120.0, 80.0).unwrap(),
    ] {
        let mut sequential = world(bounds);
        for _ in 0..9 {
            sequential.step_sequential(0.1).unwrap();
        }
        let want = snapshot(&sequential);
        for threads in [1, 2, 4] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let mut w = world(bounds);
            pool.install(|| {
                for _ in 0..9 {
                    w.step(0.1).unwrap();
                }
            });
            assert!(snapshot(&w) == want, "{bounds:?} on {threads} threads");
        }
    }
}

#[test]
fn different_seeds_differ() {
    let mut a = mixed_world(100);
    let mut b = World::builder().seed(43).build().unwrap();
    for g in a.groups().to_vec() {
        b.add_group(g).unwrap();
    }
    for i in 0..a.len() {
        let s = a.agent(a.agents().id(i)).unwrap();
        b.add_agent(AgentInit {
            position: s.position,
            velocity: s.velocity,
            orientation: s.orientation,
            ..AgentInit::at(s.position, s.group)
        })
        .unwrap();
    }
    for _ in 0..10 {
        a.step(0.05).unwrap();
        b.step(0.05).unwrap();
    }
    assert_ne!(a.agents().pos_x(), b.agents().pos_x());
}

/// The bits of built-in scene `name` at `agents` agents after `steps` steps on `threads`
/// threads (0: `step_sequential` on one).
fn scene_bits(name: &str, agents: usize, threads: usize, steps: usize) -> Vec<u32> {
    let s = throng::scenario::builtin(name)
        .unwrap()
        .with_agents(agents)
        .unwrap();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .build()
        .unwrap();
    pool.install(|| {
        let mut w = s.build().unwrap();
        for _ in 0..steps {
            if threads == 0 {
                w.step_sequential(s.dt).unwrap();
            } else {
                w.step(s.dt).unwrap();
            }
        }
        snapshot(&w)
    })
}

#[test]
fn nearest_targets_from_cell_candidates_give_the_same_bits_on_any_thread_count() {
    // Pursuit's prey find their nearest predator from candidates each worker shares across a
    // cell's agents: which agents a worker serves must not change a bit.
    for (name, agents) in [("pursuit", 6_000)] {
        let one = scene_bits(name, agents, 1, 30);
        for threads in [0, 2, 4] {
            assert!(
                one == scene_bits(name, agents, threads, 30),
                "{name} on {threads} threads (0: sequential)"
            );
        }
    }
}

#[test]
fn repulsion_from_the_cell_batch_gives_the_same_bits_on_any_thread_count() {
    // Antigravity's seekers (the anti-gravity seek plan) repel each other through the cell
    // batch's repulsion kernel, in the grid's fixed order: one copy of the scene (one group) and three side by side (three
    // groups, cells of one group each), on 1, 2 and 4 threads and sequentially.
    for agents in [1_000, 3_000] {
        let s = throng::scenario::builtin("antigravity")
            .unwrap()
            .with_agents(agents)
            .unwrap();
        let mut w = s.build().unwrap();
        w.step(s.dt).unwrap();
        assert!(
            w.last_plans().iter().all(|&p| p == "anti_gravity_seek"),
            "the anti-gravity seek plan ran: {:?}",
            w.last_plans()
        );
        assert!(
            !w.last_summed().is_empty() && w.last_summed().iter().all(|&b| b),
            "the batch summed every group's repulsion: {:?}",
            w.last_summed()
        );
        let one = scene_bits("antigravity", agents, 1, 30);
        for threads in [0, 2, 4] {
            assert!(
                one == scene_bits("antigravity", agents, threads, 30),
                "antigravity at {agents} on {threads} threads (0: sequential)"
            );
        }
    }
}
