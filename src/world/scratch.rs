//! The world's per-frame buffers ([`Scratch`]): the steering outputs and pass scratch, the
//! integration parameters, the sorted copies and nearest-agent indices, the ORCA and contact
//! buffers. Reused across steps, grown only, never serialised: a world loaded from a checkpoint
//! starts with empty ones and steps to the same bits.

use crate::movement::IntegrationParams;
use crate::plans::{self, NearestIndex, PassScratch, SortedCopies, SteerOut};

/// Per-frame buffers, reused across steps (never serialised).
#[derive(Debug, Default)]
pub(crate) struct Scratch {
    pub(super) out: SteerOut,
    pub(super) pass: PassScratch,
    pub(super) params: Vec<IntegrationParams>,
    pub(super) sorted: SortedCopies,
    /// Per group: an index over that group's agents, when some behaviour looks for its nearest.
    pub(super) nearest: Vec<Option<NearestIndex>>,
    /// The agents' order the neighbour index was last built for.
    pub(super) index_order: crate::agents::AgentOrder,
    /// Per group: the largest `nearest` search radius that targets it.
    pub(super) within: Vec<f32>,
    /// The frame-start positions (kept when obstacles or fields check moves).
    pub(super) prev_x: Vec<f32>,
    pub(super) prev_y: Vec<f32>,
    /// The reordering permutation.
    pub(super) perm: Vec<u32>,
    /// Per group, the squared arrival radius (-1 for none).
    pub(super) arrival_sq: Vec<f32>,
    /// The hashed grid that orders ORCA agents in memory when nothing else builds the world's
    /// grid.
    pub(super) order_grid: crate::spatial::HashGrid,
    /// The walls as ORCA edge chains, built for `orca_walls_of` walls.
    pub(super) orca_walls: crate::orca::WallChains,
    pub(super) orca_walls_of: usize,
    /// The ORCA pass's state (its neighbour grid, the near-contact flags).
    pub(super) orca: plans::orca::OrcaScratch,
    /// Contact resolution: its buffers, which agents move, and per group whether its agents do.
    pub(super) contact: crate::orca::contact::ContactScratch,
    pub(super) moves: Vec<bool>,
    pub(super) contact_of: Vec<bool>,
}
