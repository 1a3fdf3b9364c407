//! The social force model (Helbing, Farkas and Vicsek 2000, "Simulating dynamical features of
//! escape panic"; the anisotropy of Helbing and Molnar 1995 in the form of Helbing and Johansson):
//!
//! ```text
//! m dv/dt = m (v0 e - v) / tau + sum_j f_ij + sum_W f_iW
//! f_ij = (A w(phi) exp((r_ij - d_ij) / B) + k g(r_ij - d_ij)) n_ij
//!        + kappa g(r_ij - d_ij) ((v_j - v_i) . t_ij) t_ij
//! f_iW = (A_w exp((r_i - d_iW) / B_w) + k g(r_i - d_iW)) n_iW
//!        - kappa g(r_i - d_iW) (v_i . t_iW) t_iW
//! ```
//!
//! with `r_ij = r_i + r_j`, `d_ij` the distance of the centres, `n_ij` the unit vector from `j`
//! to `i`, `t_ij` its left normal, `g(x) = max(x, 0)` (the body force and sliding friction act
//! only on contact) and `w(phi) = lambda + (1 - lambda) (1 + cos phi) / 2` with `cos phi = -n_ij
//! . e_i` (others ahead weigh more than those behind when `lambda < 1`).
//!
//! The sliding friction is stiff: `kappa g / m * dt` exceeds 1 at an overlap of 3 mm with the
//! defaults and dt = 0.01 s, where an explicit step reverses the tangential velocity and the
//! crowd gains energy with every contact. Given the time step, [`SocialForce::pair`] and
//! [`SocialForce::wall`] therefore integrate the friction implicitly: the friction coefficient
//! is divided by `1 + n kappa g dt / m` (n = 2 for a pair, whose relative velocity both forces
//! change; 1 for a wall), so a step can at most stop the sliding, never reverse it. With
//! `dt = 0` they return the paper's forces.
//!
//! Invariants: the terms are finite for finite inputs; with `lambda = 1` the pair force on `j`
//! is exactly minus the force on `i`.

use glam::Vec2;
use serde::{Deserialize, Serialize};

use super::{away, check_cutoff, exp_capped};
use crate::error::{Result, in_range, non_negative, positive};

/// The social force model's parameters; defaults from Helbing, Farkas and Vicsek 2000 but for the
/// agents' repulsion (`a`, `b`, `lambda`), calibrated against the Juelich experiments.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SocialForce {
    /// The pedestrian's mass, kg (> 0); the forces below are in newtons. Default: 80.
    pub mass: f32,
    /// Relaxation time of the driving term, s (> 0). Default: 0.5.
    pub tau: f32,
    /// Strength of the repulsion between agents, N (>= 0). Default: 80 (the 2000 paper: 2000),
    /// from the calibration against the Juelich experiments (docs/VALIDATION.md).
    pub a: f32,
    /// Range of the repulsion between agents, m (> 0). Default: 0.4 (the 2000 paper: 0.08),
    /// from the same calibration.
    pub b: f32,
    /// Strength of the repulsion of walls, N (>= 0). Default: 2000.
    pub a_wall: f32,
    /// Range of the repulsion of walls, m (> 0). Default: 0.08.
    pub b_wall: f32,
    /// Body force constant, kg/s^2 (>= 0). Default: 1.2e5.
    pub k: f32,
    /// Sliding friction constant, kg/(m s) (>= 0). Default: 2.4e5.
    pub kappa: f32,
    /// Anisotropy: the weight of the repulsion of an agent straight behind, in [0, 1]
    /// (1: isotropic, as in the 2000 paper). Default: 0.1, from the same calibration.
    pub lambda: f32,
    /// Agents and walls farther than this from an agent's centre are ignored, m (> 0).
    /// Default: 2.
    pub cutoff: f32,
}

impl Default for SocialForce {
    fn default() -> Self {
        SocialForce {
            mass: 80.0,
            tau: 0.5,
            a: 80.0,
            b: 0.4,
            a_wall: 2000.0,
            b_wall: 0.08,
            k: 1.2e5,
            kappa: 2.4e5,
            lambda: 0.1,
            cutoff: 2.0,
        }
    }
}

