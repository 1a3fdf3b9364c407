//! The library in a game loop: target slots, builder completeness, spawn helpers, constructors,
//! the default seed and the priority combiner's weights.

use proptest::prelude::*;
use throng::field::{GoalChannels, Neighbourhood as Moves, OccupancyGrid};
use throng::gravity::{GravityPoint, Motion};
use throng::obstacles::{Circle, Obstacles, Wall};
use throng::prelude::*;
use throng::spawn::{Spawner, agents};
use throng::world::DEFAULT_SEED;

const DT: f32 = 1.0 / 30.0;

/// Bits of every agent's position and velocity.
fn state(w: &World) -> Vec<[u32; 4]> {
    let a = w.agents();
    (0..a.len())
        .map(|i| {
            let (p, v) = (a.position(i), a.velocity(i));
            [p.x, p.y, v.x, v.y].map(f32::to_bits)
        })
        .collect()
}

/// Three groups of 40: group 0 seeks slot 0 alone (the lane plan), group 1 seeks slot 0 with
/// separation (the general plan), group 2 seeks slot 1.
fn slot_world() -> (World, TargetSlot, TargetSlot) {
    let mut w = World::builder()
        .bounds(Bounds::bounded(100.0, 100.0).unwrap())
        .build()
        .unwrap();
    let s0 = w.add_target(Vec2::new(80.0, 80.0)).unwrap();
    let s1 = w.add_target(Vec2::new(20.0, 80.0)).unwrap();
    let alone = SteeringProfile::single(Behaviour::seek(Target::Slot(s0)));
    let mixed = SteeringProfile::single(Behaviour::seek(Target::Slot(s0)))
        .with(Behaviour::separation(2.0), 1.0);
    let other = SteeringProfile::single(Behaviour::seek(Target::Slot(s1)));
    for p in [alone, mixed, other] {
        let g = w.add_group(Profile::kinematic(p)).unwrap();
        let pts = Spawner::new(g as u64)
            .rect(40, Vec2::new(30.0, 10.0), Vec2::new(70.0, 50.0))
            .unwrap();
        for a in agents(&pts, g, 0.0, 3) {
            w.add_agent(a).unwrap();
        }
    }
    (w, s0, s1)
}

#[test]
fn moving_a_slot_changes_the_next_step_of_its_agents_and_of_no_other() {
    let (mut moved, s0, _) = slot_world();
    let (mut still, ..) = slot_world();
    for _ in 0..3 {
        moved.step(DT).unwrap();
        still.step(DT).unwrap();
    }
    assert_eq!(state(&moved), state(&still));
    moved.set_target_point(s0, Vec2::new(10.0, 10.0)).unwrap();
    moved.step(DT).unwrap();
    still.step(DT).unwrap();
    let (a, b) = (state(&moved), state(&still));
    for i in 0..a.len() {
        let group = moved.agents().groups()[i];
        if group == 2 {
            assert_eq!(a[i], b[i], "agent {i} of group 2 does not refer to slot 0");
        } else {
            assert_ne!(a[i], b[i], "agent {i} of group {group} refers to slot 0");
            // Heading for the new point: the velocity points at (10, 10).
            let p = moved.agents().position(i);
            let v = moved.agents().velocity(i);
            assert!(
                v.dot(Vec2::new(10.0, 10.0) - p) > 0.0,
                "agent {i} steers away"
            );
        }
    }
}

#[test]
fn a_slot_target_equals_the_same_fixed_point() {
    let (mut slots, ..) = slot_world();
    let mut points = World::builder()
        .bounds(Bounds::bounded(100.0, 100.0).unwrap())
        .build()
        .unwrap();
    let fixed = |x, y| Target::Point(Vec2::new(x, y));
    for (g, p) in [
        SteeringProfile::single(Behaviour::seek(fixed(80.0, 80.0))),
        SteeringProfile::single(Behaviour::seek(fixed(80.0, 80.0)))
            .with(Behaviour::separation(2.0), 1.0),
        SteeringProfile::single(Behaviour::seek(fixed(20.0, 80.0))),
    ]
    .into_iter()
    .enumerate()
    {
        points.add_group(Profile::kinematic(p)).unwrap();
        let pts = Spawner::new(g as u64)
            .rect(40, Vec2::new(30.0, 10.0), Vec2::new(70.0, 50.0))
            .unwrap();
        for a in agents(&pts, g, 0.0, 3) {
            points.add_agent(a).unwrap();
        }
    }
    for _ in 0..20 {
        slots.step(DT).unwrap();
        points.step(DT).unwrap();
    }
    assert_eq!(state(&slots), state(&points));
}

