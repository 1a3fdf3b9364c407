//! The agents' stable names ([`AgentId`]), a leaf beneath [`crate::agents`] and
//! [`crate::error`], which both name them. Owns nothing else.

use std::fmt;

use serde::{Deserialize, Serialize};

/// A stable name for one agent: assigned on insertion, never reused, unchanged by removals of
/// other agents and by reordering.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct AgentId(pub u32);

impl fmt::Display for AgentId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "#{}", self.0)
    }
}
