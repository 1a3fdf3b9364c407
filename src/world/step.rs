//! The step pipeline: the phases of one frame, in order, and nothing else.
//!
//! `World::step` only orchestrates. Per-agent steering lives in [`crate::plans`], the integrator
//! in [`crate::movement`], the other per-agent passes of the step (the world's edges, obstacle
//! non-penetration, the arrival count, column copies) in [`crate::passes`]; each subsystem
//! (fields, group movement, obstacles, gravity) owns its per-step state and is called through
//! its prepare hook before steering and its constrain hook after integration.

use std::time::Instant;

use super::state::World;
use super::stats::{PhaseTimes, StepStats};
use crate::bounds::Bounds;
use crate::error::{Error, MAX_DT, Result};
use crate::group;
use crate::movement::{self, MotionState, SteeringBuffers};
use crate::passes;
use crate::plans::{self, Plan, References, SteerView};
use crate::profile::Profile;
use crate::spatial::{NeighbourIndex, SpatialIndex};
use crate::steering::Steering;

/// How a step runs: on the rayon pool, or on the calling thread alone.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Execution {
    Parallel,
    Sequential,
}

impl World {
    /// Advances the world by `dt` seconds on the current rayon thread pool (run it inside
    /// `pool.install` to choose the number of threads). With [`World::set_workers_awake`], the
    /// pool's other workers wait for work awake through steps of a few thousand to some tens of
    /// thousands of agents.
    ///
    /// # Errors
    /// [`Error::InvalidTimeStep`] when `dt` is not a finite number greater than zero; the
    /// reference errors of [`World::set_group_params`] ([`Error::UnknownGroup`], ...) when a
    /// profile names something the world still lacks (a group a profile names that was never
    /// added, a field a builder's group names that was never added). The world is then
    /// unchanged.
    pub fn step(&mut self, dt: f32) -> Result<StepStats> {
        if !(self.workers_awake && super::awake::AWAKE.contains(&self.agents.len())) {
            return self.step_with(dt, Execution::Parallel);
        }
        super::awake::with_awake_workers(|| self.step_with(dt, Execution::Parallel))
    }

    /// The sequential reference step: the same phases and passes as [`World::step`] on one
    /// thread, bit for bit the same results. The per-agent loops run without rayon tasks, and
    /// the step runs in a pool of one thread, so that the few splits below them (the index's
    /// and the hashed grids' rebuilds over many points) run in sequence too. Where that pool
    /// cannot be made (no thread could be started), the step runs on the calling thread.
    ///
    /// # Errors
    /// As [`World::step`].
    pub fn step_sequential(&mut self, dt: f32) -> Result<StepStats> {
        ONE_THREAD.with(|pool| match pool {
            Some(pool) => pool.install(|| self.step_with(dt, Execution::Sequential)),
            None => self.step_with(dt, Execution::Sequential),
        })
    }

    /// The sequential step on the calling thread itself (no pool of one), for this crate's
    /// tests that set thread-local switches of the per-agent loops.
    #[cfg(test)]
    pub(crate) fn step_here(&mut self, dt: f32) -> Result<StepStats> {
        self.step_with(dt, Execution::Sequential)
    }

    /// Compiles the groups' plans when a profile or something profiles refer to changed.
    /// What a group's plan may name: the world's fields and their channels, paths, target slots
    /// and `groups` groups.
    fn references(&self, groups: usize) -> References {
        References {
            channels: self
                .fields
                .fields
                .iter()
                .map(|f| f.channels.len())
                .collect(),
            paths: self.group_movement.paths.len(),
            groups,
            targets: self.targets.len(),
        }
    }

    /// Checks `params` as the profile of a group added to the world as it is now: its values,
    /// and that every field, channel, group, path and target slot it names exists.
    /// [`World::add_group`] checks the same but lets a profile name a group added after it
    /// (the first step refuses one still missing); call this first to refuse that at once too.
    ///
    /// # Errors
    /// As [`World::set_group_params`].
    pub fn check_group_params(&self, params: &Profile) -> Result<()> {
        params.validate()?;
        self.check_group_refs(params)?;
        let group = self.groups.len();
        Plan::compile(params, group, &self.references(group + 1)).map(|_| ())
    }

