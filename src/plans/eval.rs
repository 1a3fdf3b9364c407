//! One evaluation function per behaviour: the scalar, per-agent form of every behaviour.
//!
//! Each function reads the agent ([`Me`]), the frame-t [`SteerView`] and the behaviour's
//! parameters, calls the pure function of [`crate::steering`], [`crate::group`],
//! [`crate::obstacles`], [`crate::gravity`] or [`crate::field`] that does the work, and returns
//! the request in the profile's model (a force or a desired velocity, through the
//! [`Adapter`](super::adapter::Adapter)). [`evaluate`] dispatches on the behaviour; it is the
//! reference that batch evaluations are tested against.
//!
//! Invariant: a function reads only frame-t state and writes only the agent's own [`Draws`]
//! (its wander angle and random stream), so evaluation order never matters.

use std::f32::consts::TAU;

use glam::Vec2;

use super::adapter::Adapter;
use super::view::{NEIGHBOURS, Resolved, SteerView};
use crate::bounds::Bounds;
use crate::gravity;
use crate::group::{
    self, FollowParams, JumpParams, JumpPhase, PathFollowParams, PathId, SlotParams,
};
use crate::movement::MovementModel;
use crate::obstacles::{self, Circle, Wall};
use crate::profile::Profile;
use crate::rng::{AgentRng, Stream};
use crate::steering::{
    self, AlignParams, ArriveParams, Basis, Behaviour, NeighbourSums, Steering, Target,
    WanderParams,
};

/// The agent being evaluated, as its behaviours see it (frame-t values).
#[derive(Clone, Copy)]
pub(crate) struct Me<'a> {
    /// Storage index.
    pub i: usize,
    pub position: Vec2,
    pub velocity: Vec2,
    pub orientation: f32,
    pub rotation: f32,
    pub max_speed: f32,
    pub profile: &'a Profile,
    pub adapter: Adapter,
    /// The agent's fused neighbour sums.
    pub sums: NeighbourSums,
}

impl Me<'_> {
    fn kinematic(&self) -> bool {
        self.adapter.kinematic
    }

    /// The unit heading: along the velocity, or the orientation at rest.
    fn heading(&self) -> Vec2 {
        self.velocity
            .try_normalize()
            .unwrap_or_else(|| Vec2::from_angle(self.orientation))
    }
}

/// What evaluation may change of an agent: its wander angle and its random stream.
#[derive(Debug)]
pub(crate) struct Draws {
    pub wander: f32,
    pub rng: AgentRng,
}

/// Evaluates behaviour `b` for agent `me`.
pub(crate) fn evaluate(v: &SteerView, me: &Me, b: &Behaviour, d: &mut Draws) -> Steering {
    match *b {
        Behaviour::Seek { target, threshold } => seek(v, me, target, threshold),
        Behaviour::Flee {
            target,
            panic_distance,
        } => flee(v, me, target, panic_distance),
        Behaviour::Arrive { target, params } => arrive(v, me, target, &params),
        Behaviour::Wander { params } => wander(v, me, &params, d),
        Behaviour::Pursue {
            target,
            max_prediction,
        } => pursue(v, me, target, max_prediction),
        Behaviour::Evade {
            target,
            max_prediction,
            panic_distance,
        } => evade(v, me, target, max_prediction, panic_distance),
        Behaviour::Face { target, params } => face(v, me, target, &params),
        Behaviour::LookWhereYouAreGoing { params } => look_where_you_are_going(me, &params),
        Behaviour::MatchVelocity {
            target,
            time_to_target,
        } => match_velocity(v, me, target, time_to_target),
        Behaviour::Separation { .. } => flock_term(me, super::spec::SEP),
        Behaviour::Alignment { .. } => flock_term(me, super::spec::ALI),
        Behaviour::Cohesion { .. } => flock_term(me, super::spec::COH),
        Behaviour::Repulsion { .. } => Steering::linear(me.sums.repulsion),
        Behaviour::AvoidObstacles { box_length } => avoid_obstacles(v, me, box_length),
        Behaviour::AvoidWalls { feeler_length } => avoid_walls(v, me, feeler_length),
        Behaviour::Containment { margin, lookahead } => containment(v, me, margin, lookahead),
        Behaviour::AntiGravity => anti_gravity(v, me),
        Behaviour::AntiGravitySeek { target } => anti_gravity_seek(v, me, target),
        Behaviour::FollowPath { path, params } => follow_path(
            v,
            me.i,
            (me.position, me.velocity, me.max_speed),
            &me.adapter,
            path,
            &params,
        ),
        Behaviour::FollowLeader { leader, params } => follow_leader(v, me, leader, &params),
        Behaviour::KeepFormation { params } => keep_formation(
            v,
            me.i,
            (me.position, me.velocity, me.max_speed),
            &me.adapter,
            &params,
        ),
        Behaviour::Jump {
            launch,
            landing,
            params,
        } => jump(me, launch, landing, &params),
        Behaviour::FollowField { field, channel } => follow_field(v, me, field, channel),
        Behaviour::ChooseExit {
            field,
            channels,
            switch_gain,
        } => {
            let chosen = crate::field::FollowChannel::Chosen {
                channels,
                switch_gain,
            };
            let channel = v.fields.channel_of(chosen, v.agents.ids[me.i]);
            follow_field(v, me, field, channel)
        }
        Behaviour::Vicsek { noise, .. } => vicsek(me, noise, d),
    }
}

