//! What one frame shows, and the function that draws it.
//!
//! A [`Scene`] borrows plain slices (agent positions, headings, groups and radii; obstacles,
//! walls, gravity points, paths; an optional heat map and flow overlay), so it does not depend on
//! the world's types and costs nothing to build each frame. [`draw_scene`] validates the slices'
//! lengths once and then draws in a fixed order, back to front: background, heat map, flow arrows,
//! paths, walls, obstacles, gravity points, agents. Drawing is clipped: anything outside the
//! viewport draws nothing.

use glam::Vec2;

use super::{Canvas, Palette, Viewport};
use crate::error::{Error, Result, finite_vec, positive};

/// How agents are drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AgentStyle {
    /// Radius in world units of agents when [`Scene::radii`] is empty. Default: 0.5.
    pub default_radius: f32,
    /// Smallest drawn size (nose to tail) of an agent in pixels. Default: 3.
    pub min_size_px: f32,
    /// Agents whose size (twice the radius) is below this many pixels are drawn as one-pixel dots,
    /// which keeps very crowded frames fast. Default: 2.
    pub dot_below_px: f32,
}

impl Default for AgentStyle {
    fn default() -> Self {
        AgentStyle {
            default_radius: 0.5,
            min_size_px: 3.0,
            dot_below_px: 2.0,
        }
    }
}

/// A scalar grid drawn as a heat map under everything else.
///
/// Cell `(cx, cy)` is `values[cy * width + cx]` and covers the world square
/// `origin + [cx, cx + 1) x [cy, cy + 1) * cell_size`, so row 0 is the *lowest* in the world.
#[derive(Clone, Copy, Debug)]
pub struct HeatMap<'a> {
    /// One value per cell; `[0, 1]` maps onto the ramp (clamped above), negative or NaN values are
    /// drawn as [`Palette::UNREACHABLE`].
    pub values: &'a [f32],
    /// Cells per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// World position of cell `(0, 0)`'s lower-left corner.
    pub origin: Vec2,
    /// Side of a cell in world units.
    pub cell_size: f32,
    /// Blocked (wall) cells, drawn as [`Palette::BLOCKED`]; empty for none.
    pub blocked: &'a [bool],
}

/// A vector field drawn as short arrows, one every `stride` cells.
///
/// Same cell layout as [`HeatMap`]. Arrow length is proportional to the vector's length, capped at
/// one unit.
#[derive(Clone, Copy, Debug)]
pub struct FlowOverlay<'a> {
    /// One vector per cell.
    pub vectors: &'a [Vec2],
    /// Cells per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// World position of cell `(0, 0)`'s lower-left corner.
    pub origin: Vec2,
    /// Side of a cell in world units.
    pub cell_size: f32,
    /// Draw an arrow every `stride` cells along each axis (at least 1).
    pub stride: usize,
}

/// Everything one frame shows, as borrowed slices.
///
/// Agents are `xs[i], ys[i]`; `orientations`, `groups` and `radii` are either empty or as long as
/// `xs`. Empty `orientations` draws agents as discs, empty `groups` colours every agent as group 0,
/// empty `radii` uses [`AgentStyle::default_radius`].
#[derive(Clone, Copy, Debug, Default)]
pub struct Scene<'a> {
    /// Agent x positions (world units).
    pub xs: &'a [f32],
    /// Agent y positions (world units).
    pub ys: &'a [f32],
    /// Agent headings in radians, counter-clockwise from +x.
    pub orientations: &'a [f32],
    /// Agent groups, each drawn in its own colour ([`Palette::group`]).
    pub groups: &'a [u32],
    /// Agent radii (world units).
    pub radii: &'a [f32],
    /// Circular obstacles: centre and radius.
    pub circles: &'a [(Vec2, f32)],
    /// Wall segments.
    pub segments: &'a [(Vec2, Vec2)],
    /// Gravity points: position and strength. Positive strength pushes agents away (the
    /// anti-gravity convention) and is drawn as [`Palette::REPEL`]; negative strength attracts and
    /// is drawn as [`Palette::ATTRACT`]. The dot grows with the strength's magnitude.
    pub points: &'a [(Vec2, f32)],
    /// Paths, drawn as polylines.
    pub paths: &'a [Vec<Vec2>],
    /// A heat map under everything else.
    pub heat: Option<HeatMap<'a>>,
    /// Flow arrows over the heat map.
    pub flow: Option<FlowOverlay<'a>>,
    /// How agents are drawn.
    pub style: AgentStyle,
}

/// Thickness of wall segments in pixels.
const WALL_PX: f32 = 2.0;

