//! Routing between stages: one geodesic distance field per stage on the walkable area's raster.
//!
//! [`Routes`] rasterises the walkable area once (cells of [`CELL_SIZE`]) and keeps a goal
//! channel per stage with a place (every stage but direct steering): a waypoint's goal cells
//! are the free cells whose centre lies within its distance (and the cell holding the point),
//! an exit's the one of its cells (those whose centre lies inside it) nearest their mean, so
//! that agents walk at the exit's centre as JuPedSim's walk at its centroid and spread over
//! its whole edge on the way, a queue's or waiting set's the free cells
//! within a metre of a slot. Each channel's flow follows the fast-marching distance field, so it points
//! straight at the goal or at the next corner round a hole, at any angle.
//!
//! Invariants: a channel exists for every stage with a place and has at least one goal cell
//! (adding a stage fails otherwise); the routes are rebuilt from scratch when the geometry
//! changes, and only the channels of added stages are built when a stage is added.

use glam::Vec2;

use super::Stage;
use crate::error::{Error, Result};
use crate::field::{FlowMetric, GoalChannels, Neighbourhood, OccupancyGrid};
use crate::geometry::Walkable;

/// The side of a routing cell, m: a fifth of a stride, so that a 0.8 m door is four cells.
pub(crate) const CELL_SIZE: f32 = 0.2;

/// How far round a queue's or waiting set's slot its goal cells reach, m.
const SLOT_AREA: f32 = 1.0;

/// The routing channels of a world's stages.
#[derive(Clone, Debug)]
pub(crate) struct Routes {
    channels: GoalChannels,
    /// Per stage, its channel (none for direct steering).
    channel_of: Vec<Option<usize>>,
    /// Per stage, the centre of its goal cells (where an exit's agents head once on them).
    centre: Vec<Vec2>,
}

impl Routes {
    /// Routes on `area` for `stages` (built at once).
    pub(crate) fn new(area: &Walkable, stages: &[Stage]) -> Result<Self> {
        Routes::build_on(area, stages, false)
    }

    /// Routes on `area` for `stages`, where a stage that no cell of the area reaches (a door
    /// since closed) gets no route instead of failing.
    pub(crate) fn new_cut(area: &Walkable, stages: &[Stage]) -> Result<Self> {
        Routes::build_on(area, stages, true)
    }

    fn build_on(area: &Walkable, stages: &[Stage], cut: bool) -> Result<Self> {
        let grid = area.rasterize(CELL_SIZE, area.min())?;
        let channels =
            GoalChannels::new(grid, 0.5, Neighbourhood::Eight)?.with_metric(FlowMetric::Euclidean);
        let mut routes = Routes {
            channels,
            channel_of: Vec::new(),
            centre: Vec::new(),
        };
        for (k, s) in stages.iter().enumerate() {
            if cut && goal_cells(routes.channels.grid(), s).is_empty() {
                routes.channel_of.push(None);
                routes.centre.push(Vec2::ZERO);
            } else {
                routes.add(k, s)?;
            }
        }
        routes.channels.rebuild_dirty()?;
        Ok(routes)
    }

    /// Adds stage number `k`'s channel (built by [`Routes::build`]).
    pub(crate) fn add(&mut self, k: usize, stage: &Stage) -> Result<()> {
        let grid = self.channels.grid();
        let goals = goal_cells(grid, stage);
        if matches!(stage, Stage::DirectSteering) {
            self.channel_of.push(None);
            self.centre.push(Vec2::ZERO);
            return Ok(());
        }
        if goals.is_empty() {
            return Err(Error::Invalid {
                name: format!("stage {k}"),
                reason: format!(
                    "no free cell of the walkable area (cells of {CELL_SIZE} m) lies in the {}",
                    stage.kind()
                ),
            });
        }
        let sum = goals
            .iter()
            .fold(Vec2::ZERO, |s, &(x, y)| s + grid.cell_center(x, y));
        let centre = sum / goals.len() as f32;
        // An exit is walked to at its centre, as JuPedSim's exit stage has its agents walk to
        // its centroid: the nearest of its cells drew everyone coming from one side onto the
        // same corner of a wide exit area, where they jammed.
        let goals = match stage {
            Stage::Exit { .. } => vec![nearest_cell(grid, &goals, centre)],
            _ => goals,
        };
        let c = self.channels.add_channel(&goals)?;
        self.channel_of.push(Some(c));
        self.centre.push(centre);
        Ok(())
    }

    /// Builds the channels added since the last build.
    pub(crate) fn build(&mut self) -> Result<()> {
        self.channels.rebuild_dirty().map(|_| ())
    }

    /// The direction of stage `k`'s route at `p` (zero on a goal cell, off the raster or on a
    /// wall cell).
    pub(crate) fn direction(&self, k: usize, p: Vec2) -> Vec2 {
        match self.channel_of.get(k).copied().flatten() {
            Some(c) => self.channels.flow(c).map_or(Vec2::ZERO, |f| f.sample(p)),
            None => Vec2::ZERO,
        }
    }

    /// Whether stage `k` has a route (a stage with a place that the area cuts off has none).
    pub(crate) fn has_route(&self, k: usize) -> bool {
        self.channel_of.get(k).copied().flatten().is_some()
    }

