//! Pedestrian models in SI units (metres, seconds, kilograms, newtons): the social force model
//! ([`social_force`]) and the collision-free speed model ([`cfsm`]).
//!
//! A group opts in with [`Pedestrian`] in its profile (`pedestrian = { model = "cfsm" }` in a
//! scenario file). Its other behaviours (seek, arrive, follow_field, follow_path, ...) give each
//! agent its *preferred direction*: the direction of a kinematic group's desired velocity, or of
//! a dynamic group's velocity after one step of the behaviours' acceleration. The agent's
//! *desired speed* `v0` is drawn once per agent from [`DesiredSpeed`] (Weidmann's normal
//! distribution, truncated) by its id and the world's seed, so it survives checkpoints and does
//! not depend on spawn order; it is scaled down when the behaviours ask for less than the
//! group's maximum speed (an `arrive` slowing near its target). The model then replaces the
//! behaviours' request:
//!
//! - the **social force model** computes an acceleration from the driving term, the agents
//!   within `cutoff` and the walls and circles within `cutoff`;
//! - the **collision-free speed model** computes a velocity: a direction from the preferred one
//!   and exponential repulsions, a speed from the spacing to the nearest agent ahead.
//!
//! Kinematic groups take a velocity (the social force model's `v + a dt`), dynamic groups an
//! acceleration (the speed model's `(v_new - v) / dt`), within the group's `max_speed` and
//! `max_acceleration`, which stay hard limits. The models need a small time step: 0.01 s is
//! JuPedSim's default and what the pedestrian scenarios use; the social force model's body
//! forces are stiff (`k = 1.2e5 kg/s^2`) and the integration was found stable for `dt <= 0.02 s`
//! at the 2000 paper's parameters, whose repulsion presses bodies harder than the default's.
//!
//! Walls act from their closest points, a corner once: a wall whose closest point is an end it
//! shares with a nearer wall is skipped, so a body beside a door's jamb is not repelled twice.
//!
//! Invariants: every term is finite for any finite input, including zero distance (a
//! deterministic direction from the two ids) and overlap; pair terms between equal agents are
//! equal and opposite when the anisotropy is off.

mod approx;
pub mod cfsm;
pub(crate) mod lanes;
pub(crate) mod own;
pub mod social_force;

use glam::Vec2;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result, in_range, non_negative, positive};
use crate::rng::{AgentRng, Stream};

pub use cfsm::{Cfsm, Spacing, SpeedFunction};
pub use social_force::SocialForce;

/// The largest desired speed accepted, m/s.
pub const MAX_DESIRED_SPEED: f32 = 100.0;

/// The largest `cutoff` accepted, m.
pub const MAX_CUTOFF: f32 = 1000.0;

/// Which pedestrian model moves a group.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Model {
    /// The social force model (Helbing, Farkas and Vicsek 2000).
    SocialForce,
    /// The collision-free speed model (Tordeux, Chraibi and Seyfried 2016), JuPedSim's default.
    #[default]
    Cfsm,
}

impl Model {
    /// Every model: the registry the command line, `throng validate` and the Python package
    /// take their lists of names from.
    pub const ALL: [Model; 2] = [Model::SocialForce, Model::Cfsm];

    /// The name used in scenario files: `"social_force"` or `"cfsm"`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Model::SocialForce => "social_force",
            Model::Cfsm => "cfsm",
        }
    }

    /// Other names the model is known by (`"sfm"`, JuPedSim's, for the social force model).
    #[must_use]
    pub fn aliases(self) -> &'static [&'static str] {
        match self {
            Model::SocialForce => &["sfm"],
            Model::Cfsm => &[],
        }
    }

    /// Every name a model may be given by: each model's name, then its aliases.
    pub fn names() -> impl Iterator<Item = &'static str> {
        Model::ALL
            .into_iter()
            .flat_map(|m| std::iter::once(m.name()).chain(m.aliases().iter().copied()))
    }

    /// The model named `name` (its name or an alias: `"social_force"`, `"sfm"`, `"cfsm"`).
    #[must_use]
    pub fn parse(name: &str) -> Option<Model> {
        Model::ALL
            .into_iter()
            .find(|m| m.name() == name || m.aliases().contains(&name))
    }
}

