//! Stages and journeys in whole worlds: queues release exactly what is popped, waiting sets hold
//! everyone until deactivated, round robin splits as weighted, routes go round holes, and the
//! outcome depends on neither the agents' storage order nor the thread count.

use throng::journey::{Journey, JourneyId, Stage, StageId, Transition};
use throng::ped::Model;
use throng::prelude::*;
use throng::profile::Profile;

#[path = "support/bits.rs"]
mod bits;

const DT: f32 = 0.01;

/// A world on `wkt` with one pedestrian group of `model`.
fn world(wkt: &str, model: Model) -> World {
    let area = Walkable::from_wkt(wkt).unwrap();
    let mut w = World::builder()
        .bounds(Bounds::Open)
        .seed(7)
        .group(Profile::journey_walkers(model))
        .build()
        .unwrap();
    w.set_walkable(area).unwrap();
    w
}

/// `n` agents on a grid of `spacing` in `[min, max]`, on `journey`.
fn add_grid(
    w: &mut World,
    n: usize,
    min: Vec2,
    max: Vec2,
    spacing: f32,
    journey: JourneyId,
) -> Vec<AgentId> {
    let cols = (((max.x - min.x) / spacing).floor() as usize).max(1);
    let mut ids = Vec::new();
    for k in 0..n {
        let p = min + Vec2::new((k % cols) as f32, (k / cols) as f32) * spacing;
        assert!(p.y <= max.y, "the block holds fewer than {n} agents");
        let id = w.add_agent(AgentInit::at(p, 0)).unwrap();
        w.set_journey(id, journey, None).unwrap();
        ids.push(id);
    }
    ids
}

fn run(w: &mut World, seconds: f32) {
    for _ in 0..(seconds / DT).round() as usize {
        w.step(DT).unwrap();
    }
}

const HALL: &str = "POLYGON ((0 0, 30 0, 30 20, 0 20, 0 0))";

fn waypoint_at(w: &mut World, position: Vec2, distance: f32) -> StageId {
    w.add_stage(Stage::Waypoint { position, distance }).unwrap()
}

fn exit_at(w: &mut World, min: Vec2, max: Vec2) -> StageId {
    w.add_stage(Stage::Exit {
        area: Walkable::rectangle(min, max).unwrap(),
    })
    .unwrap()
}

#[test]
fn a_queue_releases_exactly_the_popped_count() {
    for model in Model::ALL {
        let mut w = world(HALL, model);
        let slots: Vec<Vec2> = (0..10)
            .map(|k| Vec2::new(20.0 - k as f32 * 0.6, 10.0))
            .collect();
        let queue = w.add_stage(Stage::Queue { slots }).unwrap();
        let out = exit_at(&mut w, Vec2::new(28.0, 8.0), Vec2::new(30.0, 12.0));
        let j = w.add_journey(Journey::chain([queue, out])).unwrap();
        add_grid(
            &mut w,
            20,
            Vec2::new(2.0, 6.0),
            Vec2::new(8.0, 14.0),
            1.0,
            j,
        );
        run(&mut w, 40.0);
        let q = w.queue(queue).unwrap();
        assert_eq!(q.occupants.len(), 10, "{model:?}: every slot taken");
        assert_eq!(w.len(), 20, "{model:?}: nobody leaves before a pop");
        w.pop_queue(queue, 3).unwrap();
        run(&mut w, 30.0);
        assert_eq!(w.stage_counts()[out.0 as usize].left, 3, "{model:?}");
        assert_eq!(w.len(), 17, "{model:?}");
        let q = w.queue(queue).unwrap();
        assert_eq!(q.occupants.len(), 10, "{model:?}: those behind moved up");
        w.pop_queue(queue, 4).unwrap();
        run(&mut w, 30.0);
        assert_eq!(w.stage_counts()[out.0 as usize].left, 7, "{model:?}");
        let e = w.pop_queue(queue, 11).unwrap_err().to_string();
        assert!(e.contains("cannot pop 11"), "{e}");
    }
}

