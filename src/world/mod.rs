//! The world: agents, groups and their profiles, bounds, and the step pipeline.
//!
//! [`World::step`] runs the phases of one frame and returns their timings in [`StepStats`]:
//!
//! 1. **steer**: rayon over agents; each agent reads only frame-t state and writes only its own
//!    entries of the SoA output buffers (linear, angular, wander state);
//! 2. **integrate**: the vectorised integrator of [`crate::movement`];
//! 3. **bounds**: wrap-around on a torus, or clamping to a walled rectangle (the velocity
//!    component into the wall is removed).
//!
//! Determinism: per-agent randomness is keyed by (seed, [`crate::AgentId`], frame), steering has
//! no cross-agent writes and the integrator is element-wise, so the state after any number of
//! steps is bit-identical for any thread count. [`World::step_sequential`] is the single-threaded
//! scalar reference the parallel step is tested against.

mod builder;
mod fields;
mod formation;
mod state;
mod stats;
mod step;

pub use crate::group::Formation;
pub use crate::profile::Profile;
pub use builder::WorldBuilder;

/// The former name of [`Profile`]: a group's movement model, limits and behaviours.
pub type GroupParams = Profile;
pub use state::{AgentState, World};
pub use stats::{PhaseTimes, StepStats};