fn target(v: &SteerView, me: &Me, t: Target) -> Option<Resolved> {
    v.resolve(me.i, t, me.position)
}

fn seek(v: &SteerView, me: &Me, t: Target, threshold: f32) -> Steering {
    let Some(r) = target(v, me, t) else {
        return Steering::ZERO;
    };
    Steering::linear(if me.kinematic() {
        steering::kinematic_seek(me.position, r.position, me.max_speed, threshold)
    } else {
        steering::seek(
            me.position,
            me.velocity,
            r.position,
            me.max_speed,
            threshold,
        )
    })
}

fn flee(v: &SteerView, me: &Me, t: Target, panic_distance: f32) -> Steering {
    let Some(r) = target(v, me, t) else {
        return Steering::ZERO;
    };
    Steering::linear(if me.kinematic() {
        steering::kinematic_flee(me.position, r.position, me.max_speed, panic_distance)
    } else {
        steering::flee(
            me.position,
            me.velocity,
            r.position,
            me.max_speed,
            panic_distance,
        )
    })
}

fn arrive(v: &SteerView, me: &Me, t: Target, params: &ArriveParams) -> Steering {
    let Some(r) = target(v, me, t) else {
        return Steering::ZERO;
    };
    Steering::linear(if me.kinematic() {
        steering::kinematic_arrive(me.position, r.position, me.max_speed, params)
    } else {
        steering::arrive(me.position, me.velocity, r.position, me.max_speed, params)
    })
}

fn wander(v: &SteerView, me: &Me, params: &WanderParams, d: &mut Draws) -> Steering {
    if me.kinematic() {
        let (linear, angular) = steering::kinematic_wander(
            me.orientation,
            me.max_speed,
            me.profile.max_rotation,
            &mut d.rng,
        );
        return Steering { linear, angular };
    }
    let (f, angle) = steering::wander(
        me.velocity,
        me.heading(),
        d.wander,
        me.max_speed,
        params,
        v.dt,
        &mut d.rng,
    );
    d.wander = angle;
    Steering::linear(f)
}

fn pursue(v: &SteerView, me: &Me, t: Target, max_prediction: f32) -> Steering {
    let Some(r) = target(v, me, t) else {
        return Steering::ZERO;
    };
    let speed = if me.kinematic() {
        me.max_speed
    } else {
        me.velocity.length()
    };
    let predicted =
        steering::predict_position(me.position, speed, r.position, r.velocity, max_prediction);
    Steering::linear(if me.kinematic() {
        steering::kinematic_seek(me.position, predicted, me.max_speed, 0.0)
    } else {
        steering::seek(me.position, me.velocity, predicted, me.max_speed, 0.0)
    })
}

