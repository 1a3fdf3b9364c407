//! Walkable areas: polygons with holes, as JuPedSim, PedPy and SUMO describe a pedestrian
//! geometry, read from and written back as WKT (`POLYGON` or `MULTIPOLYGON`).
//!
//! A [`Walkable`] is one or more disjoint polygons, each an exterior ring with any number of
//! holes (obstacles, pillars, rooms that are not walkable). It gives the three views the
//! simulation needs of one geometry:
//!
//! - **walls** for the local models ([`Walkable::walls`]): every ring's edges in ring order, the
//!   last joining the first, so the obstacle set and ORCA's `WallChains` see each ring as one
//!   closed chain;
//! - a **point test** ([`Walkable::contains`]): inside an exterior ring and outside its holes;
//! - a **raster** into the occupancy grid that flow fields navigate on ([`Walkable::rasterize`]).
//!
//! It lives beside `obstacles` and `field` rather than inside either because it feeds both (and
//! the world's exits, whose polygons are `Walkable`s too).
//!
//! Invariants (checked by every constructor, so a `Walkable` is always valid):
//! - coordinates are finite and at most [`crate::error::MAX_COORDINATE`] in
//!   magnitude; rings are stored open (the closing point is not repeated), without consecutive
//!   duplicate points, each with at least 3 distinct points and a non-zero area;
//! - **winding**: exterior rings run counter-clockwise and holes clockwise (the OGC and
//!   GeoJSON rule, shapely's `orient(sign=1.0)`); input of either winding is normalised on load,
//!   and each ring starts at its corner of least x (then least y), so a clockwise input gives
//!   the same rings and walls as the counter-clockwise one. ORCA's
//!   `WallChains` accepts closed loops of either winding, so this is a convention for readers of
//!   the rings and of [`Walkable::to_wkt`], not a requirement of the obstacle code;
//! - no two edges of the whole area cross, overlap or touch, except consecutive edges of one
//!   ring at their shared corner (so rings are simple, a hole never touches its exterior, and
//!   each ring stays one closed wall chain); every hole lies inside its exterior ring and
//!   outside the other holes; no polygon lies inside the walkable part of another (a polygon
//!   inside another's hole, an island, is allowed);
//! - at most [`MAX_VERTICES`] vertices over all rings.

mod raster;
mod text;

use glam::Vec2;

use crate::error::{Error, MAX_COORDINATE, Result};
use crate::obstacles::Wall;

pub use raster::MAX_RASTER_SPANS;
pub use text::{MAX_WKT_BYTES, write_ring};

/// The most vertices a walkable area (or an exit polygon) may have over all its rings: the
/// validity checks are quadratic in the worst case, and 20,000 keeps them under a second.
pub const MAX_VERTICES: usize = 20_000;

/// One polygon of a walkable area: an exterior ring and its holes, each a list of corners
/// without the closing point.
#[derive(Clone, Debug, PartialEq)]
pub struct AreaPolygon {
    exterior: Vec<Vec2>,
    holes: Vec<Vec<Vec2>>,
}

impl AreaPolygon {
    /// A polygon from its exterior ring and holes, in either winding, closed (last point equal
    /// to the first) or not; checked and normalised when it becomes part of a [`Walkable`].
    #[must_use]
    pub fn new(exterior: Vec<Vec2>, holes: Vec<Vec<Vec2>>) -> Self {
        AreaPolygon { exterior, holes }
    }

    /// The exterior ring, counter-clockwise, without the closing point.
    #[must_use]
    pub fn exterior(&self) -> &[Vec2] {
        &self.exterior
    }

    /// The holes, each clockwise, without the closing point.
    #[must_use]
    pub fn holes(&self) -> &[Vec<Vec2>] {
        &self.holes
    }

    /// The exterior ring, then the holes.
    pub fn rings(&self) -> impl Iterator<Item = &[Vec2]> {
        std::iter::once(self.exterior.as_slice()).chain(self.holes.iter().map(Vec::as_slice))
    }
}

