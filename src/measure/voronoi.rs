//! Voronoi density and speed in a measurement area, as PedPy defines them
//! (`compute_individual_voronoi_polygons`, `compute_voronoi_density`, `compute_voronoi_speed`),
//! and the one-dimensional form of single-file studies.
//!
//! Each agent `i` owns the cell `V_i` of the points of the walkable area nearer to it than to
//! any other agent (PedPy: the Voronoi polygons of the positions, cut to the walkable area,
//! without a cut-off radius). In an area `A`:
//!
//! ```text
//! density = sum_i |V_i ∩ A| / |V_i|  /  |A|        speed = sum_i |v_i| |V_i ∩ A|  /  |A|
//! ```
//!
//! Cells are built by clipping: the walkable area's rings are clipped, one bisector half-plane
//! after another, by the agents in order of distance (Sutherland-Hodgman against a half-plane,
//! which keeps the area right for concave rings too), until the next agent is more than twice
//! as far as the cell's farthest vertex (no later bisector can cut it). A cell's area is its
//! exterior's clipped area less its holes'. Only agents that may own a part of `A` are
//! clipped: those within the covering radius of `A` (the largest distance from a point of `A`
//! to its nearest agent, bounded from above on a grid over `A`'s box).
//!
//! Invariants: the result depends on the positions and speeds alone, not on their order (each
//! cell is clipped by its agents sorted by distance, then index); agents on the same spot own
//! no cell beyond the first of them (PedPy rejects such input); all arithmetic is `f64`.

use glam::DVec2;

/// A ring as `f64` points.
pub type Ring = Vec<DVec2>;

/// The walkable area as rings: per polygon, its exterior and its holes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Region {
    /// `(exterior, holes)` per polygon.
    pub polygons: Vec<(Ring, Vec<Ring>)>,
}

/// The density and speed of a frame in an area.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VoronoiFrame {
    /// Persons per unit area.
    pub density: f64,
    /// `sum_i |v_i| |V_i ∩ A| / |A|`, units per second (0 when nobody owns a part of `A`).
    pub speed: f64,
}

/// Twice the signed area of `ring` (positive counter-clockwise).
fn twice_area(ring: &[DVec2]) -> f64 {
    let n = ring.len();
    (0..n).map(|k| ring[k].perp_dot(ring[(k + 1) % n])).sum()
}

/// The area of `ring`, whatever its winding.
fn area(ring: &[DVec2]) -> f64 {
    0.5 * twice_area(ring).abs()
}

/// `ring` clipped to the half-plane `{x : (x - m) . n <= 0}` (Sutherland-Hodgman), into `out`.
fn clip(ring: &[DVec2], m: DVec2, n: DVec2, out: &mut Ring) {
    out.clear();
    let k = ring.len();
    for i in 0..k {
        let (a, b) = (ring[i], ring[(i + 1) % k]);
        let (sa, sb) = ((a - m).dot(n), (b - m).dot(n));
        if sa <= 0.0 {
            out.push(a);
        }
        if (sa < 0.0 && sb > 0.0) || (sa > 0.0 && sb < 0.0) {
            out.push(a + (b - a) * (sa / (sa - sb)));
        }
    }
}

/// A half-plane `{x : (x - m) . n <= 0}`.
type HalfPlane = (DVec2, DVec2);

/// The half-planes of a convex ring's edges, the ring on their inner side; `None` when the ring
/// is not convex.
fn convex_half_planes(ring: &[DVec2]) -> Option<Vec<HalfPlane>> {
    let k = ring.len();
    let sign = twice_area(ring).signum();
    let mut planes = Vec::with_capacity(k);
    for i in 0..k {
        let (a, b, c) = (ring[i], ring[(i + 1) % k], ring[(i + 2) % k]);
        if (b - a).perp_dot(c - b) * sign < 0.0 {
            return None;
        }
        // The outward normal of edge a -> b.
        let e = b - a;
        let outward = DVec2::new(e.y, -e.x) * sign;
        planes.push((a, outward));
    }
    Some(planes)
}

/// `ring` clipped by every half-plane.
fn clip_all(ring: &[DVec2], planes: &[HalfPlane], a: &mut Ring, b: &mut Ring) -> f64 {
    a.clear();
    a.extend_from_slice(ring);
    for &(m, n) in planes {
        if a.is_empty() {
            break;
        }
        clip(a, m, n, b);
        std::mem::swap(a, b);
    }
    area(a)
}

