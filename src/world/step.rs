use std::time::Instant;

use glam::Vec2;
use rayon::prelude::*;

use super::group::GroupParams;
use super::neighbours::{self, FlockSpec, Querier, SortedCopies};
use super::state::World;
use super::stats::{PhaseTimes, StepStats};
use crate::agents::Agents;
use crate::bounds::Bounds;
use crate::error::{Error, MAX_DT, MAX_SPEED, Result};
use crate::gravity::{self, GravityField};
use crate::movement::{self, IntegrationParams, MotionState, MovementModel, SteeringBuffers};
use crate::obstacles::{self, Circle, Obstacles, Wall};
use crate::rng::AgentRng;
use crate::spatial::{GridIndex, Neighbour, NeighbourIndex, SpatialIndex};
use crate::steering::{self, Basis, Behaviour, Combine, NeighbourSums, Steering, Target};

/// Stream tag for per-frame behaviour randomness.
const STREAM_STEER: u32 = 0;
/// Agents per parallel steering task.
const STEER_CHUNK: usize = 1024;

/// Per-frame buffers, reused across steps (never serialised).
#[derive(Debug, Default)]
pub(crate) struct Scratch {
    out: SteerOut,
    params: Vec<IntegrationParams>,
    flock: Vec<FlockSpec>,
    sorted: SortedCopies,
    /// Per group: an index over that group's agents, when some behaviour looks for its nearest.
    nearest: Vec<Option<NearestIndex>>,
    prev_x: Vec<f32>,
    prev_y: Vec<f32>,
    /// The reordering permutation.
    perm: Vec<u32>,
    /// Per group: the largest `nearest` search radius that targets it.
    within: Vec<f32>,
}

/// A neighbour index over the agents of one group, for `Target::Nearest`.
#[derive(Debug, Default)]
pub(crate) struct NearestIndex {
    index: GridIndex,
    /// Agent storage index of each indexed point.
    agents: Vec<u32>,
    xs: Vec<f32>,
    ys: Vec<f32>,
}

/// The steering pass's per-agent outputs.
#[derive(Debug, Default)]
struct SteerOut {
    lin_x: Vec<f32>,
    lin_y: Vec<f32>,
    ang: Vec<f32>,
    wander: Vec<f32>,
    /// Neighbours found per agent this step.
    neighbours: Vec<f32>,
}

thread_local! {
    /// Per-worker neighbour list of the scalar traversal, reused across agents and frames.
    static NEIGHBOURS: std::cell::RefCell<Vec<Neighbour>> = const { std::cell::RefCell::new(Vec::new()) };
}

impl SteerOut {
    fn resize(&mut self, n: usize) {
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

/// Everything the steering of one agent reads: frame-t state only.
pub(crate) struct SteerCtx<'a> {
    pub agents: &'a Agents,
    pub groups: &'a [GroupParams],
    pub bounds: Bounds,
    pub seed: u64,
    pub frame: u64,
    pub dt: f32,
    pub index: &'a SpatialIndex,
    pub flock: &'a [FlockSpec],
    /// Cell-ordered copies for the grid kernel (`None`: use the scalar traversal).
    pub sorted: Option<&'a SortedCopies>,
    pub nearest: &'a [Option<NearestIndex>],
    pub obstacles: &'a Obstacles,
    pub gravity: &'a GravityField,
    pub group_movement: &'a super::formation::GroupMovement,
    /// The world's fields (read only).
    pub fields: &'a super::fields::FieldSet,
}

/// A resolved target: its position (nearest image) and velocity.
struct Resolved {
    position: Vec2,
    velocity: Vec2,
}

impl SteerCtx<'_> {
    fn resolve(&self, i: usize, target: Target, position: Vec2) -> Option<Resolved> {
        let a = self.agents;
        let (p, v) = match target {
            Target::Point(p) => (p, Vec2::ZERO),
            Target::Own => (Vec2::new(a.target_x[i], a.target_y[i]), Vec2::ZERO),
            Target::Agent(id) => {
                let j = a.index_of(id)?;
                if j == i {
                    return None;
                }
                (a.position(j), a.velocity(j))
            }
            Target::Nearest { group, within } => {
                let ni = self.nearest.get(group)?.as_ref()?;
                let j = NEIGHBOURS.with_borrow_mut(|buf| {
                    ni.index.k_nearest_at(position, 2, within, None, buf);
                    buf.iter()
                        .map(|nb| ni.agents[nb.index as usize] as usize)
                        .find(|&j| j != i)
                })?;
                (a.position(j), a.velocity(j))
            }
        };
        Some(Resolved {
            position: position + self.bounds.offset(position, p),
            velocity: v,
        })
    }

