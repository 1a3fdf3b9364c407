//! Group movement at scale: 10,000 agents in 100 formations (99 members each, five shapes in
//! turn) whose anchors follow looping paths, stepped on 1 and 2 threads; and the built-in `path`
//! scenario at 10,000 agents.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use throng::group::{FormationParams, FormationShape, Path, PathFollowParams, PathId, SlotParams};
use throng::prelude::*;
use throng::scenario::builtin;

const DT: f32 = 1.0 / 30.0;

/// 100 anchors, each on its own square loop in a 10 x 10 grid of 100-unit cells, and 99 members
/// per anchor keeping formation.
fn formations() -> World {
    let mut b = World::builder().bounds(Bounds::bounded(1000.0, 1000.0).unwrap());
    let mut centres = Vec::new();
    for k in 0..100 {
        let c = Vec2::new(
            50.0 + 100.0 * (k % 10) as f32,
            50.0 + 100.0 * (k / 10) as f32,
        );
        centres.push(c);
        let h = 30.0;
        b = b
            .path(
                Path::new(
                    vec![
                        c + Vec2::new(-h, -h),
                        c + Vec2::new(h, -h),
                        c + Vec2::new(h, h),
                        c + Vec2::new(-h, h),
                    ],
                    1.0,
                    true,
                )
                .unwrap(),
            )
            .group(Profile {
                max_speed: 4.0,
                max_acceleration: 10.0,
                ..Profile::dynamic(SteeringProfile::single(Behaviour::FollowPath {
                    path: PathId(k),
                    params: PathFollowParams::default(),
                }))
            });
    }
    let members = 100;
    b = b.group(Profile {
        max_speed: 8.0,
        max_acceleration: 30.0,
        ..Profile::dynamic(SteeringProfile::single(Behaviour::KeepFormation {
            params: SlotParams::default(),
        }))
    });
    for (k, c) in centres.iter().enumerate() {
        b = b.agent(AgentInit::at(*c + Vec2::new(-30.0, -30.0), k));
    }
    for (k, c) in centres.iter().enumerate() {
        for m in 0..99 {
            let p = *c + Vec2::new((m % 10) as f32 * 2.0 - 10.0, (m / 10) as f32 * 2.0 - 10.0);
            b = b.agent(AgentInit::at(p, members));
        }
        let shape = match k % 5 {
            0 => FormationShape::Line,
            1 => FormationShape::Column,
            2 => FormationShape::Wedge,
            3 => FormationShape::Circle,
            _ => FormationShape::Box,
        };
        let first = 100 + 99 * k as u32;
        b = b.formation(
            AgentId(k as u32),
            FormationParams {
                shape,
                spacing: 1.5,
                offset: Vec2::new(-2.0, 0.0),
                reassign_every: 0,
            },
            (first..first + 99).map(AgentId),
        );
    }
    let mut w = b.build().unwrap();
    for _ in 0..30 {
        w.step(DT).unwrap();
    }
    w
}

fn group(c: &mut Criterion) {
    let mut g = c.benchmark_group("group");
    g.sample_size(20);
    g.throughput(Throughput::Elements(10_000));
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let mut w = formations();
        assert_eq!(w.len(), 10_000);
        g.bench_with_input(
            BenchmarkId::new("formations_100x100", threads),
            &threads,
            |b, _| pool.install(|| b.iter(|| w.step(DT).unwrap())),
        );
        let s = builtin("path").unwrap().with_agents(10_000).unwrap();
        let mut w = s.build().unwrap();
        g.bench_with_input(BenchmarkId::new("path_10k", threads), &threads, |b, _| {
            pool.install(|| b.iter(|| w.step(s.dt).unwrap()))
        });
    }
    // Reassigning every formation's slots (Hungarian method, 99 x 99 each) in one step.
    let mut w = formations();
    g.bench_function("reassign_all_100x99", |b| {
        b.iter(|| {
            for k in 0..100 {
                let f = throng::group::FormationId(k);
                let m = w.formation(f).unwrap().members()[0];
                w.remove_formation_member(f, m).unwrap();
                w.add_formation_member(f, m).unwrap();
            }
            w.step(DT).unwrap()
        })
    });
    g.finish();
}

criterion_group!(benches, group);
criterion_main!(benches);
