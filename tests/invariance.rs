//! Invariances of the physics: the same scene must move the same way whatever the memory layout
//! the world chooses for its agents (`reorder_every` 0, 1, 4, 16) and whatever order the agents
//! were inserted in (other ids, another storage order).
//!
//! Floating-point sums over neighbours run in the neighbour index's order, which follows the
//! storage order within a cell: another layout may round differently, so trajectories are
//! compared within a tolerance (rounding grows slowly over a short window), never by their bits.
//! A wrong neighbour set (a stale copy read after a reorder) moves agents by centimetres in one
//! step, far beyond that tolerance.

use std::collections::HashMap;

use throng::ped::Model;
use throng::prelude::*;
use throng::scenario::{PlaneMap, Scenario, WorldKind, builtin, builtin_names};

/// Every scenario file of the validation suite.
fn validation_files() -> Vec<(String, Scenario)> {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/validation");
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    files
        .into_iter()
        .map(|p| {
            let name = p.file_stem().unwrap().to_string_lossy().into_owned();
            (name, Scenario::load(&p).unwrap())
        })
        .collect()
}

/// Every built-in scenario at `agents` agents (or its own count when smaller).
fn builtins(agents: usize) -> Vec<(String, Scenario)> {
    builtin_names()
        .into_iter()
        .map(|name| {
            let s = builtin(name).unwrap();
            let s = if s.agent_count() > agents {
                s.with_agents(agents).unwrap()
            } else {
                s
            };
            (name.to_string(), s)
        })
        .collect()
}

/// Positions and velocities by id after `steps` steps of `s` built with `reorder_every`.
fn run(s: &Scenario, reorder_every: u32, steps: usize) -> HashMap<u32, [f32; 4]> {
    let mut w = s.build().unwrap();
    w.set_reorder_every(reorder_every);
    let dt = s.dt;
    for _ in 0..steps {
        w.step(dt).unwrap();
    }
    state(&w)
}

fn state(w: &World) -> HashMap<u32, [f32; 4]> {
    let a = w.agents();
    (0..a.len())
        .map(|i| {
            let (p, v) = (a.position(i), a.velocity(i));
            (a.id(i).0, [p.x, p.y, v.x, v.y])
        })
        .collect()
}

/// The largest difference in position between two runs, over agents present in both, and the
/// number of agents present in one run only.
fn difference(a: &HashMap<u32, [f32; 4]>, b: &HashMap<u32, [f32; 4]>) -> (f32, usize) {
    let mut worst = 0.0_f32;
    let mut unmatched = 0;
    for (id, x) in a {
        match b.get(id) {
            Some(y) => worst = worst.max((x[0] - y[0]).abs().max((x[1] - y[1]).abs())),
            None => unmatched += 1,
        }
    }
    unmatched += b.keys().filter(|id| !a.contains_key(id)).count();
    (worst, unmatched)
}

/// One step from the same state, once in the stored order and once after the world reorders
/// its agents (by the neighbour grid, the field's cells or ORCA's grid, whichever it chooses),
/// at every `stride`-th frame of a run of `steps`: the positions agree to rounding (0.1 mm).
/// Rounding is all another layout may change in one step; a wrong neighbour set moves agents by
/// centimetres. Returns the disagreements.
fn one_step_in_any_layout(name: &str, s: &Scenario, steps: u64, stride: u64) -> Vec<String> {
    let mut w = s.build().unwrap();
    let mut failures = Vec::new();
    while w.frame() < steps {
        if w.frame().is_multiple_of(stride) {
            let mut bytes = Vec::new();
            w.save(&mut bytes).unwrap();
            let mut kept = World::load(&bytes[..]).unwrap();
            kept.set_reorder_every(0);
            let mut sorted = World::load(&bytes[..]).unwrap();
            sorted.set_reorder_every(1);
            kept.step(s.dt).unwrap();
            sorted.step(s.dt).unwrap();
            let (worst, unmatched) = difference(&state(&kept), &state(&sorted));
            if !(worst <= 1e-4 && unmatched == 0) {
                failures.push(format!(
                    "{name}: one step from frame {}: kept and reordered layouts differ by up to \
                     {worst}, {unmatched} agents in one only",
                    w.frame()
                ));
            }
        }
        w.step(s.dt).unwrap();
    }
    failures
}

