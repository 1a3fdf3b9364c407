//! [`Scenario::memory_estimate`]: the bytes a built world will need, checked before the build
//! against the memory the process may use.
//!
//! Invariant: the estimate saturates instead of overflowing, so a huge scenario is refused
//! rather than wrapped around to a small figure.

use super::Scenario;

impl Scenario {
    /// An estimate of the memory the built world will need, bytes: agents at
    /// [`BYTES_PER_AGENT`](crate::limits::BYTES_PER_AGENT), groups at
    /// [`BYTES_PER_GROUP`](crate::limits::BYTES_PER_GROUP), field cells and their channels,
    /// obstacles and gravity points, plus [`BASE_BYTES`](crate::limits::BASE_BYTES).
    #[must_use]
    pub fn memory_estimate(&self) -> u64 {
        use crate::limits::{
            BASE_BYTES, BYTES_PER_AGENT, BYTES_PER_CELL, BYTES_PER_CHANNEL_CELL, BYTES_PER_GROUP,
        };
        let agents = (self.agent_count() as u64).saturating_mul(BYTES_PER_AGENT);
        let groups = (self.groups.len() as u64).saturating_mul(BYTES_PER_GROUP);
        let field = self.field.as_ref().map_or(0, |f| {
            let per_cell = BYTES_PER_CELL + f.channels.len() as u64 * BYTES_PER_CHANNEL_CELL;
            f.cell_estimate(self.geometry.as_ref().map(|g| &g.walkable))
                .saturating_mul(per_cell)
        });
        let obstacles = (self.obstacles.circles.len()
            + self.obstacles.walls.len()
            + self
                .obstacles
                .polygons
                .iter()
                .map(|p| p.points.len())
                .sum::<usize>()
            + self
                .obstacles
                .random_circles
                .as_ref()
                .map_or(0, |r| r.count)
            + self
                .geometry
                .as_ref()
                .map_or(0, |g| g.walkable.vertex_count())
            + self
                .exits
                .iter()
                .filter_map(|e| e.polygon.as_ref())
                .map(crate::geometry::Walkable::vertex_count)
                .sum::<usize>()
            + self.gravity.points.len()
            + self.gravity.random.as_ref().map_or(0, |r| r.count)) as u64;
        BASE_BYTES
            .saturating_add(agents)
            .saturating_add(groups)
            .saturating_add(field)
            .saturating_add(obstacles.saturating_mul(64))
    }
}
