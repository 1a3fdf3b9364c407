//! [`Scenario::memory_estimate`]: the bytes a built world will need, checked before the build
//! against the memory the process may use.
//!
//! Invariant: the estimate saturates instead of overflowing, so a huge scenario is refused
//! rather than wrapped around to a small figure.

use super::{Scenario, StageSpec};

impl Scenario {
    /// An estimate of the memory the built world will need, bytes: agents at
    /// [`BYTES_PER_AGENT`](crate::limits::BYTES_PER_AGENT), groups at
    /// [`BYTES_PER_GROUP`](crate::limits::BYTES_PER_GROUP), field cells and their channels,
    /// the stages' routing raster (with a walkable area: a cell of 0.2 m and a channel per stage
    /// with a place), obstacles, gravity points, exit vertices and the slots of queues and
    /// waiting sets, plus [`BASE_BYTES`](crate::limits::BASE_BYTES).
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
            + self.gravity.random.as_ref().map_or(0, |r| r.count)
            + self.stage_points()) as u64;
        BASE_BYTES
            .saturating_add(agents)
            .saturating_add(groups)
            .saturating_add(field)
            .saturating_add(self.route_bytes())
            .saturating_add(obstacles.saturating_mul(64))
    }
}

impl Scenario {
    /// The bytes of the stages' routing raster: with a walkable area and stages, its cells
    /// (the area's bounding box in cells of [`ROUTE_CELL_SIZE`], and a margin) at
    /// [`BYTES_PER_CELL`] and [`BYTES_PER_CHANNEL_CELL`] per stage with a place.
    fn route_bytes(&self) -> u64 {
        use crate::journey::ROUTE_CELL_SIZE;
        use crate::limits::{BYTES_PER_CELL, BYTES_PER_CHANNEL_CELL};
        let Some(g) = self.geometry.as_ref().filter(|_| !self.stages.is_empty()) else {
            return 0;
        };
        let side = (g.walkable.max() - g.walkable.min()) / ROUTE_CELL_SIZE;
        let cells =
            ((f64::from(side.x) + 3.0) * (f64::from(side.y) + 3.0)).min(u64::MAX as f64) as u64;
        let channels = self
            .stages
            .iter()
            .filter(|s| !matches!(s, StageSpec::DirectSteering { .. }))
            .count() as u64;
        cells.saturating_mul(
            BYTES_PER_CELL.saturating_add(channels.saturating_mul(BYTES_PER_CHANNEL_CELL)),
        )
    }

    /// The points the stages hold: slots, waypoints and exit polygon vertices.
    fn stage_points(&self) -> usize {
        self.stages
            .iter()
            .map(|s| match s {
                StageSpec::Exit {
                    polygon: Some(text),
                    ..
                } => text.matches(',').count() + 1,
                other => other.points().len(),
            })
            .fold(0usize, usize::saturating_add)
    }
}
