//! Drawing a whole [`World`]: agents, obstacles, walls, gravity points, paths, exits and the first
//! field.

use glam::Vec2;

use super::{Canvas, HeatMap, Palette, Scene, Viewport, draw_scene};
use crate::error::Result;
use crate::world::World;

/// Draws frames of one world into a canvas of a fixed size. Things that do not move (obstacles,
/// walls, paths, exits) are gathered once; gravity points every frame; the field's heat map
/// whenever the world rebuilt its fields. Exits are hatched in [`Palette::EXIT`] with an outline,
/// under the agents.
#[derive(Debug)]
pub struct WorldPainter {
    canvas: Canvas,
    viewport: Viewport,
    circles: Vec<(Vec2, f32)>,
    segments: Vec<(Vec2, Vec2)>,
    paths: Vec<Vec<Vec2>>,
    points: Vec<(Vec2, f32)>,
    heat: Vec<f32>,
    blocked: Vec<bool>,
    heat_geometry: Option<(usize, usize, Vec2, f32)>,
    heat_version: Option<u64>,
    /// Pixels (row-major indices) of the exits' hatching and outlines.
    exit_pixels: Vec<usize>,
}

/// The world rectangle a picture of `world` shows: [`World::extent`].
#[must_use]
pub fn world_extent(world: &World) -> (Vec2, Vec2) {
    world.extent()
}

impl WorldPainter {
    /// A painter of `width x height` pixels showing [`world_extent`] of `world`.
    ///
    /// # Errors
    /// As [`Canvas::new`] and [`Viewport::fit`] for a bad size.
    pub fn new(world: &World, width: u32, height: u32) -> Result<Self> {
        let canvas = Canvas::new(width, height)?;
        let (min, max) = world_extent(world);
        let viewport = Viewport::fit(min, max, &canvas)?;
        let exit_pixels = exit_pixels(world, &viewport, width, height);
        Ok(WorldPainter {
            canvas,
            viewport,
            circles: world
                .obstacles()
                .circles()
                .iter()
                .map(|c| (c.center, c.radius))
                .collect(),
            segments: world
                .obstacles()
                .walls()
                .iter()
                .map(|w| (w.a, w.b))
                .collect(),
            paths: world.paths().iter().map(|p| p.points().to_vec()).collect(),
            points: Vec::new(),
            heat: Vec::new(),
            blocked: Vec::new(),
            heat_geometry: None,
            heat_version: None,
            exit_pixels,
        })
    }

    /// Draws the world's current state and returns the picture.
    ///
    /// # Errors
    /// Only if the world's slices disagree in length, which a valid world never does.
    pub fn draw(&mut self, world: &World) -> Result<&Canvas> {
        self.points.clear();
        self.points.extend(
            world
                .gravity()
                .points()
                .iter()
                .map(|p| (p.position, p.strength)),
        );
        self.refresh_heat(world);
        let a = world.agents();
        let heat = self
            .heat_geometry
            .map(|(width, height, origin, cell_size)| HeatMap {
                values: &self.heat,
                width,
                height,
                origin,
                cell_size,
                blocked: &self.blocked,
            });
        let scene = Scene {
            xs: a.pos_x(),
            ys: a.pos_y(),
            orientations: a.orientations(),
            groups: a.groups(),
            radii: a.radii(),
            circles: &self.circles,
            segments: &self.segments,
            points: &self.points,
            paths: &self.paths,
            heat,
            ..Scene::default()
        };
        draw_scene(&mut self.canvas, &self.viewport, &scene)?;
        // Agents stay on top: only pixels that no agent has coloured are marked.
        let pixels = self.canvas.pixels_mut();
        for &k in &self.exit_pixels {
            if pixels[k] < Palette::GROUP_START {
                pixels[k] = Palette::EXIT;
            }
        }
        draw_legend(&mut self.canvas, world.groups().len());
        Ok(&self.canvas)
    }

    /// The picture last drawn.
    #[must_use]
    pub fn canvas(&self) -> &Canvas {
        &self.canvas
    }

