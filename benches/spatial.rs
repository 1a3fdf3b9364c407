//! Neighbour-index benches: rebuild and "query all" (every agent's neighbours within r, offsets
//! summed) per backend and N, on a torus at flocking density (about 18 neighbours within r).
//!
//! Brute force is quadratic: its query-all runs at N = 10,000 and 20,000 only, beside the grid
//! and the k-d tree at 20,000 for the grid-vs-brute ratio.

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec2;
use throng::{Bounds, GridIndex, IndexKind, NeighbourIndex, SpatialIndex};

mod support;

const RADIUS: f32 = 1.0;
const SIZES: [usize; 3] = [10_000, 100_000, 1_000_000];

fn setup(n: usize) -> (Bounds, Vec<f32>, Vec<f32>) {
    let bounds = support::flock_world(n, RADIUS, support::FLOCK_NEIGHBOURS);
    let (xs, ys) = support::uniform_points(n, bounds, 0x5eed + n as u64);
    (bounds, xs, ys)
}

fn query_all(index: &SpatialIndex, out: &mut Vec<throng::Neighbour>) -> Vec2 {
    let mut sum = Vec2::ZERO;
    for i in 0..index.len() {
        index.neighbours_of(i, RADIUS, out);
        for nb in out.iter() {
            sum += nb.offset;
        }
    }
    sum
}

fn rebuild(c: &mut Criterion) {
    let mut group = c.benchmark_group("spatial/rebuild");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3));
    for n in SIZES {
        let (bounds, xs, ys) = setup(n);
        group.throughput(Throughput::Elements(n as u64));
        for kind in IndexKind::ALL {
            let mut index = SpatialIndex::new(kind);
            group.bench_with_input(BenchmarkId::new(kind.name(), n), &n, |b, _| {
                b.iter(|| index.rebuild(black_box(&xs), black_box(&ys), bounds, RADIUS));
            });
        }
        // The grid rebuilt from agents already sorted by cell, as after a reorder.
        let mut grid = GridIndex::default();
        grid.rebuild(&xs, &ys, bounds, RADIUS);
        let sx = grid.sorted_x().to_vec();
        let sy = grid.sorted_y().to_vec();
        group.bench_with_input(BenchmarkId::new("grid_presorted", n), &n, |b, _| {
            b.iter(|| grid.rebuild(black_box(&sx), black_box(&sy), bounds, RADIUS));
        });
    }
    group.finish();
}

fn rebuild_threads(c: &mut Criterion) {
    let mut group = c.benchmark_group("spatial/grid_rebuild_threads");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3));
    let n = 1_000_000;
    let (bounds, xs, ys) = setup(n);
    group.throughput(Throughput::Elements(n as u64));
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("a thread pool");
        let mut grid = GridIndex::default();
        group.bench_with_input(
            BenchmarkId::new(format!("{threads}_threads"), n),
            &n,
            |b, _| {
                b.iter(|| {
                    pool.install(|| grid.rebuild(black_box(&xs), black_box(&ys), bounds, RADIUS))
                });
            },
        );
    }
    group.finish();
}

fn query(c: &mut Criterion) {
    let mut group = c.benchmark_group("spatial/query_all");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3));
    for n in [10_000, 20_000, 100_000, 1_000_000] {
        let (bounds, xs, ys) = setup(n);
        group.throughput(Throughput::Elements(n as u64));
        for kind in IndexKind::ALL {
            if kind == IndexKind::Brute && n > 20_000 {
                continue; // quadratic
            }
            let mut index = SpatialIndex::new(kind);
            index.rebuild(&xs, &ys, bounds, RADIUS);
            let mut out = Vec::new();
            group.bench_with_input(BenchmarkId::new(kind.name(), n), &n, |b, _| {
                b.iter(|| query_all(&index, &mut out));
            });
        }
    }
    group.finish();
}

criterion_group!(benches, rebuild, rebuild_threads, query);
criterion_main!(benches);
