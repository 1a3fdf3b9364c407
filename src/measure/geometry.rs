//! Measurement lines and areas: validated geometry and the two predicates the recorder needs
//! (does a move cross a line, and in which direction; is a point inside an area).
//!
//! Invariants: a [`MeasurementLine`] has finite, distinct end points; a [`MeasurementArea`] is
//! a simple polygon (finite vertices, between 3 and
//! [`MAX_POLYGON_VERTICES`](crate::limits::MAX_POLYGON_VERTICES) of them, no zero-length edge,
//! no two edges touching except neighbours at their shared vertex, positive area). Names are
//! 1 to [`MAX_MEASUREMENT_NAME`](crate::limits::MAX_MEASUREMENT_NAME) bytes of ASCII letters,
//! digits, `_`, `-` and `.`, so they can head CSV columns as they are. The predicates compute
//! in `f64`.

use glam::{DVec2, Vec2};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::limits::{MAX_MEASUREMENT_NAME, MAX_POLYGON_VERTICES};

/// A counting line: agents whose move between two frames crosses the segment `from -> to` are
/// counted, in one of two directions.
///
/// The **positive** direction is to the right of `from -> to` (the line's direction turned
/// clockwise by 90 degrees): for a line from `(0, 0)` to `(0, 1)`, agents walking towards `+x`
/// cross it positively.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, try_from = "LineSpec")]
pub struct MeasurementLine {
    /// The name (CSV columns and the summary use it).
    pub name: String,
    /// One end.
    pub from: Vec2,
    /// The other end.
    pub to: Vec2,
}

/// The unchecked form of a [`MeasurementLine`], as a scenario file spells it.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LineSpec {
    name: String,
    from: Vec2,
    to: Vec2,
}

impl TryFrom<LineSpec> for MeasurementLine {
    type Error = Error;
    fn try_from(s: LineSpec) -> Result<Self> {
        let line = MeasurementLine {
            name: s.name,
            from: s.from,
            to: s.to,
        };
        line.validate()?;
        Ok(line)
    }
}

/// A crossing of a line by one move: which way, and where along the move (0 at its start, 1 at
/// its end).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Cut {
    /// +1 for the positive direction, -1 for the negative one.
    pub sign: i8,
    /// Fraction of the move at which it meets the line.
    pub at: f64,
}

impl MeasurementLine {
    /// A checked line.
    ///
    /// # Errors
    /// As [`MeasurementLine::validate`].
    pub fn new(name: &str, from: Vec2, to: Vec2) -> Result<Self> {
        let line = MeasurementLine {
            name: name.to_string(),
            from,
            to,
        };
        line.validate()?;
        Ok(line)
    }

    /// Checks the name and the end points.
    ///
    /// # Errors
    /// [`Error::Invalid`] naming the line for a bad name, an end that is not finite, or two
    /// equal ends.
    pub fn validate(&self) -> Result<()> {
        check_name("measurement line", &self.name)?;
        let bad = |reason: &str| Error::Invalid {
            name: format!("measurement line `{}`", self.name),
            reason: reason.to_string(),
        };
        if !(self.from.is_finite() && self.to.is_finite()) {
            return Err(bad("`from` and `to` must be finite points"));
        }
        if self.from == self.to {
            return Err(bad("`from` and `to` must differ"));
        }
        Ok(())
    }

    /// The line's length (the width `b` of the specific flow `J / b`).
    #[must_use]
    pub fn length(&self) -> f64 {
        self.from.as_dvec2().distance(self.to.as_dvec2())
    }

