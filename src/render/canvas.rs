//! An indexed 8-bit pixel buffer and the raster primitives that draw into it.
//!
//! Coordinates here are *pixels*: x to the right, y down, pixel `(i, j)` covers
//! `[i, i + 1) x [j, j + 1)`, and filled shapes colour the pixels whose centres they contain.
//! Every primitive clips to the canvas: points, lines and shapes partly or wholly outside it never
//! index out of bounds and never panic, and the work they do is bounded by the canvas size, not by
//! how far outside the shape lies.

use glam::Vec2;

use super::Palette;
use crate::error::{Error, Result};

/// The largest width or height a canvas (and so a GIF or PNG) may have, in pixels.
pub const MAX_SIDE: u32 = 8192;

/// Checks that `width x height` is a usable picture size: each side in `1..=MAX_SIDE`.
///
/// # Errors
/// [`Error::NotPositive`] for a zero side, [`Error::OutOfRange`] for a side over [`MAX_SIDE`].
pub fn check_size(width: u32, height: u32) -> Result<()> {
    for (name, side) in [("image width", width), ("image height", height)] {
        if side == 0 {
            return Err(Error::NotPositive { name, value: 0.0 });
        }
        if side > MAX_SIDE {
            return Err(Error::OutOfRange {
                name,
                value: f64::from(side),
                range: "[1, 8192]",
            });
        }
    }
    Ok(())
}

/// A `width x height` picture of palette indices, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Canvas {
    width: u32,
    height: u32,
    pixels: Vec<u8>,
    palette: Palette,
}

impl Canvas {
    /// A canvas of `width x height` pixels in the standard palette, cleared to
    /// [`Palette::BACKGROUND`].
    ///
    /// # Examples
    /// ```
    /// # fn main() -> throng::Result<()> {
    /// use throng::render::{Canvas, Palette};
    /// let mut canvas = Canvas::new(64, 48)?;
    /// canvas.fill_circle(glam::Vec2::new(32.0, 24.0), 5.0, Palette::WALL);
    /// assert_eq!(canvas.pixel(32, 24), Some(Palette::WALL));
    /// # Ok(())
    /// # }
    /// ```
    ///
    /// # Errors
    /// [`Error::NotPositive`] or [`Error::OutOfRange`] for a side of 0 or over [`MAX_SIDE`].
    pub fn new(width: u32, height: u32) -> Result<Self> {
        Self::with_palette(width, height, Palette::standard())
    }

    /// A canvas of `width x height` pixels in `palette`, cleared to [`Palette::BACKGROUND`].
    ///
    /// # Errors
    /// [`Error::NotPositive`] or [`Error::OutOfRange`] for a side of 0 or over [`MAX_SIDE`].
    pub fn with_palette(width: u32, height: u32, palette: Palette) -> Result<Self> {
        check_size(width, height)?;
        let pixels = vec![Palette::BACKGROUND; width as usize * height as usize];
        Ok(Canvas {
            width,
            height,
            pixels,
            palette,
        })
    }

    /// Width in pixels.
    #[must_use]
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    #[must_use]
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The palette indices, row-major, row 0 at the top.
    #[must_use]
    pub fn pixels(&self) -> &[u8] {
        &self.pixels
    }

    /// The palette indices, mutable.
    pub fn pixels_mut(&mut self) -> &mut [u8] {
        &mut self.pixels
    }

    /// The palette the indices refer to.
    #[must_use]
    pub fn palette(&self) -> &Palette {
        &self.palette
    }

    /// The palette, mutable (to recolour an index for every later frame).
    pub fn palette_mut(&mut self) -> &mut Palette {
        &mut self.palette
    }

    /// The index at pixel `(x, y)`, or `None` outside the canvas.
    #[must_use]
    pub fn pixel(&self, x: u32, y: u32) -> Option<u8> {
        (x < self.width && y < self.height)
            .then(|| self.pixels[y as usize * self.width as usize + x as usize])
    }

    /// The RGB colour at pixel `(x, y)`, or `None` outside the canvas.
    #[must_use]
    pub fn rgb(&self, x: u32, y: u32) -> Option<[u8; 3]> {
        self.pixel(x, y).map(|i| self.palette.rgb(i))
    }

    /// The whole picture as RGB bytes, row-major.
    #[must_use]
    pub fn to_rgb(&self) -> Vec<u8> {
        self.pixels
            .iter()
            .flat_map(|&i| self.palette.rgb(i))
            .collect()
    }

    /// Sets every pixel to `colour`.
    pub fn clear(&mut self, colour: u8) {
        self.pixels.fill(colour);
    }