fn evade(v: &SteerView, me: &Me, t: Target, max_prediction: f32, panic: f32) -> Steering {
    let Some(r) = target(v, me, t) else {
        return Steering::ZERO;
    };
    let f = steering::evade(
        me.position,
        me.velocity,
        r.position,
        r.velocity,
        me.max_speed,
        max_prediction,
        panic,
    );
    // Kinematic: nothing to evade leaves no request (the agent stops), as the kinematic flee.
    if f == Vec2::ZERO {
        Steering::ZERO
    } else {
        Steering::linear(me.adapter.force_request(f, me.velocity))
    }
}

fn face(v: &SteerView, me: &Me, t: Target, params: &AlignParams) -> Steering {
    let Some(r) = target(v, me, t) else {
        return Steering::ZERO;
    };
    let max_rotation = me.profile.max_rotation;
    Steering::angular(if me.kinematic() {
        steering::kinematic_face(
            me.position,
            me.orientation,
            r.position,
            max_rotation,
            params,
        )
    } else {
        steering::face(
            me.position,
            me.orientation,
            me.rotation,
            r.position,
            max_rotation,
            params,
        )
    })
}

fn look_where_you_are_going(me: &Me, params: &AlignParams) -> Steering {
    let max_rotation = me.profile.max_rotation;
    if !me.kinematic() {
        return Steering::angular(steering::look_where_you_are_going(
            me.velocity,
            me.orientation,
            me.rotation,
            max_rotation,
            params,
        ));
    }
    if me.velocity == Vec2::ZERO {
        return Steering::ZERO;
    }
    Steering::angular(steering::kinematic_face(
        Vec2::ZERO,
        me.orientation,
        me.velocity,
        max_rotation,
        params,
    ))
}

fn match_velocity(v: &SteerView, me: &Me, t: Target, time_to_target: f32) -> Steering {
    let Some(r) = target(v, me, t) else {
        return Steering::ZERO;
    };
    if me.kinematic() {
        Steering::linear(r.velocity)
    } else {
        Steering::linear(
            steering::velocity_match(me.velocity, r.velocity, time_to_target) * me.adapter.mass,
        )
    }
}

/// Separation, alignment or cohesion (by slot) from the agent's neighbour sums: full speed
/// along the sum (kinematic) or the force towards that (dynamic).
#[inline]
pub(crate) fn flock_term(me: &Me, slot: usize) -> Steering {
    Steering::linear(flock_force(
        &me.sums,
        slot,
        me.velocity,
        me.max_speed,
        me.kinematic(),
    ))
}

/// [`flock_term`]'s linear part, for callers that hold the sums and the state apart.
#[inline]
pub(crate) fn flock_force(
    sums: &NeighbourSums,
    slot: usize,
    velocity: Vec2,
    max_speed: f32,
    kinematic: bool,
) -> Vec2 {
    use super::spec::{ALI, SEP};
    match (slot, kinematic) {
        (SEP, true) => steering::desired(sums.separation, max_speed),
        (SEP, false) => steering::separation(sums, velocity, max_speed),
        (ALI, true) => steering::desired(sums.alignment, max_speed),
        (ALI, false) => steering::alignment(sums, velocity, max_speed),
        (_, true) => steering::desired(sums.cohesion, max_speed),
        (_, false) => steering::cohesion(sums, velocity, max_speed),
    }
}

/// The detection box of Buckland's obstacle avoidance against the circles near it.
fn avoid_obstacles(v: &SteerView, me: &Me, box_length: f32) -> Steering {
    let obstacles = v.obstacles;
    if obstacles.circles().is_empty() {
        return Steering::ZERO;
    }
    let basis = Basis::from_velocity(me.position, me.velocity, me.orientation);
    let length = box_length * (1.0 + me.velocity.length() / me.max_speed);
    let radius = v.agents.radius[me.i];
    let mut near = [Circle {
        center: Vec2::ZERO,
        radius: 0.0,
    }; 32];
    let mut count = 0;
    let centre = me.position + basis.heading * (0.5 * length);
    obstacles.broadphase().visit(
        centre,
        0.5 * length + radius,
        |c| {
            if count < near.len() {
                near[count] = obstacles.circles()[c as usize];
                count += 1;
            }
        },
        |_| {},
    );
    let force = obstacles::avoid_circles(
        &basis,
        radius,
        length,
        me.max_speed,
        near[..count].iter().copied(),
    );
    Steering::linear(me.adapter.force_request(force, me.velocity))
}

