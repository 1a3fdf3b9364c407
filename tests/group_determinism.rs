//! The group-movement scenarios (path, leader, formation) give the same bits on 1 and 2 threads,
//! and the parallel step equals the sequential reference, also when formation members leave and
//! join between steps.

use throng::World;
use throng::scenario::builtin;

fn snapshot(w: &World) -> Vec<u32> {
    let a = w.agents();
    a.pos_x()
        .iter()
        .chain(a.pos_y())
        .chain(a.vel_x())
        .chain(a.vel_y())
        .chain(a.orientations())
        .map(|v| v.to_bits())
        .collect()
}

fn run(name: &str, threads: Option<usize>, sequential: bool) -> Vec<u32> {
    let s = builtin(name).unwrap().with_agents(600).unwrap();
    let mut w = s.build().unwrap();
    let go = |w: &mut World| {
        for step in 0..120 {
            if sequential {
                w.step_sequential(s.dt).unwrap();
            } else {
                w.step(s.dt).unwrap();
            }
            // Membership changes between steps (formation scenario only).
            if step == 40 && !w.formations().is_empty() {
                let m = w.formations()[0].members()[1];
                w.remove_agent(m).unwrap();
                let f = throng::group::FormationId(1);
                let leaver = w.formation(f).unwrap().members()[0];
                w.remove_formation_member(f, leaver).unwrap();
                w.add_formation_member(throng::group::FormationId(2), leaver)
                    .unwrap();
            }
        }
    };
    match threads {
        Some(t) => rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .unwrap()
            .install(|| go(&mut w)),
        None => go(&mut w),
    }
    snapshot(&w)
}

#[test]
fn group_scenarios_are_bit_identical_on_1_and_2_threads_and_sequentially() {
    for name in ["path", "leader", "formation"] {
        let one = run(name, Some(1), false);
        let two = run(name, Some(2), false);
        assert!(one == two, "{name}: 1 vs 2 threads differ");
        let seq = run(name, None, true);
        assert!(one == seq, "{name}: parallel vs sequential differ");
    }
}