    /// Checks that every field and channel `params` names exists, as the profile of the next
    /// group; the groups it names may come later.
    pub(super) fn check_group_fields(&self, params: &Profile) -> Result<()> {
        let group = self.groups.len();
        let refs = References {
            groups: usize::MAX,
            ..self.references(group + 1)
        };
        Plan::compile(params, group, &refs).map(|_| ())
    }

    pub(crate) fn ensure_plans(&mut self) -> Result<()> {
        if !self.plans_stale {
            return Ok(());
        }
        let refs = self.references(self.groups.len());
        let plans = self
            .groups
            .iter()
            .enumerate()
            .map(|(g, p)| Plan::compile(p, g, &refs))
            .collect::<Result<Vec<_>>>()?;
        self.fields.set_follow(plans.iter().map(|p| p.follow));
        self.plans = plans;
        self.plans_stale = false;
        Ok(())
    }

    fn step_with(&mut self, dt: f32, exec: Execution) -> Result<StepStats> {
        if !(crate::limits::MIN_DT..=MAX_DT).contains(&dt) {
            return Err(Error::InvalidTimeStep { dt: f64::from(dt) });
        }
        self.ensure_plans()?;
        self.journeys.ensure_routes(self.walkable.as_ref())?;
        self.last_plans.clear();
        self.last_plans
            .extend(self.plans.iter().map(|p| p.kind.name()));
        let start = Instant::now();
        self.journeys.before_step(
            &mut self.agents,
            &self.obstacles,
            exec == Execution::Parallel,
        );
        let n = self.agents.len();
        let mut phases = PhaseTimes::default();
        self.scratch.out.resize(n);

        // Everything steering reads besides the agents (index, fields, formations).
        let use_kernel = self.prepare(dt, &mut phases);
        self.check_order(use_kernel)?;

        // steer
        let t = Instant::now();
        // The parallel step lets the integrator gather the cell batch's requests itself.
        self.steer_phase(dt, exec, use_kernel, exec == Execution::Parallel);
        if self.scratch.out.wandered {
            std::mem::swap(&mut self.agents.wander, &mut self.scratch.out.wander);
        }
        phases.steer = t.elapsed();

        // integrate (with the frame-start positions the constrain hooks compare against)
        let t = Instant::now();
        let contact = self.contact_on();
        let keep_start = contact || !self.obstacles.is_empty() || self.fields.is_active();
        if keep_start {
            let parallel = exec == Execution::Parallel;
            passes::copy_column(&mut self.scratch.prev_x, &self.agents.pos_x, parallel);
            passes::copy_column(&mut self.scratch.prev_y, &self.agents.pos_y, parallel);
        }
        // Without contact resolution nothing comes between the integrator and the world's
        // edges: the parallel integrator applies them to each task's agents in cache.
        let edges_inside = !contact && exec == Execution::Parallel;
        self.integrate(dt, exec, edges_inside);
        phases.integrate = t.elapsed();

        // bounds: contact between agents, the world's edges, then obstacle non-penetration
        let t = Instant::now();
        self.resolve_contacts(exec);
        if !edges_inside {
            passes::apply_bounds(&mut self.agents, self.bounds, exec == Execution::Parallel);
        }
        if !self.obstacles.is_empty() {
            self.resolve_obstacles(exec);
        }
        phases.bounds = t.elapsed();

        // fields: wall non-penetration, walkers, arrivals
        let t = Instant::now();
        self.fields.after_move(
            &mut self.agents,
            (&self.scratch.prev_x, &self.scratch.prev_y),
            self.bounds,
            dt,
            exec == Execution::Parallel,
        );
        phases.fields += t.elapsed();

        // contact's guard, after every position change of the step
        if contact {
            let t = Instant::now();
            self.guard_contacts(exec);
            phases.bounds += t.elapsed();
        }

        // Agents driven from outside stand where they were put, whatever the step did.
        self.journeys.hold_external(&mut self.agents);

        self.frame += 1;
        self.time += f64::from(dt);
        let mean_neighbours = if n == 0 {
            0.0
        } else {
            let found = self.scratch.out.found;
            found.unwrap_or_else(|| plans::cells::sum_lanes(&self.scratch.out.neighbours))
                / n as f64
        };
        let left = self.leave_through_exits();
        let (arrived, with_goal) = self.arrivals(exec == Execution::Parallel);
        Ok(StepStats {
            frame: self.frame,
            agents: self.agents.len(),
            left,
            total: start.elapsed(),
            phases,
            mean_neighbours,
            arrived,
            with_goal,
        })
    }

