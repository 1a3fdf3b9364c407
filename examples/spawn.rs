//! Each spawn helper of `throng::spawn` drawn to one PNG: six panels side by side (rectangle,
//! disc, ring, grid, jittered grid, Poisson-disc), every one clear of the same round obstacle,
//! and the free cells of a small maze below them.
//!
//! Run with `cargo run --release --example spawn --features render [-- OUT.png]` (default
//! `spawn.png` in the current directory).

use throng::field::{Cell, OccupancyGrid};
use throng::obstacles::{Circle, Obstacles};
use throng::prelude::*;
use throng::render::{Canvas, Scene, Viewport, draw_scene, write_png};
use throng::spawn::Spawner;

/// One panel's side, world units.
const SIDE: f32 = 40.0;

fn main() -> throng::Result<()> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "spawn.png".into());
    // Panel k spans x in [k * SIDE, (k + 1) * SIDE); each has a rock in its middle.
    let mut rocks = Obstacles::new();
    for k in 0..6 {
        let c = Vec2::new((k as f32 + 0.5) * SIDE, SIDE / 2.0);
        rocks.add_circle(Circle {
            center: c,
            radius: 6.0,
        })?;
    }
    let spawner = Spawner::new(42).avoiding(&rocks, 0.5);
    let corner = |k: usize| Vec2::new(k as f32 * SIDE + 2.0, 2.0);
    let far = |k: usize| Vec2::new((k + 1) as f32 * SIDE - 2.0, SIDE - 2.0);
    let centre = |k: usize| Vec2::new((k as f32 + 0.5) * SIDE, SIDE / 2.0);
    let panels = [
        spawner.rect(300, corner(0), far(0))?,
        spawner.disc(300, centre(1), 18.0)?,
        spawner.ring(300, centre(2), 10.0, 18.0)?,
        spawner.grid(300, corner(3), far(3))?,
        spawner.jittered_grid(300, corner(4), far(4), 0.8)?,
        spawner.poisson_disc(corner(5), far(5), 2.0, 10_000)?,
    ];
    // The maze: a 24 x 8 grid of 5-unit cells below the panels, every third column walled
    // except for a gap.
    let mut maze = OccupancyGrid::new(48, 8)?.with_geometry(5.0, Vec2::new(0.0, SIDE + 2.0))?;
    for x in (2..48).step_by(3) {
        for y in 0..8 {
            if y != (x % 7) {
                maze.set(x, y, Cell::Wall)?;
            }
        }
    }
    let cells = Spawner::new(42).free_cells(600, &maze)?;

    let mut points: Vec<Vec2> = panels.iter().flatten().copied().collect();
    let mut groups: Vec<u32> = panels
        .iter()
        .enumerate()
        .flat_map(|(k, p)| std::iter::repeat_n(k as u32, p.len()))
        .collect();
    points.extend(&cells);
    groups.extend(std::iter::repeat_n(6, cells.len()));
    let (xs, ys): (Vec<f32>, Vec<f32>) = points.iter().map(|p| (p.x, p.y)).unzip();
    let orientations = vec![0.0; xs.len()];
    let circles: Vec<(Vec2, f32)> = rocks
        .circles()
        .iter()
        .map(|c| (c.center, c.radius))
        .collect();
    let segments: Vec<(Vec2, Vec2)> = (0..maze.height())
        .flat_map(|y| (0..maze.width()).map(move |x| (x, y)))
        .filter(|&(x, y)| !maze.is_free(x, y))
        .map(|(x, y)| {
            let c = maze.cell_center(x, y);
            (c - Vec2::new(0.0, 2.5), c + Vec2::new(0.0, 2.5))
        })
        .collect();

    let mut canvas = Canvas::new(1200, 300)?;
    let viewport = Viewport::fit(Vec2::ZERO, Vec2::new(6.0 * SIDE, SIDE + 44.0), &canvas)?;
    let scene = Scene {
        xs: &xs,
        ys: &ys,
        orientations: &orientations,
        groups: &groups,
        circles: &circles,
        segments: &segments,
        ..Scene::default()
    };
    draw_scene(&mut canvas, &viewport, &scene)?;
    write_png(&canvas, &out)?;
    for (name, p) in [
        "rect",
        "disc",
        "ring",
        "grid",
        "jittered grid",
        "Poisson-disc",
    ]
    .iter()
    .zip(&panels)
    {
        println!("{name:>13}: {} points", p.len());
    }
    println!("   free cells: {} points", cells.len());
    println!("wrote {out}");
    Ok(())
}
