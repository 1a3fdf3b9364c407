//! The `[geometry]` table of a scenario: the walkable area as WKT (docs/SCENARIOS.md,
//! "Geometry").
//!
//! Invariants: the WKT is parsed and checked when the file is read, so a bad area is an error
//! with the file, line and column of its value and the key's name; with a walkable area the
//! world is walled to the area's bounding box when the file gives no size (see
//! [`Scenario::bounds`](super::Scenario::bounds)), its rings become walls, a `[field]` without a
//! map of its own rasterises it, and every spawned agent stands inside it, at least its radius
//! from every wall and outside the field's wall cells.

use glam::Vec2;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::geometry::Walkable;

/// The `[geometry]` table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GeometrySpec {
    /// The walkable area: a WKT `POLYGON` (exterior ring, then holes) or `MULTIPOLYGON`.
    #[serde(deserialize_with = "walkable_key")]
    pub walkable: Walkable,
}

/// Reads `geometry.walkable`, naming the key in the error.
fn walkable_key<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Walkable, D::Error> {
    let text = String::deserialize(d)?;
    Walkable::from_wkt(&text)
        .map_err(|e| serde::de::Error::custom(format!("geometry.walkable: {e}")))
}

/// Whether an agent of radius `radius` may start at `p` in `world`: inside the walkable area,
/// at least `radius` from every wall, outside every field's wall cells.
pub(crate) fn spawn_ok(world: &crate::world::World, p: Vec2, radius: f32) -> bool {
    world.walkable().is_none_or(|a| {
        a.contains(p) && !world.obstacles().near_wall(p, radius) && !world.in_field_wall(p)
    })
}

/// The reason a placed agent may not start at `p` (see [`spawn_ok`]).
pub(crate) fn spawn_error(
    world: &crate::world::World,
    group: usize,
    k: usize,
    p: Vec2,
    radius: f32,
) -> Error {
    let why = if world.walkable().is_some_and(|a| !a.contains(p)) {
        "lies outside the walkable area (or in one of its holes)".to_string()
    } else if world.obstacles().near_wall(p, radius) {
        format!("lies within the agent radius {radius} of a wall")
    } else {
        "lies in a wall cell of the field".to_string()
    };
    Error::Invalid {
        name: format!("groups[{group}].spawn"),
        reason: format!("agent {k} at ({}, {}) {why}", p.x, p.y),
    }
}

impl GeometrySpec {
    /// Checks the area against the world: a torus cannot hold one, and a walled world given with
    /// a size must contain it.
    pub(crate) fn check_world(&self, bounds: crate::bounds::Bounds) -> Result<()> {
        let a = &self.walkable;
        match bounds {
            crate::bounds::Bounds::Torus { .. } => Err(Error::Invalid {
                name: "geometry.walkable".into(),
                reason: "a walkable area needs a bounded or open world, not a torus".into(),
            }),
            crate::bounds::Bounds::Bounded { size }
                if a.min().x < 0.0
                    || a.min().y < 0.0
                    || a.max().x > size.x
                    || a.max().y > size.y =>
            {
                Err(Error::Invalid {
                    name: "geometry.walkable".into(),
                    reason: format!(
                        "the area ({}, {}) - ({}, {}) does not fit in the world [0, {}] x [0, {}]",
                        a.min().x,
                        a.min().y,
                        a.max().x,
                        a.max().y,
                        size.x,
                        size.y
                    ),
                })
            }
            _ => Ok(()),
        }
    }
}
