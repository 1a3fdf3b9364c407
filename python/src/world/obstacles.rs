//! Obstacles and gravity points of a `throng.World` from Python: circles, walls, polygons, and
//! gravity points with their motion.
//!
//! Invariant: each is checked as the Rust API checks it before the world changes.

use pyo3::prelude::*;
use throng::gravity::{GravityPoint, Motion};
use throng::obstacles::{Circle, Wall};

use super::PyWorld;
use crate::error::{OrRaise, guarded};
use crate::{arrays, convert};

#[pymethods]
impl PyWorld {
    /// Adds a circular obstacle; no agent may stand inside it.
    fn add_circle(&mut self, center: &Bound<'_, PyAny>, radius: f32) -> PyResult<()> {
        guarded(|| {
            let center = convert::vec2("center", center)?;
            self.world.add_circle(Circle { center, radius }).or_raise()
        })
    }

    /// Adds a wall: the segment from `a` to `b`, which agents cannot cross.
    fn add_wall(&mut self, a: &Bound<'_, PyAny>, b: &Bound<'_, PyAny>) -> PyResult<()> {
        guarded(|| {
            let wall = Wall {
                a: convert::vec2("a", a)?,
                b: convert::vec2("b", b)?,
            };
            self.world.add_wall(wall).or_raise()
        })
    }

    /// Adds the walls of a polyline through `points` ((m, 2)), closed into a polygon when
    /// `closed`.
    #[pyo3(signature = (points, closed=true))]
    fn add_polygon(&mut self, points: &Bound<'_, PyAny>, closed: bool) -> PyResult<()> {
        guarded(|| {
            let pts: Vec<glam::Vec2> = arrays::read_pairs("points", points)?
                .into_iter()
                .map(Into::into)
                .collect();
            self.world.add_polygon(&pts, closed).or_raise()
        })
    }

    /// Adds a gravity point pushing agents with `strength / distance**exponent` within
    /// `radius` (a positive strength repels, a negative one attracts); returns its index.
    /// `motion` is a dict as in scenario files: {"kind": "linear", "velocity": (vx, vy)},
    /// {"kind": "orbit", "center": (x, y), "orbit_radius": r, "angular_speed": w} or
    /// {"kind": "agent", "agent": id}; default static.
    #[pyo3(signature = (position, strength, radius, *, exponent=2.0, motion=None))]
    fn add_gravity_point(
        &mut self,
        position: &Bound<'_, PyAny>,
        strength: f32,
        radius: f32,
        exponent: f32,
        motion: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<usize> {
        guarded(|| {
            let motion: Motion = match motion {
                Some(m) => convert::deserialize_from_py("motion", m)?,
                None => Motion::Static,
            };
            let point = GravityPoint {
                position: convert::vec2("position", position)?,
                strength,
                exponent,
                radius,
                motion,
            };
            point.validate().or_raise()?;
            self.world.add_gravity_point(point).or_raise()
        })
    }

    /// The gravity points' current positions as a (K, 2) float32 array.
    fn gravity_positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let p = self.world.gravity().points();
        arrays::pairs(py, p.len(), None, |i| p[i].position.into(), None)
    }

    /// Moves gravity point `k`.
    fn set_gravity_position(&mut self, k: usize, position: &Bound<'_, PyAny>) -> PyResult<()> {
        guarded(|| {
            let p = convert::vec2("position", position)?;
            self.world.set_gravity_position(k, p).or_raise()
        })
    }
}