/// The distribution of desired speeds: a normal distribution truncated to `[min, max]`.
/// Defaults: Weidmann's free walking speed, mean 1.34 m/s, sd 0.26 m/s, truncated at three
/// standard deviations (0.56 to 2.12 m/s).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DesiredSpeed {
    /// Mean, m/s (> 0). Default: 1.34.
    pub mean: f32,
    /// Standard deviation, m/s (>= 0; 0 gives every agent the mean). Default: 0.26.
    pub sd: f32,
    /// Smallest speed drawn, m/s (>= 0, at most the mean). Default: 0.56.
    pub min: f32,
    /// Largest speed drawn, m/s (at least the mean, at most 100). Default: 2.12.
    pub max: f32,
}

impl Default for DesiredSpeed {
    fn default() -> Self {
        DesiredSpeed {
            mean: 1.34,
            sd: 0.26,
            min: 0.56,
            max: 2.12,
        }
    }
}

impl DesiredSpeed {
    /// Every agent at `speed`.
    #[must_use]
    pub fn fixed(speed: f32) -> Self {
        DesiredSpeed {
            mean: speed,
            sd: 0.0,
            min: speed,
            max: speed,
        }
    }

    /// Checks the parameters.
    ///
    /// # Errors
    /// [`Error::NotPositive`], [`Error::Negative`], [`Error::NonFinite`] or [`Error::Invalid`]
    /// naming the key (`pedestrian.desired_speed.mean`, ...).
    pub fn validate(&self) -> Result<()> {
        positive("pedestrian.desired_speed.mean", self.mean)?;
        non_negative("pedestrian.desired_speed.sd", self.sd)?;
        non_negative("pedestrian.desired_speed.min", self.min)?;
        for (name, v) in [
            ("pedestrian.desired_speed.mean", self.mean),
            ("pedestrian.desired_speed.sd", self.sd),
            ("pedestrian.desired_speed.min", self.min),
            ("pedestrian.desired_speed.max", self.max),
        ] {
            in_range(name, v, 0.0, MAX_DESIRED_SPEED, "[0, 100] m/s")?;
        }
        if !(self.min <= self.mean && self.mean <= self.max) {
            return Err(Error::Invalid {
                name: "pedestrian.desired_speed".into(),
                reason: format!(
                    "needs min <= mean <= max, got min {}, mean {}, max {}",
                    self.min, self.mean, self.max
                ),
            });
        }
        Ok(())
    }

    /// The desired speed of agent `id` in a world seeded with `seed`: the same for the agent's
    /// whole life, whatever the spawn order or the thread count.
    #[must_use]
    pub fn draw(&self, seed: u64, id: u32) -> f32 {
        if self.sd == 0.0 {
            return self.mean;
        }
        let mut rng = AgentRng::new(seed, id, 0, Stream::DesiredSpeed as u32);
        for _ in 0..16 {
            // Box-Muller: u1 in (0, 1] keeps the logarithm finite.
            let u1 = 1.0 - rng.unit();
            let u2 = rng.unit();
            let z = (-2.0 * u1.ln()).sqrt() * (std::f32::consts::TAU * u2).cos();
            let v = self.mean + self.sd * z;
            if (self.min..=self.max).contains(&v) {
                return v;
            }
        }
        self.mean
    }
}

/// Pre-movement times: how long after the start of the run (world time 0, the alarm) each
/// pedestrian waits before it walks, drawn per agent from the uniform distribution on
/// `[min, max]` s (RiMEA test 5 uses 10 to 100 s). A waiting pedestrian has no preferred
/// velocity: it stands. Under the social force model it has no social repulsion either, from
/// agents or walls (the repulsion is a pedestrian's motive to keep its distance, and a waiting
/// one has no motives yet): others move it only by contact, through the body force and the
/// friction. Drawn from
/// the agent's counter-based stream, so the same for any spawn order or thread count; agents
/// added after their time walk at once.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Premovement {
    /// The shortest time, s (>= 0).
    pub min: f32,
    /// The longest time, s (>= `min`, at most 1e6).
    pub max: f32,
}

