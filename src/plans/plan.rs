//! Group plans: what one profile asks of a step, compiled once.
//!
//! A [`Plan`] is compiled from a [`Profile`] when the world's plans are stale: after a group is
//! added or changed, or after a field, path or formation it may refer to was added. Compiling
//! validates every reference the profile makes (typed errors: [`Error::UnknownField`],
//! [`Error::UnknownGroup`], [`Error::UnknownPath`]), gathers the neighbour sums the profile
//! needs into one [`NeighbourSpec`], builds the model [`Adapter`] and chooses the evaluation
//! path ([`PlanKind`]). The steering pass then never looks at a profile's behaviour list to decide
//! what to do: fast paths are plans, not branches inside the per-agent function.
//!
//! Invariant: every plan of a stepping world was compiled from the current profiles and
//! references, so the per-agent code may index fields, paths and groups without checks failing.

use super::adapter::Adapter;
use super::spec::{ALI, COH, NeighbourSpec, SEP};
use crate::error::{Error, Result};
use crate::field::FollowChannel;
use crate::profile::Profile;
use crate::steering::{Behaviour, Combine, Target};

/// Longest flocking-only profile served by [`PlanKind::Flock`].
pub(crate) const FLOCK_MAX: usize = 4;

/// How the steering pass evaluates the agents of one group.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum PlanKind {
    /// Nothing but separation, alignment and cohesion in a weighted sum: the entries in list
    /// order as `(slot, weight)`. Evaluated in cell batches by the grid kernel when it is ready.
    Flock {
        /// `(slot, weight)` per behaviour, in the profile's order.
        terms: [(u8, f32); FLOCK_MAX],
        /// Entries in use.
        len: u8,
    },
    /// One `follow_field` (or `choose_exit`), alone or followed by `separation`, or by
    /// `separation` then `avoid_walls`, in a weighted sum: a block of lanes at a time
    /// ([`super::follow`]), the separation sums from the cell batch when it runs.
    FollowField {
        /// The field.
        field: usize,
        /// Its channel, or the agent's choice.
        channel: FollowChannel,
        /// The behaviour's weight.
        weight: f32,
        /// The separation term's weight, when the profile has one.
        separation: Option<f32>,
        /// `avoid_walls`' feeler length and weight, when the profile has it.
        walls: Option<(f32, f32)>,
    },
    /// One `seek` of a fixed point, a target slot or each agent's own target alone in a
    /// weighted sum: evaluated eight agents at a time in lanes.
    Seek {
        /// The point sought: a [`Target::Point`], a [`Target::Slot`] (read when the step runs)
        /// or [`Target::Own`].
        target: Target,
        /// Distance at which seeking stops.
        threshold: f32,
        /// The behaviour's weight.
        weight: f32,
    },
    /// One `arrive` at a fixed point, a target slot or each agent's own target alone in a
    /// weighted sum: evaluated eight agents at a time in lanes.
    Arrive {
        /// The point arrived at: a [`Target::Point`], a [`Target::Slot`] (read when the step
        /// runs) or [`Target::Own`].
        target: Target,
        /// Radii and timing.
        params: crate::steering::ArriveParams,
        /// The behaviour's weight.
        weight: f32,
    },
    /// One `wander` alone in a weighted sum: runs of the group's agents evaluated eight at a
    /// time in lanes, without the general loop's dispatch.
    Wander {
        /// The wander circle (dynamic agents).
        params: crate::steering::WanderParams,
        /// The behaviour's weight.
        weight: f32,
    },
    /// One `follow_path` alone in a weighted sum: the behaviour itself per agent, without the
    /// general loop's dispatch (no neighbour sums, no random stream).
    FollowPath {
        /// The path.
        path: crate::group::PathId,
        /// Prediction, lead and direction.
        params: crate::group::PathFollowParams,
        /// The behaviour's weight.
        weight: f32,
    },
    /// One `keep_formation` alone in a weighted sum: the behaviour itself per agent, without
    /// the general loop's dispatch.
    KeepFormation {
        /// Arrival at the slot.
        params: crate::group::SlotParams,
        /// The behaviour's weight.
        weight: f32,
    },
    /// One `vicsek` alone in a weighted sum. Evaluated in cell batches when the grid is ready.
    Vicsek {
        /// The noise width, radians.
        noise: f32,
        /// The behaviour's weight.
        weight: f32,
    },
    /// `follow_leader` of one agent, alone or followed by `separation`, in a weighted sum:
    /// evaluated a block of lanes at a time with the leader resolved once per run
    /// ([`super::leader`]), the separation sums from the cell batch.
    FollowLeader {
        /// The leader.
        leader: crate::agents::AgentId,
        /// The slot and its approach.
        params: crate::group::FollowParams,
        /// The behaviour's weight.
        weight: f32,
        /// The separation term's weight, when the profile has one.
        separation: Option<f32>,
    },
    /// `anti_gravity_seek`, alone or followed by `repulsion`, in a weighted sum: the behaviour
    /// itself per agent, without the general loop's dispatch, the repulsion sums from the cell
    /// batch when it serves them.
    AntiGravitySeek {
        /// The point sought.
        target: Target,
        /// The behaviour's weight.
        weight: f32,
        /// The repulsion term's weight, when the profile has one.
        repulsion: Option<f32>,
    },
    /// The general loop over the profile's behaviours and its combination.
    General,
}