    /// The prepare phases: gravity points and the neighbour index (with reordering), the
    /// nearest-agent indices, the fields' rebuilds, the formations' assignment. Returns whether
    /// the grid kernel's copies are ready.
    fn prepare(&mut self, dt: f32, phases: &mut PhaseTimes) -> bool {
        let t = Instant::now();
        self.advance_gravity(dt);
        let use_kernel = self.prepare_index();
        plans::prepare_nearest(
            &self.plans,
            &self.agents,
            self.bounds,
            &mut self.scratch.within,
            &mut self.scratch.nearest,
        );
        phases.index = t.elapsed();

        let t = Instant::now();
        self.fields.prepare(&self.agents, self.seed, self.frame);
        phases.fields = t.elapsed();

        let t = Instant::now();
        group::update_formations(
            &mut self.group_movement,
            &self.agents,
            self.bounds,
            self.frame,
        );
        phases.formations = t.elapsed();
        use_kernel
    }

    /// The steering pass (parallel or sequential): reads frame-t state, writes the outputs
    /// (with `defer`, possibly leaving the linear requests in the cell batch's outputs:
    /// [`plans::pass::SteerOut::deferred`]).
    fn steer_phase(&mut self, dt: f32, exec: Execution, use_kernel: bool, defer: bool) {
        let view = SteerView {
            agents: &self.agents,
            profiles: &self.groups,
            plans: &self.plans,
            bounds: self.bounds,
            seed: self.seed,
            frame: self.frame,
            dt,
            time: self.time,
            index: &self.index,
            sorted: use_kernel.then_some(&self.scratch.sorted),
            nearest: &self.scratch.nearest,
            obstacles: &self.obstacles,
            gravity: &self.gravity,
            group_movement: &self.group_movement,
            fields: &self.fields,
            targets: self.targets.as_slice(),
            model_params: &self.model_params,
        };
        plans::pass::run(
            &view,
            &mut self.scratch.out,
            &mut self.scratch.pass,
            (exec == Execution::Parallel, defer),
        );
        if plans::ped::any(&view) {
            plans::ped::run(&view, &mut self.scratch.out, exec == Execution::Parallel);
        }
        if plans::orca::any(&view) {
            let walls = self.obstacles.walls();
            if self.scratch.orca_walls_of != walls.len() {
                self.scratch.orca_walls = crate::orca::WallChains::new(walls);
                self.scratch.orca_walls_of = walls.len();
            }
            plans::orca::run(
                &view,
                &self.scratch.orca_walls,
                &mut self.scratch.orca,
                &mut self.scratch.out,
                exec == Execution::Parallel,
            );
        }
    }

    /// Whether some ORCA group has hard contact resolution on.
    fn contact_on(&self) -> bool {
        self.groups
            .iter()
            .any(|g| g.orca.is_some_and(|o| o.contact))
    }

    /// The last word on contact, after every other position change: pairs that still end
    /// closer than [`crate::orca::contact::FLOOR`] of their summed radii go back to the
    /// frame-start positions (the flags of [`World::resolve_contacts`] this step).
    fn guard_contacts(&mut self, exec: Execution) {
        self.contact_pass(exec, None);
    }

    /// Hard contact resolution among the agents of ORCA groups with `contact` on.
    fn resolve_contacts(&mut self, exec: Execution) {
        let iterations = self
            .groups
            .iter()
            .filter_map(|g| g.orca.filter(|o| o.contact).map(|o| o.contact_iterations))
            .max();
        let Some(iterations) = iterations else {
            return;
        };
        let a = &self.agents;
        let groups = &self.groups;
        let moves = &mut self.scratch.moves;
        moves.clear();
        if groups.iter().all(|g| g.orca.is_some_and(|o| o.contact)) {
            moves.resize(a.len(), true);
        } else {
            let table = &mut self.scratch.contact_of;
            table.clear();
            table.extend(groups.iter().map(|g| g.orca.is_some_and(|o| o.contact)));
            moves.extend(a.group.iter().map(|&g| table[g as usize]));
        }
        self.contact_pass(exec, Some(iterations));
    }

