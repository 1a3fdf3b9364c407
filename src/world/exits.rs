//! Exits: rectangles or polygons through which agents leave the world (an evacuation's doors).
//!
//! After every step, agents whose centre lies inside an exit are removed, in descending storage
//! order so that the removals do not depend on anything but the positions; `StepStats::left`
//! counts them, and [`World::departures`] lists them with the position at which they left until
//! the next step (so that measurements can still see the last move of an agent that is gone).
//! Exits are part of a checkpoint; departures are not (a loaded world has none).
//!
//! An exit is a rectangle `[min, max]` or, with `polygon`, a [`Walkable`] (a WKT polygon with
//! holes, or a multipolygon) whose bounding box is then `min` and `max`. The serialised form is
//! `{ min, max }` for a rectangle (as before polygons existed, so old checkpoints load) and
//! `{ polygon = "POLYGON (...)" }` for a polygon.

use glam::Vec2;
use serde::{Deserialize, Serialize};

use crate::agents::AgentId;
use crate::error::{Error, Result, finite_vec};
use crate::geometry::Walkable;

/// An agent that left the world through an exit, and where it stood when it left.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Departure {
    /// The agent's id (no longer live).
    pub id: AgentId,
    /// Its position at the end of the step in which it left (inside an exit).
    pub position: Vec2,
}

/// An exit: an axis-aligned rectangle, or a polygon with its bounding box.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "ExitRepr", into = "ExitRepr")]
pub struct Exit {
    /// The lower corner (of the polygon's bounding box, for a polygon exit).
    pub min: Vec2,
    /// The upper corner (each coordinate at least `min`'s).
    pub max: Vec2,
    /// The polygon, when the exit is not the rectangle. Default: none.
    pub polygon: Option<Walkable>,
}

/// The serialised form of an [`Exit`]: `min` and `max`, or `polygon`.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ExitRepr {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    min: Option<Vec2>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    max: Option<Vec2>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    polygon: Option<String>,
}

impl TryFrom<ExitRepr> for Exit {
    type Error = String;

    fn try_from(r: ExitRepr) -> std::result::Result<Self, String> {
        match (r.min, r.max, r.polygon) {
            (Some(min), Some(max), None) => Ok(Exit::rect(min, max)),
            (None, None, Some(text)) => Walkable::from_wkt(&text)
                .map(Exit::polygon)
                .map_err(|e| format!("exits.polygon: {e}")),
            (_, _, Some(_)) => Err("an exit is `min` and `max` or `polygon`, not both".into()),
            _ => Err("an exit needs `min` and `max`, or `polygon`".into()),
        }
    }
}

impl From<Exit> for ExitRepr {
    fn from(e: Exit) -> Self {
        match e.polygon {
            Some(p) => ExitRepr {
                min: None,
                max: None,
                polygon: Some(p.to_wkt()),
            },
            None => ExitRepr {
                min: Some(e.min),
                max: Some(e.max),
                polygon: None,
            },
        }
    }
}

impl Exit {
    /// The rectangle `[min, max]` (checked when it is added to a world).
    #[must_use]
    pub fn rect(min: Vec2, max: Vec2) -> Self {
        Exit {
            min,
            max,
            polygon: None,
        }
    }

    /// A polygon exit (its bounding box becomes `min` and `max`).
    #[must_use]
    pub fn polygon(area: Walkable) -> Self {
        Exit {
            min: area.min(),
            max: area.max(),
            polygon: Some(area),
        }
    }

    /// Whether `p` lies inside (a rectangle's edges included; a polygon's edges either way).
    #[must_use]
    pub fn contains(&self, p: Vec2) -> bool {
        let in_box =
            p.x >= self.min.x && p.x <= self.max.x && p.y >= self.min.y && p.y <= self.max.y;
        in_box && self.polygon.as_ref().is_none_or(|a| a.contains(p))
    }

    /// The exit as WKT: its polygon, or the rectangle as a `POLYGON` (the geometry of
    /// trajectory files).
    #[must_use]
    pub fn to_wkt(&self) -> String {
        match &self.polygon {
            Some(a) => a.to_wkt(),
            None => {
                let (a, b) = (self.min, self.max);
                format!(
                    "POLYGON (({} {}, {} {}, {} {}, {} {}, {} {}))",
                    a.x, a.y, b.x, a.y, b.x, b.y, a.x, b.y, a.x, a.y
                )
            }
        }
    }

    /// Checks the corners (a polygon was checked when it was made; its box must be its own).
    ///
    /// # Errors
    /// [`Error::NonFinite`] for a corner that is not finite, [`Error::Invalid`] when `min`
    /// exceeds `max` or a polygon's box is not `min` and `max`.
    pub fn validate(&self) -> Result<()> {
        finite_vec("exit.min", self.min)?;
        finite_vec("exit.max", self.max)?;
        if self.min.x > self.max.x || self.min.y > self.max.y {
            return Err(Error::Invalid {
                name: "exit".into(),
                reason: "min must not exceed max".into(),
            });
        }
        if let Some(a) = &self.polygon
            && (a.min() != self.min || a.max() != self.max)
        {
            return Err(Error::Invalid {
                name: "exit".into(),
                reason: "a polygon exit's min and max are its polygon's bounding box".into(),
            });
        }
        Ok(())
    }
}