impl Premovement {
    /// Checks the bounds.
    ///
    /// # Errors
    /// [`Error::NonFinite`] or
    /// [`Error::OutOfRange`] naming the key
    /// (`pedestrian.premovement.min`, ...).
    pub fn validate(&self) -> Result<()> {
        non_negative("pedestrian.premovement.min", self.min)?;
        in_range(
            "pedestrian.premovement.min",
            self.min,
            0.0,
            MAX_PREMOVEMENT,
            "[0, 1e6] s",
        )?;
        in_range(
            "pedestrian.premovement.max",
            self.max,
            self.min,
            MAX_PREMOVEMENT,
            "[min, 1e6] s",
        )?;
        Ok(())
    }

    /// The pre-movement time of agent `id` in a world of `seed`, s: the same for the agent's
    /// whole life.
    #[must_use]
    pub fn draw(&self, seed: u64, id: u32) -> f32 {
        let mut rng = AgentRng::new(seed, id, 0, Stream::Premovement as u32);
        self.min + (self.max - self.min) * rng.unit()
    }
}

/// The longest pre-movement time a scenario may ask for, s.
pub const MAX_PREMOVEMENT: f32 = 1e6;

/// A pedestrian model with its parameters: each model holds its own parameter type, and the
/// choice of model holds only the chosen model's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ModelParams {
    /// The social force model and its parameters.
    SocialForce(SocialForce),
    /// The collision-free speed model and its parameters.
    Cfsm(Cfsm),
}

impl Default for ModelParams {
    fn default() -> Self {
        ModelParams::new(Model::default())
    }
}

impl ModelParams {
    /// `model` with its default parameters.
    #[must_use]
    pub fn new(model: Model) -> Self {
        match model {
            Model::SocialForce => ModelParams::SocialForce(SocialForce::default()),
            Model::Cfsm => ModelParams::Cfsm(Cfsm::default()),
        }
    }

    /// Which model these are the parameters of.
    #[must_use]
    pub fn model(&self) -> Model {
        match self {
            ModelParams::SocialForce(_) => Model::SocialForce,
            ModelParams::Cfsm(_) => Model::Cfsm,
        }
    }

    /// Agents and walls farther than this from an agent's centre exert no force on it, m.
    #[must_use]
    pub fn cutoff(&self) -> f32 {
        match self {
            ModelParams::SocialForce(p) => p.cutoff,
            ModelParams::Cfsm(p) => p.cutoff,
        }
    }

    /// Checks the model's parameters.
    ///
    /// # Errors
    /// The variant naming the first bad key (`pedestrian.social_force.tau`, ...).
    pub fn validate(&self) -> Result<()> {
        match self {
            ModelParams::SocialForce(p) => p.validate(),
            ModelParams::Cfsm(p) => p.validate(),
        }
    }

    /// The numeric parameter `key` (a key of the model's table in a scenario file:
    /// `time_gap`, `tau`, ...), `None` when the model has no such number.
    ///
    /// # Examples
    /// ```
    /// use throng::ped::{Model, ModelParams};
    /// let p = ModelParams::new(Model::Cfsm);
    /// assert_eq!(p.value("time_gap"), Some(1.0));
    /// assert_eq!(p.value("tau"), None);
    /// let q = p.with_value("time_gap", 0.8).unwrap();
    /// assert_eq!(q.value("time_gap"), Some(0.8));
    /// assert!(p.with_value("time_gap", -1.0).is_err());
    /// ```
    #[must_use]
    pub fn value(&self, key: &str) -> Option<f32> {
        match self.table().get(key)? {
            toml::Value::Float(v) => Some(*v as f32),
            toml::Value::Integer(v) => Some(*v as f32),
            _ => None,
        }
    }

