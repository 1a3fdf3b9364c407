//! A crowd of 2,000 chases a target that a script moves around a circle every frame, around
//! two round obstacles, and prints what each frame costs.
//!
//! The target is a slot, handed back by the builder's `target_slot`: `set_target_motion` is one
//! write per frame, however many agents chase it. The world's own spawner places the crowd clear
//! of its obstacles.
//!
//! Run with `cargo run --release --example chase`.

use throng::prelude::*;

fn main() -> throng::Result<()> {
    let (centre, orbit, dt) = (Vec2::splat(100.0), 60.0, 1.0 / 30.0);
    let rocks = [
        Circle::new(Vec2::new(70.0, 100.0), 12.0),
        Circle::new(Vec2::new(135.0, 110.0), 9.0),
    ];
    let (builder, player) = World::builder()
        .bounds(Bounds::bounded(200.0, 200.0)?)
        .circles(rocks)
        .target_slot(TargetPoint::at(centre + Vec2::X * orbit));
    let mut world = builder.build()?;
    let chase = SteeringProfile::default()
        .with(Behaviour::pursue(Target::Slot(player)), 2.0)
        .with(Behaviour::avoid_obstacles(), 1.0)
        .with(Behaviour::separation(1.0), 1.0);
    let crowd = world.add_group(Profile {
        max_speed: 25.0,
        max_acceleration: 60.0,
        ..Profile::dynamic(chase)
    })?;
    let start = world.spawner(1, 0.5).disc(2_000, centre, 40.0)?;
    for a in agents(&start, crowd, 0.0, 1) {
        world.add_agent(a)?;
    }
    for frame in 0..600u32 {
        // The script: once around the circle in twenty seconds, at 18.8 units per second.
        let heading = Vec2::from_angle(frame as f32 * dt * std::f32::consts::TAU / 20.0);
        let target = centre + heading * orbit;
        let velocity = heading.perp() * orbit * std::f32::consts::TAU / 20.0;
        world.set_target_motion(player, TargetPoint::at(target).moving(velocity))?;
        let stats = world.step(dt)?;
        if frame % 60 == 0 {
            let a = world.agents();
            let mean = (0..a.len())
                .map(|i| a.position(i).distance(target))
                .sum::<f32>();
            println!(
                "frame {:>3}: {:.3} ms ({:.3} steer), mean distance to the target {:.1}",
                stats.frame,
                stats.step_ms(),
                stats.phases.steer.as_secs_f64() * 1e3,
                mean / a.len() as f32,
            );
        }
    }
    Ok(())
}
