//! Walls as ORCA obstacles: chains of vertices with their convexity, and the half-planes an
//! agent gets from the edges near it, with RVO2's treatment of convex and concave vertices.
//!
//! throng's walls are two-sided segments; closed polygons are walls whose ends meet. Walls that
//! share an end exactly (and no third wall meets there) form a chain. A point where one wall
//! ends or three or more wall ends meet (a junction) ends every chain through it, so any planar
//! arrangement (junctions of any degree, a polygon through one vertex twice, polygons touching
//! at a corner) splits into chains that are open at their junctions. [`WallChains`] turns every
//! chain into oriented *edges* whose permitted side is their right:
//!
//! - an open chain `v0 .. vk` becomes the thin loop `v0 -> .. -> vk -> .. -> v0`, so each
//!   segment appears once per side and its ends are convex (an agent goes round them); a chain
//!   that leaves a junction and comes back to it is open, with `vk = v0`;
//! - a closed loop becomes two loops: counter-clockwise for agents outside it and clockwise for
//!   agents inside it (a room), so that an agent never sees a polygon's far side as a near wall.
//!
//! A vertex is convex for an edge chain when the chain turns left there (`det >= 0`, so
//! collinear vertices count as convex). Per agent, an edge counts when the agent is on its right
//! (and on the matching side of a closed loop); edges are taken nearest first, and an edge whose
//! velocity obstacle earlier lines already cover adds nothing.
//!
//! Invariants: every vertex's `next` and `prev` are vertices of the same loop, `dir` is the
//! unit vector towards `next`, and a wall of the obstacle set maps to exactly two edges.

use std::collections::HashMap;

use glam::Vec2;

use super::lp::{EPSILON, Line};
use crate::obstacles::Wall;

/// Which agents an edge serves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Side {
    /// An edge of an open chain: any agent on its right.
    Open,
    /// An edge of closed loop `n` for agents outside it.
    Outside(u32),
    /// An edge of closed loop `n` for agents inside it.
    Inside(u32),
}

/// One vertex of an edge loop; the edge runs from it to `next`.
#[derive(Clone, Copy, Debug)]
struct Vertex {
    point: Vec2,
    /// Unit vector to `next`.
    dir: Vec2,
    next: u32,
    prev: u32,
    convex: bool,
    side: Side,
}

/// The walls of an obstacle set as ORCA edge loops.
#[derive(Clone, Debug, Default)]
pub struct WallChains {
    verts: Vec<Vertex>,
    /// The two edges (start vertices) of each wall, by wall index.
    edges_of_wall: Vec<[u32; 2]>,
    /// Each closed loop's points, counter-clockwise, for the inside test.
    loops: Vec<Vec<Vec2>>,
}

/// `det(a - c, b - a)`: positive when `c` lies left of the line `a -> b`.
#[inline]
fn left_of(a: Vec2, b: Vec2, c: Vec2) -> f32 {
    (a - c).perp_dot(b - a)
}

