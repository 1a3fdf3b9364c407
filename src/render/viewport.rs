//! The map from world coordinates to canvas pixels.
//!
//! A [`Viewport`] shows a world rectangle `[min, max]` on a canvas with one uniform scale for both
//! axes (so circles stay round), centred with letterbox bars on the longer side. World y points up
//! and pixel y points down: a point with a larger world y appears higher in the picture.

use glam::Vec2;

use super::Canvas;
use super::canvas::check_size;
use crate::error::{Error, Result, finite_vec, positive};

/// Maps world coordinates to pixel coordinates of a `width x height` canvas.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Viewport {
    min: Vec2,
    max: Vec2,
    scale: f32,
    /// Pixel position of the world point `(min.x, max.y)` (the picture's top-left corner).
    origin: Vec2,
    width: u32,
    height: u32,
}

impl Viewport {
    /// Shows the world rectangle `[min, max]` on a `width x height` picture, letterboxed.
    ///
    /// # Examples
    /// ```
    /// # fn main() -> throng::Result<()> {
    /// use glam::Vec2;
    /// use throng::render::Viewport;
    /// let vp = Viewport::new(Vec2::ZERO, Vec2::new(100.0, 50.0), 200, 200)?;
    /// assert_eq!(vp.scale(), 2.0);
    /// // The world's top-left corner sits at the top of the letterboxed band.
    /// assert_eq!(vp.to_pixel(Vec2::new(0.0, 50.0)), Vec2::new(0.0, 50.0));
    /// # Ok(())
    /// # }
    /// ```
    ///
    /// # Errors
    /// [`Error::NonFinite`] for a non-finite corner, [`Error::Invalid`] unless `min < max` on both
    /// axes, [`Error::NotPositive`] or [`Error::OutOfRange`] for a bad picture size, and
    /// [`Error::NonFinite`] when the rectangle is too small for its scale to be represented.
    pub fn new(min: Vec2, max: Vec2, width: u32, height: u32) -> Result<Self> {
        finite_vec("viewport min", min)?;
        finite_vec("viewport max", max)?;
        check_size(width, height)?;
        let span = max - min;
        if !(span.x > 0.0 && span.y > 0.0) {
            return Err(Error::Invalid {
                name: "viewport".to_string(),
                reason: format!(
                    "min ({}, {}) must lie below and left of max ({}, {})",
                    min.x, min.y, max.x, max.y
                ),
            });
        }
        let scale = positive(
            "viewport scale",
            (width as f32 / span.x).min(height as f32 / span.y),
        )?;
        let origin = Vec2::new(
            width as f32 - span.x * scale,
            height as f32 - span.y * scale,
        ) * 0.5;
        Ok(Viewport {
            min,
            max,
            scale,
            origin,
            width,
            height,
        })
    }

    /// Shows `[min, max]` on `canvas`'s size.
    ///
    /// # Errors
    /// As [`Viewport::new`].
    pub fn fit(min: Vec2, max: Vec2, canvas: &Canvas) -> Result<Self> {
        Self::new(min, max, canvas.width(), canvas.height())
    }

    /// Pixels per world unit.
    #[must_use]
    pub fn scale(&self) -> f32 {
        self.scale
    }

    /// The world rectangle's lower-left corner.
    #[must_use]
    pub fn min(&self) -> Vec2 {
        self.min
    }

    /// The world rectangle's upper-right corner.
    #[must_use]
    pub fn max(&self) -> Vec2 {
        self.max
    }

    /// The picture's width in pixels.
    #[must_use]
    pub fn width(&self) -> u32 {
        self.width
    }

    /// The picture's height in pixels.
    #[must_use]
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The pixel position of world point `p` (y flipped).
    #[inline]
    #[must_use]
    pub fn to_pixel(&self, p: Vec2) -> Vec2 {
        Vec2::new(
            self.origin.x + (p.x - self.min.x) * self.scale,
            self.origin.y + (self.max.y - p.y) * self.scale,
        )
    }

    /// The world point at pixel position `q`: the inverse of [`Viewport::to_pixel`].
    #[inline]
    #[must_use]
    pub fn to_world(&self, q: Vec2) -> Vec2 {
        Vec2::new(
            self.min.x + (q.x - self.origin.x) / self.scale,
            self.max.y - (q.y - self.origin.y) / self.scale,
        )
    }

    /// A world direction as a pixel direction (y flipped, not scaled).
    #[inline]
    #[must_use]
    pub fn to_pixel_dir(&self, d: Vec2) -> Vec2 {
        Vec2::new(d.x, -d.y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_map_to_the_letterboxed_band() {
        let vp = Viewport::new(Vec2::new(-10.0, 0.0), Vec2::new(10.0, 10.0), 100, 100).unwrap();
        assert_eq!(vp.scale(), 5.0);
        assert_eq!(vp.to_pixel(Vec2::new(-10.0, 10.0)), Vec2::new(0.0, 25.0));
        assert_eq!(vp.to_pixel(Vec2::new(10.0, 0.0)), Vec2::new(100.0, 75.0));
        // Up in the world is up in the picture.
        assert!(vp.to_pixel(Vec2::new(0.0, 9.0)).y < vp.to_pixel(Vec2::new(0.0, 1.0)).y);
        let p = Vec2::new(3.25, 7.5);
        assert!((vp.to_world(vp.to_pixel(p)) - p).length() < 1e-5);
    }

    #[test]
    fn bad_rectangles_are_rejected() {
        assert!(matches!(
            Viewport::new(Vec2::ONE, Vec2::ONE, 10, 10),
            Err(Error::Invalid { .. })
        ));
        assert!(matches!(
            Viewport::new(Vec2::ZERO, Vec2::new(f32::NAN, 1.0), 10, 10),
            Err(Error::NonFinite { .. })
        ));
        assert!(matches!(
            Viewport::new(Vec2::ZERO, Vec2::ONE, 0, 10),
            Err(Error::NotPositive { .. })
        ));
        assert!(Viewport::new(Vec2::ZERO, Vec2::splat(1e-44), 10, 10).is_err());
    }
}