impl Region {
    /// A region of one rectangle.
    #[must_use]
    pub fn rectangle(min: DVec2, max: DVec2) -> Region {
        Region {
            polygons: vec![(
                vec![min, DVec2::new(max.x, min.y), max, DVec2::new(min.x, max.y)],
                Vec::new(),
            )],
        }
    }

    /// The region of a world's walkable area.
    #[must_use]
    pub fn of(walkable: &crate::geometry::Walkable) -> Region {
        let ring = |r: &[glam::Vec2]| r.iter().map(|p| p.as_dvec2()).collect::<Ring>();
        Region {
            polygons: walkable
                .polygons()
                .iter()
                .map(|p| {
                    (
                        ring(p.exterior()),
                        p.holes().iter().map(|h| ring(h)).collect(),
                    )
                })
                .collect(),
        }
    }

    /// The farthest distance from `p` of any exterior vertex.
    fn reach(&self, p: DVec2) -> f64 {
        self.polygons
            .iter()
            .flat_map(|(e, _)| e.iter())
            .map(|v| v.distance(p))
            .fold(0.0, f64::max)
    }
}

/// Voronoi density and speed in the convex or concave simple polygon `area` (a ring), for agents
/// at `points` with speeds `speeds` in `region`. An `area` that is not convex must lie in the
/// region.
#[must_use]
pub fn voronoi_frame(
    points: &[DVec2],
    speeds: &[f64],
    region: &Region,
    area_ring: &[DVec2],
) -> VoronoiFrame {
    let size = area(area_ring);
    if points.is_empty() || size <= 0.0 {
        return VoronoiFrame::default();
    }
    let (lo, hi) = area_ring.iter().fold(
        (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    let cover = covering_radius(points, lo, hi);
    let area_planes = convex_half_planes(area_ring);
    let (mut bisectors, mut order): (Vec<HalfPlane>, Vec<(f64, usize)>) = (Vec::new(), Vec::new());
    let (mut cell, mut scratch, mut tmp) = (Ring::new(), Ring::new(), Ring::new());
    let mut frame = VoronoiFrame::default();
    for (i, &p) in points.iter().enumerate() {
        let box_distance = (lo - p).max(p - hi).max(DVec2::ZERO).length();
        if box_distance > cover {
            continue;
        }
        if points[..i].contains(&p) {
            continue;
        }
        order.clear();
        order.extend(
            points
                .iter()
                .enumerate()
                .filter(|&(j, &q)| j != i && q != p)
                .map(|(j, &q)| (p.distance_squared(q), j)),
        );
        order.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        // The bisectors that cut the cell: clip the largest exterior until the next agent is
        // beyond twice the farthest vertex.
        bisectors.clear();
        let mut reach = region.reach(p);
        for &(d2, j) in &order {
            if d2.sqrt() > 2.0 * reach {
                break;
            }
            let q = points[j];
            let n = q - p;
            bisectors.push((0.5 * (p + q), n));
            if bisectors.len() % 8 == 0 {
                reach = clipped_reach(region, &bisectors, p, &mut cell, &mut scratch);
            }
        }
        let whole = region_area(region, &bisectors, None, &mut cell, &mut scratch, &mut tmp);
        if whole <= 0.0 {
            continue;
        }
        let inside = match &area_planes {
            Some(planes) => region_area(
                region,
                &bisectors,
                Some(planes),
                &mut cell,
                &mut scratch,
                &mut tmp,
            ),
            None => clip_all(area_ring, &bisectors, &mut cell, &mut scratch),
        };
        if inside > 0.0 {
            frame.density += inside / whole;
            frame.speed += speeds.get(i).copied().unwrap_or(0.0) * inside;
        }
    }
    frame.density /= size;
    frame.speed /= size;
    frame
}

/// The farthest vertex from `p` of the region's exteriors clipped by `planes`.
fn clipped_reach(
    region: &Region,
    planes: &[HalfPlane],
    p: DVec2,
    a: &mut Ring,
    b: &mut Ring,
) -> f64 {
    let mut reach = 0.0_f64;
    for (e, _) in &region.polygons {
        clip_all(e, planes, a, b);
        reach = a.iter().map(|v| v.distance(p)).fold(reach, f64::max);
    }
    reach
}

/// The area of the region clipped by `planes` (and by `extra` when given): exteriors less holes.
fn region_area(
    region: &Region,
    planes: &[HalfPlane],
    extra: Option<&Vec<HalfPlane>>,
    a: &mut Ring,
    b: &mut Ring,
    c: &mut Ring,
) -> f64 {
    let mut total = 0.0;
    for (e, holes) in &region.polygons {
        for (k, ring) in std::iter::once(e).chain(holes).enumerate() {
            clip_all(ring, planes, a, b);
            let mut s = area(a);
            if let Some(extra) = extra
                && s > 0.0
            {
                c.clear();
                c.extend_from_slice(a);
                s = clip_all(c, extra, a, b);
            }
            total += if k == 0 { s } else { -s };
        }
    }
    total.max(0.0)
}

/// An upper bound of the largest distance from a point of the box `[lo, hi]` to its nearest
/// agent: the largest over a grid of points over the box, plus the grid's half-diagonal.
fn covering_radius(points: &[DVec2], lo: DVec2, hi: DVec2) -> f64 {
    const STEPS: usize = 16;
    let size = hi - lo;
    let h = size / STEPS as f64;
    let mut worst = 0.0_f64;
    for ix in 0..=STEPS {
        for iy in 0..=STEPS {
            let x = lo + DVec2::new(h.x * ix as f64, h.y * iy as f64);
            let nearest = points
                .iter()
                .map(|q| q.distance_squared(x))
                .fold(f64::INFINITY, f64::min)
                .sqrt();
            worst = worst.max(nearest);
        }
    }
    worst + 0.5 * h.length() + 1e-9
}

/// One-dimensional Voronoi density and speed in the interval `[a, b]` for agents at
/// coordinates `xs` along a line with speeds `speeds`: each agent's cell runs from the midpoint
/// to the agent behind to the midpoint to the agent ahead; the first and the last agent's cells
/// extend as far on their open side as on the other (a lone agent owns no cell).
#[must_use]
pub fn voronoi_1d(xs: &[f64], speeds: &[f64], (a, b): (f64, f64)) -> VoronoiFrame {
    let mut order: Vec<usize> = (0..xs.len()).collect();
    order.sort_by(|&i, &j| xs[i].total_cmp(&xs[j]).then(i.cmp(&j)));
    let n = order.len();
    let length = b - a;
    if n < 2 || length <= 0.0 {
        return VoronoiFrame::default();
    }
    let mut frame = VoronoiFrame::default();
    for k in 0..n {
        let x = xs[order[k]];
        let back = (k > 0).then(|| 0.5 * (x - xs[order[k - 1]]));
        let ahead = (k + 1 < n).then(|| 0.5 * (xs[order[k + 1]] - x));
        let (lo, hi) = match (back, ahead) {
            (Some(b), Some(f)) => (x - b, x + f),
            (None, Some(f)) => (x - f, x + f),
            (Some(b), None) => (x - b, x + b),
            (None, None) => continue,
        };
        let cell = hi - lo;
        let inside = (hi.min(b) - lo.max(a)).max(0.0);
        if cell > 0.0 && inside > 0.0 {
            frame.density += inside / cell;
            frame.speed += speeds.get(order[k]).copied().unwrap_or(0.0) * inside;
        }
    }
    frame.density /= length;
    frame.speed /= length;
    frame
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(lo: f64, hi: f64) -> Ring {
        vec![
            DVec2::new(lo, lo),
            DVec2::new(hi, lo),
            DVec2::new(hi, hi),
            DVec2::new(lo, hi),
        ]
    }

    /// A square lattice of unit spacing fills the region with cells of area 1: the density in
    /// any area inside is 1, and the speed the agents' speed.
    #[test]
    fn a_unit_lattice_has_density_one() {
        let mut points = Vec::new();
        for x in 0..10 {
            for y in 0..10 {
                points.push(DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5));
            }
        }
        let speeds = vec![1.5; points.len()];
        let region = Region::rectangle(DVec2::ZERO, DVec2::splat(10.0));
        for area in [square(2.0, 5.0), square(3.3, 6.1)] {
            let f = voronoi_frame(&points, &speeds, &region, &area);
            assert!((f.density - 1.0).abs() < 1e-9, "{f:?}");
            assert!((f.speed - 1.5).abs() < 1e-9, "{f:?}");
        }
    }

    /// Two agents in a 4 x 2 room split it at their bisector x = 1.75: cells 1.75 x 2 and
    /// 2.25 x 2, of which the area x 1..3 (the whole height) holds 0.75 x 2 and 1.25 x 2.
    #[test]
    fn two_agents_split_a_room_at_their_bisector() {
        let region = Region::rectangle(DVec2::ZERO, DVec2::new(4.0, 2.0));
        let points = [DVec2::new(0.5, 1.0), DVec2::new(3.0, 1.0)];
        let area = vec![
            DVec2::new(1.0, 0.0),
            DVec2::new(3.0, 0.0),
            DVec2::new(3.0, 2.0),
            DVec2::new(1.0, 2.0),
        ];
        let f = voronoi_frame(&points, &[1.0, 2.0], &region, &area);
        let expected = (0.75 / 1.75 + 1.25 / 2.25) / 4.0;
        assert!(
            (f.density - expected).abs() < 1e-12,
            "{f:?} against {expected}"
        );
        let speed = (1.0 * 0.75 * 2.0 + 2.0 * 1.25 * 2.0) / 4.0;
        assert!((f.speed - speed).abs() < 1e-12, "{f:?} against {speed}");
    }

    /// Holes are no one's: a hole in a cell shrinks the cell.
    #[test]
    fn a_hole_is_taken_from_the_cell() {
        let region = Region {
            polygons: vec![(square(0.0, 4.0), vec![square(2.5, 3.5)])],
        };
        let f = voronoi_frame(&[DVec2::new(1.0, 1.0)], &[0.0], &region, &square(0.0, 2.0));
        assert!((f.density - (4.0 / 15.0) / 4.0).abs() < 1e-12, "{f:?}");
    }

    /// The order of the agents does not matter.
    #[test]
    fn the_order_of_the_agents_does_not_matter() {
        let mut points: Vec<DVec2> = (0..40)
            .map(|k| {
                let t = f64::from(k);
                DVec2::new(
                    (t * 2.399).rem_euclid(8.0),
                    (t * 0.713 + 0.1).rem_euclid(3.0),
                )
            })
            .collect();
        let speeds: Vec<f64> = (0..40).map(|k| 1.0 + 0.01 * f64::from(k)).collect();
        let region = Region::rectangle(DVec2::ZERO, DVec2::new(8.0, 3.0));
        let area = vec![
            DVec2::new(2.0, 0.0),
            DVec2::new(5.0, 0.0),
            DVec2::new(5.0, 3.0),
            DVec2::new(2.0, 3.0),
        ];
        let f = voronoi_frame(&points, &speeds, &region, &area);
        let mut pairs: Vec<(DVec2, f64)> = points.iter().copied().zip(speeds).collect();
        pairs.reverse();
        points = pairs.iter().map(|p| p.0).collect();
        let speeds: Vec<f64> = pairs.iter().map(|p| p.1).collect();
        let g = voronoi_frame(&points, &speeds, &region, &area);
        assert!((f.density - g.density).abs() < 1e-12 && (f.speed - g.speed).abs() < 1e-12);
        // Cells tile the region: the density over the whole region is the count over its area.
        let whole = square(0.0, 8.0)
            .into_iter()
            .map(|p| DVec2::new(p.x, p.y * 3.0 / 8.0))
            .collect::<Ring>();
        let all = voronoi_frame(&points, &speeds, &region, &whole);
        assert!((all.density - 40.0 / 24.0).abs() < 1e-9, "{all:?}");
    }

    #[test]
    fn one_dimensional_cells_by_hand() {
        // Agents 1 m apart: density 1 / m anywhere inside.
        let xs: Vec<f64> = (0..10).map(f64::from).collect();
        let f = voronoi_1d(&xs, &[1.0; 10], (3.2, 5.2));
        assert!((f.density - 1.0).abs() < 1e-12 && (f.speed - 1.0).abs() < 1e-12);
        // Agents at 0, 1 and 2.5: cells [-0.5, 0.5] (the first one mirrored), [0.5, 1.75] and
        // [1.75, 3.25] (the last one mirrored); [1, 2] holds 0.75 of the second's 1.25 and 0.25
        // of the third's 1.5.
        let f = voronoi_1d(&[1.0, 2.5, 0.0], &[2.0, 4.0, 0.0], (1.0, 2.0));
        assert!((f.density - (0.6 + 0.25 / 1.5)).abs() < 1e-12, "{f:?}");
        assert!((f.speed - (2.0 * 0.75 + 4.0 * 0.25)).abs() < 1e-12, "{f:?}");
    }
}
