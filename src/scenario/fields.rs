//! The `[field]` table of a scenario: a grid (ASCII map or generated), its goal channels, goal
//! re-randomisation and grid walkers (documented in `docs/SCENARIOS.md`, "Fields").
//!
//! Invariants: relative map paths are resolved against the scenario file's folder when the file
//! is parsed; every random draw (caves, goals, spawn cells) derives from the scenario's seed.

use std::path::{Path, PathBuf};

use glam::Vec2;
use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::field::{
    FlowMetric, GoalChannels, MapFile, Neighbourhood, OccupancyGrid, WalkPolicy, random_free_cells,
};
use crate::world::World;

/// A scenario's field: the grid, its channels and walkers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FieldSpec {
    /// Where the cells come from. Default: the raster of the scenario's walkable area
    /// (`"walkable"`).
    #[serde(default = "walkable_map")]
    pub map: MapSource,
    /// Side of a cell in world units (> 0). Default: 1.
    #[serde(default = "one")]
    pub cell_size: f32,
    /// World position of the lower corner of cell `(0, 0)`. Default: `[0, 0]`.
    #[serde(default)]
    pub origin: Vec2,
    /// Potential decay per step, in `(0, 1)`. Default: 0.99.
    #[serde(default = "default_decay")]
    pub decay: f32,
    /// `"four"` or `"eight"`. Default: eight.
    #[serde(default = "eight")]
    pub neighbourhood: Neighbourhood,
    /// One entry per goal channel (channel `k` is entry `k`). Default: one channel with the
    /// map's `G` cells.
    #[serde(default = "map_goals")]
    pub channels: Vec<GoalSpec>,
    /// Re-randomise every channel's goals every this many steps (0: never). Default: 0.
    #[serde(default)]
    pub shuffle_every: u64,
    /// How many goals each channel gets when re-randomised. Default: 4.
    #[serde(default = "four")]
    pub shuffle_goals: usize,
    /// Groups whose agents move as grid walkers. Default: none.
    #[serde(default)]
    pub walkers: Vec<WalkerSpec>,
    /// Free cells whose centre lies within this distance of a wall cell (or the grid's
    /// border) become walls too ([`OccupancyGrid::dilated`]), so that the flow leads discs of
    /// this radius around corners instead of into them; world units, at most 64 cells.
    /// Default: 0.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub clearance: f32,
    /// With a distance `metric`: the cells within `clearance` of a wall stay walkable and cost
    /// this many times as much to cross, instead of becoming walls
    /// ([`GoalChannels::with_clearance_cost`]); in `[1, 20]`, with `map = "walkable"` and a
    /// clearance above 0. The flow then steers off walls where there is room, and still leads
    /// the whole width of a door through, where walls made of those cells narrow a door to
    /// whole cells (a door 1 m wide in 0.25 m cells with a clearance of 0.2 m leaves 0.5 m for
    /// the centres). The field's walls that hold agents' moves, and grid walkers, then see the
    /// raster without the clearance. Default: none (the cells become walls).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clearance_cost: Option<f32>,
    /// What the flow that `follow_field` agents read follows: `"steps"` (the BFS field's best
    /// neighbour, eight directions) or `"euclidean"` (the gradient of the geodesic distance by
    /// fast marching, any angle). Grid walkers climb the BFS field either way. Default: steps.
    #[serde(default, skip_serializing_if = "is_steps")]
    pub metric: FlowMetric,
    /// With `metric = "quickest"`: frames between reroutes by the crowd's density (0: never).
    /// Default: 50.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reroute_every: Option<u64>,
    /// With `metric = "quickest"`: the half-side of the square the density is counted in, world
    /// units (metres). Default: 0.5.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub density_radius: Option<f32>,
}

fn is_steps(m: &FlowMetric) -> bool {
    *m == FlowMetric::Steps
}

fn is_zero(v: &f32) -> bool {
    *v == 0.0
}

/// The cells of a field.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum MapSource {
    /// The raster of the scenario's `[geometry] walkable` area at the field's `cell_size`, on
    /// the grid lines through `origin` (see [`Walkable::rasterize`](crate::geometry::Walkable::rasterize));
    /// its goal cells (`"map"` channels) are the free cells whose centre lies inside an exit.
    Walkable,
    /// An ASCII map file (`#` wall, `.` free, `G` goal, `S` spawn), relative to the scenario.
    File(PathBuf),
    /// An ASCII map written inline.
    Ascii(String),
    /// A connected cave (see [`OccupancyGrid::caves`]).
    Caves {
        /// Columns.
        width: u32,
        /// Rows.
        height: u32,
        /// Share of wall cells, in `[0, 1)`.
        obstacles: f32,
        /// Seed of the walk. Default: the scenario's seed.
        seed: Option<u64>,
    },
    /// Connected branching tunnels, fast at any size (see [`OccupancyGrid::tunnels`]).
    Tunnels {
        /// Columns.
        width: u32,
        /// Rows.
        height: u32,
        /// Share of wall cells, in `[0, 1)`.
        obstacles: f32,
        /// Seed of the walks. Default: the scenario's seed.
        seed: Option<u64>,
    },
}