    /// The contact sweeps (`Some(iterations)`) or the guard (`None`) on this step's flags.
    fn contact_pass(&mut self, exec: Execution, sweeps: Option<u32>) {
        let a = &mut self.agents;
        let input = crate::orca::contact::ContactInput {
            bounds: self.bounds,
            radius: &a.radius,
            ids: &a.ids,
            moves: &self.scratch.moves,
            near: &self.scratch.orca.near,
            iterations: sweeps.unwrap_or(0),
            tolerance: 0.03,
            prebuilt: self.scratch.orca.prebuilt(&a.ids),
            // What moves agents between the sweeps and the guard: the walls' clamp, the torus
            // wrap, obstacles and field walls.
            unmoved: matches!(self.bounds, Bounds::Open)
                && self.obstacles.is_empty()
                && !self.fields.is_active(),
        };
        let parallel = exec == Execution::Parallel;
        let contact = &mut self.scratch.contact;
        if sweeps.is_some() {
            crate::orca::contact::resolve(&input, &mut a.pos_x, &mut a.pos_y, contact, parallel);
        } else {
            crate::orca::contact::guard(
                &input,
                (&self.scratch.prev_x, &self.scratch.prev_y),
                &mut a.pos_x,
                &mut a.pos_y,
                &mut a.vel_x,
                &mut a.vel_y,
                contact,
                parallel,
            );
        }
    }

    /// `(arrived, with_goal)`: agents of groups with an arrival radius, and those of them within
    /// it of their own target (counted in parallel chunks when `parallel`: integer sums, the
    /// same on any thread count).
    fn arrivals(&mut self, parallel: bool) -> (usize, usize) {
        if self.groups.iter().all(|g| g.arrival_radius.is_none()) {
            return (0, 0);
        }
        // Each group's squared arrival radius, -1 for none: a branch-free count per agent.
        let r_sq = &mut self.scratch.arrival_sq;
        r_sq.clear();
        r_sq.extend(
            self.groups
                .iter()
                .map(|g| g.arrival_radius.map_or(-1.0, |r| r * r)),
        );
        passes::arrivals(
            &self.agents,
            self.bounds,
            &self.scratch.arrival_sq,
            parallel,
        )
    }