    /// These parameters with the numeric parameter `key` set to `value`, checked.
    ///
    /// # Errors
    /// [`Error::Invalid`] when the model has no numeric parameter
    /// `key`; the variant naming the key for a bad value.
    pub fn with_value(&self, key: &str, value: f32) -> Result<ModelParams> {
        let mut t = self.table();
        if !matches!(
            t.get(key),
            Some(toml::Value::Float(_) | toml::Value::Integer(_))
        ) {
            let numbers: Vec<&str> = t
                .iter()
                .filter(|(_, v)| matches!(v, toml::Value::Float(_) | toml::Value::Integer(_)))
                .map(|(k, _)| k.as_str())
                .collect();
            return Err(crate::Error::Invalid {
                name: key.into(),
                reason: format!(
                    "not a numeric parameter of the {} model (those are: {})",
                    self.model().name(),
                    numbers.join(", ")
                ),
            });
        }
        if !value.is_finite() {
            return Err(crate::Error::Invalid {
                name: key.into(),
                reason: format!("{value} is not a finite number"),
            });
        }
        t.insert(key.into(), toml::Value::Float(f64::from(value)));
        let invalid = |e: toml::de::Error| crate::Error::Invalid {
            name: key.into(),
            reason: e.message().to_string(),
        };
        let p = match self {
            ModelParams::SocialForce(_) => ModelParams::SocialForce(t.try_into().map_err(invalid)?),
            ModelParams::Cfsm(_) => ModelParams::Cfsm(t.try_into().map_err(invalid)?),
        };
        p.validate()?;
        Ok(p)
    }

    /// The parameters as the model's table of a scenario file.
    fn table(&self) -> toml::Table {
        let t = match self {
            ModelParams::SocialForce(p) => toml::Table::try_from(p),
            ModelParams::Cfsm(p) => toml::Table::try_from(p),
        };
        // Plain structs of numbers, booleans and unit enums always serialise.
        t.unwrap_or_default()
    }
}

/// A group's pedestrian model and its parameters.
///
/// In a scenario file it is the `pedestrian` table ([`PedestrianTable`]): `model` names the
/// model and the table named after the model (`cfsm`, `social_force`) holds its parameters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(from = "PedestrianTable", into = "PedestrianTable")]
pub struct Pedestrian {
    /// The model and its parameters. Default: cfsm with its defaults.
    pub params: ModelParams,
    /// The agents' desired speeds. Default: Weidmann's distribution.
    pub desired_speed: DesiredSpeed,
    /// Pre-movement times. Default: none (everyone walks from the start).
    pub premovement: Option<Premovement>,
}

impl Pedestrian {
    /// The default parameters of `model`.
    #[must_use]
    pub fn new(model: Model) -> Self {
        Pedestrian {
            params: ModelParams::new(model),
            ..Pedestrian::default()
        }
    }

    /// The group's model.
    #[must_use]
    pub fn model(&self) -> Model {
        self.params.model()
    }

    /// Moves the group by `model`: with its default parameters unless it is the group's model
    /// already, whose parameters stay.
    pub fn set_model(&mut self, model: Model) {
        if self.model() != model {
            self.params = ModelParams::new(model);
        }
    }

    /// Agents and walls farther than this from an agent's centre exert no force on it, m.
    #[must_use]
    pub fn cutoff(&self) -> f32 {
        self.params.cutoff()
    }

    /// Checks every parameter.
    ///
    /// # Errors
    /// The variant naming the first bad key (`pedestrian.social_force.tau`, ...).
    pub fn validate(&self) -> Result<()> {
        self.desired_speed.validate()?;
        if let Some(p) = &self.premovement {
            p.validate()?;
        }
        self.params.validate()
    }