    /// The fused neighbour sums of agent `i` (all zero when its group needs no neighbours).
    fn sums(&self, i: usize, velocity: Vec2, orientation: f32) -> NeighbourSums {
        let a = self.agents;
        let spec = &self.flock[a.group[i] as usize];
        if !spec.active {
            return NeighbourSums::default();
        }
        let me = Querier {
            position: a.position(i),
            velocity,
            heading: velocity
                .try_normalize()
                .unwrap_or_else(|| Vec2::from_angle(orientation)),
            group: a.group[i],
        };
        match (self.index, self.sorted) {
            (SpatialIndex::Grid(grid), Some(sorted)) if spec.kernel_ok() => {
                neighbours::sums_grid(grid, sorted, self.bounds, &me, spec, self.groups.len() == 1)
            }
            _ => NEIGHBOURS.with_borrow_mut(|buf| {
                neighbours::sums_scalar(self.index, i, &me, spec, &a.vel_x, &a.vel_y, &a.group, buf)
            }),
        }
    }

    /// The steering of agent `i`: `(linear, angular, new wander angle, neighbours found)`, with
    /// the linear part a clamped acceleration (dynamic) or a desired velocity (kinematic).
    pub(crate) fn steer(&self, i: usize) -> (Steering, f32, f32) {
        let a = self.agents;
        let g = &self.groups[a.group[i] as usize];
        let kinematic = g.model == MovementModel::Kinematic;
        let velocity = a.velocity(i);
        let orientation = a.orientation[i];
        if let Some((field, channel, weight)) = self.flock[a.group[i] as usize].follow_only {
            // One flow field only: the general loop's sum without its dispatch (0 + f w, as there).
            let f = self.fields.follow(
                field,
                channel,
                a.ids[i],
                a.position(i),
                velocity,
                a.max_speed[i],
                kinematic,
            );
            let total = Steering::linear(Vec2::ZERO + f * weight);
            return (self.finish(g, kinematic, total), a.wander[i], 0.0);
        }
        if let Some((entries, len)) = self.flock[a.group[i] as usize].pure {
            // Flocking only: the same sum as the general loop below, without its dispatch.
            let sums = self.sums(i, velocity, orientation);
            let max_speed = a.max_speed[i];
            let mut total = Vec2::ZERO;
            for &(slot, weight) in &entries[..len as usize] {
                let f = match (slot, kinematic) {
                    (0, true) => steering::desired(sums.separation, max_speed),
                    (0, false) => steering::separation(&sums, velocity, max_speed),
                    (1, true) => steering::desired(sums.alignment, max_speed),
                    (1, false) => steering::alignment(&sums, velocity, max_speed),
                    (_, true) => steering::desired(sums.cohesion, max_speed),
                    (_, false) => steering::cohesion(&sums, velocity, max_speed),
                };
                total += f * weight;
            }
            return (
                self.finish(g, kinematic, Steering::linear(total)),
                a.wander[i],
                sums.count,
            );
        }
        let position = a.position(i);
        let rotation = a.rotation[i];
        let max_speed = a.max_speed[i];
        let mut wander_angle = a.wander[i];
        let mut rng = AgentRng::new(self.seed, a.ids[i].0, self.frame, STREAM_STEER);
        let sums = self.sums(i, velocity, orientation);

        let priority = g.steering.combine == Combine::Priority;
        let mut running = if kinematic {
            steering::PrioritySum::new(max_speed, g.max_rotation)
        } else {
            steering::PrioritySum::new(g.max_acceleration * g.mass, g.max_angular_acceleration)
        };
        let mut total = Steering::ZERO;
        for w in &g.steering.behaviours {
            let s = self
                .behaviour(
                    i,
                    &w.behaviour,
                    g,
                    kinematic,
                    position,
                    velocity,
                    orientation,
                    rotation,
                    max_speed,
                    &sums,
                    &mut wander_angle,
                    &mut rng,
                )
                .scaled(w.weight);
            if priority {
                if !running.push(s) {
                    break;
                }
            } else {
                total += s;
            }
        }
        if priority {
            total = running.total();
        }
        let out = self.finish(g, kinematic, total);
        (out, wander_angle, sums.count)
    }