#[test]
fn pursuit_of_a_slot_predicts_with_its_velocity() {
    let run = |velocity: Vec2| {
        let mut w = World::builder().build().unwrap();
        let s = w
            .add_target_point(TargetPoint::at(Vec2::new(20.0, 0.0)).moving(velocity))
            .unwrap();
        let g = w
            .add_group(Profile::kinematic(SteeringProfile::single(
                Behaviour::pursue(Target::Slot(s)),
            )))
            .unwrap();
        w.add_agent(AgentInit::at(Vec2::ZERO, g)).unwrap();
        w.step(DT).unwrap();
        w.agents().velocity(0)
    };
    let at_rest = run(Vec2::ZERO);
    let rising = run(Vec2::new(0.0, 10.0));
    assert!(at_rest.y.abs() < 1e-6, "{at_rest}");
    assert!(rising.y > 0.1, "pursuit leads a rising target: {rising}");
}

#[test]
fn bad_slots_and_bad_points_are_errors() {
    let mut w = World::builder().build().unwrap();
    let seek_missing = Profile::kinematic(SteeringProfile::single(Behaviour::seek(Target::Slot(
        TargetSlot(0),
    ))));
    assert!(matches!(
        w.add_group(seek_missing.clone()),
        Err(Error::UnknownTarget { slot: 0, count: 0 })
    ));
    let s = w.add_target(Vec2::ONE).unwrap();
    w.add_group(seek_missing.clone()).unwrap();
    for bad in [
        Vec2::new(f32::NAN, 0.0),
        Vec2::new(0.0, f32::INFINITY),
        Vec2::new(1e20, 0.0),
    ] {
        assert!(w.set_target_point(s, bad).is_err(), "{bad} accepted");
        assert!(w.add_target(bad).is_err(), "{bad} added");
    }
    assert_eq!(w.target_slot(s).unwrap().position, Vec2::ONE);
    assert!(matches!(
        w.set_target_point(TargetSlot(5), Vec2::ZERO),
        Err(Error::UnknownTarget { slot: 5, count: 1 })
    ));
    assert!(
        World::builder()
            .group(seek_missing)
            .build()
            .is_err_and(|e| matches!(e, Error::UnknownTarget { .. }))
    );
}

fn scene_parts() -> (Vec<Circle>, Vec<Wall>, GoalChannels, GravityPoint) {
    let circles = vec![
        Circle {
            center: Vec2::new(50.0, 50.0),
            radius: 8.0,
        },
        Circle {
            center: Vec2::new(20.0, 70.0),
            radius: 5.0,
        },
    ];
    let walls = vec![Wall {
        a: Vec2::new(10.0, 30.0),
        b: Vec2::new(40.0, 30.0),
    }];
    let grid = OccupancyGrid::new(20, 20)
        .unwrap()
        .with_geometry(5.0, Vec2::ZERO)
        .unwrap();
    let mut channels = GoalChannels::new(grid, 0.9, Moves::Eight).unwrap();
    channels.add_channel(&[(18, 18)]).unwrap();
    let gravity = GravityPoint {
        position: Vec2::new(60.0, 20.0),
        strength: 30.0,
        exponent: 2.0,
        radius: 15.0,
        motion: Motion::Static,
    };
    (circles, walls, channels, gravity)
}

fn scene_groups() -> Vec<Profile> {
    let seek = SteeringProfile::single(Behaviour::follow_field(0, 0))
        .with(Behaviour::avoid_obstacles(), 2.0)
        .with(Behaviour::anti_gravity(), 1.0)
        .with(Behaviour::separation(1.5), 1.0);
    vec![Profile::dynamic(seek)]
}