impl PlanKind {
    /// The plan's name, as [`World::last_plans`](crate::World::last_plans) reports it:
    /// `"flock"`, `"follow_field"`, `"seek"`, `"arrive"`, `"wander"`, `"follow_path"`,
    /// `"keep_formation"`, `"vicsek"`, `"follow_leader"`, `"anti_gravity_seek"` or
    /// `"general"`.
    pub(crate) fn name(&self) -> &'static str {
        match self {
            PlanKind::Flock { .. } => "flock",
            PlanKind::FollowField { .. } => "follow_field",
            PlanKind::Seek { .. } => "seek",
            PlanKind::Arrive { .. } => "arrive",
            PlanKind::Wander { .. } => "wander",
            PlanKind::FollowPath { .. } => "follow_path",
            PlanKind::KeepFormation { .. } => "keep_formation",
            PlanKind::Vicsek { .. } => "vicsek",
            PlanKind::FollowLeader { .. } => "follow_leader",
            PlanKind::AntiGravitySeek { .. } => "anti_gravity_seek",
            PlanKind::General => "general",
        }
    }
}

/// What a profile may refer to, as the world has it when plans are compiled.
#[derive(Clone, Debug, Default)]
pub(crate) struct References {
    /// Channels per field.
    pub channels: Vec<usize>,
    /// Number of paths.
    pub paths: usize,
    /// Number of groups.
    pub groups: usize,
    /// Number of target slots.
    pub targets: usize,
}

/// One group's compiled plan.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Plan {
    pub adapter: Adapter,
    pub spec: NeighbourSpec,
    pub kind: PlanKind,
    /// The field and channel of the profile's first `follow_field` or `choose_exit` behaviour.
    pub follow: Option<(usize, FollowChannel)>,
    /// The largest `within` radius of a nearest-agent target per group it looks for.
    pub nearest: Vec<(usize, f32)>,
    /// The group's ORCA filter.
    pub orca: Option<crate::orca::Orca>,
    /// The group's pedestrian model.
    pub pedestrian: Option<crate::ped::Pedestrian>,
}

