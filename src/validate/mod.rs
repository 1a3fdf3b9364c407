//! The validation suite: the RiMEA guideline's test cases that apply to a 2D simulator without
//! stairs, and two experiments (bottleneck flow against its width, the fundamental diagram
//! against Weidmann's), each run on the pedestrian models and judged against a stated
//! criterion.
//!
//! A [`Case`] names its scenarios (TOML files under `scenarios/validation/`, embedded in the
//! crate), runs them through [`Run`] and turns what it measured into [`Check`]s: a criterion in
//! words, the measured value and whether it passed. [`run_case`] adds the check every case
//! shares: no agent's move crossed a wall in any step of any of its runs. `throng validate`
//! prints the checks (and `--json`), exiting non-zero when one fails; docs/VALIDATION.md gives
//! the figures and plots.
//!
//! Invariants: a case depends only on its options (seed, size, model): the worlds are
//! bit-identical on any thread count, and the measurements depend only on the observed frames.
//! [`Size::Quick`] shrinks the crowds only where the guideline's criterion does not depend on
//! the crowd's size, and says so in each case's description.

mod cases;
mod experiments;

use glam::Vec2;
use serde::Serialize;

use crate::error::{Error, Result};
use crate::measure::{MeasurementReport, Measurements};
use crate::ped::{Model, Pedestrian, PedestrianTable};
use crate::scenario::Scenario;
use crate::world::World;

pub use cases::CASES;
pub use experiments::{
    BIDIRECTIONAL, BOTTLENECK, MIN_COVERAGE, MIN_SAMPLES, RefBin, SINGLE_FILE, T_JUNCTION_ARMS,
    T_JUNCTION_FRONT, TOLERANCE, UNIDIRECTIONAL,
};

/// How large the crowds are.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Size {
    /// The guideline's sizes.
    #[default]
    Full,
    /// Smaller crowds and fewer sample points where the criterion allows (for CI).
    Quick,
}

/// What every case runs with.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Options {
    /// The crowds' size.
    pub size: Size,
    /// The pedestrian model of every group, or the scenarios' own (the default model).
    pub model: Option<Model>,
    /// Added to every scenario's seed (0: the files' seeds).
    pub seed_offset: u64,
    /// Pedestrian parameters set in every pedestrian group of every scenario, after the model:
    /// dotted keys inside the group's `pedestrian` table (`cfsm.time_gap`,
    /// `social_force.tau`, `desired_speed.mean`) with their values. Default: none (each
    /// model's defaults). A sweep calibrates through them.
    pub params: Vec<(String, toml::Value)>,
}

/// One judged quantity of a case.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Check {
    /// What was measured, e.g. `"travel time"` or `"J/b at b = 1.2 m"`.
    pub name: String,
    /// The criterion in words, e.g. `"26 s <= t <= 34 s"`.
    pub criterion: String,
    /// The measured value (`None` when nothing could be measured, which fails).
    pub value: Option<f64>,
    /// The value's unit (`"s"`, `"1/(m s)"`, ...), empty for ratios.
    pub unit: String,
    /// Whether the criterion holds.
    pub pass: bool,
}

impl Check {
    /// A check that `value` lies in `[lo, hi]`.
    #[must_use]
    pub fn within(name: &str, value: Option<f64>, lo: f64, hi: f64, unit: &str) -> Check {
        let u = if unit.is_empty() {
            String::new()
        } else {
            format!(" {unit}")
        };
        Check {
            name: name.into(),
            criterion: format!("{lo}{u} <= value <= {hi}{u}"),
            value,
            unit: unit.into(),
            pass: value.is_some_and(|v| (lo..=hi).contains(&v)),
        }
    }

    /// A check with its own criterion text and verdict.
    #[must_use]
    pub fn new(name: &str, criterion: String, value: Option<f64>, unit: &str, pass: bool) -> Check {
        Check {
            name: name.into(),
            criterion,
            value,
            unit: unit.into(),
            pass: pass && value.is_some_and(f64::is_finite),
        }
    }
}