#[test]
fn builder_obstacles_fields_and_gravity_equal_the_same_added_after_build() {
    let (circles, walls, channels, gravity) = scene_parts();
    let mut clear = Obstacles::new();
    for c in &circles {
        clear.add_circle(*c).unwrap();
    }
    let pts = Spawner::new(9)
        .avoiding(&clear, 0.5)
        .rect(300, Vec2::new(2.0, 2.0), Vec2::new(98.0, 98.0))
        .unwrap();
    let inits: Vec<AgentInit> = agents(&pts, 0, 1.0, 9).collect();
    let mut built = World::builder()
        .bounds(Bounds::bounded(100.0, 100.0).unwrap())
        .groups(scene_groups())
        .agents(inits.clone())
        .circles(circles.clone())
        .wall(walls[0])
        .field(channels.clone())
        .gravity_point(gravity)
        .build()
        .unwrap();
    let mut after = World::builder()
        .bounds(Bounds::bounded(100.0, 100.0).unwrap())
        .groups(scene_groups())
        .agents(inits)
        .build()
        .unwrap();
    for c in circles {
        after.add_circle(c).unwrap();
    }
    after.add_wall(walls[0]).unwrap();
    after.add_field(channels).unwrap();
    after.add_gravity_point(gravity).unwrap();
    for _ in 0..30 {
        built.step(DT).unwrap();
        after.step(DT).unwrap();
    }
    assert_eq!(state(&built), state(&after));
    assert_eq!(built.obstacles().circles().len(), 2);
    assert_eq!(built.obstacles().walls().len(), 1);
}

#[test]
fn an_agent_inside_a_builder_obstacle_is_an_error_naming_it() {
    let (circles, ..) = scene_parts();
    let err = World::builder()
        .bounds(Bounds::bounded(100.0, 100.0).unwrap())
        .groups(scene_groups())
        .agent(AgentInit::at(Vec2::new(5.0, 5.0), 0))
        .agent(AgentInit::at(Vec2::new(51.0, 50.0), 0))
        .circles(circles.clone())
        .build()
        .unwrap_err()
        .to_string();
    assert!(err.contains("agent #1"), "{err}");
    // Added to a world that has the obstacle already, the agent is named as well.
    let mut w = World::builder()
        .bounds(Bounds::bounded(100.0, 100.0).unwrap())
        .groups(scene_groups())
        .circles(circles)
        .build()
        .unwrap();
    let err = w
        .add_agent(AgentInit::at(Vec2::new(51.0, 50.0), 0))
        .unwrap_err()
        .to_string();
    assert!(err.contains("agent #0"), "{err}");
}

#[test]
fn the_builder_and_scenario_files_share_the_default_seed() {
    let w = World::builder().build().unwrap();
    assert_eq!(w.seed(), DEFAULT_SEED);
    let text = "name = 't'\n[world]\nkind = 'torus'\nsize = [10, 10]\n[[groups]]\ncount = 1\n";
    let s = throng::scenario::Scenario::from_toml(text, "t.toml").unwrap();
    assert_eq!(s.build().unwrap().seed(), DEFAULT_SEED);
}

#[test]
fn priority_scales_each_request_by_its_weight_before_the_budget() {
    let run = |weight: f32, combine: Combine| {
        let p = SteeringProfile::default()
            .with(
                Behaviour::seek(Target::Point(Vec2::new(100.0, 0.0))),
                weight,
            )
            .with(Behaviour::seek(Target::Point(Vec2::new(0.0, 100.0))), 1.0)
            .combined(combine);
        let mut w = World::builder()
            .group(Profile {
                max_speed: 4.0,
                ..Profile::kinematic(p)
            })
            .agent(AgentInit::at(Vec2::ZERO, 0))
            .build()
            .unwrap();
        w.step(DT).unwrap();
        w.agents().velocity(0)
    };
    // Weight 1: the first seek spends the whole budget (the maximum speed); the second gets
    // nothing.
    let full = run(1.0, Combine::Priority);
    assert!((full - Vec2::new(4.0, 0.0)).length() < 1e-5, "{full}");
    // Weight 0.25: the first request is 1 long; the second fills the remaining 3.
    let quarter = run(0.25, Combine::Priority);
    assert!((quarter - Vec2::new(1.0, 3.0)).length() < 1e-4, "{quarter}");
}