    /// The combined request turned into the integrator's input: for the dynamic model the
    /// acceleration `force / mass` clamped to the maximum, and the angular acceleration clamped.
    #[inline]
    fn finish(&self, g: &GroupParams, kinematic: bool, total: Steering) -> Steering {
        let out = if kinematic {
            total
        } else {
            let acc = steering::truncate(total.linear / g.mass, g.max_acceleration);
            Steering {
                linear: acc,
                angular: total
                    .angular
                    .clamp(-g.max_angular_acceleration, g.max_angular_acceleration),
            }
        };
        // A finite square implies finite components, and NaN fails it; kinematic requests need
        // it for the integrator's speed clamp, dynamic ones are already truncated.
        if out.linear.length_squared().is_finite() && out.angular.is_finite() {
            return out;
        }
        // Overflowing requests (a gravity point almost on top of an agent, a tiny mass): keep
        // their direction at the limit; undefined ones (infinity minus infinity) do nothing.
        let (lin_max, ang_max) = if kinematic {
            (MAX_SPEED, g.max_rotation)
        } else {
            (g.max_acceleration, g.max_angular_acceleration)
        };
        let raw = if kinematic {
            total.linear
        } else {
            total.linear / g.mass
        };
        Steering {
            linear: steering::truncate_robust(raw, lin_max),
            angular: if total.angular.is_nan() {
                0.0
            } else {
                total.angular.clamp(-ang_max, ang_max)
            },
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn behaviour(
        &self,
        i: usize,
        b: &Behaviour,
        g: &GroupParams,
        kinematic: bool,
        position: Vec2,
        velocity: Vec2,
        orientation: f32,
        rotation: f32,
        max_speed: f32,
        sums: &NeighbourSums,
        wander_angle: &mut f32,
        rng: &mut AgentRng,
    ) -> Steering {
        let target = |t: Target| self.resolve(i, t, position);
        match *b {
            Behaviour::Seek {
                target: t,
                threshold,
            } => match target(t) {
                Some(r) if kinematic => Steering::linear(steering::kinematic_seek(
                    position, r.position, max_speed, threshold,
                )),
                Some(r) => Steering::linear(steering::seek(
                    position, velocity, r.position, max_speed, threshold,
                )),
                None => Steering::ZERO,
            },
            Behaviour::Flee {
                target: t,
                panic_distance,
            } => match target(t) {
                Some(r) if kinematic => Steering::linear(steering::kinematic_flee(
                    position,
                    r.position,
                    max_speed,
                    panic_distance,
                )),
                Some(r) => Steering::linear(steering::flee(
                    position,
                    velocity,
                    r.position,
                    max_speed,
                    panic_distance,
                )),
                None => Steering::ZERO,
            },
            Behaviour::Arrive { target: t, params } => match target(t) {
                Some(r) if kinematic => Steering::linear(steering::kinematic_arrive(
                    position, r.position, max_speed, &params,
                )),
                Some(r) => Steering::linear(steering::arrive(
                    position, velocity, r.position, max_speed, &params,
                )),
                None => Steering::ZERO,
            },
            Behaviour::Wander { params } => {
                if kinematic {
                    let (v, rot) =
                        steering::kinematic_wander(orientation, max_speed, g.max_rotation, rng);
                    Steering {
                        linear: v,
                        angular: rot,
                    }
                } else {
                    let heading = velocity
                        .try_normalize()
                        .unwrap_or_else(|| Vec2::from_angle(orientation));
                    let (f, angle) = steering::wander(
                        velocity,
                        heading,
                        *wander_angle,
                        max_speed,
                        &params,
                        self.dt,
                        rng,
                    );
                    *wander_angle = angle;
                    Steering::linear(f)
                }
            }
            Behaviour::Pursue {
                target: t,
                max_prediction,
            } => match target(t) {
                Some(r) => {
                    let speed = if kinematic {
                        max_speed
                    } else {
                        velocity.length()
                    };
                    let predicted = steering::predict_position(
                        position,
                        speed,
                        r.position,
                        r.velocity,
                        max_prediction,
                    );
                    if kinematic {
                        Steering::linear(steering::kinematic_seek(
                            position, predicted, max_speed, 0.0,
                        ))
                    } else {
                        Steering::linear(steering::seek(
                            position, velocity, predicted, max_speed, 0.0,
                        ))
                    }
                }
                None => Steering::ZERO,
            },
            Behaviour::Evade {
                target: t,
                max_prediction,
                panic_distance,
            } => match target(t) {
                Some(r) => {
                    let f = steering::evade(
                        position,
                        velocity,
                        r.position,
                        r.velocity,
                        max_speed,
                        max_prediction,
                        panic_distance,
                    );
                    // Kinematic: the desired velocity is the force plus the current velocity.
                    if kinematic && f != Vec2::ZERO {
                        Steering::linear(f + velocity)
                    } else {
                        Steering::linear(f)
                    }
                }
                None => Steering::ZERO,
            },
            Behaviour::Face { target: t, params } => match target(t) {
                Some(r) if kinematic => Steering::angular(steering::kinematic_face(
                    position,
                    orientation,
                    r.position,
                    g.max_rotation,
                    &params,
                )),
                Some(r) => Steering::angular(steering::face(
                    position,
                    orientation,
                    rotation,
                    r.position,
                    g.max_rotation,
                    &params,
                )),
                None => Steering::ZERO,
            },
            Behaviour::LookWhereYouAreGoing { params } => {
                if kinematic {
                    if velocity == Vec2::ZERO {
                        Steering::ZERO
                    } else {
                        Steering::angular(steering::kinematic_face(
                            Vec2::ZERO,
                            orientation,
                            velocity,
                            g.max_rotation,
                            &params,
                        ))
                    }
                } else {
                    Steering::angular(steering::look_where_you_are_going(
                        velocity,
                        orientation,
                        rotation,
                        g.max_rotation,
                        &params,
                    ))
                }
            }
            Behaviour::MatchVelocity {
                target: t,
                time_to_target,
            } => match target(t) {
                Some(r) if kinematic => Steering::linear(r.velocity),
                Some(r) => Steering::linear(
                    steering::velocity_match(velocity, r.velocity, time_to_target) * g.mass,
                ),
                None => Steering::ZERO,
            },
            Behaviour::Separation { .. } if kinematic => {
                Steering::linear(steering::desired(sums.separation, max_speed))
            }
            Behaviour::Separation { .. } => {
                Steering::linear(steering::separation(sums, velocity, max_speed))
            }
            Behaviour::Alignment { .. } if kinematic => {
                Steering::linear(steering::desired(sums.alignment, max_speed))
            }
            Behaviour::Alignment { .. } => {
                Steering::linear(steering::alignment(sums, velocity, max_speed))
            }
            Behaviour::Cohesion { .. } if kinematic => {
                Steering::linear(steering::desired(sums.cohesion, max_speed))
            }
            Behaviour::Cohesion { .. } => {
                Steering::linear(steering::cohesion(sums, velocity, max_speed))
            }
            Behaviour::Repulsion { .. } => Steering::linear(sums.repulsion),
            Behaviour::AvoidObstacles { box_length } => {
                if self.obstacles.circles().is_empty() {
                    return Steering::ZERO;
                }
                let basis = Basis::from_velocity(position, velocity, orientation);
                let length = box_length * (1.0 + velocity.length() / max_speed);
                let radius = self.agents.radius[i];
                let mut near = [Circle {
                    center: Vec2::ZERO,
                    radius: 0.0,
                }; 32];
                let mut count = 0;
                let centre = position + basis.heading * (0.5 * length);
                self.obstacles.broadphase().visit(
                    centre,
                    0.5 * length + radius,
                    |c| {
                        if count < near.len() {
                            near[count] = self.obstacles.circles()[c as usize];
                            count += 1;
                        }
                    },
                    |_| {},
                );
                let force = obstacles::avoid_circles(
                    &basis,
                    radius,
                    length,
                    max_speed,
                    near[..count].iter().copied(),
                );
                if kinematic {
                    Steering::linear(force + velocity)
                } else {
                    Steering::linear(force)
                }
            }
            Behaviour::AvoidWalls { feeler_length } => {
                if self.obstacles.walls().is_empty() {
                    return Steering::ZERO;
                }
                let basis = Basis::from_velocity(position, velocity, orientation);
                let mut near = [Wall {
                    a: Vec2::ZERO,
                    b: Vec2::X,
                }; 32];
                let mut count = 0;
                self.obstacles.broadphase().visit(
                    position,
                    feeler_length,
                    |_| {},
                    |w| {
                        if count < near.len() {
                            near[count] = self.obstacles.walls()[w as usize];
                            count += 1;
                        }
                    },
                );
                let force = obstacles::avoid_walls(
                    &basis,
                    feeler_length,
                    max_speed,
                    near[..count].iter().copied(),
                );
                if kinematic {
                    Steering::linear(force + velocity)
                } else {
                    Steering::linear(force)
                }
            }
            Behaviour::Containment { margin, lookahead } => match self.bounds {
                Bounds::Bounded { size } => {
                    let force = obstacles::containment(
                        position, velocity, size, margin, lookahead, max_speed,
                    );
                    if kinematic {
                        Steering::linear(force + velocity)
                    } else {
                        Steering::linear(force)
                    }
                }
                _ => Steering::ZERO,
            },
            Behaviour::AntiGravity => {
                let force = NEIGHBOURS.with_borrow_mut(|buf| self.gravity.force_at(position, buf));
                Steering::linear(force)
            }
            Behaviour::AntiGravitySeek { target: t } => match target(t) {
                Some(r) => {
                    let force =
                        NEIGHBOURS.with_borrow_mut(|buf| self.gravity.force_at(position, buf));
                    let desired =
                        gravity::antigravity_seek(position, r.position, force) * max_speed;
                    if kinematic {
                        Steering::linear(desired)
                    } else {
                        Steering::linear(desired - velocity)
                    }
                }
                None => Steering::ZERO,
            },
            Behaviour::FollowPath { .. }
            | Behaviour::FollowLeader { .. }
            | Behaviour::KeepFormation { .. }
            | Behaviour::Jump { .. } => {
                self.group_behaviour(i, b, g, kinematic, position, velocity, max_speed)
            }
            Behaviour::FollowField { field, channel } => Steering::linear(self.fields.follow(
                field,
                channel,
                self.agents.ids[i],
                position,
                velocity,
                max_speed,
                kinematic,
            )),
        }
    }
}

/// How a step runs: the parallel, SIMD pipeline or the sequential scalar reference.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Execution {
    Parallel,
    Sequential,
}

impl World {
    /// Advances the world by `dt` seconds on the current rayon thread pool (run it inside
    /// `pool.install` to choose the number of threads).
    ///
    /// # Errors
    /// [`Error::InvalidTimeStep`] when `dt` is not a finite number greater than zero; the world is
    /// then unchanged.
    pub fn step(&mut self, dt: f32) -> Result<StepStats> {
        self.step_with(dt, Execution::Parallel)
    }

