//! Static obstacles: circles and line-segment walls (closed polygons are walls), a broad-phase
//! grid over them, Reynolds' avoidance behaviours, and the hard non-penetration step.
//!
//! Invariants the world keeps with [`Obstacles::resolve`], checked every step: no agent centre
//! ever lies strictly inside a circle obstacle, and no agent's move crosses a wall. Steering
//! ([`avoid_circles`], [`avoid_walls`]) keeps agents away smoothly; the resolve step is the
//! guarantee when steering is not enough.

mod broadphase;

use glam::Vec2;
use serde::{Deserialize, Serialize};

pub use broadphase::ObstacleGrid;

use crate::error::{Error, Result, positive};
use crate::vector::Basis;

/// A circular obstacle.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Circle {
    /// Centre.
    pub center: Vec2,
    /// Radius (> 0).
    pub radius: f32,
}

impl Circle {
    /// The circle of `radius` around `center` (checked when it is added to a world).
    #[must_use]
    pub fn new(center: Vec2, radius: f32) -> Self {
        Circle { center, radius }
    }
}

/// A wall: a line segment agents may not cross.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Wall {
    /// One end.
    pub a: Vec2,
    /// The other end.
    pub b: Vec2,
}

impl Wall {
    /// The point of the segment closest to `p`.
    #[inline]
    #[must_use]
    pub fn closest_point(&self, p: Vec2) -> Vec2 {
        let ab = self.b - self.a;
        let len_sq = ab.length_squared();
        if len_sq == 0.0 {
            return self.a;
        }
        let t = ((p - self.a).dot(ab) / len_sq).clamp(0.0, 1.0);
        self.a + ab * t
    }

    /// The point of the segment closest to `p`, and whether it is one of the ends: then exactly
    /// that end (where [`Wall::closest_point`] may round `a + (b - a) * 1` off `b`), so that walls
    /// meeting at a corner can be matched by their shared end.
    #[inline]
    #[must_use]
    pub fn closest_point_or_end(&self, p: Vec2) -> (Vec2, bool) {
        let ab = self.b - self.a;
        let len_sq = ab.length_squared();
        if len_sq == 0.0 {
            return (self.a, true);
        }
        let t = (p - self.a).dot(ab) / len_sq;
        if t <= 0.0 {
            (self.a, true)
        } else if t >= 1.0 {
            (self.b, true)
        } else {
            (self.a + ab * t, false)
        }
    }
}

/// Where segment `p0 -> p1` first meets segment `q0 -> q1`: `(t along p, point)`, or `None`.
/// Touching counts as meeting.
#[inline]
#[must_use]
pub fn segment_intersection(p0: Vec2, p1: Vec2, q0: Vec2, q1: Vec2) -> Option<(f32, Vec2)> {
    let r = p1 - p0;
    let s = q1 - q0;
    let denom = r.perp_dot(s);
    let qp = q0 - p0;
    if denom == 0.0 {
        return None; // parallel (collinear overlaps are handled by the closest-point test)
    }
    let t = qp.perp_dot(s) / denom;
    let u = qp.perp_dot(r) / denom;
    if (0.0..=1.0).contains(&t) && (0.0..=1.0).contains(&u) {
        Some((t, p0 + r * t))
    } else {
        None
    }
}

/// The checks of [`Obstacles::add_circle`].
fn check_circle(circle: &Circle) -> Result<()> {
    crate::error::coordinate("circle.center", circle.center)?;
    positive("circle.radius", circle.radius)?;
    crate::error::in_range(
        "circle.radius",
        circle.radius,
        0.0,
        crate::error::MAX_COORDINATE,
        "(0, 1e18]",
    )?;
    Ok(())
}

/// The checks of [`Obstacles::add_wall`].
fn check_wall(wall: &Wall) -> Result<()> {
    crate::error::coordinate("wall.a", wall.a)?;
    crate::error::coordinate("wall.b", wall.b)?;
    if wall.a == wall.b {
        return Err(Error::Invalid {
            name: "wall".into(),
            reason: "its two ends are the same point".into(),
        });
    }
    Ok(())
}

/// The obstacles of a world and their broad-phase grid.
#[derive(Clone, Debug, Default)]
pub struct Obstacles {
    circles: Vec<Circle>,
    walls: Vec<Wall>,
    grid: ObstacleGrid,
}

impl Obstacles {
    /// No obstacles.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Obstacles from lists of circles and walls, each checked as [`Obstacles::add_circle`] and
    /// [`Obstacles::add_wall`] do, with the broad phase built once.
    pub(crate) fn from_lists(circles: Vec<Circle>, walls: Vec<Wall>) -> Result<Self> {
        let mut o = Obstacles::new();
        circles.iter().try_for_each(check_circle)?;
        walls.iter().try_for_each(check_wall)?;
        o.circles = circles;
        o.walls = walls;
        o.grid.rebuild(&o.circles, &o.walls);
        Ok(o)
    }

