//! The steering pass's outputs: one column per output in storage order ([`SteerOut`]), the
//! chunks of them one parallel task writes ([`OutChunks`]) and the task size ([`STEER_CHUNK`]).
//! The pass writes them; the pedestrian models and the ORCA filter read and replace the linear
//! requests; the integrator reads them all.
//!
//! Invariant: every column holds one value per agent, in the agents' storage order.

/// Agents per parallel steering task.
pub(crate) const STEER_CHUNK: usize = 1024;

/// The steering pass's per-agent outputs, in storage order.
#[derive(Debug, Default)]
pub(crate) struct SteerOut {
    pub lin_x: Vec<f32>,
    pub lin_y: Vec<f32>,
    pub ang: Vec<f32>,
    pub wander: Vec<f32>,
    /// Neighbours found per agent this step (not written when `found` holds their total).
    pub neighbours: Vec<f32>,
    /// The neighbours all agents found this step, when the pass summed them itself.
    pub found: Option<f64>,
    /// Whether `ang` was written this step; when not, every agent's angular output is zero.
    pub angular: bool,
    /// Whether `wander` was written this step; when not, every wander angle is unchanged.
    pub wandered: bool,
    /// Whether `lin_x` and `lin_y` were left unwritten because every agent's request waits in
    /// the cell batch's outputs, in the grid's order
    /// ([`CellOut::take_all`](super::cells::CellOut::take_all) copies them out, as the
    /// integrator does task by task); never when a pedestrian model or the ORCA filter reads and
    /// replaces the requests after the pass.
    pub deferred: bool,
}

impl SteerOut {
    /// Sizes every output for `n` agents.
    pub(crate) fn resize(&mut self, n: usize) {
        for v in [
            &mut self.lin_x,
            &mut self.lin_y,
            &mut self.ang,
            &mut self.wander,
            &mut self.neighbours,
        ] {
            v.resize(n, 0.0);
        }
    }
}

/// One task's chunks of the pass outputs: linear x and y, angular, wander angle, neighbours.
pub(crate) type OutChunks<'c> = (
    &'c mut [f32],
    &'c mut [f32],
    &'c mut [f32],
    &'c mut [f32],
    &'c mut [f32],
);
