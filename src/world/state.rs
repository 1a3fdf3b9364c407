//! The [`World`] itself: the agents, their groups, the obstacles, targets, gravity points and
//! fields a step reads, and the methods that read and change them between steps.
//!
//! Invariant: every mutator validates its input before it changes anything, so nothing invalid
//! reaches the buffers and a refused call leaves the world as it was.

use glam::Vec2;

use super::Profile;
use super::scratch::Scratch;
use crate::agents::{AgentId, AgentInit, Agents};
use crate::bounds::Bounds;
use crate::error::{Error, Result, finite, finite_vec, non_negative, positive};
use crate::gravity::{GravityField, GravityPoint, Motion};
use crate::movement::wrap_orientation;
use crate::obstacles::{Circle, Obstacles, Wall};
use crate::rng::{AgentRng, Stream};
use crate::spatial::{IndexKind, SpatialIndex};

/// Default reordering period, frames.
pub const DEFAULT_REORDER_EVERY: u32 = 4;

/// Checks an agent's own maximum speed: finite, greater than zero, at most
/// [`crate::error::MAX_SPEED`].
pub(crate) fn check_max_speed(s: f32) -> Result<f32> {
    crate::error::in_range(
        "max_speed",
        positive("max_speed", s)?,
        0.0,
        crate::error::MAX_SPEED,
        "(0, 1e12]",
    )
}

/// A snapshot of one agent's state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AgentState {
    /// The agent's id.
    pub id: AgentId,
    /// Position.
    pub position: Vec2,
    /// Velocity.
    pub velocity: Vec2,
    /// Orientation, radians in `[0, 2pi)`.
    pub orientation: f32,
    /// Rotation, radians per second.
    pub rotation: f32,
    /// Group index.
    pub group: usize,
}

/// A simulated world: agents, their groups, bounds, and the step pipeline.
#[derive(Debug)]
pub struct World {
    pub(crate) agents: Agents,
    pub(crate) groups: Vec<Profile>,
    pub(crate) bounds: Bounds,
    pub(crate) seed: u64,
    pub(crate) frame: u64,
    pub(crate) time: f64,
    pub(crate) scratch: Scratch,
    pub(crate) index: SpatialIndex,
    /// Reorder agents by grid cell every this many frames (0: never).
    pub(crate) reorder_every: u32,
    /// Whether steps keep the pool's other workers awake ([`World::set_workers_awake`]).
    pub(crate) workers_awake: bool,
    pub(crate) obstacles: Obstacles,
    pub(crate) gravity: GravityField,
    /// Paths and formations (group movement).
    pub(crate) group_movement: crate::group::GroupMovement,
    /// Goal fields, walls and grid walkers.
    pub(crate) fields: crate::field::FieldSet,
    /// One compiled plan per group, current unless `plans_stale`.
    pub(crate) plans: Vec<crate::plans::Plan>,
    /// Set when a group, field or path changed: plans are compiled again before the next step.
    pub(crate) plans_stale: bool,
    /// Per group, the name of the plan the latest step ran ([`World::last_plans`]; not part of
    /// a checkpoint).
    pub(crate) last_plans: Vec<&'static str>,
    /// Shared target slots behaviours refer to.
    pub(crate) targets: crate::targets::TargetSlots,
    /// Rectangles and polygons through which agents leave the world.
    pub(crate) exits: Vec<super::Exit>,
    /// The agents that left through an exit in the latest step (not part of a checkpoint).
    pub(crate) departures: Vec<super::Departure>,
    /// The walkable area whose walls were added (`World::set_walkable`), if any.
    pub(crate) walkable: Option<crate::geometry::Walkable>,
    /// Stages, journeys and the agents on them.
    pub(crate) journeys: crate::journey::Journeys,
    /// Pedestrian model parameters of single agents ([`World::set_agent_model_params`]).
    pub(crate) model_params: crate::ped::own::AgentModelParams,
}

