//! Pedestrian model parameters of single agents (`World::set_agent_model_params`): every agent
//! given the same parameters of its own walks exactly as a group with those parameters does, on
//! any thread count and through a checkpoint; bad parameters, ids and models are errors that
//! change nothing.

use throng::ped::{Cfsm, ModelParams, SocialForce};
use throng::prelude::*;
use throng::scenario::{Scenario, builtin};

#[path = "support/bits.rs"]
mod bits;

/// The built-in corridor with 400 pedestrians walking by the speed model.
fn corridor() -> Scenario {
    builtin("corridor").unwrap().with_agents(400).unwrap()
}

/// The speed model with a longer time gap than the default.
fn patient() -> ModelParams {
    ModelParams::Cfsm(Cfsm {
        time_gap: 1.1,
        strength_neighbour: 6.0,
        ..Cfsm::default()
    })
}

fn steps(w: &mut World, dt: f32, n: usize) {
    for _ in 0..n {
        w.step(dt).unwrap();
    }
}

/// The corridor with every agent given `params` of its own.
fn each_own(s: &Scenario, params: ModelParams) -> World {
    let mut w = s.build().unwrap();
    let ids: Vec<AgentId> = (0..w.len()).map(|i| w.agents().id(i)).collect();
    for id in ids {
        w.set_agent_model_params(id, Some(params)).unwrap();
    }
    w
}

#[test]
fn every_agents_own_parameters_walk_as_the_groups_would() {
    let s = corridor();
    let mut group = s.clone();
    for g in &mut group.groups {
        g.params.pedestrian.as_mut().unwrap().params = patient();
    }
    let mut by_group = group.build().unwrap();
    let mut own = each_own(&s, patient());
    let mut plain = s.build().unwrap();
    for w in [&mut by_group, &mut own, &mut plain] {
        steps(w, s.dt, 300);
    }
    assert_eq!(bits::by_id(&own), bits::by_id(&by_group));
    assert_ne!(bits::by_id(&own), bits::by_id(&plain));
    let id = own.agents().id(7);
    assert_eq!(own.agent_model_params(id).unwrap(), Some(patient()));
    assert_eq!(
        plain.agent_model_params(id).unwrap(),
        Some(ModelParams::Cfsm(Cfsm::default()))
    );
}

#[test]
fn one_agents_own_parameters_move_it_alone_and_none_takes_them_back() {
    let s = corridor();
    let mut plain = s.build().unwrap();
    let mut one = s.build().unwrap();
    let id = one.agents().id(0);
    one.set_agent_model_params(id, Some(patient())).unwrap();
    let mut back = s.build().unwrap();
    back.set_agent_model_params(id, Some(patient())).unwrap();
    back.set_agent_model_params(id, None).unwrap();
    // One step: only the agent itself can differ yet.
    for w in [&mut plain, &mut one, &mut back] {
        steps(w, s.dt, 1);
    }
    let (p, o) = (bits::by_id(&plain), bits::by_id(&one));
    let differ: Vec<usize> = (0..p.len()).filter(|&k| p[k] != o[k]).collect();
    assert!(!differ.is_empty() && differ.len() <= 1, "{differ:?}");
    assert_eq!(bits::by_id(&back), p);
}

#[test]
fn own_parameters_give_the_same_bits_on_one_and_two_threads_and_through_a_checkpoint() {
    let s = corridor();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let mut w = each_own(&s, patient());
        pool.install(|| steps(&mut w, s.dt, 200));
        bits::by_id(&w)
    };
    let one = run(1);
    assert_eq!(one, run(2));

    let mut w = each_own(&s, patient());
    steps(&mut w, s.dt, 100);
    let mut bytes = Vec::new();
    w.save(&mut bytes).unwrap();
    let mut back = World::load(bytes.as_slice()).unwrap();
    assert_eq!(
        back.agent_model_params(back.agents().id(3)).unwrap(),
        Some(patient())
    );
    steps(&mut w, s.dt, 100);
    steps(&mut back, s.dt, 100);
    assert_eq!(bits::by_id(&back), bits::by_id(&w));
    assert_eq!(bits::by_id(&w), one);
}

#[test]
fn bad_parameters_ids_and_models_are_errors_that_change_nothing() {
    let s = corridor();
    let mut w = s.build().unwrap();
    let id = w.agents().id(0);
    let before = w.agent_model_params(id).unwrap();
    let nan = ModelParams::Cfsm(Cfsm {
        time_gap: f32::NAN,
        ..Cfsm::default()
    });
    let e = w.set_agent_model_params(id, Some(nan)).unwrap_err();
    assert!(e.to_string().contains("time_gap"), "{e}");
    let other = ModelParams::SocialForce(SocialForce::default());
    let e = w.set_agent_model_params(id, Some(other)).unwrap_err();
    assert!(e.to_string().contains("social_force"), "{e}");
    let e = w
        .set_agent_model_params(AgentId(1_000_000), Some(patient()))
        .unwrap_err();
    assert!(matches!(e, throng::Error::UnknownAgent { .. }), "{e}");
    assert!(w.agent_model_params(AgentId(1_000_000)).is_err());
    assert_eq!(w.agent_model_params(id).unwrap(), before);

    // An agent of a group with no pedestrian model has no model parameters.
    let mut flock = builtin("flock")
        .unwrap()
        .with_agents(10)
        .unwrap()
        .build()
        .unwrap();
    let bird = flock.agents().id(0);
    assert_eq!(flock.agent_model_params(bird).unwrap(), None);
    let e = flock
        .set_agent_model_params(bird, Some(patient()))
        .unwrap_err();
    assert!(e.to_string().contains("no pedestrian model"), "{e}");
}
