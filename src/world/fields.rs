//! The world's field API: adding fields, moving their goals, blocking cells, grid walkers and
//! arrivals, and quickest-path rerouting. The per-step work lives in the fields subsystem (`crate::field::FieldSet`).

use glam::Vec2;

use super::state::World;
use crate::agents::AgentId;
use crate::error::{Error, Result};
use crate::field::{
    FlowMetric, GoalChannels, GridWalkers, WalkPolicy, WalkerGroup, WorldField, cell_of, in_wall,
    wall_bits,
};

pub(crate) use crate::field::{DEFAULT_DENSITY_RADIUS, DEFAULT_REROUTE_EVERY};
use crate::limits::MAX_REROUTE_EVERY;

/// The checks of [`World::set_field_rerouting`].
pub(crate) fn check_rerouting(channels: &GoalChannels, every: u64, radius: f32) -> Result<()> {
    if channels.metric() != FlowMetric::Quickest {
        return Err(Error::Invalid {
            name: "field.reroute_every".into(),
            reason: "rerouting by the crowd's density needs the \"quickest\" metric".into(),
        });
    }
    if every > MAX_REROUTE_EVERY {
        return Err(Error::OutOfRange {
            name: "field.reroute_every",
            value: every as f64,
            range: "[0, 2^40] frames",
        });
    }
    let cells = radius / channels.grid().cell_size();
    crate::error::finite("field.density_radius", radius)?;
    if !(radius > 0.0 && cells <= 64.0) {
        return Err(Error::OutOfRange {
            name: "field.density_radius",
            value: f64::from(radius),
            range: "(0, 64 cells]",
        });
    }
    Ok(())
}

/// The checks of [`World::shuffle_field_goals_every`]: `count` goals fit the grid's free cells.
pub(crate) fn check_shuffle(channels: &GoalChannels, every: u64, count: usize) -> Result<()> {
    let free = channels.grid().free_count();
    if every > 0 && (count == 0 || count > free) {
        return Err(Error::Invalid {
            name: "goal count".into(),
            reason: format!("{count} goals requested; the grid has {free} free cells"),
        });
    }
    Ok(())
}

impl World {
    /// Adds a field (an occupancy grid with its goal channels) and returns its number, which
    /// `follow_field` behaviours name. Dirty channels are built at the start of the next step.
    ///
    /// # Examples
    /// ```
    /// # fn main() -> throng::Result<()> {
    /// use throng::field::{GoalChannels, Neighbourhood, OccupancyGrid};
    /// use throng::prelude::*;
    /// let grid = OccupancyGrid::parse_ascii("......\n.####.\n......\n", "<map>")?.grid;
    /// let mut channels = GoalChannels::new(grid, 0.9, Neighbourhood::Eight)?;
    /// channels.add_channel(&[(5, 2)])?;
    /// let follow = SteeringProfile::single(Behaviour::FollowField { field: 0, channel: 0 });
    /// let mut world = World::builder()
    ///     .bounds(Bounds::bounded(6.0, 3.0)?)
    ///     .group(Profile { max_speed: 3.0, ..Profile::kinematic(follow) })
    ///     .agent(AgentInit::at(Vec2::new(0.5, 0.5), 0))
    ///     .build()?;
    /// world.add_field(channels)?;
    /// for _ in 0..200 {
    ///     world.step(1.0 / 30.0)?;
    /// }
    /// assert!(world.has_arrived(AgentId(0)));
    /// # Ok(()) }
    /// ```
    ///
    /// # Errors
    /// [`Error::Invalid`] when an agent already stands inside one of the grid's walls.
    pub fn add_field(&mut self, channels: GoalChannels) -> Result<usize> {
        let grid = channels.grid();
        if let Some(i) = (0..self.agents.len()).find(|&i| in_wall(grid, self.agents.position(i))) {
            return Err(Error::Invalid {
                name: "field".into(),
                reason: format!(
                    "agent {} stands inside a wall of the field's grid",
                    self.agents.ids[i]
                ),
            });
        }
        let bits = wall_bits(grid);
        self.plans_stale = true;
        let reroute_every = if channels.metric() == FlowMetric::Quickest {
            DEFAULT_REROUTE_EVERY
        } else {
            0
        };
        self.fields.fields.push(WorldField {
            channels,
            shuffle_every: 0,
            shuffle_count: 0,
            reroute_every,
            density_radius: DEFAULT_DENSITY_RADIUS,
            congestion: Default::default(),
            walkers: Vec::new(),
            wall_bits: bits,
        });
        Ok(self.fields.fields.len() - 1)
    }

    /// Number of fields.
    #[must_use]
    pub fn field_count(&self) -> usize {
        self.fields.fields.len()
    }

