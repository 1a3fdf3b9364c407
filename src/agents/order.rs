//! The agents' storage order as a value.
//!
//! An [`AgentOrder`] names one arrangement of the agents in storage: which agent is at which
//! index. [`crate::agents::Agents`] holds the order of its buffers and takes a new one whenever
//! that arrangement changes (a reorder, an agent added or removed, a store rebuilt from a
//! checkpoint). Every copy derived from the agents in storage order (the neighbour index, the
//! grid kernel's cell-ordered copies, the nearest-agent indices) records the order it was built
//! for, and the step refuses to read a copy made for another order
//! ([`crate::Error::StaleOrder`]): such a copy would hand each agent another agent's
//! neighbours.
//!
//! Invariant: two stores hold the same order only when one is a clone of the other with no
//! change of arrangement since, so equal orders mean equal arrangements.

use std::sync::atomic::{AtomicU64, Ordering};

/// One arrangement of the agents in storage (see the module docs). Compared, never inspected.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct AgentOrder(u64);

/// The next order to hand out (0 is [`AgentOrder::NONE`]).
static NEXT: AtomicU64 = AtomicU64::new(1);

impl AgentOrder {
    /// The order of no arrangement: what a copy that was never built records.
    pub const NONE: AgentOrder = AgentOrder(0);

    /// An order that no store has held before.
    pub(crate) fn fresh() -> AgentOrder {
        AgentOrder(NEXT.fetch_add(1, Ordering::Relaxed))
    }
}

impl Default for AgentOrder {
    /// [`AgentOrder::NONE`].
    fn default() -> Self {
        AgentOrder::NONE
    }
}
