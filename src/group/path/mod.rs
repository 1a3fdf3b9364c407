//! Paths (polylines, open or looping, with a radius) and Reynolds' path following.
//!
//! A [`Path`] is validated on construction (at least two finite points, a positive total length, a
//! finite radius >= 0) and keeps the cumulative arc length at every point. Added to a world (or
//! by [`Path::indexed`]), a path of more than 16 segments that a grid of at most 4,096 cells
//! resolves (up to some hundreds of segments, spread out) also gets a grid listing per cell the
//! segments that can be nearest there, within the world's [`GridBudget`]: projecting a point near
//! the path reads a few segments, elsewhere (and without a grid) one pass over all of them in
//! lanes, with the same result either way; [`Path::point_at`] is one binary search. Arc lengths lie in
//! `[0, length]`; on a looping path they are taken modulo the length. Paths live in world
//! coordinates and are not wrapped on a torus: keep them inside the world.
//!
//! In files: [`segments`] holds the indices a projection searches (the segments in lanes, the
//! grid of candidate segments) and [`follow`] the path-following behaviour.

use glam::Vec2;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result, finite_vec, non_negative, positive};

mod follow;
mod segments;

pub use follow::{PathDirection, PathFollowParams, follow_path};
pub use segments::GridBudget;
use segments::{LANES, SegmentBlock, SegmentGrid, SegmentLanes, segment_distance};

/// The index of a path added to a world with `World::add_path` (in scenario files: the position
/// in the `[[paths]]` list, starting at 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(transparent)]
pub struct PathId(pub u32);

/// A path's data as written in scenario files: `{ points = [[0, 0], [10, 0]], radius = 2, looped = true }`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PathSpec {
    /// The polyline's points, in order (at least two).
    pub points: Vec<Vec2>,
    /// Half-width of the path (>= 0). Default: 1.
    #[serde(default = "one")]
    pub radius: f32,
    /// Whether the last point joins the first. Default: false.
    #[serde(default)]
    pub looped: bool,
}

fn one() -> f32 {
    1.0
}

/// A validated polyline with a radius, open or looping.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "PathSpec", into = "PathSpec")]
pub struct Path {
    points: Vec<Vec2>,
    radius: f32,
    looped: bool,
    /// `cumulative[k]` is the arc length at the start of segment `k`; one more entry than
    /// segments, the last being the total length.
    cumulative: Vec<f32>,
    /// The segments in lanes, for [`Path::project`].
    lanes: SegmentLanes,
    /// The segments that can be nearest, per cell around the path, for [`Path::project`].
    grid: SegmentGrid,
}

/// Where a point projects onto a path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projection {
    /// Arc length of the nearest point on the path.
    pub arc: f32,
    /// The nearest point on the path.
    pub point: Vec2,
    /// Distance from the projected point to the path.
    pub distance: f32,
}

impl TryFrom<PathSpec> for Path {
    type Error = Error;
    fn try_from(s: PathSpec) -> Result<Self> {
        Path::new(s.points, s.radius, s.looped)
    }
}

impl From<Path> for PathSpec {
    fn from(p: Path) -> Self {
        PathSpec {
            points: p.points,
            radius: p.radius,
            looped: p.looped,
        }
    }
}