    /// Whether agent `id` of a world of `seed` still waits at world time `time` (see
    /// [`Premovement`]).
    #[inline]
    #[must_use]
    pub fn waits(&self, seed: u64, id: u32, time: f64) -> bool {
        self.premovement
            .is_some_and(|p| time < f64::from(p.draw(seed, id)))
    }
}

/// The `pedestrian` table of a scenario file, the form a [`Pedestrian`] is read from and
/// written as: the model's name and a table of parameters per model. Written out, the tables
/// of the models the group does not use hold their defaults; read, only the group's model's
/// table is kept (the scenario loader refuses another model's table in a file).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PedestrianTable {
    /// `"social_force"` or `"cfsm"`. Default: cfsm.
    pub model: Model,
    /// The agents' desired speeds. Default: Weidmann's distribution.
    pub desired_speed: DesiredSpeed,
    /// The social force model's parameters (used when `model = "social_force"`).
    pub social_force: SocialForce,
    /// The collision-free speed model's parameters (used when `model = "cfsm"`).
    pub cfsm: Cfsm,
    /// Pre-movement times. Default: none (everyone walks from the start).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub premovement: Option<Premovement>,
}

impl PedestrianTable {
    /// Checks every parameter, those of every model's table.
    ///
    /// # Errors
    /// The variant naming the first bad key (`pedestrian.social_force.tau`, ...).
    pub fn validate(&self) -> Result<()> {
        self.desired_speed.validate()?;
        if let Some(p) = &self.premovement {
            p.validate()?;
        }
        self.social_force.validate()?;
        self.cfsm.validate()
    }
}

impl From<PedestrianTable> for Pedestrian {
    fn from(t: PedestrianTable) -> Self {
        Pedestrian {
            params: match t.model {
                Model::SocialForce => ModelParams::SocialForce(t.social_force),
                Model::Cfsm => ModelParams::Cfsm(t.cfsm),
            },
            desired_speed: t.desired_speed,
            premovement: t.premovement,
        }
    }
}

impl From<Pedestrian> for PedestrianTable {
    fn from(p: Pedestrian) -> Self {
        let mut t = PedestrianTable {
            model: p.model(),
            desired_speed: p.desired_speed,
            premovement: p.premovement,
            ..PedestrianTable::default()
        };
        match p.params {
            ModelParams::SocialForce(m) => t.social_force = m,
            ModelParams::Cfsm(m) => t.cfsm = m,
        }
        t
    }
}

/// Checks a cut-off distance.
pub(crate) fn check_cutoff(name: &'static str, v: f32) -> Result<()> {
    positive(name, v)?;
    in_range(name, v, 0.0, MAX_CUTOFF, "(0, 1000] m")?;
    Ok(())
}

/// The unit vector from `other` to `me` given the offset `d = me - other` and its length; at
/// zero distance a fixed direction whose sign is set by the ids, so the pair still separates
/// and the two get opposite directions.
#[inline]
#[must_use]
pub fn away(d: Vec2, dist: f32, me: u32, other: u32) -> Vec2 {
    if dist > 1e-6 {
        d / dist
    } else if me < other {
        Vec2::X
    } else {
        -Vec2::X
    }
}

