//! A crowd of 2,000 agents finding the nearest of four goals through a cave (document 001).
//!
//! Setup: a seeded 400 x 400 cave (85% walls, free space connected), one BFS potential field
//! from four goals (decay 0.99, 8-neighbourhood) with its flow field, shared by every agent.
//! One tick: each agent samples the flow field where it stands and steers along it at full speed
//! (dynamic model) while keeping apart from its neighbours; the world keeps every agent out of
//! the walls. Prints how many have arrived.
//!
//! Run with `cargo run --release --example field_crowd`.

use throng::field::{GoalChannels, Neighbourhood as Cells, OccupancyGrid, random_free_cells};
use throng::prelude::*;

fn main() -> throng::Result<()> {
    let grid = OccupancyGrid::caves(400, 400, 0.85, 7)?;
    let goals = random_free_cells(&grid, 4, 8)?;
    let starts = random_free_cells(&grid, 2_000, 9)?;
    let mut channels = GoalChannels::new(grid, 0.99, Cells::Eight)?;
    channels.add_channel(&goals)?;

    let crowd = SteeringProfile::default()
        .with(
            Behaviour::FollowField {
                field: 0,
                channel: 0,
            },
            1.0,
        )
        .with(
            Behaviour::Separation {
                hood: Neighbourhood::radius(0.6),
            },
            0.3,
        );
    let group = Profile {
        max_speed: 6.0,
        max_acceleration: 30.0,
        radius: 0.25,
        ..Profile::dynamic(crowd)
    };
    let agents = starts
        .iter()
        .map(|&(x, y)| AgentInit::at(Vec2::new(x as f32 + 0.5, y as f32 + 0.5), 0));
    let mut world = World::builder()
        .bounds(Bounds::bounded(400.0, 400.0)?)
        .seed(7)
        .group(group)
        .agents(agents)
        .build()?;
    world.add_field(channels)?;

    for step in 1..=8_000 {
        world.step(1.0 / 30.0)?;
        if step % 500 == 0 {
            println!(
                "step {step:5}: {:5} of {} agents at a goal",
                world.arrived_count(),
                world.len()
            );
        }
        if world.arrived_count() == world.len() {
            println!("everyone arrived after {step} steps");
            break;
        }
    }
    Ok(())
}