impl Path {
    /// A path through `points` with half-width `radius`; `looped` joins the last point to the first.
    ///
    /// # Examples
    /// ```
    /// use throng::group::Path;
    /// use glam::Vec2;
    /// # fn main() -> throng::Result<()> {
    /// let square = Path::new(vec![Vec2::ZERO, Vec2::new(10.0, 0.0), Vec2::new(10.0, 10.0), Vec2::new(0.0, 10.0)], 1.0, true)?;
    /// assert_eq!(square.length(), 40.0);
    /// assert_eq!(square.point_at(45.0), Vec2::new(5.0, 0.0));
    /// # Ok(())
    /// # }
    /// ```
    ///
    /// # Errors
    /// [`Error::Invalid`] for fewer than two points or a path of zero length,
    /// [`Error::NonFinite`] for a NaN or infinite coordinate, [`Error::Negative`] for a negative
    /// radius.
    pub fn new(points: Vec<Vec2>, radius: f32, looped: bool) -> Result<Self> {
        if points.len() < 2 {
            return Err(Error::Invalid {
                name: "path.points".into(),
                reason: format!("a path needs at least two points, got {}", points.len()),
            });
        }
        for p in &points {
            finite_vec("path.points", *p)?;
        }
        non_negative("path.radius", radius)?;
        let segments = if looped {
            points.len()
        } else {
            points.len() - 1
        };
        let mut cumulative = Vec::with_capacity(segments + 1);
        let mut total = 0.0_f32;
        cumulative.push(0.0);
        for k in 0..segments {
            total += points[k].distance(points[(k + 1) % points.len()]);
            cumulative.push(total);
        }
        positive("path length", total).map_err(|_| Error::Invalid {
            name: "path.points".into(),
            reason: if total.is_finite() {
                "all points coincide: the path has zero length".into()
            } else {
                "the path's length overflows f32: its points lie too far apart".into()
            },
        })?;
        let mut path = Path {
            points,
            radius,
            looped,
            cumulative,
            lanes: SegmentLanes::default(),
            grid: SegmentGrid::default(),
        };
        let mut blocks = vec![SegmentBlock::default(); path.segments().div_ceil(LANES)];
        for (k, block) in blocks.iter_mut().enumerate() {
            for l in 0..LANES {
                let s = k * LANES + l;
                let (a, ab) = if s < path.segments() {
                    let (a, b) = path.segment(s);
                    (a, b - a)
                } else {
                    (Vec2::splat(f32::INFINITY), Vec2::ZERO)
                };
                let (h, m) = (l / 4, l % 4);
                (block.ax[h][m], block.ay[h][m]) = (a.x, a.y);
                (block.abx[h][m], block.aby[h][m]) = (ab.x, ab.y);
                block.len_sq[h][m] = ab.length_squared();
            }
        }
        path.lanes = SegmentLanes { blocks };
        Ok(path)
    }

    /// The path with its grid of candidate segments built (see [`GridBudget`]), so that
    /// [`Path::project`] reads a few segments near the path instead of all of them; the
    /// projections are the same. [`World::add_path`](crate::World::add_path) does this itself
    /// within the world's budget.
    #[must_use]
    pub fn indexed(mut self) -> Self {
        self.index(&mut GridBudget::default());
        self
    }

    /// Builds the grid of candidate segments when `budget` allows, and takes what it cost out
    /// of the budget.
    pub(crate) fn index(&mut self, budget: &mut GridBudget) {
        let segments: Vec<(Vec2, Vec2)> = (0..self.segments())
            .map(|k| {
                let (a, b) = self.segment(k);
                (a, b - a)
            })
            .collect();
        self.grid = SegmentGrid::build(&segments, budget);
    }

    /// Whether [`Path::project`] has a grid of candidate segments (a path of more than 16
    /// segments, [`Path::indexed`] or added to a world, and within the budget).
    #[must_use]
    pub fn is_indexed(&self) -> bool {
        self.grid.nx > 0
    }

    /// The points, in order.
    #[must_use]
    pub fn points(&self) -> &[Vec2] {
        &self.points
    }

    /// The half-width.
    #[must_use]
    pub fn radius(&self) -> f32 {
        self.radius
    }

    /// Whether the path loops.
    #[must_use]
    pub fn is_looped(&self) -> bool {
        self.looped
    }

    /// Total arc length (including the closing segment of a loop).
    #[must_use]
    pub fn length(&self) -> f32 {
        *self.cumulative.last().unwrap_or(&0.0)
    }

    fn segments(&self) -> usize {
        self.cumulative.len() - 1
    }

    fn segment(&self, k: usize) -> (Vec2, Vec2) {
        (self.points[k], self.points[(k + 1) % self.points.len()])
    }

    /// Maps an arc length into the path's range: modulo the length on a loop, clamped otherwise.
    #[must_use]
    pub fn normalize_arc(&self, arc: f32) -> f32 {
        let len = self.length();
        // Already in range: what both forms below give, bit for bit (`-0.0` included), without
        // the remainder's division.
        if (0.0..len).contains(&arc) {
            return arc;
        }
        if self.looped {
            let a = arc.rem_euclid(len);
            if a >= len { 0.0 } else { a }
        } else {
            arc.clamp(0.0, len)
        }
    }