    /// Whether there are none.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.circles.is_empty() && self.walls.is_empty()
    }

    /// The circles.
    #[must_use]
    pub fn circles(&self) -> &[Circle] {
        &self.circles
    }

    /// The walls.
    #[must_use]
    pub fn walls(&self) -> &[Wall] {
        &self.walls
    }

    /// The broad-phase grid over the obstacles.
    #[must_use]
    pub fn broadphase(&self) -> &ObstacleGrid {
        &self.grid
    }

    /// Adds a circle.
    ///
    /// # Errors
    /// [`Error::NonFinite`] or [`Error::NotPositive`] for a bad centre or radius.
    pub fn add_circle(&mut self, circle: Circle) -> Result<()> {
        check_circle(&circle)?;
        self.circles.push(circle);
        self.grid.rebuild(&self.circles, &self.walls);
        Ok(())
    }

    /// Adds many circles and rebuilds the broad phase once (adding them one by one rebuilds it
    /// after each, which is quadratic in the count). Nothing is added when one is bad.
    ///
    /// # Errors
    /// As [`Obstacles::add_circle`], for the first bad circle.
    pub fn add_circles(&mut self, circles: &[Circle]) -> Result<()> {
        circles.iter().try_for_each(check_circle)?;
        crate::error::try_reserve(&mut self.circles, circles.len(), "circles")?;
        self.circles.extend_from_slice(circles);
        self.grid.rebuild(&self.circles, &self.walls);
        Ok(())
    }

    /// Adds a wall.
    ///
    /// # Errors
    /// [`Error::NonFinite`] for a bad end, [`Error::Invalid`] for a wall of length zero.
    pub fn add_wall(&mut self, wall: Wall) -> Result<()> {
        check_wall(&wall)?;
        self.walls.push(wall);
        self.grid.rebuild(&self.circles, &self.walls);
        Ok(())
    }

    /// Adds many walls and rebuilds the broad phase once; nothing is added when one is bad.
    ///
    /// # Errors
    /// As [`Obstacles::add_wall`], for the first bad wall.
    pub fn add_walls(&mut self, walls: &[Wall]) -> Result<()> {
        walls.iter().try_for_each(check_wall)?;
        crate::error::try_reserve(&mut self.walls, walls.len(), "walls")?;
        self.walls.extend_from_slice(walls);
        self.grid.rebuild(&self.circles, &self.walls);
        Ok(())
    }

    /// Adds the walls of a polyline, closed into a polygon when `closed`.
    ///
    /// # Errors
    /// [`Error::Invalid`] for fewer than two points (three when closed), or as [`Obstacles::add_wall`].
    pub fn add_polygon(&mut self, points: &[Vec2], closed: bool) -> Result<()> {
        let need = if closed { 3 } else { 2 };
        if points.len() < need {
            return Err(Error::Invalid {
                name: "polygon".into(),
                reason: format!("needs at least {need} points, got {}", points.len()),
            });
        }
        let mut walls = Vec::with_capacity(points.len());
        for w in points.windows(2) {
            walls.push(Wall { a: w[0], b: w[1] });
        }
        if closed {
            walls.push(Wall {
                a: points[points.len() - 1],
                b: points[0],
            });
        }
        for w in &walls {
            crate::error::coordinate("polygon point", w.a)?;
            crate::error::coordinate("polygon point", w.b)?;
        }
        for w in walls {
            if w.a != w.b {
                self.walls.push(w);
            }
        }
        self.grid.rebuild(&self.circles, &self.walls);
        Ok(())
    }

    /// Whether `p` lies strictly inside some circle.
    #[must_use]
    pub fn inside_circle(&self, p: Vec2) -> bool {
        self.near_circle(p, 0.0)
    }

    /// Whether `p` lies closer than `margin` (>= 0) to some circle's edge, or inside it.
    #[must_use]
    pub fn near_circle(&self, p: Vec2, margin: f32) -> bool {
        let mut near = false;
        self.grid.visit(
            p,
            margin,
            |c| {
                let c = &self.circles[c as usize];
                near |= c.center.distance_squared(p) < sq(c.radius + margin);
            },
            |_| {},
        );
        near
    }

    /// Whether `p` lies closer than `margin` (>= 0) to some wall.
    #[must_use]
    pub fn near_wall(&self, p: Vec2, margin: f32) -> bool {
        let mut near = false;
        self.grid.visit(
            p,
            margin,
            |_| {},
            |w| {
                let w = &self.walls[w as usize];
                near |= w.closest_point(p).distance_squared(p) < sq(margin);
            },
        );
        near
    }

    /// Whether the move `from -> to` crosses a wall.
    #[must_use]
    pub fn crosses_wall(&self, from: Vec2, to: Vec2) -> bool {
        let reach = (to - from).length();
        let mut hit = false;
        self.grid.visit(
            from,
            reach,
            |_| {},
            |w| {
                hit |= segment_intersection(
                    from,
                    to,
                    self.walls[w as usize].a,
                    self.walls[w as usize].b,
                )
                .is_some()
            },
        );
        hit
    }

    /// The hard non-penetration step for one agent that moved from `from` (a valid position) to
    /// `to` with velocity `velocity`: pushes the centre out of any circle it entered and takes
    /// back a move that crossed a wall, removing the velocity component into the obstacle.
    /// Returns the corrected position and velocity.
    #[must_use]
    pub fn resolve(&self, from: Vec2, to: Vec2, velocity: Vec2) -> (Vec2, Vec2) {
        let mut p = to;
        let mut v = velocity;
        // Circles: push the centre back onto the surface, a few rounds for overlapping circles.
        let rounds = if self.circles.is_empty() { 0 } else { 4 };
        for _ in 0..rounds {
            let mut moved = false;
            self.grid.visit(
                p,
                0.0,
                |c| {
                    let c = self.circles[c as usize];
                    let d = p - c.center;
                    let d_sq = d.length_squared();
                    if d_sq < sq(c.radius) {
                        let n = d
                            .try_normalize()
                            .or_else(|| (from - c.center).try_normalize())
                            .unwrap_or(Vec2::X);
                        p = c.center + n * (c.radius * (1.0 + 1e-5) + 1e-5);
                        let into = v.dot(n);
                        if into < 0.0 {
                            v -= n * into;
                        }
                        moved = true;
                    }
                },
                |_| {},
            );
            if !moved {
                break;
            }
        }
        if rounds > 0 && self.inside_circle(p) {
            return (from, Vec2::ZERO);
        }
        // Walls: a move that crosses one is taken back.
        if p != from && self.crosses_wall(from, p) {
            let mut normal = Vec2::ZERO;
            self.grid.visit(
                from,
                (p - from).length(),
                |_| {},
                |w| {
                    let w = self.walls[w as usize];
                    if segment_intersection(from, p, w.a, w.b).is_some() {
                        normal = (w.b - w.a).perp().normalize_or_zero();
                    }
                },
            );
            let into = v.dot(normal);
            return (from, v - normal * into);
        }
        (p, v)
    }
}

