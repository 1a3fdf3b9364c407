//! # throng
//!
//! A data-parallel crowd and flock simulator.
//!
//! throng keeps agents in structure-of-arrays buffers, steers them with Reynolds' behaviours in
//! the kinematic and the dynamic (Newton-Euler, force / mass) model, and steps them with a
//! rayon-parallel steering pass feeding a SIMD integrator. The same seed gives the same bits on
//! any number of threads.
//!
//! ## Quick start
//! ```
//! use throng::prelude::*;
//!
//! # fn main() -> throng::Result<()> {
//! let target = Vec2::new(80.0, 20.0);
//! let arrive = SteeringProfile::single(Behaviour::Arrive { target: Target::Point(target), params: ArriveParams::default() });
//! let mut world = World::builder()
//!     .bounds(Bounds::bounded(100.0, 100.0)?)
//!     .group(Profile { max_speed: 5.0, max_acceleration: 10.0, ..Profile::dynamic(arrive) })
//!     .agent(AgentInit::at(Vec2::new(10.0, 10.0), 0))
//!     .build()?;
//! // An agent's id is stable; its storage index changes as the world reorders its agents.
//! let id = world.agents().id(0);
//! for _ in 0..600 {
//!     world.step(1.0 / 30.0)?;
//! }
//! let p = world.agent(id).expect("nobody left").position;
//! assert!(p.distance(target) < 0.3);
//! # Ok(())
//! # }
//! ```
//!
//! ## Modules
//! - [`agents`]: SoA storage with stable [`AgentId`]s.
//! - [`movement`]: the kinematic and dynamic models and the vectorised integrator.
//! - [`steering`]: behaviours as pure functions and as data, and their combination.
//! - [`profile`]: [`Profile`], what the agents of a group share.
//! - [`spatial`]: the neighbour-index contract and its grid, k-d tree and brute-force backends.
//! - [`field`]: occupancy grids, BFS potential, Dijkstra integration and flow fields, walkers.
//! - [`obstacles`]: circles and walls, their avoidance and non-penetration.
//! - [`geometry`]: walkable areas (polygons with holes) from and to WKT: their walls, point test
//!   and occupancy raster.
//! - [`orca`]: optimal reciprocal collision avoidance, a velocity filter for crowds.
//! - [`gravity`]: anti-gravity points and the force they exert.
//! - [`group`]: group movement: path following, leader following, formations, jumps.
//! - [`world`]: [`World`], [`WorldBuilder`], the step pipeline and [`StepStats`].
//! - [`scenario`]: scenario files and the built-in scenarios.
//! - [`measure`]: pedestrian measurements: flow through lines, density and speed in areas,
//!   evacuation time.
//! - [`validate`]: the validation suite: RiMEA's test cases and the bottleneck and
//!   fundamental-diagram experiments, each with its criterion.
//! - `render` (feature `render`): PNG and animated GIF output.
//! - [`spawn`]: seeded placements in rectangles, discs, rings, grids, Poisson-disc layouts and
//!   free cells, clear of obstacles when asked.
//! - [`targets`]: shared target slots that behaviours refer to and a program moves every frame.
//! - [`checkpoint`]: saving a world's whole state and loading it to resume bit for bit.
//! - [`bounds`]: open, walled and wrap-around worlds and their metric.
//! - [`rng`]: the counter-based random stream keyed by (seed, agent, frame).
//! - [`timing`]: step timings, run summaries and the benchmark report.
//! - [`error`]: the [`Error`] type.
//! - `cache_lines` (internal): cache lines and the vector loops over long columns.
//! - `simd` (internal): the processors the SIMD kernels are compiled for, each list in one place.
//!
//! ## Features
//! By default the crate is the simulation core alone.
//! - `render` (opt-in): PNG and animated GIF output (the `gif` and `png` crates).
//!
//! The `throng` command-line program is the workspace's `throng-cli` package (`cli/`).

pub mod agents;
pub mod bounds;
mod cache_lines;
pub mod checkpoint;
pub mod error;
pub mod field;
pub mod geometry;
pub mod gravity;
pub mod group;
mod id;
pub mod journey;
pub mod limits;
pub mod measure;
pub mod movement;
pub mod obstacles;
#[cfg(feature = "oracle")]
pub mod oracle;
pub mod orca;
pub mod output;
mod passes;
pub mod ped;
mod plans;
pub mod profile;
#[cfg(feature = "render")]
pub mod render;
pub mod rng;
pub mod scenario;
mod simd;
pub mod spatial;
pub mod spawn;
pub mod steering;
pub mod targets;
pub mod timing;
pub mod validate;
mod vector;
pub mod world;

pub use agents::{AgentId, AgentInit, Agents};
pub use bounds::Bounds;
pub use error::{Error, Result};
pub use field::{
    FlowField, GoalChannels, GridWalkers, IntegrationField, OccupancyGrid, PotentialField,
};
pub use geometry::Walkable;
pub use profile::Profile;
pub use spatial::{
    BruteIndex, GridIndex, HashGrid, IndexKind, KdTreeIndex, Neighbour, NeighbourIndex,
    SpatialIndex,
};
#[allow(deprecated)]
pub use world::GroupParams;
pub use world::{StepStats, World, WorldBuilder};

/// The types most programs need, for `use throng::prelude::*`.
pub mod prelude {
    pub use crate::agents::{AgentId, AgentInit, Agents};
    pub use crate::bounds::Bounds;
    pub use crate::error::{Error, Result};
    pub use crate::geometry::Walkable;
    pub use crate::movement::{MovementModel, OrientationMode};
    pub use crate::obstacles::{Circle, Obstacles};
    pub use crate::profile::Profile;
    pub use crate::spawn::{Spawner, agents};
    pub use crate::steering::{
        ArriveParams, Behaviour, Combine, Neighbourhood, Steering, SteeringProfile, Target,
        WanderParams, Weighted,
    };
    pub use crate::targets::{TargetPoint, TargetSlot};
    #[allow(deprecated)]
    pub use crate::world::GroupParams;
    pub use crate::world::{AgentState, StepStats, World, WorldBuilder};
    pub use glam::Vec2;
}

/// The README's code blocks, doctested: its library example is a whole `main.rs`.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;