    fn segment_at(&self, arc: f32) -> usize {
        // The last segment whose start is <= arc.
        let k = self.cumulative.partition_point(|&c| c <= arc);
        k.saturating_sub(1).min(self.segments() - 1)
    }

    /// The point at arc length `arc` (normalised as by [`Path::normalize_arc`]).
    #[must_use]
    pub fn point_at(&self, arc: f32) -> Vec2 {
        let arc = self.normalize_arc(arc);
        let k = self.segment_at(arc);
        let (a, b) = self.segment(k);
        let len = self.cumulative[k + 1] - self.cumulative[k];
        if len <= 0.0 {
            return a;
        }
        a.lerp(b, ((arc - self.cumulative[k]) / len).clamp(0.0, 1.0))
    }

    /// The unit direction of travel (increasing arc length) at arc length `arc`.
    #[must_use]
    pub fn tangent_at(&self, arc: f32) -> Vec2 {
        let arc = self.normalize_arc(arc);
        let mut k = self.segment_at(arc);
        // Skip zero-length segments.
        for _ in 0..self.segments() {
            let (a, b) = self.segment(k);
            if let Some(t) = (b - a).try_normalize() {
                return t;
            }
            k = (k + 1) % self.segments();
        }
        Vec2::X
    }

    /// Projects `p` onto the path: the nearest point, its arc length and the distance. Ties go to
    /// the earlier segment, so the result is deterministic.
    #[must_use]
    pub fn project(&self, p: Vec2) -> Projection {
        // Around the path, the grid's candidates one at a time; elsewhere every segment, eight
        // at a time in lanes. Both by the scalar form's operations (`project_scalar` in the
        // tests), then the first strictly nearest in segment order.
        let mut best_sq = f32::INFINITY;
        let mut best: Option<(usize, f32)> = None;
        if let Some(candidates) = self.grid.candidates(p) {
            // The segments that can be nearest here, in segment order (see `SegmentGrid`).
            for c in candidates {
                let (d, t) = segment_distance(c.a, c.ab, c.len_sq, p);
                if d < best_sq {
                    best_sq = d;
                    best = Some((c.k as usize, t));
                }
            }
        } else {
            for (b, block) in self.lanes.blocks.iter().enumerate() {
                let (d, t) = block.distances(p);
                for k in 0..LANES {
                    if d[k] < best_sq {
                        best_sq = d[k];
                        best = Some((b * LANES + k, t[k]));
                    }
                }
            }
        }
        let Some((k, t)) = best else {
            return Projection {
                arc: self.normalize_arc(0.0),
                point: self.points[0],
                distance: best_sq.sqrt(),
            };
        };
        let (a, b) = self.segment(k);
        Projection {
            arc: self.normalize_arc(
                self.cumulative[k] + t * (self.cumulative[k + 1] - self.cumulative[k]),
            ),
            point: a + (b - a) * t,
            distance: best_sq.sqrt(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The scalar projection, one segment at a time: the reference of [`Path::project`].
    pub(super) fn project_scalar(path: &Path, p: Vec2) -> Projection {
        let mut best = Projection {
            arc: 0.0,
            point: path.points[0],
            distance: f32::INFINITY,
        };
        let mut best_sq = f32::INFINITY;
        for k in 0..path.segments() {
            let (a, b) = path.segment(k);
            let ab = b - a;
            let len_sq = ab.length_squared();
            let t = if len_sq > 0.0 {
                ((p - a).dot(ab) / len_sq).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let q = a + ab * t;
            let d_sq = q.distance_squared(p);
            if d_sq < best_sq {
                best_sq = d_sq;
                best = Projection {
                    arc: path.cumulative[k] + t * (path.cumulative[k + 1] - path.cumulative[k]),
                    point: q,
                    distance: 0.0,
                };
            }
        }
        best.distance = best_sq.sqrt();
        best.arc = path.normalize_arc(best.arc);
        best
    }

    pub(super) fn bits(p: Projection) -> [u32; 4] {
        [p.arc, p.point.x, p.point.y, p.distance].map(f32::to_bits)
    }

    #[test]
    fn the_projection_in_lanes_equals_the_scalar_one_bit_for_bit() {
        let mut rng = crate::rng::AgentRng::new(5, 0, 0, 0);
        for (n, looped) in [
            (2, false),
            (2, true),
            (7, false),
            (8, true),
            (9, false),
            (24, true),
            (40, false),
        ] {
            let mut points: Vec<Vec2> = (0..n)
                .map(|_| Vec2::new(rng.signed(), rng.signed()) * 50.0)
                .collect();
            // Repeated points: zero-length segments, and ties between segments.
            if n > 2 {
                points[n / 2] = points[0];
            }
            let path = Path::new(points, 2.0, looped).unwrap();
            for q in 0..400 {
                let p = match q % 4 {
                    0 => path.points()[q % n],
                    1 => Vec2::new(rng.signed(), rng.signed()) * 80.0,
                    2 => Vec2::new(rng.signed(), rng.signed()) * 1e30,
                    _ => Vec2::new(rng.signed(), rng.signed()) * 5.0,
                };
                assert_eq!(
                    bits(path.project(p)),
                    bits(project_scalar(&path, p)),
                    "path of {n} points, looped {looped}, query {p}"
                );
            }
        }
    }

    #[test]
    fn arcs_in_range_are_normalised_to_themselves_as_the_remainder_gives_them() {
        for looped in [false, true] {
            let path = Path::new(
                vec![Vec2::ZERO, Vec2::new(3.0, 0.0), Vec2::new(3.0, 7.1)],
                1.0,
                looped,
            )
            .unwrap();
            let len = path.length();
            for arc in [-0.0, 0.0, 1e-30, 1.5, len * 0.999_999, len, len * 1.5, -2.0] {
                let slow = if looped {
                    let a = arc.rem_euclid(len);
                    if a >= len { 0.0 } else { a }
                } else {
                    arc.clamp(0.0, len)
                };
                assert_eq!(path.normalize_arc(arc).to_bits(), slow.to_bits(), "{arc}");
            }
        }
    }

    pub(super) fn square() -> Path {
        Path::new(
            vec![
                Vec2::ZERO,
                Vec2::new(10.0, 0.0),
                Vec2::new(10.0, 10.0),
                Vec2::new(0.0, 10.0),
            ],
            1.0,
            true,
        )
        .unwrap()
    }

    #[test]
    fn projection_and_arc_agree() {
        let s = square();
        let pr = s.project(Vec2::new(12.0, 5.0));
        assert_eq!(pr.point, Vec2::new(10.0, 5.0));
        assert_eq!(pr.arc, 15.0);
        assert_eq!(pr.distance, 2.0);
        assert_eq!(s.point_at(pr.arc), pr.point);
        // The closing segment of the loop.
        let pr = s.project(Vec2::new(-1.0, 4.0));
        assert_eq!(pr.arc, 36.0);
        assert_eq!(s.tangent_at(36.0), Vec2::new(0.0, -1.0));
    }

    #[test]
    fn bad_paths_are_rejected() {
        assert!(matches!(
            Path::new(vec![], 1.0, false),
            Err(Error::Invalid { .. })
        ));
        assert!(matches!(
            Path::new(vec![Vec2::ONE, Vec2::ONE], 1.0, true),
            Err(Error::Invalid { .. })
        ));
        assert!(matches!(
            Path::new(vec![Vec2::ZERO, Vec2::ONE], -1.0, false),
            Err(Error::Negative { .. })
        ));
        // A length beyond f32: said as such, not as coinciding points.
        match Path::new(vec![Vec2::ZERO, Vec2::new(3e38, -3e38)], 1.0, false) {
            Err(Error::Invalid { reason, .. }) => assert!(reason.contains("overflows"), "{reason}"),
            other => panic!("{other:?}"),
        }
        assert!(matches!(
            Path::new(vec![Vec2::ZERO, Vec2::NAN], 1.0, false),
            Err(Error::NonFinite { .. })
        ));
    }
}