    /// The integrator over all agents: the SIMD pass, or its scalar reference sequentially
    /// (with `edges`, the parallel pass also applies the world's bounds to each task's agents,
    /// as [`passes::apply_bounds`] would after it).
    fn integrate(&mut self, dt: f32, exec: Execution, edges: bool) {
        self.scratch.params.clear();
        self.scratch
            .params
            .extend(self.groups.iter().map(|g| g.integration(dt)));
        // While no agent has a maximum speed of its own, the integrator takes each group's
        // from its entry instead of reading the agents' column; otherwise the entries carry
        // none, so that groups which differ only in it still make one entry.
        let group_speeds = self.agents.speeds_of_groups();
        if !group_speeds {
            for p in &mut self.scratch.params {
                p.max_speed = 0.0;
            }
        }
        // Groups that all integrate alike (the copies of a tiled scenario, most worlds) are one
        // entry, and the integrator reads no group index.
        let params = &mut self.scratch.params;
        if params.iter().all(|p| Some(p) == params.first()) {
            params.truncate(1);
        }
        let out = &self.scratch.out;
        // With no angular output and every rotation +0, rotations stay +0: not read or written.
        let still = !out.angular && self.agents.rotations_at_rest();
        let a = &mut self.agents;
        let state = MotionState {
            pos_x: &mut a.pos_x,
            pos_y: &mut a.pos_y,
            vel_x: &mut a.vel_x,
            vel_y: &mut a.vel_y,
            orientation: &mut a.orientation,
            rotation: if still { &mut [] } else { &mut a.rotation },
        };
        let steer = SteeringBuffers {
            lin_x: &out.lin_x,
            lin_y: &out.lin_y,
            ang: if out.angular { &out.ang } else { &[] },
            max_speed: if group_speeds { &[] } else { &a.max_speed },
            group: &a.group,
        };
        let bounds = self.bounds;
        let edge = |s: &mut MotionState<'_>| {
            if edges {
                passes::bound_piece((s.pos_x, s.pos_y, s.vel_x, s.vel_y), bounds);
            }
        };
        let (cells, index) = (&self.scratch.pass.cells, &self.index);
        let take = |base: usize, x: &mut [f32], y: &mut [f32]| cells.take_all(index, base, (x, y));
        // Requests still in the cell batch's outputs: each task gathers its own.
        let turning = match exec {
            Execution::Parallel => {
                let linear = out.deferred.then_some(&take as _);
                movement::integrate_then(state, steer, &self.scratch.params, dt, &edge, linear)
            }
            Execution::Sequential => {
                debug_assert!(!out.deferred, "the sequential step writes every request");
                movement::integrate_scalar(state, steer, &self.scratch.params, dt);
                self.agents.rotation.iter().any(|r| r.to_bits() != 0)
            }
        };
        if !still {
            self.agents.set_turning(turning);
        }
    }

    /// The steering each agent would apply in the next step from the current state, without
    /// advancing the world: `(id, linear, angular)` with the linear part the clamped
    /// acceleration (dynamic) or the desired velocity (kinematic). Useful to compare backends and
    /// to inspect behaviours. Runs the same prepare phases as a step, so agents may be reordered
    /// in storage (ids are unaffected), fields rebuilt and formations reassigned.
    ///
    /// # Errors
    /// As [`World::step`].
    pub fn steering_outputs(&mut self, dt: f32) -> Result<Vec<(crate::AgentId, Steering)>> {
        if !(crate::limits::MIN_DT..=MAX_DT).contains(&dt) {
            return Err(Error::InvalidTimeStep { dt: f64::from(dt) });
        }
        self.ensure_plans()?;
        self.scratch.out.resize(self.agents.len());
        let mut phases = PhaseTimes::default();
        let use_kernel = self.prepare(dt, &mut phases);
        self.check_order(use_kernel)?;
        self.steer_phase(dt, Execution::Parallel, use_kernel, false);
        let o = &self.scratch.out;
        Ok((0..self.agents.len())
            .map(|i| {
                let s = Steering {
                    linear: glam::Vec2::new(o.lin_x[i], o.lin_y[i]),
                    angular: if o.angular { o.ang[i] } else { 0.0 },
                };
                (self.agents.ids[i], s)
            })
            .collect())
    }

    /// Moves scripted and agent-borne gravity points and reindexes them.
    fn advance_gravity(&mut self, dt: f32) {
        if self.gravity.is_empty() {
            return;
        }
        let agents = &self.agents;
        self.gravity
            .advance(dt, self.time + f64::from(dt), self.bounds, |id| {
                agents.index_of(id).map(|i| agents.position(i))
            });
    }

    /// The hard non-penetration step: no centre inside a circle, no move across a wall.
    fn resolve_obstacles(&mut self, exec: Execution) {
        let a = &mut self.agents;
        passes::resolve_obstacles(
            &self.obstacles,
            self.bounds,
            (&self.scratch.prev_x, &self.scratch.prev_y),
            (&mut a.pos_x, &mut a.pos_y, &mut a.vel_x, &mut a.vel_y),
            exec == Execution::Parallel,
        )
    }

    /// The one owner of the agents' order in a frame: decides the frame's order once, before
    /// any index or copy is built from it, then builds the neighbour index and the grid kernel's
    /// copies for that order (recording it in each, [`World::check_order`]). Returns whether
    /// the grid kernel's copies are ready.
    ///
    /// On the frames a reorder is due (every `reorder_every`), the agents are ordered by the
    /// first of these that the world has:
    /// 1. the neighbour index's grid, when some group queries neighbours (flocking, Vicsek,
    ///    pedestrian models, ORCA on a torus): neighbours then sit together in memory;
    /// 2. the cells of the first field, when fields are followed and nothing queries neighbours:
    ///    field lookups then walk memory in order;
    /// 3. a hashed grid of ORCA's neighbour distance, when ORCA is the only reader of
    ///    neighbours: its pass then shares a cell's candidates.
    ///
    /// Nothing else reorders the agents during a step.
    fn prepare_index(&mut self) -> bool {
        // ORCA reads its own hashed grid in open and walled worlds, the world's index on a torus.
        let torus = self.bounds.is_torus();
        let query_r = self
            .plans
            .iter()
            .map(|p| {
                let flock = if p.spec.active { p.spec.query_r } else { 0.0 };
                let orca = p.orca.filter(|_| torus).map_or(0.0, |o| o.neighbour_dist);
                flock
                    .max(orca)
                    .max(p.pedestrian.map_or(0.0, |m| m.cutoff()))
            })
            .fold(self.model_params.max_cutoff, f32::max);
        let reorder_due = self.reorder_every > 0
            && self.frame.is_multiple_of(u64::from(self.reorder_every))
            && !self.agents.is_empty();
        if query_r > 0.0 || !self.fields.fields.is_empty() {
            // Agents are not in the order of ORCA's grid: its cells stay narrow.
            self.scratch.orca.wide = false;
        }
        if query_r <= 0.0 || self.agents.is_empty() {
            if reorder_due && !self.fields.fields.is_empty() {
                self.fields.order_by_cell(&mut self.agents);
            } else if reorder_due {
                self.order_by_orca_grid();
            }
            return false;
        }
        let a = &self.agents;
        self.index.rebuild(&a.pos_x, &a.pos_y, self.bounds, query_r);
        self.scratch.index_order = self.agents.order();
        let SpatialIndex::Grid(grid) = &mut self.index else {
            return false;
        };
        if reorder_due {
            self.scratch.perm.clear();
            self.scratch.perm.extend_from_slice(grid.order());
            self.agents.reorder(&self.scratch.perm);
            // The grid of the reordered agents: the same cells, the identity order.
            grid.adopt_order();
            self.scratch.index_order = self.agents.order();
        }
        let SpatialIndex::Grid(grid) = &self.index else {
            return false;
        };
        // Unit headings for Vicsek sums, which read every neighbour's (the cell batch computes
        // a view cone's, the agent's own, per task).
        let headings = self.plans.iter().any(|p| p.spec.vicsek_r_sq.is_some());
        let one_group = self.plans.len() == 1;
        self.scratch
            .sorted
            .fill(grid, &self.agents, headings, one_group);
        true
    }

    /// Orders the agents by a hashed grid of ORCA's neighbour distance, when some group uses
    /// ORCA (nothing else sorts the agents then): the agents of a cell together, in their
    /// previous order, the cells of a row one after another. That keeps ORCA's neighbours close
    /// in memory and lets the agents of a cell share their gathered candidates. The grid is the
    /// step's own, built for this alone on reorder frames; the world's index is left as it is.
    /// Cells are twice the distance where agents are sparse (`plans::orca::wide_cells`,
    /// decided from this frame's positions alone, so that the order does not depend on earlier
    /// frames), and the ORCA pass uses the same cells until the next reorder.
    fn order_by_orca_grid(&mut self) {
        let orca_r = plans::orca::reach(&self.plans);
        if orca_r <= 0.0 {
            return;
        }
        let a = &self.agents;
        let grid = &mut self.scratch.order_grid;
        grid.rebuild(&a.pos_x, &a.pos_y, 2.0 * orca_r);
        let wide = plans::orca::wide_cells(grid.crowding());
        if !wide {
            grid.rebuild(&a.pos_x, &a.pos_y, orca_r);
        }
        self.scratch.orca.wide = wide;
        self.scratch.perm.clear();
        self.scratch.perm.extend_from_slice(grid.order());
        self.agents.reorder(&self.scratch.perm);
        // The grid of the reordered agents serves the ORCA pass of this frame.
        grid.adopt_order();
        let a = &self.agents;
        self.scratch.orca.adopt(grid, &a.ids, (&a.pos_x, &a.pos_y));
    }

    /// Whether every copy of the agents' data that steering reads this frame was built for the
    /// agents' current order: the neighbour index (when it covers the agents), the grid
    /// kernel's cell-ordered copies (when `use_kernel`), and the nearest-agent indices.
    ///
    /// # Errors
    /// [`Error::StaleOrder`] naming the first stale copy.
    pub(crate) fn check_order(&self, use_kernel: bool) -> Result<()> {
        let now = self.agents.order();
        let index_read = self.index.len() == self.agents.len() && !self.agents.is_empty();
        if index_read && self.scratch.index_order != now {
            return Err(Error::StaleOrder {
                copy: "neighbour index",
            });
        }
        if use_kernel && self.scratch.sorted.order() != now {
            return Err(Error::StaleOrder {
                copy: "grid kernel's cell-ordered copies",
            });
        }
        if self
            .scratch
            .nearest
            .iter()
            .flatten()
            .any(|n| n.order() != now)
        {
            return Err(Error::StaleOrder {
                copy: "nearest-agent index",
            });
        }
        Ok(())
    }
}

