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
//! lanes save (docs/notes/performance-history.md).
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
            dir = leg_of(rel_pos, w, radius, (dist_sq - r_sq).sqrt()) / dist_sq;
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

/// Whether the line [`agent_line`] gives for these inputs surely permits `v`: `true` only when
/// its violation at `v` is below `-margin`, where the margin (a `2^-12` share of the sum of the
/// magnitudes of `vel`, `v`, `rel_vel`, `w` and `radius / tau`) is far above the rounding of
/// either computation, so that the built line's [`Line::violation`] at `v` is then at most
/// zero. `false` when that is not certain: agents that overlap, scaled products that leave the
/// range where rounding is relative (subnormal or near overflow: agents a hair apart near the
/// origin, or magnitudes far beyond any scenario's), or values that are not numbers. `share` is
/// in `[0, 1]`, as the filter derives it from validated responsibilities.
///
/// It decides without building the line: no division, and no square root in the cut-off case.
/// In the cut-off case (the same `w`, bit for bit, as [`agent_line`]'s) the violation is
/// `w . (vel - v) / |w| + share * (radius / tau - |w|)`, below `-m` exactly when
/// `share |w|^2 - w . (vel - v) > (share * radius / tau + m) |w|`, compared in squares. On a
/// leg (the same unnormalised leg `d`, of length `|rel_pos|^2`) it is
/// `(d x (vel - v) - share * d x rel_vel) / |rel_pos|^2`.
#[inline(always)]
#[must_use]
#[allow(clippy::too_many_arguments)]
pub fn permits(
    vel: Vec2,
    rel_pos: Vec2,
    rel_vel: Vec2,
    radius: f32,
    inv_tau: f32,
    share: f32,
    v: Vec2,
) -> bool {
    let dist_sq = rel_pos.length_squared();
    let r_sq = radius * radius;
    // Overlapping (a value that is not a number fails every comparison below).
    if dist_sq <= r_sq {
        return false;
    }
    let w = rel_vel - rel_pos * inv_tau;
    let w_len_sq = w.length_squared();
    let dot = w.dot(rel_pos);
    let change = vel - v;
    let magnitude = vel.abs().element_sum()
        + v.abs().element_sum()
        + rel_vel.abs().element_sum()
        + w.abs().element_sum()
        + radius * inv_tau;
    let margin = PERMIT_MARGIN * magnitude;
    // Within the range of normal numbers, with room: below it the products lose the relative
    // precision the margin assumes (their rounding is absolute), above it they overflow.
    if !(margin * dist_sq >= PERMIT_TINY && magnitude * dist_sq <= PERMIT_HUGE) {
        return false;
    }
    if dot < 0.0 && dot * dot > r_sq * w_len_sq {
        let x = share * w_len_sq - w.dot(change);
        let y = share * radius * inv_tau + margin;
        let bound = y * y * w_len_sq;
        bound >= PERMIT_TINY && x > 0.0 && x * x > bound
    } else {
        let d = leg_of(rel_pos, w, radius, (dist_sq - r_sq).sqrt());
        d.perp_dot(change) - share * d.perp_dot(rel_vel) < -margin * dist_sq
    }
}

/// [`permits`]' margin, as a share of the sum of the magnitudes it adds up: about 2,000 times
/// the rounding of one operation, more than the few dozen operations of either computation can
/// lose.
const PERMIT_MARGIN: f32 = 1.0 / 4096.0;

/// The smallest scaled product [`permits`] decides on (2^-100, far above the subnormals).
const PERMIT_TINY: f32 = 7.888_609e-31;

/// The largest scaled product [`permits`] decides on (2^120, far below overflow).
const PERMIT_HUGE: f32 = 1.329_228e36;