fn check_len(name: &str, len: usize, agents: usize) -> Result<()> {
    if len == 0 || len == agents {
        Ok(())
    } else {
        Err(Error::Invalid {
            name: format!("scene {name}"),
            reason: format!("has {len} entries for {agents} agents"),
        })
    }
}

fn check_grid(
    name: &str,
    len: usize,
    width: usize,
    height: usize,
    cell_size: f32,
    origin: Vec2,
) -> Result<()> {
    positive("grid cell size", cell_size)?;
    finite_vec("grid origin", origin)?;
    if width == 0 || height == 0 || width.checked_mul(height) != Some(len) {
        return Err(Error::Invalid {
            name: name.to_string(),
            reason: format!("{len} values do not fill a {width} x {height} grid"),
        });
    }
    Ok(())
}

impl Scene<'_> {
    /// Checks that the slices fit together.
    ///
    /// # Errors
    /// [`Error::Invalid`] when a per-agent slice has the wrong length or a grid's values do not
    /// fill it, [`Error::NotPositive`] or [`Error::NonFinite`] for a bad grid cell size or origin,
    /// or a bad agent style.
    pub fn validate(&self) -> Result<()> {
        let n = self.xs.len();
        if self.ys.len() != n {
            return Err(Error::Invalid {
                name: "scene ys".to_string(),
                reason: format!("has {} entries for {n} xs", self.ys.len()),
            });
        }
        check_len("orientations", self.orientations.len(), n)?;
        check_len("groups", self.groups.len(), n)?;
        check_len("radii", self.radii.len(), n)?;
        positive("default agent radius", self.style.default_radius)?;
        positive("minimum agent size", self.style.min_size_px)?;
        crate::error::non_negative("dot size threshold", self.style.dot_below_px)?;
        if let Some(h) = &self.heat {
            check_grid(
                "heat map",
                h.values.len(),
                h.width,
                h.height,
                h.cell_size,
                h.origin,
            )?;
            check_len("heat map blocked mask", h.blocked.len(), h.values.len())?;
        }
        if let Some(f) = &self.flow {
            check_grid(
                "flow overlay",
                f.vectors.len(),
                f.width,
                f.height,
                f.cell_size,
                f.origin,
            )?;
            if f.stride == 0 {
                return Err(Error::NotPositive {
                    name: "flow overlay stride",
                    value: 0.0,
                });
            }
        }
        Ok(())
    }
}

/// Draws `scene` onto `canvas` through `viewport`, replacing what was there.
///
/// The viewport should have the canvas's size; if it does not, drawing still clips to the canvas.
///
/// # Examples
/// ```
/// # fn main() -> throng::Result<()> {
/// use glam::Vec2;
/// use throng::render::{Canvas, Palette, Scene, Viewport, draw_scene};
/// let mut canvas = Canvas::new(100, 100)?;
/// let viewport = Viewport::fit(Vec2::ZERO, Vec2::splat(10.0), &canvas)?;
/// let scene = Scene { xs: &[5.0], ys: &[5.0], orientations: &[0.0], groups: &[3], ..Scene::default() };
/// draw_scene(&mut canvas, &viewport, &scene)?;
/// assert_eq!(canvas.pixel(50, 50), Some(Palette::group(3)));
/// # Ok(())
/// # }
/// ```
///
/// # Errors
/// As [`Scene::validate`]; nothing is drawn then.
pub fn draw_scene(canvas: &mut Canvas, viewport: &Viewport, scene: &Scene<'_>) -> Result<()> {
    scene.validate()?;
    canvas.clear(Palette::BACKGROUND);
    if let Some(heat) = &scene.heat {
        draw_heat(canvas, viewport, heat);
    }
    if let Some(flow) = &scene.flow {
        draw_flow(canvas, viewport, flow);
    }
    for path in scene.paths {
        let mut prev: Option<Vec2> = None;
        for &p in path {
            let q = viewport.to_pixel(p);
            if let Some(prev) = prev {
                canvas.line(prev, q, Palette::PATH);
            }
            prev = Some(q);
        }
    }
    for &(a, b) in scene.segments {
        canvas.thick_line(
            viewport.to_pixel(a),
            viewport.to_pixel(b),
            WALL_PX,
            Palette::WALL,
        );
    }
    for &(c, r) in scene.circles {
        canvas.fill_circle(
            viewport.to_pixel(c),
            r * viewport.scale(),
            Palette::OBSTACLE,
        );
    }
    for &(p, strength) in scene.points {
        let colour = if strength > 0.0 {
            Palette::REPEL
        } else {
            Palette::ATTRACT
        };
        let r = (2.5 + 1.5 * (1.0 + strength.abs()).log2()).min(10.0);
        canvas.fill_circle(viewport.to_pixel(p), r, colour);
    }
    draw_agents(canvas, viewport, scene);
    Ok(())
}

