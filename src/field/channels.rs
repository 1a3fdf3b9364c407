//! Goal channels: several potential fields side by side on one grid, one per goal type.
//!
//! Each channel holds its goal cells, its [`PotentialField`] and a [`FlowField`]: the potential's
//! own flow, or with [`FlowMetric::Euclidean`] the flow of the goals' [`DistanceField`] (grid
//! walkers always climb the potential); [`FlowMetric::Quickest`] flows are built with per-cell
//! costs that the world sets from the crowd's density.
//! Agents of a group follow their group's channel. Changing a channel's goals (moving them, or
//! re-randomising them, as a click does in the classic flow-field demo) marks that channel dirty; changing a cell
//! between free and wall marks every channel dirty. [`GoalChannels::rebuild_dirty`] rebuilds the
//! dirty channels, in parallel (each build is itself sequential and deterministic).
//!
//! Invariants: a channel's goals always lie on free cells of the grid; a dirty channel exposes no
//! field, so nobody follows a stale one.

use rayon::prelude::*;

use super::distance::{DistanceField, MAX_CELL_COST};
use super::flow::FlowField;
use super::lattice::{Neighbourhood, check_goals};
use super::occupancy::{Cell, OccupancyGrid, random_free_cells};
use super::potential::{PotentialField, check_decay};
use crate::error::{Error, Result};

/// What the flow of a channel follows.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum FlowMetric {
    /// The BFS field's steps: each cell points to its best neighbour, one of eight directions.
    #[default]
    Steps,
    /// The geodesic Euclidean distance ([`DistanceField`]): each cell points down its gradient,
    /// straight at the goal or the next wall corner at any angle.
    Euclidean,
    /// The quickest way through the crowd: the travel time of a [`DistanceField`] whose cell
    /// costs ([`GoalChannels::set_costs`]) a world sets from the local density of agents (see
    /// [`World::set_field_rerouting`](crate::World::set_field_rerouting)), so that a crowd
    /// jammed at a corner or a door spreads round it instead of pressing on; otherwise as
    /// `Euclidean`.
    Quickest,
}

impl FlowMetric {
    /// Whether the flow comes from a [`DistanceField`].
    #[must_use]
    pub fn is_distance(self) -> bool {
        self != FlowMetric::Steps
    }
}

#[derive(Clone, Debug)]
struct Channel {
    goals: Vec<(u32, u32)>,
    built: Option<Built>,
    dirty: bool,
}

#[derive(Clone, Debug)]
struct Built {
    field: PotentialField,
    flow: FlowField,
    /// Kept with a distance metric, so that rebuilds reuse its buffers.
    distance: Option<DistanceField>,
}

/// Several goal fields on one grid, rebuilt when goals or obstacles change.
#[derive(Clone, Debug)]
pub struct GoalChannels {
    grid: OccupancyGrid,
    decay: f32,
    neighbourhood: Neighbourhood,
    metric: FlowMetric,
    /// Per cell (row-major), the cost the distance flows are built with; empty for none.
    costs: Vec<f32>,
    /// Cells whose centre lies within `.0` of a wall cost `.1` times as much to cross (the
    /// distance flows only); none by default.
    clearance: Option<(f32, f32)>,
    /// Per cell, whether it lies within the clearance of a wall; `None` until computed for the
    /// grid as it stands.
    near: Option<Vec<bool>>,
    /// With a clearance: `costs` (or 1) times the clearance's cost, capped at
    /// [`MAX_CELL_COST`]; what the distance flows are built with then.
    effective: Vec<f32>,
    channels: Vec<Channel>,
}