    /// Whether the move `p -> q` crosses the line, and which way.
    ///
    /// Sides are half-open: a point is on the right when it lies strictly to the right, and on
    /// the left otherwise (on the line counts as left). A move crosses when it changes side at a
    /// point of the segment (its ends included). So a move along the line never crosses, a move
    /// that ends on the line from the left does not cross (the next move that leaves it to the
    /// right does), and one that ends on it from the right crosses negatively at once.
    #[must_use]
    pub(crate) fn cut(&self, p: DVec2, q: DVec2) -> Option<Cut> {
        let a = self.from.as_dvec2();
        let d = self.to.as_dvec2() - a;
        // d x (r - a): negative on the right of from -> to.
        let side = |r: DVec2| d.perp_dot(r - a);
        let (sp, sq) = (side(p), side(q));
        let sign = match (sp < 0.0, sq < 0.0) {
            (false, true) => 1,
            (true, false) => -1,
            _ => return None,
        };
        let at = (sp / (sp - sq)).clamp(0.0, 1.0);
        let x = p + (q - p) * at;
        let u = (x - a).dot(d) / d.length_squared();
        (0.0..=1.0).contains(&u).then_some(Cut { sign, at })
    }
}

/// A measurement area: a simple polygon in which agents are counted every frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, try_from = "AreaSpec")]
pub struct MeasurementArea {
    /// The name (CSV columns and the summary use it).
    pub name: String,
    /// The vertices in order, either winding, the closing vertex not repeated.
    pub polygon: Vec<Vec2>,
}

/// The unchecked form of a [`MeasurementArea`]: `polygon` as `[[x, y], ...]` or as a WKT
/// `POLYGON ((x y, ...))` with a single ring.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct AreaSpec {
    name: String,
    polygon: PolygonSpec,
}

#[derive(Deserialize)]
#[serde(
    untagged,
    expecting = "`polygon` must be a list of [x, y] points or a WKT POLYGON string"
)]
enum PolygonSpec {
    Points(Vec<Vec2>),
    Wkt(String),
}

impl TryFrom<AreaSpec> for MeasurementArea {
    type Error = Error;
    fn try_from(s: AreaSpec) -> Result<Self> {
        let points = match s.polygon {
            PolygonSpec::Points(p) => p,
            PolygonSpec::Wkt(text) => parse_wkt_polygon(&s.name, &text)?,
        };
        MeasurementArea::new(&s.name, points)
    }
}

impl MeasurementArea {
    /// A checked area; a last vertex equal to the first (a closed ring, as WKT writes it) is
    /// dropped.
    ///
    /// # Errors
    /// As [`MeasurementArea::validate`].
    pub fn new(name: &str, mut polygon: Vec<Vec2>) -> Result<Self> {
        if polygon.len() > 1 && polygon.first() == polygon.last() {
            polygon.pop();
        }
        let area = MeasurementArea {
            name: name.to_string(),
            polygon,
        };
        area.validate()?;
        Ok(area)
    }

    /// Checks the name and that the polygon is simple.
    ///
    /// # Errors
    /// [`Error::Invalid`] naming the area: a bad name, fewer than 3 or more than
    /// [`MAX_POLYGON_VERTICES`] vertices, a vertex that is not finite, a zero-length edge, two
    /// edges that touch or cross, or a zero area.
    pub fn validate(&self) -> Result<()> {
        check_name("measurement area", &self.name)?;
        let bad = |reason: String| Error::Invalid {
            name: format!("measurement area `{}`", self.name),
            reason,
        };
        let n = self.polygon.len();
        if !(3..=MAX_POLYGON_VERTICES).contains(&n) {
            return Err(bad(format!(
                "`polygon` has {n} vertices; it needs 3 to {MAX_POLYGON_VERTICES}"
            )));
        }
        if let Some(k) = self.polygon.iter().position(|p| !p.is_finite()) {
            return Err(bad(format!("`polygon` vertex {k} is not a finite point")));
        }
        let v: Vec<DVec2> = self.polygon.iter().map(|p| p.as_dvec2()).collect();
        let edge = |k: usize| (v[k], v[(k + 1) % n]);
        for k in 0..n {
            let (a, b) = edge(k);
            if a == b {
                return Err(bad(format!(
                    "`polygon` vertices {k} and {} are the same point",
                    (k + 1) % n
                )));
            }
        }
        for i in 0..n {
            for j in i + 1..n {
                let neighbours = j == i + 1 || (i == 0 && j == n - 1);
                let (a, b) = edge(i);
                let (c, d) = edge(j);
                let touch = if neighbours {
                    // Neighbours share one vertex; they must not overlap beyond it.
                    let shared = if j == i + 1 { b } else { a };
                    let (p, q) = if j == i + 1 { (a, d) } else { (b, c) };
                    collinear_overlap(shared, p, q)
                } else {
                    segments_touch(a, b, c, d)
                };
                if touch {
                    return Err(bad(format!(
                        "`polygon` is not simple: edges {i} and {j} touch or cross"
                    )));
                }
            }
        }
        if self.area() <= 0.0 {
            return Err(bad("`polygon` encloses no area".into()));
        }
        Ok(())
    }

