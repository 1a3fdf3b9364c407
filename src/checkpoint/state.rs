//! The state a checkpoint holds ([`WorldState`]), captured from a world and restored into a new
//! one through the world's own validation.
//!
//! Restoring builds the world part by part with the constructors and checks of the API (bounds,
//! paths, target slots, profiles with their references, obstacles, gravity points, occupancy grids, goal
//! channels, walkers, formation parameters), then checks what only a saved world has: agent ids
//! and storage order, per-agent state, walker and formation membership, dirty flags. Channels
//! that were clean are built at once (the same build as in the running world), those that were
//! dirty are left for the next step's prepare hook, so rebuilds and the arrival resets they cause
//! happen on the same frames as without the checkpoint.

use std::f32::consts::TAU;

use glam::Vec2;
use serde::{Deserialize, Serialize};

use super::invalid;
use crate::agents::{AgentColumns, AgentId, Agents};
use crate::bounds::Bounds;
use crate::error::{Error, Result, finite, finite_vec, non_negative};
use crate::field::{
    Cell, FlowMetric, GoalChannels, GridWalkers, Neighbourhood, OccupancyGrid, WalkPolicy,
    WalkerGroup, WorldField, wall_bits,
};
use crate::gravity::{GravityPoint, Motion};
use crate::group::{Formation, FormationParams, NO_FORMATION, Path};
use crate::obstacles::{Circle, Obstacles, Wall};
use crate::profile::Profile;
use crate::spatial::{IndexKind, SpatialIndex};
use crate::world::World;

/// Everything a step reads that is not derived (see the module docs of [`crate::checkpoint`]).
#[derive(Serialize, Deserialize)]
pub(super) struct WorldState {
    seed: u64,
    frame: u64,
    time: f64,
    bounds: Bounds,
    index: IndexKind,
    reorder_every: u32,
    groups: Vec<Profile>,
    paths: Vec<Path>,
    /// Target slots (absent from files written before slots existed: none).
    #[serde(default)]
    targets: Vec<crate::targets::TargetPoint>,
    /// Exits (absent from files written before exits existed: none).
    #[serde(default)]
    exits: Vec<crate::world::Exit>,
    /// The walkable area, as WKT (absent from files written before walkable areas existed:
    /// none). Its walls are among `walls`.
    #[serde(default)]
    walkable: Option<crate::geometry::Walkable>,
    circles: Vec<Circle>,
    walls: Vec<Wall>,
    gravity: Vec<GravityPoint>,
    ids_issued: u64,
    agents: AgentColumns,
    formations: Vec<FormationState>,
    fields: Vec<FieldState>,
    /// Ids of the agents marked arrived.
    arrived: Vec<u32>,
    /// `(id, channel)` of each agent that has chosen an exit (absent from files written before
    /// exit choice existed: none).
    #[serde(default)]
    chosen: Vec<(u32, u8)>,
    field_rebuilds: u64,
    /// Stages, journeys, queue states and the agents on them (absent from files written before
    /// journeys existed: none).
    #[serde(default)]
    journeys: Option<crate::journey::Journeys>,
    /// `(id, parameters)` of each agent with pedestrian model parameters of its own (absent
    /// from files written before they existed: none).
    #[serde(default)]
    model_params: Vec<(u32, crate::ped::Pedestrian)>,
}

#[derive(Serialize, Deserialize)]
struct FormationState {
    anchor: AgentId,
    params: FormationParams,
    members: Vec<AgentId>,
    slots: Vec<Vec2>,
    dirty: bool,
}