impl GoalChannels {
    /// No channels yet, on `grid`, with fields of `decay` and `neighbourhood`.
    ///
    /// # Examples
    /// ```
    /// # fn main() -> throng::Result<()> {
    /// use throng::field::{GoalChannels, Neighbourhood, OccupancyGrid};
    /// let grid = OccupancyGrid::new(8, 8)?;
    /// let mut channels = GoalChannels::new(grid, 0.9, Neighbourhood::Eight)?;
    /// let food = channels.add_channel(&[(0, 0)])?;
    /// let water = channels.add_channel(&[(7, 7)])?;
    /// channels.rebuild_dirty()?;
    /// assert_eq!(channels.field(food).unwrap().steps(7, 7), Some(7));
    /// channels.set_goals(water, &[(7, 0)])?;
    /// assert!(channels.field(water).is_none()); // dirty until rebuilt
    /// assert_eq!(channels.rebuild_dirty()?, 1);
    /// # Ok(()) }
    /// ```
    ///
    /// # Errors
    /// [`Error::NonFinite`] or [`Error::OutOfRange`] unless `decay` lies in `(0, 1)`.
    pub fn new(grid: OccupancyGrid, decay: f32, neighbourhood: Neighbourhood) -> Result<Self> {
        Ok(GoalChannels {
            grid,
            decay: check_decay(decay)?,
            neighbourhood,
            metric: FlowMetric::Steps,
            costs: Vec::new(),
            clearance: None,
            near: None,
            effective: Vec::new(),
            channels: Vec::new(),
        })
    }

    /// The same channels with every free cell whose centre lies within `distance` (world
    /// units) of a wall cell or the grid's border ([`OccupancyGrid::near_walls`]) costing
    /// `cost` times as much to cross, on top of any [`GoalChannels::set_costs`] (the product
    /// capped at [`MAX_CELL_COST`], so that a crowd's cost of 5 or more on such a cell reads
    /// as 20 with a cost of 4); every channel is marked dirty. The flows of a distance metric
    /// then steer off walls where going round the band is cheaper than crossing it (a soft
    /// version of [`OccupancyGrid::dilated`]'s walls), but still lead through a door narrower
    /// than twice the distance, which a dilated grid closes or narrows to whole cells. The
    /// grid itself keeps those cells free, so the walls that agents' moves are held to are the
    /// grid's own. The cells follow the walls as they change ([`GoalChannels::set_blocked`]).
    /// Flows of the [`FlowMetric::Steps`] metric ignore costs.
    ///
    /// # Examples
    /// ```
    /// # fn main() -> throng::Result<()> {
    /// use throng::field::{FlowMetric, GoalChannels, Neighbourhood, OccupancyGrid};
    /// // A wall with a door one cell wide at x = 2: dilating by one cell would close it.
    /// let map = OccupancyGrid::parse_ascii(".....\n##.##\n.....\n", "<map>")?;
    /// let mut channels = GoalChannels::new(map.grid, 0.9, Neighbourhood::Eight)?
    ///     .with_metric(FlowMetric::Euclidean)
    ///     .with_clearance_cost(1.0, 4.0)?;
    /// let exit = channels.add_channel(&[(2, 2)])?;
    /// channels.rebuild_dirty()?;
    /// // Every cell lies within 1 of a wall or the border: the door is open, at 4 times the cost.
    /// let cost = channels.travel_cost(exit, glam::Vec2::new(2.5, 0.5)).unwrap();
    /// assert!((cost - 4.0 * 2.0).abs() < 1e-3, "{cost}");
    /// # Ok(()) }
    /// ```
    ///
    /// # Errors
    /// [`Error::OutOfRange`] or [`Error::NonFinite`] for a distance outside `[0, 64]` cells or
    /// a cost outside `[1, MAX_CELL_COST]`.
    pub fn with_clearance_cost(mut self, distance: f32, cost: f32) -> Result<Self> {
        let near = self.grid.near_walls(distance)?;
        crate::error::in_range("field.clearance_cost", cost, 1.0, MAX_CELL_COST, "[1, 20]")?;
        self.clearance = Some((distance, cost));
        self.near = Some(near);
        for c in &mut self.channels {
            c.dirty = true;
        }
        Ok(self)
    }

    /// The clearance and its cost ([`GoalChannels::with_clearance_cost`]), if any.
    #[must_use]
    pub fn clearance_cost(&self) -> Option<(f32, f32)> {
        self.clearance
    }

    /// The same channels with flows that follow `metric` (every channel is marked dirty).
    #[must_use]
    pub fn with_metric(mut self, metric: FlowMetric) -> Self {
        if metric != self.metric {
            self.metric = metric;
            for c in &mut self.channels {
                c.dirty = true;
                c.built = None;
            }
        }
        self
    }

    /// What the channels' flows follow.
    #[must_use]
    pub fn metric(&self) -> FlowMetric {
        self.metric
    }

