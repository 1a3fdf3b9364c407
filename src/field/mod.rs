//! Grid potential fields, flow fields and grid walkers.
//!
//! The pieces, in the order a user meets them:
//!
//! - [`OccupancyGrid`]: free and wall cells placed in the world, built in code, parsed from ASCII
//!   maps ([`OccupancyGrid::parse_ascii`]) or generated ([`OccupancyGrid::caves`]).
//! - [`PotentialField`]: the multi-goal BFS field with decay (energy 1 at the goals, times `decay`
//!   per step), in 4- or 8-[`Neighbourhood`]s.
//! - [`DistanceField`]: geodesic Euclidean distances by fast marching, whose gradient points
//!   straight at the goal or the next wall corner at any angle.
//! - [`IntegrationField`]: Dijkstra path costs (1 per orthogonal step, `sqrt(2)` per diagonal,
//!   optional per-cell costs) for smoother paths.
//! - [`FlowField`]: the direction to the best neighbour, precomputed per cell and sampled
//!   bilinearly in continuous space.
//! - [`GridWalkers`]: the discrete climb to the best free neighbour cell, with queueing, in a parallel
//!   deterministic step.
//! - [`GoalChannels`]: one field per goal type, rebuilt when goals or obstacles change; its
//!   [`FlowMetric`] says whether agents follow the BFS field's steps or the distance field.
//!
//! Shared invariants: cells are addressed `(x, y)` with `x < width`, `y < height`; diagonal steps
//! never cut a wall's corner; ties between equally good neighbours go to the first in
//! [`DIRECTIONS`]; every result is independent of the number of threads.

mod channels;
mod congestion;
mod distance;
mod flow;
mod integration;
mod lattice;
mod occupancy;
mod potential;
mod set;
mod walker;

pub use channels::{ChannelSet, FlowMetric, GoalChannels};
pub use congestion::{DEFAULT_DENSITY_RADIUS, DEFAULT_REROUTE_EVERY};
pub use distance::{DistanceField, MAX_CELL_COST};
pub use flow::FlowField;
pub use integration::IntegrationField;
pub use lattice::{DIRECTIONS, Neighbourhood};
pub use occupancy::{Cell, MapFile, OccupancyGrid, random_free_cells};
pub use potential::PotentialField;
pub use walker::{GridWalkers, WalkPolicy, WalkStats};

pub(crate) use occupancy::cell_of;
pub(crate) use set::{FieldSet, FollowChannel, WalkerGroup, WorldField, in_wall, wall_bits};
