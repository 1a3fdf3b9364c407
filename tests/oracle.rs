//! The neighbour oracle (`cargo test --release --features oracle --test oracle`): at every step
//! of a short window of every validation scene (both pedestrian models), every built-in scene
//! and a few worlds built to reach every path of the flocking batch, each model's neighbours as
//! it used them (`throng::oracle`) are those a brute-force pass over the frame-start state finds,
//! by id, the world reordering its agents every frame:
//!
//! - the pedestrian models' lists: exactly the agents within the cut-off, itself excluded;
//! - ORCA's list: the `k` nearest within its neighbour distance (all of them when fewer);
//! - flocking's and every per-agent plan's sums: the counts, and the separation, alignment,
//!   cohesion and repulsion sums over the agents each neighbourhood admits (radius, view cone,
//!   group), itself excluded;
//! - Vicsek's sums: the count and the unit headings within its radius, itself included.
//!
//! Each also read the agent's own frame-start position. This catches the agent-order defect that
//! `World::prepare_index` now prevents: a model steered from copies built for a previous order
//! reads another agent's position and a stale ranking, so it sees itself among its neighbours
//! and misses some that are near. Breaking the pedestrian gather's self-exclusion (the `me` lane
//! filter), or the flocking batch's (`Runs::without_self_run`), fails this test.

use std::collections::{BTreeSet, HashMap, HashSet};

use throng::IndexKind;
use throng::oracle::{Seen, Summed};
use throng::ped::Model;
use throng::prelude::*;
use throng::scenario::{Scenario, builtin, builtin_names};
use throng::steering::NeighbourSums;

#[path = "support/flocks.rs"]
mod flocks;
use flocks::two_flocks;

/// Distances within this share of the cut-off count as ties: either answer is right.
const TIE: f32 = 1e-5;