/// A waiting set of 30 slots `spacing` apart, filled by 25 pedestrians: how many of them are
/// seated after 60 s, whether all are out 60 s after it is deactivated, and how many left
/// through the exit.
fn waiting_set(spacing: f32) -> (usize, bool, u64) {
    let mut w = world(HALL, Model::Cfsm);
    // Filled from the far side, so that those arriving later need not pass the seated.
    let slots: Vec<Vec2> = (0..30)
        .map(|k| Vec2::new(18.0 - (k / 6) as f32, 6.0 + (k % 6) as f32) * spacing)
        .collect();
    let wait = w
        .add_stage(Stage::WaitingSet {
            slots,
            active: true,
        })
        .unwrap();
    let out = exit_at(&mut w, Vec2::new(28.0, 8.0), Vec2::new(30.0, 12.0));
    let j = w.add_journey(Journey::chain([wait, out])).unwrap();
    add_grid(
        &mut w,
        25,
        Vec2::new(2.0, 6.0),
        Vec2::new(8.0, 14.0),
        1.0,
        j,
    );
    run(&mut w, 60.0);
    assert_eq!(w.len(), 25, "nobody leaves an active waiting set");
    let seated = w.queue(wait).unwrap().occupants.len();
    w.set_waiting_set_active(wait, false).unwrap();
    run(&mut w, 60.0);
    (seated, w.is_empty(), w.stage_counts()[out.0 as usize].left)
}

#[test]
fn a_waiting_set_holds_everyone_until_deactivated() {
    // Slots 1.1 m apart: a pedestrian that walked into the seated block for a slot another
    // took can walk out between any two of them (below).
    let (seated, empty, left) = waiting_set(1.1);
    assert_eq!(seated, 25);
    assert!(empty, "everyone leaves once it is deactivated");
    assert_eq!(left, 25);
}

/// With slots 1 m apart, at this world's seed (7; 1 of seeds 0 to 59), a pedestrian that walked into the seated
/// block for a slot another took must walk back out between two seated ones whose bodies
/// leave a gap of 0.6 m: the speed model's repulsion (JuPedSim's strength 8 and range 0.1 m)
/// turns it back at every approach, and it steps in a cycle of three for good
/// (docs/VALIDATION.md, "The narrow door"; with `path_width = 1` none of the 60 seeds).
#[test]
#[ignore = "a pedestrian cycles at a 0.6 m gap between seated ones (docs/VALIDATION.md)"]
fn a_waiting_set_of_slots_a_metre_apart_seats_everyone() {
    let (seated, empty, _) = waiting_set(1.0);
    assert_eq!(seated, 25);
    assert!(empty);
}

#[test]
fn round_robin_one_to_three_splits_within_ten_percent() {
    let mut w = world(HALL, Model::Cfsm);
    let start = w
        .add_stage(Stage::Waypoint {
            position: Vec2::new(15.0, 10.0),
            distance: 2.0,
        })
        .unwrap();
    let a = exit_at(&mut w, Vec2::new(28.0, 0.0), Vec2::new(30.0, 4.0));
    let b = exit_at(&mut w, Vec2::new(28.0, 16.0), Vec2::new(30.0, 20.0));
    let j = w
        .add_journey(
            Journey::new([start, a, b])
                .with_transition(start, Transition::round_robin([(a, 1), (b, 3)])),
        )
        .unwrap();
    add_grid(
        &mut w,
        400,
        Vec2::new(0.5, 0.5),
        Vec2::new(12.0, 19.5),
        0.55,
        j,
    );
    run(&mut w, 150.0);
    assert_eq!(w.len(), 0, "everyone left");
    let c = w.stage_counts();
    let (la, lb) = (c[a.0 as usize].left as f64, c[b.0 as usize].left as f64);
    assert_eq!(la + lb, 400.0);
    assert!((la / 400.0 - 0.25).abs() <= 0.025, "{la} : {lb}");
}

#[test]
fn least_targeted_balances_two_exits() {
    let mut w = world(HALL, Model::Cfsm);
    let start = w
        .add_stage(Stage::Waypoint {
            position: Vec2::new(6.0, 10.0),
            distance: 3.0,
        })
        .unwrap();
    let a = exit_at(&mut w, Vec2::new(28.0, 0.0), Vec2::new(30.0, 4.0));
    let b = exit_at(&mut w, Vec2::new(28.0, 16.0), Vec2::new(30.0, 20.0));
    let j = w
        .add_journey(
            Journey::new([start, a, b]).with_transition(start, Transition::least_targeted([a, b])),
        )
        .unwrap();
    add_grid(
        &mut w,
        100,
        Vec2::new(3.0, 7.0),
        Vec2::new(9.0, 13.0),
        0.6,
        j,
    );
    run(&mut w, 100.0);
    let c = w.stage_counts();
    let (la, lb) = (c[a.0 as usize].left, c[b.0 as usize].left);
    assert_eq!(la + lb, 100);
    assert!(la.abs_diff(lb) <= 2, "{la} : {lb}");
}

