//! Document 000's anti-gravity movement: one agent crosses a field of repelling gravity points
//! (`strength / distance^2`) to reach its target, one step at a time.
//!
//! One tick: the gravity points' forces on the agent are summed (through a grid over the points),
//! the direction `normalize(normalize(target - p) + total force)` is taken at full speed, and the
//! agent moves. Prints the path every few steps.
//!
//! Run with `cargo run --release --example antigravity`.

use throng::gravity::GravityPoint;
use throng::prelude::*;

fn main() -> throng::Result<()> {
    let target = Vec2::new(380.0, 200.0);
    let seeker = Profile {
        max_speed: 20.0,
        ..Profile::kinematic(SteeringProfile::single(Behaviour::AntiGravitySeek {
            target: Target::Point(target),
        }))
    };
    let mut world = World::builder()
        .bounds(Bounds::bounded(400.0, 400.0)?)
        .group(seeker)
        .agent(AgentInit::at(Vec2::new(20.0, 190.0), 0))
        .build()?;
    // A lattice of repelling points with strength 2000 and n = 2, as in the document.
    for i in 0..4 {
        for j in 0..5 {
            let p = Vec2::new(
                100.0 + 60.0 * i as f32,
                60.0 + 70.0 * j as f32 + 35.0 * (i % 2) as f32,
            );
            world.add_gravity_point(GravityPoint::fixed(p, 2000.0, 2.0, 300.0))?;
        }
    }
    for step in 0..2_000 {
        world.step(1.0 / 30.0)?;
        let p = world.agents().position(0);
        if step % 20 == 0 {
            println!("step {step:4}: ({:6.1}, {:6.1})", p.x, p.y);
        }
        if p.distance(target) <= 1.0 {
            println!("reached the target after {step} steps");
            break;
        }
    }
    Ok(())
}