#[inline]
fn sq(x: f32) -> f32 {
    x * x
}

/// Reynolds' obstacle avoidance with a detection box: the box reaches `box_length` ahead of the
/// agent along its heading and is as wide as the agent (`agent_radius` each side). Of the circles
/// that intersect it, the closest ahead produces a lateral force away from its centre (stronger
/// the closer it is) and a braking force. `max_force` scales the result.
#[must_use]
pub fn avoid_circles(
    basis: &Basis,
    agent_radius: f32,
    box_length: f32,
    max_force: f32,
    circles: impl IntoIterator<Item = Circle>,
) -> Vec2 {
    let mut closest: Option<(f32, Vec2, f32)> = None; // (local x, local centre, expanded radius)
    for c in circles {
        let local = basis.to_local(c.center);
        let expanded = c.radius + agent_radius;
        if local.x < -expanded || local.x > box_length + expanded || local.y.abs() >= expanded {
            continue;
        }
        // Nearest intersection of the box's centre line with the expanded circle.
        let sqrt_part = (expanded * expanded - local.y * local.y).max(0.0).sqrt();
        let mut ix = local.x - sqrt_part;
        if ix <= 0.0 {
            ix = local.x + sqrt_part;
        }
        if ix < 0.0 {
            continue;
        }
        if closest.is_none_or(|(best, _, _)| ix < best) {
            closest = Some((ix, local, expanded));
        }
    }
    let Some((ix, local, expanded)) = closest else {
        return Vec2::ZERO;
    };
    let urgency = 1.0 + (box_length - ix.min(box_length)) / box_length;
    let side = if local.y == 0.0 {
        1.0
    } else {
        -local.y.signum()
    };
    let lateral = side * (expanded - local.y.abs()) / expanded * urgency;
    let braking = -0.2 * (expanded - local.x.min(expanded)).max(0.0) / expanded;
    basis.vector_to_world(Vec2::new(braking, lateral)) * max_force
}