/// A room with a pillar (a hole) between the crowd and the exit: the route goes round it.
const PILLAR: &str = "POLYGON ((0 0, 20 0, 20 10, 0 10, 0 0), (8 2, 12 2, 12 8, 8 8, 8 2))";

#[test]
fn routes_go_round_a_hole_of_the_walkable_area() {
    let mut w = world(PILLAR, Model::Cfsm);
    let out = exit_at(&mut w, Vec2::new(19.0, 4.0), Vec2::new(20.0, 6.0));
    let j = w.add_journey(Journey::chain([out])).unwrap();
    add_grid(&mut w, 12, Vec2::new(1.0, 3.5), Vec2::new(5.0, 6.5), 1.0, j);
    assert!(w.route_cells() > 0);
    run(&mut w, 40.0);
    assert_eq!(w.len(), 0, "everyone found the way round the pillar");
    // Without routes (a straight line at the exit) they press against the pillar.
    let mut straight = World::builder()
        .bounds(Bounds::Open)
        .seed(7)
        .group(Profile::journey_walkers(Model::Cfsm))
        .build()
        .unwrap();
    let area = Walkable::from_wkt(PILLAR).unwrap();
    straight
        .add_polygon(area.polygons()[0].exterior(), true)
        .unwrap();
    straight
        .add_polygon(&area.polygons()[0].holes()[0], true)
        .unwrap();
    let out = exit_at(&mut straight, Vec2::new(19.0, 4.0), Vec2::new(20.0, 6.0));
    let j = straight.add_journey(Journey::chain([out])).unwrap();
    add_grid(
        &mut straight,
        12,
        Vec2::new(1.0, 3.5),
        Vec2::new(5.0, 6.5),
        1.0,
        j,
    );
    run(&mut straight, 40.0);
    assert!(
        !straight.is_empty(),
        "the test's pillar blocks the straight line"
    );
}

#[test]
fn an_exit_is_walked_to_at_its_centre_as_in_jupedsim() {
    // A wide exit area in the hall's upper right, an agent below and left of it: JuPedSim's
    // agents walk at an exit's centroid, so this one enters the area through its west edge
    // near (30, 13), not at its nearest corner (30, 10).
    let mut w = world("POLYGON ((0 0, 40 0, 40 20, 0 20, 0 0))", Model::Cfsm);
    let out = exit_at(&mut w, Vec2::new(30.0, 10.0), Vec2::new(40.0, 20.0));
    let j = w.add_journey(Journey::chain([out])).unwrap();
    let id = w.add_agent(AgentInit::at(Vec2::new(10.0, 5.0), 0)).unwrap();
    w.set_journey(id, j, None).unwrap();
    let mut last = Vec2::ZERO;
    for _ in 0..3000 {
        let Some(a) = w.agent(id) else { break };
        last = a.position;
        w.step(DT).unwrap();
    }
    assert!(w.is_empty(), "the agent left");
    assert!(last.x >= 29.5 && (12.0..14.0).contains(&last.y), "{last}");
}

/// A journey scene with every kind of stage and transition.
fn mixed(reorder_every: u32) -> World {
    let mut w = world(PILLAR, Model::Cfsm);
    w.set_reorder_every(reorder_every);
    let via = w
        .add_stage(Stage::Waypoint {
            position: Vec2::new(10.0, 9.0),
            distance: 0.8,
        })
        .unwrap();
    let slots: Vec<Vec2> = (0..6)
        .map(|k| Vec2::new(15.0 + k as f32 * 0.6, 1.0))
        .collect();
    let queue = w.add_stage(Stage::Queue { slots }).unwrap();
    let a = exit_at(&mut w, Vec2::new(19.0, 4.0), Vec2::new(20.0, 6.0));
    let b = exit_at(&mut w, Vec2::new(19.0, 8.0), Vec2::new(20.0, 10.0));
    let j = w
        .add_journey(
            Journey::new([via, queue, a, b])
                .with_transition(via, Transition::round_robin([(queue, 1), (b, 2)]))
                .with_transition(queue, Transition::least_targeted([a, b])),
        )
        .unwrap();
    add_grid(&mut w, 60, Vec2::new(0.5, 0.5), Vec2::new(7.0, 9.5), 0.7, j);
    w
}

