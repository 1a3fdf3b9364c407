//! Group movement: path following, leader following, formations and jumps.
//!
//! Everything here is a pure function or plain data, usable on its own like the rest of
//! [`crate::steering`]; the world ([`crate::World::add_path`], [`crate::World::add_formation`])
//! keeps the shared paths and formations and the [`crate::steering::Behaviour`] variants
//! `FollowPath`, `FollowLeader`, `KeepFormation` and `Jump` refer to them.
//!
//! - [`path`](Path): polylines with a radius, projection and arc length, [`follow_path`].
//! - formations: [`FormationShape`], [`FormationParams`], [`slot_offsets`], [`slot_velocity`].
//! - assignment: [`assign_min_cost`] (Hungarian method) and [`assign_slots`].
//! - leader following: [`FollowParams`], [`follow_leader`].
//! - jumps: [`JumpParams`], [`jump_plan`] (reports [`crate::Error::Impossible`]), [`jump_phase`].
//!
//! Slots are offsets in the anchor's or leader's local frame ([`crate::steering::Basis`]: x
//! forward, y left). Everything is deterministic: no randomness except a follower's fixed spread,
//! which derives from the seed and its id.

mod assignment;
mod formation;
mod jump;
mod leader;
mod movement;
mod path;

pub(crate) use assignment::distance_matrix;
pub use assignment::{
    BLOCK, EXACT_MAX, assign_min_cost, assign_slots, assign_slots_local, assignment_cost,
};
pub use formation::{
    FormationId, FormationParams, FormationShape, SlotParams, slot_offsets, slot_velocity,
};
pub use jump::{JumpParams, JumpPhase, JumpPlan, jump_phase, jump_plan, run_up_length};
pub use leader::{FollowParams, follow_leader};
pub use movement::Formation;
pub(crate) use movement::{GroupMovement, NO_FORMATION, update_formations, update_formations_in};
pub use path::{
    GridBudget, Path, PathDirection, PathFollowParams, PathId, PathSpec, Projection, follow_path,
};
