//! # throng
//!
//! A data-parallel crowd and flock simulator.
#![warn(missing_docs)]

pub mod agents;
pub mod bounds;
pub mod error;
pub mod rng;
#[cfg(feature = "render")]
pub mod render;

pub use agents::{AgentId, AgentInit, Agents};
pub use bounds::Bounds;
pub use error::{Error, Result};