fn run_mixed(w: &mut World) {
    for k in 0..3000 {
        if k % 300 == 299 {
            let held = w.queue(StageId(1)).unwrap().occupants.len();
            w.pop_queue(StageId(1), held.min(2)).unwrap();
        }
        w.step(DT).unwrap();
    }
}

/// Each agent's journey and stage, and each queue's occupants: what the journey system decides.
type Decisions = (Vec<(u32, Option<(JourneyId, StageId)>)>, Vec<Vec<AgentId>>);

fn decisions(w: &World) -> Decisions {
    let mut on: Vec<_> = w
        .agents()
        .ids()
        .iter()
        .map(|&id| (id.0, w.journey_of(id)))
        .collect();
    on.sort_unstable();
    let queues = (0..w.stage_count() as u32)
        .filter_map(|s| w.queue(StageId(s)).ok())
        .map(|q| q.occupants)
        .collect();
    (on, queues)
}

/// The largest distance between the same agent's positions in two states.
fn worst(a: &[(u32, [u32; 4])], b: &[(u32, [u32; 4])]) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|((i, x), (j, y))| {
            assert_eq!(i, j);
            let p = Vec2::new(f32::from_bits(x[0]), f32::from_bits(x[1]));
            let q = Vec2::new(f32::from_bits(y[0]), f32::from_bits(y[1]));
            p.distance(q)
        })
        .fold(0.0, f32::max)
}

#[test]
fn journeys_do_not_depend_on_the_agent_order() {
    // One step from the same saved state in the kept and in a fresh layout, every 100 frames:
    // the same decisions, and positions equal to rounding (the neighbour sums' order may
    // differ; a decision taken in storage order would move agents by centimetres).
    let mut w = mixed(4);
    for k in 0..3000 {
        if k % 300 == 299 {
            let held = w.queue(StageId(1)).unwrap().occupants.len();
            w.pop_queue(StageId(1), held.min(2)).unwrap();
        }
        if k % 100 == 50 {
            let mut bytes = Vec::new();
            w.save(&mut bytes).unwrap();
            let mut kept = World::load(&bytes[..]).unwrap();
            kept.set_reorder_every(0);
            let mut sorted = World::load(&bytes[..]).unwrap();
            sorted.set_reorder_every(1);
            kept.step(DT).unwrap();
            sorted.step(DT).unwrap();
            assert_eq!(decisions(&kept), decisions(&sorted), "frame {k}");
            let d = worst(&bits::by_id(&kept), &bits::by_id(&sorted));
            assert!(d <= 1e-4, "frame {k}: layouts differ by {d} m");
        }
        w.step(DT).unwrap();
    }
    assert!(w.len() < 60 && w.stage_counts()[2].left + w.stage_counts()[3].left > 0);
}

