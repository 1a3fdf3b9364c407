//! Moving a target slot: the cost of `set_target_point` with 10 and with 100,000 agents seeking
//! the slot (it must not grow with them), and the step of 100,000 agents seeking a slot moved
//! every frame beside the same step with a fixed point.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use throng::prelude::*;
use throng::spawn::{Spawner, agents};

fn world(n: usize) -> (World, TargetSlot) {
    let mut w = World::builder()
        .bounds(Bounds::torus(1000.0, 1000.0).unwrap())
        .build()
        .unwrap();
    let slot = w.add_target(Vec2::splat(500.0)).unwrap();
    let g = w
        .add_group(Profile::kinematic(SteeringProfile::single(
            Behaviour::seek(Target::Slot(slot)),
        )))
        .unwrap();
    let pts = Spawner::new(1)
        .rect(n, Vec2::ZERO, Vec2::splat(999.0))
        .unwrap();
    for a in agents(&pts, g, 0.0, 1) {
        w.add_agent(a).unwrap();
    }
    w.step(1.0 / 30.0).unwrap();
    (w, slot)
}

fn set_target(c: &mut Criterion) {
    let mut group = c.benchmark_group("set_target_point");
    for n in [10usize, 100_000] {
        let (mut w, slot) = world(n);
        let mut k = 0u32;
        group.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| {
                k = k.wrapping_add(1);
                let p = Vec2::new((k % 1000) as f32, 500.0);
                w.set_target_point(slot, std::hint::black_box(p)).unwrap();
            });
        });
    }
    group.finish();

    let mut group = c.benchmark_group("seek_step_100k");
    group.sample_size(20);
    let (mut moving, slot) = world(100_000);
    let mut k = 0u32;
    group.bench_function("slot_moved_every_frame", |b| {
        b.iter(|| {
            k = k.wrapping_add(1);
            moving
                .set_target_point(slot, Vec2::new((k % 1000) as f32, 500.0))
                .unwrap();
            moving.step(1.0 / 30.0).unwrap()
        });
    });
    group.finish();
}

criterion_group!(benches, set_target);
criterion_main!(benches);
