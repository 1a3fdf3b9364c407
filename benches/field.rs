//! Field builds (BFS potential, Dijkstra integration, flow) at 512^2, 2048^2 and 4096^2 cells
//! with 4 goals (fresh, and `_rebuild`: in place reusing the buffers; `_reference`: the literal
//! reference BFS, at 2048^2 only), flow-field sampling for 100,000 points, and one `World::step` of the
//! `fields-large` scenario (100,000 agents following a 2048^2 flow field) on 1 and 2 threads.
//!
//! Grids: 512^2 is a cave (drunkard's walk, 50% obstacles, connected); the larger ones are open
//! ground with 20% scattered obstacles (the free space is one large component).

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec2;
use throng::field::{
    FlowField, IntegrationField, Neighbourhood, OccupancyGrid, PotentialField, random_free_cells,
};

fn grid(side: u32) -> OccupancyGrid {
    if side <= 512 {
        OccupancyGrid::caves(side, side, 0.5, 1).unwrap()
    } else {
        OccupancyGrid::scattered(side, side, 0.2, 1).unwrap()
    }
}

fn builds(c: &mut Criterion) {
    let mut g = c.benchmark_group("field_build");
    g.sample_size(10);
    for side in [512u32, 2048, 4096] {
        let grid = grid(side);
        let goals = random_free_cells(&grid, 4, 2).unwrap();
        g.throughput(Throughput::Elements(u64::from(side) * u64::from(side)));
        for (name, n) in [
            ("bfs4", Neighbourhood::Four),
            ("bfs8", Neighbourhood::Eight),
        ] {
            g.bench_with_input(BenchmarkId::new(name, side), &side, |b, _| {
                b.iter(|| PotentialField::bfs(&grid, black_box(&goals), 0.99, n).unwrap())
            });
            // In place, as goal channels rebuild: the field's buffers are reused.
            let mut field = PotentialField::bfs(&grid, &goals, 0.99, n).unwrap();
            g.bench_with_input(
                BenchmarkId::new(format!("{name}_rebuild"), side),
                &side,
                |b, _| b.iter(|| field.rebuild(&grid, black_box(&goals)).unwrap()),
            );
            if side == 2048 {
                g.bench_with_input(
                    BenchmarkId::new(format!("{name}_reference"), side),
                    &side,
                    |b, _| {
                        b.iter(|| {
                            PotentialField::bfs_reference(&grid, black_box(&goals), 0.99, n)
                                .unwrap()
                        })
                    },
                );
            }
        }
        g.bench_with_input(BenchmarkId::new("dijkstra8", side), &side, |b, _| {
            b.iter(|| {
                IntegrationField::dijkstra(&grid, black_box(&goals), Neighbourhood::Eight, None)
                    .unwrap()
            })
        });
        let field = PotentialField::bfs(&grid, &goals, 0.99, Neighbourhood::Eight).unwrap();
        g.bench_with_input(BenchmarkId::new("flow_from_bfs8", side), &side, |b, _| {
            b.iter(|| FlowField::from_potential(black_box(&field)))
        });
        let mut flow = FlowField::from_potential(&field);
        g.bench_with_input(
            BenchmarkId::new("flow_from_bfs8_rebuild", side),
            &side,
            |b, _| b.iter(|| flow.rebuild_from_potential(black_box(&field))),
        );
    }
    g.finish();
}

fn sampling(c: &mut Criterion) {
    let grid = grid(2048);
    let goals = random_free_cells(&grid, 4, 2).unwrap();
    let flow = FlowField::from_potential(
        &PotentialField::bfs(&grid, &goals, 0.99, Neighbourhood::Eight).unwrap(),
    );
    // 100,000 points spread over the grid by a fixed low-discrepancy sequence.
    let points: Vec<Vec2> = (0..100_000u32)
        .map(|i| {
            Vec2::new(
                (i as f32 * 0.618_034).fract(),
                (i as f32 * 0.754_878).fract(),
            ) * 2048.0
        })
        .collect();
    let mut g = c.benchmark_group("flow_sample");
    g.throughput(Throughput::Elements(points.len() as u64));
    g.bench_function("100k_points_2048", |b| {
        b.iter(|| {
            points
                .iter()
                .fold(Vec2::ZERO, |acc, &p| acc + flow.sample(black_box(p)))
        })
    });
    g.finish();
}

/// The `fields-large` world (2048^2 tunnels, 4 goals, 100,000 agents) with `follow_field` as
/// the only behaviour, stepped once so that its field is built. Every iteration steps the same
/// world on (agents keep walking towards the goals). The scenario's periodic goal shuffle is off:
/// this measures following a field, and the builds have benches of their own.
fn following_world() -> throng::World {
    let mut s = throng::scenario::builtin("fields-large").unwrap();
    if let Some(f) = s.field.as_mut() {
        f.shuffle_every = 0;
    }
    s.groups[0]
        .params
        .steering
        .behaviours
        .retain(|w| w.behaviour.name() == "follow_field");
    let mut world = s.build().unwrap();
    world.step(s.dt).unwrap();
    world
}

fn following(c: &mut Criterion) {
    let mut g = c.benchmark_group("follow");
    g.sample_size(20);
    g.throughput(Throughput::Elements(100_000));
    for threads in [1usize, 2] {
        // A fresh world for each thread count, so both measure the same stretch of the walk.
        let mut world = following_world();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        g.bench_function(BenchmarkId::new("follow/100000", threads), |b| {
            b.iter(|| pool.install(|| world.step(1.0 / 30.0).unwrap()))
        });
    }
    g.finish();
}

criterion_group!(benches, builds, sampling, following);
criterion_main!(benches);
