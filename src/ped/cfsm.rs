//! The collision-free speed model (Tordeux, Chraibi and Seyfried 2016, "Collision-free speed
//! model for pedestrian dynamics"), the default model of JuPedSim, with JuPedSim's parameter
//! names:
//!
//! ```text
//! e_i = normalise(e0_i + sum_j a exp((l_ij - d_ij) / D) n_ij + sum_W a_w exp((r_i - d_iW) / D_w) n_iW)
//! v_i = V(s_i) e_i
//! ```
//!
//! with `l_ij = r_i + r_j`, `n_ij` the unit vector from `j` to `i`, and `s_i` the smallest
//! spacing to an agent `j` ahead of `i` (`e_i . (x_j - x_i) >= 0`) within the strip of
//! half-width `l_ij` along `e_i`. A first-order model: the result is a velocity.
//!
//! The paper and JuPedSim measure the spacing as `d_ij - l_ij` and take
//! `V(s) = min(v0, max(0, s / T))` with `T = 1 s`, without the pressure terms, the reference
//! speed and the path width below: `{ spacing = "centre", speed_function = "linear", time_gap
//! = 1, pressed_time_gap = 1, pressed_anisotropy = 1, reference_speed = 0, path_width = 1 }`
//! reproduces them. throng's defaults are calibrated against the Juelich experiments (the
//! `exp-*` cases of docs/VALIDATION.md): the spacing is the distance to contact along `e_i`
//! ([`Spacing::Contact`]), `V(s) = v0 tanh(s / (v0 T))` ([`SpeedFunction::Smooth`]), `T = 1 s`
//! (the single-file runs' time gap) at the single-file runs' free speed 1.13 m/s and scaled
//! by `1.13 / v0` for others ([`Cfsm::reference_speed`]), a path 0.8 times the two radii wide
//! ([`Cfsm::path_width`]) and the pressure from behind below. With the paper's strip a crowd
//! in two dimensions walks 15 to 25% below the experiments at `T = 1` while single file fits;
//! the narrower path brings the corridors, the counterflow and Weidmann's curve (RiMEA 4) to
//! them without moving single file.
//!
//! Pressure from behind: a pedestrian with more of the crowd behind than ahead (at the front of
//! a queue, in the mouth of a bottleneck) accepts a shorter time gap. Of the `n` agents within
//! the cut-off, `n_b` behind (`e_i . (x_j - x_i) < 0`), the imbalance `(2 n_b - n) / max(n, 4)`
//! gives the pressure `q = clamp((imbalance - onset) / span, 0, 1)`, and the time gap is
//! `T + (T_p - T) q`. In a crowd of even density the imbalance stays near zero and the time gap
//! at `T`, so the fundamental diagram keeps its calibration; at a bottleneck's mouth it brings
//! the specific flow into the experiments' band (docs/VALIDATION.md). `pressed_time_gap =
//! time_gap` turns it off.
//!
//! Anisotropy (not in the paper): the repulsion of `j` is weighted by `lambda + (1 - lambda) (1
//! + cos phi) / 2`, `phi` the angle between `e0_i` and `x_j - x_i`, as the social force model
//! weights its own. `lambda` follows the pressure from behind: `lambda = L + (L_p - L) q0`
//! ([`Cfsm::anisotropy`] `L`, 1 by default, the paper's isotropic repulsion;
//! [`Cfsm::pressed_anisotropy`] `L_p`, 0 by default), where `q0` is the pressure above counted
//! about the preferred direction `e0_i` (the direction is what the repulsion decides, so it
//! cannot be counted about that). In a crowd of even density `q0` stays near zero and the
//! model is the paper's, so the fundamental diagrams keep their calibration; a pedestrian with
//! the crowd pressing from behind (in the mouth of a door) is steered by those ahead and beside
//! it only. With isotropic repulsion at a door two or three bodies wide, four pedestrians (two
//! against the jambs, two in front of the door) steer one another into each other's way and
//! stand at contact for good, an arch: RiMEA 9 and 11 and the bottleneck at 0.8 m locked so at
//! every seed measured. A constant `lambda < 1` opens some arches and closes others, and in
//! single file lets the one ahead push a pedestrian backwards; under pressure only, none of
//! the validation rooms locks at the seeds measured (docs/VALIDATION.md, "The narrow door").
//! `pressed_anisotropy = anisotropy` turns it off.
//!
//! Reference speed (not in the paper; 1.13 m/s by default, 0 turns it off): with
//! [`Cfsm::reference_speed`] `v_r > 0`
//! a pedestrian with the desired speed `v0` takes the time gaps times `v_r / v0`, so that `v /
//! v0` is the same function of the spacing for every pedestrian, as Weidmann's fundamental
//! diagram has `v / v0` one function of the density; pedestrians then keep a distance rather
//! than a time.
//!
//! Path width (not in the paper; 0.8 by default): with [`Cfsm::path_width`] `w < 1` only a
//! neighbour within `w l_ij` of the line along `e_i` counts for the spacing, taken as the walk
//! to contact of a body `w` times as wide (continuous to the distance ahead at the path's
//! edge), so that a neighbour grazing the path (its body within `l_ij` but not within `w
//! l_ij`) is passed and its contact left to the repulsion, as people turn a shoulder to pass;
//! a line in single file is not changed. At 1 the strip is the paper's.
//!
//! Sidestepping (not in the paper, off by default): a pedestrian blocked at contact ahead turns its direction by
//! 45, then 90 degrees to either side and takes the first turn with room ahead, so that an arch
//! of pedestrians at a narrow door, each in the way of another, breaks up as real ones do. It
//! moves only where the model would let it move in that direction, so the freedom from
//! collisions stands.
//!
//! Invariants: the direction is a unit vector or zero; the speed lies in `[0, v0]`; the time gap
//! lies in `[pressed_time_gap, time_gap]` (times `reference_speed / v0` when that is on).

