//! The neighbours each model saw, recorded for tests (the `oracle` feature; without it nothing
//! is recorded and the steering loops are unchanged).
//!
//! The pedestrian models record, for every agent they move, the ids of the agents they summed
//! over, after the gather and before any pair term: the test compares them with a brute-force
//! query over the frame-start positions. A copy built for another order (an agent seeing the
//! positions or ids of a previous layout, itself among its neighbours) shows as a wrong set.
//! The record is global: one test at a time may step worlds while it records.

use std::sync::Mutex;

use glam::Vec2;

/// One agent's neighbours as a model saw them in one step.
#[derive(Clone, Debug, PartialEq)]
pub struct Seen {
    /// The model: `"pedestrian"`.
    pub model: &'static str,
    /// The agent's id.
    pub agent: u32,
    /// The position the model read for it.
    pub position: Vec2,
    /// The cut-off the model gathered within.
    pub radius: f32,
    /// The ids of the agents it gathered, in its order.
    pub neighbours: Vec<u32>,
}

static LOG: Mutex<Vec<Seen>> = Mutex::new(Vec::new());

/// Records what a model saw.
pub(crate) fn record(seen: Seen) {
    LOG.lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
        .push(seen);
}

/// What was recorded since the last call, in no particular order.
pub fn take() -> Vec<Seen> {
    std::mem::take(
        &mut *LOG
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner),
    )
}
