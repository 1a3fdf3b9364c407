use std::time::Instant;

use glam::Vec2;
use rayon::prelude::*;

use super::group::GroupParams;
use super::state::World;
use super::stats::{PhaseTimes, StepStats};
use crate::agents::Agents;
use crate::bounds::Bounds;
use crate::error::{Error, Result};
use crate::movement::{self, IntegrationParams, MotionState, MovementModel, SteeringBuffers};
use crate::rng::AgentRng;
use crate::steering::{self, Behaviour, Combine, Steering, Target};

/// Stream tag for per-frame behaviour randomness.
const STREAM_STEER: u32 = 0;
/// Agents per parallel steering task.
const STEER_CHUNK: usize = 1024;

/// Per-frame buffers, reused across steps (never serialised).
#[derive(Debug, Default)]
pub(crate) struct Scratch {
    lin_x: Vec<f32>,
    lin_y: Vec<f32>,
    ang: Vec<f32>,
    wander: Vec<f32>,
    params: Vec<IntegrationParams>,
}

impl Scratch {
    fn resize(&mut self, n: usize) {
        for v in [
            &mut self.lin_x,
            &mut self.lin_y,
            &mut self.ang,
            &mut self.wander,
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
    pub group_movement: &'a super::formation::GroupMovement,
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
        };
        Some(Resolved {
            position: position + self.bounds.offset(position, p),
            velocity: v,
        })
    }

    /// The steering of agent `i`: `(linear, angular, new wander angle)`, with the linear part a
    /// clamped acceleration (dynamic) or a desired velocity (kinematic).
    pub(crate) fn steer(&self, i: usize) -> (Steering, f32) {
        let a = self.agents;
        let g = &self.groups[a.group[i] as usize];
        let kinematic = g.model == MovementModel::Kinematic;
        let position = a.position(i);
        let velocity = a.velocity(i);
        let orientation = a.orientation[i];
        let rotation = a.rotation[i];
        let max_speed = a.max_speed[i];
        let mut wander_angle = a.wander[i];
        let mut rng = AgentRng::new(self.seed, a.ids[i].0, self.frame, STREAM_STEER);

        let mut parts = [Steering::ZERO; 16];
        let mut weights = [0.0_f32; 16];
        let mut count = 0;
        let mut total = Steering::ZERO;
        for (k, w) in g.steering.behaviours.iter().enumerate() {
            let s = self.behaviour(
                i,
                &w.behaviour,
                g,
                kinematic,
                position,
                velocity,
                orientation,
                rotation,
                max_speed,
                &mut wander_angle,
                &mut rng,
            );
            match g.steering.combine {
                Combine::WeightedSum => total += s.scaled(w.weight),
                Combine::Priority => {
                    if k < parts.len() {
                        parts[k] = s;
                        weights[k] = w.weight;
                        count = k + 1;
                    }
                }
            }
        }
        if g.steering.combine == Combine::Priority {
            let (budget, ang_budget) = if kinematic {
                (max_speed, g.max_rotation)
            } else {
                (g.max_acceleration * g.mass, g.max_angular_acceleration)
            };
            total = steering::priority_sum(
                (0..count).map(|k| parts[k].scaled(weights[k])),
                budget,
                ang_budget,
            );
        }
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
        (out, wander_angle)
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
            Behaviour::FollowPath { .. }
            | Behaviour::FollowLeader { .. }
            | Behaviour::KeepFormation { .. }
            | Behaviour::Jump { .. } => {
                self.group_behaviour(i, b, g, kinematic, position, velocity, max_speed)
            }
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
        if !(dt.is_finite() && dt > 0.0) {
            return Err(Error::InvalidTimeStep { dt: f64::from(dt) });
        }
        let start = Instant::now();
        let n = self.agents.len();
        let mut phases = PhaseTimes::default();
        self.scratch.resize(n);

        // 1. index (none yet for the core behaviours)
        let t = Instant::now();
        phases.index = t.elapsed();

        // 2. steer (formations re-form first, sequentially)
        let t = Instant::now();
        self.update_formations();
        {
            let ctx = SteerCtx {
                agents: &self.agents,
                groups: &self.groups,
                bounds: self.bounds,
                seed: self.seed,
                frame: self.frame,
                dt,
                group_movement: &self.group_movement,
            };
            let s = &mut self.scratch;
            let kernel =
                |base: usize, lx: &mut [f32], ly: &mut [f32], an: &mut [f32], wa: &mut [f32]| {
                    for k in 0..lx.len() {
                        let (st, w) = ctx.steer(base + k);
                        lx[k] = st.linear.x;
                        ly[k] = st.linear.y;
                        an[k] = st.angular;
                        wa[k] = w;
                    }
                };
            match exec {
                Execution::Parallel => {
                    (
                        s.lin_x.par_chunks_mut(STEER_CHUNK),
                        s.lin_y.par_chunks_mut(STEER_CHUNK),
                        s.ang.par_chunks_mut(STEER_CHUNK),
                        s.wander.par_chunks_mut(STEER_CHUNK),
                    )
                        .into_par_iter()
                        .enumerate()
                        .for_each(|(c, (lx, ly, an, wa))| kernel(c * STEER_CHUNK, lx, ly, an, wa));
                }
                Execution::Sequential => {
                    kernel(0, &mut s.lin_x, &mut s.lin_y, &mut s.ang, &mut s.wander)
                }
            }
        }
        std::mem::swap(&mut self.agents.wander, &mut self.scratch.wander);
        phases.steer = t.elapsed();

        // 3. integrate
        let t = Instant::now();
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
                lin_x: &self.scratch.lin_x,
                lin_y: &self.scratch.lin_y,
                ang: &self.scratch.ang,
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
        phases.bounds = t.elapsed();

        self.frame += 1;
        self.time += f64::from(dt);
        Ok(StepStats {
            frame: self.frame,
            agents: n,
            total: start.elapsed(),
            phases,
            mean_neighbours: 0.0,
        })
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