use glam::Vec2;
use serde::{Deserialize, Serialize};

use super::approx::tanh_poly;
use super::{away, check_cutoff, exp_capped};
use crate::error::{Result, in_range, non_negative, positive};

/// The collision-free speed model's parameters: JuPedSim 1.4's repulsions and cut-off, the
/// spacing, speed function and time gaps calibrated against the Juelich experiments.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Cfsm {
    /// The time gap `T`, s (> 0): the slope of the speed function at zero spacing is `1 / T`.
    /// Default: 1 (as JuPedSim), at [`Cfsm::reference_speed`].
    pub time_gap: f32,
    /// The time gap `T_p` under full pressure from behind, s (in `(0, time_gap]`; equal to
    /// `time_gap` for no pressure term, as in JuPedSim). Keep `dt <= pressed_time_gap` for the
    /// model's freedom from collisions (with those ahead within [`Cfsm::path_width`]). Default: 0.4.
    pub pressed_time_gap: f32,
    /// The imbalance of neighbours behind over ahead at which the pressure starts (in `[0,
    /// 1)`). Default: 0.15.
    pub pressure_onset: f32,
    /// The rise of the imbalance above the onset over which the pressure grows from 0 to 1
    /// (in `(0, 2]`). Default: 0.15.
    pub pressure_span: f32,
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
    /// How the spacing to an agent ahead is measured. Default: [`Spacing::Contact`]
    /// (JuPedSim: [`Spacing::Centre`]).
    pub spacing: Spacing,
    /// How the speed follows from the spacing. Default: [`SpeedFunction::Smooth`] (JuPedSim:
    /// [`SpeedFunction::Linear`]).
    pub speed_function: SpeedFunction,
    /// Whether a blocked pedestrian (one whose spacing ahead is at most
    /// [`BLOCKED_SPACING`]) steps sideways: it takes, of its direction turned by 45 and then
    /// by 90 degrees to either side (the side of its preferred direction first), the first
    /// turn that leaves it room ahead and does not lead into a wall within
    /// [`SIDESTEP_WALL_MARGIN`] of its body, at the speed the model gives for that room.
    /// Without it, pedestrians at a narrow door can stand in each other's way at contact until
    /// the crowd behind them thins (an arch: the model is first order and deterministic); with
    /// it, such arches break up within seconds, but at doors of two bodies' width the last
    /// two pedestrians can end up held for good on either side of the entrance by their
    /// mutual repulsion (docs/VALIDATION.md measures both). Default: false (as JuPedSim).
    pub sidestep: bool,
    /// The weight `lambda` of the repulsion of a neighbour straight behind (in `[0, 1]`): a
    /// neighbour at the angle `phi` from the preferred direction repels with the weight
    /// `lambda + (1 - lambda) (1 + cos phi) / 2` (the social force model's anisotropy).
    /// Default: 1, the paper's and JuPedSim's isotropic repulsion (the weight is then exactly 1).
    pub anisotropy: f32,
    /// The weight `lambda` of a neighbour straight behind under full pressure from behind (in
    /// `[0, 1]`): the weight is taken between [`Cfsm::anisotropy`] (no pressure) and this by
    /// the pressure counted about the preferred direction ([`Cfsm::anisotropy_at`]). Equal to
    /// `anisotropy` for no such term, as in JuPedSim. Default: 0.
    pub pressed_anisotropy: f32,
    /// The desired speed, m/s, at which the time gaps are [`Cfsm::time_gap`] and
    /// [`Cfsm::pressed_time_gap`] (>= 0; 0 for every pedestrian's time gaps as given). A
    /// pedestrian with the desired speed `v0` takes them times `reference_speed / v0`, so
    /// that its speed relative to its desired speed is one function of the spacing for all:
    /// pedestrians keep a distance rather than a time (Weidmann's `v / v0` as one function
    /// of the density). Default: 1.13, the free speed of the Juelich single-file runs, from
    /// which the default time gap is taken (JuPedSim: 0).
    pub reference_speed: f32,
    /// The half-width of the path a pedestrian keeps clear ahead, as a fraction `w` of `l_ij`
    /// (in `[0.5, 1]`): only a neighbour within `w l_ij` of the line along `e_i` counts for
    /// the spacing. Under [`Spacing::Contact`] the spacing is the walk to contact of a body
    /// `w` times as wide, `x - sqrt(l_ij^2 - (y / w)^2)`, which runs continuously to the
    /// distance ahead `x` at the path's edge; under [`Spacing::Centre`] it is `d_ij - l_ij`
    /// as before. At 1 (the paper's strip) a neighbour whose body grazes the path stops a
    /// pedestrian as one straight ahead does; below 1 a pedestrian walks past a graze, and
    /// the repulsion alone keeps the two bodies apart, as people turn a shoulder or sway to
    /// pass: the model is then free of collisions with those straight ahead, not with those
    /// it grazes. A line of people in single file is not changed. Default: 0.8 (JuPedSim:
    /// 1; below about 0.75 the grazes the repulsion resolves make the results depend on the
    /// time step, docs/VALIDATION.md).
    pub path_width: f32,
}