/// The leg of the velocity obstacle nearest to `w` (the left one when `w` lies to the left of
/// `rel_pos`), unnormalised: its length is `|rel_pos|^2` (`leg` is the length of the tangent,
/// `sqrt(|rel_pos|^2 - radius^2)`). [`agent_line`] divides it by that length; [`permits`] uses
/// it as it is, the same bits.
#[inline(always)]
fn leg_of(rel_pos: Vec2, w: Vec2, radius: f32, leg: f32) -> Vec2 {
    if rel_pos.perp_dot(w) > 0.0 {
        Vec2::new(
            rel_pos.x * leg - rel_pos.y * radius,
            rel_pos.x * radius + rel_pos.y * leg,
        )
    } else {
        -Vec2::new(
            rel_pos.x * leg + rel_pos.y * radius,
            -rel_pos.x * radius + rel_pos.y * leg,
        )
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

    /// [`permits`] never claims a velocity the built line forbids: velocities at every
    /// distance from the line, down to a few units in the last place on either side, for both
    /// cases of apart agents, every share, point agents and discs, scales from 1e-21 (agents a
    /// hair apart, subnormal products) to 1e9; and it is not vacuous: it
    /// claims every velocity that the line clearly permits (by more than a hundredth of the
    /// magnitudes involved).
    #[test]
    fn permits_only_what_the_built_line_permits_and_all_it_clearly_does() {
        let mut rng = crate::rng::AgentRng::new(9, 4, 2, 7);
        let (mut claimed, mut clear, mut cases) = (0, 0, [0usize; 2]);
        for case in 0..200_000 {
            let scale = [1e-3, 0.3, 1.0, 5.0, 300.0, 1e-21, 1e-15, 1e9][case % 8];
            let signed = |rng: &mut crate::rng::AgentRng, s: f32| rng.signed() * s;
            let vel = Vec2::new(signed(&mut rng, 2.0 * scale), signed(&mut rng, 2.0 * scale));
            let rel = Vec2::new(
                signed(&mut rng, 20.0 * scale),
                signed(&mut rng, 20.0 * scale),
            );
            // Nearly equal velocities (a stream, the circle's ring) as often as any others.
            let spread = if case % 2 == 0 { 4.0 } else { 0.01 };
            let rel_vel = Vec2::new(
                signed(&mut rng, spread * scale),
                signed(&mut rng, spread * scale),
            );
            // Point agents (a radius of zero is valid) as well as discs.
            let radius = if case % 7 == 0 {
                0.0
            } else {
                (0.2 + rng.unit() * 3.0) * scale
            };
            let inv_tau = [0.1, 0.5, 1.0, 4.0][(case / 5) % 4];
            let share = [0.5, 1.0, 0.25, 0.0, 0.9][(case / 20) % 5];
            let line = agent_line(vel, rel, rel_vel, radius, inv_tau, 4.0, share, 1.0);
            // A velocity at a random distance from the line (a few ulps to far), either side.
            let along = signed(&mut rng, 4.0 * scale);
            let off = match case % 3 {
                0 => signed(&mut rng, 4.0 * scale),
                1 => signed(&mut rng, 1e-3 * scale),
                _ => signed(&mut rng, 1e-6 * scale),
            };
            let normal = Vec2::new(line.dir.y, -line.dir.x);
            let v = line.point + line.dir * along + normal * off;
            let magnitude = vel.abs().element_sum()
                + v.abs().element_sum()
                + rel_vel.abs().element_sum()
                + rel.length() * inv_tau
                + radius * inv_tau;
            let got = permits(vel, rel, rel_vel, radius, inv_tau, share, v);
            if got {
                claimed += 1;
                assert!(
                    line.violation(v) <= 0.0,
                    "case {case}: claimed, violation {}: {vel} {rel} {rel_vel} {radius} \
                     {inv_tau} {share} {v}",
                    line.violation(v)
                );
            }
            if rel.length_squared() > radius * radius {
                let w = rel_vel - rel * inv_tau;
                let cut =
                    w.dot(rel) < 0.0 && w.dot(rel).powi(2) > radius * radius * w.length_squared();
                cases[usize::from(cut)] += 1;
                // Clear cases at ordinary scales (the extremes are declined by design).
                if (1e-3..=300.0).contains(&scale) && line.violation(v) < -0.01 * magnitude {
                    clear += 1;
                    assert!(got, "case {case}: clearly permitted, not claimed");
                }
            }
        }
        assert!(claimed > 20_000 && clear > 15_000, "{claimed} {clear}");
        // Point agents a hair apart near the origin: the leg's products are subnormal, and
        // the line is violated.
        let (vel, rel) = (
            Vec2::new(-0.497_845_77, 0.006_402_015_7),
            Vec2::new(5.380_547e-23, 2.814_388e-23),
        );
        let rel_vel = Vec2::new(0.531_894_2, -0.782_381_06);
        let v = crate::orca::lp::tested(Vec2::new(-0.532_871_5, 0.690_586_1), 2.0);
        assert!(agent_line(vel, rel, rel_vel, 0.0, 0.1, 4.0, 0.5, 1.0).violation(v) > 0.0);
        assert!(!permits(vel, rel, rel_vel, 0.0, 0.1, 0.5, v));
        // Values that are not numbers, and overlapping agents, are never claimed.
        let (one, far) = (Vec2::ONE, Vec2::new(9.0, 0.0));
        assert!(permits(one, far, Vec2::ZERO, 1.0, 0.1, 0.5, one));
        for bad in [f32::NAN, f32::INFINITY] {
            let odd = Vec2::new(bad, 0.0);
            assert!(!permits(odd, far, Vec2::ZERO, 1.0, 0.1, 0.5, one));
            assert!(!permits(one, odd, Vec2::ZERO, 1.0, 0.1, 0.5, one));
            assert!(!permits(one, far, odd, 1.0, 0.1, 0.5, one));
            assert!(!permits(one, far, Vec2::ZERO, bad, 0.1, 0.5, one));
            assert!(!permits(one, far, Vec2::ZERO, 1.0, 0.1, bad, one));
            assert!(!permits(one, far, Vec2::ZERO, 1.0, 0.1, 0.5, odd));
        }
        assert!(!permits(
            one,
            Vec2::new(0.5, 0.0),
            Vec2::ZERO,
            1.0,
            0.1,
            0.5,
            one
        ));
        assert!(cases.iter().all(|&c| c > 5_000), "{cases:?}");
    }

    /// When [`permits`] holds for every neighbour, the programs' answer over the built lines is
    /// [`crate::orca::lp::accepted`] of the velocity they test, bit for bit: the filter's free
    /// flow gives what building the lines and solving gives. Neighbourhoods of a stream (nearly
    /// equal velocities, where most hold) and of a crowd in conflict (where most do not).
    #[test]
    fn when_every_neighbour_permits_the_programs_answer_is_the_tested_velocity() {
        use crate::orca::lp::{accepted, solve, tested, unconstrained};
        let mut rng = crate::rng::AgentRng::new(3, 8, 1, 5);
        let (mut free, mut bound_lines) = (0, 0);
        let mut projected = Vec::new();
        for case in 0..20_000 {
            let spread = if case % 2 == 0 { 0.05 } else { 2.0 };
            let max_speed = 2.0;
            let vel = Vec2::new(rng.signed(), rng.signed()) * 1.5;
            let pref = vel + Vec2::new(rng.signed(), rng.signed()) * spread;
            let n = 1 + case % 12;
            let lines: Vec<Line> = (0..n)
                .map(|_| {
                    let rel = Vec2::new(rng.signed(), rng.signed()) * 15.0;
                    let rel_vel = Vec2::new(rng.signed(), rng.signed()) * spread;
                    let radius = 1.0 + rng.unit() * 2.0;
                    let share = [0.5, 1.0, 0.3][case % 3];
                    let line = agent_line(vel, rel, rel_vel, radius, 0.1, 4.0, share, 1.0);
                    (
                        line,
                        permits(
                            vel,
                            rel,
                            rel_vel,
                            radius,
                            0.1,
                            share,
                            tested(pref, max_speed),
                        ),
                    )
                })
                .filter_map(|(line, permitted)| {
                    // Only the neighbourhoods where every neighbour permits are compared.
                    permitted.then_some(line).or_else(|| {
                        bound_lines += 1;
                        None
                    })
                })
                .collect();
            if lines.len() < n {
                continue;
            }
            free += 1;
            let want = accepted(tested(pref, max_speed), max_speed);
            let bits = |v: Vec2| [v.x.to_bits(), v.y.to_bits()];
            let got = solve(&lines, 0, max_speed, pref, &mut projected);
            assert_eq!(bits(got), bits(want), "case {case}");
            let got = unconstrained(&lines, max_speed, pref).expect("no line violated");
            assert_eq!(bits(got), bits(want), "case {case}");
        }
        assert!(free > 5_000 && bound_lines > 5_000, "{free} {bound_lines}");
    }
}
