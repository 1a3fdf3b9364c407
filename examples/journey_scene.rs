//! The journey scene of `scripts/peers/journeys.py` as a Rust program, for profiles and
//! instruction counts of its step without Python.
//!
//! Setup: the open concourse 215 m x 184 m with two holes, a waypoint at (188, 92) reached
//! within 100 m, two exits 15 m x 44 m on the east wall; 10,000 agents on a 1.8 m lattice
//! (jittered by up to 0.05 m by a seeded generator, not numpy's), the even ones on a weighted
//! round robin 1:3 to the exits, the odd ones to the least targeted exit; the speed model with
//! JuPedSim's parameters (as the script's `THRONG_PARAMS`), radius 0.2 m, 1.2 m/s, dt 0.01 s.
//! One tick: `World::step` on a pool of `threads` workers.
//!
//! Run with `cargo run --release --example journey_scene -- [agents] [steps] [threads]
//! [warmup]` (defaults 10000, 200, 1, 20); prints the build time, ms per step, the agents
//! left at each exit and a checksum of the positions by id.

use std::time::Instant;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use throng::journey::{Journey, Stage, Transition};
use throng::ped::{Model, Pedestrian, PedestrianTable};
use throng::prelude::*;
use throng::profile::Profile;
use throng::{Bounds, Walkable};

const CONCOURSE: &str = "POLYGON ((0 0, 215 0, 215 184, 0 184, 0 0), \
     (190 87, 194 87, 194 97, 190 97, 190 87), \
     (195 60, 197 60, 197 62, 195 62, 195 60))";
const NORTH: &str = "POLYGON ((200 140, 215 140, 215 184, 200 184, 200 140))";
const SOUTH: &str = "POLYGON ((200 0, 215 0, 215 44, 200 44, 200 0))";
/// The script's `THRONG_PARAMS`: JuPedSim's collision-free speed model.
const PARAMS: &str = "[cfsm]\ntime_gap = 1.0\npressed_time_gap = 1.0\npressed_anisotropy = 1.0\n\
     reference_speed = 0.0\npath_width = 1.0\nspacing = \"centre\"\nspeed_function = \"linear\"\n";

fn arg(k: usize, default: usize) -> usize {
    std::env::args()
        .nth(k)
        .and_then(|a| a.parse().ok())
        .unwrap_or(default)
}

fn scene(agents: usize) -> throng::Result<World> {
    let mut world = World::builder().bounds(Bounds::Open).seed(1).build()?;
    world.set_walkable(Walkable::from_wkt(CONCOURSE)?)?;
    let hall = world.add_stage(Stage::Waypoint {
        position: Vec2::new(188.0, 92.0),
        distance: 100.0,
    })?;
    let north = world.add_stage(Stage::Exit {
        area: Walkable::from_wkt(NORTH)?,
    })?;
    let south = world.add_stage(Stage::Exit {
        area: Walkable::from_wkt(SOUTH)?,
    })?;
    let rr = world.add_journey(
        Journey::new([hall, north, south])
            .with_transition(hall, Transition::round_robin([(north, 1), (south, 3)])),
    )?;
    let lt = world.add_journey(
        Journey::new([hall, north, south])
            .with_transition(hall, Transition::least_targeted([north, south])),
    )?;
    let table: PedestrianTable = toml::from_str(PARAMS).expect("the parameters parse");
    let mut profile = Profile::journey_walkers(Model::Cfsm);
    profile.pedestrian = Some(Pedestrian::from(table));
    let group = world.add_group(profile)?;
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    for k in 0..agents.min(10_000) {
        let (i, j) = ((k / 100) as f32, (k % 100) as f32);
        let p = Vec2::new(180.2 - 1.8 * i, 2.9 + 1.8 * j)
            + Vec2::new(rng.random_range(-0.05..0.05), rng.random_range(-0.05..0.05));
        let id = world.add_agent(AgentInit {
            position: p,
            group,
            radius: Some(0.2),
            desired_speed: Some(1.2),
            ..AgentInit::default()
        })?;
        world.set_journey(id, if k % 2 == 0 { rr } else { lt }, Some(hall))?;
    }
    Ok(world)
}

fn main() -> throng::Result<()> {
    let (agents, steps, threads, warmup) = (arg(1, 10_000), arg(2, 200), arg(3, 1), arg(4, 20));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .build()
        .expect("a thread pool");
    pool.install(|| {
        let t = Instant::now();
        let mut world = scene(agents)?;
        let step = |w: &mut World| w.step(0.01);
        for _ in 0..warmup {
            step(&mut world)?;
        }
        let built = t.elapsed();
        let t = Instant::now();
        for _ in 0..steps {
            step(&mut world)?;
        }
        let ms = t.elapsed().as_secs_f64() * 1e3 / steps.max(1) as f64;
        let left: Vec<u64> = world.stage_counts().iter().map(|c| c.left).collect();
        // The positions' bits by id, folded: equal runs print the same number.
        let a = world.agents();
        let mut by_id: Vec<(u32, u32, u32)> = (0..a.len())
            .map(|i| (a.id(i).0, a.pos_x()[i].to_bits(), a.pos_y()[i].to_bits()))
            .collect();
        by_id.sort_unstable();
        let sum = by_id.iter().fold(0u64, |h, &(id, x, y)| {
            (h ^ u64::from(id) ^ (u64::from(x) << 32 | u64::from(y))).wrapping_mul(0x100_0000_01b3)
        });
        println!(
            "{agents} agents, {threads} threads: build and {warmup} warm-up steps {:.1} ms, \
             {ms:.3} ms a step, {} left inside, left per stage {left:?}, positions {sum:016x}",
            built.as_secs_f64() * 1e3,
            world.len()
        );
        Ok(())
    })
}