impl WallChains {
    /// The chains of `walls`.
    #[must_use]
    pub fn new(walls: &[Wall]) -> Self {
        // `+ 0.0` makes -0.0 the same point as 0.0, as `==` (and the walk below) has it.
        let key = |p: Vec2| ((p.x + 0.0).to_bits(), (p.y + 0.0).to_bits());
        let mut ends: HashMap<(u32, u32), Vec<(usize, bool)>> = HashMap::new();
        for (w, wall) in walls.iter().enumerate() {
            ends.entry(key(wall.a)).or_default().push((w, false));
            ends.entry(key(wall.b)).or_default().push((w, true));
        }
        // The other wall at `p` when exactly two walls meet there.
        let through = |p: Vec2, from: usize| -> Option<(usize, bool)> {
            match ends[&key(p)][..] {
                [a, b] if a.0 != b.0 => Some(if a.0 == from { b } else { a }),
                _ => None,
            }
        };
        let mut out = WallChains {
            edges_of_wall: vec![[0, 0]; walls.len()],
            ..WallChains::default()
        };
        let mut used = vec![false; walls.len()];
        // Walks from wall `w` leaving its end `from_b` (false: from `a` towards `b`); returns
        // the points and walls visited, and whether it came back to the start.
        let walk = |w: usize, mut forward: bool, used: &mut Vec<bool>| {
            let (mut pts, mut ws) = (Vec::new(), Vec::new());
            let start = if forward { walls[w].a } else { walls[w].b };
            pts.push(start);
            let mut cur = w;
            loop {
                used[cur] = true;
                ws.push(cur);
                let end = if forward { walls[cur].b } else { walls[cur].a };
                if end == start {
                    return (pts, ws, true);
                }
                pts.push(end);
                match through(end, cur) {
                    Some((next, at_b)) if !used[next] => {
                        cur = next;
                        forward = !at_b;
                    }
                    _ => return (pts, ws, false),
                }
            }
        };
        // Open chains first, from their ends; what remains are closed loops.
        for w in 0..walls.len() {
            for from_b in [false, true] {
                let p = if from_b { walls[w].b } else { walls[w].a };
                if !used[w] && through(p, w).is_none() {
                    let (mut pts, ws, closed) = walk(w, !from_b, &mut used);
                    if closed {
                        // Back at the junction it left (three or more wall ends meet there):
                        // the loop is an open chain from the junction to itself.
                        pts.push(p);
                    }
                    out.push_open(&pts, &ws);
                }
            }
        }
        for w in 0..walls.len() {
            if !used[w] {
                let (pts, ws, closed) = walk(w, true, &mut used);
                if closed {
                    out.push_closed(pts, &ws);
                } else {
                    out.push_open(&pts, &ws);
                }
            }
        }
        out
    }

    /// Appends a loop through `pts` (each point once, the loop closing back to the first).
    fn push_loop(&mut self, pts: &[Vec2], side: Side) -> u32 {
        let base = self.verts.len() as u32;
        let n = pts.len() as u32;
        for (k, &p) in pts.iter().enumerate() {
            let k = k as u32;
            let next = pts[((k + 1) % n) as usize];
            let prev = pts[((k + n - 1) % n) as usize];
            self.verts.push(Vertex {
                point: p,
                dir: (next - p).normalize_or_zero(),
                next: base + (k + 1) % n,
                prev: base + (k + n - 1) % n,
                convex: left_of(prev, p, next) >= 0.0,
                side,
            });
        }
        base
    }

    /// An open chain `pts[0] .. pts[k]` of walls `ws` (wall `ws[i]` joins `pts[i]` and `pts[i + 1]`).
    fn push_open(&mut self, pts: &[Vec2], ws: &[usize]) {
        let k = ws.len();
        let mut thin: Vec<Vec2> = pts.to_vec();
        thin.extend(pts[1..k].iter().rev());
        let base = self.push_loop(&thin, Side::Open);
        for (i, &w) in ws.iter().enumerate() {
            // Forward edge i, backward edge 2k - 1 - i.
            self.edges_of_wall[w] = [base + i as u32, base + (2 * k - 1 - i) as u32];
        }
    }

    /// A closed loop through `pts` of walls `ws` (wall `ws[i]` joins `pts[i]` and `pts[i + 1]`).
    fn push_closed(&mut self, mut pts: Vec<Vec2>, ws: &[usize]) {
        let n = pts.len();
        let id = self.loops.len() as u32;
        let area: f32 = (0..n).map(|i| pts[i].perp_dot(pts[(i + 1) % n])).sum();
        let ccw = area >= 0.0;
        let outside = self.push_loop_ordered(&pts, ccw, Side::Outside(id));
        let inside = self.push_loop_ordered(&pts, !ccw, Side::Inside(id));
        for (i, &w) in ws.iter().enumerate() {
            // In the given order edge i joins pts[i] -> pts[i + 1]; reversed, pts[i + 1] sits
            // at position n - 2 - i (mod n) and starts the same wall's edge.
            let (f, r) = (i as u32, ((2 * n - 2 - i) % n) as u32);
            self.edges_of_wall[w] = if ccw {
                [outside + f, inside + r]
            } else {
                [outside + r, inside + f]
            };
        }
        if !ccw {
            pts.reverse();
        }
        self.loops.push(pts);
    }