impl Plan {
    /// Compiles the plan of group `group`'s profile.
    ///
    /// # Errors
    /// [`Error::UnknownField`] for a `follow_field` naming a missing field or channel,
    /// [`Error::UnknownGroup`] for a nearest-agent target of a missing group,
    /// [`Error::UnknownPath`] for a `follow_path` naming a missing path,
    /// [`Error::UnknownTarget`] for a target slot the world does not have,
    /// [`Error::Invalid`] for a `choose_exit` beside another `choose_exit` or `follow_field`.
    pub(crate) fn compile(profile: &Profile, group: usize, refs: &References) -> Result<Plan> {
        let mut nearest: Vec<(usize, f32)> = Vec::new();
        let mut follow = None;
        for w in &profile.steering.behaviours {
            match w.behaviour {
                Behaviour::FollowField { field, channel } => {
                    if refs.channels.get(field).is_none_or(|&n| channel >= n) {
                        return Err(Error::UnknownField {
                            group,
                            field,
                            channel,
                            fields: refs.channels.len(),
                        });
                    }
                    follow.get_or_insert((field, FollowChannel::Fixed(channel)));
                }
                Behaviour::ChooseExit {
                    field,
                    channels,
                    switch_gain,
                } => {
                    let n = refs.channels.get(field).copied().unwrap_or(0);
                    let channel = channels.max().unwrap_or(0);
                    if n == 0 || channel >= n {
                        return Err(Error::UnknownField {
                            group,
                            field,
                            channel,
                            fields: refs.channels.len(),
                        });
                    }
                    follow.get_or_insert((
                        field,
                        FollowChannel::Chosen {
                            channels,
                            switch_gain,
                        },
                    ));
                    // An agent keeps one choice: it cannot serve a second field behaviour.
                    let others = profile
                        .steering
                        .behaviours
                        .iter()
                        .filter(|o| {
                            matches!(
                                o.behaviour,
                                Behaviour::FollowField { .. } | Behaviour::ChooseExit { .. }
                            )
                        })
                        .count();
                    if others > 1 {
                        return Err(Error::Invalid {
                            name: format!("groups[{group}].steering"),
                            reason: "a profile with choose_exit may have no other choose_exit \
                                     or follow_field behaviour (each agent keeps one choice)"
                                .into(),
                        });
                    }
                }
                Behaviour::FollowPath { path, .. } if path.0 as usize >= refs.paths => {
                    return Err(Error::UnknownPath {
                        path: path.0,
                        count: refs.paths,
                    });
                }
                _ => {}
            }
            if let Some(Target::Slot(s)) = w.behaviour.target()
                && s.0 as usize >= refs.targets
            {
                return Err(Error::UnknownTarget {
                    slot: s.0,
                    count: refs.targets,
                });
            }
            if let Some(Target::Nearest { group: g, within }) = w.behaviour.target() {
                if g >= refs.groups {
                    return Err(Error::UnknownGroup {
                        group: g,
                        count: refs.groups,
                    });
                }
                match nearest.iter_mut().find(|(k, _)| *k == g) {
                    Some((_, r)) => *r = r.max(within),
                    None => nearest.push((g, within)),
                }
            }
        }
        let (spec, flock) = neighbour_spec(profile);
        let kind = match flock {
            Some((terms, len)) => PlanKind::Flock { terms, len },
            None => lone_plan(profile, follow)
                .or_else(|| with_separation(profile, &spec, follow))
                .or_else(|| field_with_walls(profile, &spec, follow))
                .or_else(|| anti_gravity_seek(profile))
                .unwrap_or(PlanKind::General),
        };
        Ok(Plan {
            adapter: Adapter::of(profile),
            spec,
            kind,
            follow,
            nearest,
            orca: profile.orca,
            pedestrian: profile.pedestrian,
        })
    }
}

/// The plan of a profile whose only behaviour, in a weighted sum, has a plan of its own
/// (`follow` is the field and channel of its `follow_field` or `choose_exit`), or `None`.
fn lone_plan(profile: &Profile, follow: Option<(usize, FollowChannel)>) -> Option<PlanKind> {
    let [w] = &profile.steering.behaviours[..] else {
        return None;
    };
    if profile.steering.combine != Combine::WeightedSum {
        return None;
    }
    let weight = w.weight;
    // Seek and arrive lanes serve a fixed point, a target slot or each agent's own target.
    let lanes = |t: Target| matches!(t, Target::Point(_) | Target::Slot(_) | Target::Own);
    Some(match w.behaviour {
        Behaviour::FollowField { .. } | Behaviour::ChooseExit { .. } => {
            let (field, channel) = follow?;
            PlanKind::FollowField {
                field,
                channel,
                weight,
                separation: None,
                walls: None,
            }
        }
        Behaviour::Seek { target, threshold } if lanes(target) => PlanKind::Seek {
            target,
            threshold,
            weight,
        },
        Behaviour::Arrive { target, params } if lanes(target) => PlanKind::Arrive {
            target,
            params,
            weight,
        },
        Behaviour::Wander { params } => PlanKind::Wander { params, weight },
        Behaviour::FollowPath { path, params } => PlanKind::FollowPath {
            path,
            params,
            weight,
        },
        Behaviour::KeepFormation { params } => PlanKind::KeepFormation { params, weight },
        Behaviour::Vicsek { noise, .. } => PlanKind::Vicsek { noise, weight },
        _ => return None,
    })
}

/// A weighted-sum profile's lead behaviour, alone or followed by one behaviour that `second`
/// accepts (with that one's weight), or `None`.
fn lead_then(
    profile: &Profile,
    second: impl Fn(&Behaviour) -> bool,
) -> Option<(&crate::steering::Weighted, Option<f32>)> {
    if profile.steering.combine != Combine::WeightedSum {
        return None;
    }
    match &profile.steering.behaviours[..] {
        [lead] => Some((lead, None)),
        [lead, next] if second(&next.behaviour) => Some((lead, Some(next.weight))),
        _ => None,
    }
}