#[derive(Serialize, Deserialize)]
struct FieldState {
    width: u32,
    height: u32,
    cell_size: f32,
    origin: Vec2,
    /// Row-major: true on wall cells.
    walls: Vec<bool>,
    decay: f32,
    neighbourhood: Neighbourhood,
    /// Absent in files written before the metric existed: those followed the steps.
    #[serde(default)]
    metric: FlowMetric,
    /// The cell costs the distance flows are built with (empty for none), and the quickest
    /// metric's reroute period and density window; absent in older files.
    #[serde(default)]
    costs: Vec<f32>,
    #[serde(default)]
    reroute_every: u64,
    #[serde(default = "default_density_radius")]
    density_radius: f32,
    /// The clearance and its cost (`GoalChannels::with_clearance_cost`); absent in older files.
    #[serde(default)]
    clearance_cost: Option<(f32, f32)>,
    /// Per channel: its goals and whether it waits for a rebuild.
    channels: Vec<(Vec<(u32, u32)>, bool)>,
    shuffle_every: u64,
    shuffle_count: u64,
    walkers: Vec<WalkerState>,
}

fn default_density_radius() -> f32 {
    crate::world::fields::DEFAULT_DENSITY_RADIUS
}

#[derive(Serialize, Deserialize)]
struct WalkerState {
    ids: Vec<AgentId>,
    policy: WalkPolicy,
    cells: Vec<(u32, u32)>,
    channels: Vec<u32>,
    arrived: Vec<bool>,
}

/// Prefixes a validation error with the part of the state it concerns.
fn at<T>(part: impl FnOnce() -> String, r: Result<T>) -> Result<T> {
    r.map_err(|e| match e {
        Error::Checkpoint(_) => e,
        other => invalid(part(), other.to_string()),
    })
}

impl WorldState {
    /// The state of `w`.
    pub(super) fn capture(w: &World) -> Self {
        let gm = &w.group_movement;
        WorldState {
            seed: w.seed,
            frame: w.frame,
            time: w.time,
            bounds: w.bounds,
            index: w.index.kind(),
            reorder_every: w.reorder_every,
            groups: w.groups.clone(),
            paths: gm.paths.clone(),
            targets: w.targets.as_slice().to_vec(),
            exits: w.exits.clone(),
            walkable: w.walkable.clone(),
            circles: w.obstacles.circles().to_vec(),
            walls: w.obstacles.walls().to_vec(),
            gravity: w.gravity.points().to_vec(),
            ids_issued: w.agents.ids_issued() as u64,
            agents: w.agents.to_columns(),
            formations: gm
                .formations
                .iter()
                .map(|f| FormationState {
                    anchor: f.anchor,
                    params: f.params.clone(),
                    members: f.members.clone(),
                    slots: f.slots.clone(),
                    dirty: f.dirty,
                })
                .collect(),
            fields: w.fields.fields.iter().map(FieldState::capture).collect(),
            arrived: (0..w.fields.arrived.len() as u32)
                .filter(|&k| w.fields.arrived[k as usize])
                .collect(),
            chosen: (0..w.fields.chosen.len() as u32)
                .filter_map(|k| w.fields.chosen_of(AgentId(k)).map(|c| (k, c as u8)))
                .collect(),
            field_rebuilds: w.fields.rebuilds,
            journeys: (!w.journeys.is_empty()).then(|| w.journeys.clone()),
            model_params: w.model_params.entries(),
        }
    }

