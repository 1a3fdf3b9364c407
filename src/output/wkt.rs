//! The walkable area of a world as a WKT polygon, for trajectory files that carry their geometry
//! (JuPedSim's SQLite format, read by PedPy as a `WalkableArea`).
//!
//! A world with a walkable area (`[geometry] walkable`, [`World::set_walkable`]) gives that
//! area, as read. Otherwise the outer ring is the world's rectangle, or for an open world the
//! box around its agents, obstacles, paths and field grown by a margin ([`World::extent`], what
//! pictures show). Closed wall chains (the scenario's closed polygons) that lie
//! strictly inside it become holes when they are simple polygons and their bounding boxes are
//! disjoint from each other's, so the polygon is always valid (OGC simple features); other walls
//! and circle obstacles are left out. Rings are closed (the first point repeated), the outer ring
//! counter-clockwise and the holes clockwise.

use glam::Vec2;

use crate::obstacles::{Wall, segment_intersection};
use crate::world::World;

/// Rings with more edges than this are not checked for self-crossings and left out as holes.
const MAX_HOLE_EDGES: usize = 4096;

/// The walkable area of `world` as WKT: `POLYGON ((outer ring), (hole), ...)`.
#[must_use]
pub fn walkable_wkt(world: &World) -> String {
    if let Some(area) = world.walkable() {
        return area.to_wkt();
    }
    let (min, max) = walkable_bounds(world);
    let outer = [min, Vec2::new(max.x, min.y), max, Vec2::new(min.x, max.y)];
    let mut wkt = String::from("POLYGON (");
    crate::geometry::write_ring(&mut wkt, &outer);
    for mut hole in holes(world.obstacles().walls(), min, max) {
        if crate::geometry::twice_area(&hole) > 0.0 {
            hole.reverse();
        }
        wkt.push_str(", ");
        crate::geometry::write_ring(&mut wkt, &hole);
    }
    wkt.push(')');
    wkt
}

/// The corners `(min, max)` of the box around [`walkable_wkt`]'s polygon: the walkable area's
/// bounding box when the world has one, else [`World::extent`].
#[must_use]
pub fn walkable_bounds(world: &World) -> (Vec2, Vec2) {
    match world.walkable() {
        Some(area) => (area.min(), area.max()),
        None => world.extent(),
    }
}

/// The closed chains of consecutive walls (each wall's end is the next one's start, the last
/// ends at the first's start) that can be holes of the rectangle `min..max`.
fn holes(walls: &[Wall], min: Vec2, max: Vec2) -> Vec<Vec<Vec2>> {
    let mut rings: Vec<Vec<Vec2>> = Vec::new();
    let mut start = 0;
    while start < walls.len() {
        let mut end = start;
        while end + 1 < walls.len() && walls[end + 1].a == walls[end].b {
            end += 1;
        }
        let chain = &walls[start..=end];
        if chain.len() >= 3 && chain[chain.len() - 1].b == chain[0].a {
            rings.push(chain.iter().map(|w| w.a).collect());
        }
        start = end + 1;
    }
    let inside = |p: &Vec2| p.x > min.x && p.y > min.y && p.x < max.x && p.y < max.y;
    rings.retain(|r| r.iter().all(inside) && r.len() <= MAX_HOLE_EDGES && is_simple(r));
    let boxes: Vec<(Vec2, Vec2)> = rings.iter().map(|r| bounding_box(r)).collect();
    let overlaps = |k: usize| {
        let (lo, hi) = boxes[k];
        boxes
            .iter()
            .enumerate()
            .any(|(j, &(l, h))| j != k && lo.x <= h.x && l.x <= hi.x && lo.y <= h.y && l.y <= hi.y)
    };
    let keep: Vec<bool> = (0..rings.len()).map(|k| !overlaps(k)).collect();
    rings
        .into_iter()
        .zip(keep)
        .filter_map(|(r, k)| k.then_some(r))
        .collect()
}