/// Wall avoidance with three feelers (ahead, and half as long at 45 degrees either side): the
/// feeler that reaches deepest past a wall produces a force along the wall's normal, towards the
/// agent's side, proportional to the overshoot.
#[must_use]
pub fn avoid_walls(
    basis: &Basis,
    feeler_length: f32,
    max_force: f32,
    walls: impl IntoIterator<Item = Wall> + Clone,
) -> Vec2 {
    let p = basis.position;
    let diag = std::f32::consts::FRAC_1_SQRT_2;
    let feelers = [
        basis.to_world(Vec2::new(feeler_length, 0.0)),
        basis.to_world(Vec2::new(
            0.5 * feeler_length * diag,
            0.5 * feeler_length * diag,
        )),
        basis.to_world(Vec2::new(
            0.5 * feeler_length * diag,
            -0.5 * feeler_length * diag,
        )),
    ];
    let mut best = Vec2::ZERO;
    let mut best_depth = 0.0_f32;
    for tip in feelers {
        let mut nearest: Option<(f32, Wall)> = None;
        for w in walls.clone() {
            if let Some((t, _)) = segment_intersection(p, tip, w.a, w.b)
                && nearest.is_none_or(|(bt, _)| t < bt)
            {
                nearest = Some((t, w));
            }
        }
        if let Some((t, w)) = nearest {
            let depth = (1.0 - t) * (tip - p).length();
            if depth > best_depth {
                let mut n = (w.b - w.a).perp().normalize_or_zero();
                if n.dot(p - w.a) < 0.0 {
                    n = -n;
                }
                best_depth = depth;
                best = n * (depth / feeler_length);
            }
        }
    }
    best * max_force
}

/// Containment in a walled rectangle `[0, size]`: when the position predicted `lookahead`
/// seconds ahead lies within `margin` of an edge (or beyond), a force pushes back inside,
/// proportional to how far in the margin it reaches.
#[must_use]
pub fn containment(
    position: Vec2,
    velocity: Vec2,
    size: Vec2,
    margin: f32,
    lookahead: f32,
    max_force: f32,
) -> Vec2 {
    let ahead = position + velocity * lookahead;
    let push = |x: f32, side: f32| -> f32 {
        if x < margin {
            (margin - x) / margin
        } else if x > side - margin {
            -(x - (side - margin)) / margin
        } else {
            0.0
        }
    };
    Vec2::new(push(ahead.x, size.x), push(ahead.y, size.y)).clamp_length_max(1.0) * max_force
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resolve_pushes_out_of_circles_and_back_from_walls() {
        let mut o = Obstacles::new();
        o.add_circle(Circle {
            center: Vec2::new(5.0, 0.0),
            radius: 1.0,
        })
        .unwrap();
        o.add_wall(Wall {
            a: Vec2::new(-2.0, -5.0),
            b: Vec2::new(-2.0, 5.0),
        })
        .unwrap();
        let (p, v) = o.resolve(
            Vec2::new(3.0, 0.0),
            Vec2::new(4.5, 0.0),
            Vec2::new(1.0, 0.0),
        );
        assert!(p.distance(Vec2::new(5.0, 0.0)) >= 1.0, "{p}");
        assert!(v.x <= 0.0);
        let (p, v) = o.resolve(
            Vec2::new(-1.0, 0.0),
            Vec2::new(-3.0, 0.5),
            Vec2::new(-2.0, 0.5),
        );
        assert_eq!(p, Vec2::new(-1.0, 0.0));
        assert!(v.x.abs() < 1e-6 && (v.y - 0.5).abs() < 1e-6, "{v}");
    }

    #[test]
    fn avoidance_turns_away_from_a_circle_ahead() {
        let basis = Basis::from_orientation(Vec2::ZERO, 0.0);
        let f = avoid_circles(
            &basis,
            0.5,
            5.0,
            1.0,
            [Circle {
                center: Vec2::new(3.0, 0.3),
                radius: 1.0,
            }],
        );
        assert!(f.y < 0.0, "circle slightly left: steer right, got {f}");
        let none = avoid_circles(
            &basis,
            0.5,
            5.0,
            1.0,
            [Circle {
                center: Vec2::new(-3.0, 0.0),
                radius: 1.0,
            }],
        );
        assert_eq!(none, Vec2::ZERO);
    }

    #[test]
    fn bad_obstacles_are_rejected() {
        let mut o = Obstacles::new();
        assert!(matches!(
            o.add_circle(Circle {
                center: Vec2::ZERO,
                radius: -1.0
            }),
            Err(Error::NotPositive { .. })
        ));
        assert!(matches!(
            o.add_wall(Wall {
                a: Vec2::ONE,
                b: Vec2::ONE
            }),
            Err(Error::Invalid { .. })
        ));
        assert!(matches!(
            o.add_polygon(&[Vec2::ZERO, Vec2::ONE], true),
            Err(Error::Invalid { .. })
        ));
    }
}