    /// The centre of stage `k`'s goal cells.
    pub(crate) fn centre(&self, k: usize) -> Option<Vec2> {
        self.channel_of.get(k).copied().flatten()?;
        self.centre.get(k).copied()
    }

    /// The routing grid.
    pub(crate) fn grid(&self) -> &OccupancyGrid {
        self.channels.grid()
    }

    /// Whether stage `k`'s route leads from point `p` to it. Only a point whose free cell (or
    /// nearest free neighbour) lies in a part of the area that no free cell connects to the
    /// stage is refused: a stage without a route, a route not built yet and a point off the
    /// raster or walled in leave nothing to judge.
    pub(crate) fn reaches(&self, k: usize, p: Vec2) -> bool {
        let grid = self.channels.grid();
        free_cell_at(grid, p).is_none_or(|(x, y)| self.reaches_cell(k, x, y))
    }

    /// Whether stage `to`'s route leads to it from some goal cell of `from` (a stage without
    /// goal cells, such as direct steering, leaves nothing to judge).
    pub(crate) fn stage_reaches(&self, from: &Stage, to: usize) -> bool {
        let cells = goal_cells(self.channels.grid(), from);
        cells.is_empty() || cells.iter().any(|&(x, y)| self.reaches_cell(to, x, y))
    }

    fn reaches_cell(&self, k: usize, x: u32, y: u32) -> bool {
        let Some(c) = self.channel_of.get(k).copied().flatten() else {
            return true;
        };
        if self.channels.is_dirty(c) {
            return true;
        }
        let centre = self.channels.grid().cell_center(x, y);
        self.channels.travel_cost(c, centre).is_some()
    }
}

/// Of `cells` (not empty, in `(y, x)` order), the one whose centre lies nearest `p` (the first on
/// a tie).
fn nearest_cell(grid: &OccupancyGrid, cells: &[(u32, u32)], p: Vec2) -> (u32, u32) {
    let mut best = cells[0];
    let mut best_d = f32::INFINITY;
    for &(x, y) in cells {
        let d = grid.cell_center(x, y).distance_squared(p);
        if d < best_d {
            best = (x, y);
            best_d = d;
        }
    }
    best
}

/// The goal cells of `stage` on `grid`.
fn goal_cells(grid: &OccupancyGrid, stage: &Stage) -> Vec<(u32, u32)> {
    let cells = || (0..grid.height()).flat_map(move |y| (0..grid.width()).map(move |x| (x, y)));
    let mut goals: Vec<(u32, u32)> = match stage {
        Stage::Waypoint { position, distance } => {
            let mut g: Vec<(u32, u32)> = cells()
                .filter(|&(x, y)| {
                    grid.is_free(x, y) && grid.cell_center(x, y).distance(*position) <= *distance
                })
                .collect();
            g.extend(free_cell_at(grid, *position));
            g
        }
        Stage::Exit { area } => cells()
            .filter(|&(x, y)| grid.is_free(x, y) && area.contains(grid.cell_center(x, y)))
            .collect(),
        Stage::Queue { slots } | Stage::WaitingSet { slots, .. } => {
            // The free cells within a metre of a slot, so that a crowd arriving at a queue
            // spreads along it instead of converging on one cell.
            let reach = (SLOT_AREA / grid.cell_size()).ceil() as i64;
            let mut g = Vec::new();
            for &p in slots {
                g.extend(free_cell_at(grid, p));
                let Some((cx, cy)) = grid.world_to_cell(p) else {
                    continue;
                };
                for dy in -reach..=reach {
                    for dx in -reach..=reach {
                        let (x, y) = (i64::from(cx) + dx, i64::from(cy) + dy);
                        if x < 0
                            || y < 0
                            || x >= i64::from(grid.width())
                            || y >= i64::from(grid.height())
                        {
                            continue;
                        }
                        let (x, y) = (x as u32, y as u32);
                        if grid.is_free(x, y) && grid.cell_center(x, y).distance(p) <= SLOT_AREA {
                            g.push((x, y));
                        }
                    }
                }
            }
            g
        }
        Stage::DirectSteering => Vec::new(),
    };
    goals.sort_unstable_by_key(|&(x, y)| (y, x));
    goals.dedup();
    goals
}

/// The free cell holding `p`, or failing that the free one of its eight neighbours nearest to
/// `p` (a point within a cell's width of a wall may lie on a cell the raster calls a wall).
fn free_cell_at(grid: &OccupancyGrid, p: Vec2) -> Option<(u32, u32)> {
    let (x, y) = grid.world_to_cell(p)?;
    if grid.is_free(x, y) {
        return Some((x, y));
    }
    let mut best: Option<((u32, u32), f32)> = None;
    for dy in -1i64..=1 {
        for dx in -1i64..=1 {
            let (nx, ny) = (i64::from(x) + dx, i64::from(y) + dy);
            if nx < 0 || ny < 0 || nx >= i64::from(grid.width()) || ny >= i64::from(grid.height()) {
                continue;
            }
            let (nx, ny) = (nx as u32, ny as u32);
            let d = grid.cell_center(nx, ny).distance(p);
            if grid.is_free(nx, ny) && best.is_none_or(|(_, b)| d < b) {
                best = Some(((nx, ny), d));
            }
        }
    }
    best.map(|b| b.0)
}