fn inside_rect(p: Vec2, min: Vec2, max: Vec2) -> bool {
    p.x >= min.x && p.y >= min.y && p.x <= max.x && p.y <= max.y
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    #[test]
    fn spawn_helpers_are_deterministic_and_stay_in_their_shapes(
        seed in any::<u64>(),
        n in 0usize..400,
        (x, y) in (-50.0f32..50.0, -50.0f32..50.0),
        (w, h) in (0.5f32..40.0, 0.5f32..40.0),
        r in 0.5f32..30.0,
        inner_frac in 0.0f32..0.9,
        jitter in 0.0f32..1.0,
    ) {
        let (min, max) = (Vec2::new(x, y), Vec2::new(x + w, y + h));
        let c = Vec2::new(x, y);
        let s = Spawner::new(seed);
        let shapes = [
            s.rect(n, min, max).unwrap(),
            s.disc(n, c, r).unwrap(),
            s.ring(n, c, r * inner_frac, r).unwrap(),
            s.grid(n, min, max).unwrap(),
            s.jittered_grid(n, min, max, jitter).unwrap(),
        ];
        let again = Spawner::new(seed);
        prop_assert_eq!(&shapes[0], &again.rect(n, min, max).unwrap());
        prop_assert_eq!(&shapes[2], &again.ring(n, c, r * inner_frac, r).unwrap());
        prop_assert_eq!(&shapes[4], &again.jittered_grid(n, min, max, jitter).unwrap());
        for pts in &shapes {
            prop_assert_eq!(pts.len(), n);
        }
        let eps = 1e-3 * (1.0 + r);
        prop_assert!(shapes[0].iter().all(|&p| inside_rect(p, min, max)));
        prop_assert!(shapes[1].iter().all(|&p| p.distance(c) <= r + eps));
        let in_ring = |p: Vec2| (r * inner_frac - eps..=r + eps).contains(&p.distance(c));
        prop_assert!(shapes[2].iter().all(|&p| in_ring(p)));
        prop_assert!(shapes[3].iter().all(|&p| inside_rect(p, min, max)));
        prop_assert!(shapes[4].iter().all(|&p| inside_rect(p, min, max)));
        if n >= 20 {
            prop_assert_ne!(&shapes[0], &Spawner::new(seed ^ 1).rect(n, min, max).unwrap());
        }
    }

    #[test]
    fn poisson_disc_points_keep_their_spacing_and_avoid_obstacles(
        seed in any::<u64>(),
        spacing in 0.5f32..3.0,
        (w, h) in (5.0f32..40.0, 5.0f32..40.0),
        clearance in 0.0f32..1.0,
    ) {
        let mut obstacles = Obstacles::new();
        obstacles.add_circle(Circle { center: Vec2::new(w / 2.0, h / 2.0), radius: w.min(h) / 4.0 }).unwrap();
        let s = Spawner::new(seed).avoiding(&obstacles, clearance);
        let (min, max) = (Vec2::ZERO, Vec2::new(w, h));
        let pts = s.poisson_disc(min, max, spacing, 100_000).unwrap();
        prop_assert_eq!(&pts, &s.poisson_disc(min, max, spacing, 100_000).unwrap());
        // Maximal-ish: a fair share of the area is covered (a square lattice of the spacing
        // holds area / spacing^2 points; blue noise reaches well over a third of that).
        let free_area = w * h - std::f32::consts::PI * (w.min(h) / 4.0 + clearance).powi(2);
        prop_assert!(pts.len() as f32 > 0.3 * free_area / (spacing * spacing), "{} points", pts.len());
        for (k, &p) in pts.iter().enumerate() {
            prop_assert!(inside_rect(p, min, max));
            prop_assert!(!obstacles.near_circle(p, clearance), "{p} near the obstacle");
            for &q in &pts[..k] {
                prop_assert!(p.distance(q) >= spacing * (1.0 - 1e-5), "{p} and {q} too close");
            }
        }
        for pts in [
            s.rect(200, min, max).unwrap(),
            s.disc(200, Vec2::new(w / 2.0, h / 2.0), w.min(h) / 2.0).unwrap(),
            s.grid(200, min, max).unwrap(),
            s.jittered_grid(200, min, max, 0.5).unwrap(),
        ] {
            prop_assert_eq!(pts.len(), 200);
            prop_assert!(pts.iter().all(|&p| !obstacles.near_circle(p, clearance)));
        }
    }
}