/// A validation case: its name, what it reproduces, and how it is judged.
pub struct Case {
    /// Short name, e.g. `"rimea-01"`.
    pub id: &'static str,
    /// One line.
    pub title: &'static str,
    /// The source and its criterion, and what `Size::Quick` changes.
    pub about: &'static str,
    /// Runs the case.
    run: fn(&Options, &mut Runs) -> Result<Vec<Check>>,
}

impl std::fmt::Debug for Case {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Case").field("id", &self.id).finish()
    }
}

/// What a case reports.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CaseReport {
    /// The case's id.
    pub id: &'static str,
    /// The case's title.
    pub title: &'static str,
    /// Its checks, the wall check last.
    pub checks: Vec<Check>,
    /// Whether every check passed.
    pub pass: bool,
    /// Simulated steps over all of the case's runs.
    pub steps: u64,
    /// Simulated agent-steps over all of the case's runs.
    pub agent_steps: u64,
    /// Measured curves (the fundamental diagram, J/b against b, ...), for plots.
    pub series: Vec<Series>,
    /// Against measured crowds (the `exp-*` cases): per density bin or width, the measured
    /// value beside the experiment's and the relative error.
    pub errors: Vec<BinError>,
}

/// One bin of a comparison with an experiment: the measured value against the experiment's.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BinError {
    /// What is compared, e.g. `"speed (m/s) by Voronoi density (1/m^2)"`.
    pub quantity: String,
    /// The bin's lower end (inclusive), or the width for a bottleneck.
    pub lo: f64,
    /// The bin's upper end (exclusive), or the width for a bottleneck.
    pub hi: f64,
    /// The experiment's value (the mean of its samples in the bin).
    pub reference: f64,
    /// The experiment's samples in the bin.
    pub reference_samples: usize,
    /// The simulation's value (`None` without samples).
    pub measured: Option<f64>,
    /// The simulation's samples in the bin.
    pub samples: usize,
    /// `(measured - reference) / reference`.
    pub relative_error: Option<f64>,
}

/// A measured curve of a case.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Series {
    /// What it shows.
    pub name: String,
    /// The x axis' label with its unit.
    pub x: String,
    /// The y axis' label with its unit.
    pub y: String,
    /// The points `[x, y]`.
    pub points: Vec<[f64; 2]>,
}

/// The case named `id`.
///
/// # Errors
/// [`Error::Invalid`] naming the known cases when there is none.
pub fn case(id: &str) -> Result<&'static Case> {
    CASES
        .iter()
        .find(|c| c.id == id)
        .ok_or_else(|| Error::Invalid {
            name: "validate".into(),
            reason: format!(
                "no case `{id}`; the cases are {}",
                CASES.iter().map(|c| c.id).collect::<Vec<_>>().join(", ")
            ),
        })
}

/// Runs `case` with `options`, on the current rayon pool.
///
/// # Errors
/// A scenario that does not build or a step that fails (a defect: the shipped scenarios are
/// valid).
pub fn run_case(case: &Case, options: &Options) -> Result<CaseReport> {
    let mut runs = Runs::default();
    let mut checks = (case.run)(options, &mut runs)?;
    checks.push(Check::new(
        "moves through a wall",
        "none, checked every step of every run".into(),
        Some(runs.wall_crossings as f64),
        "",
        runs.wall_crossings == 0,
    ));
    Ok(CaseReport {
        id: case.id,
        title: case.title,
        pass: checks.iter().all(|c| c.pass),
        checks,
        steps: runs.steps,
        agent_steps: runs.agent_steps,
        series: runs.series,
        errors: runs.errors,
    })
}

/// The totals of a case's runs.
#[derive(Debug, Default)]
pub struct Runs {
    wall_crossings: u64,
    steps: u64,
    agent_steps: u64,
    series: Vec<Series>,
    errors: Vec<BinError>,
}

