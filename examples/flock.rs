//! A flock of 5,000 boids on a torus, stepped on all cores.
//!
//! One tick: the grid index is rebuilt (agents reordered by cell every few frames), every boid
//! sums its neighbours' separation, alignment and cohesion in one fused pass, and the SIMD
//! integrator moves them. Prints the flock's polarisation as it forms.
//!
//! Run with `cargo run --release --example flock`.

use throng::prelude::*;
use throng::steering::polarisation;

fn main() -> throng::Result<()> {
    let boids = SteeringProfile::default()
        .with(
            Behaviour::Separation {
                hood: Neighbourhood::radius(2.0),
            },
            1.5,
        )
        .with(
            Behaviour::Alignment {
                hood: Neighbourhood::radius(5.0),
            },
            2.0,
        )
        .with(
            Behaviour::Cohesion {
                hood: Neighbourhood::radius(5.0),
            },
            0.8,
        );
    let group = Profile {
        max_speed: 4.0,
        max_acceleration: 8.0,
        ..Profile::dynamic(boids)
    };
    // About 18 neighbours within the 5-unit flocking radius.
    let side = (5_000.0 * std::f32::consts::PI * 25.0 / 18.0_f32).sqrt();
    let mut builder = World::builder()
        .bounds(Bounds::torus(side, side)?)
        .seed(7)
        .group(group);
    let mut rng = throng::rng::AgentRng::new(7, 0, 0, 1);
    for _ in 0..5_000 {
        let position = Vec2::new(rng.unit() * side, rng.unit() * side);
        let heading = rng.unit() * std::f32::consts::TAU;
        builder = builder.agent(AgentInit {
            velocity: Vec2::from_angle(heading) * 4.0,
            ..AgentInit::at(position, 0)
        });
    }
    let mut world = builder.build()?;
    for frame in 1..=600 {
        let stats = world.step(1.0 / 30.0)?;
        if frame % 100 == 0 {
            let a = world.agents();
            println!(
                "frame {frame:4}: {:.2} ms, {:.1} neighbours each, polarisation {:.3}",
                stats.total_ms(),
                stats.mean_neighbours,
                polarisation(a.vel_x(), a.vel_y())
            );
        }
    }
    Ok(())
}