impl SocialForce {
    /// Checks every parameter.
    ///
    /// # Errors
    /// The variant naming the first bad key (`pedestrian.social_force.tau`, ...).
    pub fn validate(&self) -> Result<()> {
        for (name, v) in [
            ("pedestrian.social_force.mass", self.mass),
            ("pedestrian.social_force.tau", self.tau),
            ("pedestrian.social_force.b", self.b),
            ("pedestrian.social_force.b_wall", self.b_wall),
        ] {
            positive(name, v)?;
            in_range(name, v, 0.0, 1e6, "(0, 1e6]")?;
        }
        for (name, v) in [
            ("pedestrian.social_force.a", self.a),
            ("pedestrian.social_force.a_wall", self.a_wall),
            ("pedestrian.social_force.k", self.k),
            ("pedestrian.social_force.kappa", self.kappa),
        ] {
            non_negative(name, v)?;
            in_range(name, v, 0.0, 1e9, "[0, 1e9]")?;
        }
        non_negative("pedestrian.social_force.lambda", self.lambda)?;
        in_range(
            "pedestrian.social_force.lambda",
            self.lambda,
            0.0,
            1.0,
            "[0, 1]",
        )?;
        check_cutoff("pedestrian.social_force.cutoff", self.cutoff)
    }

    /// The driving acceleration `(v0 e - v) / tau`, m/s^2.
    #[inline]
    #[must_use]
    pub fn driving(&self, v0: f32, e: Vec2, v: Vec2) -> Vec2 {
        (e * v0 - v) / self.tau
    }

    /// The force of agent `j` on agent `i`, N. `d = x_i - x_j`; `e` is `i`'s preferred direction
    /// (a unit vector, or zero when it has none); the ids choose the direction at zero distance;
    /// `dt > 0` integrates the friction implicitly over a step of that length (module docs).
    #[inline]
    #[must_use]
    #[allow(clippy::too_many_arguments)]
    pub fn pair(
        &self,
        d: Vec2,
        v_i: Vec2,
        v_j: Vec2,
        r_ij: f32,
        e: Vec2,
        ids: (u32, u32),
        dt: f32,
    ) -> Vec2 {
        let dist = d.length();
        let n = away(d, dist, ids.0, ids.1);
        let overlap = r_ij - dist;
        let cos_phi = -n.dot(e);
        let w = self.lambda + (1.0 - self.lambda) * 0.5 * (1.0 + cos_phi);
        let mut normal = self.a * w * exp_capped(overlap / self.b);
        let mut f = Vec2::ZERO;
        if overlap > 0.0 {
            normal += self.k * overlap;
            let t = n.perp();
            let c = self.kappa * overlap;
            let c = c / (1.0 + 2.0 * c * dt / self.mass);
            f += t * (c * (v_j - v_i).dot(t));
        }
        f + n * normal
    }

    /// The force of a wall whose closest point to agent `i` lies at `x_i - d`, N; `normal` is
    /// the direction used when the centre lies on the wall (`d` zero); `dt` as for
    /// [`SocialForce::pair`].
    #[inline]
    #[must_use]
    pub fn wall(&self, d: Vec2, v_i: Vec2, r_i: f32, normal: Vec2, dt: f32) -> Vec2 {
        let dist = d.length();
        let n = if dist > 1e-6 { d / dist } else { normal };
        let overlap = r_i - dist;
        let mut push = self.a_wall * exp_capped(overlap / self.b_wall);
        let mut f = Vec2::ZERO;
        if overlap > 0.0 {
            push += self.k * overlap;
            let t = n.perp();
            let c = self.kappa * overlap;
            let c = c / (1.0 + c * dt / self.mass);
            f -= t * (c * v_i.dot(t));
        }
        f + n * push
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Vec2, b: Vec2, tol: f32) -> bool {
        (a - b).length() <= tol * (1.0 + b.length())
    }

    #[test]
    fn driving_term_by_hand() {
        let p = SocialForce::default();
        // (1.34 * (1, 0) - (0.5, 0.2)) / 0.5 = (1.68, -0.4)
        let a = p.driving(1.34, Vec2::X, Vec2::new(0.5, 0.2));
        assert!(close(a, Vec2::new(1.68, -0.4), 1e-6), "{a}");
    }

