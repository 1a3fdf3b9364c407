//! Agents stored as structure-of-arrays buffers with stable ids.
//!
//! [`Agents`] keeps one contiguous `Vec<f32>` per scalar quantity (positions and velocities split
//! into x and y), so the integrator runs over plain `f32` slices in wide lanes and the steering
//! pass reads only the fields it needs. Storage order is dense and may change (removal swaps the
//! last agent into the hole; [`Agents::reorder`] applies a permutation for cache locality), but an
//! [`AgentId`] names the same agent for its whole life: ids are never reused.
//!
//! Invariant: every number in the buffers is finite. The only ways in are validated
//! (the world's validated constructors and mutators).

mod order;
mod store;

pub use order::AgentOrder;

pub(crate) use store::{AgentColumns, any_both, largest};
pub use store::{AgentId, AgentInit, Agents};

/// Flags recording which per-agent overrides are set.
pub(crate) mod store_flags {
    pub(crate) use super::store::{OVERRIDE_RADIUS, OVERRIDE_SPEED};
}