    /// The sequential, scalar reference step: the same results as [`World::step`], bit for bit,
    /// computed on one thread without SIMD.
    ///
    /// # Errors
    /// [`Error::InvalidTimeStep`] as for [`World::step`].
    pub fn step_sequential(&mut self, dt: f32) -> Result<StepStats> {
        self.step_with(dt, Execution::Sequential)
    }

    fn step_with(&mut self, dt: f32, exec: Execution) -> Result<StepStats> {
        if !(dt.is_finite() && dt > 0.0 && dt <= MAX_DT) {
            return Err(Error::InvalidTimeStep { dt: f64::from(dt) });
        }
        self.check_references()?;
        let start = Instant::now();
        let n = self.agents.len();
        let mut phases = PhaseTimes::default();
        self.scratch.out.resize(n);

        // 1. index: rebuilt when some group queries neighbours; agents reordered by cell when due;
        //    gravity points moved and reindexed; per-group indices for nearest-agent targets
        let t = Instant::now();
        self.advance_gravity(dt);
        let use_kernel = self.index_phase();
        phases.index = t.elapsed();

        // 2. steer (formations re-form first, sequentially)
        let t = Instant::now();
        self.update_formations();
        self.steer_phase(dt, exec, use_kernel);
        std::mem::swap(&mut self.agents.wander, &mut self.scratch.out.wander);
        phases.steer = t.elapsed();

        // 3. integrate
        let t = Instant::now();
        if !self.obstacles.is_empty() {
            self.scratch.prev_x.clone_from(&self.agents.pos_x);
            self.scratch.prev_y.clone_from(&self.agents.pos_y);
        }
        self.scratch.params.clear();
        self.scratch
            .params
            .extend(self.groups.iter().map(|g| g.integration(dt)));
        {
            let a = &mut self.agents;
            let state = MotionState {
                pos_x: &mut a.pos_x,
                pos_y: &mut a.pos_y,
                vel_x: &mut a.vel_x,
                vel_y: &mut a.vel_y,
                orientation: &mut a.orientation,
                rotation: &mut a.rotation,
            };
            let steer = SteeringBuffers {
                lin_x: &self.scratch.out.lin_x,
                lin_y: &self.scratch.out.lin_y,
                ang: &self.scratch.out.ang,
                max_speed: &a.max_speed,
                group: &a.group,
            };
            match exec {
                Execution::Parallel => movement::integrate(state, steer, &self.scratch.params, dt),
                Execution::Sequential => {
                    movement::integrate_scalar(state, steer, &self.scratch.params, dt)
                }
            }
        }
        phases.integrate = t.elapsed();

        // 4. bounds
        let t = Instant::now();
        apply_bounds(&mut self.agents, self.bounds);
        if !self.obstacles.is_empty() {
            self.resolve_obstacles(exec);
        }
        self.fields
            .after_move(&mut self.agents, dt, exec == Execution::Parallel);
        phases.bounds = t.elapsed();

        self.frame += 1;
        self.time += f64::from(dt);
        let mean_neighbours = if n == 0 {
            0.0
        } else {
            self.scratch
                .out
                .neighbours
                .iter()
                .map(|&c| f64::from(c))
                .sum::<f64>()
                / n as f64
        };
        Ok(StepStats {
            frame: self.frame,
            agents: n,
            total: start.elapsed(),
            phases,
            mean_neighbours,
        })
    }

