//! Anti-gravity movement (potential-field motion planning): gravity points that repel or attract.
//!
//! Each point pushes an agent with `strength / distance^exponent` along the bearing from the point
//! to the agent: a positive strength repels, a negative one attracts. The total force is the sum
//! over the points within each point's cut-off `radius`; points are kept in a uniform grid, so an
//! agent only visits the points near it, never all of them. Points can be static, move on a
//! script (a constant velocity, an orbit), or ride on an agent.
//!
//! [`antigravity_seek`] is the anti-gravity seek:
//! `normalize(normalize(target - p) + total_force)`.
//!
//! Powers of the distance (`distance_power`): whole exponents 0 to 4 are exact products of the
//! distance and its square (the square as the offset's squared length), any other exponent is
//! `powf`; agent repulsion (`plans::neighbours` and the cell batch's kernel) uses the same
//! function, so the lane forms give its bits.

use glam::Vec2;
use serde::{Deserialize, Serialize};

use crate::agents::AgentId;
use crate::bounds::Bounds;
use crate::error::{Error, Result, finite, finite_vec, non_negative, positive};
use crate::spatial::{GridIndex, Neighbour, NeighbourIndex};

/// How a gravity point moves.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Motion {
    /// It stays where it is.
    #[default]
    Static,
    /// It moves at a constant velocity (wrapping or clamped by the world's bounds).
    Linear {
        /// Units per second.
        velocity: Vec2,
    },
    /// It circles `center` at `orbit_radius`, `angular_speed` radians per second.
    Orbit {
        /// Centre of the orbit.
        center: Vec2,
        /// Radius of the orbit.
        orbit_radius: f32,
        /// Radians per second (the sign gives the direction).
        angular_speed: f32,
    },
    /// It sits on an agent (and vanishes when the agent is removed).
    Agent {
        /// The agent.
        agent: AgentId,
    },
}

/// A gravity point.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GravityPoint {
    /// Where it is now.
    pub position: Vec2,
    /// Force at distance 1; positive repels, negative attracts.
    pub strength: f32,
    /// The `n` of `strength / distance^n` (>= 0). Default: 2.
    #[serde(default = "two")]
    pub exponent: f32,
    /// Cut-off (> 0): agents farther away feel nothing from this point.
    pub radius: f32,
    /// How it moves. Default: static.
    #[serde(default)]
    pub motion: Motion,
}

fn two() -> f32 {
    2.0
}

impl GravityPoint {
    /// A static point.
    #[must_use]
    pub fn fixed(position: Vec2, strength: f32, exponent: f32, radius: f32) -> Self {
        GravityPoint {
            position,
            strength,
            exponent,
            radius,
            motion: Motion::Static,
        }
    }

    /// Checks the numbers.
    ///
    /// # Errors
    /// [`Error::NonFinite`], [`Error::Negative`] or [`Error::NotPositive`] naming the parameter.
    pub fn validate(&self) -> Result<()> {
        crate::error::coordinate("gravity.position", self.position)?;
        finite("gravity.strength", self.strength)?;
        non_negative("gravity.exponent", self.exponent)?;
        positive("gravity.radius", self.radius)?;
        if let Motion::Orbit {
            center,
            orbit_radius,
            angular_speed,
        } = self.motion
        {
            crate::error::coordinate("gravity.motion.center", center)?;
            non_negative("gravity.motion.orbit_radius", orbit_radius)?;
            finite("gravity.motion.angular_speed", angular_speed)?;
        }
        if let Motion::Linear { velocity } = self.motion {
            finite_vec("gravity.motion.velocity", velocity)?;
        }
        Ok(())
    }

    /// The force this point exerts on an agent at offset `d` from the point (`d = agent - point`,
    /// under the world's metric): zero beyond the cut-off or at the point itself.
    #[inline]
    #[must_use]
    pub fn force(&self, d: Vec2) -> Vec2 {
        let d_sq = d.length_squared();
        if d_sq > self.radius * self.radius || d_sq == 0.0 {
            return Vec2::ZERO;
        }
        let dist = d_sq.sqrt();
        d / dist * (self.strength / distance_power(dist, d_sq, self.exponent))
    }
}