    /// The enclosed area (shoelace formula), positive whatever the winding.
    #[must_use]
    pub fn area(&self) -> f64 {
        let n = self.polygon.len();
        let twice: f64 = (0..n)
            .map(|k| {
                let (a, b) = (
                    self.polygon[k].as_dvec2(),
                    self.polygon[(k + 1) % n].as_dvec2(),
                );
                a.perp_dot(b)
            })
            .sum();
        0.5 * twice.abs()
    }

    /// The lower and upper corners of the bounding box.
    #[must_use]
    pub fn bounding_box(&self) -> (Vec2, Vec2) {
        self.polygon.iter().fold(
            (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY)),
            |(lo, hi), &p| (lo.min(p), hi.max(p)),
        )
    }

    /// Whether `p` lies inside (even-odd rule with half-open edges: of two areas that share an
    /// edge, a point on it belongs to exactly one).
    #[must_use]
    pub fn contains(&self, p: Vec2) -> bool {
        let p = p.as_dvec2();
        let n = self.polygon.len();
        let mut inside = false;
        let mut j = n - 1;
        for i in 0..n {
            let (a, b) = (self.polygon[i].as_dvec2(), self.polygon[j].as_dvec2());
            if (a.y > p.y) != (b.y > p.y) {
                let x = a.x + (p.y - a.y) / (b.y - a.y) * (b.x - a.x);
                if p.x < x {
                    inside = !inside;
                }
            }
            j = i;
        }
        inside
    }
}

/// Whether the neighbouring edges `shared -> p` and `shared -> q` overlap beyond their shared
/// vertex (they point the same way along one line).
fn collinear_overlap(shared: DVec2, p: DVec2, q: DVec2) -> bool {
    let (u, w) = (p - shared, q - shared);
    u.perp_dot(w) == 0.0 && u.dot(w) > 0.0
}