    /// The parallel (or sequential) steering pass: reads frame-t state, writes the outputs.
    fn steer_phase(&mut self, dt: f32, exec: Execution, use_kernel: bool) {
        let ctx = SteerCtx {
            agents: &self.agents,
            groups: &self.groups,
            bounds: self.bounds,
            seed: self.seed,
            frame: self.frame,
            dt,
            index: &self.index,
            flock: &self.scratch.flock,
            sorted: use_kernel.then_some(&self.scratch.sorted),
            nearest: &self.scratch.nearest,
            obstacles: &self.obstacles,
            gravity: &self.gravity,
            group_movement: &self.group_movement,
            fields: &self.fields,
        };
        let s = &mut self.scratch.out;
        let kernel = |base: usize,
                      lx: &mut [f32],
                      ly: &mut [f32],
                      an: &mut [f32],
                      wa: &mut [f32],
                      nb: &mut [f32]| {
            for k in 0..lx.len() {
                let (st, w, count) = ctx.steer(base + k);
                lx[k] = st.linear.x;
                ly[k] = st.linear.y;
                an[k] = st.angular;
                wa[k] = w;
                nb[k] = count;
            }
        };
        match exec {
            Execution::Parallel => {
                (
                    s.lin_x.par_chunks_mut(STEER_CHUNK),
                    s.lin_y.par_chunks_mut(STEER_CHUNK),
                    s.ang.par_chunks_mut(STEER_CHUNK),
                    s.wander.par_chunks_mut(STEER_CHUNK),
                    s.neighbours.par_chunks_mut(STEER_CHUNK),
                )
                    .into_par_iter()
                    .enumerate()
                    .for_each(|(c, (lx, ly, an, wa, nb))| {
                        kernel(c * STEER_CHUNK, lx, ly, an, wa, nb)
                    });
            }
            Execution::Sequential => kernel(
                0,
                &mut s.lin_x,
                &mut s.lin_y,
                &mut s.ang,
                &mut s.wander,
                &mut s.neighbours,
            ),
        }
    }