#[test]
fn free_cell_spawns_stay_on_free_cells() {
    let mut grid = OccupancyGrid::new(10, 10)
        .unwrap()
        .with_geometry(2.0, Vec2::new(-10.0, -10.0))
        .unwrap();
    for y in 0..10 {
        for x in 0..10 {
            if (x + y) % 3 == 0 {
                grid.set(x, y, throng::field::Cell::Wall).unwrap();
            }
        }
    }
    let pts = Spawner::new(4).free_cells(500, &grid).unwrap();
    assert_eq!(pts, Spawner::new(4).free_cells(500, &grid).unwrap());
    for p in pts {
        let (x, y) = grid.world_to_cell(p).expect("on the grid");
        assert!(grid.is_free(x, y), "{p} on a wall cell");
    }
    let walls = OccupancyGrid::from_cells(2, 1, vec![throng::field::Cell::Wall; 2]).unwrap();
    assert!(Spawner::new(0).free_cells(1, &walls).is_err());
}

#[test]
fn impossible_or_absurd_spawns_are_errors_not_hangs() {
    let mut full = Obstacles::new();
    full.add_circle(Circle {
        center: Vec2::splat(5.0),
        radius: 50.0,
    })
    .unwrap();
    let (min, max) = (Vec2::ZERO, Vec2::splat(10.0));
    let s = Spawner::new(1).avoiding(&full, 0.0);
    assert!(s.rect(10, min, max).is_err());
    assert!(s.grid(10, min, max).is_err());
    assert!(s.poisson_disc(min, max, 1.0, 10).is_err());
    let s = Spawner::new(1);
    assert!(s.rect(200_000_000, min, max).is_err());
    assert!(s.poisson_disc(min, Vec2::splat(1e9), 1e-3, 10).is_err());
    assert!(s.rect(1, max, min).is_err());
    assert!(s.disc(1, Vec2::new(f32::NAN, 0.0), 1.0).is_err());
    assert!(s.ring(1, Vec2::ZERO, 2.0, 1.0).is_err());
    assert!(s.jittered_grid(1, min, max, 2.0).is_err());
}

#[test]
fn scenario_files_declare_target_slots() {
    let text = r#"
name = "slots"
[world]
kind = "bounded"
size = [100, 100]
[[targets]]
position = [90, 90]
[[groups]]
count = 50
model = "kinematic"
max_speed = 10
spawn = { kind = "rect", min = [5, 5], max = [20, 20] }
steering = { behaviours = [{ kind = "arrive", target = { slot = 0 } }] }
"#;
    let s = throng::scenario::Scenario::from_toml(text, "slots.toml").unwrap();
    let mut w = s.build().unwrap();
    assert_eq!(w.target_slots(), 1);
    w.set_target_point(TargetSlot(0), Vec2::new(50.0, 80.0))
        .unwrap();
    for _ in 0..600 {
        w.step(DT).unwrap();
    }
    let a = w.agents();
    assert!((0..a.len()).all(|i| a.position(i).distance(Vec2::new(50.0, 80.0)) < 1.0));
    let missing = text.replace("{ slot = 0 }", "{ slot = 1 }");
    let err = throng::scenario::Scenario::from_toml(&missing, "slots.toml")
        .and_then(|s| s.build())
        .unwrap_err()
        .to_string();
    assert!(err.contains("no target slot 1"), "{err}");
}

#[test]
fn target_slots_survive_a_checkpoint() {
    let (mut w, s0, _) = slot_world();
    w.step(DT).unwrap();
    w.set_target_motion(
        s0,
        TargetPoint::at(Vec2::new(15.0, 60.0)).moving(Vec2::new(1.0, 2.0)),
    )
    .unwrap();
    let mut bytes = Vec::new();
    w.save(&mut bytes).unwrap();
    let mut loaded = World::load(&mut bytes.as_slice()).unwrap();
    assert_eq!(loaded.target_slot(s0), w.target_slot(s0));
    for _ in 0..5 {
        w.step(DT).unwrap();
        loaded.step(DT).unwrap();
    }
    assert_eq!(state(&w), state(&loaded));
}

/// `GroupParams`, the former name of `Profile`, still compiles where users wrote it, as a
/// deprecated alias at the crate's root, in the prelude and in `world`.
#[test]
#[allow(deprecated)]
fn the_former_name_of_profile_still_compiles() {
    let p: throng::GroupParams = throng::Profile::default();
    let q: throng::prelude::GroupParams = throng::world::GroupParams::default();
    assert_eq!(p, q);
}
