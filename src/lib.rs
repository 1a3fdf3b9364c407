//! # throng
//!
//! A data-parallel crowd and flock simulator.
#![warn(missing_docs)]

pub mod agents;
pub mod bounds;
pub mod error;
pub mod rng;
pub mod spatial;

pub use agents::{AgentId, AgentInit, Agents};
pub use bounds::Bounds;
pub use error::{Error, Result};
pub use spatial::{BruteIndex, GridIndex, IndexKind, KdTreeIndex, Neighbour, NeighbourIndex, SpatialIndex};