/// `exponent` as a whole number from 0 to 4, the exponents [`distance_power`] takes as exact
/// products, or `None`.
#[inline]
#[must_use]
pub(crate) fn whole_exponent(exponent: f32) -> Option<u8> {
    (0..=4u8).find(|&e| f32::from(e) == exponent)
}

/// `dist^E` for a whole exponent `E` from 0 to 4, from the distance `dist` and its square
/// `d_sq` (the offset's squared length): 1, `dist`, `d_sq`, `d_sq * dist`, `d_sq * d_sq`.
#[inline(always)]
#[must_use]
pub(crate) fn whole_power<const E: u8>(dist: f32, d_sq: f32) -> f32 {
    match E {
        0 => 1.0,
        1 => dist,
        2 => d_sq,
        3 => d_sq * dist,
        _ => d_sq * d_sq,
    }
}

/// `dist^exponent` for the distance `dist` whose square is `d_sq`: [`whole_power`] for whole
/// exponents from 0 to 4, `powf` otherwise.
#[inline]
#[must_use]
pub(crate) fn distance_power(dist: f32, d_sq: f32, exponent: f32) -> f32 {
    match whole_exponent(exponent) {
        Some(0) => whole_power::<0>(dist, d_sq),
        Some(1) => whole_power::<1>(dist, d_sq),
        Some(2) => whole_power::<2>(dist, d_sq),
        Some(3) => whole_power::<3>(dist, d_sq),
        Some(_) => whole_power::<4>(dist, d_sq),
        None => dist.powf(exponent),
    }
}

/// The anti-gravity seek direction: `normalize(normalize(target - position) + force)` (zero when both
/// vanish).
#[inline]
#[must_use]
pub fn antigravity_seek(position: Vec2, target: Vec2, force: Vec2) -> Vec2 {
    ((target - position).normalize_or_zero() + force).normalize_or_zero()
}

/// All gravity points of a world, indexed for cut-off queries.
#[derive(Clone, Debug, Default)]
pub struct GravityField {
    points: Vec<GravityPoint>,
    index: GridIndex,
    xs: Vec<f32>,
    ys: Vec<f32>,
    max_radius: f32,
    dirty: bool,
}

impl GravityField {
    /// The points.
    #[must_use]
    pub fn points(&self) -> &[GravityPoint] {
        &self.points
    }

    /// Whether there are no points.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Adds a point; returns its index.
    ///
    /// # Errors
    /// As [`GravityPoint::validate`].
    pub fn add(&mut self, p: GravityPoint) -> Result<usize> {
        p.validate()?;
        self.points.push(p);
        self.dirty = true;
        Ok(self.points.len() - 1)
    }

    /// Moves point `k` to `position`.
    ///
    /// # Errors
    /// [`Error::Invalid`] for an unknown point, [`Error::NonFinite`] for a bad position.
    pub fn set_position(&mut self, k: usize, position: Vec2) -> Result<()> {
        crate::error::coordinate("gravity.position", position)?;
        let count = self.points.len();
        let p = self.points.get_mut(k).ok_or_else(|| Error::Invalid {
            name: "gravity point".into(),
            reason: format!("no point {k} (there are {count})"),
        })?;
        p.position = position;
        self.dirty = true;
        Ok(())
    }