    #[test]
    fn pair_force_by_hand_apart_and_in_contact() {
        // The 2000 paper's parameters (isotropic, A = 2000 N, B = 0.08 m).
        let p = SocialForce {
            a: 2000.0,
            b: 0.08,
            lambda: 1.0,
            ..SocialForce::default()
        };
        // Apart: d = 1 m, r_ij = 0.6 m: 2000 exp(-0.4 / 0.08) = 2000 e^-5 = 13.4759 N along +x.
        let f = p.pair(
            Vec2::X,
            Vec2::ZERO,
            Vec2::ZERO,
            0.6,
            Vec2::ZERO,
            (0, 1),
            0.0,
        );
        assert!(close(f, Vec2::new(13.475_894, 0.0), 1e-5), "{f}");
        // Overlap 0.1 m, j sliding past at 1 m/s along +y (t = n.perp() = +y):
        // normal 2000 e^1.25 + 1.2e5 * 0.1 = 6980.69 + 12000; friction 2.4e5 * 0.1 * 1 = 24000.
        let f = p.pair(
            Vec2::new(0.5, 0.0),
            Vec2::ZERO,
            Vec2::Y,
            0.6,
            Vec2::ZERO,
            (0, 1),
            0.0,
        );
        assert!(close(f, Vec2::new(18_980.686, 24_000.0), 1e-5), "{f}");
    }

    #[test]
    fn anisotropy_weighs_agents_ahead_more() {
        let p = SocialForce {
            lambda: 0.2,
            ..SocialForce::default()
        };
        // j ahead of i (i walks +x, j at +x: d = x_i - x_j = -x): cos phi = 1, w = 1.
        let ahead = p.pair(-Vec2::X, Vec2::ZERO, Vec2::ZERO, 0.6, Vec2::X, (0, 1), 0.0);
        // j behind: cos phi = -1, w = lambda.
        let behind = p.pair(Vec2::X, Vec2::ZERO, Vec2::ZERO, 0.6, Vec2::X, (0, 1), 0.0);
        assert!((ahead.length() * 0.2 - behind.length()).abs() < 1e-4);
    }

    #[test]
    fn pair_forces_are_equal_and_opposite() {
        // Isotropic (with anisotropy each agent weighs the other by its own direction).
        let p = SocialForce {
            lambda: 1.0,
            ..SocialForce::default()
        };
        let (xi, xj) = (Vec2::new(0.1, 0.2), Vec2::new(0.35, -0.1));
        let (vi, vj) = (Vec2::new(1.0, 0.3), Vec2::new(-0.4, 0.9));
        for r in [0.1, 0.4, 0.8] {
            let fi = p.pair(xi - xj, vi, vj, r, Vec2::X, (0, 1), 0.0);
            let fj = p.pair(xj - xi, vj, vi, r, -Vec2::Y, (1, 0), 0.0);
            assert!(close(fi, -fj, 1e-6), "{fi} {fj}");
        }
        // Zero distance: finite, opposite.
        let fi = p.pair(Vec2::ZERO, vi, vj, 0.4, Vec2::X, (3, 9), 0.0);
        let fj = p.pair(Vec2::ZERO, vj, vi, 0.4, Vec2::X, (9, 3), 0.0);
        assert!(fi.is_finite() && close(fi, -fj, 1e-6));
    }

    #[test]
    fn wall_force_by_hand_and_at_zero_distance() {
        let p = SocialForce::default();
        // 0.5 m from the wall, radius 0.3: 2000 e^(-0.2 / 0.08) = 164.17 N.
        let f = p.wall(Vec2::new(0.0, 0.5), Vec2::X, 0.3, Vec2::Y, 0.0);
        assert!(close(f, Vec2::new(0.0, 164.169_99), 1e-5), "{f}");
        // In contact 0.1 m deep, moving along the wall at 1 m/s (t = (-1, 0)): friction
        // -kappa * 0.1 * (v . t) t = -24000 * (-1) * (-1, 0) = (-24000, 0).
        let f = p.wall(Vec2::new(0.0, 0.2), Vec2::X, 0.3, Vec2::Y, 0.0);
        let normal = 2000.0 * (0.1f32 / 0.08).exp() + 1.2e5 * 0.1;
        assert!(close(f, Vec2::new(-24_000.0, normal), 1e-5), "{f}");
        let f = p.wall(Vec2::ZERO, Vec2::X, 0.3, Vec2::Y, 0.0);
        assert!(f.is_finite() && f.y > 0.0);
        // The implicit friction of a step can stop the sliding but not reverse it: at 0.1 m
        // overlap the explicit coefficient 24000 kg/s is 3 m/s per step at 80 kg and 0.01 s.
        let v = Vec2::new(1.0, 0.0);
        let f = p.wall(Vec2::new(0.0, 0.2), v, 0.3, Vec2::Y, 0.01);
        let after = v + f / p.mass * 0.01;
        assert!(after.x >= 0.0 && after.x < 1.0, "{after}");
        // Absurd overlap: still finite.
        assert!(p.wall(Vec2::ZERO, Vec2::X, 1e6, Vec2::Y, 0.01).is_finite());
    }
}
