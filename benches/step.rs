//! Step throughput of the core behaviours (seek, wander), the Vicsek model and path following at
//! 10,000 and 100,000 agents, on the parallel SIMD path and on the sequential scalar reference.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use throng::World;
use throng::scenario::builtin;

fn world(name: &str, n: usize) -> (World, f32) {
    let s = builtin(name).unwrap().with_agents(n).unwrap();
    let mut w = s.build().unwrap();
    for _ in 0..5 {
        w.step(s.dt).unwrap();
    }
    (w, s.dt)
}

fn step(c: &mut Criterion) {
    let mut g = c.benchmark_group("step");
    g.sample_size(20);
    for name in ["seek", "wander", "vicsek", "path"] {
        for n in [10_000, 100_000] {
            g.throughput(Throughput::Elements(n as u64));
            let (mut w, dt) = world(name, n);
            g.bench_with_input(
                BenchmarkId::new(format!("{name}/parallel"), n),
                &n,
                |b, _| b.iter(|| w.step(dt).unwrap()),
            );
            let (mut w, dt) = world(name, n);
            g.bench_with_input(
                BenchmarkId::new(format!("{name}/sequential"), n),
                &n,
                |b, _| b.iter(|| w.step_sequential(dt).unwrap()),
            );
        }
    }
    g.finish();
}

criterion_group!(benches, step);
criterion_main!(benches);
