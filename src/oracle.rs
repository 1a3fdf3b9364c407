//! The neighbours each model saw, recorded for tests (the `oracle` feature; without it nothing
//! is recorded and the steering loops are unchanged).
//!
//! Two kinds of record. Models that keep a neighbour list record it ([`Seen`]): the pedestrian
//! models, after the gather and before any pair term, and ORCA, the `k` nearest it built
//! half-planes from. Models that sum over their neighbourhood without a list record the sums
//! they used ([`Summed`]): flocking and Vicsek agents of the cell batch after their kernel
//! (before the terms), and every agent whose plan reads neighbour sums per agent. The test
//! compares each with a brute-force pass over the frame-start state by id. A copy built for
//! another order (an agent seeing the positions or ids of a previous layout, itself among its
//! neighbours) shows as a wrong set or wrong sums. The record is global: one test at a time may
//! step worlds while it records.

use std::sync::Mutex;

use glam::Vec2;

use crate::steering::NeighbourSums;

/// One agent's neighbours as a model saw them in one step.
#[derive(Clone, Debug, PartialEq)]
pub struct Seen {
    /// The model: `"pedestrian"` or `"orca"`.
    pub model: &'static str,
    /// The agent's id.
    pub agent: u32,
    /// The position the model read for it.
    pub position: Vec2,
    /// The cut-off the model gathered within.
    pub radius: f32,
    /// At most this many, the nearest (ties by id), when the model caps its neighbours.
    pub nearest: Option<usize>,
    /// The ids of the agents it gathered, in its order.
    pub neighbours: Vec<u32>,
}

/// One neighbourhood of a summing model: who counts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hood {
    /// Neighbours within this distance (inclusive).
    pub radius: f32,
    /// The cosine of the half view angle about the agent's heading (-1: all round).
    pub view_cos: f32,
    /// Only the agent's own group counts.
    pub same_group: bool,
}

/// One agent's neighbour sums as a model used them in one step.
#[derive(Clone, Debug, PartialEq)]
pub struct Summed {
    /// The model: `"flocking"` (the cell batch's flocking plan), `"vicsek"` (its Vicsek plan,
    /// the agent itself included in the heading sum and count) or `"summed"` (a plan reading
    /// the sums per agent, the agent itself excluded).
    pub model: &'static str,
    /// The agent's id.
    pub agent: u32,
    /// The position the model read for it.
    pub position: Vec2,
    /// `count` counts every agent, of any group, within this distance.
    pub query_radius: f32,
    /// The separation, alignment and cohesion neighbourhoods (`None`: the term is off).
    pub hoods: [Option<Hood>; 3],
    /// Repulsion `(strength, exponent, radius)`, summed as `-d / |d| * strength / |d|^exponent`.
    pub repulsion: Option<(f32, f32, f32)>,
    /// The Vicsek neighbourhood's radius, every group.
    pub vicsek_radius: Option<f32>,
    /// At most this many neighbours, the nearest.
    pub cap: Option<u32>,
    /// The sums.
    pub sums: NeighbourSums,
}

static LOG: Mutex<Vec<Seen>> = Mutex::new(Vec::new());
static SUMS: Mutex<Vec<Summed>> = Mutex::new(Vec::new());

/// Records what a model saw.
pub(crate) fn record(seen: Seen) {
    LOG.lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
        .push(seen);
}

/// Records the sums a model used.
pub(crate) fn record_sums(summed: Summed) {
    SUMS.lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
        .push(summed);
}

/// The neighbour lists recorded since the last call, in no particular order.
pub fn take() -> Vec<Seen> {
    std::mem::take(
        &mut *LOG
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner),
    )
}

/// The neighbour sums recorded since the last call, in no particular order.
pub fn take_sums() -> Vec<Summed> {
    std::mem::take(
        &mut *SUMS
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner),
    )
}