/// The goals of one channel.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum GoalSpec {
    /// The map's `G` cells.
    Map,
    /// These cells.
    Cells(Vec<(u32, u32)>),
    /// This many distinct random free cells.
    Random(usize),
    /// The free cells whose centre lies inside exit `k` (the `k`-th of the scenario's
    /// `[[exits]]`): one channel per exit, for allocated escape routes and `choose_exit`.
    Exit(usize),
}

/// A group moved by grid walkers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WalkerSpec {
    /// The group (index in `groups`).
    pub group: usize,
    /// The channel its walkers follow. Default: 0.
    #[serde(default)]
    pub channel: usize,
    /// `"queue"` or `"next_best"`. Default: queue.
    #[serde(default)]
    pub policy: WalkPolicy,
}

fn walkable_map() -> MapSource {
    MapSource::Walkable
}
fn one() -> f32 {
    1.0
}
fn four() -> usize {
    4
}
fn default_decay() -> f32 {
    0.99
}
fn eight() -> Neighbourhood {
    Neighbourhood::Eight
}
fn map_goals() -> Vec<GoalSpec> {
    vec![GoalSpec::Map]
}

impl FieldSpec {
    /// A field over the inline ASCII map `text` with cells of `cell_size`, origin `(0, 0)`,
    /// one channel with the map's goals and the other keys at their defaults.
    #[must_use]
    pub fn inline(text: String, cell_size: f32) -> FieldSpec {
        FieldSpec {
            map: MapSource::Ascii(text),
            cell_size,
            origin: Vec2::ZERO,
            decay: default_decay(),
            neighbourhood: Neighbourhood::Eight,
            channels: map_goals(),
            shuffle_every: 0,
            shuffle_goals: four(),
            walkers: Vec::new(),
            clearance: 0.0,
            clearance_cost: None,
            metric: FlowMetric::Steps,
            reroute_every: None,
            density_radius: None,
        }
    }

    /// Makes a relative map path relative to the folder of `source_name` (the scenario file).
    pub(crate) fn resolve_paths(&mut self, source_name: &str) {
        if let MapSource::File(p) = &mut self.map
            && p.is_relative()
            && let Some(dir) = Path::new(source_name).parent()
        {
            *p = dir.join(&*p);
        }
    }

    /// Checks the counts against their ceilings before anything is built.
    pub(crate) fn validate(&self) -> Result<()> {
        use super::obstacles::at_most;
        use crate::limits::{MAX_CELLS, MAX_CHANNELS, MAX_RANDOM_GOALS};
        // Checked first: a side of 0 made the memory estimate of a walkable raster 16 EiB.
        crate::error::positive("field.cell_size", self.cell_size)?;
        at_most(
            "field.channels",
            self.channels.len(),
            MAX_CHANNELS,
            "[1, 64]",
        )?;
        at_most(
            "field.shuffle_goals",
            self.shuffle_goals,
            MAX_RANDOM_GOALS,
            "[0, 1000000]",
        )?;
        for g in &self.channels {
            if let GoalSpec::Random(n) = g {
                at_most(
                    "field.channels.random",
                    *n,
                    MAX_RANDOM_GOALS,
                    "[0, 1000000]",
                )?;
            }
        }
        if let Some(cost) = self.clearance_cost {
            crate::error::in_range(
                "field.clearance_cost",
                cost,
                1.0,
                crate::field::MAX_CELL_COST,
                "[1, 20]",
            )?;
            if self.clearance <= 0.0 {
                return Err(Error::Invalid {
                    name: "field.clearance_cost".into(),
                    reason:
                        "it costs the cells within `clearance` of a wall: set a clearance above 0"
                            .into(),
                });
            }
            if self.metric == FlowMetric::Steps {
                return Err(Error::Invalid {
                    name: "field.clearance_cost".into(),
                    reason: "costs shape the flows of a distance metric only: set `metric = \"euclidean\"` or `\"quickest\"`".into(),
                });
            }
            if self.map != MapSource::Walkable {
                return Err(Error::Invalid {
                    name: "field.clearance_cost".into(),
                    reason: "the clearance applies to the walkable raster (`map = \"walkable\"`)"
                        .into(),
                });
            }
        }
        if let MapSource::Caves { width, height, .. } | MapSource::Tunnels { width, height, .. } =
            &self.map
            && u64::from(*width) * u64::from(*height) > MAX_CELLS
        {
            return Err(Error::OutOfRange {
                name: "field.map cells (width x height)",
                value: f64::from(*width) * f64::from(*height),
                range: "[1, 268435456]",
            });
        }
        Ok(())
    }