/// A walkable area: disjoint polygons with holes (see the module docs for its invariants).
///
/// # Examples
/// ```
/// # fn main() -> throng::Result<()> {
/// use throng::geometry::Walkable;
/// use glam::Vec2;
/// let room = Walkable::from_wkt("POLYGON ((0 0, 10 0, 10 10, 0 10, 0 0), (4 4, 6 4, 6 6, 4 6, 4 4))")?;
/// assert!(room.contains(Vec2::new(1.0, 1.0)));
/// assert!(!room.contains(Vec2::new(5.0, 5.0))); // in the hole
/// assert_eq!(room.walls().len(), 8);
/// assert_eq!(room.to_wkt(), "POLYGON ((0 0, 10 0, 10 10, 0 10, 0 0), (4 4, 4 6, 6 6, 6 4, 4 4))");
/// # Ok(()) }
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Walkable {
    polygons: Vec<AreaPolygon>,
    min: Vec2,
    max: Vec2,
}

/// Twice the signed area of a ring (positive when counter-clockwise), in `f64`.
#[must_use]
pub fn twice_area(ring: &[Vec2]) -> f64 {
    let n = ring.len();
    (0..n)
        .map(|i| {
            let (a, b) = (ring[i], ring[(i + 1) % n]);
            f64::from(a.x) * f64::from(b.y) - f64::from(b.x) * f64::from(a.y)
        })
        .sum()
}

