//! The `flock` scenario's step at 10,000, 100,000 and 1,000,000 agents on 1 and 2 threads, at the
//! starting density (about 18 neighbours per agent), and the grid, k-d tree and brute-force
//! backends side by side at 20,000.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use throng::scenario::builtin;
use throng::{IndexKind, World};

fn flock(n: usize) -> (World, f32) {
    let s = builtin("flock").unwrap().with_agents(n).unwrap();
    let mut w = s.build().unwrap();
    w.step(s.dt).unwrap();
    (w, s.dt)
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("flock");
    g.sample_size(10);
    for n in [10_000, 100_000, 1_000_000] {
        g.throughput(Throughput::Elements(n as u64));
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let (mut w, dt) = flock(n);
            g.bench_with_input(
                BenchmarkId::new(format!("grid/{threads}t"), n),
                &n,
                |b, _| {
                    b.iter(|| pool.install(|| w.step(dt).unwrap()));
                },
            );
        }
    }
    // The same step on every backend at 20,000 agents, in one run: the grid's SIMD kernel, the
    // scalar traversal over the k-d tree, and the quadratic brute force.
    let n = 20_000;
    g.throughput(Throughput::Elements(n as u64));
    for kind in [IndexKind::Grid, IndexKind::KdTree, IndexKind::Brute] {
        let (mut w, dt) = flock(n);
        w.set_index(kind);
        g.bench_with_input(
            BenchmarkId::new(format!("{}/2t", kind.name()), n),
            &n,
            |b, _| b.iter(|| w.step(dt).unwrap()),
        );
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