    /// Sets pixel `(x, y)` to `colour`; does nothing outside the canvas.
    #[inline]
    pub fn set_pixel(&mut self, x: i32, y: i32, colour: u8) {
        if x >= 0 && y >= 0 && (x as u32) < self.width && (y as u32) < self.height {
            self.pixels[y as usize * self.width as usize + x as usize] = colour;
        }
    }

    /// Colours the one pixel that contains point `p`.
    #[inline]
    pub fn dot(&mut self, p: Vec2, colour: u8) {
        // Compare as floats first: casting a far-off point saturates, which is also fine.
        if p.x >= 0.0 && p.y >= 0.0 && p.x < self.width as f32 && p.y < self.height as f32 {
            self.set_pixel(p.x as i32, p.y as i32, colour);
        }
    }

    /// Fills row `y` from column `x0` to `x1` inclusive, both already clipped to the canvas.
    #[inline]
    fn span(&mut self, y: usize, x0: usize, x1: usize, colour: u8) {
        let row = y * self.width as usize;
        self.pixels[row + x0..=row + x1].fill(colour);
    }

    /// The clipped range of pixel rows (or columns, given `len`) whose centres lie in `[lo, hi]`.
    #[inline]
    fn centre_range(lo: f32, hi: f32, len: u32) -> Option<(usize, usize)> {
        // Clamp first (also keeps the integer conversions exact), then round with integer
        // arithmetic: `f32::ceil` and `floor` are library calls on baseline x86-64, a visible
        // share of drawing small triangles (docs/PERFORMANCE.md, "Tuning constants").
        let bound = len as f32 + 1.0;
        let lo = (lo - 0.5).clamp(-1.0, bound);
        let hi = (hi - 0.5).clamp(-1.0, bound);
        if lo.is_nan() || hi.is_nan() {
            return None;
        }
        let (t_lo, t_hi) = (lo as i32, hi as i32);
        // Truncation rounds towards zero: up for negatives, down for positives.
        let first = (t_lo + i32::from((t_lo as f32) < lo)).max(0);
        let last = (t_hi - i32::from((t_hi as f32) > hi)).min(len as i32 - 1);
        (first <= last).then_some((first as usize, last as usize))
    }

    /// Fills the convex polygon `points` (in either winding): every pixel whose centre lies inside.
    /// Fewer than three points draw nothing.
    pub fn fill_convex(&mut self, points: &[Vec2], colour: u8) {
        if points.len() < 3 {
            return;
        }
        let (lo, hi) = points
            .iter()
            .fold((Vec2::INFINITY, Vec2::NEG_INFINITY), |(lo, hi), &p| {
                (lo.min(p), hi.max(p))
            });
        if !(hi.x >= 0.0 && lo.x <= self.width as f32) {
            return;
        }
        let Some((row0, row1)) = Self::centre_range(lo.y, hi.y, self.height) else {
            return;
        };
        for row in row0..=row1 {
            let yc = row as f32 + 0.5;
            let (mut xl, mut xr) = (f32::INFINITY, f32::NEG_INFINITY);
            let mut prev = points[points.len() - 1];
            for &p in points {
                // Half-open in y, so a vertex on the scanline counts once per edge pair.
                if (prev.y <= yc) != (p.y <= yc) {
                    // Always from the upper end, so an edge gives the same x in either winding.
                    let (top, bottom) = if prev.y < p.y { (prev, p) } else { (p, prev) };
                    let x = top.x + (yc - top.y) * ((bottom.x - top.x) / (bottom.y - top.y));
                    xl = xl.min(x);
                    xr = xr.max(x);
                }
                prev = p;
            }
            if let Some((x0, x1)) = Self::centre_range(xl, xr, self.width) {
                self.span(row, x0, x1, colour);
            }
        }
    }

