//! Drawing a whole [`World`]: agents, obstacles, walls, gravity points, paths and the first field.

use glam::Vec2;

use super::{Canvas, HeatMap, Scene, Viewport, draw_scene};
use crate::error::Result;
use crate::world::World;

/// Draws frames of one world into a canvas of a fixed size. Things that do not move (obstacles,
/// walls, paths) are gathered once; gravity points every frame; the field's heat map whenever
/// the world rebuilt its fields.
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
}

/// The world rectangle a picture of `world` shows: the bounds' rectangle, or for an open world the
/// box around agents, obstacles, gravity points, paths and fields, with a margin.
#[must_use]
pub fn world_extent(world: &World) -> (Vec2, Vec2) {
    if let Some(size) = world.bounds().size() {
        return (Vec2::ZERO, size);
    }
    let mut lo = Vec2::splat(f32::INFINITY);
    let mut hi = Vec2::splat(f32::NEG_INFINITY);
    let mut add = |p: Vec2| {
        lo = lo.min(p);
        hi = hi.max(p);
    };
    let a = world.agents();
    for i in 0..a.len() {
        add(a.position(i));
    }
    for c in world.obstacles().circles() {
        add(c.center - c.radius);
        add(c.center + c.radius);
    }
    for w in world.obstacles().walls() {
        add(w.a);
        add(w.b);
    }
    for p in world.gravity().points() {
        add(p.position);
    }
    for path in world.paths() {
        for &p in path.points() {
            add(p);
        }
    }
    if let Some(f) = world.field(0) {
        let g = f.grid();
        add(g.origin());
        add(g.origin() + Vec2::new(g.width() as f32, g.height() as f32) * g.cell_size());
    }
    if !lo.is_finite() || !hi.is_finite() {
        return (Vec2::splat(-1.0), Vec2::splat(1.0));
    }
    let margin = ((hi - lo).max_element() * 0.05).max(1.0);
    (lo - margin, hi + margin)
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