/// The plan of a profile that is one behaviour with a plan of its own for this shape
/// (`follow_leader` of one agent, `follow_field` or `choose_exit`), alone or followed by
/// `separation` the cell batch serves, in a weighted sum, or `None` (`follow` as for
/// [`lone_plan`]).
fn with_separation(
    profile: &Profile,
    spec: &NeighbourSpec,
    follow: Option<(usize, FollowChannel)>,
) -> Option<PlanKind> {
    let (lead, separation) = lead_then(profile, |b| matches!(b, Behaviour::Separation { .. }))?;
    if separation.is_some() && !spec.kernel_ok() {
        return None;
    }
    let weight = lead.weight;
    match lead.behaviour {
        Behaviour::FollowLeader {
            leader: Target::Agent(leader),
            params,
        } => Some(PlanKind::FollowLeader {
            leader,
            params,
            weight,
            separation,
        }),
        Behaviour::FollowField { .. } | Behaviour::ChooseExit { .. } => {
            let (field, channel) = follow?;
            Some(PlanKind::FollowField {
                field,
                channel,
                weight,
                separation,
                walls: None,
            })
        }
        _ => None,
    }
}

/// The plan of a profile that is `anti_gravity_seek`, alone or followed by `repulsion`, in a
/// weighted sum, or `None`.
fn anti_gravity_seek(profile: &Profile) -> Option<PlanKind> {
    let (lead, repulsion) = lead_then(profile, |b| matches!(b, Behaviour::Repulsion { .. }))?;
    let Behaviour::AntiGravitySeek { target } = lead.behaviour else {
        return None;
    };
    Some(PlanKind::AntiGravitySeek {
        target,
        weight: lead.weight,
        repulsion,
    })
}

/// The plan of a profile that is `follow_field` (or `choose_exit`), `separation` the cell batch
/// serves and `avoid_walls`, in that order, in a weighted sum (the shape of a crowd crossing a
/// town), or `None` (`follow` as for [`lone_plan`]).
fn field_with_walls(
    profile: &Profile,
    spec: &NeighbourSpec,
    follow: Option<(usize, FollowChannel)>,
) -> Option<PlanKind> {
    let [lead, sep, avoid] = &profile.steering.behaviours[..] else {
        return None;
    };
    let (Behaviour::Separation { .. }, Behaviour::AvoidWalls { feeler_length }) =
        (&sep.behaviour, &avoid.behaviour)
    else {
        return None;
    };
    if profile.steering.combine != Combine::WeightedSum || !spec.kernel_ok() {
        return None;
    }
    let (field, channel) = follow?;
    matches!(
        lead.behaviour,
        Behaviour::FollowField { .. } | Behaviour::ChooseExit { .. }
    )
    .then_some(PlanKind::FollowField {
        field,
        channel,
        weight: lead.weight,
        separation: Some(sep.weight),
        walls: Some((*feeler_length, avoid.weight)),
    })
}