    /// The goal channels of `field` (with their potential and flow fields once built).
    #[must_use]
    pub fn field(&self, field: usize) -> Option<&GoalChannels> {
        self.fields.fields.get(field).map(|f| &f.channels)
    }

    /// Moves the goals of one channel; the channel is rebuilt at the start of the next step and
    /// its followers' arrival flags are reset then.
    ///
    /// # Errors
    /// [`Error::Invalid`] for an unknown field or channel, or bad goals (see
    /// [`GoalChannels::set_goals`]).
    pub fn set_field_goals(
        &mut self,
        field: usize,
        channel: usize,
        goals: &[(u32, u32)],
    ) -> Result<()> {
        self.fields
            .get_mut(field)?
            .channels
            .set_goals(channel, goals)
    }

    /// Re-randomises the goals of one channel: `n` distinct free cells drawn with `seed`.
    ///
    /// # Errors
    /// As [`GoalChannels::randomize_goals`], and for an unknown field.
    pub fn randomize_field_goals(
        &mut self,
        field: usize,
        channel: usize,
        n: usize,
        seed: u64,
    ) -> Result<()> {
        self.fields
            .get_mut(field)?
            .channels
            .randomize_goals(channel, n, seed)
    }

    /// Re-randomises every channel's goals of `field` to `count` free cells each, every `every`
    /// frames (the classic demo's click; 0 turns it off). The draws derive from the world seed, the
    /// frame and the channel.
    ///
    /// # Errors
    /// [`Error::Invalid`] for an unknown field, `count == 0` with `every > 0`, or a `count`
    /// larger than the grid's free cells.
    pub fn shuffle_field_goals_every(
        &mut self,
        field: usize,
        every: u64,
        count: usize,
    ) -> Result<()> {
        let f = self.fields.get_mut(field)?;
        check_shuffle(&f.channels, every, count)?;
        f.shuffle_every = every;
        f.shuffle_count = count;
        Ok(())
    }

    /// Sets how a field of the [`FlowMetric::Quickest`] metric follows the crowd: every `every`
    /// frames (counted from frame 0; 0 turns it off, the costs then stay as they are) the cell
    /// costs are set from the density of all agents in a square of half-side `radius` (world
    /// units, taken as metres, at least one cell) around each cell and the channels are rebuilt
    /// with them at once. The arrival flags are kept: the goals have not moved. A field added
    /// with that metric starts with every 50 frames and a radius of 0.5 (a window of about 1 m^2).
    ///
    /// # Errors
    /// [`Error::Invalid`] for an unknown field or one of another metric; [`Error::NonFinite`] or
    /// [`Error::OutOfRange`] for a radius outside `(0, 64]` cells or `every` beyond
    /// [`MAX_REROUTE_EVERY`](crate::limits::MAX_REROUTE_EVERY).
    pub fn set_field_rerouting(&mut self, field: usize, every: u64, radius: f32) -> Result<()> {
        let f = self.fields.get_mut(field)?;
        check_rerouting(&f.channels, every, radius)?;
        f.reroute_every = every;
        f.density_radius = radius;
        Ok(())
    }

    /// Makes cell `(x, y)` of `field` a wall or free ground; the field's channels are rebuilt
    /// at the start of the next step.
    ///
    /// # Errors
    /// [`Error::Invalid`] for an unknown field, a cell outside the grid, a goal cell becoming a
    /// wall, or a cell that an agent or walker stands on becoming a wall.
    pub fn set_field_blocked(&mut self, field: usize, x: u32, y: u32, blocked: bool) -> Result<()> {
        let f = self.fields.get_mut(field)?;
        f.channels.grid().check_cell("cell", x, y)?;
        if blocked {
            let grid = f.channels.grid();
            let taken = (0..self.agents.len())
                .find(|&i| cell_of(grid, self.agents.position(i)) == Some((x as usize, y as usize)))
                .map(|i| self.agents.ids[i]);
            let walker = f.walkers.iter().any(|w| w.walkers.occupant(x, y).is_some());
            if let Some(id) = taken {
                return Err(Error::Invalid {
                    name: "cell".into(),
                    reason: format!("agent {id} stands on ({x}, {y})"),
                });
            }
            if walker {
                return Err(Error::Invalid {
                    name: "cell".into(),
                    reason: format!("a walker stands on ({x}, {y})"),
                });
            }
        }
        let f = self.fields.get_mut(field)?;
        f.channels.set_blocked(x, y, blocked)?;
        let i = y as usize * f.channels.grid().width() as usize + x as usize;
        if blocked {
            f.wall_bits[i / 64] |= 1 << (i % 64);
        } else {
            f.wall_bits[i / 64] &= !(1 << (i % 64));
        }
        Ok(())
    }

