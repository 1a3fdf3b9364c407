//! The world: agents, groups and their profiles, bounds, obstacles, gravity points, fields,
//! paths and formations, and the step that orchestrates them.
//!
//! [`World::step`] runs the phases of one frame and returns their timings in [`StepStats`]:
//! plans compiled when stale; **index** (gravity points, the neighbour index and reordering, the
//! nearest-agent indices); the subsystems' prepare hooks (**fields**, **formations**);
//! **steer** (the steering layer's pass); **integrate** (the vectorised integrator of
//! [`crate::movement`]); **bounds** (contact between ORCA agents, torus wrap or wall clamp, obstacle
//! non-penetration); the fields' constrain hook; contact's guard; arrivals counted and agents in
//! exits removed. No per-agent logic lives here: the per-agent passes are the steering layer's,
//! the integrator's and those of `passes` (the edges, obstacle moves, arrivals).
//!
//! Determinism: per-agent randomness is keyed by (seed, [`crate::AgentId`], frame), steering has
//! no cross-agent writes and the integrator is element-wise, so the state after any number of
//! steps is bit-identical for any thread count. [`World::step_sequential`] runs the same phases
//! and passes on one thread (with the scalar integrator), the reference the parallel step is
//! tested against bit for bit.

mod awake;
mod builder;
mod exits;
pub(crate) mod fields;
mod formation;
mod journeys;
mod leave;
mod model_params;
mod scratch;
mod state;
mod stats;
mod step;
mod targets;
mod walkable;

pub use crate::group::Formation;
pub use crate::profile::Profile;
pub use builder::{DEFAULT_SEED, WorldBuilder};
pub use exits::{Departure, Exit};

/// The former name of [`Profile`]: a group's movement model, limits and behaviours.
#[deprecated(since = "0.1.0", note = "renamed to `Profile`")]
pub type GroupParams = Profile;
pub(crate) use state::check_max_speed;
pub use state::{AgentState, World};
pub use stats::{PhaseTimes, StepStats};