#[test]
fn simultaneous_completions_are_decided_in_id_order_whatever_the_layout() {
    // Forty agents complete a waypoint in the same step, in storage orders that differ (one
    // world kept its insertion order, the other reordered by the grid): the round robin and
    // the least-targeted choice give each id the same next stage in both.
    let decide = |reorder_every: u32| {
        let mut w = world(HALL, Model::Cfsm);
        w.set_reorder_every(reorder_every);
        let start = w
            .add_stage(Stage::Waypoint {
                position: Vec2::new(6.0, 10.0),
                distance: 6.0,
            })
            .unwrap();
        let a = exit_at(&mut w, Vec2::new(28.0, 0.0), Vec2::new(30.0, 4.0));
        let b = exit_at(&mut w, Vec2::new(28.0, 16.0), Vec2::new(30.0, 20.0));
        let c = exit_at(&mut w, Vec2::new(28.0, 8.0), Vec2::new(30.0, 12.0));
        let rr = w
            .add_journey(
                Journey::new([start, a, b, c])
                    .with_transition(start, Transition::round_robin([(a, 1), (b, 2), (c, 1)])),
            )
            .unwrap();
        let lt = w
            .add_journey(
                Journey::new([start, a, b, c])
                    .with_transition(start, Transition::least_targeted([a, b, c])),
            )
            .unwrap();
        // Inserted in a scattered order, so that the grid's order differs from the ids'.
        let mut ids = Vec::new();
        for k in 0..40u32 {
            let m = (k * 17) % 40;
            let p = Vec2::new(3.0 + (m % 8) as f32 * 0.7, 7.5 + (m / 8) as f32 * 0.7);
            ids.push(w.add_agent(AgentInit::at(p, 0)).unwrap());
        }
        w.step(DT).unwrap();
        for (k, &id) in ids.iter().enumerate() {
            w.set_journey(id, if k % 2 == 0 { rr } else { lt }, None)
                .unwrap();
        }
        w.step(DT).unwrap();
        let order: Vec<u32> = w.agents().ids().iter().map(|id| id.0).collect();
        (decisions(&w).0, order)
    };
    let (kept, kept_order) = decide(0);
    let (sorted, sorted_order) = decide(1);
    assert_ne!(
        kept_order, sorted_order,
        "the test needs two storage orders"
    );
    assert!(
        kept.iter().all(|(_, s)| s.unwrap().1 != StageId(0)),
        "all completed at once"
    );
    assert_eq!(kept, sorted);
}

#[test]
fn journeys_give_the_same_bits_on_one_two_and_four_threads_and_after_a_checkpoint() {
    let mut base = mixed(4);
    run_mixed(&mut base);
    let want = bits::by_id(&base);
    for threads in [1, 2, 4] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let mut w = mixed(4);
        pool.install(|| run_mixed(&mut w));
        assert_eq!(bits::by_id(&w), want, "{threads} threads");
    }
    // Saved halfway through (with agents seated and released), resumed: the same bits.
    let mut w = mixed(4);
    let mut resumed = None;
    for k in 0..3000 {
        if k % 300 == 299 {
            let held = w.queue(StageId(1)).unwrap().occupants.len();
            w.pop_queue(StageId(1), held.min(2)).unwrap();
        }
        if k == 1500 {
            let mut bytes = Vec::new();
            w.save(&mut bytes).unwrap();
            resumed = Some(World::load(&bytes[..]).unwrap());
        }
        if let Some(r) = &mut resumed {
            if k % 300 == 299 {
                let held = r.queue(StageId(1)).unwrap().occupants.len();
                r.pop_queue(StageId(1), held.min(2)).unwrap();
            }
            r.step(DT).unwrap();
        }
        w.step(DT).unwrap();
    }
    let r = resumed.unwrap();
    assert_eq!(bits::by_id(&r), want);
    assert_eq!(decisions(&r), decisions(&w));
    assert_eq!(r.stage_counts(), w.stage_counts());
}

/// A crowd of thousands, so that the journey passes' parallel tasks (1,024 agents each) split
/// it: agents complete a waypoint in many steps, and each round robin and least-targeted
/// choice and each target down a route round a hole is the same on the sequential reference
/// step and on two and four threads.
#[test]
fn a_crowd_split_across_tasks_gives_the_sequential_bits_on_two_and_four_threads() {
    let scene = || {
        let mut w = world(
            "POLYGON ((0 0, 60 0, 60 40, 0 40, 0 0), (44 18, 46 18, 46 22, 44 22, 44 18))",
            Model::Cfsm,
        );
        let hall = waypoint_at(&mut w, Vec2::new(48.0, 20.0), 14.0);
        let north = exit_at(&mut w, Vec2::new(56.0, 32.0), Vec2::new(60.0, 40.0));
        let south = exit_at(&mut w, Vec2::new(56.0, 0.0), Vec2::new(60.0, 8.0));
        let rr = w
            .add_journey(
                Journey::new([hall, north, south])
                    .with_transition(hall, Transition::round_robin([(north, 1), (south, 3)])),
            )
            .unwrap();
        let lt = w
            .add_journey(
                Journey::new([hall, north, south])
                    .with_transition(hall, Transition::least_targeted([north, south])),
            )
            .unwrap();
        let ids = add_grid(
            &mut w,
            3000,
            Vec2::new(0.5, 0.5),
            Vec2::new(40.0, 39.5),
            0.7,
            rr,
        );
        for id in ids.into_iter().skip(1).step_by(2) {
            w.set_journey(id, lt, None).unwrap();
        }
        w
    };
    let run = |w: &mut World, sequential: bool| {
        let mut moved_on = Vec::new();
        for _ in 0..400 {
            if sequential {
                w.step_sequential(DT).unwrap();
            } else {
                w.step(DT).unwrap();
            }
            let on_hall = w.stage_counts()[0].targeting;
            moved_on.push(on_hall);
        }
        moved_on
    };
    let mut reference = scene();
    let on_hall = run(&mut reference, true);
    // Agents complete the waypoint in the first step (over a hundred) and in many steps after.
    let steps_with_completions = on_hall.windows(2).filter(|w| w[1] < w[0]).count();
    assert!(steps_with_completions > 20, "{steps_with_completions}");
    assert!(on_hall[0] < 2900 && on_hall[0] > 0 && *on_hall.last().unwrap() < on_hall[0] - 100);
    let want = bits::by_id(&reference);
    for threads in [2, 4] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let mut w = scene();
        pool.install(|| run(&mut w, false));
        assert_eq!(bits::by_id(&w), want, "{threads} threads");
        assert_eq!(decisions(&w), decisions(&reference), "{threads} threads");
    }
}

