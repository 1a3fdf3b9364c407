//! WKT text for walkable areas: `POLYGON` and `MULTIPOLYGON` read through the `wkt` crate,
//! written back in the same form (the geometry column of a trajectory file).
//!
//! Invariants: only `POLYGON` and `MULTIPOLYGON` are read (a pre-scan refuses other types, text
//! after the geometry, unbalanced or nested-too-deep parentheses and texts over
//! [`MAX_WKT_BYTES`] before the parser sees them, so no input can recurse or allocate without
//! bound); `z` and `m` coordinates are ignored; written numbers are `f32`'s shortest round-trip
//! form, so writing and reading again gives the same area bit for bit.

use std::fmt::Write as _;
use std::str::FromStr;

use glam::Vec2;
use serde::{Deserialize, Serialize};

use super::{AreaPolygon, Walkable};
use crate::error::{Error, Result};

/// The longest WKT text read, bytes (4 MiB: [`MAX_VERTICES`](super::MAX_VERTICES) points with
/// long numbers fit).
pub const MAX_WKT_BYTES: usize = 4 << 20;

fn invalid(reason: impl Into<String>) -> Error {
    Error::Invalid {
        name: "area".into(),
        reason: reason.into(),
    }
}

/// Checks the shape of the text before the parser reads it: the geometry type, balanced
/// parentheses at most as deep as the type needs, nothing after the geometry.
fn prescan(text: &str) -> Result<()> {
    if text.len() > MAX_WKT_BYTES {
        return Err(invalid(format!(
            "the WKT text has {} bytes, more than the {MAX_WKT_BYTES} allowed",
            text.len()
        )));
    }
    let body = text.trim_start();
    let word: String = body
        .chars()
        .take_while(char::is_ascii_alphabetic)
        .collect::<String>()
        .to_ascii_uppercase();
    let depth_allowed = match word.as_str() {
        "POLYGON" => 2,
        "MULTIPOLYGON" => 3,
        "" => return Err(invalid("expected a WKT POLYGON or MULTIPOLYGON")),
        other => {
            return Err(invalid(format!(
                "expected a WKT POLYGON or MULTIPOLYGON, got {}",
                crate::error::escaped(&other.chars().take(40).collect::<String>())
            )));
        }
    };
    let mut depth = 0usize;
    for (i, c) in body.char_indices() {
        match c {
            '(' => {
                depth += 1;
                if depth > depth_allowed {
                    return Err(invalid(format!(
                        "too many nested parentheses for a {word} at byte {i}"
                    )));
                }
            }
            ')' => {
                if depth == 0 {
                    return Err(invalid(format!("an unmatched ')' at byte {i}")));
                }
                depth -= 1;
                if depth == 0 && !body[i + 1..].trim().is_empty() {
                    return Err(invalid(format!("text after the {word} at byte {}", i + 1)));
                }
            }
            _ => {}
        }
    }
    if depth != 0 {
        return Err(invalid("unbalanced parentheses: a ')' is missing"));
    }
    Ok(())
}

/// The points of one parsed ring, checked to be closed; the closing point is dropped later.
fn ring_points(ring: &::wkt::types::LineString<f64>, name: &str) -> Result<Vec<Vec2>> {
    let coords = ring.coords();
    let (Some(first), Some(last)) = (coords.first(), coords.last()) else {
        return Err(invalid(format!("{name} is empty")));
    };
    if first.x != last.x || first.y != last.y {
        return Err(invalid(format!(
            "{name} is not closed: it starts at ({}, {}) and ends at ({}, {})",
            first.x, first.y, last.x, last.y
        )));
    }
    let mut out = Vec::with_capacity(coords.len());
    for c in coords {
        let p = Vec2::new(c.x as f32, c.y as f32);
        if !(c.x.is_finite() && c.y.is_finite() && p.is_finite()) {
            return Err(invalid(format!(
                "{name}: the point ({}, {}) is not a finite f32",
                c.x, c.y
            )));
        }
        out.push(p);
    }
    Ok(out)
}