    /// A world in this state, every part validated.
    pub(super) fn restore(self) -> Result<World> {
        at(|| "bounds".into(), self.bounds.validate())?;
        let mut w = World::from_parts(Vec::new(), self.bounds, self.seed);
        w.frame = self.frame;
        if !(self.time.is_finite() && self.time >= 0.0) {
            return Err(invalid(
                "time",
                format!("{} is not a simulated time", self.time),
            ));
        }
        w.time = self.time;
        w.index = SpatialIndex::new(self.index);
        w.reorder_every = self.reorder_every;
        // Paths were validated when decoded (`Path` deserialises through `Path::new`).
        for p in self.paths {
            w.add_path(p)?;
        }
        for (k, t) in self.targets.into_iter().enumerate() {
            at(
                || format!("targets[{k}]"),
                w.add_target_point(t).map(|_| ()),
            )?;
        }
        for (g, p) in self.groups.into_iter().enumerate() {
            at(|| format!("groups[{g}]"), w.add_group_before_fields(p))?;
        }
        for (k, e) in self.exits.into_iter().enumerate() {
            at(|| format!("exits[{k}]"), w.add_exit(e))?;
        }
        w.obstacles = at(
            || "obstacles".into(),
            Obstacles::from_lists(self.circles, self.walls),
        )?;
        // The area was checked when it was decoded; its walls came back with the others.
        w.walkable = self.walkable;
        let issued = usize::try_from(self.ids_issued)
            .ok()
            .filter(|&n| n <= super::MAX_IDS_ISSUED)
            .ok_or_else(|| {
                invalid(
                    "ids_issued",
                    format!(
                        "{} ids, more than the {} a checkpoint may hold",
                        self.ids_issued,
                        super::MAX_IDS_ISSUED
                    ),
                )
            })?;
        for (k, p) in self.gravity.into_iter().enumerate() {
            if let Motion::Agent { agent } = p.motion
                && agent.0 as usize >= issued
            {
                return Err(invalid(
                    format!("gravity[{k}]"),
                    format!("rides on agent {agent}, which was never added"),
                ));
            }
            at(|| format!("gravity[{k}]"), w.gravity.add(p))?;
        }
        w.agents = restore_agents(self.agents, issued, &w)?;
        for (k, f) in self.fields.into_iter().enumerate() {
            let field = at(|| format!("fields[{k}]"), f.restore(issued))?;
            w.fields.fields.push(field);
        }
        let mut arrived = vec![false; issued];
        for id in self.arrived {
            *arrived
                .get_mut(id as usize)
                .ok_or_else(|| invalid("arrived", format!("agent #{id} was never added")))? = true;
        }
        w.fields.arrived = arrived;
        for (id, c) in self.chosen {
            if id as usize >= issued || c >= 64 {
                return Err(invalid(
                    "chosen",
                    format!("agent #{id} and channel {c}: no such agent or channel"),
                ));
            }
            w.fields.choose_for(AgentId(id), usize::from(c), issued);
        }
        w.fields.rebuilds = self.field_rebuilds;
        restore_formations(&mut w, self.formations, issued)?;
        if let Some(j) = self.journeys {
            w.journeys = at(
                || "journeys".into(),
                j.restored(w.walkable.as_ref(), issued),
            )?;
        }
        w.model_params = at(
            || "model_params".into(),
            crate::ped::own::AgentModelParams::from_entries(self.model_params, issued),
        )?;
        // Profiles may name fields and channels: check every reference now, not at the first step.
        w.plans_stale = true;
        at(|| "groups".into(), w.ensure_plans())?;
        Ok(w)
    }
}

