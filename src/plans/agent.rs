//! One agent's steering by its group's plan, per agent: the flocking, flow-field, path,
//! formation, wander and anti-gravity seek plans without dispatch, and the general plan (every behaviour of the
//! profile evaluated by [`evaluate`] and combined). The batched paths (the cell batch, the lanes,
//! leader following) fall back to it where their vector form does not serve an agent exactly,
//! and are held to its bits by the tests.
//!
//! Invariant: reads frame-t state only and writes nothing; the request is a clamped acceleration
//! (dynamic) or a desired velocity (kinematic).

use super::adapter::Adapter;
use super::eval::{self, Draws, Me, evaluate};
use super::plan::PlanKind;
use super::spec::SEP;
use super::view::SteerView;
use crate::rng::{AgentRng, Stream};
use crate::steering::{self, Combine, Steering};

/// The steering of agent `i`, per agent: `(request, new wander angle, neighbours found)`, the
/// request being a clamped acceleration (dynamic) or a desired velocity (kinematic).
pub(crate) fn steer_agent(v: &SteerView, i: usize) -> (Steering, f32, f32) {
    steer_agent_with(v, i, None)
}

/// [`steer_agent`] with the agent's neighbour sums when the cell batch computed them (the
/// general plan then does not query its neighbourhood itself).
pub(crate) fn steer_agent_with(
    v: &SteerView,
    i: usize,
    sums: Option<&crate::steering::NeighbourSums>,
) -> (Steering, f32, f32) {
    let a = v.agents;
    let g = a.group[i] as usize;
    let plan = &v.plans[g];
    let adapter = plan.adapter;
    let velocity = a.velocity(i);
    // A lone behaviour's request as the general loop sums and finishes it (0 + s w, as there),
    // without its dispatch.
    let lone = |s: Steering, weight: f32| adapter.finish(Steering::ZERO + s.scaled(weight));
    match plan.kind {
        PlanKind::FollowField {
            field,
            channel,
            weight,
            separation,
            walls,
        } => {
            let f = v.fields.follow(
                field,
                v.fields.channel_of(channel, a.ids[i]),
                a.ids[i],
                a.position(i),
                velocity,
                a.max_speed[i],
                adapter.kinematic,
            );
            // The general loop's sum without its dispatch (0 + f w, then the separation term,
            // as there).
            let mut total = glam::Vec2::ZERO + f * weight;
            let mut found = 0.0;
            if let Some(w) = separation {
                let sums = sums
                    .copied()
                    .unwrap_or_else(|| v.sums(i, velocity, a.orientation[i]));
                let max_speed = a.max_speed[i];
                total += eval::flock_force(&sums, SEP, velocity, max_speed, adapter.kinematic) * w;
                found = sums.count;
            }
            if let Some((feeler_length, w)) = walls {
                let agent = (a.position(i), velocity, a.orientation[i], a.max_speed[i]);
                total += eval::wall_request(v, agent, &adapter, feeler_length) * w;
            }
            (adapter.finish(Steering::linear(total)), a.wander[i], found)
        }
        PlanKind::FollowPath {
            path,
            params,
            weight,
        } => {
            let me = (a.position(i), velocity, a.max_speed[i]);
            let s = eval::follow_path(v, i, me, &adapter, path, &params);
            (lone(s, weight), a.wander[i], 0.0)
        }
        PlanKind::KeepFormation { params, weight } => {
            let me = (a.position(i), velocity, a.max_speed[i]);
            let s = eval::keep_formation(v, i, me, &adapter, &params);
            (lone(s, weight), a.wander[i], 0.0)
        }
        PlanKind::Wander { params, weight } => {
            // The general loop's draws and sum without its dispatch (0 + s w, as there).
            let mut rng = AgentRng::new(v.seed, a.ids[i].0, v.frame, Stream::Steer as u32);
            let orientation = a.orientation[i];
            let (s, angle) = if adapter.kinematic {
                let profile = &v.profiles[g];
                let (linear, angular) = steering::kinematic_wander(
                    orientation,
                    a.max_speed[i],
                    profile.max_rotation,
                    &mut rng,
                );
                (Steering { linear, angular }, a.wander[i])
            } else {
                let heading = velocity
                    .try_normalize()
                    .unwrap_or_else(|| glam::Vec2::from_angle(orientation));
                let (f, angle) = steering::wander(
                    velocity,
                    heading,
                    a.wander[i],
                    a.max_speed[i],
                    &params,
                    v.dt,
                    &mut rng,
                );
                (Steering::linear(f), angle)
            };
            (lone(s, weight), angle, 0.0)
        }
        PlanKind::Flock { terms, len } => {
            let sums = v.sums(i, velocity, a.orientation[i]);
            let total = flock_total(
                &terms[..len as usize],
                &sums,
                velocity,
                a.max_speed[i],
                &adapter,
            );
            (
                adapter.finish(Steering::linear(total)),
                a.wander[i],
                sums.count,
            )
        }
        PlanKind::AntiGravitySeek {
            target,
            weight,
            repulsion,
        } => {
            // The general loop's sum without its dispatch (0 + s w, then the repulsion term, as
            // there).
            let agent = (a.position(i), velocity, a.max_speed[i]);
            let s = eval::anti_gravity_seek_request(v, i, agent, &adapter, target);
            let mut total = Steering::ZERO + s.scaled(weight);
            let mut found = 0.0;
            if let Some(w) = repulsion {
                let sums = sums
                    .copied()
                    .unwrap_or_else(|| v.sums(i, velocity, a.orientation[i]));
                total += Steering::linear(sums.repulsion).scaled(w);
                found = sums.count;
            }
            (adapter.finish(total), a.wander[i], found)
        }
        PlanKind::General
        | PlanKind::Vicsek { .. }
        | PlanKind::Seek { .. }
        | PlanKind::Arrive { .. }
        | PlanKind::FollowLeader { .. } => general(v, i, &adapter, sums),
    }
}

