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