    /// The steering each agent would apply in the next step from the current state, without
    /// advancing the world: `(id, linear, angular)` with the linear part the clamped
    /// acceleration (dynamic) or the desired velocity (kinematic). Useful to compare backends and
    /// to inspect behaviours. Agents may be reordered in storage (ids are unaffected).
    ///
    /// # Errors
    /// [`Error::InvalidTimeStep`] when `dt` is not a finite number greater than zero.
    pub fn steering_outputs(&mut self, dt: f32) -> Result<Vec<(crate::AgentId, Steering)>> {
        if !(dt.is_finite() && dt > 0.0 && dt <= MAX_DT) {
            return Err(Error::InvalidTimeStep { dt: f64::from(dt) });
        }
        self.check_references()?;
        self.scratch.out.resize(self.agents.len());
        let use_kernel = self.index_phase();
        self.update_formations();
        self.steer_phase(dt, Execution::Parallel, use_kernel);
        let o = &self.scratch.out;
        Ok((0..self.agents.len())
            .map(|i| {
                let s = Steering {
                    linear: Vec2::new(o.lin_x[i], o.lin_y[i]),
                    angular: o.ang[i],
                };
                (self.agents.ids[i], s)
            })
            .collect())
    }

    /// Rebuilds the neighbour index when some group needs neighbours, reorders the agents by
    /// grid cell when due, and fills the grid kernel's copies. Returns whether the grid kernel
    /// is ready.
    /// Everything the steering pass reads besides the agents: the neighbour index (and the
    /// reordering), the nearest-of-group indices, and the fields' rebuilds. Returns whether the
    /// grid kernel is ready.
    fn index_phase(&mut self) -> bool {
        let use_kernel = self.prepare_index();
        self.prepare_nearest();
        let (seed, frame, every) = (self.seed, self.frame, self.reorder_every);
        self.fields
            .prepare(&mut self.agents, &self.groups, seed, frame, every);
        use_kernel
    }