/// The weighted sum of flocking terms, in the profile's order (as the general loop sums them).
#[inline(always)]
pub(crate) fn flock_total(
    terms: &[(u8, f32)],
    sums: &crate::steering::NeighbourSums,
    velocity: glam::Vec2,
    max_speed: f32,
    adapter: &Adapter,
) -> glam::Vec2 {
    let mut total = glam::Vec2::ZERO;
    for &(slot, weight) in terms {
        total +=
            eval::flock_force(sums, slot as usize, velocity, max_speed, adapter.kinematic) * weight;
    }
    total
}

/// The general plan: every behaviour of the profile evaluated and combined.
fn general(
    v: &SteerView,
    i: usize,
    adapter: &Adapter,
    sums: Option<&crate::steering::NeighbourSums>,
) -> (Steering, f32, f32) {
    let a = v.agents;
    let profile = &v.profiles[a.group[i] as usize];
    let velocity = a.velocity(i);
    let orientation = a.orientation[i];
    let me = Me {
        i,
        position: a.position(i),
        velocity,
        orientation,
        rotation: a.rotation[i],
        max_speed: a.max_speed[i],
        profile,
        adapter: *adapter,
        sums: sums.map_or_else(|| v.sums(i, velocity, orientation), |s| *s),
    };
    let mut draws = Draws {
        wander: a.wander[i],
        rng: AgentRng::new(v.seed, a.ids[i].0, v.frame, Stream::Steer as u32),
    };
    let total = match profile.steering.combine {
        Combine::WeightedSum => {
            let mut total = Steering::ZERO;
            for w in &profile.steering.behaviours {
                total += evaluate(v, &me, &w.behaviour, &mut draws).scaled(w.weight);
            }
            total
        }
        Combine::Priority => {
            let mut running = adapter.budget(me.max_speed);
            for w in &profile.steering.behaviours {
                let s = evaluate(v, &me, &w.behaviour, &mut draws).scaled(w.weight);
                if !running.push(s) {
                    break;
                }
            }
            running.total()
        }
    };
    (adapter.finish(total), draws.wander, me.sums.count)
}