/// A validation scenario by file name (without `.toml`) from `scenarios/validation/`.
///
/// # Errors
/// [`Error::Invalid`] for an unknown name; the parser's errors (a defect).
pub fn scenario(name: &str) -> Result<Scenario> {
    let text = cases::SCENARIOS
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, t)| *t)
        .ok_or_else(|| Error::Invalid {
            name: "validate".into(),
            reason: format!("no validation scenario `{name}`"),
        })?;
    Scenario::from_toml(text, &format!("scenarios/validation/{name}.toml"))
}

/// The names of the validation scenarios, as files under `scenarios/validation/`.
#[must_use]
pub fn scenario_names() -> Vec<&'static str> {
    cases::SCENARIOS.iter().map(|(n, _)| *n).collect()
}

/// What one run of a scenario saw.
#[derive(Debug)]
pub struct Outcome {
    /// The measurements' summary.
    pub report: MeasurementReport,
    /// Every crossing of every measurement line: `(line, agent id, time, sign)`.
    pub crossings: Vec<(usize, u32, f64, i8)>,
    /// World time at the end of the run, s.
    pub time: f64,
    /// The time at which the last agent left through an exit (`None`: not emptied).
    pub evacuation_time: Option<f64>,
    /// Agents still in the world at the end.
    pub inside: usize,
    /// Agents that left through exits.
    pub left: u64,
    /// Per observed frame in the measurement window, when the scenario measures Voronoi
    /// densities: the time and each area's values (the samples of a fundamental diagram).
    pub area_frames: Vec<(f64, Vec<crate::measure::AreaFrame>)>,
    /// Per agent id: the time at which it first stood more than [`MOVED`] from where it
    /// started (`None`: it never did, or it was added later).
    pub moved: Vec<Option<f64>>,
    /// The world at the end.
    pub world: World,
}

/// How far, m, an agent must be from where it started for [`Outcome::moved`] to count it.
pub const MOVED: f32 = 0.01;

/// Runs scenarios for a case: steps each until its world is empty or its `steps` are done,
/// observing the measurements and checking every move against the walls.
#[derive(Debug)]
pub struct Run<'a> {
    runs: &'a mut Runs,
    options: Options,
}