/// Over a short window from the start, every layout gives the same positions to within
/// `tolerance` (rounding, grown over the window). Returns the disagreements.
fn layouts_agree(name: &str, s: &Scenario, steps: usize, tolerance: f32) -> Vec<String> {
    let reference = run(s, 0, steps);
    let mut failures = Vec::new();
    for every in [1, 4, 16] {
        let other = run(s, every, steps);
        let (worst, unmatched) = difference(&reference, &other);
        if !(worst <= tolerance && unmatched == 0) {
            failures.push(format!(
                "{name}: reorder_every {every} against 0 after {steps} steps: positions differ \
                 by up to {worst}, {unmatched} agents in one run only"
            ));
        }
    }
    failures
}

/// Fails with every disagreement listed.
fn all_agree(failures: Vec<String>) {
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The validation files with every pedestrian group on `model`.
fn validation_with(model: Model) -> Vec<(String, Scenario)> {
    let mut files = validation_files();
    for (_, s) in &mut files {
        for g in &mut s.groups {
            if let Some(p) = &mut g.params.pedestrian {
                p.set_model(model);
            }
        }
    }
    files
}

#[test]
fn one_step_of_every_validation_scene_is_the_same_in_any_layout() {
    let mut failures = Vec::new();
    for model in Model::ALL {
        for (name, s) in validation_with(model) {
            failures.extend(one_step_in_any_layout(
                &format!("{name} {model:?}"),
                &s,
                200,
                9,
            ));
        }
    }
    all_agree(failures);
}

#[test]
fn one_step_of_every_builtin_scene_is_the_same_in_any_layout() {
    all_agree(
        builtins(2000)
            .iter()
            .flat_map(|(name, s)| one_step_in_any_layout(name, s, 40, 7))
            .collect(),
    );
}

/// The social force model is smooth: rounding from another summation order stays below a
/// millimetre over half a second. (The speed model is not: its spacing, blocking and side-step
/// rules switch at thresholds, so a rounding difference of 1e-7 m can flip a decision within a
/// few steps and move an agent by a centimetre; it is held to the one-step test above and to
/// the macroscopic test below.)
#[test]
fn the_social_force_model_moves_alike_in_every_layout_over_a_window() {
    all_agree(
        validation_with(Model::SocialForce)
            .iter()
            .flat_map(|(name, s)| layouts_agree(name, s, 50, 1e-3))
            .collect(),
    );
}

#[test]
fn every_builtin_scene_moves_alike_in_every_layout_over_a_window() {
    all_agree(
        builtins(2000)
            .iter()
            .flat_map(|(name, s)| layouts_agree(name, s, 20, 1e-3))
            .collect(),
    );
}

/// The bottleneck (1.2 m) emptied with `reorder_every` `every`, by `model`, at seed offset
/// `seed`: the time the last pedestrian left, those left inside, and the flow through the
/// entrance (the middle 60% of the first crossings).
fn bottleneck_in_layout(model: Model, every: u32, seed: u64) -> (Option<f64>, usize, f64) {
    let mut s = throng::validate::scenario("bottleneck").unwrap();
    s.world.reorder_every = Some(every);
    let options = throng::validate::Options {
        model: Some(model),
        seed_offset: seed,
        ..Default::default()
    };
    let mut runs = throng::validate::Runs::default();
    let o = throng::validate::Run::new(&mut runs, &options)
        .run(s)
        .unwrap();
    (
        o.evacuation_time,
        o.inside,
        throng::validate::middle_flow(&o.crossings, 0).unwrap(),
    )
}

/// The means over `SEEDS` seeds of the bottleneck's evacuation time and flow with
/// `reorder_every` `every`, and the runs that did not empty.
fn bottleneck_means(model: Model, every: u32) -> (f64, f64, usize) {
    const SEEDS: u64 = 4;
    let (mut t, mut j, mut stuck) = (0.0, 0.0, 0);
    for seed in 0..SEEDS {
        let (time, left, flow) = bottleneck_in_layout(model, every, seed);
        t += time.unwrap_or(f64::NAN) / SEEDS as f64;
        j += flow / SEEDS as f64;
        stuck += usize::from(left > 0);
    }
    (t, j, stuck)
}

/// The bottleneck's mean flow and mean count left inside over `seeds` seeds with
/// `reorder_every` `every`.
fn bottleneck_flow_and_inside(model: Model, every: u32, seeds: u64) -> (f64, f64) {
    let (mut j, mut inside) = (0.0, 0.0);
    for seed in 0..seeds {
        let (_, left, flow) = bottleneck_in_layout(model, every, seed);
        j += flow / seeds as f64;
        inside += left as f64 / seeds as f64;
    }
    (j, inside)
}

/// The long size of the macroscopic test, for the social force model (`--ignored`, about two
/// minutes): its bottleneck does not always empty at 1.2 m, so the flow and the number left
/// inside agree, within 2% of the flow and of the 200 pedestrians. Means over 32 seeds: a
/// single run's flow at 1.2 m lies within about 4% of the mean (1.86, 1.76 and 1.72 1/s at
/// seeds 0 to 2), and means over four and over eight seeds differed between layouts by 2.4%
/// and 2.1%, by chance alone.
#[test]
#[ignore = "long: the social force model's bottleneck over 32 seeds and four layouts"]
fn the_social_force_bottleneck_flows_alike_in_every_layout() {
    let mut failures = Vec::new();
    let model = Model::SocialForce;
    const SEEDS: u64 = 32;
    let (j0, inside0) = bottleneck_flow_and_inside(model, 0, SEEDS);
    for every in [1, 4, 16] {
        let (j, inside) = bottleneck_flow_and_inside(model, every, SEEDS);
        eprintln!(
            "reorder_every {every}: flow {j:.3} against {j0:.3} 1/s, {inside:.2} against \
             {inside0:.2} left inside"
        );
        if !((j / j0 - 1.0).abs() <= 0.02 && (inside - inside0).abs() <= 0.02 * 200.0) {
            failures.push(format!(
                "{model:?}, reorder_every {every}: flow {j:.3} against {j0:.3} 1/s, {inside:.1} \
                 against {inside0:.1} left inside"
            ));
        }
    }
    all_agree(failures);
}

/// The long size of the one-step layout tests (`--ignored`): along the whole of every
/// validation scene's first 2,000 frames (every 97th), both models, and along 200 frames of
/// every built-in scene at up to 20,000 agents (every 37th, past the size at which the passes
/// split into parallel tasks).
#[test]
#[ignore = "long: full-size scenes over long windows"]
fn one_step_of_every_full_size_scene_is_the_same_in_any_layout() {
    let mut failures = Vec::new();
    for model in Model::ALL {
        for (name, s) in validation_with(model) {
            let name = format!("{name} {model:?}");
            failures.extend(one_step_in_any_layout(&name, &s, 2000, 97));
        }
    }
    for (name, s) in builtins(20_000) {
        failures.extend(one_step_in_any_layout(&name, &s, 200, 37));
    }
    all_agree(failures);
}

/// Macroscopic outputs do not depend on the layout: the speed model's bottleneck evacuation
/// time and flow, averaged over four seeds (a single run moves by a few percent with any
/// rounding difference), agree within 2% for every `reorder_every`.
#[test]
fn the_bottleneck_empties_alike_in_every_layout() {
    let mut failures = Vec::new();
    let model = Model::Cfsm;
    let (t0, j0, stuck0) = bottleneck_means(model, 0);
    for every in [1, 4, 16] {
        let (t, j, stuck) = bottleneck_means(model, every);
        if !((t / t0 - 1.0).abs() <= 0.02 && (j / j0 - 1.0).abs() <= 0.02) || stuck + stuck0 > 0 {
            failures.push(format!(
                "{model:?}, reorder_every {every}: evacuation {t:.2} s against {t0:.2} s, flow \
                 {j:.3} against {j0:.3} 1/s, {stuck} and {stuck0} runs not emptied"
            ));
        }
    }
    all_agree(failures);
}

/// `w` with its agents taken out and put back in reverse storage order: new ids, another
/// insertion order, the same agents (position, velocity, orientation, group, radius, maximum
/// and desired speed, target). Returns the new world and, per new id, the old id.
fn relabelled(w: &World) -> (World, HashMap<u32, u32>) {
    let mut bytes = Vec::new();
    w.save(&mut bytes).unwrap();
    let mut out = World::load(&bytes[..]).unwrap();
    let a = w.agents();
    let ids: Vec<AgentId> = a.ids().to_vec();
    for &id in &ids {
        out.remove_agent(id).unwrap();
    }
    let mut map = HashMap::new();
    for i in (0..a.len()).rev() {
        let init = AgentInit {
            position: a.position(i),
            velocity: a.velocity(i),
            orientation: a.orientations()[i],
            rotation: a.rotations()[i],
            group: a.groups()[i] as usize,
            max_speed: Some(a.max_speeds()[i]),
            radius: Some(a.radii()[i]),
            desired_speed: Some(a.desired_speeds()[i]),
        };
        let new = out.add_agent(init).unwrap();
        out.set_target(new, a.target(i)).unwrap();
        map.insert(new.0, a.id(i).0);
    }
    (out, map)
}

/// Agents inserted in another order (so with other ids and another storage order) take the
/// same step: one step from states along each validation scene (speed model and social force
/// model), relabelled or not, agrees to 0.1 mm agent by agent. Scenes whose randomness is keyed
/// by id (pre-movement times) are left out: relabelling changes their draws by design.
#[test]
fn relabelled_agents_take_the_same_step() {
    let mut failures = Vec::new();
    for model in Model::ALL {
        for (name, s) in validation_with(model) {
            if s.groups.iter().any(|g| {
                g.params
                    .pedestrian
                    .as_ref()
                    .is_some_and(|p| p.premovement.is_some())
            }) {
                continue;
            }
            let mut w = s.build().unwrap();
            while w.frame() < 60 {
                if w.frame().is_multiple_of(20) {
                    let (mut other, map) = relabelled(&w);
                    let mut bytes = Vec::new();
                    w.save(&mut bytes).unwrap();
                    let mut same = World::load(&bytes[..]).unwrap();
                    same.step(s.dt).unwrap();
                    other.step(s.dt).unwrap();
                    let theirs: HashMap<u32, [f32; 4]> = state(&other)
                        .into_iter()
                        .map(|(id, v)| (map[&id], v))
                        .collect();
                    let (worst, unmatched) = difference(&state(&same), &theirs);
                    if !(worst <= 1e-4 && unmatched == 0) {
                        failures.push(format!(
                            "{name} {model:?}: one step from frame {}: relabelled agents differ \
                             by up to {worst}, {unmatched} unmatched",
                            w.frame()
                        ));
                    }
                }
                w.step(s.dt).unwrap();
            }
        }
    }
    all_agree(failures);
}

/// The motions every scene is tried under: a translation by (37.25, -12.5), which no grid's
/// cells divide, so agents sit elsewhere in their cells; a quarter turn and a mirror image
/// about the world's centre (a walled or wrapped world turns onto itself only there) or, in an
/// open world, about a point off every grid line. Every number is a multiple of 1/4, so the
/// moved coordinates of a snapped state are exact (see [`snapped`]).
fn motions(s: &Scenario) -> Vec<(&'static str, PlaneMap)> {
    let centre = match s.world.kind {
        WorldKind::Open => Vec2::new(3.5, -1.75),
        _ => s.bounds().unwrap().size().unwrap() * 0.5,
    };
    vec![
        ("translated", PlaneMap::Translate(Vec2::new(37.25, -12.5))),
        ("turned", PlaneMap::Rotate90 { center: centre }),
        ("mirrored", PlaneMap::MirrorX { axis: centre.x }),
    ]
}

/// `p` rounded to a multiple of the power of two `quantum`.
fn snap(p: Vec2, quantum: f32) -> Vec2 {
    (p / quantum).round() * quantum
}

/// The smallest power of two that is at least the spacing of `f32`s at `extent`: multiples of
/// it up to `extent` are exact, and so are their sums and differences within that range.
fn quantum(extent: f32) -> f32 {
    (extent.max(1.0).log2().ceil() - 23.0).exp2()
}

/// Snaps the positions and own targets of `w`'s agents to multiples of a power of two at which
/// they, their images under `map` and the differences between them are exact, so that the moved
/// scene starts from exactly the moved state: no rounding of the inputs, which the speed model's
/// thresholds (and a field's cell edges) would turn into centimetres. The velocities' images
/// (negations, swaps) are exact as they are.
fn snapped(w: &mut World, map: PlaneMap) {
    let a = w.agents();
    let reach = |p: Vec2| p.abs().max(map.point(p).abs()).max_element();
    let (mut far, mut far_target) = (0.0_f32, 0.0_f32);
    for i in 0..a.len() {
        far = far.max(reach(a.position(i)));
        far_target = far_target.max(reach(a.target(i)));
    }
    let (q, qt) = (quantum(2.0 * far), quantum(2.0 * far_target));
    let states: Vec<_> = (0..a.len())
        .map(|i| (a.id(i), a.position(i), a.target(i)))
        .collect();
    for (id, p, t) in states {
        // An agent pushed into a circle stays where it is (a position inside one is refused).
        let _ = w.set_position(id, snap(p, q));
        w.set_target(id, snap(t, qt)).unwrap();
    }
}

/// Gives the agents of `moved` the state of `w`'s agents under `map`: positions (wrapped into
/// `moved`'s world), velocities, own targets; agents gone from `w` leave `moved` too. Returns
/// the agents that could not be placed (inside a circle obstacle, where a position is refused:
/// they keep their own, and are not compared).
fn put_moved(w: &World, moved: &mut World, map: PlaneMap) -> Vec<AgentId> {
    let a = w.agents();
    let gone: Vec<AgentId> = moved
        .agents()
        .ids()
        .iter()
        .copied()
        .filter(|&id| a.index_of(id).is_none())
        .collect();
    for id in gone {
        moved.remove_agent(id).unwrap();
    }
    let bounds = moved.bounds();
    let mut unplaced = Vec::new();
    for i in 0..a.len() {
        let id = a.id(i);
        if moved
            .set_position(id, bounds.wrap(map.point(a.position(i))))
            .is_err()
        {
            unplaced.push(id);
        }
        moved.set_velocity(id, map.vector(a.velocity(i))).unwrap();
        moved.set_target(id, map.point(a.target(i))).unwrap();
    }
    unplaced
}

/// Along the first `steps` frames of `s`, the scene moved by `map` (built from the moved
/// scenario, its agents given the original's state, moved, before every step) takes the moved
/// step to `tolerance` (0.1 mm in CI), agent by agent. Returns the disagreements, or why the
/// scene cannot be moved.
fn moved_scene_takes_the_moved_step(
    name: &str,
    s: &Scenario,
    (motion, map): (&str, PlaneMap),
    steps: u64,
    tolerance: f32,
) -> std::result::Result<Vec<String>, String> {
    let moved = s
        .transformed(map)
        .map_err(|e| format!("{name} {motion}: {e}"))?;
    let mut w = s.build().unwrap();
    let mut m = moved.build().unwrap();
    let bounds = m.bounds();
    let mut failures = Vec::new();
    while w.frame() < steps {
        snapped(&mut w, map);
        let unplaced = put_moved(&w, &mut m, map);
        w.step(s.dt).unwrap();
        m.step(s.dt).unwrap();
        let (a, b) = (w.agents(), m.agents());
        let mut worst = (0.0_f32, None);
        let mut unmatched = b.len().abs_diff(a.len());
        for i in 0..a.len() {
            match b.index_of(a.id(i)) {
                Some(_) if unplaced.contains(&a.id(i)) => {}
                Some(j) => {
                    let d = bounds
                        .offset(bounds.wrap(map.point(a.position(i))), b.position(j))
                        .abs()
                        .max_element();
                    if d > worst.0 || d.is_nan() {
                        worst = (d, Some(a.id(i).0));
                    }
                }
                None => unmatched += 1,
            }
        }
        if !(worst.0 <= tolerance && unmatched == 0) {
            failures.push(format!(
                "{name} {motion}: the step to frame {}: moved by up to {} (agent {:?}), {unmatched} \
                 agents in one only",
                w.frame(),
                worst.0,
                worst.1
            ));
            break;
        }
    }
    Ok(failures)
}

/// Scenes and motions that do not take the moved step, as measured (the first step that
/// differs and by how much), so that any other disagreement fails: `(scene name prefix,
/// motion, what is known)`. Each is an open question or a model's own handedness, not a
/// tolerance.
const NOT_INVARIANT: &[(&str, &str, &str)] = &[
    (
        "wander",
        "turned",
        "wander's per-agent wander point is state the test cannot move (0.38 m at the first step)",
    ),
    ("wander", "mirrored", "as turned (0.53 m)"),
    (
        "vicsek",
        "mirrored",
        "the noise angle is drawn with a sense of rotation a mirror reverses (0.29 m)",
    ),
    (
        "circle",
        "turned",
        "ORCA from an exactly symmetric start: 1.7 cm at the first step, open",
    ),
    ("circle", "mirrored", "as turned (2.4 cm), open"),
    (
        "crossing",
        "turned",
        "ORCA: 0.35 mm at the first step, open",
    ),
    (
        "crossing",
        "mirrored",
        "ORCA: 0.50 mm at the first step, open",
    ),
    (
        "rimea-15-short Cfsm",
        "mirrored",
        "1.5 cm at the first step (speed model): the quickest paths' descent takes the +x side \
         of a ridge where both sides are equally near, so the mirrored crowd walks unmirrored; \
         open (docs/VALIDATION.md)",
    ),
    (
        "rimea-15-long Cfsm",
        "mirrored",
        "1.4 cm at the first step (speed model), as rimea-15-short; open",
    ),
    (
        "rimea-06-corner Cfsm",
        "turned",
        "0.12 mm at frame 28, not traced, open",
    ),
    (
        "exp-t-junction Cfsm",
        "translated",
        "0.13 mm at frame 8, open",
    ),
];

/// Every scene in `scenes` under every motion of [`motions`], each step within `tolerance`:
/// the disagreements, and the scenes and motions left out (they cannot be moved, or are in
/// [`NOT_INVARIANT`]) with the reason. At the sharp tolerance (0.1 mm) a listed scene that
/// takes the moved step fails too, so that the list stays true.
fn moved_scenes(
    scenes: &[(String, Scenario)],
    steps: u64,
    tolerance: f32,
) -> (Vec<String>, Vec<String>) {
    let (mut failures, mut left_out) = (Vec::new(), Vec::new());
    for (name, s) in scenes {
        for (motion, map) in motions(s) {
            let known = NOT_INVARIANT
                .iter()
                .find(|(scene, m, _)| name.starts_with(scene) && *m == motion);
            match (
                moved_scene_takes_the_moved_step(name, s, (motion, map), steps, tolerance),
                known,
            ) {
                (Ok(f), None) => failures.extend(f),
                (Ok(f), Some((_, _, why))) if !f.is_empty() => {
                    left_out.push(format!("{} (known: {why})", f.join("; ")));
                }
                (Ok(_), Some(_)) if tolerance <= SHARP => failures.push(format!(
                    "{name} {motion}: listed as not invariant, but takes the moved step"
                )),
                (Ok(_), Some(_)) => {}
                (Err(why), _) => left_out.push(why),
            }
        }
    }
    (failures, left_out)
}

/// The moved step's tolerance over the first 30 frames: rounding alone.
const SHARP: f32 = 1e-4;

/// The moved step's tolerance over long windows. The scene's own geometry (walls, exits, the
/// field's origin) is moved in `f32`, which rounds its coordinates by up to 4e-6 m at 50 m, and
/// the density raster of the quickest paths bins agents into half-open cells, which a mirror or
/// a turn does not map onto themselves for an agent on a cell's edge. Over hundreds of frames
/// some pedestrian comes to stand where such a difference flips one of the speed model's
/// thresholds (spacing, blocking, side step) or changes a social force contact, and moves by
/// millimetres in that one step (measured: up to 5.6 mm over 300 frames of every validation
/// scene, rimea-12 mirrored with the social force model). A term not moved with the scene (a
/// wall left behind) moves agents by centimetres within a few frames.
const LONG: f32 = 1e-2;

/// [`moved_scenes`] over every validation scene with both pedestrian models, the scenes left
/// out printed.
fn moved_validation_scenes(steps: u64, tolerance: f32) -> Vec<String> {
    let mut failures = Vec::new();
    for model in Model::ALL {
        let scenes: Vec<_> = validation_with(model)
            .into_iter()
            .map(|(name, s)| (format!("{name} {model:?}"), s))
            .collect();
        failures.extend(printed(moved_scenes(&scenes, steps, tolerance)));
    }
    failures
}

/// The failures, after printing the scenes left out.
fn printed((failures, left_out): (Vec<String>, Vec<String>)) -> Vec<String> {
    for why in left_out {
        eprintln!("left out: {why}");
    }
    failures
}

/// A scene translated, turned a quarter or mirrored takes the same step, moved: one step from
/// the same state (the original's, moved) agrees to 0.1 mm agent by agent at each of the first
/// 30 frames of every validation scene, with both pedestrian models. Neighbour grids, the
/// field's raster (its origin moves with the scene) and the walls' broad phase all see other
/// coordinates; a term that is not moved with the scene (a wall left behind, a goal, an axis
/// written into a model) moves agents by centimetres. Scenes that cannot be moved are listed
/// (see `Scenario::transformed`): the test fails only on disagreements.
#[test]
fn every_validation_scene_moves_alike_translated_turned_and_mirrored() {
    all_agree(moved_validation_scenes(30, SHARP));
}

/// [`every_validation_scene_moves_alike_translated_turned_and_mirrored`] for the built-in
/// scenes (flocking, Vicsek, ORCA, fields, group movement) at up to 2,000 agents.
#[test]
fn every_builtin_scene_moves_alike_translated_turned_and_mirrored() {
    all_agree(printed(moved_scenes(&builtins(2000), 30, SHARP)));
}

/// The long size of the moved-scene tests (`--ignored`): 300 frames of every validation scene
/// (both models) and 100 of every built-in scene at up to 20,000 agents, each moved step within
/// [`LONG`].
#[test]
#[ignore = "long: moved scenes over long windows"]
fn every_full_size_scene_moves_alike_translated_turned_and_mirrored() {
    let mut failures = moved_validation_scenes(300, LONG);
    failures.extend(printed(moved_scenes(&builtins(20_000), 100, LONG)));
    all_agree(failures);
}
