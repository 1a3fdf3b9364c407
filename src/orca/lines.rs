//! The ORCA half-plane of one agent against another agent or a circle obstacle.
//!
//! For agents A and B with relative position `p = pB - pA`, relative velocity `v = vA - vB`
//! and combined radius `r`, the truncated velocity obstacle of horizon `tau` is the cone of
//! velocities that reach the disc of radius `r` around `p` within `tau`, cut off by the disc of
//! radius `r / tau` around `p / tau`. `u` is the smallest change of `v` that leaves it; A takes
//! the share `responsibility` of it, and the line through `vA + share * u`, perpendicular to
//! `u`, bounds A's permitted velocities. When A and B already overlap, the cut-off disc of one
//! time step replaces it (the pair separates within the step).
//!
//! [`LineBlock`] computes eight lines at once in lanes, bit for bit [`agent_line`]'s. The
//! steering layer's filter calls [`agent_line`] per neighbour: its inputs arrive one neighbour at
//! a time, and written a lane at a time then read back as vectors they cost more than the
//! lanes save (docs/PERFORMANCE.md).
//!
//! Invariant: the returned line's direction is a unit vector and every value is finite for
//! finite inputs (coincident agents get a deterministic direction, see [`agent_line`]).

use glam::Vec2;

use super::lp::Line;

/// The ORCA line of an agent with velocity `vel` against a neighbour at relative position
/// `rel_pos` with relative velocity `rel_vel = vel - neighbour velocity`, combined radius
/// `radius`, horizon `1 / inv_tau`, step `1 / inv_dt`, of which the agent takes the share
/// `share` (0.5 between two ORCA agents, 1 against a static obstacle). `tie` (+1 or -1) chooses
/// the direction in which exactly coincident agents with equal velocities separate; the two
/// agents of a pair must pass opposite signs (the caller derives them from the ids).
#[inline]
#[must_use]
#[allow(clippy::too_many_arguments)]
pub fn agent_line(
    vel: Vec2,
    rel_pos: Vec2,
    rel_vel: Vec2,
    radius: f32,
    inv_tau: f32,
    inv_dt: f32,
    share: f32,
    tie: f32,
) -> Line {
    let dist_sq = rel_pos.length_squared();
    let r_sq = radius * radius;
    let (dir, u);
    if dist_sq > r_sq {
        // Apart: the velocity obstacle's cut-off disc or one of its legs is nearest.
        let w = rel_vel - rel_pos * inv_tau;
        let w_len_sq = w.length_squared();
        let dot = w.dot(rel_pos);
        if dot < 0.0 && dot * dot > r_sq * w_len_sq {
            let w_len = w_len_sq.sqrt();
            let unit = w / w_len;
            dir = Vec2::new(unit.y, -unit.x);
            u = unit * (radius * inv_tau - w_len);
        } else {
            let leg = (dist_sq - r_sq).sqrt();
            dir = if rel_pos.perp_dot(w) > 0.0 {
                // The left leg.
                Vec2::new(
                    rel_pos.x * leg - rel_pos.y * radius,
                    rel_pos.x * radius + rel_pos.y * leg,
                ) / dist_sq
            } else {
                // The right leg.
                -Vec2::new(
                    rel_pos.x * leg + rel_pos.y * radius,
                    -rel_pos.x * radius + rel_pos.y * leg,
                ) / dist_sq
            };
            u = dir * rel_vel.dot(dir) - rel_vel;
        }
    } else {
        // Overlapping: leave the disc of one time step.
        let w = rel_vel - rel_pos * inv_dt;
        let w_len = w.length();
        let unit = if w_len > 0.0 {
            w / w_len
        } else {
            Vec2::new(tie, 0.0)
        };
        dir = Vec2::new(unit.y, -unit.x);
        u = unit * (radius * inv_dt - w_len);
    }
    Line {
        point: vel + u * share,
        dir,
    }
}

/// Lanes in a [`LineBlock`].
pub const LANES: usize = 8;

