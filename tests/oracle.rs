//! The neighbour oracle (`cargo test --release --features oracle --test oracle`): at every step
//! of a short window of every validation scene (both pedestrian models) and every built-in
//! scene, each pedestrian's neighbours as its model gathered them (`throng::oracle`) are exactly
//! the agents within the model's cut-off of its frame-start position, itself excluded, found by
//! brute force over the world's agents, and the position the model read is the agent's own.
//!
//! This catches the agent-order defect that `World::prepare_index` now prevents: a pedestrian
//! steered from copies built for a previous order reads another agent's position and the ids of
//! a stale ranking, so it sees itself among its neighbours and misses some that are near; the
//! recorded position or set differs from the brute-force one at the first step after a reorder.
//! Breaking the gather's self-exclusion (the `me` lane filter) fails this test at every scene.

use std::collections::{HashMap, HashSet};

use throng::ped::Model;
use throng::prelude::*;
use throng::scenario::{Scenario, builtin, builtin_names};

/// Distances within this share of the cut-off count as ties: either answer is right.
const TIE: f32 = 1e-5;

/// Every validation scene with every group on `model`, and every built-in scene at up to 2,000
/// agents.
fn scenes() -> Vec<(String, Scenario)> {
    let mut out = Vec::new();
    for model in [Model::Cfsm, Model::SocialForce] {
        for name in throng::validate::scenario_names() {
            let mut s = throng::validate::scenario(name).unwrap();
            for g in &mut s.groups {
                if let Some(p) = &mut g.params.pedestrian {
                    p.model = model;
                }
            }
            out.push((format!("{name} {model:?}"), s));
        }
    }
    for name in builtin_names() {
        let s = builtin(name).unwrap();
        let s = if s.agent_count() > 2000 {
            s.with_agents(2000).unwrap()
        } else {
            s
        };
        out.push((name.to_string(), s));
    }
    out
}

/// The disagreements between what the models saw over the first `steps` steps of `s` and
/// brute force.
fn check(name: &str, s: &Scenario, steps: u64) -> Vec<String> {
    let mut w = s.build().unwrap();
    w.set_reorder_every(1);
    let mut failures = Vec::new();
    throng::oracle::take();
    while w.frame() < steps && failures.is_empty() {
        let a = w.agents();
        let at: HashMap<u32, Vec2> = (0..a.len()).map(|i| (a.id(i).0, a.position(i))).collect();
        let bounds = w.bounds();
        let frame = w.frame();
        w.step(s.dt).unwrap();
        for seen in throng::oracle::take() {
            let me = at[&seen.agent];
            if seen.position != me {
                failures.push(format!(
                    "{name} frame {frame}: agent {} was read at {} instead of {me}",
                    seen.agent, seen.position
                ));
            }
            let got: HashSet<u32> = seen.neighbours.iter().copied().collect();
            if got.len() != seen.neighbours.len() {
                failures.push(format!(
                    "{name} frame {frame}: agent {} saw a neighbour twice",
                    seen.agent
                ));
            }
            let r = seen.radius;
            for (&id, &p) in &at {
                let d = bounds.offset(me, p).length();
                let tie = (d - r).abs() <= TIE * r.max(1.0);
                let within = id != seen.agent && d <= r;
                if !tie && within != got.contains(&id) {
                    failures.push(format!(
                        "{name} frame {frame} ({}): agent {} {} agent {id} at {d} (cut-off {r})",
                        seen.model,
                        seen.agent,
                        if within { "missed" } else { "saw" },
                    ));
                }
            }
            if let Some(id) = got.iter().find(|id| !at.contains_key(id)) {
                failures.push(format!(
                    "{name} frame {frame}: agent {} saw agent {id}, absent",
                    seen.agent
                ));
            }
        }
    }
    failures.truncate(5);
    failures
}

/// Every pedestrian sees exactly the agents within its model's cut-off, itself excluded, at
/// every step of the first 30 of every scene, the world reordering its agents every frame.
#[test]
fn every_pedestrian_sees_the_neighbours_brute_force_finds() {
    let failures: Vec<String> = scenes()
        .iter()
        .flat_map(|(name, s)| check(name, s, 30))
        .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