impl<'a> Run<'a> {
    /// A runner for a case's runs with `options`.
    pub fn new(runs: &'a mut Runs, options: &Options) -> Run<'a> {
        Run {
            runs,
            options: options.clone(),
        }
    }

    /// Runs `s` (with the options' model and seed) to its end.
    ///
    /// # Errors
    /// As [`Scenario::build`] and [`World::step`].
    pub fn run(&mut self, s: Scenario) -> Result<Outcome> {
        self.run_until(s, |_| false)
    }

    /// Runs `s` until its world is empty, its steps are done or `stop` holds after a step.
    ///
    /// # Errors
    /// As [`Scenario::build`] and [`World::step`].
    pub fn run_until(&mut self, mut s: Scenario, stop: impl Fn(&World) -> bool) -> Result<Outcome> {
        if let Some(model) = self.options.model {
            for g in &mut s.groups {
                if let Some(p) = &mut g.params.pedestrian {
                    p.set_model(model);
                }
            }
        }
        if !self.options.params.is_empty() {
            for g in &mut s.groups {
                if let Some(p) = &mut g.params.pedestrian {
                    *p = with_params(p, &self.options.params)?;
                }
            }
        }
        s.seed = s.seed.wrapping_add(self.options.seed_offset);
        let s = s.expanded()?;
        let mut world = s.build()?;
        let mut measure = Measurements::new(&s.measurements)?;
        measure.observe(&world);
        let mut crossings = Vec::new();
        let mut last: Vec<Option<Vec2>> = Vec::new();
        remember(&world, &mut last);
        let start = last.clone();
        let mut moved: Vec<Option<f64>> = vec![None; start.len()];
        let mut area_frames = Vec::new();
        let sampled = |t: f64| {
            s.measurements.voronoi && s.measurements.window.is_none_or(|[a, b]| a <= t && t <= b)
        };
        for _ in 0..s.steps {
            if world.is_empty() {
                break;
            }
            let n = world.len() as u64;
            world.step(s.dt)?;
            self.runs.steps += 1;
            self.runs.agent_steps += n;
            measure.observe(&world);
            if sampled(world.time()) {
                area_frames.push((world.time(), measure.area_frames().to_vec()));
            }
            crossings.extend(
                measure
                    .crossings()
                    .iter()
                    .map(|c| (c.line, c.id.0, c.time, c.sign)),
            );
            self.runs.wall_crossings += wall_crossings(&world, &last);
            remember(&world, &mut last);
            for (m, (p, s)) in moved.iter_mut().zip(last.iter().zip(&start)) {
                if let (None, Some(p), Some(s)) = (*m, p, s)
                    && p.distance(*s) > MOVED
                {
                    *m = Some(world.time());
                }
            }
            if stop(&world) {
                break;
            }
        }
        Ok(Outcome {
            report: measure.report(),
            crossings,
            time: world.time(),
            evacuation_time: measure.evacuation_time(),
            inside: world.len(),
            left: measure.left(),
            area_frames,
            moved,
            world,
        })
    }
}

/// `p` with the dotted `params` set (keys inside the `pedestrian` table), validated.
///
/// The keys are set in the table a scenario file would hold ([`PedestrianTable`]), whose every
/// model's table is checked, so `social_force.tau=-1` is refused for a cfsm group too; the
/// group keeps its model, and the parameters of the model it uses.
///
/// # Errors
/// [`Error::Invalid`] naming a key that leads nowhere or a value of the wrong kind; the
/// parameters' own checks ([`PedestrianTable::validate`]).
pub fn with_params(p: &Pedestrian, params: &[(String, toml::Value)]) -> Result<Pedestrian> {
    let invalid = |key: &str, reason: String| Error::Invalid {
        name: format!("pedestrian.{key}"),
        reason,
    };
    let mut table = match toml::Value::try_from(PedestrianTable::from(*p)) {
        Ok(toml::Value::Table(t)) => t,
        Ok(_) | Err(_) => {
            return Err(invalid("", "the parameters do not form a table".into()));
        }
    };
    for (key, value) in params {
        crate::scenario::set_path(&mut table, key, value.clone())?;
    }
    let out: PedestrianTable =
        toml::Value::Table(table)
            .try_into()
            .map_err(|e: toml::de::Error| {
                let keys: Vec<&str> = params.iter().map(|(k, _)| k.as_str()).collect();
                invalid(&keys.join(", "), e.message().to_string())
            })?;
    out.validate()?;
    Ok(out.into())
}

/// Each agent's position by id.
fn remember(world: &World, last: &mut Vec<Option<Vec2>>) {
    let a = world.agents();
    last.clear();
    last.resize(a.ids_issued(), None);
    for (i, id) in a.ids().iter().enumerate() {
        last[id.0 as usize] = Some(a.position(i));
    }
}

/// The agents whose move from `last` crosses a wall or ends outside the walkable area.
fn wall_crossings(world: &World, last: &[Option<Vec2>]) -> u64 {
    let a = world.agents();
    let obstacles = world.obstacles();
    let area = world.walkable();
    let mut n = 0;
    for (i, id) in a.ids().iter().enumerate() {
        let p = a.position(i);
        let crossed = last
            .get(id.0 as usize)
            .copied()
            .flatten()
            .is_some_and(|from| obstacles.crosses_wall(from, p));
        let outside = area.is_some_and(|w| !w.contains(p));
        n += u64::from(crossed || outside);
    }
    n
}

/// The flow over the middle 60% of the first crossings of each agent (as JuPedSim's
/// bottleneck peer measures it with PedPy's N-t diagram): `(k1 - k0) / (t_k1 - t_k0)` with
/// `k0 = floor(0.2 n)`, `k1 = ceil(0.8 n) - 1`, persons per second; `None` below 10 crossings.
#[must_use]
pub fn middle_flow(crossings: &[(usize, u32, f64, i8)], line: usize) -> Option<f64> {
    let mut first: Vec<(u32, f64)> = Vec::new();
    for &(l, id, t, _) in crossings {
        if l == line && !first.iter().any(|&(i, _)| i == id) {
            first.push((id, t));
        }
    }
    let mut times: Vec<f64> = first.iter().map(|&(_, t)| t).collect();
    times.sort_by(f64::total_cmp);
    let n = times.len();
    if n < 10 {
        return None;
    }
    let k0 = (0.2 * n as f64).floor() as usize;
    let k1 = ((0.8 * n as f64).ceil() as usize).saturating_sub(1);
    let span = times[k1] - times[k0];
    (span > 0.0).then(|| (k1 - k0) as f64 / span)
}

/// Weidmann's fundamental diagram: the speed at density `rho` (persons/m^2) for the free speed
/// 1.34 m/s, `1.34 (1 - exp(-1.913 (1 / rho - 1 / 5.4)))`, 0 at and above 5.4.
#[must_use]
pub fn weidmann(rho: f64) -> f64 {
    if rho <= 0.0 {
        return 1.34;
    }
    (1.34 * (1.0 - (-1.913 * (1.0 / rho - 1.0 / 5.4)).exp())).max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weidmann_by_hand() {
        assert!(
            (weidmann(1.0) - 1.34 * (1.0 - (-1.913f64 * (1.0 - 1.0 / 5.4)).exp())).abs() < 1e-12
        );
        assert!((weidmann(2.0) - 0.6066).abs() < 1e-3);
        assert_eq!(weidmann(6.0), 0.0);
        assert_eq!(weidmann(0.0), 1.34);
    }

    #[test]
    fn middle_flow_counts_first_crossings_between_the_20_and_80_percent_ones() {
        // 11 agents crossing once every 0.5 s, agent 3 crossing back and again later.
        let mut c: Vec<(usize, u32, f64, i8)> =
            (0..11).map(|k| (0, k, f64::from(k) * 0.5, 1)).collect();
        c.push((0, 3, 9.0, -1));
        c.push((1, 20, 0.1, 1));
        // n = 11: k0 = 2, k1 = 8: 6 gaps over 3 s.
        assert_eq!(middle_flow(&c, 0), Some(2.0));
        assert_eq!(middle_flow(&c, 1), None);
    }

    #[test]
    fn the_wall_check_counts_moves_across_a_wall() {
        let s = Scenario::from_toml(
            "[obstacles]\nwalls = [{ a = [5, 0], b = [5, 10] }]\n\
             [[groups]]\ncount = 1\nspawn = { kind = \"points\", points = [[4, 5]] }\n",
            "<test>",
        )
        .unwrap();
        let world = s.build().unwrap();
        assert_eq!(wall_crossings(&world, &[Some(Vec2::new(4.5, 5.0))]), 0);
        assert_eq!(wall_crossings(&world, &[Some(Vec2::new(6.0, 5.0))]), 1);
        assert_eq!(wall_crossings(&world, &[None]), 0);
    }

    #[test]
    fn every_case_has_a_unique_id_and_its_scenarios_parse() {
        let mut ids: Vec<&str> = CASES.iter().map(|c| c.id).collect();
        ids.sort_unstable();
        ids.dedup();
        assert_eq!(ids.len(), CASES.len());
        for name in scenario_names() {
            let s = scenario(name).unwrap();
            assert_eq!(s.name, name);
            s.validate().unwrap();
        }
        assert!(case("nope").is_err());
        assert!(scenario("nope").is_err());
    }
}