/// The neighbour spec of a profile (a behaviour listed twice: the last one counts), and its
/// flocking-only terms when the profile is nothing but separation, alignment and cohesion in a
/// weighted sum.
#[allow(clippy::type_complexity)]
fn neighbour_spec(g: &Profile) -> (NeighbourSpec, Option<([(u8, f32); FLOCK_MAX], u8)>) {
    let mut s = NeighbourSpec {
        cos: [-1.0; 3],
        cap: g.max_neighbours,
        ..NeighbourSpec::default()
    };
    let mut terms = [(0u8, 0.0f32); FLOCK_MAX];
    let mut len = 0usize;
    let mut pure = g.steering.combine == Combine::WeightedSum
        && !g.steering.behaviours.is_empty()
        && g.steering.behaviours.len() <= FLOCK_MAX;
    for w in &g.steering.behaviours {
        let (slot, hood) = match &w.behaviour {
            Behaviour::Separation { hood } => (SEP, hood),
            Behaviour::Alignment { hood } => (ALI, hood),
            Behaviour::Cohesion { hood } => (COH, hood),
            Behaviour::Repulsion {
                strength,
                exponent,
                radius,
            } => {
                s.repel = Some((*strength, *exponent, radius * radius));
                s.active = true;
                s.query_r = s.query_r.max(*radius);
                pure = false;
                continue;
            }
            Behaviour::Vicsek { radius, .. } => {
                s.vicsek_r_sq = Some(radius * radius);
                s.active = true;
                s.query_r = s.query_r.max(*radius);
                pure = false;
                continue;
            }
            _ => {
                pure = false;
                continue;
            }
        };
        if pure {
            terms[len] = (slot as u8, w.weight);
            len += 1;
        }
        s.active = true;
        s.on[slot] = true;
        s.r_sq[slot] = hood.radius * hood.radius;
        s.cos[slot] = hood.view_cos;
        s.same[slot] = hood.same_group;
        s.query_r = s.query_r.max(hood.radius);
    }
    (s, pure.then_some((terms, len as u8)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::agents::AgentId;
    use crate::steering::{SteeringProfile, Weighted};

    fn kind_of(behaviours: Vec<Weighted>) -> PlanKind {
        let mut steering = SteeringProfile::single(behaviours[0].behaviour.clone());
        steering.behaviours = behaviours;
        let refs = References {
            channels: vec![1],
            groups: 1,
            ..References::default()
        };
        Plan::compile(&Profile::dynamic(steering), 0, &refs)
            .unwrap()
            .kind
    }

    #[test]
    fn one_behaviour_then_separation_has_a_plan_of_its_own() {
        let lead = Weighted::new(Behaviour::follow_leader(AgentId(4)), 1.5);
        let field = Weighted::new(
            Behaviour::FollowField {
                field: 0,
                channel: 0,
            },
            1.0,
        );
        let sep = Weighted::new(Behaviour::separation(2.0), 0.5);
        let look = Weighted::new(Behaviour::look_where_you_are_going(), 1.0);
        assert!(matches!(
            kind_of(vec![lead.clone(), sep.clone()]),
            PlanKind::FollowLeader {
                leader: AgentId(4),
                weight: 1.5,
                separation: Some(0.5),
                ..
            }
        ));
        assert!(matches!(
            kind_of(vec![lead.clone()]),
            PlanKind::FollowLeader {
                separation: None,
                ..
            }
        ));
        assert!(matches!(
            kind_of(vec![field.clone(), sep.clone()]),
            PlanKind::FollowField {
                field: 0,
                separation: Some(0.5),
                ..
            }
        ));
        // `avoid_walls` after the separation: still the field's plan, with the feelers.
        let walls = Weighted::new(Behaviour::AvoidWalls { feeler_length: 2.0 }, 3.0);
        assert!(matches!(
            kind_of(vec![field.clone(), sep.clone(), walls.clone()]),
            PlanKind::FollowField {
                separation: Some(0.5),
                walls: Some((2.0, 3.0)),
                ..
            }
        ));
        assert_eq!(
            kind_of(vec![field.clone(), walls.clone(), sep.clone()]),
            PlanKind::General
        );
        assert_eq!(
            kind_of(vec![lead.clone(), sep.clone(), walls]),
            PlanKind::General
        );
        // Another order, a third behaviour, or repulsion beside it: the general plan.
        assert_eq!(kind_of(vec![sep.clone(), lead.clone()]), PlanKind::General);
        assert_eq!(
            kind_of(vec![lead.clone(), sep.clone(), look]),
            PlanKind::General
        );
        let repel = Weighted::new(
            Behaviour::Repulsion {
                strength: 1.0,
                exponent: 2.0,
                radius: 2.0,
            },
            1.0,
        );
        assert_eq!(kind_of(vec![field, repel.clone()]), PlanKind::General);
        // Anti-gravity seek, alone or followed by repulsion: its own plan; in another order, the
        // general plan.
        let seek = Weighted::new(
            Behaviour::anti_gravity_seek(Target::Point(glam::Vec2::new(5.0, 1.0))),
            2.0,
        );
        assert!(matches!(
            kind_of(vec![seek.clone(), repel.clone()]),
            PlanKind::AntiGravitySeek {
                weight: 2.0,
                repulsion: Some(1.0),
                ..
            }
        ));
        assert!(matches!(
            kind_of(vec![seek.clone()]),
            PlanKind::AntiGravitySeek {
                repulsion: None,
                ..
            }
        ));
        assert_eq!(kind_of(vec![repel, seek]), PlanKind::General);
    }
}