/// The inputs of up to [`LANES`] agent lines, one per lane, as [`agent_line`] takes them (the
/// velocity and the horizons are shared by the block). Lanes past those in use may hold any
/// value: their lines are computed and ignored.
#[derive(Clone, Copy, Debug, Default)]
pub struct LineBlock {
    /// Relative positions of the neighbours (`rel_pos`).
    pub rel_x: [f32; LANES],
    /// See `rel_x`.
    pub rel_y: [f32; LANES],
    /// Relative velocities (`rel_vel`).
    pub rel_vx: [f32; LANES],
    /// See `rel_vx`.
    pub rel_vy: [f32; LANES],
    /// Combined radii.
    pub radius: [f32; LANES],
    /// Shares of the avoidance.
    pub share: [f32; LANES],
    /// Directions for coincident agents (+1 or -1).
    pub tie: [f32; LANES],
}

impl LineBlock {
    /// The lines of every lane: lane `k` is `agent_line(vel, rel_pos[k], rel_vel[k],
    /// radius[k], inv_tau, inv_dt, share[k], tie[k])` bit for bit. Every case is evaluated in
    /// every lane and the right one selected, with the scalar form's operations in its order, so
    /// the block compiles to vector code where the caller's target allows.
    #[inline(always)]
    #[must_use]
    pub fn lines(&self, vel: Vec2, inv_tau: f32, inv_dt: f32) -> [Line; LANES] {
        let mut px = [0.0f32; LANES];
        let mut py = [0.0f32; LANES];
        let mut dx = [0.0f32; LANES];
        let mut dy = [0.0f32; LANES];
        for k in 0..LANES {
            let (rx, ry) = (self.rel_x[k], self.rel_y[k]);
            let (vx, vy) = (self.rel_vx[k], self.rel_vy[k]);
            let radius = self.radius[k];
            let dist_sq = rx * rx + ry * ry;
            let r_sq = radius * radius;
            // Apart, the cut-off disc.
            let (wx, wy) = (vx - rx * inv_tau, vy - ry * inv_tau);
            let w_len_sq = wx * wx + wy * wy;
            let dot = wx * rx + wy * ry;
            let cut = dot < 0.0 && dot * dot > r_sq * w_len_sq;
            let w_len = w_len_sq.sqrt();
            let (cx, cy) = (wx / w_len, wy / w_len);
            let s = radius * inv_tau - w_len;
            let cut_dir = (cy, -cx);
            let cut_u = (cx * s, cy * s);
            // Apart, a leg.
            let leg = (dist_sq - r_sq).sqrt();
            let left = rx * wy - ry * wx > 0.0;
            let (ax, ay) = if left {
                (rx * leg - ry * radius, rx * radius + ry * leg)
            } else {
                (-(rx * leg + ry * radius), -(-rx * radius + ry * leg))
            };
            let leg_dir = (ax / dist_sq, ay / dist_sq);
            let along = vx * leg_dir.0 + vy * leg_dir.1;
            let leg_u = (leg_dir.0 * along - vx, leg_dir.1 * along - vy);
            // Overlapping.
            let (ox, oy) = (vx - rx * inv_dt, vy - ry * inv_dt);
            let o_len = (ox * ox + oy * oy).sqrt();
            let (ux, uy) = if o_len > 0.0 {
                (ox / o_len, oy / o_len)
            } else {
                (self.tie[k], 0.0)
            };
            let so = radius * inv_dt - o_len;
            let over_dir = (uy, -ux);
            let over_u = (ux * so, uy * so);

            let ((dirx, diry), (ux, uy)) = if dist_sq > r_sq {
                if cut {
                    (cut_dir, cut_u)
                } else {
                    (leg_dir, leg_u)
                }
            } else {
                (over_dir, over_u)
            };
            let share = self.share[k];
            px[k] = vel.x + ux * share;
            py[k] = vel.y + uy * share;
            dx[k] = dirx;
            dy[k] = diry;
        }
        std::array::from_fn(|k| Line {
            point: Vec2::new(px[k], py[k]),
            dir: Vec2::new(dx[k], dy[k]),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether an agent at the origin moving at `v` for `tau` seconds comes within `r` of a
    /// static disc at `p` (sampled along the way).
    fn collides(v: Vec2, p: Vec2, r: f32, tau: f32) -> bool {
        (0..=1000).any(|k| (v * (tau * k as f32 / 1000.0)).distance(p) < r * 0.999)
    }

    #[test]
    fn a_static_obstacles_line_permits_only_collision_free_velocities() {
        // With the whole responsibility, every permitted velocity is collision-free.
        let p = Vec2::new(5.0, 0.5);
        let r = 1.5;
        let vel = Vec2::new(2.0, 0.0);
        assert!(collides(vel, p, r, 2.0));
        let line = agent_line(vel, p, vel, r, 0.5, 4.0, 1.0, 1.0);
        for i in -20..=20 {
            for j in -20..=20 {
                let v = Vec2::new(i as f32 * 0.15, j as f32 * 0.15);
                if line.violation(v) < -1e-4 {
                    assert!(!collides(v, p, r, 2.0), "{v} permitted but collides");
                }
            }
        }
        // The current velocity collides, so it is not permitted.
        assert!(line.violation(vel) > 0.0);
    }

    #[test]
    fn a_block_of_lanes_equals_the_scalar_line_bit_for_bit() {
        let mut rng = crate::rng::AgentRng::new(5, 1, 2, 3);
        let mut cases = [0usize; 3];
        for _ in 0..4000 {
            let mut block = LineBlock::default();
            let vel = Vec2::new(rng.signed() * 2.0, rng.signed() * 2.0);
            for k in 0..LANES {
                let scale = [0.2, 1.0, 3.0, 20.0][k % 4];
                block.rel_x[k] = rng.signed() * scale;
                block.rel_y[k] = rng.signed() * scale;
                block.rel_vx[k] = rng.signed() * 4.0;
                block.rel_vy[k] = rng.signed() * 4.0;
                block.radius[k] = 0.5 + rng.unit() * 3.0;
                block.share[k] = [0.5, 1.0, 0.25][k % 3];
                block.tie[k] = if k % 2 == 0 { 1.0 } else { -1.0 };
            }
            // Coincident agents with equal velocities, and a pair exactly at contact.
            block.rel_x[7] = 0.0;
            block.rel_y[7] = 0.0;
            block.rel_vx[7] = 0.0;
            block.rel_vy[7] = 0.0;
            block.rel_x[6] = block.radius[6];
            block.rel_y[6] = 0.0;
            let lines = block.lines(vel, 0.1, 4.0);
            for (k, &line) in lines.iter().enumerate() {
                let rel = Vec2::new(block.rel_x[k], block.rel_y[k]);
                let want = agent_line(
                    vel,
                    rel,
                    Vec2::new(block.rel_vx[k], block.rel_vy[k]),
                    block.radius[k],
                    0.1,
                    4.0,
                    block.share[k],
                    block.tie[k],
                );
                let bits = |l: Line| [l.point.x, l.point.y, l.dir.x, l.dir.y].map(f32::to_bits);
                assert_eq!(bits(line), bits(want), "lane {k}: {block:?}");
                let r = block.radius[k];
                let w = Vec2::new(block.rel_vx[k], block.rel_vy[k]) - rel * 0.1;
                let cut = w.dot(rel) < 0.0 && w.dot(rel).powi(2) > r * r * w.length_squared();
                cases[if rel.length_squared() <= r * r {
                    2
                } else if cut {
                    0
                } else {
                    1
                }] += 1;
            }
        }
        // Every case of the line was met many times.
        assert!(cases.iter().all(|&c| c > 1000), "{cases:?}");
    }

    #[test]
    fn coincident_agents_separate_in_opposite_directions() {
        let a = agent_line(Vec2::ZERO, Vec2::ZERO, Vec2::ZERO, 1.0, 0.1, 4.0, 0.5, 1.0);
        let b = agent_line(Vec2::ZERO, Vec2::ZERO, Vec2::ZERO, 1.0, 0.1, 4.0, 0.5, -1.0);
        assert!(a.point.is_finite() && b.point.is_finite());
        assert!((a.dir.length() - 1.0).abs() < 1e-6);
        // Each forbids standing still and permits moving away from the other.
        assert!(a.violation(Vec2::ZERO) > 0.0 && b.violation(Vec2::ZERO) > 0.0);
        assert!(a.point.dot(b.point) < 0.0);
    }
}