    /// Turns the agents of `group` into grid walkers on `field` following `channel` (the discrete
    /// climb to the best free neighbour cell): each is moved to the centre of its cell (or, when another walker has
    /// that cell, of the next free cell in row-major order), and from then on every step moves it
    /// at most one cell, by [`GridWalkers`] with `policy`, overriding its own steering. Returns
    /// the number of walkers. Agents added to the group later are not walkers.
    ///
    /// # Errors
    /// [`Error::Invalid`] for an unknown field or channel, an agent outside the grid or on a
    /// wall, or more walkers than free cells; [`Error::UnknownGroup`].
    pub fn add_walkers(
        &mut self,
        field: usize,
        group: usize,
        channel: usize,
        policy: WalkPolicy,
    ) -> Result<usize> {
        if group >= self.groups.len() {
            return Err(Error::UnknownGroup {
                group,
                count: self.groups.len(),
            });
        }
        let f = self.fields.get_mut(field)?;
        f.channels.goals(channel)?;
        let mut ids: Vec<AgentId> = (0..self.agents.len())
            .filter(|&i| self.agents.group[i] as usize == group)
            .map(|i| self.agents.ids[i])
            .collect();
        ids.sort_unstable();
        let grid = f.channels.grid();
        let (w, len) = (grid.width() as usize, grid.len());
        let mut taken = vec![false; len];
        for wg in &f.walkers {
            for k in 0..wg.walkers.len() {
                if !wg.walkers.is_arrived(k) {
                    let (x, y) = wg.walkers.position(k);
                    taken[y as usize * w + x as usize] = true;
                }
            }
        }
        let mut starts = Vec::with_capacity(ids.len());
        for &id in &ids {
            let i = self.agents.index_of(id).expect("live agent");
            let p = self.agents.position(i);
            let Some((x, y)) = cell_of(grid, p) else {
                return Err(Error::Invalid {
                    name: "walker".into(),
                    reason: format!("agent {id} at {p} lies outside the field's grid"),
                });
            };
            if !grid.cells()[y * w + x].is_free() {
                return Err(Error::Invalid {
                    name: "walker".into(),
                    reason: format!("agent {id} stands inside a wall"),
                });
            }
            let start = y * w + x;
            let Some(k) = (0..len)
                .map(|k| (start + k) % len)
                .find(|&k| grid.cells()[k].is_free() && !taken[k])
            else {
                return Err(Error::Invalid {
                    name: "walker".into(),
                    reason: "more walkers than free cells".into(),
                });
            };
            taken[k] = true;
            starts.push(((k % w) as u32, (k / w) as u32));
        }
        let walkers = GridWalkers::with_channels(grid, &starts, &vec![channel as u32; ids.len()])?;
        for (&id, &(x, y)) in ids.iter().zip(&starts) {
            let i = self.agents.index_of(id).expect("live agent");
            let c = grid.cell_center(x, y);
            (self.agents.pos_x[i], self.agents.pos_y[i]) = (c.x, c.y);
            (self.agents.vel_x[i], self.agents.vel_y[i]) = (0.0, 0.0);
        }
        let n = ids.len();
        f.walkers.push(WalkerGroup {
            walkers,
            ids,
            policy,
        });
        Ok(n)
    }

    /// The `k`-th walker group of `field` (in [`World::add_walkers`] order).
    #[must_use]
    pub fn walkers(&self, field: usize, k: usize) -> Option<&GridWalkers> {
        self.fields
            .fields
            .get(field)?
            .walkers
            .get(k)
            .map(|w| &w.walkers)
    }

    /// Whether agent `id` has reached a goal of the channel it follows (`follow_field` or a
    /// walker) since that channel was last rebuilt.
    #[must_use]
    pub fn has_arrived(&self, id: AgentId) -> bool {
        self.fields.arrived_of(id)
    }

    /// The channel agent `id` has chosen by `choose_exit` (see
    /// [`Behaviour::ChooseExit`](crate::steering::Behaviour::ChooseExit)), or `None` when it
    /// has not chosen (its group does not choose, or it has not steered yet).
    #[must_use]
    pub fn chosen_channel(&self, id: AgentId) -> Option<usize> {
        self.fields.chosen_of(id)
    }

    /// Number of live agents that have arrived (see [`World::has_arrived`]).
    #[must_use]
    pub fn arrived_count(&self) -> usize {
        self.agents
            .ids
            .iter()
            .filter(|&&id| self.fields.arrived_of(id))
            .count()
    }

    /// Channel rebuilds done so far, over all fields.
    #[must_use]
    pub fn field_rebuilds(&self) -> u64 {
        self.fields.rebuilds
    }

    /// Whether world point `p` lies inside a wall cell of some field.
    #[must_use]
    pub fn in_field_wall(&self, p: Vec2) -> bool {
        self.fields
            .fields
            .iter()
            .any(|f| in_wall(f.channels.grid(), p))
    }
}