/// Draws the agents of a validated scene.
fn draw_agents(canvas: &mut Canvas, viewport: &Viewport, scene: &Scene<'_>) {
    let style = scene.style;
    let scale = viewport.scale();
    let (w, h) = (canvas.width() as f32, canvas.height() as f32);
    for (i, (&x, &y)) in scene.xs.iter().zip(scene.ys).enumerate() {
        let p = viewport.to_pixel(Vec2::new(x, y));
        let colour = Palette::group(scene.groups.get(i).copied().unwrap_or(0));
        let radius = scene.radii.get(i).copied().unwrap_or(style.default_radius);
        let size = 2.0 * radius * scale;
        if size.is_nan() || size < style.dot_below_px {
            canvas.dot(p, colour);
            continue;
        }
        let size = size.max(style.min_size_px);
        // Cull: the shape lies within `size` of `p`.
        if !(p.x > -size && p.y > -size && p.x < w + size && p.y < h + size) {
            continue;
        }
        match scene.orientations.get(i) {
            None => canvas.fill_circle(p, 0.5 * size, colour),
            Some(&theta) => {
                let (s, c) = theta.sin_cos();
                // Pixel y points down, so a heading (c, s) in the world is (c, -s) here.
                let fwd = Vec2::new(c, -s) * size;
                let side = Vec2::new(s, c) * (0.35 * size);
                let tail = p - 0.4 * fwd;
                canvas.fill_triangle(p + 0.6 * fwd, tail + side, tail - side, colour);
                canvas.dot(p, colour);
            }
        }
    }
}

/// For each pixel index along one axis, the grid cell whose span holds the pixel's centre, or
/// `None` where the pixel lies outside the grid.
fn cell_lookup(pixels: u32, cells: usize, to_cell: impl Fn(f32) -> f32) -> Vec<Option<u32>> {
    (0..pixels)
        .map(|k| {
            let c = to_cell(k as f32 + 0.5).floor();
            (c >= 0.0 && c < cells as f32).then_some(c as u32)
        })
        .collect()
}

fn draw_heat(canvas: &mut Canvas, viewport: &Viewport, heat: &HeatMap<'_>) {
    let inv = 1.0 / heat.cell_size;
    let cols = cell_lookup(canvas.width(), heat.width, |px| {
        (viewport.to_world(Vec2::new(px, 0.0)).x - heat.origin.x) * inv
    });
    let rows = cell_lookup(canvas.height(), heat.height, |py| {
        (viewport.to_world(Vec2::new(0.0, py)).y - heat.origin.y) * inv
    });
    let Some(first_col) = cols.iter().position(Option::is_some) else {
        return;
    };
    let last_col = cols.iter().rposition(Option::is_some).unwrap_or(first_col);
    let cols = &cols[first_col..=last_col];
    let width = canvas.width() as usize;
    let pixels = canvas.pixels_mut();
    for (py, row) in rows.iter().enumerate() {
        let Some(cy) = row else { continue };
        let base = *cy as usize * heat.width;
        let values = &heat.values[base..base + heat.width];
        let blocked = heat.blocked.get(base..base + heat.width);
        let out = &mut pixels[py * width + first_col..=py * width + last_col];
        for (px, col) in out.iter_mut().zip(cols) {
            let Some(cx) = col else { continue };
            let cx = *cx as usize;
            *px = if blocked.is_some_and(|b| b[cx]) {
                Palette::BLOCKED
            } else {
                Palette::heat(values[cx])
            };
        }
    }
}