    /// Advances scripted motion by `dt` and moves agent-borne points to their agents
    /// (`agent_position` looks an agent up); then reindexes if anything moved.
    pub fn advance(
        &mut self,
        dt: f32,
        time: f64,
        bounds: Bounds,
        agent_position: impl Fn(AgentId) -> Option<Vec2>,
    ) {
        for p in &mut self.points {
            match p.motion {
                Motion::Static => {}
                Motion::Linear { velocity } => {
                    p.position = bounds.wrap(p.position + velocity * dt);
                    self.dirty = true;
                }
                Motion::Orbit {
                    center,
                    orbit_radius,
                    angular_speed,
                } => {
                    let a = (f64::from(angular_speed) * time) as f32;
                    p.position = bounds.wrap(center + Vec2::from_angle(a) * orbit_radius);
                    self.dirty = true;
                }
                Motion::Agent { agent } => {
                    if let Some(pos) = agent_position(agent)
                        && pos != p.position
                    {
                        p.position = pos;
                        self.dirty = true;
                    }
                }
            }
        }
        if self.dirty {
            self.reindex(bounds);
        }
    }

    fn reindex(&mut self, bounds: Bounds) {
        self.xs.clear();
        self.ys.clear();
        self.max_radius = 0.0;
        for p in &self.points {
            self.xs.push(p.position.x);
            self.ys.push(p.position.y);
            self.max_radius = self.max_radius.max(p.radius);
        }
        // Points may sit outside a walled world (they only push); index them in an open grid then.
        let b = if bounds.is_torus() {
            bounds
        } else {
            Bounds::Open
        };
        self.index
            .rebuild(&self.xs, &self.ys, b, self.max_radius.max(1e-3));
        self.dirty = false;
    }

    /// Makes sure the index matches the points.
    pub fn prepare(&mut self, bounds: Bounds) {
        if self.dirty {
            self.reindex(bounds);
        }
    }

    /// The total force at `position`, summed over the points within their cut-offs in ascending
    /// point order (`buf` is scratch). On a torus the offsets are minimum images.
    pub fn force_at(&self, position: Vec2, buf: &mut Vec<Neighbour>) -> Vec2 {
        if self.points.is_empty() {
            return Vec2::ZERO;
        }
        self.index.neighbours_at(position, self.max_radius, buf);
        let mut f = Vec2::ZERO;
        for nb in buf.iter() {
            let p = &self.points[nb.index as usize];
            // The index's offset runs from the agent to the point (the minimum image on a torus).
            f += p.force(-nb.offset);
        }
        f
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn force_follows_the_formula() {
        let p = GravityPoint::fixed(Vec2::ZERO, 2000.0, 2.0, 1000.0);
        let f = p.force(Vec2::new(10.0, 0.0));
        assert!(
            (f - Vec2::new(20.0, 0.0)).length() < 1e-4,
            "2000 / 10^2 along +x: {f}"
        );
        let attract = GravityPoint {
            strength: -2000.0,
            ..p
        };
        assert!(attract.force(Vec2::new(10.0, 0.0)).x < 0.0);
        assert_eq!(
            p.force(Vec2::new(2000.0, 0.0)),
            Vec2::ZERO,
            "beyond the cut-off"
        );
    }

    #[test]
    fn indexed_sum_equals_the_plain_sum() {
        let mut g = GravityField::default();
        let mut plain = Vec2::ZERO;
        let at = Vec2::new(50.0, 50.0);
        for k in 0..200 {
            let pos = Vec2::new((k * 37 % 100) as f32, (k * 53 % 100) as f32);
            let p = GravityPoint::fixed(
                pos,
                10.0 + k as f32,
                1.0 + (k % 3) as f32,
                5.0 + (k % 20) as f32,
            );
            g.add(p).unwrap();
            plain += p.force(at - pos);
        }
        g.prepare(Bounds::Open);
        let f = g.force_at(at, &mut Vec::new());
        assert!(
            (f - plain).length() <= 1e-4 * plain.length().max(1.0),
            "{f} vs {plain}"
        );
    }

    #[test]
    fn seek_combination_is_a_unit_vector() {
        let d = antigravity_seek(Vec2::ZERO, Vec2::new(10.0, 0.0), Vec2::new(0.0, 3.0));
        assert!((d.length() - 1.0).abs() < 1e-6);
        assert!(d.y > d.x, "a strong push dominates the direction");
    }
}