#[test]
fn bad_stages_and_journeys_are_errors_naming_them() {
    let mut w = world(HALL, Model::Cfsm);
    let e = w
        .add_stage(Stage::Waypoint {
            position: Vec2::new(50.0, 5.0),
            distance: 1.0,
        })
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("stage 0") && e.contains("outside the walkable area"),
        "{e}"
    );
    let e = w
        .add_stage(Stage::Waypoint {
            position: Vec2::new(f32::NAN, 5.0),
            distance: 1.0,
        })
        .unwrap_err()
        .to_string();
    assert!(e.contains("finite"), "{e}");
    let e = w
        .add_stage(Stage::Queue { slots: vec![] })
        .unwrap_err()
        .to_string();
    assert!(e.contains("slots"), "{e}");
    let p = w
        .add_stage(Stage::Waypoint {
            position: Vec2::new(5.0, 5.0),
            distance: 1.0,
        })
        .unwrap();
    let q = w
        .add_stage(Stage::Waypoint {
            position: Vec2::new(9.0, 5.0),
            distance: 1.0,
        })
        .unwrap();
    let cycle = Journey::new([p, q])
        .with_transition(p, Transition::fixed(q))
        .with_transition(q, Transition::fixed(p));
    let e = w.add_journey(cycle).unwrap_err().to_string();
    assert!(e.contains("journey 0") && e.contains("for ever"), "{e}");
    let e = w.add_journey(Journey::chain([p, StageId(9)])).unwrap_err();
    assert!(
        matches!(&e, throng::Error::UnknownJourneyStage { journey, stage: 9, stages: 2 } if journey == "journey 0"),
        "{e}"
    );
    assert_eq!(
        e.to_string(),
        "journey 0 names no stage 9 (the world has 2)"
    );
    let e = w.pop_queue(p, 1).unwrap_err().to_string();
    assert!(e.contains("only a queue"), "{e}");
    let id = w.add_agent(AgentInit::at(Vec2::new(2.0, 2.0), 0)).unwrap();
    let e = w.set_journey(id, JourneyId(3), None).unwrap_err();
    assert!(
        matches!(e, throng::Error::UnknownJourney { journey: 3, .. }),
        "{e}"
    );
    let e = w
        .set_direct_target(id, Vec2::new(f32::INFINITY, 0.0))
        .unwrap_err()
        .to_string();
    assert!(e.contains("finite"), "{e}");
}