/// `exp(x)` with the exponent capped at 60, so that absurd overlaps give large but finite
/// forces.
#[inline]
pub(crate) fn exp_capped(x: f32) -> f32 {
    x.min(60.0).exp()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_model_name_and_alias_parses_to_its_model_and_no_name_is_shared() {
        let names: Vec<&str> = Model::names().collect();
        assert_eq!(names, ["social_force", "sfm", "cfsm"]);
        for m in Model::ALL {
            assert_eq!(Model::parse(m.name()), Some(m));
            for &a in m.aliases() {
                assert_eq!(Model::parse(a), Some(m));
            }
            // The scenario files' name is the serde name.
            let toml = format!("m = {:?}", m.name());
            #[derive(serde::Deserialize)]
            struct T {
                m: Model,
            }
            assert_eq!(toml::from_str::<T>(&toml).unwrap().m, m);
        }
        let unique: std::collections::BTreeSet<_> = names.iter().collect();
        assert_eq!(unique.len(), names.len());
        assert_eq!(Model::parse("magic"), None);
    }

    #[test]
    fn desired_speeds_follow_the_truncated_normal() {
        let d = DesiredSpeed::default();
        let n = 20_000u32;
        let v: Vec<f32> = (0..n).map(|id| d.draw(7, id)).collect();
        assert!(v.iter().all(|&s| (d.min..=d.max).contains(&s)));
        let mean = v.iter().sum::<f32>() / n as f32;
        let var = v.iter().map(|s| (s - mean).powi(2)).sum::<f32>() / n as f32;
        assert!((mean - 1.34).abs() < 0.01, "mean {mean}");
        assert!((var.sqrt() - 0.26).abs() < 0.01, "sd {}", var.sqrt());
        // The same agent gets the same speed; another seed another one.
        assert_eq!(d.draw(7, 5), d.draw(7, 5));
        assert_ne!(d.draw(7, 5), d.draw(8, 5));
        assert_eq!(DesiredSpeed::fixed(1.2).draw(3, 4), 1.2);
    }

    #[test]
    fn bad_values_name_the_key() {
        let bad = [
            DesiredSpeed {
                mean: 0.0,
                ..DesiredSpeed::default()
            },
            DesiredSpeed {
                sd: f32::NAN,
                ..DesiredSpeed::default()
            },
            DesiredSpeed {
                min: 2.0,
                ..DesiredSpeed::default()
            },
            DesiredSpeed {
                max: 1e9,
                ..DesiredSpeed::default()
            },
        ];
        for d in bad {
            let e = d.validate().unwrap_err().to_string();
            assert!(e.contains("desired_speed"), "{e}");
        }
        assert!(Pedestrian::default().validate().is_ok());
    }

    #[test]
    fn the_table_form_holds_every_models_table_and_reading_keeps_the_groups_own() {
        let keys = |p: Pedestrian| match toml::Value::try_from(p).unwrap() {
            toml::Value::Table(t) => t.keys().cloned().collect::<Vec<_>>(),
            other => panic!("{other:?}"),
        };
        for m in Model::ALL {
            let mut p = Pedestrian::new(m);
            assert_eq!(p.model(), m);
            assert_eq!(keys(p), ["cfsm", "desired_speed", "model", "social_force"]);
            let back: Pedestrian = toml::Value::try_from(p).unwrap().try_into().unwrap();
            assert_eq!(back, p);
            // Switching to the same model keeps its parameters; to another gives its defaults.
            p.params = match p.params {
                ModelParams::SocialForce(mut sf) => {
                    sf.tau = 0.4;
                    ModelParams::SocialForce(sf)
                }
                ModelParams::Cfsm(mut cf) => {
                    cf.time_gap = 0.8;
                    ModelParams::Cfsm(cf)
                }
            };
            let tuned = p;
            p.set_model(m);
            assert_eq!(p, tuned);
            for other in Model::ALL.into_iter().filter(|&o| o != m) {
                let mut q = tuned;
                q.set_model(other);
                assert_eq!(q, Pedestrian::new(other));
            }
        }
        // Read, only the table of the group's model is kept.
        let t: Pedestrian = toml::from_str(
            "model = \"cfsm\"\nsocial_force = { tau = 0.4 }\ncfsm = { time_gap = 0.8 }",
        )
        .unwrap();
        let ModelParams::Cfsm(cf) = t.params else {
            panic!("{t:?}")
        };
        assert_eq!(cf.time_gap, 0.8);
    }

    #[test]
    fn away_is_a_unit_vector_even_at_zero_distance() {
        assert_eq!(away(Vec2::new(3.0, 4.0), 5.0, 0, 1), Vec2::new(0.6, 0.8));
        assert_eq!(away(Vec2::ZERO, 0.0, 0, 1), -away(Vec2::ZERO, 0.0, 1, 0));
        assert!(exp_capped(1e9).is_finite());
    }
}
