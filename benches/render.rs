//! Rendering speed: drawing a frame of 50,000 agents into an 800 x 800 canvas (as triangles and as
//! dots), drawing a heat map, and encoding one such frame as GIF (streamed to a file) and PNG.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec2;
use throng::render::{Canvas, GifRecorder, HeatMap, Scene, Viewport, draw_scene, write_png};

const AGENTS: usize = 50_000;
const SIDE: u32 = 800;
const WORLD: f32 = 400.0;

/// Deterministic pseudo-random numbers in [0, 1) (SplitMix64), so every run draws the same frame.
fn uniform(seed: u64) -> impl FnMut() -> f32 {
    let mut state = seed;
    move || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
}

struct Agents {
    xs: Vec<f32>,
    ys: Vec<f32>,
    orientations: Vec<f32>,
    groups: Vec<u32>,
}

fn agents() -> Agents {
    let mut r = uniform(7);
    let xs = (0..AGENTS).map(|_| r() * WORLD).collect();
    let ys = (0..AGENTS).map(|_| r() * WORLD).collect();
    let orientations = (0..AGENTS).map(|_| r() * std::f32::consts::TAU).collect();
    let groups = (0..AGENTS).map(|i| (i % 4) as u32).collect();
    Agents {
        xs,
        ys,
        orientations,
        groups,
    }
}

fn scene<'a>(a: &'a Agents, radii: &'a [f32]) -> Scene<'a> {
    Scene {
        xs: &a.xs,
        ys: &a.ys,
        orientations: &a.orientations,
        groups: &a.groups,
        radii,
        ..Scene::default()
    }
}

fn bench_render(c: &mut Criterion) {
    let a = agents();
    let mut canvas = Canvas::new(SIDE, SIDE).unwrap();
    let vp = Viewport::fit(Vec2::ZERO, Vec2::splat(WORLD), &canvas).unwrap();
    // At 2 px per world unit: radius 0.75 draws 3 px triangles, radius 0.25 (1 px) draws dots.
    let triangles = vec![0.75_f32; AGENTS];
    let dots = vec![0.25_f32; AGENTS];

    // The same agents in cell order (rows of 4 world units, then x), as a world that reorders
    // its agents by grid cell stores them: neighbouring agents touch neighbouring memory.
    let sorted = {
        let mut order: Vec<usize> = (0..AGENTS).collect();
        order.sort_by(|&i, &j| {
            let key = |k: usize| ((a.ys[k] / 4.0) as u32, a.xs[k]);
            key(i).partial_cmp(&key(j)).unwrap()
        });
        Agents {
            xs: order.iter().map(|&i| a.xs[i]).collect(),
            ys: order.iter().map(|&i| a.ys[i]).collect(),
            orientations: order.iter().map(|&i| a.orientations[i]).collect(),
            groups: order.iter().map(|&i| a.groups[i]).collect(),
        }
    };

    let mut g = c.benchmark_group("render_draw");
    g.throughput(Throughput::Elements(AGENTS as u64));
    for (name, radii) in [("triangles", &triangles), ("dots", &dots)] {
        g.bench_with_input(BenchmarkId::new(name, AGENTS), radii, |b, radii| {
            b.iter(|| draw_scene(&mut canvas, &vp, black_box(&scene(&a, radii))).unwrap());
        });
    }
    g.bench_function(BenchmarkId::new("triangles_cell_order", AGENTS), |b| {
        b.iter(|| draw_scene(&mut canvas, &vp, black_box(&scene(&sorted, &triangles))).unwrap());
    });
    g.finish();

    let mut g = c.benchmark_group("render_heat");
    let cells = 200_usize;
    let values: Vec<f32> = {
        let mut r = uniform(11);
        (0..cells * cells).map(|_| r()).collect()
    };
    let cell_size = WORLD / cells as f32;
    g.throughput(Throughput::Elements(u64::from(SIDE * SIDE)));
    g.bench_function(BenchmarkId::new("heat_map_200x200", SIDE * SIDE), |b| {
        let heat = HeatMap {
            values: &values,
            width: cells,
            height: cells,
            origin: Vec2::ZERO,
            cell_size,
            blocked: &[],
        };
        let s = Scene {
            heat: Some(heat),
            ..Scene::default()
        };
        b.iter(|| draw_scene(&mut canvas, &vp, black_box(&s)).unwrap());
    });
    g.finish();

    draw_scene(&mut canvas, &vp, &scene(&a, &triangles)).unwrap();
    let dir = std::env::temp_dir();
    let mut g = c.benchmark_group("render_encode");
    g.throughput(Throughput::Elements(1));
    g.bench_function("gif_frame_800x800_50k_agents", |b| {
        let path = dir.join(format!("throng-bench-{}.gif", std::process::id()));
        // A fresh file per sample keeps the file from growing over the whole run.
        b.iter_custom(|iters| {
            let mut gif = GifRecorder::create(&path, SIDE, SIDE, 4).unwrap();
            let start = Instant::now();
            for _ in 0..iters {
                gif.push(black_box(&canvas)).unwrap();
            }
            let elapsed = start.elapsed();
            gif.finish().unwrap();
            elapsed
        });
        std::fs::remove_file(&path).ok();
    });
    g.bench_function("png_800x800_50k_agents", |b| {
        let path = dir.join(format!("throng-bench-{}.png", std::process::id()));
        b.iter(|| write_png(black_box(&canvas), &path).unwrap());
        std::fs::remove_file(&path).ok();
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().warm_up_time(Duration::from_secs(1)).measurement_time(Duration::from_secs(3));
    targets = bench_render
}
criterion_main!(benches);
