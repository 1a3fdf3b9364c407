//! Optimal reciprocal collision avoidance (ORCA; van den Berg, Guy, Lin and Manocha,
//! "Reciprocal n-body collision avoidance", 2011): a velocity filter that replaces a group's
//! preferred velocity by the velocity closest to it that is collision-free for a time horizon.
//!
//! A group opts in with [`Orca`] in its profile (`orca = { ... }` in a scenario file). Its
//! other behaviours give each agent a preferred velocity (the kinematic model's desired
//! velocity; in the dynamic model, the velocity the behaviours' acceleration would reach in one
//! step). The steering layer then builds, per agent:
//!
//! 1. the half-planes of the static obstacles near it ([`WallChains`] for walls and polygons,
//!    with RVO2's treatment of convex and concave vertices; circles as static discs), with
//!    horizon `time_horizon_obst`; these are *hard* and never relaxed;
//! 2. the half-plane of each of its nearest `max_neighbours` neighbours within `neighbour_dist`
//!    ([`agent_line`]), with horizon `time_horizon`, of which the agent takes its share of
//!    responsibility;
//!
//! and solves the linear program of [`lp::solve`] in its speed circle. Kinematic agents take
//! the result as their velocity. Dynamic agents accelerate towards it within their maximum
//! acceleration, so the guarantee holds only as far as the acceleration allows them to reach the
//! chosen velocity in one step.
//!
//! Invariants: the filter reads frame-t positions and velocities only and writes only each
//! agent's own steering output, so results do not depend on the thread count; every line is
//! finite; the chosen velocity lies in the agent's speed circle.

pub(crate) mod contact;
pub mod lines;
pub mod lp;
pub mod obstacles;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result, non_negative, positive};

pub use lines::{LineBlock, agent_line, permits};
pub use lp::{Line, accepted, solve, tested, unconstrained};
pub use obstacles::WallChains;

/// The largest `max_neighbours` a group may ask for.
pub const MAX_NEIGHBOURS: u32 = 1024;

/// A group's ORCA parameters (RVO2's agent defaults of its Circle example).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Orca {
    /// Neighbours farther than this are ignored (> 0). Default: 15.
    pub neighbour_dist: f32,
    /// At most this many nearest neighbours are considered, ties broken by id
    /// (1 ..= 1024). Default: 10.
    pub max_neighbours: u32,
    /// Seconds ahead for which velocities are collision-free with other agents (> 0).
    /// Default: 10.
    pub time_horizon: f32,
    /// Seconds ahead for which velocities are collision-free with obstacles (> 0). Default: 10.
    pub time_horizon_obst: f32,
    /// The agent's share of avoiding another ORCA agent, in [0, 1]: two agents take
    /// `rho_a / (rho_a + rho_b)` and `rho_b / (rho_a + rho_b)` of it (half each when both are
    /// zero), so a leader with a small value leaves most of it to the others. Against agents of
    /// groups without ORCA (which do not avoid) the agent takes all of it. Default: 0.5.
    pub responsibility: f32,
    /// When given (> 0), the behaviours' velocity is truncated to this speed before avoidance,
    /// while avoidance may use the full maximum speed (RVO2's preferred speed 1 with maximum
    /// speed 2). Default: none.
    pub pref_speed: Option<f32>,
    /// The size (>= 0, units per second) of a deterministic random offset of the preferred
    /// velocity, drawn from the agent's counter-based stream each step, which breaks perfectly
    /// symmetric encounters. Default: 0.
    pub perturbation: f32,
    /// Hard contact resolution after integration: agents of ORCA groups with it on that overlap
    /// by more than 3% of their summed radii are pushed apart (deterministically, in up to
    /// `contact_iterations` sweeps); where the sweeps leave a pair closer than 0.96 of its
    /// summed radii, agents go back to their frame-start positions, so that no step brings two
    /// of them closer than that. Default: false.
    pub contact: bool,
    /// Sweeps of contact resolution per step (1 ..= 64). Default: 8.
    pub contact_iterations: u32,
}

