//! What a newcomer writes with the prelude alone: a target slot handed back by the builder
//! (no `TargetSlot(0)` from a doc sentence), the spawn helpers and obstacle types, a spawner
//! that avoids the world's own obstacles, the step time under the name the command line gives
//! it, and a lookup by stable id that survives the reorders.

use throng::prelude::*;

#[test]
fn the_builder_hands_back_each_target_slot_it_adds() {
    let (builder, first) = World::builder()
        .bounds(Bounds::bounded(100.0, 100.0).unwrap())
        .target_slot(TargetPoint::at(Vec2::new(10.0, 10.0)));
    let (builder, second) = builder
        .target(TargetPoint::at(Vec2::new(20.0, 20.0)))
        .target_slot(TargetPoint::at(Vec2::new(30.0, 30.0)));
    let chase = SteeringProfile::single(Behaviour::seek(Target::Slot(second)));
    let mut world = builder
        .group(Profile::kinematic(chase))
        .agent(AgentInit::at(Vec2::new(50.0, 50.0), 0))
        .build()
        .unwrap();
    assert_eq!(
        world.target_slot(first).unwrap().position,
        Vec2::new(10.0, 10.0)
    );
    assert_eq!(
        world.target_slot(second).unwrap().position,
        Vec2::new(30.0, 30.0),
        "the third slot added, after a plain `target`"
    );
    world
        .set_target_point(second, Vec2::new(90.0, 50.0))
        .unwrap();
    world.step(0.1).unwrap();
    assert!(
        world.agents().velocity(0).x > 0.0,
        "the agent seeks the moved slot"
    );
}

#[test]
fn the_worlds_spawner_avoids_its_own_circles() {
    let rocks = [
        Circle::new(Vec2::new(40.0, 50.0), 8.0),
        Circle::new(Vec2::new(62.0, 50.0), 6.0),
    ];
    let world = World::builder()
        .bounds(Bounds::bounded(100.0, 100.0).unwrap())
        .circles(rocks)
        .group(Profile::dynamic(SteeringProfile::default()))
        .build()
        .unwrap();
    let obstacles: &Obstacles = world.obstacles();
    let points = world
        .spawner(5, 0.5)
        .disc(500, Vec2::splat(50.0), 25.0)
        .unwrap();
    assert_eq!(points.len(), 500);
    for p in &points {
        for c in &rocks {
            assert!(p.distance(c.center) >= c.radius + 0.5, "{p} in {c:?}");
        }
    }
    let same = Spawner::new(5)
        .avoiding(obstacles, 0.5)
        .disc(500, Vec2::splat(50.0), 25.0)
        .unwrap();
    assert_eq!(points, same);
    let inits: Vec<AgentInit> = agents(&points, 0, 0.0, 5).collect();
    assert_eq!(inits.len(), 500);
}

#[test]
fn step_time_has_the_command_lines_name_and_ids_outlive_reorders() {
    let start = Spawner::new(2)
        .rect(400, Vec2::ZERO, Vec2::splat(50.0))
        .unwrap();
    let flock = SteeringProfile::default()
        .with(Behaviour::separation(2.0), 1.0)
        .with(Behaviour::cohesion(5.0), 0.5);
    let mut world = World::builder()
        .bounds(Bounds::torus(50.0, 50.0).unwrap())
        .group(Profile::dynamic(flock))
        .agents(agents(&start, 0, 3.0, 2))
        .build()
        .unwrap();
    let id = world.agents().id(123);
    let mut moved = false;
    for _ in 0..20 {
        let stats = world.step(0.1).unwrap();
        assert_eq!(stats.step_ms(), stats.total_ms());
        let i = world.agents().index_of(id).unwrap();
        moved |= i != 123;
        assert_eq!(
            world.agent(id).unwrap().position,
            world.agents().position(i)
        );
    }
    assert!(
        moved,
        "the reorder moved the agent in storage (or this test shows nothing)"
    );
}