    /// Sets the per-cell costs (row-major, one per cell, each in `[1, MAX_CELL_COST]`; walls'
    /// entries ignored) that flows from a distance field are built with, or none (`&[]`), and
    /// marks every channel dirty. The goals and the BFS fields do not change, and flows of the
    /// [`FlowMetric::Steps`] metric ignore costs.
    ///
    /// # Errors
    /// As [`DistanceField::fast_marching_with_costs`] for the costs; nothing changes then.
    pub fn set_costs(&mut self, costs: &[f32]) -> Result<()> {
        if !costs.is_empty() {
            super::distance::check_costs(&self.grid, costs)?;
        }
        self.costs.clear();
        self.costs.extend_from_slice(costs);
        for c in &mut self.channels {
            c.dirty = true;
        }
        Ok(())
    }

    /// The per-cell costs of the distance flows (empty for none).
    #[must_use]
    pub fn costs(&self) -> &[f32] {
        &self.costs
    }

    /// Adds a channel with `goals` (dirty until the next rebuild) and returns its index.
    ///
    /// # Errors
    /// [`Error::Invalid`] when `goals` is empty or a goal is outside the grid or on a wall.
    pub fn add_channel(&mut self, goals: &[(u32, u32)]) -> Result<usize> {
        check_goals(&self.grid, goals)?;
        self.channels.push(Channel {
            goals: goals.to_vec(),
            built: None,
            dirty: true,
        });
        Ok(self.channels.len() - 1)
    }

    /// Number of channels.
    #[must_use]
    pub fn len(&self) -> usize {
        self.channels.len()
    }