/// The agents, each value checked as [`World::add_agent`] and the mutators check it.
fn restore_agents(mut c: AgentColumns, issued: usize, w: &World) -> Result<Agents> {
    let n = c.ids.len();
    if c.desired_speed.is_empty() && n > 0 {
        // Written before pedestrian models: the speeds the agents would have been given.
        c.desired_speed = (0..n)
            .map(|i| {
                let g = c.group.get(i).and_then(|&g| w.groups.get(g as usize));
                g.and_then(|g| g.pedestrian)
                    .map(|p| p.desired_speed)
                    .unwrap_or_default()
                    .draw(w.seed, c.ids[i].0)
            })
            .collect();
    }
    let lens = [
        c.pos_x.len(),
        c.pos_y.len(),
        c.vel_x.len(),
        c.vel_y.len(),
        c.orientation.len(),
        c.rotation.len(),
        c.wander.len(),
        c.group.len(),
        c.max_speed.len(),
        c.radius.len(),
        c.desired_speed.len(),
        c.overrides.len(),
        c.target_x.len(),
        c.target_y.len(),
    ];
    if let Some(len) = lens.iter().find(|&&l| l != n) {
        return Err(invalid(
            "agents",
            format!("{n} ids but a buffer of {len} values"),
        ));
    }
    for i in 0..n {
        let part = || format!("agents[{i}] ({})", c.ids[i]);
        let check = || -> Result<()> {
            w.bounds
                .check_point("position", Vec2::new(c.pos_x[i], c.pos_y[i]))?;
            finite_vec("velocity", Vec2::new(c.vel_x[i], c.vel_y[i]))?;
            let o = finite("orientation", c.orientation[i])?;
            if !(0.0..TAU).contains(&o) {
                return Err(Error::OutOfRange {
                    name: "orientation",
                    value: f64::from(o),
                    range: "[0, 2pi)",
                });
            }
            finite("rotation", c.rotation[i])?;
            finite("wander", c.wander[i])?;
            crate::error::coordinate("target", Vec2::new(c.target_x[i], c.target_y[i]))?;
            crate::world::check_max_speed(c.max_speed[i])?;
            non_negative("radius", c.radius[i])?;
            non_negative("desired_speed", c.desired_speed[i])?;
            crate::error::in_range(
                "desired_speed",
                c.desired_speed[i],
                0.0,
                crate::ped::MAX_DESIRED_SPEED,
                "[0, 100] m/s",
            )?;
            if c.group[i] as usize >= w.groups.len() {
                return Err(Error::UnknownGroup {
                    group: c.group[i] as usize,
                    count: w.groups.len(),
                });
            }
            if c.overrides[i] > 3 {
                return Err(Error::Invalid {
                    name: "overrides".into(),
                    reason: format!("unknown flags {:#x}", c.overrides[i]),
                });
            }
            Ok(())
        };
        at(part, check())?;
    }
    // An agent without a maximum speed of its own carries its group's (the world keeps it so);
    // one whose value differs is marked as having its own, so that the passes which take the
    // group's value while no agent has its own never replace a speed the file gave it.
    for i in 0..n {
        let own = c.overrides[i] & crate::agents::store_flags::OVERRIDE_SPEED != 0;
        if !own && c.max_speed[i] != w.groups[c.group[i] as usize].max_speed {
            c.overrides[i] |= crate::agents::store_flags::OVERRIDE_SPEED;
        }
    }
    Agents::from_columns(c, issued).map_err(|id| {
        invalid(
            "agents",
            format!("id {id} is listed twice or was never issued ({issued} ids issued)"),
        )
    })
}

/// The formations, their parameters checked as [`World::add_formation`] does and their
/// membership as it keeps it (a member is not the anchor and belongs to one formation).
fn restore_formations(w: &mut World, formations: Vec<FormationState>, issued: usize) -> Result<()> {
    let mut owner = vec![NO_FORMATION; issued];
    for (k, f) in formations.into_iter().enumerate() {
        let part = || format!("formations[{k}]");
        at(part, f.params.validate())?;
        let n = f.members.len();
        if n != f.slots.len() {
            return Err(invalid(
                part(),
                format!("{n} members but {} slots", f.slots.len()),
            ));
        }
        if n > f.params.capacity() {
            at(part, f.params.slots(n))?;
        }
        if f.anchor.0 as usize >= issued {
            return Err(invalid(
                part(),
                format!("anchor {} was never added", f.anchor),
            ));
        }
        for (&m, &s) in f.members.iter().zip(&f.slots) {
            at(part, finite_vec("formation slot", s))?;
            let Some(o) = owner.get_mut(m.0 as usize) else {
                return Err(invalid(part(), format!("member {m} was never added")));
            };
            if m == f.anchor || *o != NO_FORMATION {
                return Err(invalid(
                    part(),
                    format!("member {m} is the anchor or belongs to another formation"),
                ));
            }
            *o = k as u32;
            w.group_movement.set_slot(m, (k as u32, s));
        }
        w.group_movement.formations.push(Formation {
            anchor: f.anchor,
            params: f.params,
            members: f.members,
            slots: f.slots,
            dirty: f.dirty,
        });
    }
    Ok(())
}

