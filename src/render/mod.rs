//! Headless pictures: frames drawn into an indexed 256-colour buffer, written as an animated GIF
//! or a PNG.
//!
//! A frame is a [`Canvas`] of palette indices in the fixed [`Palette`]. [`draw_scene`] draws a
//! [`Scene`] (plain slices: agents, obstacles, walls, gravity points, paths, an optional heat map
//! and flow overlay) through a [`Viewport`] that maps world units to pixels, y up. Because pixels
//! are palette indices from the start, encoding needs no colour quantisation: a
//! [`GifRecorder`] streams each frame straight to its file, and [`write_png`] writes an indexed PNG.
//!
//! Invariants: every drawing call clips to the canvas (no panics and no out-of-bounds writes for
//! shapes anywhere, however far outside); canvas sides lie in `1..=`[`MAX_SIDE`]; drawing allocates
//! nothing per agent.
//!
//! # Examples
//! ```no_run
//! # fn main() -> throng::Result<()> {
//! use glam::Vec2;
//! use throng::render::{Canvas, GifRecorder, Scene, Viewport, draw_scene, write_png};
//! let mut canvas = Canvas::new(400, 400)?;
//! let viewport = Viewport::fit(Vec2::ZERO, Vec2::splat(100.0), &canvas)?;
//! let mut gif = GifRecorder::create("out.gif", 400, 400, 4)?;
//! let (mut xs, ys, headings) = (vec![10.0_f32, 20.0], vec![50.0_f32, 60.0], vec![0.0_f32, 1.0]);
//! for _ in 0..30 {
//!     xs.iter_mut().for_each(|x| *x += 1.0);
//!     let scene = Scene { xs: &xs, ys: &ys, orientations: &headings, groups: &[0, 1], ..Scene::default() };
//!     draw_scene(&mut canvas, &viewport, &scene)?;
//!     gif.push(&canvas)?;
//! }
//! gif.finish()?;
//! write_png(&canvas, "last.png")?;
//! # Ok(())
//! # }
//! ```

mod canvas;
mod output;
mod palette;
mod scene;
mod viewport;
mod world;

pub use canvas::{Canvas, MAX_SIDE, check_size};
pub use output::{GifRecorder, write_png};
pub use palette::Palette;
pub use scene::{AgentStyle, FlowOverlay, HeatMap, Scene, draw_scene};
pub use viewport::Viewport;
pub use world::{WorldPainter, world_extent};