    /// Whether there are no channels.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.channels.is_empty()
    }

    /// The grid all channels share.
    #[must_use]
    pub fn grid(&self) -> &OccupancyGrid {
        &self.grid
    }

    fn channel(&self, channel: usize) -> Result<&Channel> {
        self.channels.get(channel).ok_or_else(|| Error::Invalid {
            name: "channel".into(),
            reason: format!("no channel {channel} (there are {})", self.channels.len()),
        })
    }

    /// The goals of `channel`.
    ///
    /// # Errors
    /// [`Error::Invalid`] when the channel does not exist.
    pub fn goals(&self, channel: usize) -> Result<&[(u32, u32)]> {
        Ok(&self.channel(channel)?.goals)
    }

    /// Replaces the goals of `channel` (moved goals) and marks it dirty.
    ///
    /// # Errors
    /// [`Error::Invalid`] when the channel does not exist or the goals are bad (as
    /// [`GoalChannels::add_channel`]); nothing changes then.
    pub fn set_goals(&mut self, channel: usize, goals: &[(u32, u32)]) -> Result<()> {
        self.channel(channel)?;
        check_goals(&self.grid, goals)?;
        let ch = &mut self.channels[channel];
        ch.goals = goals.to_vec();
        ch.dirty = true;
        Ok(())
    }

    /// Re-randomises the goals of `channel`: `n` distinct free cells drawn with `seed` (the
    /// the classic demo's "click to randomize goals").
    ///
    /// # Errors
    /// [`Error::Invalid`] when the channel does not exist, `n` is 0, or the grid has fewer than
    /// `n` free cells.
    pub fn randomize_goals(&mut self, channel: usize, n: usize, seed: u64) -> Result<()> {
        let goals = random_free_cells(&self.grid, n, seed)?;
        self.set_goals(channel, &goals)
    }

    /// Makes `(x, y)` a wall (`blocked`) or free ground; when that changes the cell, every channel
    /// is marked dirty.
    ///
    /// # Errors
    /// [`Error::Invalid`] when the cell lies outside the grid, or would become a wall while it is
    /// a goal of some channel.
    pub fn set_blocked(&mut self, x: u32, y: u32, blocked: bool) -> Result<()> {
        self.grid.check_cell("cell", x, y)?;
        if blocked && let Some(ch) = self.channels.iter().position(|c| c.goals.contains(&(x, y))) {
            return Err(Error::Invalid {
                name: "cell".into(),
                reason: format!("({x}, {y}) is a goal of channel {ch} and cannot become a wall"),
            });
        }
        let cell = if blocked { Cell::Wall } else { Cell::Free };
        if self.grid.cell(x, y) != Some(cell) {
            self.grid.set(x, y, cell)?;
            self.near = None;
            for ch in &mut self.channels {
                ch.dirty = true;
            }
        }
        Ok(())
    }

    /// The fields' decay.
    #[must_use]
    pub fn decay(&self) -> f32 {
        self.decay
    }

    /// The fields' neighbourhood.
    #[must_use]
    pub fn neighbourhood(&self) -> Neighbourhood {
        self.neighbourhood
    }

    /// Marks an existing `channel` as waiting for a rebuild (a restored dirty flag).
    pub(crate) fn mark_dirty(&mut self, channel: usize) {
        if let Some(c) = self.channels.get_mut(channel) {
            c.dirty = true;
        }
    }

    /// Whether `channel` waits for a rebuild (false for a channel that does not exist).
    #[must_use]
    pub fn is_dirty(&self, channel: usize) -> bool {
        self.channels.get(channel).is_some_and(|c| c.dirty)
    }

    /// Rebuilds every dirty channel (in parallel) and returns how many were rebuilt.
    ///
    /// # Errors
    /// Only what [`PotentialField::bfs`] returns, which the checks on the way in rule out.
    pub fn rebuild_dirty(&mut self) -> Result<usize> {
        let distance = self.metric.is_distance();
        if distance && self.channels.iter().any(|c| c.dirty) {
            self.update_effective_costs();
        }
        let (grid, decay, neighbourhood) = (&self.grid, self.decay, self.neighbourhood);
        let costs = if self.clearance.is_some() {
            Some(&self.effective[..])
        } else {
            (!self.costs.is_empty()).then_some(&self.costs[..])
        };
        let results: Vec<Result<()>> = self
            .channels
            .par_iter_mut()
            .filter(|c| c.dirty)
            .map(|c| {
                // Rebuild in place when possible: the buffers are kept, so no fresh pages.
                match &mut c.built {
                    Some(b) => {
                        b.field.rebuild(grid, &c.goals)?;
                        match &mut b.distance {
                            Some(d) => {
                                d.rebuild_with_costs(grid, &c.goals, costs)?;
                                b.flow.rebuild_from_distance(d);
                            }
                            None => b.flow.rebuild_from_potential(&b.field),
                        }
                    }
                    None => {
                        let field = PotentialField::bfs(grid, &c.goals, decay, neighbourhood)?;
                        let (flow, distance) = if distance {
                            let d = match costs {
                                Some(k) => {
                                    DistanceField::fast_marching_with_costs(grid, &c.goals, k)?
                                }
                                None => DistanceField::fast_marching(grid, &c.goals)?,
                            };
                            (FlowField::from_distance(&d), Some(d))
                        } else {
                            (FlowField::from_potential(&field), None)
                        };
                        c.built = Some(Built {
                            field,
                            flow,
                            distance,
                        });
                    }
                }
                c.dirty = false;
                Ok(())
            })
            .collect();
        let rebuilt = results.len();
        results.into_iter().collect::<Result<Vec<()>>>()?;
        Ok(rebuilt)
    }

    /// With a clearance, the costs the distance flows are built with: the set costs (or 1)
    /// times the clearance's cost on the cells near walls, capped at [`MAX_CELL_COST`].
    fn update_effective_costs(&mut self) {
        let Some((distance, cost)) = self.clearance else {
            return;
        };
        let near = self.near.get_or_insert_with(|| {
            // The distance was checked against this grid's cell size, which never changes, so
            // this is never the empty mask (whose costs `rebuild_dirty` would refuse).
            self.grid.near_walls(distance).unwrap_or_default()
        });
        self.effective.clear();
        self.effective
            .extend(near.iter().enumerate().map(|(i, &n)| {
                let base = self.costs.get(i).copied().unwrap_or(1.0);
                if n {
                    (base * cost).min(MAX_CELL_COST)
                } else {
                    base
                }
            }));
    }

    /// The potential field of `channel`, or `None` when it does not exist or is dirty.
    #[must_use]
    pub fn field(&self, channel: usize) -> Option<&PotentialField> {
        self.channels
            .get(channel)
            .filter(|c| !c.dirty)
            .and_then(|c| c.built.as_ref())
            .map(|b| &b.field)
    }

    /// The flow field of `channel`, or `None` when it does not exist or is dirty.
    #[must_use]
    pub fn flow(&self, channel: usize) -> Option<&FlowField> {
        self.channels
            .get(channel)
            .filter(|c| !c.dirty)
            .and_then(|c| c.built.as_ref())
            .map(|b| &b.flow)
    }

    /// How far the goals of `channel` are from world point `p`, for choosing among channels:
    /// with a distance metric the geodesic distance of `p`'s cell (with the quickest metric,
    /// weighted by the cells' costs: the free speed's travel time through the crowd, in metres;
    /// with a [clearance cost](GoalChannels::with_clearance_cost), weighted by it too, so that
    /// of two doors the wider costs less), otherwise the BFS field's steps times the cell size. `None` when the channel does not
    /// exist or is dirty, or when `p` lies off the grid, on a wall or where no goal is reached.
    #[must_use]
    pub fn travel_cost(&self, channel: usize, p: glam::Vec2) -> Option<f32> {
        let built = self
            .channels
            .get(channel)
            .filter(|c| !c.dirty)
            .and_then(|c| c.built.as_ref())?;
        let (x, y) = self.grid.world_to_cell(p)?;
        match &built.distance {
            Some(d) => d.distance(x, y),
            None => built
                .field
                .steps(x, y)
                .map(|s| s as f32 * self.grid.cell_size()),
        }
    }
}