fn polygon_of(poly: &::wkt::types::Polygon<f64>, p: usize) -> Result<AreaPolygon> {
    let rings = poly.rings();
    if rings.is_empty() {
        return Err(invalid(format!("polygon {p} is empty")));
    }
    let mut parsed = Vec::with_capacity(rings.len());
    for (r, ring) in rings.iter().enumerate() {
        parsed.push(ring_points(ring, &super::ring_name(p, r))?);
    }
    let exterior = parsed.remove(0);
    Ok(AreaPolygon::new(exterior, parsed))
}

impl Walkable {
    /// Reads a WKT `POLYGON` (exterior ring, then holes) or `MULTIPOLYGON`, in either winding;
    /// `z` and `m` coordinates are ignored. Rings must be closed (the last point repeats the
    /// first).
    ///
    /// # Errors
    /// [`Error::Invalid`] naming what is wrong: not a polygon or multipolygon, a syntax error,
    /// an empty geometry, a ring that is not closed, or any check of
    /// [`Walkable::from_polygons`].
    pub fn from_wkt(text: &str) -> Result<Self> {
        prescan(text)?;
        let parsed = ::wkt::Wkt::<f64>::from_str(text)
            .map_err(|e| invalid(format!("the WKT does not parse: {e}")))?;
        let polygons = match &parsed {
            ::wkt::Wkt::Polygon(p) => vec![polygon_of(p, 0)?],
            ::wkt::Wkt::MultiPolygon(m) => {
                if m.polygons().is_empty() {
                    return Err(invalid("the multipolygon is empty"));
                }
                m.polygons()
                    .iter()
                    .enumerate()
                    .map(|(p, poly)| polygon_of(poly, p))
                    .collect::<Result<Vec<_>>>()?
            }
            _ => return Err(invalid("expected a WKT POLYGON or MULTIPOLYGON")),
        };
        Self::from_polygons(polygons)
    }

    /// The area as WKT: `POLYGON ((x y, ...), (...))` for one polygon, `MULTIPOLYGON` for more;
    /// rings closed, exterior rings counter-clockwise and holes clockwise.
    #[must_use]
    pub fn to_wkt(&self) -> String {
        let mut out = String::new();
        let polygon = |out: &mut String, poly: &AreaPolygon| {
            out.push('(');
            for (r, ring) in poly.rings().enumerate() {
                if r > 0 {
                    out.push_str(", ");
                }
                write_ring(out, ring);
            }
            out.push(')');
        };
        if let [single] = self.polygons.as_slice() {
            out.push_str("POLYGON ");
            polygon(&mut out, single);
        } else {
            out.push_str("MULTIPOLYGON (");
            for (k, poly) in self.polygons.iter().enumerate() {
                if k > 0 {
                    out.push_str(", ");
                }
                polygon(&mut out, poly);
            }
            out.push(')');
        }
        out
    }
}

impl FromStr for Walkable {
    type Err = Error;

    /// As [`Walkable::from_wkt`].
    fn from_str(s: &str) -> Result<Self> {
        Walkable::from_wkt(s)
    }
}

impl std::fmt::Display for Walkable {
    /// As [`Walkable::to_wkt`].
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.to_wkt())
    }
}

/// A walkable area is serialised as its WKT text (scenario files, checkpoints).
impl Serialize for Walkable {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.serialize_str(&self.to_wkt())
    }
}

impl<'de> Deserialize<'de> for Walkable {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        let text = String::deserialize(d)?;
        Walkable::from_wkt(&text).map_err(serde::de::Error::custom)
    }
}

/// Appends one WKT ring, `(x y, x y, ..., x y)`, with the first point repeated at the end.
pub fn write_ring(out: &mut String, ring: &[Vec2]) {
    out.push('(');
    for (k, p) in ring.iter().chain(ring.first()).enumerate() {
        if k > 0 {
            out.push_str(", ");
        }
        let _ = write!(out, "{} {}", p.x, p.y);
    }
    out.push(')');
}