impl World {
    pub(crate) fn from_parts(groups: Vec<Profile>, bounds: Bounds, seed: u64) -> Self {
        World {
            agents: Agents::new(),
            groups,
            bounds,
            seed,
            frame: 0,
            time: 0.0,
            scratch: Scratch::default(),
            index: SpatialIndex::new(IndexKind::Grid),
            reorder_every: DEFAULT_REORDER_EVERY,
            workers_awake: false,
            obstacles: Obstacles::new(),
            gravity: GravityField::default(),
            group_movement: Default::default(),
            fields: Default::default(),
            plans: Vec::new(),
            plans_stale: true,
            last_plans: Vec::new(),
            targets: Default::default(),
            exits: Vec::new(),
            departures: Vec::new(),
            walkable: None,
            journeys: Default::default(),
            model_params: Default::default(),
        }
    }

    /// Per group, in group order, the name of the plan by which the latest step evaluated the
    /// group's steering: `"general"` for the general loop over the profile's behaviours, else
    /// the fast plan's (`"flock"`, `"seek"`, `"wander"`, ...); empty before the first step.
    /// For tests that compare a fast plan with the general one and must know which one ran; the
    /// names are no stable interface.
    #[doc(hidden)]
    #[must_use]
    pub fn last_plans(&self) -> &[&'static str] {
        &self.last_plans
    }

    /// Per group, in group order, whether the latest step took the group's neighbour sums
    /// (flocking terms, or repulsion) from the cell batch rather than from each agent's own
    /// neighbour query; empty before the first step. For tests that must know which path summed
    /// the neighbours; no stable interface.
    #[doc(hidden)]
    #[must_use]
    pub fn last_summed(&self) -> &[bool] {
        &self.scratch.pass.summed
    }

    /// The world's obstacles.
    #[must_use]
    pub fn obstacles(&self) -> &Obstacles {
        &self.obstacles
    }