/// Feelers against the walls near the agent.
fn avoid_walls(v: &SteerView, me: &Me, feeler_length: f32) -> Steering {
    let agent = (me.position, me.velocity, me.orientation, me.max_speed);
    Steering::linear(wall_request(v, agent, &me.adapter, feeler_length))
}

/// `avoid_walls`' linear request for an agent at `position` with `velocity`, `orientation` and
/// `max_speed`: the feelers against the walls the broad phase finds near it, as a force or a
/// desired velocity by `adapter`; zero in a world without walls.
pub(crate) fn wall_request(
    v: &SteerView,
    (position, velocity, orientation, max_speed): (Vec2, Vec2, f32, f32),
    adapter: &Adapter,
    feeler_length: f32,
) -> Vec2 {
    let obstacles = v.obstacles;
    if obstacles.walls().is_empty() {
        return Vec2::ZERO;
    }
    let basis = Basis::from_velocity(position, velocity, orientation);
    let mut near = [Wall {
        a: Vec2::ZERO,
        b: Vec2::X,
    }; 32];
    let mut count = 0;
    obstacles.broadphase().visit(
        position,
        feeler_length,
        |_| {},
        |w| {
            if count < near.len() {
                near[count] = obstacles.walls()[w as usize];
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
    adapter.force_request(force, velocity)
}

fn containment(v: &SteerView, me: &Me, margin: f32, lookahead: f32) -> Steering {
    let Bounds::Bounded { size } = v.bounds else {
        return Steering::ZERO;
    };
    let force = obstacles::containment(
        me.position,
        me.velocity,
        size,
        margin,
        lookahead,
        me.max_speed,
    );
    Steering::linear(me.adapter.force_request(force, me.velocity))
}

fn gravity_force(v: &SteerView, me: &Me) -> Vec2 {
    NEIGHBOURS.with_borrow_mut(|buf| v.gravity.force_near(me.position, buf))
}

fn anti_gravity(v: &SteerView, me: &Me) -> Steering {
    Steering::linear(gravity_force(v, me))
}

fn anti_gravity_seek(v: &SteerView, me: &Me, t: Target) -> Steering {
    let agent = (me.position, me.velocity, me.max_speed);
    anti_gravity_seek_request(v, me.i, agent, &me.adapter, t)
}

/// Agent `i`'s `anti_gravity_seek` request (its position, velocity and maximum speed given):
/// the general plan's evaluation and the `AntiGravitySeek` plan's.
pub(crate) fn anti_gravity_seek_request(
    v: &SteerView,
    i: usize,
    (position, velocity, max_speed): (Vec2, Vec2, f32),
    adapter: &Adapter,
    t: Target,
) -> Steering {
    let Some(r) = v.resolve(i, t, position) else {
        return Steering::ZERO;
    };
    let force = NEIGHBOURS.with_borrow_mut(|buf| v.gravity.force_near(position, buf));
    let desired = gravity::antigravity_seek(position, r.position, force) * max_speed;
    Steering::linear(adapter.toward(desired, velocity))
}

/// Agent `i`'s `follow_path` request (its position, velocity and maximum speed given): the
/// general plan's evaluation and the `FollowPath` plan's.
pub(crate) fn follow_path(
    v: &SteerView,
    i: usize,
    (position, velocity, max_speed): (Vec2, Vec2, f32),
    adapter: &Adapter,
    path: PathId,
    params: &PathFollowParams,
) -> Steering {
    let Some(path) = v.group_movement.paths.get(path.0 as usize) else {
        return Steering::ZERO;
    };
    let id = v.agents.ids[i];
    let desired = group::follow_path(
        position,
        velocity,
        path,
        params.direction.sign(id.0),
        max_speed,
        params,
    );
    adapter.towards(desired, velocity, params.time_to_target)
}

/// The frame of agent `j` as seen from `position` (nearest image on a torus), and its velocity.
fn frame_of(v: &SteerView, j: usize, position: Vec2) -> (Basis, Vec2) {
    let a = v.agents;
    let p = position + v.bounds.offset(position, a.position(j));
    (Basis::from_orientation(p, a.orientation[j]), a.velocity(j))
}

fn follow_leader(v: &SteerView, me: &Me, leader: Target, params: &FollowParams) -> Steering {
    let a = v.agents;
    let Target::Agent(leader) = leader else {
        return Steering::ZERO;
    };
    let Some(j) = a.index_of(leader).filter(|&j| j != me.i) else {
        return Steering::ZERO;
    };
    let (basis, leader_velocity) = frame_of(v, j, me.position);
    let mut slot = params.offset;
    if params.spread > 0.0 {
        let mut rng = AgentRng::new(v.seed, a.ids[me.i].0, 0, Stream::Spread as u32);
        let r = params.spread * rng.unit().sqrt();
        // The polynomial sine and cosine, which the leader's lanes evaluate too.
        let (sin, cos) = crate::steering::trig::sin_cos(TAU * rng.unit());
        slot += Vec2::new(cos, sin) * r;
    }
    let desired = group::follow_leader(
        me.position,
        &basis,
        leader_velocity,
        slot,
        me.max_speed,
        params,
    );
    me.adapter
        .towards(desired, me.velocity, params.time_to_target)
}

/// Agent `i`'s `keep_formation` request (its position, velocity and maximum speed given): the
/// general plan's evaluation and the `KeepFormation` plan's.
pub(crate) fn keep_formation(
    v: &SteerView,
    i: usize,
    (position, velocity, max_speed): (Vec2, Vec2, f32),
    adapter: &Adapter,
    params: &SlotParams,
) -> Steering {
    let a = v.agents;
    let gm = v.group_movement;
    let anchor = gm
        .slot(a.ids[i])
        .and_then(|(f, s)| Some((a.index_of(gm.formations[f].anchor())?, s)));
    let desired = match anchor {
        Some((j, local)) => {
            let (basis, anchor_velocity) = frame_of(v, j, position);
            group::slot_velocity(
                position,
                basis.to_world(local),
                anchor_velocity,
                max_speed,
                params,
            )
        }
        // No formation or no anchor: stop.
        None => Vec2::ZERO,
    };
    adapter.towards(desired, velocity, params.time_to_target)
}

fn jump(me: &Me, launch: Vec2, landing: Vec2, params: &JumpParams) -> Steering {
    // An impossible jump (this agent's own maximum speed may be lower than the group's) is not
    // attempted.
    let Ok(plan) = group::jump_plan(launch, landing, params, me.max_speed) else {
        return Steering::ZERO;
    };
    let acc = if me.profile.model == MovementModel::Kinematic {
        f32::INFINITY
    } else {
        me.profile.max_acceleration
    };
    match group::jump_phase(
        me.position,
        me.velocity,
        launch,
        landing,
        &plan,
        me.max_speed,
        acc,
        params,
    ) {
        JumpPhase::Approach(vel) | JumpPhase::RunUp(vel) => {
            me.adapter.towards(vel, me.velocity, params.time_to_target)
        }
        JumpPhase::Flight if me.kinematic() => Steering::linear(plan.velocity),
        JumpPhase::Flight => Steering::ZERO,
    }
}

pub(crate) fn follow_field(v: &SteerView, me: &Me, field: usize, channel: usize) -> Steering {
    Steering::linear(v.fields.follow(
        field,
        channel,
        v.agents.ids[me.i],
        me.position,
        me.velocity,
        me.max_speed,
        me.kinematic(),
    ))
}

/// The Vicsek heading: the sum of the neighbours' unit velocities and the agent's own, turned
/// by the noise, at full speed (a desired velocity; kinematic profiles only, which validation
/// of the world's groups guarantees).
fn vicsek(me: &Me, noise: f32, d: &mut Draws) -> Steering {
    let sum = me.sums.heading + me.heading();
    let turn = noise * 0.5 * d.rng.signed();
    Steering::linear(steering::vicsek_heading(sum, turn) * me.max_speed)
}