thread_local! {
    /// The calling thread's pool of one thread for [`World::step_sequential`] (one per calling
    /// thread, so that sequential steps on several threads do not queue for one), made on first
    /// use; `None` when its thread could not be started.
    static ONE_THREAD: Option<rayon::ThreadPool> =
        rayon::ThreadPoolBuilder::new().num_threads(1).build().ok();
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A reorder after the prepare phases (what the fields' prepare hook once did) leaves the
    /// neighbour index, the grid kernel's copies and the nearest-agent indices built for the
    /// previous order: the step's check names the stale copy instead of reading it, and after
    /// the next prepare (which builds every copy for the current order) it passes again.
    #[test]
    fn a_copy_built_for_another_order_is_refused() {
        for name in ["bottleneck", "flock", "pursuit"] {
            let mut w = crate::scenario::builtin(name)
                .unwrap()
                .with_agents(300)
                .unwrap()
                .build()
                .unwrap();
            let mut phases = PhaseTimes::default();
            w.ensure_plans().unwrap();
            let use_kernel = w.prepare(0.01, &mut phases);
            assert!(w.check_order(use_kernel).is_ok(), "{name}: fresh copies");
            let n = w.agents.len() as u32;
            let reversed: Vec<u32> = (0..n).rev().collect();
            w.agents.reorder(&reversed);
            assert!(
                matches!(w.check_order(use_kernel), Err(Error::StaleOrder { .. })),
                "{name}: a stale copy was not caught"
            );
            assert!(w.step(0.01).is_ok(), "{name}: the step rebuilds its copies");
        }
    }

    /// The near-contact flags (each agent's nearest hit against the reach of a step) of an open
    /// world, whose ORCA pass takes its hits from its hashed grid (in the order found when they
    /// are few), equal those of the same crowd on a torus far from its seams (hits sorted through
    /// the world's index), agent by agent, through the ring and the crowded centre.
    #[test]
    fn near_flags_from_hits_in_any_order_equal_those_from_sorted_hits() {
        let text = |kind: &str| {
            let s = std::fs::read_to_string(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/scenarios/circle.toml"
            ))
            .unwrap();
            s.replace("kind = \"open\"", kind)
                .replace("center = [0, 0]", "center = [2000, 2000]")
                .replace(
                    "kind = \"antipode\"",
                    "kind = \"antipode\", center = [2000, 2000]",
                )
        };
        let load = |kind: &str| {
            let s = crate::scenario::Scenario::from_toml(&text(kind), "circle.toml").unwrap();
            (s.build().unwrap(), s.dt)
        };
        let (mut open, dt) = load("kind = \"open\"");
        let (mut torus, _) = load("kind = \"torus\"\nsize = [4000, 4000]");
        let (mut flagged, mut unflagged) = (0, 0);
        for step in 0..900 {
            open.step(dt).unwrap();
            torus.step(dt).unwrap();
            let (a, b) = (open.agents(), torus.agents());
            for k in 0..a.len() {
                let j = b.index_of(a.id(k)).unwrap();
                let (x, y) = (open.scratch.orca.near[k], torus.scratch.orca.near[j]);
                assert_eq!(x, y, "agent {:?} at step {step}", a.id(k));
                (flagged, unflagged) = (flagged + usize::from(x), unflagged + usize::from(!x));
            }
        }
        assert!(
            flagged > 1000 && unflagged > 1000,
            "{flagged} flagged, {unflagged} not"
        );
    }
}