/// Whether the closed segments `a b` and `c d` have a point in common.
fn segments_touch(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> bool {
    let orient = |p: DVec2, q: DVec2, r: DVec2| (q - p).perp_dot(r - p);
    let on = |p: DVec2, q: DVec2, r: DVec2| {
        r.x >= p.x.min(q.x) && r.x <= p.x.max(q.x) && r.y >= p.y.min(q.y) && r.y <= p.y.max(q.y)
    };
    let (o1, o2) = (orient(a, b, c), orient(a, b, d));
    let (o3, o4) = (orient(c, d, a), orient(c, d, b));
    if o1 * o2 < 0.0 && o3 * o4 < 0.0 {
        return true;
    }
    (o1 == 0.0 && on(a, b, c))
        || (o2 == 0.0 && on(a, b, d))
        || (o3 == 0.0 && on(c, d, a))
        || (o4 == 0.0 && on(c, d, b))
}

/// The vertices of a WKT `POLYGON ((x y, x y, ...))` with one ring (no holes).
fn parse_wkt_polygon(name: &str, text: &str) -> Result<Vec<Vec2>> {
    let bad = |reason: &str| Error::Invalid {
        name: format!("measurement area `{name}`"),
        reason: format!("`polygon` {reason}"),
    };
    let t = text.trim();
    let body = t
        .get(..7)
        .filter(|head| head.eq_ignore_ascii_case("polygon"))
        .map(|_| t[7..].trim())
        .ok_or_else(|| bad("must be a list of [x, y] points or a WKT POLYGON string"))?;
    let ring = body
        .strip_prefix('(')
        .and_then(|b| b.strip_suffix(')'))
        .map(str::trim)
        .and_then(|b| b.strip_prefix('('))
        .and_then(|b| b.strip_suffix(')'))
        .ok_or_else(|| bad("must read POLYGON ((x y, x y, ...))"))?;
    if ring.contains('(') || ring.contains(')') {
        return Err(bad(
            "must have one ring: holes are not supported in a measurement area",
        ));
    }
    ring.split(',')
        .map(|pair| {
            let xy: Vec<f32> = pair
                .split_whitespace()
                .map(str::parse::<f32>)
                .collect::<std::result::Result<_, _>>()
                .map_err(|_| bad(&format!("has a bad point `{}`", pair.trim())))?;
            match xy[..] {
                [x, y] => Ok(Vec2::new(x, y)),
                _ => Err(bad(&format!(
                    "has a point `{}` without exactly two coordinates",
                    pair.trim()
                ))),
            }
        })
        .collect()
}

/// Checks a line's or an area's name.
fn check_name(what: &str, name: &str) -> Result<()> {
    let ok = !name.is_empty()
        && name.len() <= MAX_MEASUREMENT_NAME
        && name
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || matches!(b, b'_' | b'-' | b'.'));
    if ok {
        Ok(())
    } else {
        Err(Error::Invalid {
            name: format!("{what} name"),
            reason: format!(
                "`{name}` must be 1 to {MAX_MEASUREMENT_NAME} ASCII letters, digits, `_`, `-` or `.`"
            ),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn d(x: f64, y: f64) -> DVec2 {
        DVec2::new(x, y)
    }

    #[test]
    fn a_move_across_is_cut_once_with_its_direction() {
        let l = MeasurementLine::new("l", Vec2::new(0.0, 0.0), Vec2::new(0.0, 2.0)).unwrap();
        let c = l.cut(d(-1.0, 1.0), d(1.0, 1.0)).unwrap();
        assert_eq!(c.sign, 1);
        assert_eq!(c.at, 0.5);
        assert_eq!(l.cut(d(1.0, 1.0), d(-3.0, 1.0)).unwrap().sign, -1);
        assert_eq!(l.cut(d(1.0, 1.0), d(-3.0, 1.0)).unwrap().at, 0.25);
        // Beyond the ends, and along the line: no cut.
        assert_eq!(l.cut(d(-1.0, 3.0), d(1.0, 3.0)), None);
        assert_eq!(l.cut(d(0.0, 0.5), d(0.0, 1.5)), None);
        assert_eq!(l.cut(d(-1.0, 1.0), d(-0.5, 1.0)), None);
    }

    #[test]
    fn a_stop_on_the_line_counts_once_whichever_side_it_came_from() {
        let l = MeasurementLine::new("l", Vec2::ZERO, Vec2::new(0.0, 2.0)).unwrap();
        // From the left onto the line, then off to the right: one positive crossing.
        let steps = [d(-1.0, 1.0), d(0.0, 1.0), d(1.0, 1.0)];
        let cuts: Vec<_> = steps.windows(2).filter_map(|w| l.cut(w[0], w[1])).collect();
        assert_eq!(cuts.len(), 1);
        assert_eq!(cuts[0].sign, 1);
        // From the right onto the line, then off to the left: one negative crossing.
        let steps = [d(1.0, 1.0), d(0.0, 1.0), d(-1.0, 1.0)];
        let cuts: Vec<_> = steps.windows(2).filter_map(|w| l.cut(w[0], w[1])).collect();
        assert_eq!(cuts.iter().map(|c| c.sign).collect::<Vec<_>>(), [-1]);
    }

    #[test]
    fn lines_reject_bad_names_and_points() {
        assert!(MeasurementLine::new("a b", Vec2::ZERO, Vec2::ONE).is_err());
        assert!(MeasurementLine::new("", Vec2::ZERO, Vec2::ONE).is_err());
        assert!(MeasurementLine::new("a", Vec2::ONE, Vec2::ONE).is_err());
        assert!(MeasurementLine::new("a", Vec2::NAN, Vec2::ONE).is_err());
        let l = MeasurementLine::new("door-1.a", Vec2::ZERO, Vec2::new(3.0, 4.0)).unwrap();
        assert_eq!(l.length(), 5.0);
    }

    #[test]
    fn areas_are_simple_polygons() {
        let square = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]].map(Vec2::from);
        let a = MeasurementArea::new("sq", square.to_vec()).unwrap();
        assert_eq!(a.area(), 4.0);
        let closed: Vec<Vec2> = square.iter().chain(&square[..1]).copied().collect();
        assert_eq!(MeasurementArea::new("sq", closed).unwrap(), a);
        let bow = [[0.0, 0.0], [2.0, 2.0], [2.0, 0.0], [0.0, 2.0]].map(Vec2::from);
        let msg = MeasurementArea::new("bow", bow.to_vec())
            .unwrap_err()
            .to_string();
        assert!(msg.contains("not simple"), "{msg}");
        assert!(MeasurementArea::new("two", square[..2].to_vec()).is_err());
        let flat = [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]].map(Vec2::from);
        assert!(MeasurementArea::new("flat", flat.to_vec()).is_err());
        let spike = [[0.0, 0.0], [2.0, 0.0], [1.0, 0.0], [1.0, 1.0]].map(Vec2::from);
        assert!(MeasurementArea::new("spike", spike.to_vec()).is_err());
        let many: Vec<Vec2> = (0..=MAX_POLYGON_VERTICES)
            .map(|k| Vec2::from_angle(k as f32 * 0.006))
            .collect();
        let msg = MeasurementArea::new("many", many).unwrap_err().to_string();
        assert!(msg.contains("1024"), "{msg}");
    }

    #[test]
    fn containment_splits_shared_edges() {
        let left = MeasurementArea::new(
            "l",
            [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
                .map(Vec2::from)
                .to_vec(),
        )
        .unwrap();
        let right = MeasurementArea::new(
            "r",
            [[1.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0]]
                .map(Vec2::from)
                .to_vec(),
        )
        .unwrap();
        assert!(left.contains(Vec2::new(0.5, 0.5)));
        assert!(!left.contains(Vec2::new(1.5, 0.5)));
        let on_edge = Vec2::new(1.0, 0.5);
        assert!(left.contains(on_edge) != right.contains(on_edge));
        assert_eq!(left.bounding_box(), (Vec2::ZERO, Vec2::ONE));
    }

    #[test]
    fn wkt_polygons_with_one_ring_are_read() {
        let p = parse_wkt_polygon("a", "POLYGON ((0 0, 4 0, 4 3, 0 3, 0 0))").unwrap();
        let a = MeasurementArea::new("a", p).unwrap();
        assert_eq!(a.polygon.len(), 4);
        assert_eq!(a.area(), 12.0);
        let holes = "POLYGON ((0 0, 4 0, 4 3, 0 0), (1 1, 2 1, 2 2, 1 1))";
        let msg = parse_wkt_polygon("a", holes).unwrap_err().to_string();
        assert!(msg.contains("holes"), "{msg}");
        assert!(parse_wkt_polygon("a", "LINESTRING (0 0, 1 1)").is_err());
        assert!(parse_wkt_polygon("a", "POLYGON ((0 0, 1))").is_err());
    }
}