    /// A loop through `pts` in their order (`forward`) or reversed.
    fn push_loop_ordered(&mut self, pts: &[Vec2], forward: bool, side: Side) -> u32 {
        if forward {
            self.push_loop(pts, side)
        } else {
            let rev: Vec<Vec2> = pts.iter().rev().copied().collect();
            self.push_loop(&rev, side)
        }
    }

    /// Whether there are no edges.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.verts.is_empty()
    }

    /// The edges of wall `w` that serve an agent at `p`, appended to `out` with their squared
    /// distance to `p` when it is below `range_sq`. `inside_cache` remembers the inside test
    /// of closed loops for this agent.
    pub(crate) fn edges_near(
        &self,
        w: usize,
        p: Vec2,
        range_sq: f32,
        inside_cache: &mut Vec<(u32, bool)>,
        out: &mut Vec<(f32, u32)>,
    ) {
        for e in self.edges_of_wall[w] {
            let v1 = self.verts[e as usize];
            let v2 = self.verts[v1.next as usize];
            if left_of(v1.point, v2.point, p) >= 0.0 {
                continue; // the agent is not on this edge's right
            }
            let wanted = match v1.side {
                Side::Open => true,
                Side::Outside(l) | Side::Inside(l) => {
                    let is_in = match inside_cache.iter().find(|(k, _)| *k == l) {
                        Some(&(_, b)) => b,
                        None => {
                            let b = crate::geometry::ring_contains(&self.loops[l as usize], p);
                            inside_cache.push((l, b));
                            b
                        }
                    };
                    is_in == matches!(v1.side, Side::Inside(_))
                }
            };
            if !wanted {
                continue;
            }
            let d_sq = segment_dist_sq(v1.point, v2.point, p);
            if d_sq < range_sq {
                out.push((d_sq, e));
            }
        }
    }

    /// Appends the ORCA lines of edges `edges` (nearest first) for an agent at `pos` with
    /// velocity `vel` and radius `radius`, horizon `1 / inv_tau`.
    pub(crate) fn lines(
        &self,
        edges: &[(f32, u32)],
        pos: Vec2,
        vel: Vec2,
        radius: f32,
        inv_tau: f32,
        lines: &mut Vec<Line>,
    ) {
        for &(_, e) in edges {
            if let Some(line) = self.edge_line(e, pos, vel, radius, inv_tau, lines) {
                lines.push(line);
            }
        }
    }

    /// The line of edge `e`, or `None` when earlier lines cover it or a concave vertex or a
    /// neighbouring edge takes care of it.
    fn edge_line(
        &self,
        e: u32,
        pos: Vec2,
        vel: Vec2,
        radius: f32,
        inv_tau: f32,
        lines: &[Line],
    ) -> Option<Line> {
        let mut o1 = self.verts[e as usize];
        let mut o2 = self.verts[o1.next as usize];
        let rel1 = o1.point - pos;
        let rel2 = o2.point - pos;
        // Covered when both ends, scaled to velocities, lie deep enough beyond an earlier line.
        let covered = lines.iter().any(|l| {
            (rel1 * inv_tau - l.point).perp_dot(l.dir) - inv_tau * radius >= -EPSILON
                && (rel2 * inv_tau - l.point).perp_dot(l.dir) - inv_tau * radius >= -EPSILON
        });
        if covered {
            return None;
        }
        let (d1, d2) = (rel1.length_squared(), rel2.length_squared());
        let r_sq = radius * radius;
        let edge = o2.point - o1.point;
        let s = (-rel1).dot(edge) / edge.length_squared();
        let d_line = (-rel1 - edge * s).length_squared();
        let stop = |dir: Vec2| Line {
            point: Vec2::ZERO,
            dir,
        };
        if s < 0.0 && d1 <= r_sq {
            // Touching the first vertex: stop moving into it (a concave one is someone else's).
            return o1
                .convex
                .then(|| stop(Vec2::new(-rel1.y, rel1.x).normalize_or_zero()));
        }
        if s > 1.0 && d2 <= r_sq {
            return (o2.convex && rel2.perp_dot(o2.dir) >= 0.0)
                .then(|| stop(Vec2::new(-rel2.y, rel2.x).normalize_or_zero()));
        }
        if (0.0..1.0).contains(&s) && d_line <= r_sq {
            return Some(stop(-o1.dir)); // touching the edge itself
        }
        // The legs of the velocity obstacle.
        let leg_left = |rel: Vec2, d: f32| {
            let leg = (d - r_sq).sqrt();
            Vec2::new(rel.x * leg - rel.y * radius, rel.x * radius + rel.y * leg) / d
        };
        let leg_right = |rel: Vec2, d: f32| {
            let leg = (d - r_sq).sqrt();
            Vec2::new(rel.x * leg + rel.y * radius, -rel.x * radius + rel.y * leg) / d
        };
        let same;
        let (mut left, mut right);
        if s < 0.0 && d_line <= r_sq {
            // Seen obliquely: the first vertex alone defines the obstacle.
            if !o1.convex {
                return None;
            }
            o2 = o1;
            same = true;
            left = leg_left(rel1, d1);
            right = leg_right(rel1, d1);
        } else if s > 1.0 && d_line <= r_sq {
            if !o2.convex {
                return None;
            }
            o1 = o2;
            same = true;
            left = leg_left(rel2, d2);
            right = leg_right(rel2, d2);
        } else {
            same = false;
            left = if o1.convex {
                leg_left(rel1, d1)
            } else {
                -o1.dir // a concave vertex: the leg extends the cut-off line
            };
            right = if o2.convex {
                leg_right(rel2, d2)
            } else {
                o1.dir
            };
        }
        // A leg pointing into the neighbouring edge is replaced by that edge ("foreign"): a
        // velocity projected on it gets no line here, the neighbour's own line takes care of it.
        let left_neighbour = self.verts[o1.prev as usize];
        let (mut left_foreign, mut right_foreign) = (false, false);
        if o1.convex && left.perp_dot(-left_neighbour.dir) >= 0.0 {
            left = -left_neighbour.dir;
            left_foreign = true;
        }
        if o2.convex && right.perp_dot(o2.dir) <= 0.0 {
            right = o2.dir;
            right_foreign = true;
        }
        let left_cut = (o1.point - pos) * inv_tau;
        let right_cut = (o2.point - pos) * inv_tau;
        let cut = right_cut - left_cut;
        let t = if same {
            0.5
        } else {
            (vel - left_cut).dot(cut) / cut.length_squared()
        };
        let t_left = (vel - left_cut).dot(left);
        let t_right = (vel - right_cut).dot(right);
        let on_disc = |centre: Vec2| {
            let unit = (vel - centre).normalize_or_zero();
            Line {
                point: centre + unit * (radius * inv_tau),
                dir: Vec2::new(unit.y, -unit.x),
            }
        };
        if (t < 0.0 && t_left < 0.0) || (same && t_left < 0.0 && t_right < 0.0) {
            return Some(on_disc(left_cut));
        }
        if t > 1.0 && t_right < 0.0 {
            return Some(on_disc(right_cut));
        }
        let d_cut = if !(0.0..=1.0).contains(&t) || same {
            f32::INFINITY
        } else {
            (vel - (left_cut + cut * t)).length_squared()
        };
        let d_left = if t_left < 0.0 {
            f32::INFINITY
        } else {
            (vel - (left_cut + left * t_left)).length_squared()
        };
        let d_right = if t_right < 0.0 {
            f32::INFINITY
        } else {
            (vel - (right_cut + right * t_right)).length_squared()
        };
        let shifted = |anchor: Vec2, dir: Vec2| Line {
            point: anchor + Vec2::new(-dir.y, dir.x) * (radius * inv_tau),
            dir,
        };
        if d_cut <= d_left && d_cut <= d_right {
            Some(shifted(left_cut, -o1.dir))
        } else if d_left <= d_right {
            (!left_foreign).then(|| shifted(left_cut, left))
        } else {
            (!right_foreign).then(|| shifted(right_cut, -right))
        }
    }
}