/// A walkable area of two parts that do not touch: a journey from one part to the other, or an
/// agent put on a stage of the other part, could never arrive, and ran without a word.
#[test]
fn a_stage_in_a_part_of_the_area_nothing_reaches_is_an_error() {
    let mut w = world(
        "MULTIPOLYGON (((0 0, 15 0, 15 20, 0 20, 0 0)), ((25 0, 40 0, 40 20, 25 20, 25 0)))",
        Model::Cfsm,
    );
    let left = waypoint_at(&mut w, Vec2::new(10.0, 10.0), 2.0);
    let right = exit_at(&mut w, Vec2::new(37.0, 16.0), Vec2::new(40.0, 20.0));
    let e = w
        .add_journey(Journey::chain([left, right]))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("journey 0") && e.contains("stage 1 cannot be reached from stage 0"),
        "{e}"
    );
    let other = Journey::new([left, right])
        .with_transition(left, Transition::round_robin([(left, 1), (right, 1)]));
    assert!(w.add_journey(other).is_err());
    let out_left = exit_at(&mut w, Vec2::new(0.0, 0.0), Vec2::new(2.0, 2.0));
    let j = w.add_journey(Journey::chain([left, out_left])).unwrap();
    let there = w.add_journey(Journey::new([right])).unwrap();
    let a = w.add_agent(AgentInit::at(Vec2::new(5.0, 5.0), 0)).unwrap();
    let e = w.set_journey(a, there, None).unwrap_err().to_string();
    assert!(
        e.contains(&format!("agent {a}")) && e.contains("cannot reach stage 1"),
        "{e}"
    );
    assert_eq!(w.journey_of(a), None);
    w.set_journey(a, j, None).unwrap();
    let b = w.add_agent(AgentInit::at(Vec2::new(30.0, 5.0), 0)).unwrap();
    w.set_journey(b, there, None).unwrap();
    run(&mut w, 20.0);
    assert_eq!(w.len(), 0, "both walked to an exit of their own part");
}

#[test]
fn a_direct_steering_stage_walks_to_the_point_set_from_outside() {
    let mut w = world(HALL, Model::Cfsm);
    let direct = w.add_stage(Stage::DirectSteering).unwrap();
    let j = w.add_journey(Journey::chain([direct])).unwrap();
    let id = w.add_agent(AgentInit::at(Vec2::new(2.0, 2.0), 0)).unwrap();
    w.set_journey(id, j, None).unwrap();
    run(&mut w, 2.0);
    let p = w.agent(id).unwrap().position;
    assert!(
        p.distance(Vec2::new(2.0, 2.0)) < 0.05,
        "no target: it stays"
    );
    w.set_direct_target(id, Vec2::new(10.0, 12.0)).unwrap();
    run(&mut w, 15.0);
    let p = w.agent(id).unwrap().position;
    assert!(p.distance(Vec2::new(10.0, 12.0)) < 0.2, "{p}");
}

#[test]
fn nobody_walks_into_an_agent_driven_from_outside() {
    // A robot of radius 0.4 m crosses the path of forty pedestrians at 0.8 m/s, written from
    // outside every step; they walk round or wait, and it goes exactly where it is put.
    let mut w = world(HALL, Model::Cfsm);
    let out = exit_at(&mut w, Vec2::new(28.0, 8.0), Vec2::new(30.0, 12.0));
    let j = w.add_journey(Journey::chain([out])).unwrap();
    add_grid(
        &mut w,
        40,
        Vec2::new(1.0, 7.0),
        Vec2::new(6.0, 13.0),
        0.8,
        j,
    );
    let mut robot_profile = Profile::kinematic(SteeringProfile::default());
    robot_profile.radius = 0.4;
    let g = w.add_group(robot_profile).unwrap();
    let start = Vec2::new(14.0, 1.0);
    let robot = w.add_agent(AgentInit::at(start, g)).unwrap();
    let v = Vec2::new(0.0, 0.8);
    let mut closest = f32::INFINITY;
    for k in 0..6000 {
        let p = start + v * (k as f32 * DT).min(22.0);
        let p = Vec2::new(p.x, p.y.min(19.0));
        w.set_external(robot, p, v).unwrap();
        w.step(DT).unwrap();
        assert_eq!(w.agent(robot).unwrap().position, p, "step {k}");
        let a = w.agents();
        for i in 0..a.len() {
            if a.id(i) != robot {
                closest = closest.min(a.position(i).distance(p) - a.radii()[i] - 0.4);
            }
        }
    }
    assert!(w.is_external(robot));
    assert_eq!(
        w.stage_counts()[out.0 as usize].left,
        40,
        "everyone passed the robot"
    );
    assert!(closest > -0.05 * 0.6, "overlap of {} m", -closest);
    let e = w
        .set_external(robot, Vec2::new(-5.0, 5.0), Vec2::ZERO)
        .unwrap_err()
        .to_string();
    assert!(e.contains("outside the walkable area"), "{e}");
}