    /// Checks that every field, channel and group a behaviour names exists. Groups may be added
    /// before the fields they follow, so this runs at each step (a few comparisons per behaviour).
    fn check_references(&self) -> Result<()> {
        let groups = self.groups.len();
        for (gi, g) in self.groups.iter().enumerate() {
            for w in &g.steering.behaviours {
                if let Behaviour::FollowField { field, channel } = w.behaviour {
                    let ok = self.field(field).is_some_and(|f| channel < f.len());
                    if !ok {
                        return Err(Error::Invalid {
                            name: format!("group {gi} ({}) follow_field", g.name),
                            reason: format!(
                                "field {field} channel {channel} does not exist (the world has {} fields)",
                                self.field_count()
                            ),
                        });
                    }
                }
                if let Some(Target::Nearest { group, .. }) = w.behaviour.target()
                    && group >= groups
                {
                    return Err(Error::UnknownGroup {
                        group,
                        count: groups,
                    });
                }
            }
        }
        Ok(())
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

    /// Builds an index over each group some behaviour looks for the nearest agent of.
    fn prepare_nearest(&mut self) {
        let groups = self.groups.len();
        self.scratch.nearest.resize_with(groups, || None);
        let mut within = std::mem::take(&mut self.scratch.within);
        within.clear();
        within.resize(groups, 0.0);
        for g in &self.groups {
            for w in &g.steering.behaviours {
                if let Some(Target::Nearest { group, within: r }) = w.behaviour.target()
                    && group < groups
                {
                    within[group] = within[group].max(r);
                }
            }
        }
        for (g, &r) in within.iter().enumerate() {
            if r <= 0.0 {
                self.scratch.nearest[g] = None;
                continue;
            }
            let ni = self.scratch.nearest[g].get_or_insert_with(NearestIndex::default);
            ni.agents.clear();
            ni.xs.clear();
            ni.ys.clear();
            let a = &self.agents;
            for i in 0..a.len() {
                if a.group[i] as usize == g {
                    ni.agents.push(i as u32);
                    ni.xs.push(a.pos_x[i]);
                    ni.ys.push(a.pos_y[i]);
                }
            }
            ni.index.rebuild(&ni.xs, &ni.ys, self.bounds, r);
        }
        self.scratch.within = within;
    }

    /// The hard non-penetration step: no centre inside a circle, no move across a wall.
    fn resolve_obstacles(&mut self, exec: Execution) {
        let obstacles = &self.obstacles;
        let bounds = self.bounds;
        let (px, py) = (&self.scratch.prev_x, &self.scratch.prev_y);
        let fix = |base: usize, x: &mut [f32], y: &mut [f32], vx: &mut [f32], vy: &mut [f32]| {
            for k in 0..x.len() {
                let from = Vec2::new(px[base + k], py[base + k]);
                let to = Vec2::new(x[k], y[k]);
                // On a torus, resolve the move as the short hop it was, then wrap.
                let to_image = from + bounds.offset(from, to);
                let (p, v) = obstacles.resolve(from, to_image, Vec2::new(vx[k], vy[k]));
                let p = if p == to_image { to } else { bounds.wrap(p) };
                x[k] = p.x;
                y[k] = p.y;
                vx[k] = v.x;
                vy[k] = v.y;
            }
        };
        let a = &mut self.agents;
        match exec {
            Execution::Parallel => {
                (
                    a.pos_x.par_chunks_mut(STEER_CHUNK),
                    a.pos_y.par_chunks_mut(STEER_CHUNK),
                    a.vel_x.par_chunks_mut(STEER_CHUNK),
                    a.vel_y.par_chunks_mut(STEER_CHUNK),
                )
                    .into_par_iter()
                    .enumerate()
                    .for_each(|(c, (x, y, vx, vy))| fix(c * STEER_CHUNK, x, y, vx, vy));
            }
            Execution::Sequential => fix(0, &mut a.pos_x, &mut a.pos_y, &mut a.vel_x, &mut a.vel_y),
        }
    }

    fn prepare_index(&mut self) -> bool {
        self.scratch.flock.clear();
        self.scratch
            .flock
            .extend(self.groups.iter().map(FlockSpec::of));
        let query_r = self
            .scratch
            .flock
            .iter()
            .filter(|s| s.active)
            .map(|s| s.query_r)
            .fold(0.0_f32, f32::max);
        if query_r <= 0.0 || self.agents.is_empty() {
            return false;
        }
        let a = &self.agents;
        self.index.rebuild(&a.pos_x, &a.pos_y, self.bounds, query_r);
        let SpatialIndex::Grid(grid) = &self.index else {
            return false;
        };
        if self.reorder_every > 0 && self.frame.is_multiple_of(u64::from(self.reorder_every)) {
            self.scratch.perm.clear();
            self.scratch.perm.extend_from_slice(grid.order());
            self.agents.reorder(&self.scratch.perm);
            let a = &self.agents;
            self.index.rebuild(&a.pos_x, &a.pos_y, self.bounds, query_r);
        }
        let SpatialIndex::Grid(grid) = &self.index else {
            return false;
        };
        let a = &self.agents;
        self.scratch.sorted.fill(grid, &a.vel_x, &a.vel_y, &a.group);
        true
    }
}

/// Wraps positions on a torus; on a walled rectangle clamps them and removes the velocity
/// component that points into the wall.
fn apply_bounds(a: &mut Agents, bounds: Bounds) {
    match bounds {
        Bounds::Open => {}
        Bounds::Torus { size } => {
            for x in &mut a.pos_x {
                *x = crate::bounds::wrap_coord(*x, size.x);
            }
            for y in &mut a.pos_y {
                *y = crate::bounds::wrap_coord(*y, size.y);
            }
        }
        Bounds::Bounded { size } => {
            clamp_axis(&mut a.pos_x, &mut a.vel_x, size.x);
            clamp_axis(&mut a.pos_y, &mut a.vel_y, size.y);
        }
    }
}

fn clamp_axis(pos: &mut [f32], vel: &mut [f32], side: f32) {
    for (p, v) in pos.iter_mut().zip(vel.iter_mut()) {
        if *p < 0.0 {
            *p = 0.0;
            *v = v.max(0.0);
        } else if *p > side {
            *p = side;
            *v = v.min(0.0);
        }
    }
}