    /// The number of cells the map will have, as far as it is known before it is read (a map
    /// file counts one cell per byte).
    pub(crate) fn cell_estimate(&self, area: Option<&crate::geometry::Walkable>) -> u64 {
        match &self.map {
            MapSource::Walkable => area.map_or(0, |a| {
                let side = (a.max() - a.min()) / self.cell_size.max(f32::MIN_POSITIVE);
                ((f64::from(side.x) + 2.0) * (f64::from(side.y) + 2.0)).min(u64::MAX as f64) as u64
            }),
            MapSource::File(p) => std::fs::metadata(p).map_or(0, |m| m.len()),
            MapSource::Ascii(text) => text.len() as u64,
            MapSource::Caves { width, height, .. } | MapSource::Tunnels { width, height, .. } => {
                u64::from(*width) * u64::from(*height)
            }
        }
    }

    /// Checks, before any agent is spawned, that the walker groups fit on the free cells (one
    /// walker per cell); `counts` holds each group's agent count.
    pub(crate) fn check_walkers(
        &self,
        world: &World,
        field: usize,
        counts: &[usize],
    ) -> Result<()> {
        let Some(f) = world.field(field) else {
            return Ok(());
        };
        let free = f.grid().free_count();
        let walkers = self
            .walkers
            .iter()
            .filter_map(|w| counts.get(w.group).copied())
            .fold(0usize, usize::saturating_add);
        if walkers > free {
            return Err(Error::Invalid {
                name: "field.walkers".into(),
                reason: format!(
                    "more walkers than free cells ({walkers} walkers, {free} free cells)"
                ),
            });
        }
        Ok(())
    }

    fn map(&self, seed: u64, world: &World) -> Result<MapFile> {
        let map = match &self.map {
            MapSource::Walkable => {
                let area = world.walkable().ok_or_else(|| Error::Invalid {
                    name: "field.map".into(),
                    reason: "the walkable raster needs `[geometry] walkable`".into(),
                })?;
                let grid = area.rasterize(self.cell_size, self.origin)?;
                // With a clearance cost the cells near walls stay free (costed in `add_to`).
                let grid = match self.clearance_cost {
                    Some(_) => grid,
                    None => grid.dilated(self.clearance)?,
                };
                let goals = (0..grid.height())
                    .flat_map(|y| (0..grid.width()).map(move |x| (x, y)))
                    .filter(|&(x, y)| {
                        grid.is_free(x, y)
                            && world
                                .exits()
                                .iter()
                                .any(|e| e.contains(grid.cell_center(x, y)))
                    })
                    .collect();
                return Ok(MapFile {
                    source_name: "<walkable>".into(),
                    grid,
                    goals,
                    spawns: Vec::new(),
                });
            }
            MapSource::File(p) => OccupancyGrid::load_ascii(p)?,
            MapSource::Ascii(text) => OccupancyGrid::parse_ascii(text, "<field.map.ascii>")?,
            MapSource::Caves {
                width,
                height,
                obstacles,
                seed: s,
            } => MapFile {
                source_name: "<caves>".into(),
                grid: OccupancyGrid::caves(*width, *height, *obstacles, s.unwrap_or(seed))?,
                goals: Vec::new(),
                spawns: Vec::new(),
            },
            MapSource::Tunnels {
                width,
                height,
                obstacles,
                seed: s,
            } => MapFile {
                source_name: "<tunnels>".into(),
                grid: OccupancyGrid::tunnels(*width, *height, *obstacles, s.unwrap_or(seed))?,
                goals: Vec::new(),
                spawns: Vec::new(),
            },
        };
        let grid = map.grid.with_geometry(self.cell_size, self.origin)?;
        Ok(MapFile { grid, ..map })
    }