/// A set of goal channels of one field (channels 0 to 63, as a field has at most 64), written
/// in a scenario as a list of channel numbers; the empty set stands for every channel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct ChannelSet(u64);

impl ChannelSet {
    /// Every channel of the field.
    pub const ALL: ChannelSet = ChannelSet(0);

    /// The channels listed.
    ///
    /// # Errors
    /// [`Error::OutOfRange`] for a channel above 63.
    pub fn of(channels: &[usize]) -> Result<Self> {
        let mut bits = 0u64;
        for &c in channels {
            if c >= 64 {
                return Err(Error::OutOfRange {
                    name: "choose_exit.channels",
                    value: c as f64,
                    range: "[0, 63]",
                });
            }
            bits |= 1 << c;
        }
        Ok(ChannelSet(bits))
    }

    /// Whether this is the set of every channel.
    #[must_use]
    pub fn is_all(&self) -> bool {
        self.0 == 0
    }

    /// The channels below `count` (a field's channel count) in the set, ascending.
    pub fn iter(self, count: usize) -> impl Iterator<Item = usize> {
        (0..count.min(64)).filter(move |&c| self.0 == 0 || self.0 & (1 << c) != 0)
    }

    /// Whether `channel` is in the set.
    #[must_use]
    pub fn contains(self, channel: usize) -> bool {
        channel < 64 && (self.0 == 0 || self.0 & (1 << channel) != 0)
    }

    /// The largest channel listed, if the set lists any.
    #[must_use]
    pub fn max(self) -> Option<usize> {
        (self.0 != 0).then(|| 63 - self.0.leading_zeros() as usize)
    }
}

impl serde::Serialize for ChannelSet {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        let list: Vec<usize> = (0..64).filter(|&c| self.0 & (1 << c) != 0).collect();
        serde::Serialize::serialize(&list, s)
    }
}

impl<'de> serde::Deserialize<'de> for ChannelSet {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        let list = <Vec<usize> as serde::Deserialize>::deserialize(d)?;
        ChannelSet::of(&list).map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec2;

    /// A room 12 x 9 cells split by a wall at row 4 with a door of `door` cells at x 5..,
    /// the goal at (6, 7), two cells from the top border.
    fn room(door: u32) -> OccupancyGrid {
        let mut g = OccupancyGrid::new(12, 9).unwrap();
        for x in 0..12 {
            if !(5..5 + door).contains(&x) {
                g.set(x, 4, Cell::Wall).unwrap();
            }
        }
        g
    }