impl Cfsm {
    /// The keys a speed model's table written by an older build lacks, each with the value its
    /// worlds stepped with, which is not always today's default: `pressed_anisotropy` equal to
    /// the anisotropy (no such term), `reference_speed` 0 (the time gaps as given) and
    /// `path_width` 1 (the paper's strip). `has` tells whether the table names a key and
    /// `anisotropy` is its anisotropy, if named. Empty for a table that is not the speed
    /// model's (one without `time_gap` and `pressure_onset`, which every version had) and for
    /// one written today, which names every key.
    #[must_use]
    pub fn absent_keys(
        has: impl Fn(&str) -> bool,
        anisotropy: Option<f32>,
    ) -> Vec<(&'static str, f32)> {
        if !(has("time_gap") && has("pressure_onset")) {
            return Vec::new();
        }
        let added = [
            ("pressed_anisotropy", anisotropy.unwrap_or(1.0)),
            ("reference_speed", 0.0),
            ("path_width", 1.0),
        ];
        added.into_iter().filter(|(k, _)| !has(k)).collect()
    }

    /// The speed model's TOML `table` (a saved `params=` table of the Python `Simulation`)
    /// with the keys an older build did not write filled in ([`Cfsm::absent_keys`]).
    pub fn fill_absent_keys(table: &mut toml::Table) {
        let anisotropy = match table.get("anisotropy") {
            Some(toml::Value::Float(v)) => Some(*v as f32),
            Some(toml::Value::Integer(v)) => Some(*v as f32),
            _ => None,
        };
        for (key, x) in Cfsm::absent_keys(|k| table.contains_key(k), anisotropy) {
            table.insert(key.into(), toml::Value::Float(f64::from(x)));
        }
    }
}

/// [`Cfsm::weight`] for the anisotropy `lambda`.
#[inline]
fn weight_under(n: Vec2, e0: Vec2, lambda: f32) -> f32 {
    lambda + (1.0 - lambda) * (0.5 - 0.5 * (e0.x * n.x + e0.y * n.y))
}

/// The spacing, m, at or below which a pedestrian counts as blocked ([`Cfsm::sidestep`]).
pub const BLOCKED_SPACING: f32 = 0.01;

/// How close, m, to a wall or circle a pedestrian's body may be before it does not step
/// sideways towards it ([`Cfsm::sidestep`]).
pub const SIDESTEP_WALL_MARGIN: f32 = 0.05;

/// The optimal-velocity function `V(s)`: the speed for the spacing `s` ahead.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SpeedFunction {
    /// `min(v0, max(0, s / T))` (the paper's and JuPedSim's).
    Linear,
    /// `v0 tanh(max(0, s) / (v0 T))`: the same slope `1 / T` at `s = 0`, approaching `v0`
    /// smoothly, so that pedestrians slow down before the spacing reaches `v0 T`, as
    /// Weidmann's fundamental diagram has them do at 0.5 to 1.5 persons/m^2.
    #[default]
    Smooth,
}