fn draw_flow(canvas: &mut Canvas, viewport: &Viewport, flow: &FlowOverlay<'_>) {
    let reach = 0.45 * flow.stride as f32 * flow.cell_size * viewport.scale();
    let head = (0.3 * reach).clamp(1.5, 4.0);
    for cy in (flow.stride / 2..flow.height).step_by(flow.stride) {
        for cx in (flow.stride / 2..flow.width).step_by(flow.stride) {
            let v = flow.vectors[cy * flow.width + cx];
            let len = v.length();
            if !len.is_finite() || len <= 0.0 {
                continue;
            }
            let centre = flow.origin + (Vec2::new(cx as f32, cy as f32) + 0.5) * flow.cell_size;
            let dir = viewport.to_pixel_dir(v / len);
            let from = viewport.to_pixel(centre);
            let tip = from + dir * (reach * len.min(1.0));
            canvas.line(from, tip, Palette::ARROW);
            let side = Vec2::new(-dir.y, dir.x) * (0.6 * head);
            canvas.fill_triangle(tip + dir * head, tip + side, tip - side, Palette::ARROW);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn setup() -> (Canvas, Viewport) {
        let canvas = Canvas::new(200, 100).unwrap();
        let vp = Viewport::fit(Vec2::ZERO, Vec2::new(20.0, 10.0), &canvas).unwrap();
        (canvas, vp)
    }

    #[test]
    fn mismatched_slices_are_rejected() {
        let (mut c, vp) = setup();
        let bad = Scene {
            xs: &[1.0, 2.0],
            ys: &[1.0],
            ..Scene::default()
        };
        assert!(matches!(
            draw_scene(&mut c, &vp, &bad),
            Err(Error::Invalid { .. })
        ));
        let bad = Scene {
            xs: &[1.0, 2.0],
            ys: &[1.0, 2.0],
            groups: &[1],
            ..Scene::default()
        };
        assert!(matches!(
            draw_scene(&mut c, &vp, &bad),
            Err(Error::Invalid { .. })
        ));
        let heat = HeatMap {
            values: &[0.0; 5],
            width: 2,
            height: 3,
            origin: Vec2::ZERO,
            cell_size: 1.0,
            blocked: &[],
        };
        let bad = Scene {
            heat: Some(heat),
            ..Scene::default()
        };
        assert!(matches!(
            draw_scene(&mut c, &vp, &bad),
            Err(Error::Invalid { .. })
        ));
    }

    #[test]
    fn heat_map_rows_run_upwards_and_walls_show() {
        let (mut c, vp) = setup();
        // 2 x 2 cells of 5 world units over the picture's left half: row 0 at the bottom.
        let values = [0.0, 1.0, 0.5, f32::NAN];
        let blocked = [false, false, true, false];
        let heat = HeatMap {
            values: &values,
            width: 2,
            height: 2,
            origin: Vec2::ZERO,
            cell_size: 5.0,
            blocked: &blocked,
        };
        draw_scene(
            &mut c,
            &vp,
            &Scene {
                heat: Some(heat),
                ..Scene::default()
            },
        )
        .unwrap();
        assert_eq!(c.pixel(10, 90), Some(Palette::heat(0.0)));
        assert_eq!(c.pixel(90, 90), Some(Palette::heat(1.0)));
        assert_eq!(c.pixel(10, 10), Some(Palette::BLOCKED));
        assert_eq!(c.pixel(90, 10), Some(Palette::UNREACHABLE));
        assert_eq!(c.pixel(150, 50), Some(Palette::BACKGROUND));
    }

    #[test]
    fn tiny_agents_become_single_dots() {
        let (mut c, vp) = setup();
        // Radius 0.05 world units = 0.5 px: size 1 px < 2 px.
        let scene = Scene {
            xs: &[10.0],
            ys: &[5.0],
            orientations: &[0.0],
            radii: &[0.05],
            ..Scene::default()
        };
        draw_scene(&mut c, &vp, &scene).unwrap();
        assert_eq!(
            c.pixels()
                .iter()
                .filter(|&&p| p != Palette::BACKGROUND)
                .count(),
            1
        );
        // Radius 0.15 = 3 px across: a triangle of several pixels.
        let scene = Scene {
            radii: &[0.15],
            ..scene
        };
        draw_scene(&mut c, &vp, &scene).unwrap();
        assert!(
            c.pixels()
                .iter()
                .filter(|&&p| p != Palette::BACKGROUND)
                .count()
                > 2
        );
    }

    #[test]
    fn obstacles_walls_points_paths_and_arrows_are_drawn() {
        let (mut c, vp) = setup();
        let vectors = vec![Vec2::X; 4 * 2];
        let scene = Scene {
            circles: &[(Vec2::new(3.0, 3.0), 1.0)],
            segments: &[(Vec2::new(0.0, 9.0), Vec2::new(20.0, 9.0))],
            points: &[
                (Vec2::new(15.0, 3.0), 100.0),
                (Vec2::new(18.0, 3.0), -100.0),
            ],
            paths: &[vec![Vec2::new(1.0, 6.0), Vec2::new(19.0, 6.0)]],
            flow: Some(FlowOverlay {
                vectors: &vectors,
                width: 4,
                height: 2,
                origin: Vec2::ZERO,
                cell_size: 5.0,
                stride: 1,
            }),
            ..Scene::default()
        };
        draw_scene(&mut c, &vp, &scene).unwrap();
        assert_eq!(c.pixel(30, 70), Some(Palette::OBSTACLE));
        assert_eq!(c.pixel(100, 10), Some(Palette::WALL));
        assert_eq!(c.pixel(150, 70), Some(Palette::REPEL));
        assert_eq!(c.pixel(180, 70), Some(Palette::ATTRACT));
        assert_eq!(c.pixel(100, 40), Some(Palette::PATH));
        assert!(c.pixels().contains(&Palette::ARROW));
    }
}
