//! The plan layer: the one owner of an agent's steering, between the world and the sensing
//! modules. Each group's profile is compiled into a [`Plan`] here, and the steering pass runs
//! every agent by its plan; [`crate::steering`] holds the behaviours themselves, as pure
//! functions and data, which the plans call.
//!
//! The world orchestrates a step; the leaf modules ([`crate::steering`], [`crate::spatial`],
//! [`crate::field`], [`crate::obstacles`], [`crate::gravity`], [`crate::group`]) hold pure
//! functions and data. This layer joins them, and imports nothing from [`crate::world`]:
//!
//! - [`plan`]: a group's [`Plan`], compiled once from its profile when the profile or something
//!   it references changes: validated references, the neighbour sums it needs, the model adapter
//!   and the evaluation path;
//! - [`view`]: the read-only [`SteerView`] of frame-t state (targets, neighbour sums, nearest
//!   agents, obstacles, gravity, paths and slots, flow samples);
//! - [`eval`]: one evaluation function per behaviour, the per-agent reference;
//! - [`adapter`]: the model adapter (force and desired velocity, clamps, the overflow guard);
//! - [`neighbours`]: the fused neighbour traversal (scalar reference and per-agent grid kernel);
//! - [`cells`]: flocking evaluated in cell batches by a SIMD kernel;
//! - [`pass`]: the steering pass that runs each agent by its plan into the SoA outputs of
//!   [`out`];
//! - [`agent`]: one agent's steering by its plan, the per-agent path the batched ones agree
//!   with;
//! - [`lanes`]: a lone seek, arrive or wander a block of lanes at a time;
//! - `leader`: leader following in lanes, the leader resolved once per run;
//! - `follow`: field following in lanes, the flow resolved once per run;
//! - [`pack`]: left-packing the candidates within a radius, eight lanes at a time;
//! - [`ped`]: the pedestrian models, which replace the requests of pedestrian groups by the
//!   social force model's accelerations or the collision-free speed model's velocities;
//! - [`orca`]: the ORCA filter, which replaces the requests of ORCA groups by collision-free
//!   velocities.
//!
//! Invariants: the pass reads frame-t state only and writes only each agent's own outputs, so
//! the result does not depend on the thread count; plans are current whenever a step runs.

pub(crate) mod adapter;
pub(crate) mod agent;
pub(crate) mod cells;
pub(crate) mod eval;
mod follow;
pub(crate) mod lanes;
mod leader;
pub(crate) mod neighbours;
pub(crate) mod orca;
pub(crate) mod out;
pub(crate) mod pack;
pub(crate) mod pass;
pub(crate) mod ped;
pub(crate) mod plan;
pub(crate) mod spec;
pub(crate) mod view;

pub(crate) use neighbours::SortedCopies;
pub(crate) use out::{STEER_CHUNK, SteerOut};
pub(crate) use pass::PassScratch;
pub(crate) use plan::{Plan, References};
pub(crate) use view::{NearestIndex, SteerView, prepare_nearest};