    /// Fills triangle `a b c` (in either winding): every pixel whose centre lies inside. Covers
    /// the same pixels as [`Canvas::fill_convex`] with the three points, with the edge slopes
    /// computed once instead of per row.
    pub fn fill_triangle(&mut self, a: Vec2, b: Vec2, c: Vec2, colour: u8) {
        // Sort by y: a on top (smallest y), c at the bottom.
        let (a, b) = if b.y < a.y { (b, a) } else { (a, b) };
        let (b, c) = if c.y < b.y { (c, b) } else { (b, c) };
        let (a, b) = if b.y < a.y { (b, a) } else { (a, b) };
        let (lo_x, hi_x) = (a.x.min(b.x).min(c.x), a.x.max(b.x).max(c.x));
        if !(hi_x >= 0.0 && lo_x <= self.width as f32) {
            return;
        }
        let Some((row0, row1)) = Self::centre_range(a.y, c.y, self.height) else {
            return;
        };
        // Only rows whose centres lie in the half-open [a.y, c.y) are crossed by the edges, and a
        // zero-height edge is never used, so the inverse slopes below are never taken of 0 / 0.
        let slope = |p: Vec2, q: Vec2| (q.x - p.x) / (q.y - p.y);
        let (s_ac, s_ab, s_bc) = (slope(a, c), slope(a, b), slope(b, c));
        for row in row0..=row1 {
            let yc = row as f32 + 0.5;
            if yc < a.y || yc >= c.y {
                continue;
            }
            let x_long = a.x + (yc - a.y) * s_ac;
            let x_short = if yc < b.y {
                a.x + (yc - a.y) * s_ab
            } else {
                b.x + (yc - b.y) * s_bc
            };
            if let Some((x0, x1)) =
                Self::centre_range(x_long.min(x_short), x_long.max(x_short), self.width)
            {
                self.span(row, x0, x1, colour);
            }
        }
    }

    /// Fills the disc of `radius` pixels around `centre`. The pixel holding the centre is always
    /// coloured, so a tiny disc still shows as a dot.
    pub fn fill_circle(&mut self, centre: Vec2, radius: f32, colour: u8) {
        self.dot(centre, colour);
        let r = radius.max(0.0);
        if !(centre.x + r >= 0.0 && centre.x - r <= self.width as f32) {
            return;
        }
        let Some((row0, row1)) = Self::centre_range(centre.y - r, centre.y + r, self.height) else {
            return;
        };
        let r_sq = r * r;
        for row in row0..=row1 {
            let dy = row as f32 + 0.5 - centre.y;
            let half = (r_sq - dy * dy).max(0.0).sqrt();
            if let Some((x0, x1)) = Self::centre_range(centre.x - half, centre.x + half, self.width)
            {
                self.span(row, x0, x1, colour);
            }
        }
    }

    /// Draws a one-pixel line from `a` to `b` (both ends included), clipped to the canvas.
    pub fn line(&mut self, a: Vec2, b: Vec2, colour: u8) {
        let Some((a, b)) = clip_segment(a, b, self.width as f32, self.height as f32) else {
            return;
        };
        let d = b - a;
        // After clipping the segment spans at most the canvas diagonal; the cap also guards
        // against infinities from far-off input.
        let cap = (self.width + self.height) as f32 * 2.0;
        let steps = d.x.abs().max(d.y.abs()).ceil().clamp(1.0, cap) as u32;
        let step = d / steps as f32;
        for k in 0..=steps {
            let p = a + step * k as f32;
            self.set_pixel(p.x.floor() as i32, p.y.floor() as i32, colour);
        }
    }

    /// Draws a line `width` pixels thick from `a` to `b` as a filled quad (at least one pixel).
    pub fn thick_line(&mut self, a: Vec2, b: Vec2, width: f32, colour: u8) {
        let d = b - a;
        let len = d.length();
        if width <= 1.0 || !len.is_finite() || len <= 0.0 {
            self.line(a, b, colour);
            return;
        }
        let n = Vec2::new(-d.y, d.x) * (0.5 * width / len);
        self.fill_convex(&[a + n, b + n, b - n, a - n], colour);
        self.line(a, b, colour);
    }

    /// Draws one-pixel lines through `points` in order.
    pub fn polyline(&mut self, points: &[Vec2], colour: u8) {
        for pair in points.windows(2) {
            self.line(pair[0], pair[1], colour);
        }
    }
}

