//! The heading/side basis of a vehicle and its local <-> world transforms (Buckland's vehicle
//! drawing matrix).

use glam::{Affine2, Mat2, Vec2};

/// A vehicle's local frame: `heading` (unit, forward), `side` (unit, the heading turned a quarter
/// turn counter-clockwise: left) and `position` (the origin).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Basis {
    /// Forward unit vector.
    pub heading: Vec2,
    /// Left unit vector, `heading.perp()`.
    pub side: Vec2,
    /// The frame's origin in world coordinates.
    pub position: Vec2,
}

impl Basis {
    /// The frame of an agent at `position` facing `orientation` radians.
    #[must_use]
    pub fn from_orientation(position: Vec2, orientation: f32) -> Self {
        let (s, c) = orientation.sin_cos();
        let heading = Vec2::new(c, s);
        Basis {
            heading,
            side: heading.perp(),
            position,
        }
    }

    /// The frame of an agent at `position` moving at `velocity`; falls back to `orientation`
    /// when the agent is at rest.
    #[must_use]
    pub fn from_velocity(position: Vec2, velocity: Vec2, orientation: f32) -> Self {
        match velocity.try_normalize() {
            Some(heading) => Basis {
                heading,
                side: heading.perp(),
                position,
            },
            None => Self::from_orientation(position, orientation),
        }
    }

    /// A point given in the local frame (x forward, y left), in world coordinates.
    #[inline]
    #[must_use]
    pub fn to_world(&self, local: Vec2) -> Vec2 {
        self.position + self.heading * local.x + self.side * local.y
    }

    /// A world point in the local frame.
    #[inline]
    #[must_use]
    pub fn to_local(&self, world: Vec2) -> Vec2 {
        let d = world - self.position;
        Vec2::new(d.dot(self.heading), d.dot(self.side))
    }

    /// A local direction (no translation) in world coordinates.
    #[inline]
    #[must_use]
    pub fn vector_to_world(&self, local: Vec2) -> Vec2 {
        self.heading * local.x + self.side * local.y
    }

    /// The affine matrix (columns heading, side; translation position) that draws a vehicle
    /// modelled in local coordinates at its place in the world.
    #[must_use]
    pub fn matrix(&self) -> Affine2 {
        Affine2::from_mat2_translation(Mat2::from_cols(self.heading, self.side), self.position)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn local_world_round_trip() {
        let b = Basis::from_orientation(Vec2::new(3.0, -2.0), 0.7);
        let p = Vec2::new(1.5, -0.25);
        let w = b.to_world(p);
        assert!((b.to_local(w) - p).length() < 1e-5);
        assert!((b.matrix().transform_point2(p) - w).length() < 1e-5);
        let north = Basis::from_orientation(Vec2::ZERO, std::f32::consts::FRAC_PI_2);
        assert!((north.to_world(Vec2::X) - Vec2::Y).length() < 1e-6);
        assert!(
            (north.to_world(Vec2::Y) + Vec2::X).length() < 1e-6,
            "side is to the left"
        );
    }
}