    /// Builds the grid and channels and adds them to `world` (before any agent is spawned).
    pub(crate) fn add_to(&self, world: &mut World, seed: u64) -> Result<usize> {
        let map = self.map(seed, world)?;
        if self.channels.is_empty() {
            return Err(Error::Invalid {
                name: "field.channels".into(),
                reason: "at least one channel is required".into(),
            });
        }
        let mut channels = GoalChannels::new(map.grid.clone(), self.decay, self.neighbourhood)?
            .with_metric(self.metric);
        if let (Some(cost), MapSource::Walkable) = (self.clearance_cost, &self.map) {
            channels = channels.with_clearance_cost(self.clearance, cost)?;
        }
        for (k, g) in self.channels.iter().enumerate() {
            let goals = match g {
                GoalSpec::Map if self.map == MapSource::Walkable && map.goals.is_empty() => {
                    return Err(Error::Invalid {
                        name: "field.channels".into(),
                        reason: "a \"map\" channel of the walkable raster has the free cells whose centre lies inside an exit, and there are none (add an exit inside the walkable area, or give the channel's cells)".into(),
                    });
                }
                GoalSpec::Map => map.require_goals()?.to_vec(),
                GoalSpec::Cells(c) => c.clone(),
                GoalSpec::Random(n) => {
                    random_free_cells(&map.grid, *n, seed ^ 0x60a1_0000 ^ k as u64)?
                }
                GoalSpec::Exit(e) => exit_cells(&map.grid, world, k, *e)?,
            };
            channels.add_channel(&goals)?;
        }
        world.add_field(channels)
    }

    /// Goal re-randomisation and walkers, once the agents are spawned.
    pub(crate) fn finish(&self, world: &mut World, field: usize) -> Result<()> {
        world.shuffle_field_goals_every(field, self.shuffle_every, self.shuffle_goals)?;
        if self.metric == FlowMetric::Quickest
            || self.reroute_every.is_some()
            || self.density_radius.is_some()
        {
            world.set_field_rerouting(
                field,
                self.reroute_every
                    .unwrap_or(crate::world::fields::DEFAULT_REROUTE_EVERY),
                self.density_radius
                    .unwrap_or(crate::world::fields::DEFAULT_DENSITY_RADIUS),
            )?;
        }
        for w in &self.walkers {
            world.add_walkers(field, w.group, w.channel, w.policy)?;
        }
        Ok(())
    }
}

/// The free cells of `grid` whose centre lies inside exit `exit` of `world`, for channel
/// `channel`.
fn exit_cells(
    grid: &OccupancyGrid,
    world: &World,
    channel: usize,
    exit: usize,
) -> Result<Vec<(u32, u32)>> {
    let exits = world.exits();
    let e = exits.get(exit).ok_or_else(|| Error::Invalid {
        name: format!("field.channels[{channel}]"),
        reason: format!(
            "exit {exit} does not exist (the scenario has {})",
            exits.len()
        ),
    })?;
    let cells: Vec<(u32, u32)> = (0..grid.height())
        .flat_map(|y| (0..grid.width()).map(move |x| (x, y)))
        .filter(|&(x, y)| grid.is_free(x, y) && e.contains(grid.cell_center(x, y)))
        .collect();
    if cells.is_empty() {
        return Err(Error::Invalid {
            name: format!("field.channels[{channel}]"),
            reason: format!("no free cell of the field has its centre inside exit {exit}"),
        });
    }
    Ok(cells)
}

/// A uniformly random point on the free cells of the world's first field (rejection sampling).
pub(crate) fn free_point(
    world: &World,
    rng: &mut ChaCha8Rng,
    free_cells: &mut Option<crate::spawn::FreeCells>,
) -> Result<Vec2> {
    let no_field = || Error::Invalid {
        name: "spawn".into(),
        reason: "`free_cells` spawning needs a `[field]` with at least one free cell".into(),
    };
    let grid = world.field(0).ok_or_else(no_field)?.grid();
    let size = Vec2::new(grid.width() as f32, grid.height() as f32);
    let in_cell = |x: u32, y: u32, inner: Vec2| {
        let inner = inner.clamp(Vec2::splat(0.01), Vec2::splat(0.99));
        grid.origin() + (Vec2::new(x as f32, y as f32) + inner) * grid.cell_size()
    };
    // A few uniform draws over the whole grid first: on a mostly free grid one of them lands
    // in a free cell.
    for _ in 0..64 {
        let u = Vec2::new(rng.random::<f32>(), rng.random::<f32>()) * size;
        let (x, y) = (
            (u.x as u32).min(grid.width() - 1),
            (u.y as u32).min(grid.height() - 1),
        );
        let p = in_cell(x, y, u - Vec2::new(x as f32, y as f32));
        if grid.is_free(x, y) && grid.world_to_cell(p) == Some((x, y)) {
            return Ok(p);
        }
    }
    // A sparse grid: a free cell drawn uniformly from the index of the free cells (made once
    // per build), then a point inside it.
    let free = free_cells.get_or_insert_with(|| crate::spawn::FreeCells::new(grid));
    if free.is_empty() {
        return Err(no_field());
    }
    let (x, y) = free.nth(grid, rng.random_range(0..free.len()));
    let mut p = in_cell(x, y, Vec2::new(rng.random::<f32>(), rng.random::<f32>()));
    if grid.world_to_cell(p) != Some((x, y)) {
        // Far from the origin the cell's inside may round onto its edge: take its centre.
        p = grid.cell_center(x, y);
    }
    Ok(p)
}