/// Clips segment `a b` to the rectangle `[0, w] x [0, h]` (Liang-Barsky); `None` when it misses.
fn clip_segment(a: Vec2, b: Vec2, w: f32, h: f32) -> Option<(Vec2, Vec2)> {
    let d = b - a;
    let (mut t0, mut t1) = (0.0_f32, 1.0_f32);
    for (p, q) in [(-d.x, a.x), (d.x, w - a.x), (-d.y, a.y), (d.y, h - a.y)] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                if r > t1 {
                    return None;
                }
                t0 = t0.max(r);
            } else {
                if r < t0 {
                    return None;
                }
                t1 = t1.min(r);
            }
        }
    }
    Some((a + d * t0, a + d * t1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn count(c: &Canvas, colour: u8) -> usize {
        c.pixels().iter().filter(|&&p| p == colour).count()
    }

    #[test]
    fn sizes_are_checked() {
        assert!(matches!(Canvas::new(0, 10), Err(Error::NotPositive { .. })));
        assert!(matches!(Canvas::new(10, 0), Err(Error::NotPositive { .. })));
        assert!(matches!(
            Canvas::new(MAX_SIDE + 1, 10),
            Err(Error::OutOfRange { .. })
        ));
        let c = Canvas::new(3, 2).unwrap();
        assert_eq!(c.pixels().len(), 6);
        assert_eq!(c.pixel(3, 0), None);
    }

    #[test]
    fn triangle_covers_about_its_area() {
        let mut c = Canvas::new(100, 100).unwrap();
        c.fill_triangle(
            Vec2::new(10.0, 10.0),
            Vec2::new(90.0, 10.0),
            Vec2::new(10.0, 90.0),
            1,
        );
        let n = count(&c, 1) as f32;
        assert!((n - 3200.0).abs() < 100.0, "{n}");
        // Winding does not matter.
        let mut d = Canvas::new(100, 100).unwrap();
        d.fill_triangle(
            Vec2::new(10.0, 10.0),
            Vec2::new(10.0, 90.0),
            Vec2::new(90.0, 10.0),
            1,
        );
        assert_eq!(c, d);
    }

    #[test]
    fn circle_covers_about_its_area() {
        let mut c = Canvas::new(100, 100).unwrap();
        c.fill_circle(Vec2::new(50.0, 50.0), 20.0, 1);
        let n = count(&c, 1) as f32;
        let area = std::f32::consts::PI * 400.0;
        assert!((n - area).abs() < 0.03 * area, "{n} vs {area}");
        assert_eq!(c.pixel(50, 50), Some(1));
        assert_eq!(c.pixel(50, 29), Some(0));
    }

    #[test]
    fn line_joins_its_ends() {
        let mut c = Canvas::new(50, 50).unwrap();
        c.line(Vec2::new(2.5, 3.5), Vec2::new(40.5, 20.5), 1);
        assert_eq!(c.pixel(2, 3), Some(1));
        assert_eq!(c.pixel(40, 20), Some(1));
        assert_eq!(count(&c, 1), 39);
        // A line through the canvas from far outside is clipped, not skipped.
        let mut c = Canvas::new(50, 50).unwrap();
        c.line(Vec2::new(-1e9, 25.5), Vec2::new(1e9, 25.5), 1);
        assert_eq!(count(&c, 1), 50);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]
        /// Shapes anywhere, of any size, never panic and never touch pixels they do not cover.
        #[test]
        fn primitives_clip_without_panicking(
            pts in prop::collection::vec((-1e7_f32..1e7, -1e7_f32..1e7), 3),
            r in 0.0_f32..1e6,
            w in 1_u32..40, h in 1_u32..40,
        ) {
            let mut c = Canvas::new(w, h).unwrap();
            let p: Vec<Vec2> = pts.iter().map(|&(x, y)| Vec2::new(x, y)).collect();
            c.fill_triangle(p[0], p[1], p[2], 1);
            c.fill_circle(p[0], r, 2);
            c.line(p[1], p[2], 3);
            c.thick_line(p[0], p[2], 3.0, 4);
            c.dot(p[1], 5);
            prop_assert_eq!(c.pixels().len(), (w * h) as usize);
        }

        /// The triangle fast path covers exactly the pixels of the general convex fill.
        #[test]
        fn triangle_matches_convex_fill(
            pts in prop::collection::vec((-20.0_f32..60.0, -20.0_f32..60.0), 3),
            snap in any::<bool>(),
        ) {
            // Snapping to half-pixels puts vertices and edges exactly on pixel centres.
            let p: Vec<Vec2> = pts
                .iter()
                .map(|&(x, y)| if snap { Vec2::new((x * 2.0).round() / 2.0, (y * 2.0).round() / 2.0) } else { Vec2::new(x, y) })
                .collect();
            let mut fast = Canvas::new(40, 40).unwrap();
            let mut general = Canvas::new(40, 40).unwrap();
            fast.fill_triangle(p[0], p[1], p[2], 1);
            general.fill_convex(&p, 1);
            prop_assert_eq!(fast, general);
        }

        /// A disc that lies wholly outside the canvas colours nothing.
        #[test]
        fn outside_disc_draws_nothing(x in 60.0_f32..1e6, y in -1e6_f32..1e6, r in 0.0_f32..10.0) {
            let mut c = Canvas::new(40, 40).unwrap();
            c.fill_circle(Vec2::new(x + r, y), r, 1);
            c.fill_triangle(Vec2::new(x, y), Vec2::new(x + r, y), Vec2::new(x, y + r + 1.0), 1);
            prop_assert_eq!(count(&c, 1), 0);
        }
    }
}
