//! The collision-free speed model (Tordeux, Chraibi and Seyfried 2016, "Collision-free speed
//! model for pedestrian dynamics"), the default model of JuPedSim, with JuPedSim's parameter
//! names and defaults:
//!
//! ```text
//! e_i = normalise(e0_i + sum_j a exp((l_ij - d_ij) / D) n_ij + sum_W a_w exp((r_i - d_iW) / D_w) n_iW)
//! v_i = min(v0_i, max(0, s_i / T)) e_i
//! ```
//!
//! with `l_ij = r_i + r_j`, `n_ij` the unit vector from `j` to `i`, and `s_i` the smallest
//! spacing `d_ij - l_ij` to an agent `j` ahead of `i` (`e_i . (x_j - x_i) >= 0`) within the strip
//! of half-width `l_ij` along `e_i`. A first-order model: the result is a velocity.
//!
//! Invariants: the direction is a unit vector or zero; the speed lies in `[0, v0]`.

use glam::Vec2;
use serde::{Deserialize, Serialize};

use super::{away, check_cutoff, exp_capped};
use crate::error::{Result, in_range, non_negative, positive};

/// The collision-free speed model's parameters; defaults as in JuPedSim 1.4.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Cfsm {
    /// The time gap `T`, s (> 0): an agent walks at most its spacing ahead divided by this.
    /// Default: 1.
    pub time_gap: f32,
    /// Strength `a` of the repulsion between agents (>= 0). Default: 8.
    pub strength_neighbour: f32,
    /// Range `D` of the repulsion between agents, m (> 0). Default: 0.1.
    pub range_neighbour: f32,
    /// Strength of the repulsion of walls (>= 0). Default: 5.
    pub strength_wall: f32,
    /// Range of the repulsion of walls, m (> 0). Default: 0.02.
    pub range_wall: f32,
    /// Agents and walls farther than this from an agent's centre are ignored, m (> 0).
    /// Default: 2.
    pub cutoff: f32,
}

impl Default for Cfsm {
    fn default() -> Self {
        Cfsm {
            time_gap: 1.0,
            strength_neighbour: 8.0,
            range_neighbour: 0.1,
            strength_wall: 5.0,
            range_wall: 0.02,
            cutoff: 2.0,
        }
    }
}

impl Cfsm {
    /// Checks every parameter.
    ///
    /// # Errors
    /// The variant naming the first bad key (`pedestrian.cfsm.time_gap`, ...).
    pub fn validate(&self) -> Result<()> {
        for (name, v) in [
            ("pedestrian.cfsm.time_gap", self.time_gap),
            ("pedestrian.cfsm.range_neighbour", self.range_neighbour),
            ("pedestrian.cfsm.range_wall", self.range_wall),
        ] {
            positive(name, v)?;
            in_range(name, v, 0.0, 1e6, "(0, 1e6]")?;
        }
        for (name, v) in [
            (
                "pedestrian.cfsm.strength_neighbour",
                self.strength_neighbour,
            ),
            ("pedestrian.cfsm.strength_wall", self.strength_wall),
        ] {
            non_negative(name, v)?;
            in_range(name, v, 0.0, 1e9, "[0, 1e9]")?;
        }
        check_cutoff("pedestrian.cfsm.cutoff", self.cutoff)
    }

    /// The repulsion of agent `j` on agent `i`'s direction; `d = x_i - x_j`.
    #[inline]
    #[must_use]
    pub fn repulsion(&self, d: Vec2, l_ij: f32, ids: (u32, u32)) -> Vec2 {
        let dist = d.length();
        away(d, dist, ids.0, ids.1)
            * (self.strength_neighbour * exp_capped((l_ij - dist) / self.range_neighbour))
    }

    /// The repulsion of a wall whose closest point lies at `x_i - d`; `normal` is used when the
    /// centre lies on the wall.
    #[inline]
    #[must_use]
    pub fn wall(&self, d: Vec2, r_i: f32, normal: Vec2) -> Vec2 {
        let dist = d.length();
        let n = if dist > 1e-6 { d / dist } else { normal };
        n * (self.strength_wall * exp_capped((r_i - dist) / self.range_wall))
    }

    /// The spacing to agent `j` at `x_j = x_i + rel` along the unit direction `e`: `d_ij -
    /// l_ij` when `j` lies ahead within the strip of half-width `l_ij`, else `None`. An agent
    /// at the very same point is not ahead (the repulsion sends the two opposite ways, and
    /// neither would move if each counted the other).
    #[inline]
    #[must_use]
    pub fn spacing(rel: Vec2, e: Vec2, l_ij: f32) -> Option<f32> {
        if rel == Vec2::ZERO || e.dot(rel) < 0.0 || e.perp().dot(rel).abs() > l_ij {
            return None;
        }
        Some(rel.length() - l_ij)
    }

    /// The speed for the smallest spacing `s` ahead and the desired speed `v0`.
    #[inline]
    #[must_use]
    pub fn speed(&self, s: f32, v0: f32) -> f32 {
        (s / self.time_gap).clamp(0.0, v0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn terms_by_hand() {
        let m = Cfsm::default();
        // d = 0.5 m, l = 0.4 m: 8 e^(-0.1 / 0.1) = 2.943 along +x.
        let r = m.repulsion(Vec2::new(0.5, 0.0), 0.4, (0, 1));
        assert!((r - Vec2::new(8.0 * (-1.0f32).exp(), 0.0)).length() < 1e-5);
        // Equal and opposite.
        let rj = m.repulsion(Vec2::new(-0.5, 0.0), 0.4, (1, 0));
        assert_eq!(r, -rj);
        // Wall 0.25 m away, radius 0.2: 5 e^(-0.05 / 0.02) = 0.4104.
        let w = m.wall(Vec2::new(0.0, 0.25), 0.2, Vec2::Y);
        assert!((w.y - 5.0 * (-2.5f32).exp()).abs() < 1e-5 && w.x == 0.0);
        assert!(m.wall(Vec2::ZERO, 0.2, Vec2::Y).is_finite());
        assert!(m.repulsion(Vec2::ZERO, 0.4, (0, 1)).is_finite());
    }

    #[test]
    fn spacing_counts_agents_ahead_in_the_strip_only() {
        let e = Vec2::X;
        assert_eq!(Cfsm::spacing(Vec2::new(1.0, 0.0), e, 0.4), Some(0.6));
        assert_eq!(
            Cfsm::spacing(Vec2::new(1.0, 0.3), e, 0.4).map(|s| (s * 1e4).round()),
            Some(((1.09f32.sqrt() - 0.4) * 1e4).round())
        );
        assert_eq!(Cfsm::spacing(Vec2::new(-1.0, 0.0), e, 0.4), None);
        assert_eq!(Cfsm::spacing(Vec2::new(1.0, 0.5), e, 0.4), None);
        assert_eq!(Cfsm::spacing(Vec2::ZERO, e, 0.4), None);
    }

    #[test]
    fn speed_is_spacing_over_time_gap_within_zero_and_v0() {
        let m = Cfsm::default();
        assert_eq!(m.speed(0.6, 1.34), 0.6);
        assert_eq!(m.speed(5.0, 1.34), 1.34);
        assert_eq!(m.speed(-0.1, 1.34), 0.0);
    }
}