    /// A [`Spawner`](crate::spawn::Spawner) drawing from `seed` that places no point inside
    /// this world's circles or within `clearance` of their edges (for agents of radius
    /// `clearance`): [`Spawner::avoiding`](crate::spawn::Spawner::avoiding) with the world's
    /// own obstacles, so that they are not repeated for the spawn.
    ///
    /// # Examples
    /// ```
    /// use throng::prelude::*;
    ///
    /// # fn main() -> throng::Result<()> {
    /// let mut world = World::builder()
    ///     .bounds(Bounds::bounded(100.0, 100.0)?)
    ///     .circle(Circle::new(Vec2::splat(50.0), 10.0))
    ///     .group(Profile::dynamic(SteeringProfile::default()))
    ///     .build()?;
    /// let start = world.spawner(3, 0.5).disc(200, Vec2::splat(50.0), 30.0)?;
    /// for a in agents(&start, 0, 0.0, 3) {
    ///     world.add_agent(a)?;
    /// }
    /// assert_eq!(world.len(), 200);
    /// # Ok(())
    /// # }
    /// ```
    #[must_use]
    pub fn spawner(&self, seed: u64, clearance: f32) -> crate::spawn::Spawner<'_> {
        crate::spawn::Spawner::new(seed).avoiding(&self.obstacles, clearance)
    }

    /// Adds a circular obstacle.
    ///
    /// # Errors
    /// As [`Obstacles::add_circle`], or [`Error::Invalid`] when an agent's centre lies inside it.
    pub fn add_circle(&mut self, circle: Circle) -> Result<()> {
        self.add_circles(&[circle])
    }

    /// Adds many circles at once, building the obstacle broad phase once; nothing is added
    /// when one is bad.
    ///
    /// # Errors
    /// As [`Obstacles::add_circles`], or [`Error::Invalid`] when an agent's centre lies inside
    /// one of them.
    pub fn add_circles(&mut self, circles: &[Circle]) -> Result<()> {
        let mut test = Obstacles::new();
        test.add_circles(circles)?;
        if let Some(i) =
            (0..self.agents.len()).find(|&i| test.inside_circle(self.agents.position(i)))
        {
            return Err(Error::Invalid {
                name: "circle".into(),
                reason: format!("agent {} stands inside it", self.agents.id(i)),
            });
        }
        self.obstacles.add_circles(circles)
    }

    /// Adds a wall (a segment agents cannot cross).
    ///
    /// # Errors
    /// As [`Obstacles::add_wall`].
    pub fn add_wall(&mut self, wall: Wall) -> Result<()> {
        self.obstacles.add_wall(wall)
    }

    /// Adds the walls of a polyline, closed into a polygon when `closed`.
    ///
    /// # Errors
    /// As [`Obstacles::add_polygon`].
    pub fn add_polygon(&mut self, points: &[Vec2], closed: bool) -> Result<()> {
        self.obstacles.add_polygon(points, closed)
    }

    /// The world's gravity points.
    #[must_use]
    pub fn gravity(&self) -> &GravityField {
        &self.gravity
    }

    /// Adds a gravity point; returns its index.
    ///
    /// # Errors
    /// As [`GravityPoint::validate`]; [`Error::UnknownAgent`] for a point riding on an unknown agent.
    pub fn add_gravity_point(&mut self, point: GravityPoint) -> Result<usize> {
        if let Motion::Agent { agent } = point.motion {
            self.index(agent)?;
        }
        self.gravity.add(point)
    }

    /// Moves gravity point `k`.
    ///
    /// # Errors
    /// [`Error::Invalid`] for an unknown point, [`Error::NonFinite`] for a bad position.
    pub fn set_gravity_position(&mut self, k: usize, position: Vec2) -> Result<()> {
        self.gravity.set_position(k, position)
    }

    /// The neighbour-index backend in use.
    #[must_use]
    pub fn index_kind(&self) -> IndexKind {
        self.index.kind()
    }

    /// Chooses the neighbour-index backend (the grid by default). Flocking sums agree across
    /// backends to rounding.
    pub fn set_index(&mut self, kind: IndexKind) {
        if self.index.kind() != kind {
            self.index = SpatialIndex::new(kind);
        }
    }

    /// How often (in frames) agents are reordered by grid cell for cache locality; 0 never.
    #[must_use]
    pub fn reorder_every(&self) -> u32 {
        self.reorder_every
    }

    /// Sets how often agents are reordered by grid cell (0: never). Ids are unaffected; only the
    /// storage order changes.
    pub fn set_reorder_every(&mut self, frames: u32) {
        self.reorder_every = frames;
    }

    /// Whether [`World::step`] keeps the pool's other workers awake through steps of 4,096 to
    /// 65,535 agents.
    #[must_use]
    pub fn workers_awake(&self) -> bool {
        self.workers_awake
    }

    /// Makes [`World::step`] keep the rayon pool's other workers awake until each step of
    /// 4,096 to 65,535 agents returns, as OpenMP's workers wait between parallel regions,
    /// instead of letting them sleep between the step's short loops (whose wake-ups a
    /// 10,000-agent step otherwise waits for, a varying time). Off by default: the waiting
    /// workers occupy their cores through the step, which other processes or pools sharing
    /// those cores then miss. Results are the same either way; only timings change. Not
    /// saved in checkpoints (a setting of the run, like its thread count).
    pub fn set_workers_awake(&mut self, on: bool) {
        self.workers_awake = on;
    }

    /// The agents, in storage order.
    #[must_use]
    pub fn agents(&self) -> &Agents {
        &self.agents
    }

    /// Number of live agents.
    #[must_use]
    pub fn len(&self) -> usize {
        self.agents.len()
    }

    /// Whether the world has no agents.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.agents.is_empty()
    }

    /// The groups' profiles.
    #[must_use]
    pub fn groups(&self) -> &[Profile] {
        &self.groups
    }

    /// The world's bounds.
    #[must_use]
    pub fn bounds(&self) -> Bounds {
        self.bounds
    }

    /// The rectangle `(min, max)` the world occupies: the bounds' rectangle, or for an open
    /// world the box around agents, obstacles, gravity points, paths and the first field, grown
    /// by 5% of its larger side (at least 1); `(-1, -1)..(1, 1)` for an empty open world.
    /// Pictures show it and trajectory files take it as the walkable area's outline.
    #[must_use]
    pub fn extent(&self) -> (Vec2, Vec2) {
        if let Some(size) = self.bounds.size() {
            return (Vec2::ZERO, size);
        }
        let mut lo = Vec2::splat(f32::INFINITY);
        let mut hi = Vec2::splat(f32::NEG_INFINITY);
        let mut add = |p: Vec2| {
            lo = lo.min(p);
            hi = hi.max(p);
        };
        let a = self.agents();
        for i in 0..a.len() {
            add(a.position(i));
        }
        for c in self.obstacles().circles() {
            add(c.center - c.radius);
            add(c.center + c.radius);
        }
        for w in self.obstacles().walls() {
            add(w.a);
            add(w.b);
        }
        for p in self.gravity().points() {
            add(p.position);
        }
        for path in self.paths() {
            for &p in path.points() {
                add(p);
            }
        }
        if let Some(f) = self.field(0) {
            let g = f.grid();
            add(g.origin());
            add(g.origin() + Vec2::new(g.width() as f32, g.height() as f32) * g.cell_size());
        }
        if !lo.is_finite() || !hi.is_finite() {
            return (Vec2::splat(-1.0), Vec2::splat(1.0));
        }
        let margin = ((hi - lo).max_element() * 0.05).max(1.0);
        (lo - margin, hi + margin)
    }

    /// The seed all randomness derives from.
    #[must_use]
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// Frames stepped so far.
    #[must_use]
    pub fn frame(&self) -> u64 {
        self.frame
    }

    /// Simulated seconds so far.
    #[must_use]
    pub fn time(&self) -> f64 {
        self.time
    }

    /// The order parameter of the velocities: the length of the mean unit velocity, 1 when every
    /// agent moves the same way, about `1 / sqrt(N)` for independent random headings (agents at
    /// rest are left out; 0 for none). See [`crate::steering::polarisation`].
    #[must_use]
    pub fn polarisation(&self) -> f32 {
        crate::steering::polarisation(&self.agents.vel_x, &self.agents.vel_y)
    }

    /// The state of agent `id`, if it is alive.
    #[must_use]
    pub fn agent(&self, id: AgentId) -> Option<AgentState> {
        let i = self.agents.index_of(id)?;
        Some(AgentState {
            id,
            position: self.agents.position(i),
            velocity: self.agents.velocity(i),
            orientation: self.agents.orientation[i],
            rotation: self.agents.rotation[i],
            group: self.agents.group[i] as usize,
        })
    }

    fn index(&self, id: AgentId) -> Result<usize> {
        self.agents.index_of(id).ok_or(Error::UnknownAgent { id })
    }

    fn check_group(&self, group: usize) -> Result<()> {
        if group < self.groups.len() {
            Ok(())
        } else {
            Err(Error::UnknownGroup {
                group,
                count: self.groups.len(),
            })
        }
    }

    /// Adds a group and returns its index.
    ///
    /// The fields, channels, paths and target slots that `params` names must exist when the
    /// group is added (add a field with [`World::add_field`] before the groups that follow it).
    /// A group it names may be added after it, as a scenario's groups may name each other; the
    /// first step refuses one that is still missing. [`World::check_group_params`] refuses that
    /// too, at once.
    ///
    /// # Errors
    /// The variant naming the first bad parameter of `params`; [`Error::UnknownField`] for a
    /// field or channel the world does not have, [`Error::UnknownPath`] and
    /// [`Error::UnknownTarget`] for a path or target slot. Nothing is added then.
    pub fn add_group(&mut self, params: Profile) -> Result<usize> {
        params.validate()?;
        self.check_group_refs(&params)?;
        self.check_group_fields(&params)?;
        Ok(self.push_group(params))
    }

    /// Adds a group whose values and paths and target slots are checked, leaving the fields
    /// it names to the plans' compile: a checkpoint restores its fields after its groups and
    /// compiles every plan at the end.
    pub(crate) fn add_group_before_fields(&mut self, params: Profile) -> Result<usize> {
        params.validate()?;
        self.check_group_refs(&params)?;
        Ok(self.push_group(params))
    }

    fn push_group(&mut self, params: Profile) -> usize {
        self.groups.push(params);
        self.plans_stale = true;
        self.groups.len() - 1
    }

    /// Replaces a group's profile. Agents without their own maximum speed or radius take the new
    /// values (and have their velocities truncated to the new maximum speed).
    ///
    /// # Errors
    /// [`Error::UnknownGroup`], or the variant naming the first bad parameter of `params`;
    /// [`Error::UnknownField`] (and the like) for a field, channel, group, path or target slot
    /// that `params` names and the world does not have.
    pub fn set_group_params(&mut self, group: usize, params: Profile) -> Result<()> {
        self.check_group(group)?;
        params.validate()?;
        self.check_group_refs(&params)?;
        // The world is built: a field or group the profile names must exist now (a missing one
        // made every later step fail). The plans are compiled as the next step would.
        let old = std::mem::replace(&mut self.groups[group], params);
        self.plans_stale = true;
        if let Err(e) = self.ensure_plans() {
            self.groups[group] = old;
            return Err(e);
        }
        let (max_speed, radius) = (self.groups[group].max_speed, self.groups[group].radius);
        for i in 0..self.agents.len() {
            if self.agents.group[i] as usize == group {
                let o = self.agents.overrides[i];
                if o & crate::agents::store_flags::OVERRIDE_SPEED == 0 {
                    self.agents.max_speed[i] = max_speed;
                    self.clamp_velocity(i);
                }
                if o & crate::agents::store_flags::OVERRIDE_RADIUS == 0 {
                    self.agents.radius[i] = radius;
                }
            }
        }
        Ok(())
    }

    /// Reserves room for `additional` more agents in every agent buffer, as an error instead
    /// of an abort when the memory is not there.
    ///
    /// # Errors
    /// [`Error::OutOfMemory`].
    pub fn try_reserve_agents(&mut self, additional: usize) -> Result<()> {
        self.agents.try_reserve(additional)
    }

    /// Adds an agent and returns its id.
    ///
    /// # Errors
    /// [`Error::UnknownGroup`], [`Error::NonFinite`] for a NaN or infinite number, an error for a
    /// position outside the world, [`Error::NotPositive`] / [`Error::Negative`] for a bad maximum
    /// speed or radius override.
    pub fn add_agent(&mut self, init: AgentInit) -> Result<AgentId> {
        self.check_group(init.group)?;
        self.bounds.check_point("position", init.position)?;
        if self.obstacles.inside_circle(init.position) {
            return Err(Error::Invalid {
                name: "position".into(),
                reason: format!(
                    "agent {} at ({}, {}) lies inside an obstacle",
                    AgentId(self.agents.ids_issued() as u32),
                    init.position.x,
                    init.position.y
                ),
            });
        }
        finite_vec("velocity", init.velocity)?;
        finite("orientation", init.orientation)?;
        finite("rotation", init.rotation)?;
        let g = &self.groups[init.group];
        let max_speed = match init.max_speed {
            Some(s) => check_max_speed(s)?,
            None => g.max_speed,
        };
        let radius = match init.radius {
            Some(r) => non_negative("radius", r)?,
            None => g.radius,
        };
        // No agent is faster than its maximum speed, whatever it starts with: the integrator and
        // the contact guard count on it.
        let init = AgentInit {
            orientation: wrap_orientation(init.orientation),
            velocity: crate::steering::truncate(init.velocity, max_speed),
            ..init
        };
        // The initial wander angle is random but keyed by the id the agent will get.
        let next_id = self.agents.ids_issued() as u32;
        let wander = AgentRng::new(self.seed, next_id, 0, Stream::Spawn as u32).signed()
            * std::f32::consts::PI;
        let desired_speed = match init.desired_speed {
            Some(v) => {
                crate::error::non_negative("desired_speed", v)?;
                crate::error::in_range(
                    "desired_speed",
                    v,
                    0.0,
                    crate::ped::MAX_DESIRED_SPEED,
                    "[0, 100] m/s",
                )?
            }
            None => g
                .pedestrian
                .map(|p| p.desired_speed)
                .unwrap_or_default()
                .draw(self.seed, next_id),
        };
        Ok(self
            .agents
            .push(&init, max_speed, radius, wander, desired_speed))
    }

    /// Removes an agent. Other agents keep their ids.
    ///
    /// # Errors
    /// [`Error::UnknownAgent`] when `id` names no live agent.
    pub fn remove_agent(&mut self, id: AgentId) -> Result<()> {
        let i = self.index(id)?;
        self.agents.swap_remove(i);
        Ok(())
    }

    /// Sets an agent's own target point (used by behaviours whose target is
    /// [`crate::steering::Target::Own`]).
    ///
    /// # Errors
    /// [`Error::UnknownAgent`], [`Error::NonFinite`], or [`Error::OutOfRange`] for a coordinate
    /// beyond 1e18 ([`crate::error::coordinate`]).
    pub fn set_target(&mut self, id: AgentId, target: Vec2) -> Result<()> {
        crate::error::coordinate("target", target)?;
        let i = self.index(id)?;
        self.agents.target_x[i] = target.x;
        self.agents.target_y[i] = target.y;
        Ok(())
    }

    /// Moves an agent.
    ///
    /// # Errors
    /// [`Error::UnknownAgent`], [`Error::NonFinite`], or an error for a point outside the world.
    pub fn set_position(&mut self, id: AgentId, position: Vec2) -> Result<()> {
        self.bounds.check_point("position", position)?;
        if self.obstacles.inside_circle(position) {
            return Err(Error::Invalid {
                name: "position".into(),
                reason: format!("({}, {}) lies inside an obstacle", position.x, position.y),
            });
        }
        let i = self.index(id)?;
        self.agents.pos_x[i] = position.x;
        self.agents.pos_y[i] = position.y;
        Ok(())
    }

    /// Sets an agent's velocity (clamped to its maximum speed).
    ///
    /// # Errors
    /// [`Error::UnknownAgent`], [`Error::NonFinite`].
    pub fn set_velocity(&mut self, id: AgentId, velocity: Vec2) -> Result<()> {
        finite_vec("velocity", velocity)?;
        let i = self.index(id)?;
        let v = crate::steering::truncate(velocity, self.agents.max_speed[i]);
        self.agents.vel_x[i] = v.x;
        self.agents.vel_y[i] = v.y;
        Ok(())
    }

    /// Sets an agent's own maximum speed (its velocity is truncated to it).
    ///
    /// # Errors
    /// [`Error::UnknownAgent`], [`Error::NotPositive`], [`Error::NonFinite`].
    pub fn set_max_speed(&mut self, id: AgentId, max_speed: f32) -> Result<()> {
        check_max_speed(max_speed)?;
        let i = self.index(id)?;
        self.agents.set_own_max_speed(i, max_speed);
        self.clamp_velocity(i);
        Ok(())
    }

    /// Sets an agent's desired walking speed under a pedestrian model ([`crate::ped`]).
    ///
    /// # Errors
    /// [`Error::UnknownAgent`], [`Error::NonFinite`], or [`Error::OutOfRange`] outside
    /// `[0, 100]` m/s.
    pub fn set_desired_speed(&mut self, id: AgentId, speed: f32) -> Result<()> {
        crate::error::finite("desired_speed", speed)?;
        crate::error::in_range(
            "desired_speed",
            speed,
            0.0,
            crate::ped::MAX_DESIRED_SPEED,
            "[0, 100] m/s",
        )?;
        let i = self.index(id)?;
        self.agents.desired_speed[i] = speed;
        Ok(())
    }

    /// Sets an agent's own radius (its group's radius no longer applies to it).
    ///
    /// # Errors
    /// [`Error::UnknownAgent`], [`Error::NonFinite`] or [`Error::Negative`].
    pub fn set_radius(&mut self, id: AgentId, radius: f32) -> Result<()> {
        non_negative("radius", radius)?;
        let i = self.index(id)?;
        self.agents.radius[i] = radius;
        self.agents.overrides[i] |= crate::agents::store_flags::OVERRIDE_RADIUS;
        Ok(())
    }

    /// Truncates agent `i`'s velocity to its maximum speed.
    fn clamp_velocity(&mut self, i: usize) {
        let a = &mut self.agents;
        let v = crate::steering::truncate(glam::Vec2::new(a.vel_x[i], a.vel_y[i]), a.max_speed[i]);
        a.vel_x[i] = v.x;
        a.vel_y[i] = v.y;
    }
}