/// How the spacing `s_i` to an agent `j` ahead in the strip is measured.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Spacing {
    /// `d_ij - l_ij`, the gap between the two discs whatever their lateral offset (the
    /// paper's and JuPedSim's).
    Centre,
    /// The distance `i` can walk along `e_i` before its disc touches `j`'s:
    /// `x - sqrt(l_ij^2 - y^2)` for `j` at `x` ahead and `y` to the side. Equal to `Centre`
    /// straight ahead; larger for agents ahead to the side, so that staggered lanes can zip.
    #[default]
    Contact,
}

/// The smallest neighbour count the imbalance is divided by, so that one agent behind and none
/// ahead is not full pressure.
pub const PRESSURE_MIN_COUNT: f32 = 4.0;

impl Default for Cfsm {
    fn default() -> Self {
        Cfsm {
            time_gap: 1.0,
            pressed_time_gap: 0.4,
            pressure_onset: 0.15,
            pressure_span: 0.15,
            strength_neighbour: 8.0,
            range_neighbour: 0.1,
            strength_wall: 5.0,
            range_wall: 0.02,
            cutoff: 2.0,
            spacing: Spacing::Contact,
            speed_function: SpeedFunction::Smooth,
            sidestep: false,
            anisotropy: 1.0,
            pressed_anisotropy: 0.0,
            reference_speed: 1.13,
            path_width: 0.8,
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
        positive("pedestrian.cfsm.pressed_time_gap", self.pressed_time_gap)?;
        in_range(
            "pedestrian.cfsm.pressed_time_gap",
            self.pressed_time_gap,
            0.0,
            self.time_gap,
            "(0, time_gap]",
        )?;
        in_range(
            "pedestrian.cfsm.pressure_onset",
            self.pressure_onset,
            0.0,
            0.999_999,
            "[0, 1)",
        )?;
        positive("pedestrian.cfsm.pressure_span", self.pressure_span)?;
        in_range(
            "pedestrian.cfsm.pressure_span",
            self.pressure_span,
            0.0,
            2.0,
            "(0, 2]",
        )?;
        in_range(
            "pedestrian.cfsm.anisotropy",
            self.anisotropy,
            0.0,
            1.0,
            "[0, 1]",
        )?;
        in_range(
            "pedestrian.cfsm.pressed_anisotropy",
            self.pressed_anisotropy,
            0.0,
            1.0,
            "[0, 1]",
        )?;
        non_negative("pedestrian.cfsm.reference_speed", self.reference_speed)?;
        in_range(
            "pedestrian.cfsm.reference_speed",
            self.reference_speed,
            0.0,
            1e3,
            "[0, 1e3]",
        )?;
        in_range(
            "pedestrian.cfsm.path_width",
            self.path_width,
            0.5,
            1.0,
            "[0.5, 1]",
        )?;
        check_cutoff("pedestrian.cfsm.cutoff", self.cutoff)
    }

    /// The pressure `q` in `[0, 1]` on an agent with `behind` of its `total` neighbours within
    /// the cut-off behind it (see the module docs).
    #[inline]
    #[must_use]
    pub fn pressure(&self, behind: f32, total: f32) -> f32 {
        let imbalance = (2.0 * behind - total) / total.max(PRESSURE_MIN_COUNT);
        ((imbalance - self.pressure_onset) / self.pressure_span).clamp(0.0, 1.0)
    }

    /// The time gap under the pressure `q`: `T + (T_p - T) q`.
    #[inline]
    #[must_use]
    pub fn time_gap_at(&self, q: f32) -> f32 {
        self.time_gap + (self.pressed_time_gap - self.time_gap) * q
    }

    /// The anisotropy `lambda` under the pressure `q0` counted about the preferred direction:
    /// `anisotropy + (pressed_anisotropy - anisotropy) q0`, exactly `anisotropy` when the two
    /// are equal.
    #[inline]
    #[must_use]
    pub fn anisotropy_at(&self, q0: f32) -> f32 {
        if self.pressed_anisotropy == self.anisotropy {
            return self.anisotropy;
        }
        self.anisotropy + (self.pressed_anisotropy - self.anisotropy) * q0
    }

    /// Whether the anisotropy follows the pressure ([`Cfsm::pressed_anisotropy`] differs from
    /// [`Cfsm::anisotropy`]), so that the neighbours behind the preferred direction must be
    /// counted before the repulsion.
    #[inline]
    #[must_use]
    pub fn pressed_anisotropy_on(&self) -> bool {
        self.pressed_anisotropy != self.anisotropy
    }

    /// Whether a neighbour at `x_j = x_i + rel` lies behind an agent walking along `e` (counts
    /// towards the pressure).
    #[inline]
    #[must_use]
    pub fn is_behind(rel: Vec2, e: Vec2) -> bool {
        e.dot(rel) < 0.0
    }

    /// The repulsion of agent `j` on the direction of agent `i`, whose preferred direction is
    /// `e0`; `d = x_i - x_j`. Weighted by [`Cfsm::anisotropy`] (no pressure; see
    /// [`Cfsm::repulsion_under`]).
    #[inline]
    #[must_use]
    pub fn repulsion(&self, d: Vec2, l_ij: f32, ids: (u32, u32), e0: Vec2) -> Vec2 {
        self.repulsion_under(d, l_ij, ids, e0, self.anisotropy)
    }

    /// [`Cfsm::repulsion`] weighted by the anisotropy `lambda` ([`Cfsm::anisotropy_at`]).
    #[inline]
    #[must_use]
    pub fn repulsion_under(
        &self,
        d: Vec2,
        l_ij: f32,
        ids: (u32, u32),
        e0: Vec2,
        lambda: f32,
    ) -> Vec2 {
        let dist = d.length();
        let n = away(d, dist, ids.0, ids.1);
        n * (self.strength_neighbour * exp_capped((l_ij - dist) / self.range_neighbour))
            * weight_under(n, e0, lambda)
    }

    /// The anisotropy's weight of a neighbour in the direction `-n` (`n` the unit vector from
    /// it to the agent) for the preferred direction `e0`: `lambda + (1 - lambda) (1 + cos
    /// phi) / 2` with `lambda` = [`Cfsm::anisotropy`], 1 straight ahead, `lambda` straight
    /// behind, `(1 + lambda) / 2` to the side and for `e0 = 0`.
    #[inline]
    #[must_use]
    pub fn weight(&self, n: Vec2, e0: Vec2) -> f32 {
        weight_under(n, e0, self.anisotropy)
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

    /// The spacing to agent `j` at `x_j = x_i + rel` along `e` under this model's
    /// [`Spacing`] rule, `None` when `j` is not ahead within the path of half-width
    /// `path_width * l_ij` ([`Cfsm::path_width`]; at 1 as [`Cfsm::spacing`]).
    #[inline]
    #[must_use]
    pub fn spacing_to(&self, rel: Vec2, e: Vec2, l_ij: f32) -> Option<f32> {
        let side = e.perp().dot(rel).abs();
        if rel == Vec2::ZERO || e.dot(rel) < 0.0 || side > l_ij * self.path_width {
            return None;
        }
        Some(match self.spacing {
            Spacing::Centre => rel.length() - l_ij,
            Spacing::Contact => {
                let wide = side * (1.0 / self.path_width);
                e.dot(rel) - (l_ij * l_ij - wide * wide).max(0.0).sqrt()
            }
        })
    }

    /// The speed for the smallest spacing `s` ahead and the desired speed `v0`, without
    /// pressure (time gap `T`).
    #[inline]
    #[must_use]
    pub fn speed(&self, s: f32, v0: f32) -> f32 {
        self.speed_with_gap(s, v0, self.time_gap)
    }

    /// The speed for the spacing `s`, the desired speed `v0` and the pressure `q`
    /// ([`Cfsm::pressure`]).
    #[inline]
    #[must_use]
    pub fn speed_under(&self, s: f32, v0: f32, q: f32) -> f32 {
        self.speed_with_gap(s, v0, self.time_gap_at(q))
    }

    #[inline]
    fn speed_with_gap(&self, s: f32, v0: f32, time_gap: f32) -> f32 {
        let time_gap = if self.reference_speed > 0.0 && v0 > 0.0 {
            time_gap * (self.reference_speed / v0)
        } else {
            time_gap
        };
        match self.speed_function {
            SpeedFunction::Linear => (s / time_gap).clamp(0.0, v0),
            SpeedFunction::Smooth if v0 > 0.0 => v0 * tanh_poly(s.max(0.0) / (v0 * time_gap)),
            SpeedFunction::Smooth => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn terms_by_hand() {
        let m = Cfsm {
            anisotropy: 0.8,
            ..Cfsm::default()
        };
        // d = 0.5 m, l = 0.4 m, j straight ahead: 8 e^(-0.1 / 0.1) = 2.943 along +x.
        let r = m.repulsion(Vec2::new(0.5, 0.0), 0.4, (0, 1), -Vec2::X);
        assert!((r - Vec2::new(8.0 * (-1.0f32).exp(), 0.0)).length() < 1e-5);
        // Equal and opposite when each walks towards the other.
        let rj = m.repulsion(Vec2::new(-0.5, 0.0), 0.4, (1, 0), Vec2::X);
        assert_eq!(r, -rj);
        // The anisotropy: 0.8 of it from straight behind, 0.9 from the side.
        let behind = m.repulsion(Vec2::new(0.5, 0.0), 0.4, (0, 1), Vec2::X);
        assert!((behind - r * 0.8).length() < 1e-5);
        let side = m.repulsion(Vec2::new(0.5, 0.0), 0.4, (0, 1), Vec2::Y);
        assert!((side - r * 0.9).length() < 1e-5);
        let isotropic = Cfsm {
            anisotropy: 1.0,
            ..m
        };
        assert_eq!(
            isotropic.repulsion(Vec2::new(0.5, 0.0), 0.4, (0, 1), Vec2::X),
            r
        );
        // Wall 0.25 m away, radius 0.2: 5 e^(-0.05 / 0.02) = 0.4104.
        let w = m.wall(Vec2::new(0.0, 0.25), 0.2, Vec2::Y);
        assert!((w.y - 5.0 * (-2.5f32).exp()).abs() < 1e-5 && w.x == 0.0);
        assert!(m.wall(Vec2::ZERO, 0.2, Vec2::Y).is_finite());
        assert!(m.repulsion(Vec2::ZERO, 0.4, (0, 1), Vec2::X).is_finite());
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

    /// JuPedSim's parametrisation.
    fn jupedsim() -> Cfsm {
        Cfsm {
            anisotropy: 1.0,
            pressed_anisotropy: 1.0,
            reference_speed: 0.0,
            time_gap: 1.0,
            pressed_time_gap: 1.0,
            spacing: Spacing::Centre,
            speed_function: SpeedFunction::Linear,
            path_width: 1.0,
            ..Cfsm::default()
        }
    }

    /// The defaults with the time gaps 0.6 and 0.4 s for every desired speed (no reference
    /// speed), as the hand computations below take them.
    fn plain_gaps() -> Cfsm {
        Cfsm {
            time_gap: 0.6,
            reference_speed: 0.0,
            ..Cfsm::default()
        }
    }

    #[test]
    fn speed_is_spacing_over_time_gap_within_zero_and_v0() {
        let m = jupedsim();
        assert_eq!(m.speed(0.6, 1.34), 0.6);
        assert_eq!(m.speed(5.0, 1.34), 1.34);
        assert_eq!(m.speed(-0.1, 1.34), 0.0);
    }

    #[test]
    fn smooth_speed_by_hand() {
        let m = plain_gaps();
        // v0 tanh(s / (v0 T)): 1.34 tanh(0.6 / 0.804) = 0.848.
        assert!((m.speed(0.6, 1.34) - 1.34 * (0.6f32 / 0.804).tanh()).abs() < 1e-6);
        assert!((m.speed(0.6, 1.34) - 0.848).abs() < 1e-3);
        // Slope 1 / T at zero, below v0 everywhere, zero for overlaps and for v0 = 0.
        assert!((m.speed(1e-3, 1.34) / 1e-3 - 1.0 / 0.6).abs() < 1e-2);
        assert!(m.speed(100.0, 1.34) <= 1.34 && m.speed(100.0, 1.34) > 1.339);
        assert_eq!(m.speed(-0.1, 1.34), 0.0);
        assert_eq!(m.speed(1.0, 0.0), 0.0);
    }

    #[test]
    fn a_reference_speed_makes_the_speed_relative_to_v0_one_function_of_the_spacing() {
        for speed_function in [SpeedFunction::Linear, SpeedFunction::Smooth] {
            let m = Cfsm {
                reference_speed: 1.34,
                speed_function,
                ..Cfsm::default()
            };
            let plain = Cfsm {
                reference_speed: 0.0,
                ..m
            };
            for s in [0.0f32, 0.05, 0.2, 0.5, 1.0, 3.0] {
                // At the reference speed, the time gaps as given.
                assert_eq!(m.speed_under(s, 1.34, 0.3), plain.speed_under(s, 1.34, 0.3));
                // Elsewhere, v / v0 is the same function of the spacing.
                for v0 in [0.6f32, 1.11, 2.0] {
                    let relative = m.speed_under(s, v0, 0.3) / v0;
                    let at_reference = m.speed_under(s, 1.34, 0.3) / 1.34;
                    assert!((relative - at_reference).abs() < 1e-6, "{s} {v0}");
                    assert!((0.0..=v0).contains(&m.speed_under(s, v0, 0.3)));
                }
            }
            assert_eq!(m.speed(1.0, 0.0), 0.0);
        }
        let bad = Cfsm {
            reference_speed: -1.0,
            ..Cfsm::default()
        };
        assert!(
            bad.validate()
                .unwrap_err()
                .to_string()
                .contains("reference_speed")
        );
    }

    #[test]
    fn contact_spacing_is_the_walk_to_touching() {
        let m = Cfsm {
            path_width: 1.0,
            ..Cfsm::default()
        };
        let e = Vec2::X;
        // Straight ahead: as the centre rule.
        assert_eq!(m.spacing_to(Vec2::new(1.0, 0.0), e, 0.4), Some(0.6));
        // 0.3 to the side: touching after 1 - sqrt(0.16 - 0.09) = 0.7354 m.
        let s = m.spacing_to(Vec2::new(1.0, 0.3), e, 0.4).unwrap();
        assert!((s - (1.0 - 0.07f32.sqrt())).abs() < 1e-6);
        assert!(s > Cfsm::spacing(Vec2::new(1.0, 0.3), e, 0.4).unwrap());
        assert_eq!(m.spacing_to(Vec2::new(1.0, 0.5), e, 0.4), None);
        assert_eq!(m.spacing_to(Vec2::new(-1.0, 0.0), e, 0.4), None);
        assert_eq!(
            jupedsim().spacing_to(Vec2::new(1.0, 0.3), e, 0.4),
            Cfsm::spacing(Vec2::new(1.0, 0.3), e, 0.4)
        );
    }

    #[test]
    fn a_narrower_path_passes_a_graze_and_keeps_a_line_ahead() {
        let e = Vec2::X;
        for spacing in [Spacing::Centre, Spacing::Contact] {
            let full = Cfsm {
                spacing,
                path_width: 1.0,
                ..Cfsm::default()
            };
            let narrow = Cfsm {
                path_width: 0.6,
                ..full
            };
            // Straight ahead (a line in single file): the same spacing.
            for x in [0.45f32, 1.0, 1.7] {
                let rel = Vec2::new(x, 0.0);
                assert_eq!(narrow.spacing_to(rel, e, 0.4), full.spacing_to(rel, e, 0.4));
            }
            // A graze, 0.3 to the side of 0.4: it stops the full path only.
            let rel = Vec2::new(1.0, 0.3);
            assert!(full.spacing_to(rel, e, 0.4).is_some());
            assert_eq!(narrow.spacing_to(rel, e, 0.4), None);
        }
        // Within the path, 0.2 to the side: the centre rule as before; the walk to contact with
        // a body 0.6 as wide, 1 - sqrt(0.16 - (0.2 / 0.6)^2) = 0.7789 m, which runs
        // continuously to the centre distance ahead at the path's edge.
        let rel = Vec2::new(1.0, 0.2);
        let centre = Cfsm {
            spacing: Spacing::Centre,
            path_width: 0.6,
            ..Cfsm::default()
        };
        assert_eq!(centre.spacing_to(rel, e, 0.4), Cfsm::spacing(rel, e, 0.4));
        let contact = Cfsm {
            spacing: Spacing::Contact,
            path_width: 0.6,
            ..Cfsm::default()
        };
        let s = contact.spacing_to(rel, e, 0.4).unwrap();
        assert!(
            (s - (1.0 - (0.16f32 - 0.04 / 0.36).sqrt())).abs() < 1e-6,
            "{s}"
        );
        let edge = contact.spacing_to(Vec2::new(1.0, 0.2399), e, 0.4).unwrap();
        assert!((edge - 1.0).abs() < 0.02, "{edge}");
        for bad in [0.0, 0.49, -0.5, 1.01, f32::NAN, f32::INFINITY, 1e-40] {
            let m = Cfsm {
                path_width: bad,
                ..Cfsm::default()
            };
            let e = m.validate().unwrap_err().to_string();
            assert!(e.contains("path_width"), "{bad}: {e}");
        }
    }

    #[test]
    fn an_older_table_gets_the_values_it_stepped_with_and_a_new_one_keeps_its_own() {
        let mut old: toml::Table =
            toml::from_str("time_gap = 0.6\npressure_onset = 0.15\nanisotropy = 0.9").unwrap();
        Cfsm::fill_absent_keys(&mut old);
        let cf: Cfsm = old.try_into().unwrap();
        assert_eq!(
            (cf.pressed_anisotropy, cf.reference_speed, cf.path_width),
            (0.9, 0.0, 1.0)
        );
        let mut new: toml::Table =
            toml::from_str(&toml::to_string(&Cfsm::default()).unwrap()).unwrap();
        Cfsm::fill_absent_keys(&mut new);
        assert_eq!(new.try_into::<Cfsm>().unwrap(), Cfsm::default());
        // A table that is not the speed model's gets nothing.
        let other = |k: &str| ["time_gap", "tau"].contains(&k);
        assert!(Cfsm::absent_keys(other, None).is_empty());
    }

    #[test]
    fn pressure_by_hand() {
        let m = plain_gaps();
        // An even crowd: no pressure, the time gap T.
        assert_eq!(m.pressure(10.0, 20.0), 0.0);
        assert_eq!(m.time_gap_at(0.0), 0.6);
        // 13 of 20 behind: imbalance 0.3, (0.3 - 0.15) / 0.15 = 1, the time gap T_p.
        assert!((m.pressure(13.0, 20.0) - 1.0).abs() < 1e-6);
        assert!((m.time_gap_at(1.0) - 0.4).abs() < 1e-7);
        // 45 of 80: imbalance 0.125, below the onset.
        assert_eq!(m.pressure(45.0, 80.0), 0.0);
        // 9 of 40: imbalance -0.55 (the back of a queue): none.
        assert_eq!(m.pressure(9.0, 40.0), 0.0);
        // 22 of 40: imbalance 0.1; 23 of 40: 0.15, the onset; 24.5 of 40: 0.225, half-way.
        assert_eq!(m.pressure(23.0, 40.0), 0.0);
        assert!((m.pressure(24.5, 40.0) - 0.5).abs() < 1e-6);
        // Half-way between T = 0.6 s and T_p = 0.4 s.
        assert!((m.time_gap_at(0.5) - 0.5).abs() < 1e-6);
        // One agent behind, none ahead: imbalance 1 / 4 (the minimum count), q = 2 / 3.
        assert!((m.pressure(1.0, 1.0) - (0.25 - 0.15) / 0.15).abs() < 1e-6);
        // Nobody near: no pressure, and no division by zero.
        assert_eq!(m.pressure(0.0, 0.0), 0.0);
        // Under pressure the speed rises at the same spacing, never above v0.
        assert!(m.speed_under(0.3, 1.34, 1.0) > m.speed(0.3, 1.34));
        assert_eq!(m.speed_under(0.3, 1.34, 0.0), m.speed(0.3, 1.34));
        assert!(m.speed_under(10.0, 1.34, 1.0) <= 1.34);
        // JuPedSim's parameters have none.
        assert_eq!(
            jupedsim().speed_under(0.3, 1.34, 1.0),
            jupedsim().speed(0.3, 1.34)
        );
        // The anisotropy: the paper's isotropic weight without pressure, none from straight
        // behind under full pressure, half-way between at half the pressure; JuPedSim's has
        // none, and equal keys give exactly `anisotropy`.
        assert_eq!(m.anisotropy_at(0.0), 1.0);
        assert_eq!(m.anisotropy_at(1.0), 0.0);
        assert!((m.anisotropy_at(0.5) - 0.5).abs() < 1e-7);
        assert!(m.pressed_anisotropy_on() && !jupedsim().pressed_anisotropy_on());
        assert_eq!(jupedsim().anisotropy_at(0.7), 1.0);
        let pressed = Cfsm {
            anisotropy: 0.3,
            pressed_anisotropy: 0.3,
            ..m
        };
        assert_eq!(pressed.anisotropy_at(0.37).to_bits(), 0.3f32.to_bits());
        let (n, e0) = (Vec2::X, Vec2::X);
        assert_eq!(
            m.repulsion_under(n, 0.4, (0, 1), e0, 1.0),
            m.repulsion(n, 0.4, (0, 1), e0)
        );
        assert_eq!(m.repulsion_under(n, 0.4, (0, 1), e0, 0.0), Vec2::ZERO);
        assert!(Cfsm::is_behind(Vec2::new(-0.1, 1.0), Vec2::X));
        assert!(!Cfsm::is_behind(Vec2::new(0.0, 1.0), Vec2::X));
    }

    #[test]
    fn bad_pressure_keys_are_named() {
        let with = |set: fn(&mut Cfsm)| {
            let mut m = Cfsm::default();
            set(&mut m);
            m
        };
        for (m, key) in [
            (with(|m| m.pressed_time_gap = 1.2), "pressed_time_gap"),
            (with(|m| m.pressed_time_gap = 0.0), "pressed_time_gap"),
            (with(|m| m.pressure_onset = f32::NAN), "pressure_onset"),
            (with(|m| m.pressure_onset = 1.0), "pressure_onset"),
            (with(|m| m.pressure_span = 0.0), "pressure_span"),
            (with(|m| m.pressure_span = f32::INFINITY), "pressure_span"),
            (with(|m| m.pressed_anisotropy = -0.1), "pressed_anisotropy"),
            (
                with(|m| m.pressed_anisotropy = f32::NAN),
                "pressed_anisotropy",
            ),
            (with(|m| m.pressed_anisotropy = 1.5), "pressed_anisotropy"),
        ] {
            let e = m.validate().unwrap_err().to_string();
            assert!(e.contains(key), "{e}");
        }
        assert!(Cfsm::default().validate().is_ok());
    }
}