/// Whether `p` lies inside `ring` by the crossing rule (points on the edge count either way);
/// ORCA's closed wall loops use it too.
pub(crate) fn ring_contains(ring: &[Vec2], p: Vec2) -> bool {
    let mut inside = false;
    let mut j = ring.len() - 1;
    for i in 0..ring.len() {
        let (a, b) = (ring[i], ring[j]);
        if (a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x {
            inside = !inside;
        }
        j = i;
    }
    inside
}

/// How a ring is named in errors.
fn ring_name(p: usize, r: usize) -> String {
    if r == 0 {
        format!("polygon {p}, exterior ring")
    } else {
        format!("polygon {p}, hole {}", r - 1)
    }
}

/// Checks and cleans one ring: finite bounded coordinates, the closing point and consecutive
/// duplicates dropped, at least three distinct points, a non-zero area; oriented
/// counter-clockwise when `ccw`, clockwise otherwise.
fn clean_ring(ring: &[Vec2], name: &str, ccw: bool) -> Result<Vec<Vec2>> {
    let bad = |reason: String| Error::Invalid {
        name: name.to_string(),
        reason,
    };
    let mut out: Vec<Vec2> = Vec::with_capacity(ring.len());
    for &p in ring {
        if !(p.is_finite() && p.x.abs() <= MAX_COORDINATE && p.y.abs() <= MAX_COORDINATE) {
            return Err(bad(format!(
                "the point ({}, {}) is not finite or lies beyond 1e18",
                p.x, p.y
            )));
        }
        if out.last() != Some(&p) {
            out.push(p);
        }
    }
    while out.len() > 1 && out.first() == out.last() {
        out.pop();
    }
    if out.len() < 3 {
        return Err(bad(format!(
            "a ring needs at least 3 distinct points, it has {}",
            out.len()
        )));
    }
    let area = twice_area(&out);
    if area == 0.0 {
        let (a, b) = (out[0], out[1]);
        let collinear = out.iter().all(|&p| {
            f64::from(b.x - a.x) * f64::from(p.y - a.y)
                == f64::from(b.y - a.y) * f64::from(p.x - a.x)
        });
        return Err(bad(if collinear {
            "the ring has no area (its points are collinear)".into()
        } else {
            "the ring crosses itself (its parts cancel to no area)".into()
        }));
    }
    if (area > 0.0) != ccw {
        out.reverse();
    }
    // A canonical start, so that the winding alone never changes the ring.
    let start = (0..out.len())
        .min_by(|&i, &j| {
            (out[i].x, out[i].y)
                .partial_cmp(&(out[j].x, out[j].y))
                .unwrap_or(std::cmp::Ordering::Equal)
        })
        .unwrap_or(0);
    out.rotate_left(start);
    Ok(out)
}

/// `(b - a) x (c - a)` in `f64`.
fn orient(a: Vec2, b: Vec2, c: Vec2) -> f64 {
    let (ax, ay) = (f64::from(a.x), f64::from(a.y));
    (f64::from(b.x) - ax) * (f64::from(c.y) - ay) - (f64::from(b.y) - ay) * (f64::from(c.x) - ax)
}

/// Whether `p`, collinear with `a -> b`, lies on that segment.
fn within(a: Vec2, b: Vec2, p: Vec2) -> bool {
    p.x >= a.x.min(b.x) && p.x <= a.x.max(b.x) && p.y >= a.y.min(b.y) && p.y <= a.y.max(b.y)
}

/// Whether the closed segments `a -> b` and `c -> d` share a point.
fn segments_meet(a: Vec2, b: Vec2, c: Vec2, d: Vec2) -> bool {
    let (d1, d2) = (orient(c, d, a), orient(c, d, b));
    let (d3, d4) = (orient(a, b, c), orient(a, b, d));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    (d1 == 0.0 && within(c, d, a))
        || (d2 == 0.0 && within(c, d, b))
        || (d3 == 0.0 && within(a, b, c))
        || (d4 == 0.0 && within(a, b, d))
}

/// One edge for the crossing check: its ends, its ring and its place in the ring.
#[derive(Clone, Copy)]
struct Edge {
    a: Vec2,
    b: Vec2,
    ring: usize,
    k: usize,
    len: usize,
}

/// Checks that no two edges of `rings` meet except consecutive edges of one ring at their
/// shared corner (where they must not fold back onto each other). A sweep over x: each edge is
/// tested against the edges whose x-range overlaps its own.
fn check_crossings(rings: &[(String, &[Vec2])]) -> Result<()> {
    let mut edges = Vec::new();
    for (r, (_, ring)) in rings.iter().enumerate() {
        let n = ring.len();
        for k in 0..n {
            edges.push(Edge {
                a: ring[k],
                b: ring[(k + 1) % n],
                ring: r,
                k,
                len: n,
            });
        }
    }
    edges.sort_by(|e, f| e.a.x.min(e.b.x).total_cmp(&f.a.x.min(f.b.x)));
    for (i, e) in edges.iter().enumerate() {
        let e_max = e.a.x.max(e.b.x);
        let (e_lo, e_hi) = (e.a.y.min(e.b.y), e.a.y.max(e.b.y));
        for f in &edges[i + 1..] {
            if f.a.x.min(f.b.x) > e_max {
                break;
            }
            if f.a.y.max(f.b.y) < e_lo || f.a.y.min(f.b.y) > e_hi {
                continue;
            }
            let (first, second) = if (e.ring, e.k) < (f.ring, f.k) {
                (e, f)
            } else {
                (f, e)
            };
            let same = first.ring == second.ring;
            let next = same && second.k == first.k + 1;
            let wrap = same && first.k == 0 && second.k == first.len - 1;
            let meets = if next || wrap {
                // Consecutive edges share a corner; they must not run back along each other.
                let (p, q, r) = if next {
                    (first.a, first.b, second.b)
                } else {
                    (second.a, second.b, first.b)
                };
                orient(p, q, r) == 0.0 && (q - p).dot(r - q) < 0.0
            } else {
                segments_meet(e.a, e.b, f.a, f.b)
            };
            if meets {
                let (ne, nf) = (&rings[e.ring].0, &rings[f.ring].0);
                let what = if e.ring == f.ring {
                    format!("{ne} crosses or touches itself")
                } else {
                    format!("{ne} crosses or touches {nf}")
                };
                return Err(Error::Invalid {
                    name: "area".into(),
                    reason: format!(
                        "{what}: the edge ({}, {}) - ({}, {}) meets the edge ({}, {}) - ({}, {})",
                        e.a.x, e.a.y, e.b.x, e.b.y, f.a.x, f.a.y, f.b.x, f.b.y
                    ),
                });
            }
        }
    }
    Ok(())
}

impl Walkable {
    /// A walkable area from polygons, checked and normalised (see the module docs).
    ///
    /// # Errors
    /// [`Error::Invalid`] naming the polygon and ring for: no polygon, more than
    /// [`MAX_VERTICES`] vertices, a point that is not finite or beyond 1e18, a ring with fewer
    /// than 3 distinct points or no area, edges that cross or touch, a hole outside its
    /// exterior ring or inside another hole, a polygon inside another.
    pub fn from_polygons(polygons: Vec<AreaPolygon>) -> Result<Self> {
        if polygons.is_empty() {
            return Err(Error::Invalid {
                name: "area".into(),
                reason: "it has no polygon".into(),
            });
        }
        let vertices = polygons
            .iter()
            .flat_map(AreaPolygon::rings)
            .map(<[Vec2]>::len)
            .fold(0usize, usize::saturating_add);
        if vertices > MAX_VERTICES {
            return Err(Error::Invalid {
                name: "area".into(),
                reason: format!("{vertices} vertices, more than the {MAX_VERTICES} allowed"),
            });
        }
        let mut clean = Vec::with_capacity(polygons.len());
        for (p, poly) in polygons.iter().enumerate() {
            let exterior = clean_ring(&poly.exterior, &ring_name(p, 0), true)?;
            let holes = poly
                .holes
                .iter()
                .enumerate()
                .map(|(h, ring)| clean_ring(ring, &ring_name(p, h + 1), false))
                .collect::<Result<Vec<_>>>()?;
            clean.push(AreaPolygon { exterior, holes });
        }
        let named: Vec<(String, &[Vec2])> = clean
            .iter()
            .enumerate()
            .flat_map(|(p, poly)| {
                poly.rings()
                    .enumerate()
                    .map(move |(r, ring)| (ring_name(p, r), ring))
            })
            .collect();
        check_crossings(&named)?;
        // With no edges meeting, one corner tells on which side of a ring a whole ring lies.
        let invalid = |reason: String| Error::Invalid {
            name: "area".into(),
            reason,
        };
        for (p, poly) in clean.iter().enumerate() {
            for (h, hole) in poly.holes.iter().enumerate() {
                if !ring_contains(&poly.exterior, hole[0]) {
                    return Err(invalid(format!(
                        "{} lies outside its exterior ring",
                        ring_name(p, h + 1)
                    )));
                }
                if let Some(g) = (0..poly.holes.len())
                    .find(|&g| g != h && ring_contains(&poly.holes[g], hole[0]))
                {
                    return Err(invalid(format!(
                        "{} lies inside {}",
                        ring_name(p, h + 1),
                        ring_name(p, g + 1)
                    )));
                }
            }
        }
        let mut area = Walkable {
            polygons: Vec::new(),
            min: Vec2::splat(f32::INFINITY),
            max: Vec2::splat(f32::NEG_INFINITY),
        };
        for (p, poly) in clean.iter().enumerate() {
            let single = Walkable {
                polygons: vec![poly.clone()],
                min: Vec2::ZERO,
                max: Vec2::ZERO,
            };
            if let Some(q) = (0..clean.len())
                .find(|&q| q != p && single.contains_unbounded(clean[q].exterior[0]))
            {
                return Err(invalid(format!(
                    "polygon {q} lies inside the walkable part of polygon {p}"
                )));
            }
            for &v in &poly.exterior {
                area.min = area.min.min(v);
                area.max = area.max.max(v);
            }
        }
        area.polygons = clean;
        Ok(area)
    }

    /// A walkable area of one polygon: its exterior ring and holes, in either winding.
    ///
    /// # Errors
    /// As [`Walkable::from_polygons`].
    pub fn from_rings(exterior: Vec<Vec2>, holes: Vec<Vec<Vec2>>) -> Result<Self> {
        Self::from_polygons(vec![AreaPolygon::new(exterior, holes)])
    }

    /// The axis-aligned rectangle `[min, max]`, as an area.
    ///
    /// # Errors
    /// As [`Walkable::from_polygons`] (a rectangle without area is an error).
    pub fn rectangle(min: Vec2, max: Vec2) -> Result<Self> {
        Self::from_rings(
            vec![min, Vec2::new(max.x, min.y), max, Vec2::new(min.x, max.y)],
            Vec::new(),
        )
    }

    /// The polygons, normalised (exterior rings counter-clockwise, holes clockwise).
    #[must_use]
    pub fn polygons(&self) -> &[AreaPolygon] {
        &self.polygons
    }

    /// Every ring of every polygon, exterior rings before their holes.
    pub fn rings(&self) -> impl Iterator<Item = &[Vec2]> {
        self.polygons.iter().flat_map(AreaPolygon::rings)
    }

    /// The number of vertices over all rings.
    #[must_use]
    pub fn vertex_count(&self) -> usize {
        self.rings().map(<[Vec2]>::len).sum()
    }

    /// The lower corner of the bounding box.
    #[must_use]
    pub fn min(&self) -> Vec2 {
        self.min
    }

    /// The upper corner of the bounding box.
    #[must_use]
    pub fn max(&self) -> Vec2 {
        self.max
    }

    /// The walkable area (exterior areas less the holes), square units.
    #[must_use]
    pub fn area(&self) -> f64 {
        // Exterior rings are counter-clockwise (positive), holes clockwise (negative).
        self.rings().map(twice_area).sum::<f64>() * 0.5
    }

    /// Whether `p` lies in the walkable area: inside an exterior ring and outside its holes.
    /// Points exactly on an edge may count either way.
    #[must_use]
    pub fn contains(&self, p: Vec2) -> bool {
        if !(p.x >= self.min.x && p.x <= self.max.x && p.y >= self.min.y && p.y <= self.max.y) {
            return false;
        }
        self.contains_unbounded(p)
    }

    /// [`Walkable::contains`] without the bounding-box test: the crossing rule over every ring
    /// (the rings are disjoint and holes nested in their exteriors, so the parity is the answer).
    fn contains_unbounded(&self, p: Vec2) -> bool {
        self.rings()
            .fold(false, |inside, r| inside ^ ring_contains(r, p))
    }

    /// The distance from `p` to the nearest edge of any ring.
    #[must_use]
    pub fn distance_to_boundary(&self, p: Vec2) -> f32 {
        self.edges()
            .map(|w| w.closest_point(p).distance(p))
            .fold(f32::INFINITY, f32::min)
    }

    /// Every ring's edges in ring order, the last of a ring joining its last corner to its first.
    fn edges(&self) -> impl Iterator<Item = Wall> + '_ {
        self.rings().flat_map(|r| {
            (0..r.len()).map(move |k| Wall {
                a: r[k],
                b: r[(k + 1) % r.len()],
            })
        })
    }

    /// The walls of the area: every ring's edges in ring order, the last edge of a ring ending
    /// where its first begins, so each ring is one closed wall chain (for the obstacle set and
    /// ORCA's edge chains). Exterior rings' walls come counter-clockwise, holes' clockwise.
    #[must_use]
    pub fn walls(&self) -> Vec<Wall> {
        self.edges().collect()
    }

    /// The same area moved by `offset` (a scenario's tiles).
    ///
    /// # Errors
    /// As [`Walkable::from_polygons`]: moved points may leave the coordinate range, or meet
    /// after rounding.
    pub fn translated(&self, offset: Vec2) -> Result<Self> {
        self.mapped(|q| q + offset)
    }

    /// The image of the area under `f`, a map of the plane that keeps polygons simple (a
    /// translation, a rotation, a mirror image); rings are normalised again, so a mirror's
    /// reversed windings are set right.
    ///
    /// # Errors
    /// As [`Walkable::from_polygons`].
    pub fn mapped(&self, f: impl Fn(Vec2) -> Vec2) -> Result<Self> {
        let moved = |ring: &[Vec2]| ring.iter().map(|&q| f(q)).collect::<Vec<_>>();
        Self::from_polygons(
            self.polygons
                .iter()
                .map(|p| {
                    AreaPolygon::new(
                        moved(&p.exterior),
                        p.holes.iter().map(|h| moved(h)).collect(),
                    )
                })
                .collect(),
        )
    }
}

#[cfg(test)]
mod tests;