/// The smallest axis-aligned box around `points`.
fn bounding_box(points: &[Vec2]) -> (Vec2, Vec2) {
    points.iter().fold(
        (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    )
}

/// Whether a closed ring has non-zero area, no repeated point and no two edges that meet other
/// than neighbours at their shared corner.
fn is_simple(ring: &[Vec2]) -> bool {
    let n = ring.len();
    if crate::geometry::twice_area(ring) == 0.0 {
        return false;
    }
    for i in 0..n {
        if ring[i + 1..].contains(&ring[i]) {
            return false;
        }
    }
    let edge = |k: usize| (ring[k], ring[(k + 1) % n]);
    for i in 0..n {
        for j in i + 1..n {
            let neighbours = j == i + 1 || (i == 0 && j == n - 1);
            if neighbours {
                continue;
            }
            let ((p0, p1), (q0, q1)) = (edge(i), edge(j));
            if segment_intersection(p0, p1, q0, q1).is_some() {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{AgentInit, Bounds};

    fn world(bounds: Bounds) -> World {
        World::builder().bounds(bounds).build().unwrap()
    }

    #[test]
    fn a_walled_world_is_its_rectangle() {
        let w = world(Bounds::bounded(10.0, 4.5).unwrap());
        assert_eq!(
            walkable_wkt(&w),
            "POLYGON ((0 0, 10 0, 10 4.5, 0 4.5, 0 0))"
        );
    }

    #[test]
    fn an_empty_open_world_is_a_square_around_the_origin() {
        let w = world(Bounds::Open);
        assert_eq!(
            walkable_wkt(&w),
            "POLYGON ((-1 -1, 1 -1, 1 1, -1 1, -1 -1))"
        );
    }

    #[test]
    fn closed_polygons_inside_become_clockwise_holes_and_crossing_ones_do_not() {
        let mut w = world(Bounds::bounded(10.0, 10.0).unwrap());
        let square = [
            Vec2::new(1.0, 1.0),
            Vec2::new(3.0, 1.0),
            Vec2::new(3.0, 3.0),
            Vec2::new(1.0, 3.0),
        ];
        w.add_polygon(&square, true).unwrap();
        // A bow tie crosses itself; an open polyline is no ring; one poking out of the world
        // is no hole.
        let bow = [
            Vec2::new(5.0, 5.0),
            Vec2::new(7.0, 7.0),
            Vec2::new(7.0, 5.0),
            Vec2::new(5.0, 7.0),
        ];
        w.add_polygon(&bow, true).unwrap();
        w.add_polygon(&square.map(|p| p + Vec2::new(0.0, 5.0)), false)
            .unwrap();
        w.add_polygon(&square.map(|p| p + Vec2::new(8.0, 0.0)), true)
            .unwrap();
        assert_eq!(
            walkable_wkt(&w),
            "POLYGON ((0 0, 10 0, 10 10, 0 10, 0 0), (1 3, 3 3, 3 1, 1 1, 1 3))"
        );
    }

    #[test]
    fn holes_whose_boxes_overlap_are_left_out() {
        let mut w = world(Bounds::bounded(10.0, 10.0).unwrap());
        let tri = [
            Vec2::new(1.0, 1.0),
            Vec2::new(4.0, 1.0),
            Vec2::new(1.0, 4.0),
        ];
        w.add_polygon(&tri, true).unwrap();
        w.add_polygon(&tri.map(|p| p + Vec2::splat(1.5)), true)
            .unwrap();
        assert_eq!(walkable_wkt(&w), "POLYGON ((0 0, 10 0, 10 10, 0 10, 0 0))");
    }

    #[test]
    fn a_walkable_area_is_given_as_read_with_its_own_bounds() {
        let mut w = World::builder()
            .group(crate::Profile::default())
            .agents([AgentInit::at(Vec2::new(2.0, 2.0), 0)])
            .build()
            .unwrap();
        let wkt = "POLYGON ((0 0, 10 0, 10 4.5, 14 4.5, 14 5.5, 10 5.5, 10 10, 0 10, 0 0))";
        w.set_walkable(crate::Walkable::from_wkt(wkt).unwrap())
            .unwrap();
        assert_eq!(walkable_wkt(&w), wkt);
        assert_eq!(
            walkable_bounds(&w),
            (Vec2::new(0.0, 0.0), Vec2::new(14.0, 10.0))
        );
    }

    #[test]
    fn an_open_world_is_its_content_grown_by_a_margin() {
        let w = World::builder()
            .group(crate::Profile::default())
            .agents([Vec2::new(-5.0, 2.0), Vec2::new(15.0, 4.0)].map(|p| AgentInit::at(p, 0)))
            .build()
            .unwrap();
        // The larger side is 20, so the margin is 1.
        assert_eq!(
            walkable_bounds(&w),
            (Vec2::new(-6.0, 1.0), Vec2::new(16.0, 5.0))
        );
    }
}
