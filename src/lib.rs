//! # throng
//!
//! A data-parallel crowd and flock simulator.
#![warn(missing_docs)]

pub mod agents;
pub mod bounds;
pub mod error;
pub mod field;
pub mod rng;

pub use agents::{AgentId, AgentInit, Agents};
pub use bounds::Bounds;
pub use error::{Error, Result};
pub use field::{FlowField, GoalChannels, GridWalkers, IntegrationField, Neighbourhood, OccupancyGrid, PotentialField};