/// Every validation scene with every group on `model`, and every built-in scene at up to 2,000
/// agents.
fn scenes() -> Vec<(String, Scenario)> {
    let mut out = Vec::new();
    for model in Model::ALL {
        for name in throng::validate::scenario_names() {
            let mut s = throng::validate::scenario(name).unwrap();
            for g in &mut s.groups {
                if let Some(p) = &mut g.params.pedestrian {
                    p.set_model(model);
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

/// What [`check_sums`] says of a record it cannot judge: a neighbour on an edge.
const TIED: &str = "tied";

/// One agent's frame-start state.
#[derive(Clone, Copy)]
struct Agent {
    position: Vec2,
    velocity: Vec2,
    orientation: f32,
    group: u32,
}

impl Agent {
    /// The unit velocity, or the unit orientation at rest (the view cones' and Vicsek's heading).
    fn heading(&self) -> Vec2 {
        self.velocity
            .try_normalize()
            .unwrap_or_else(|| Vec2::from_angle(self.orientation))
    }
}

/// Every agent's frame-start state by id.
fn state(w: &World) -> HashMap<u32, Agent> {
    let a = w.agents();
    (0..a.len())
        .map(|i| {
            let agent = Agent {
                position: a.position(i),
                velocity: a.velocity(i),
                orientation: a.orientations()[i],
                group: a.groups()[i],
            };
            (a.id(i).0, agent)
        })
        .collect()
}

/// Whether `d` lies within `r`, and whether it is a tie (within `TIE` of it).
fn within(d: f32, r: f32) -> (bool, bool) {
    (d <= r, (d - r).abs() <= TIE * r.max(1.0))
}

/// The disagreement of a neighbour list with brute force, if any.
fn check_list(seen: &Seen, at: &HashMap<u32, Agent>, bounds: &Bounds) -> Option<String> {
    let me = at[&seen.agent].position;
    if seen.position != me {
        return Some(format!(
            "agent {} was read at {} instead of {me}",
            seen.agent, seen.position
        ));
    }
    let got: HashSet<u32> = seen.neighbours.iter().copied().collect();
    if got.len() != seen.neighbours.len() {
        return Some(format!("agent {} saw a neighbour twice", seen.agent));
    }
    if got.contains(&seen.agent) {
        return Some(format!("agent {} ({}) saw itself", seen.agent, seen.model));
    }
    if let Some(id) = got.iter().find(|id| !at.contains_key(id)) {
        return Some(format!("agent {} saw agent {id}, absent", seen.agent));
    }
    let r = seen.radius;
    // Everyone else by distance; the ties at the cut-off may go either way.
    let mut others: Vec<(f32, u32, bool)> = at
        .iter()
        .filter(|&(&id, _)| id != seen.agent)
        .map(|(&id, other)| {
            let d = bounds.offset(me, other.position).length();
            let (inside, tie) = within(d, r);
            (d, id, inside || tie)
        })
        .collect();
    others.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
    let near: Vec<(f32, u32)> = others.iter().filter(|o| o.2).map(|o| (o.0, o.1)).collect();
    let sure = |d: f32| !within(d, r).1;
    // Capped at the `k` nearest: the list is as long as it can be, and nobody left out is
    // nearer than the farthest taken (to a tie).
    if let Some(k) = seen.nearest
        && near.len() > k
    {
        let farthest = near
            .iter()
            .filter(|(_, id)| got.contains(id))
            .map(|&(d, _)| d)
            .fold(0.0, f32::max);
        if got.len() != k && sure(near[k].0) {
            return Some(format!(
                "agent {} ({}) saw {} of its {k} nearest",
                seen.agent,
                seen.model,
                got.len()
            ));
        }
        return near
            .iter()
            .find(|(d, id)| !got.contains(id) && *d < farthest - TIE * r.max(1.0))
            .map(|(d, id)| {
                format!(
                    "agent {} ({}) missed agent {id} at {d}, nearer than one it saw at {farthest}",
                    seen.agent, seen.model
                )
            });
    }
    for &(d, id, _) in &others {
        let (inside, tie) = within(d, r);
        if !tie && inside != got.contains(&id) {
            return Some(format!(
                "agent {} ({}) {} agent {id} at {d} (cut-off {r})",
                seen.agent,
                seen.model,
                if inside { "missed" } else { "saw" },
            ));
        }
    }
    None
}

/// The sums brute force finds for `rec`'s agent, and the magnitudes of their terms (for the
/// rounding tolerance); `None` when a neighbour lies on an edge of a neighbourhood (a tie,
/// either answer right).
fn brute_sums(
    rec: &Summed,
    at: &HashMap<u32, Agent>,
    bounds: &Bounds,
) -> Option<(NeighbourSums, [f32; 5])> {
    let me = at[&rec.agent];
    let heading = me.heading();
    let vicsek = rec.model == "vicsek";
    let mut near: Vec<(f32, u32, Vec2)> = Vec::new();
    for (&id, other) in at {
        if id == rec.agent && !vicsek {
            continue;
        }
        let d = bounds.offset(me.position, other.position);
        let dist = d.length();
        let reach = if vicsek {
            rec.vicsek_radius?
        } else {
            rec.query_radius
        };
        let (inside, tie) = within(dist, reach);
        if tie {
            return None;
        }
        if inside {
            near.push((dist, id, d));
        }
    }
    if let Some(k) = rec.cap {
        near.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        let k = k as usize;
        if near.len() > k {
            if (near[k].0 - near[k - 1].0).abs() <= TIE * rec.query_radius.max(1.0) {
                return None;
            }
            near.truncate(k);
        }
    }
    let mut s = NeighbourSums::default();
    let mut mags = [0.0f32; 5];
    for &(dist, id, d) in &near {
        let other = at[&id];
        s.count += 1.0;
        let d2 = dist * dist;
        for (b, hood) in rec.hoods.iter().enumerate() {
            let Some(h) = hood else { continue };
            let (inside, tie) = within(dist, h.radius);
            let dot = heading.dot(d);
            let cone_tie =
                h.view_cos > -1.0 && (dot - h.view_cos * dist).abs() <= 1e-5 * dist.max(1.0);
            if tie || cone_tie {
                return None;
            }
            let sees = inside
                && (!h.same_group || other.group == me.group)
                && (h.view_cos <= -1.0 || dot >= h.view_cos * dist);
            if !sees {
                continue;
            }
            match b {
                0 if d2 > 0.0 => {
                    s.separation -= d / d2;
                    mags[0] += 1.0 / dist;
                }
                0 => {}
                1 => {
                    s.alignment += other.velocity;
                    s.alignment_count += 1.0;
                    mags[1] += other.velocity.length();
                }
                _ => {
                    s.cohesion += d;
                    s.cohesion_count += 1.0;
                    mags[2] += dist;
                }
            }
        }
        if let Some((strength, exponent, radius)) = rec.repulsion {
            let (inside, tie) = within(dist, radius);
            if tie {
                return None;
            }
            if inside && d2 > 0.0 {
                let f = strength / dist.powf(exponent);
                s.repulsion -= d / dist * f;
                mags[3] += f;
            }
        }
        if let Some(r) = rec.vicsek_radius
            && within(dist, r).0
        {
            s.heading += other.heading();
            mags[4] += 1.0;
        }
    }
    Some((s, mags))
}

/// The disagreement of a model's sums with brute force, if any.
fn check_sums(rec: &Summed, at: &HashMap<u32, Agent>, bounds: &Bounds) -> Option<String> {
    let me = at[&rec.agent].position;
    if rec.position != me {
        return Some(format!(
            "agent {} ({}) was read at {} instead of {me}",
            rec.agent, rec.model, rec.position
        ));
    }
    let Some((want, mags)) = brute_sums(rec, at, bounds) else {
        return Some(TIED.to_string());
    };
    let got = &rec.sums;
    let counts = [
        ("count", got.count, want.count),
        ("alignment count", got.alignment_count, want.alignment_count),
        ("cohesion count", got.cohesion_count, want.cohesion_count),
    ];
    let vicsek = rec.model == "vicsek";
    for (what, g, w) in counts {
        if g != w && !(vicsek && what != "count") {
            return Some(format!(
                "agent {} ({}): {what} {g}, brute force {w}",
                rec.agent, rec.model
            ));
        }
    }
    let sums = [
        ("separation", got.separation, want.separation, mags[0]),
        ("alignment", got.alignment, want.alignment, mags[1]),
        ("cohesion", got.cohesion, want.cohesion, mags[2]),
        ("repulsion", got.repulsion, want.repulsion, mags[3]),
        ("heading", got.heading, want.heading, mags[4]),
    ];
    for (what, g, w, mag) in sums {
        if vicsek && what != "heading" {
            continue;
        }
        // Rounding: the terms summed in another order.
        if (g - w).length() > 1e-4 * mag + 1e-5 {
            return Some(format!(
                "agent {} ({}): {what} {g}, brute force {w}",
                rec.agent, rec.model
            ));
        }
    }
    None
}

/// The disagreements between what the models used over the first `steps` steps of `w` and
/// brute force, and the models that recorded.
fn check(name: &str, mut w: World, dt: f32, steps: u64) -> (Vec<String>, BTreeSet<&'static str>) {
    w.set_reorder_every(1);
    let mut failures = Vec::new();
    let mut models = BTreeSet::new();
    let (mut judged, mut tied) = (0usize, 0usize);
    throng::oracle::take();
    throng::oracle::take_sums();
    while w.frame() < steps && failures.is_empty() {
        let at = state(&w);
        let bounds = w.bounds();
        let frame = w.frame();
        w.step(dt).unwrap();
        for seen in throng::oracle::take()
            .iter()
            .filter(|r| sampled(r.agent, frame))
        {
            models.insert(seen.model);
            if let Some(f) = check_list(seen, &at, &bounds) {
                failures.push(format!("{name} frame {frame}: {f}"));
            }
        }
        for rec in throng::oracle::take_sums()
            .iter()
            .filter(|r| sampled(r.agent, frame))
        {
            models.insert(rec.model);
            match check_sums(rec, &at, &bounds) {
                Some(f) if f == TIED => tied += 1,
                Some(f) => failures.push(format!("{name} frame {frame}: {f}")),
                None => judged += 1,
            }
        }
    }
    // Edges are rare: a tolerance that skipped most records would test nothing.
    if tied * 20 > judged {
        failures.push(format!("{name}: {tied} records tied, {judged} judged"));
    }
    failures.truncate(5);
    (failures, models)
}

/// Whether agent `id`'s records at `frame` are checked: a quarter of the agents, another
/// quarter each frame (brute force over every agent is quadratic).
fn sampled(id: u32, frame: u64) -> bool {
    (u64::from(id) + frame).is_multiple_of(4)
}

/// Every model's neighbours, lists and sums, are those brute force finds, at every step of the
/// first 30 of every scene, the world reordering its agents every frame; and every kind of
/// model recorded (a model that stops recording would stop being checked).
#[test]
fn every_model_sees_the_neighbours_brute_force_finds() {
    let mut failures = Vec::new();
    let mut models = BTreeSet::new();
    for (name, s) in scenes() {
        let (f, m) = check(&name, s.build().unwrap(), s.dt, 30);
        failures.extend(f);
        models.extend(m);
    }
    for bounds in [
        Bounds::bounded(60.0, 40.0).unwrap(),
        Bounds::torus(60.0, 40.0).unwrap(),
    ] {
        for (halves, index) in [
            (false, IndexKind::Grid),
            (true, IndexKind::Grid),
            (false, IndexKind::KdTree),
        ] {
            let name = format!("two flocks {bounds:?} halves {halves} {index:?}");
            let mut w = two_flocks(bounds, halves, 3000, false);
            w.set_index(index);
            let (f, m) = check(&name, w, 1.0 / 30.0, 10);
            failures.extend(f);
            models.extend(m);
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    let all = BTreeSet::from(["flocking", "orca", "pedestrian", "summed", "vicsek"]);
    assert_eq!(models, all, "the models that recorded");
}