impl Default for Orca {
    fn default() -> Self {
        Orca {
            neighbour_dist: 15.0,
            max_neighbours: 10,
            time_horizon: 10.0,
            time_horizon_obst: 10.0,
            responsibility: 0.5,
            pref_speed: None,
            perturbation: 0.0,
            contact: false,
            contact_iterations: 8,
        }
    }
}

impl Orca {
    /// Checks every parameter.
    ///
    /// # Errors
    /// [`Error::NotPositive`], [`Error::Negative`], [`Error::NonFinite`] or [`Error::Invalid`]
    /// naming the first bad key (`orca.neighbour_dist`, ...).
    pub fn validate(&self) -> Result<()> {
        positive("orca.neighbour_dist", self.neighbour_dist)?;
        crate::error::in_range(
            "orca.neighbour_dist",
            self.neighbour_dist,
            0.0,
            1e9,
            "(0, 1e9]",
        )?;
        if self.max_neighbours == 0 || self.max_neighbours > MAX_NEIGHBOURS {
            return Err(Error::Invalid {
                name: "orca.max_neighbours".into(),
                reason: format!(
                    "must be 1 ..= {MAX_NEIGHBOURS}, got {}",
                    self.max_neighbours
                ),
            });
        }
        positive("orca.time_horizon", self.time_horizon)?;
        positive("orca.time_horizon_obst", self.time_horizon_obst)?;
        for (name, v) in [
            ("orca.time_horizon", self.time_horizon),
            ("orca.time_horizon_obst", self.time_horizon_obst),
        ] {
            crate::error::in_range(name, v, 0.0, 1e9, "(0, 1e9]")?;
        }
        non_negative("orca.responsibility", self.responsibility)?;
        if self.responsibility > 1.0 {
            return Err(Error::Invalid {
                name: "orca.responsibility".into(),
                reason: format!("must lie in [0, 1], got {}", self.responsibility),
            });
        }
        if let Some(s) = self.pref_speed {
            positive("orca.pref_speed", s)?;
            crate::error::in_range(
                "orca.pref_speed",
                s,
                0.0,
                crate::error::MAX_SPEED,
                "(0, 1e12]",
            )?;
        }
        non_negative("orca.perturbation", self.perturbation)?;
        crate::error::in_range(
            "orca.perturbation",
            self.perturbation,
            0.0,
            crate::error::MAX_SPEED,
            "[0, 1e12]",
        )?;
        if !(1..=64).contains(&self.contact_iterations) {
            return Err(Error::Invalid {
                name: "orca.contact_iterations".into(),
                reason: format!("must be 1 ..= 64, got {}", self.contact_iterations),
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_values_are_typed_errors_naming_the_key() {
        let bad = [
            Orca {
                neighbour_dist: 0.0,
                ..Orca::default()
            },
            Orca {
                neighbour_dist: f32::NAN,
                ..Orca::default()
            },
            Orca {
                max_neighbours: 0,
                ..Orca::default()
            },
            Orca {
                time_horizon: -1.0,
                ..Orca::default()
            },
            Orca {
                time_horizon_obst: 0.0,
                ..Orca::default()
            },
            Orca {
                responsibility: 1.5,
                ..Orca::default()
            },
            Orca {
                responsibility: -0.1,
                ..Orca::default()
            },
            Orca {
                pref_speed: Some(0.0),
                ..Orca::default()
            },
            Orca {
                perturbation: f32::INFINITY,
                ..Orca::default()
            },
            Orca {
                contact_iterations: 0,
                ..Orca::default()
            },
        ];
        for o in bad {
            let e = o.validate().expect_err("accepted a bad value").to_string();
            assert!(e.contains("orca."), "{e}");
        }
        Orca::default().validate().unwrap();
    }
}