impl FieldState {
    fn capture(f: &WorldField) -> Self {
        let ch = &f.channels;
        let grid = ch.grid();
        FieldState {
            width: grid.width(),
            height: grid.height(),
            cell_size: grid.cell_size(),
            origin: grid.origin(),
            walls: grid.cells().iter().map(|c| !c.is_free()).collect(),
            decay: ch.decay(),
            neighbourhood: ch.neighbourhood(),
            metric: ch.metric(),
            costs: ch.costs().to_vec(),
            reroute_every: f.reroute_every,
            density_radius: f.density_radius,
            clearance_cost: ch.clearance_cost(),
            channels: (0..ch.len())
                .map(|c| (ch.goals(c).unwrap_or_default().to_vec(), ch.is_dirty(c)))
                .collect(),
            shuffle_every: f.shuffle_every,
            shuffle_count: f.shuffle_count as u64,
            walkers: f
                .walkers
                .iter()
                .map(|wg| {
                    let wk = &wg.walkers;
                    WalkerState {
                        ids: wg.ids.clone(),
                        policy: wg.policy,
                        cells: wk.positions(),
                        channels: (0..wk.len()).map(|i| wk.channel(i)).collect(),
                        arrived: (0..wk.len()).map(|i| wk.is_arrived(i)).collect(),
                    }
                })
                .collect(),
        }
    }

    /// The field, built through the grid's and the channels' constructors.
    fn restore(self, issued: usize) -> Result<WorldField> {
        let cells = self
            .walls
            .iter()
            .map(|&w| if w { Cell::Wall } else { Cell::Free })
            .collect();
        let grid = OccupancyGrid::from_cells(self.width, self.height, cells)?
            .with_geometry(self.cell_size, self.origin)?;
        let mut channels =
            GoalChannels::new(grid, self.decay, self.neighbourhood)?.with_metric(self.metric);
        if let Some((distance, cost)) = self.clearance_cost {
            channels = channels.with_clearance_cost(distance, cost)?;
        }
        channels.set_costs(&self.costs)?;
        if self.reroute_every > 0 || self.metric == FlowMetric::Quickest {
            crate::world::fields::check_rerouting(
                &channels,
                self.reroute_every,
                self.density_radius,
            )?;
        }
        for (goals, _) in &self.channels {
            channels.add_channel(goals)?;
        }
        // Clean channels are built now, as the running world built them; dirty ones wait.
        channels.rebuild_dirty()?;
        for (c, (_, dirty)) in self.channels.iter().enumerate() {
            if *dirty {
                channels.mark_dirty(c);
            }
        }
        let count = usize::try_from(self.shuffle_count).unwrap_or(usize::MAX);
        crate::world::fields::check_shuffle(&channels, self.shuffle_every, count)?;
        let mut walkers = Vec::with_capacity(self.walkers.len());
        for (k, ws) in self.walkers.into_iter().enumerate() {
            let bad = |reason: String| Error::Invalid {
                name: format!("walkers[{k}]"),
                reason,
            };
            if ws.ids.len() != ws.cells.len() || ws.channels.len() != ws.cells.len() {
                return Err(bad(format!(
                    "{} ids, {} cells and {} channels",
                    ws.ids.len(),
                    ws.cells.len(),
                    ws.channels.len()
                )));
            }
            if let Some(id) = ws.ids.iter().find(|id| id.0 as usize >= issued) {
                return Err(bad(format!("agent {id} was never added")));
            }
            if let Some(c) = ws.channels.iter().find(|&&c| c as usize >= channels.len()) {
                return Err(bad(format!("channel {c} does not exist")));
            }
            let gw = GridWalkers::restore(channels.grid(), &ws.cells, &ws.channels, &ws.arrived)?;
            walkers.push(WalkerGroup {
                walkers: gw,
                ids: ws.ids,
                policy: ws.policy,
            });
        }
        let bits = wall_bits(channels.grid());
        Ok(WorldField {
            channels,
            shuffle_every: self.shuffle_every,
            shuffle_count: count,
            reroute_every: self.reroute_every,
            density_radius: self.density_radius,
            congestion: Default::default(),
            walkers,
            wall_bits: bits,
        })
    }
}