/// Squared distance from `p` to the segment `a b`.
fn segment_dist_sq(a: Vec2, b: Vec2, p: Vec2) -> f32 {
    Wall { a, b }.closest_point(p).distance_squared(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(c: Vec2, h: f32) -> Vec<Wall> {
        let p = [
            c + Vec2::new(-h, -h),
            c + Vec2::new(h, -h),
            c + Vec2::new(h, h),
            c + Vec2::new(-h, h),
        ];
        (0..4)
            .map(|i| Wall {
                a: p[i],
                b: p[(i + 1) % 4],
            })
            .collect()
    }

    #[test]
    fn chains_link_walls_and_mark_convexity() {
        let chains = WallChains::new(&square(Vec2::ZERO, 1.0));
        assert_eq!(chains.loops.len(), 1);
        assert_eq!(chains.verts.len(), 8);
        for (k, v) in chains.verts.iter().enumerate() {
            assert_eq!(v.convex, matches!(v.side, Side::Outside(_)), "{v:?}");
            assert_eq!(chains.verts[v.next as usize].prev as usize, k);
        }
        // Each wall's two edges run along it, one each way.
        for (w, wall) in square(Vec2::ZERO, 1.0).iter().enumerate() {
            let [a, b] = chains.edges_of_wall[w].map(|e| {
                let v = chains.verts[e as usize];
                (v.point, chains.verts[v.next as usize].point)
            });
            assert_eq!(a, (wall.a, wall.b));
            assert_eq!(b, (wall.b, wall.a));
        }
        // An open L: four edges, all three vertices of each side's walk convex or concave by turn.
        let l = [
            Wall {
                a: Vec2::ZERO,
                b: Vec2::X,
            },
            Wall {
                a: Vec2::new(1.0, 1.0),
                b: Vec2::X,
            },
        ];
        let chains = WallChains::new(&l);
        assert!(chains.loops.is_empty());
        assert_eq!(chains.verts.len(), 4);
        let convex = chains.verts.iter().filter(|v| v.convex).count();
        assert_eq!(
            convex, 3,
            "the two free ends and the outer side of the corner"
        );
    }

    #[test]
    fn an_agent_sees_only_the_near_side_of_a_block_and_every_side_of_a_room() {
        let chains = WallChains::new(&square(Vec2::ZERO, 1.0));
        let mut cache = Vec::new();
        let mut out = Vec::new();
        for w in 0..4 {
            chains.edges_near(w, Vec2::new(3.0, 0.2), 100.0, &mut cache, &mut out);
        }
        assert_eq!(
            out.len(),
            1,
            "outside, east of the block: its east face only"
        );
        let room = WallChains::new(&square(Vec2::ZERO, 10.0));
        let (mut cache, mut out) = (Vec::new(), Vec::new());
        for w in 0..4 {
            room.edges_near(w, Vec2::new(3.0, 0.2), 1000.0, &mut cache, &mut out);
        }
        assert_eq!(out.len(), 4, "inside a room: all four walls");
    }

    #[test]
    fn a_line_from_a_wall_forbids_walking_into_it() {
        let walls = [Wall {
            a: Vec2::new(2.0, -5.0),
            b: Vec2::new(2.0, 5.0),
        }];
        let chains = WallChains::new(&walls);
        let (mut cache, mut edges, mut lines) = (Vec::new(), Vec::new(), Vec::new());
        let pos = Vec2::ZERO;
        chains.edges_near(0, pos, 400.0, &mut cache, &mut edges);
        assert_eq!(edges.len(), 1);
        chains.lines(&edges, pos, Vec2::new(1.0, 0.0), 0.5, 0.5, &mut lines);
        assert_eq!(lines.len(), 1);
        // Walking at 1 toward a wall 1.5 away past the agent's radius within 2 s is forbidden,
        // walking along it is permitted.
        assert!(lines[0].violation(Vec2::new(1.0, 0.0)) > 0.0);
        assert!(lines[0].violation(Vec2::new(0.0, 1.0)) <= 0.0);
        assert!(lines[0].violation(Vec2::new(-1.0, 0.0)) <= 0.0);
    }
}