/// A room with doors east and north, each into a short corridor.
const TWO_DOORS: &str =
    "POLYGON ((0 0, 20 0, 20 4, 24 4, 24 6, 20 6, 20 10, 11 10, 11 14, 9 14, 9 10, 0 10, 0 0))";
/// The same room with the east door closed: a wall 5 cm thick parts the room from the corridor
/// beyond the door.
const EAST_CLOSED: &str = "MULTIPOLYGON (((0 0, 20 0, 20 10, 11 10, 11 14, 9 14, 9 10, 0 10, 0 0)), ((20.05 4, 24 4, 24 6, 20.05 6, 20.05 4)))";

#[test]
fn after_a_door_closes_nobody_passes_it() {
    let mut w = world(TWO_DOORS, Model::Cfsm);
    let east = exit_at(&mut w, Vec2::new(23.0, 4.0), Vec2::new(24.0, 6.0));
    let north = exit_at(&mut w, Vec2::new(9.0, 13.0), Vec2::new(11.0, 14.0));
    let to_east = w.add_journey(Journey::chain([east])).unwrap();
    let to_north = w.add_journey(Journey::chain([north])).unwrap();
    let ids = add_grid(
        &mut w,
        80,
        Vec2::new(1.0, 1.0),
        Vec2::new(9.0, 9.0),
        0.7,
        to_east,
    );
    run(&mut w, 14.0);
    // A world with no walkable area has none to switch from; a new area that leaves an agent
    // outside is refused, naming it, and nothing changes.
    let e = w
        .switch_walkable(Walkable::from_wkt("POLYGON ((0 0, 5 0, 5 5, 0 5, 0 0))").unwrap())
        .unwrap_err()
        .to_string();
    assert!(e.contains("stands outside the new area"), "{e}");
    // Refused while someone stands in the new wall's 5 cm: a few steps later it closes.
    let mut tries = 0;
    while w
        .switch_walkable(Walkable::from_wkt(EAST_CLOSED).unwrap())
        .is_err()
    {
        tries += 1;
        assert!(tries < 200, "the doorway never cleared");
        w.step(DT).unwrap();
    }
    let left_east = w.stage_counts()[east.0 as usize].left;
    assert!(left_east > 0, "some left before the door closed");
    // Those in the room turn north; those in the corridor walk on east.
    let a = w.agents();
    let corridor: Vec<AgentId> = (0..a.len())
        .filter(|&i| a.position(i).x > 20.0)
        .map(|i| a.id(i))
        .collect();
    // The room is cut off from the east exit: everyone in it is stranded, in a checkpoint too.
    let mut room: Vec<AgentId> = (0..a.len())
        .filter(|&i| a.position(i).x < 20.0)
        .map(|i| a.id(i))
        .collect();
    room.sort_unstable();
    assert!(!room.is_empty() && !corridor.is_empty());
    assert_eq!(w.stranded_agents(), room);
    let mut bytes = Vec::new();
    w.save(&mut bytes).unwrap();
    assert_eq!(World::load(&bytes[..]).unwrap().stranded_agents(), room);
    for &id in &ids {
        if let Some(s) = w.agent(id)
            && s.position.x < 20.0
        {
            w.set_journey(id, to_north, None).unwrap();
        }
    }
    assert_eq!(w.stranded_agents(), Vec::<AgentId>::new());
    for _ in 0..(120.0 / DT) as usize {
        w.step(DT).unwrap();
        let a = w.agents();
        assert!(
            (0..a.len()).all(|i| a.position(i).x <= 20.0 || corridor.contains(&a.id(i))),
            "someone passed the closed door"
        );
    }
    let c = w.stage_counts();
    assert_eq!(
        c[east.0 as usize].left,
        left_east + corridor.len() as u64,
        "after the door closed, only those beyond it left east"
    );
    assert_eq!(c[east.0 as usize].left + c[north.0 as usize].left, 80);
    // The checkpoint carries the current geometry.
    let mut bytes = Vec::new();
    w.save(&mut bytes).unwrap();
    let back = World::load(&bytes[..]).unwrap();
    assert_eq!(back.walkable(), w.walkable());
}