    fn built(grid: OccupancyGrid, clearance: Option<(f32, f32)>, costs: &[f32]) -> GoalChannels {
        let mut c = GoalChannels::new(grid, 0.9, Neighbourhood::Eight)
            .unwrap()
            .with_metric(FlowMetric::Euclidean);
        if let Some((d, k)) = clearance {
            c = c.with_clearance_cost(d, k).unwrap();
        }
        c.set_costs(costs).unwrap();
        c.add_channel(&[(6, 7)]).unwrap();
        c.rebuild_dirty().unwrap();
        c
    }

    /// Every cell's travel cost, row-major.
    fn all_costs(c: &GoalChannels) -> Vec<Option<f32>> {
        let g = c.grid();
        (0..g.height())
            .flat_map(|y| (0..g.width()).map(move |x| (x, y)))
            .map(|(x, y)| c.travel_cost(0, g.cell_center(x, y)))
            .collect()
    }

    #[test]
    fn a_clearance_cost_is_the_near_wall_cells_costs_times_the_set_costs() {
        let grid = room(2);
        let near = grid.near_walls(0.5).unwrap();
        assert!(near.iter().any(|&n| n) && near.iter().any(|&n| !n));
        // Costs set from outside (a crowd): 1 to 19 over the cells.
        let set: Vec<f32> = (0..grid.len()).map(|i| 1.0 + (i % 19) as f32).collect();
        let by_hand = |set: &[f32], near: &[bool]| -> Vec<f32> {
            near.iter()
                .enumerate()
                .map(|(i, &n)| {
                    let b = set.get(i).copied().unwrap_or(1.0);
                    if n { (b * 3.0).min(MAX_CELL_COST) } else { b }
                })
                .collect()
        };
        for costs in [&[][..], &set[..]] {
            let with = built(grid.clone(), Some((0.5, 3.0)), costs);
            let reference = built(grid.clone(), None, &by_hand(costs, &near));
            assert_eq!(all_costs(&with), all_costs(&reference));
        }
        // New costs on built channels (a reroute) are built in place with the clearance's.
        let mut with = built(grid.clone(), Some((0.5, 3.0)), &[]);
        with.set_costs(&set).unwrap();
        with.rebuild_dirty().unwrap();
        let reference = built(grid.clone(), None, &by_hand(&set, &near));
        assert_eq!(all_costs(&with), all_costs(&reference));
        // A wall added later moves the costed cells with it.
        let mut with = built(grid.clone(), Some((0.5, 3.0)), &[]);
        with.set_blocked(1, 5, true).unwrap();
        with.rebuild_dirty().unwrap();
        let mut changed = grid.clone();
        changed.set(1, 5, Cell::Wall).unwrap();
        let reference = built(
            changed.clone(),
            None,
            &by_hand(&[], &changed.near_walls(0.5).unwrap()),
        );
        assert_eq!(all_costs(&with), all_costs(&reference));
        assert_ne!(
            all_costs(&with),
            all_costs(&built(grid, Some((0.5, 3.0)), &[]))
        );
    }

    #[test]
    fn a_door_that_the_dilated_grid_closes_stays_open_at_a_cost() {
        // Two cells wide, a clearance of one cell: dilation walls the door up.
        let (grid, below) = (room(2), Vec2::new(6.5, 1.5));
        let dilated = built(grid.dilated(1.0).unwrap(), None, &[]);
        assert_eq!(dilated.travel_cost(0, below), None);
        let costed = built(grid.clone(), Some((1.0, 4.0)), &[]);
        let plain = built(grid, None, &[]);
        let (c, p) = (
            costed.travel_cost(0, below).unwrap(),
            plain.travel_cost(0, below).unwrap(),
        );
        assert!(c > p && c <= 4.0 * p, "{c} against {p}");
        assert!(
            [(5, 4), (6, 4)].iter().all(|&(x, y)| costed
                .travel_cost(0, costed.grid().cell_center(x, y))
                .is_some()),
            "the door's cells are reachable"
        );
        // Where there is room, the flow steers off the walls: on the top border, left of the
        // goal, it turns down away from the border more steeply than the plain flow.
        let at = Vec2::new(2.5, 8.5);
        let f = costed.flow(0).unwrap().sample(at);
        let g = plain.flow(0).unwrap().sample(at);
        assert!(f.x > 0.0 && g.x > 0.0 && f.y / f.x < g.y / g.x, "{f} {g}");
    }
}
