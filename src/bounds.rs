//! World bounds and the metric every neighbour query uses.
//!
//! A world is an open plane, a walled rectangle, or a wrap-around rectangle (a torus, as in the
//! vehicle notes). Rectangles span `[0, size.x) x [0, size.y)`. On a torus the offset between two
//! points is the *minimum image*: the shortest of the wrapped differences, computed per axis by
//! [`Bounds::offset`]. Every backend of the neighbour index uses that one function, so all of them
//! report bit-identical offsets.

use glam::Vec2;
use serde::{Deserialize, Serialize};

use crate::error::{Error, MAX_COORDINATE, Result, positive};

/// The shape of the world agents live in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Bounds {
    /// An unbounded plane: no wrap, no walls.
    #[default]
    Open,
    /// A rectangle `[0, size.x] x [0, size.y]` whose edges agents are kept inside.
    Bounded {
        /// Width and height in world units.
        size: Vec2,
    },
    /// A wrap-around rectangle `[0, size.x) x [0, size.y)`: leaving one edge re-enters at the other.
    Torus {
        /// Width and height in world units.
        size: Vec2,
    },
}

impl Bounds {
    /// A wrap-around world of `width x height`.
    ///
    /// # Errors
    /// [`Error::NotPositive`] or [`Error::NonFinite`] for a bad side.
    pub fn torus(width: f32, height: f32) -> Result<Self> {
        let b = Bounds::Torus {
            size: Vec2::new(width, height),
        };
        b.validate()?;
        Ok(b)
    }

    /// A walled world of `width x height`.
    ///
    /// # Errors
    /// [`Error::NotPositive`] or [`Error::NonFinite`] for a bad side.
    pub fn bounded(width: f32, height: f32) -> Result<Self> {
        let b = Bounds::Bounded {
            size: Vec2::new(width, height),
        };
        b.validate()?;
        Ok(b)
    }

    /// Checks the bounds' numbers.
    ///
    /// # Errors
    /// [`Error::NotPositive`] or [`Error::NonFinite`] for a bad side.
    pub fn validate(&self) -> Result<()> {
        match *self {
            Bounds::Open => Ok(()),
            Bounds::Bounded { size } | Bounds::Torus { size } => {
                positive("world width", size.x)?;
                positive("world height", size.y)?;
                crate::error::in_range("world width", size.x, 0.0, MAX_COORDINATE, "(0, 1e18]")?;
                crate::error::in_range("world height", size.y, 0.0, MAX_COORDINATE, "(0, 1e18]")?;
                Ok(())
            }
        }
    }

    /// The rectangle's size, or `None` for an open world.
    #[must_use]
    pub fn size(&self) -> Option<Vec2> {
        match *self {
            Bounds::Open => None,
            Bounds::Bounded { size } | Bounds::Torus { size } => Some(size),
        }
    }

    /// Whether the world wraps around.
    #[must_use]
    pub fn is_torus(&self) -> bool {
        matches!(self, Bounds::Torus { .. })
    }

    /// Whether `p` lies in the world (inside the rectangle, or anywhere when open).
    #[must_use]
    pub fn contains(&self, p: Vec2) -> bool {
        match *self {
            Bounds::Open => p.is_finite(),
            Bounds::Bounded { size } => p.x >= 0.0 && p.y >= 0.0 && p.x <= size.x && p.y <= size.y,
            Bounds::Torus { size } => p.x >= 0.0 && p.y >= 0.0 && p.x < size.x && p.y < size.y,
        }
    }

    /// Checks that `p` is finite and lies in the world.
    ///
    /// # Errors
    /// [`Error::NonFinite`] or [`Error::Invalid`] when outside.
    pub fn check_point(&self, name: &'static str, p: Vec2) -> Result<Vec2> {
        crate::error::coordinate(name, p)?;
        if self.contains(p) {
            Ok(p)
        } else {
            Err(Error::Invalid {
                name: name.to_string(),
                reason: format!("({}, {}) lies outside the world {self:?}", p.x, p.y),
            })
        }
    }

    /// The offset from `from` to `to` under the world's metric: the plain difference, or on a torus
    /// the minimum image (per axis, a difference of more than half the side is wrapped once; exactly
    /// half is kept as it is).
    #[inline]
    #[must_use]
    pub fn offset(&self, from: Vec2, to: Vec2) -> Vec2 {
        let d = to - from;
        match *self {
            Bounds::Torus { size } => Vec2::new(wrap_delta(d.x, size.x), wrap_delta(d.y, size.y)),
            _ => d,
        }
    }

    /// Squared distance between two points under the world's metric.
    #[inline]
    #[must_use]
    pub fn distance_sq(&self, a: Vec2, b: Vec2) -> f32 {
        self.offset(a, b).length_squared()
    }

    /// Maps a point back into the world: wraps it on a torus, clamps it to the rectangle when
    /// bounded, leaves it when open.
    #[inline]
    #[must_use]
    pub fn wrap(&self, p: Vec2) -> Vec2 {
        match *self {
            Bounds::Open => p,
            Bounds::Bounded { size } => p.clamp(Vec2::ZERO, size),
            Bounds::Torus { size } => Vec2::new(wrap_coord(p.x, size.x), wrap_coord(p.y, size.y)),
        }
    }
}

/// Wraps one axis of a difference to its minimum image, for `|d| < 2 * side`.
#[inline]
#[must_use]
pub fn wrap_delta(d: f32, side: f32) -> f32 {
    let half = 0.5 * side;
    if d > half {
        d - side
    } else if d < -half {
        d + side
    } else {
        d
    }
}

/// Wraps a coordinate into `[0, side)`.
#[inline]
#[must_use]
pub fn wrap_coord(x: f32, side: f32) -> f32 {
    if (0.0..side).contains(&x) {
        return x;
    }
    let w = x.rem_euclid(side);
    // rem_euclid can round up to exactly `side` for tiny negative inputs.
    if w >= side { 0.0 } else { w }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn minimum_image_wraps_across_the_seam() {
        let b = Bounds::torus(10.0, 10.0).unwrap();
        assert_eq!(
            b.offset(Vec2::new(9.5, 1.0), Vec2::new(0.5, 1.0)),
            Vec2::new(1.0, 0.0)
        );
        assert_eq!(
            b.offset(Vec2::new(0.5, 0.5), Vec2::new(9.5, 9.5)),
            Vec2::new(-1.0, -1.0)
        );
        assert_eq!(
            b.offset(Vec2::new(0.0, 0.0), Vec2::new(5.0, 0.0)),
            Vec2::new(5.0, 0.0)
        );
    }

    #[test]
    fn wrap_coord_stays_in_range() {
        for x in [-1e-9_f32, -10.0, -0.0, 10.0, 25.3, -7.25, f32::MIN_POSITIVE] {
            let w = wrap_coord(x, 10.0);
            assert!((0.0..10.0).contains(&w), "{x} -> {w}");
        }
    }

    #[test]
    fn bad_sides_are_rejected() {
        assert!(matches!(
            Bounds::torus(0.0, 1.0),
            Err(Error::NotPositive { .. })
        ));
        assert!(matches!(
            Bounds::bounded(f32::NAN, 1.0),
            Err(Error::NonFinite { .. })
        ));
    }
}