    /// The heat map of field 0, channel 0: 1 at the goals falling to 0 at the farthest reachable
    /// cell (by steps, so that it stays visible where the potential underflows), walls blocked.
    fn refresh_heat(&mut self, world: &World) {
        let Some(channels) = world.field(0) else {
            return;
        };
        let version = world.field_rebuilds();
        if self.heat_version == Some(version) {
            return;
        }
        let Some(field) = channels.field(0) else {
            return;
        };
        let grid = channels.grid();
        let (w, h) = (grid.width(), grid.height());
        self.heat.clear();
        self.blocked.clear();
        let mut max_steps = 1u32;
        for y in 0..h {
            for x in 0..w {
                if let Some(s) = field.steps(x, y) {
                    max_steps = max_steps.max(s);
                }
            }
        }
        for y in 0..h {
            for x in 0..w {
                self.blocked.push(!grid.is_free(x, y));
                self.heat.push(match field.steps(x, y) {
                    Some(s) => 1.0 - s as f32 / max_steps as f32,
                    None => -1.0,
                });
            }
        }
        self.heat_geometry = Some((w as usize, h as usize, grid.origin(), grid.cell_size()));
        self.heat_version = Some(version);
    }
}

/// The pixels that mark the world's exits on a `width x height` picture: each exit's border
/// and a diagonal hatching of its inside (pixel centres tested with [`Exit::contains`]).
///
/// [`Exit::contains`]: crate::world::Exit::contains
fn exit_pixels(world: &World, viewport: &Viewport, width: u32, height: u32) -> Vec<usize> {
    let (w, h) = (width as i64, height as i64);
    let mut out = Vec::new();
    for exit in world.exits() {
        let (a, b) = (viewport.to_pixel(exit.min), viewport.to_pixel(exit.max));
        let (lo, hi) = (a.min(b), a.max(b));
        if !(lo.is_finite() && hi.is_finite()) {
            continue;
        }
        let x0 = (lo.x.floor() as i64).clamp(0, w);
        let x1 = (hi.x.ceil() as i64).clamp(0, w);
        let y0 = (lo.y.floor() as i64).clamp(0, h);
        let y1 = (hi.y.ceil() as i64).clamp(0, h);
        let inside = |x: i64, y: i64| {
            let centre = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            exit.contains(viewport.to_world(centre))
        };
        for y in y0..y1 {
            for x in x0..x1 {
                if !inside(x, y) {
                    continue;
                }
                let border =
                    !(inside(x - 1, y) && inside(x + 1, y) && inside(x, y - 1) && inside(x, y + 1));
                if border || (x + y) % 4 == 0 {
                    out.push((y * w + x) as usize);
                }
            }
        }
    }
    out
}

/// Pixels of the digits 0 to 9 in a 3 x 5 font, one row of three bits per entry, top first.
const DIGITS: [[u8; 5]; 10] = [
    [0b111, 0b101, 0b101, 0b101, 0b111],
    [0b010, 0b110, 0b010, 0b010, 0b111],
    [0b111, 0b001, 0b111, 0b100, 0b111],
    [0b111, 0b001, 0b111, 0b001, 0b111],
    [0b101, 0b101, 0b111, 0b001, 0b001],
    [0b111, 0b100, 0b111, 0b001, 0b111],
    [0b111, 0b100, 0b111, 0b101, 0b111],
    [0b111, 0b001, 0b010, 0b010, 0b010],
    [0b111, 0b101, 0b111, 0b101, 0b111],
    [0b111, 0b101, 0b111, 0b001, 0b111],
];

/// The group legend in the top-left corner when a world has several groups: per group a swatch
/// of its colour and its index (groups beyond the palette's colours share theirs, so at most
/// [`Palette::GROUP_COUNT`] rows), drawn only where the picture has room for it.
fn draw_legend(canvas: &mut Canvas, groups: usize) {
    let rows = groups.min(usize::from(Palette::GROUP_COUNT));
    let (row_h, x0, y0) = (10_i32, 4_i32, 4_i32);
    if groups < 2 || (canvas.height() as i32) < y0 + row_h * rows as i32 || canvas.width() < 48 {
        return;
    }
    for g in 0..rows {
        let top = y0 + row_h * g as i32;
        for dy in 0..7 {
            for dx in 0..7 {
                canvas.set_pixel(x0 + dx, top + dy, Palette::group(g as u32));
            }
        }
        let mut x = x0 + 10;
        for digit in g.to_string().bytes().map(|b| usize::from(b - b'0')) {
            for (dy, bits) in DIGITS[digit].iter().enumerate() {
                for dx in 0..3 {
                    if bits & (0b100 >> dx) != 0 {
                        canvas.set_pixel(x + dx, top + 1 + dy as i32, Palette::WHITE);
                    }
                }
            }
            x += 4;
        }
    }
}
