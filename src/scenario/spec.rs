//! A scenario as its file states it ([`Scenario`] and the types of its tables), the checks
//! of every value against its range and ceiling, the memory estimate, and the build of a
//! [`World`] from it.
//!
//! Invariant: a scenario is validated whole before anything is built, and the error names
//! the first bad key with its path (`groups[2].spawn.count`).

use std::f32::consts::PI;
use std::path::Path;

use glam::Vec2;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::agents::AgentInit;
use crate::bounds::Bounds;
use crate::error::{Error, Result, finite, finite_vec, non_negative, positive};
use crate::spatial::IndexKind;
use crate::world::{GroupParams, World};

/// A whole simulation, as read from a TOML file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Short name. Default: the file stem.
    #[serde(default)]
    pub name: String,
    /// One line for `throng list`. Default: empty.
    #[serde(default)]
    pub description: String,
    /// Seed of all randomness (spawn positions, wander). Default: 1.
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Time step, seconds (> 0). Default: 1/30.
    #[serde(default = "default_dt")]
    pub dt: f32,
    /// Steps to run. Default: 300.
    #[serde(default = "default_steps")]
    pub steps: u64,
    /// The world.
    #[serde(default)]
    pub world: WorldSpec,
    /// The groups, in order (group index = position in this list).
    pub groups: Vec<GroupSpec>,
    /// Paths that `follow_path` behaviours name by index. Default: none.
    #[serde(default)]
    pub paths: Vec<crate::group::Path>,
    /// Shared target slots (`{ slot = N }` in a behaviour's target names the `N`-th).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub targets: Vec<crate::targets::TargetPoint>,
    /// Formations, added once every agent has spawned. Default: none.
    #[serde(default)]
    pub formations: Vec<super::FormationSpec>,
    /// Obstacles: circles, walls, polygons, random circles. Default: none.
    #[serde(default)]
    pub obstacles: super::ObstacleSpec,
    /// Anti-gravity points. Default: none.
    #[serde(default)]
    pub gravity: super::GravitySpec,
    /// A grid field (goal channels, walls, walkers). Default: none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub field: Option<super::fields::FieldSpec>,
    /// Exits: `{ min = [x, y], max = [x, y] }` rectangles or `{ polygon = "POLYGON (...)" }`
    /// through which agents leave the world. Default: none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub exits: Vec<crate::world::Exit>,
    /// A generated pedestrian geometry (`kind = "corridor"` or `"bottleneck"`), written out as
    /// walls, exits and a field when the world is built. Default: none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layout: Option<super::layout::Layout>,
    /// Measurement lines and areas and the summary's time window (`[measurements]`).
    /// Default: none.
    #[serde(default, skip_serializing_if = "no_measurements")]
    pub measurements: crate::measure::MeasurementSpec,
    /// The walkable area (`[geometry] walkable = "POLYGON (...)"`). Default: none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub geometry: Option<super::GeometrySpec>,
}

fn no_measurements(m: &crate::measure::MeasurementSpec) -> bool {
    *m == crate::measure::MeasurementSpec::default()
}

fn default_seed() -> u64 {
    1
}
fn default_dt() -> f32 {
    1.0 / 30.0
}
fn default_steps() -> u64 {
    300
}

/// The world's shape.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WorldSpec {
    /// `"torus"`, `"bounded"` or `"open"`. Default: open.
    pub kind: WorldKind,
    /// Width and height. Required for torus and bounded worlds unless `density` is given.
    pub size: Option<Vec2>,
    /// Size the (square) world from the agent count so that the density stays fixed.
    pub density: Option<DensitySpec>,
    /// Size the (square) world from the agent count for this many agents per unit area (> 0),
    /// as the Vicsek model states its density. Used when neither `size` nor `density` is given.
    pub agents_per_area: Option<f32>,
    /// Neighbour-index backend: `"grid"`, `"kdtree"` or `"brute"`. Default: grid.
    pub index: IndexKind,
    /// Reorder agents by grid cell every this many frames (0: never). Default: 4.
    pub reorder_every: Option<u32>,
    /// How `--agents` scales the scenario: `"counts"` (the groups' counts, in proportion) or
    /// `"tiles"` (copies of the whole scenario side by side, so density and squad sizes stay).
    /// Default: counts.
    pub scale: WorldScale,
}

/// How a scenario grows with `--agents` ([`Scenario::with_agents`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WorldScale {
    /// The groups' counts grow in proportion, in the same world (or one sized by `density`).
    #[default]
    Counts,
    /// The scenario is repeated on a grid of copies of its world, each with its share.
    Tiles,
}

/// The kind of world.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WorldKind {
    /// Unbounded plane.
    #[default]
    Open,
    /// Walled rectangle.
    Bounded,
    /// Wrap-around rectangle.
    Torus,
}

/// A density target: the world grows with the agent count so that each agent has about
/// `neighbours` others within `radius` (area = N * pi * radius^2 / neighbours).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DensitySpec {
    /// Mean neighbours within `radius` (> 0).
    pub neighbours: f32,
    /// The radius (> 0).
    pub radius: f32,
}

/// Where a group's agents start.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Spawn {
    /// Uniformly over the whole world (torus or bounded worlds only).
    #[default]
    Uniform,
    /// Uniformly in a rectangle.
    Rect {
        /// Lower corner.
        min: Vec2,
        /// Upper corner.
        max: Vec2,
    },
    /// Uniformly in a disc.
    Disc {
        /// Centre.
        center: Vec2,
        /// Radius (>= 0).
        radius: f32,
    },
    /// At these points, in order (the group's count is the number of points).
    Points {
        /// The points.
        points: Vec<Vec2>,
    },
    /// Uniformly over the free cells of the scenario's `[field]`.
    FreeCells,
    /// On a lattice: agent `k` at `origin + (k mod columns, k div columns) * spacing` (with
    /// `transpose`, `(k div columns, k mod columns)`), so the block grows by rows with the count.
    Grid {
        /// The first agent's position.
        origin: Vec2,
        /// The step along x and along y; negative steps grow the other way.
        spacing: Vec2,
        /// Agents per row (> 0): along x, or along y with `transpose`.
        columns: usize,
        /// Rows run along y and grow along x. Default: false.
        #[serde(default)]
        transpose: bool,
    },
    /// Uniformly at random in a rectangle, every agent at least `distance` from the agents
    /// placed before it by a `spread` spawn of any group (dart throwing, as JuPedSim's
    /// `distribute_by_number`); an error when no room is found.
    Spread {
        /// Lower corner.
        min: Vec2,
        /// Upper corner.
        max: Vec2,
        /// The smallest distance between centres (>= 0).
        distance: f32,
    },
    /// In the area of the scenario's `[layout]`, as `spread` with 0.45 m between agents and
    /// 0.25 m from the walls.
    Layout,
    /// Evenly on a circle, agent `k` of `n` at the angle `k * 2 pi / n` from +x (RVO2's Circle
    /// example). With `per`, the radius grows with the count: `radius * n / per`, so the
    /// spacing stays that of `per` agents on a circle of `radius`.
    Circle {
        /// Centre.
        center: Vec2,
        /// Radius (>= 0).
        radius: f32,
        /// The count at which the radius is `radius` (> 0). Default: none (fixed radius).
        #[serde(default)]
        per: Option<usize>,
    },
}

/// Each agent's own target point (`goal` in a group's table), which `target = "own"` seeks
/// and an `arrival_radius` counts arrivals at.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum AgentGoal {
    /// The start position mirrored through `center` (default the origin): crossing a circle.
    Antipode {
        /// The centre of the mirror.
        #[serde(default)]
        center: Vec2,
    },
    /// One point for every agent of the group.
    Point {
        /// The point.
        point: Vec2,
    },
    /// The start position moved by `by`: a stream crossing the world.
    Offset {
        /// The displacement.
        by: Vec2,
    },
}

impl AgentGoal {
    /// The goal of an agent that starts at `start`.
    #[must_use]
    pub fn of(&self, start: Vec2) -> Vec2 {
        match *self {
            AgentGoal::Antipode { center } => center * 2.0 - start,
            AgentGoal::Point { point } => point,
            AgentGoal::Offset { by } => start + by,
        }
    }

    /// Moves the goal with a scenario tile.
    pub(crate) fn shift(&mut self, offset: Vec2) {
        match self {
            AgentGoal::Antipode { center } => *center += offset,
            AgentGoal::Point { point } => *point += offset,
            AgentGoal::Offset { .. } => {}
        }
    }
}

/// Agent `k` of `n` evenly on a circle, as [`Spawn::Circle`] places it.
fn circle_point(center: Vec2, radius: f32, per: Option<usize>, k: usize, n: usize) -> Vec2 {
    let r = match per {
        Some(per) => radius * n as f32 / per as f32,
        None => radius,
    };
    let angle = k as f32 * std::f32::consts::TAU * (1.0 / n as f32);
    center + Vec2::new(angle.cos(), angle.sin()) * r
}

/// One group: its count, spawn region and profile. The profile's keys (`model`, `max_speed`,
/// `steering`, ...) sit directly in the group's table; unknown keys are errors.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GroupSpec {
    /// Number of agents at the scenario's default size. Default: 1.
    #[serde(default = "default_count")]
    pub count: usize,
    /// Whether `--agents` leaves this group's count alone (a single leader, say). Default: false.
    #[serde(default)]
    pub fixed: bool,
    /// Where the agents start. Default: uniform over the world.
    #[serde(default)]
    pub spawn: Spawn,
    /// Initial speed, in a random direction (>= 0). Default: 0.
    #[serde(default)]
    pub initial_speed: f32,
    /// Each agent's own target point. Default: none (the start position).
    #[serde(default)]
    pub goal: Option<AgentGoal>,
    /// The profile.
    #[serde(flatten)]
    pub params: GroupParams,
}

fn default_count() -> usize {
    1
}

/// The keys of a group's table that are not profile keys.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct GroupPlacement {
    #[serde(default = "default_count")]
    count: usize,
    #[serde(default)]
    fixed: bool,
    #[serde(default)]
    spawn: Spawn,
    #[serde(default)]
    initial_speed: f32,
    #[serde(default)]
    goal: Option<AgentGoal>,
}

impl<'de> Deserialize<'de> for GroupSpec {
    /// Splits the table into placement keys and profile keys so that both reject unknown keys
    /// (serde's `flatten` would silently ignore them).
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        use serde::de::Error as _;
        let mut table = toml::Table::deserialize(d)?;
        let mut placement = toml::Table::new();
        for key in ["count", "fixed", "spawn", "initial_speed", "goal"] {
            if let Some(v) = table.remove(key) {
                placement.insert(key.to_string(), v);
            }
        }
        let p = GroupPlacement::deserialize(toml::Value::Table(placement))
            .map_err(|e| D::Error::custom(e.message()))?;
        let params = GroupParams::deserialize(toml::Value::Table(table))
            .map_err(|e| D::Error::custom(e.message()))?;
        Ok(GroupSpec {
            count: p.count,
            fixed: p.fixed,
            spawn: p.spawn,
            initial_speed: p.initial_speed,
            goal: p.goal,
            params,
        })
    }
}

/// Checks that every number of a parsed scenario except a `seed` has a magnitude of at most
/// [`MAX_NUMBER`](crate::limits::MAX_NUMBER); the error names the key.
fn check_numbers(table: &toml::Table, prefix: &str) -> std::result::Result<(), String> {
    fn walk(v: &toml::Value, key: &str) -> std::result::Result<(), String> {
        let max = crate::limits::MAX_NUMBER;
        let over = |shown: String| {
            Err(format!(
                "{key} = {shown} lies beyond 1e18, the ceiling of every number in a scenario file"
            ))
        };
        match v {
            toml::Value::Float(f) if f.is_finite() && f.abs() > max => over(f.to_string()),
            toml::Value::Integer(i) if (*i as f64).abs() > max && !key.ends_with("seed") => {
                over(i.to_string())
            }
            toml::Value::Array(a) => a
                .iter()
                .enumerate()
                .try_for_each(|(k, v)| walk(v, &format!("{key}[{k}]"))),
            toml::Value::Table(t) => check_numbers(t, key),
            _ => Ok(()),
        }
    }
    table.iter().try_for_each(|(k, v)| {
        let key = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        walk(v, &key)
    })
}

/// An error of group `i`'s table, its message led by the group's path (`groups[0]`).
fn in_group<T>(i: usize, r: Result<T>) -> Result<T> {
    r.map_err(|e| at_path(format!("groups[{i}]"), e))
}

/// `e` as an error of the scenario key at `path`: "invalid groups[0]: orca.time_horizon must
/// ...". Errors that already name their place (a scenario or map file's) stay as they are.
fn at_path(path: String, e: Error) -> Error {
    match e {
        Error::Scenario { .. } | Error::MapParse { .. } | Error::Io { .. } => e,
        Error::Invalid { name, reason } if name.starts_with("groups[") => {
            Error::Invalid { name, reason }
        }
        other => Error::Invalid {
            name: path,
            reason: other.to_string(),
        },
    }
}

/// Checks that no group's `pedestrian` table holds the parameters of a model the group does
/// not use (a `social_force` table under `model = "cfsm"`, the default, was silently ignored);
/// the error names the key. Only the file as written is checked, so `--pedestrian-model` may
/// still switch a group to the other model's defaults.
fn check_model_tables(table: &toml::Table) -> std::result::Result<(), String> {
    let Some(groups) = table.get("groups").and_then(toml::Value::as_array) else {
        return Ok(());
    };
    for (i, g) in groups.iter().enumerate() {
        let Some(p) = g.get("pedestrian").and_then(toml::Value::as_table) else {
            continue;
        };
        let model = p
            .get("model")
            .and_then(toml::Value::as_str)
            .and_then(crate::ped::Model::parse)
            .unwrap_or_default();
        for other in [crate::ped::Model::SocialForce, crate::ped::Model::Cfsm] {
            if other != model && p.contains_key(other.name()) {
                return Err(format!(
                    "groups[{i}].pedestrian.{}: the group's pedestrian model is {}, which does not read this table (set `model = \"{}\"` or remove the table)",
                    other.name(),
                    model.name(),
                    other.name()
                ));
            }
        }
    }
    Ok(())
}

/// Byte offset to 1-based (line, column).
pub(crate) fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before
        .rfind('\n')
        .map_or(before.len(), |nl| before.len() - nl - 1)
        + 1;
    (line, col)
}

impl Scenario {
    /// Parses a scenario from TOML text; `source_name` names it in errors.
    ///
    /// # Errors
    /// [`Error::Scenario`] with line and column for a syntax error, an unknown key or a bad
    /// value; the variant naming the parameter for an out-of-range number.
    pub fn from_toml(text: &str, source_name: &str) -> Result<Self> {
        let mut s: Scenario = toml::from_str(text).map_err(|e| Error::Scenario {
            source_name: source_name.to_string(),
            location: e.span().map(|sp| line_col(text, sp.start)),
            message: e.message().trim().to_string(),
        })?;
        if let Ok(table) = toml::from_str::<toml::Table>(text) {
            check_numbers(&table, "")
                .and_then(|()| check_model_tables(&table))
                .map_err(|message| Error::Scenario {
                    source_name: source_name.to_string(),
                    location: None,
                    message,
                })?;
        }
        if let Some(f) = &mut s.field {
            f.resolve_paths(source_name);
        }
        if s.name.is_empty() {
            s.name = Path::new(source_name)
                .file_stem()
                .map(|f| f.to_string_lossy().into_owned())
                .unwrap_or_default();
        }
        s.validate().map_err(|e| match e {
            Error::Scenario { .. } => e,
            other => Error::Scenario {
                source_name: source_name.to_string(),
                location: None,
                message: other.to_string(),
            },
        })?;
        Ok(s)
    }

    /// Reads and parses a scenario file of at most
    /// [`MAX_SCENARIO_BYTES`](crate::limits::MAX_SCENARIO_BYTES) (larger files are refused
    /// before they are read).
    ///
    /// # Errors
    /// [`Error::Io`] when the file cannot be read or is too large, otherwise as
    /// [`Scenario::from_toml`].
    pub fn load(path: &Path) -> Result<Self> {
        let text =
            crate::limits::read_text(path, crate::limits::MAX_SCENARIO_BYTES, "scenario files")?;
        Self::from_toml(&text, &path.display().to_string())
    }

    /// Checks every value.
    ///
    /// # Errors
    /// The variant naming the first bad value.
    pub fn validate(&self) -> Result<()> {
        positive("dt", self.dt)?;
        crate::error::in_range(
            "dt",
            self.dt,
            crate::limits::MIN_DT,
            crate::error::MAX_DT,
            "[1e-6, 1e6]",
        )?;
        if self.agent_count() > crate::error::MAX_AGENTS {
            return Err(Error::OutOfRange {
                name: "count",
                value: self.agent_count() as f64,
                range: "at most 100000000 agents in all",
            });
        }
        self.obstacles.validate()?;
        self.gravity.validate()?;
        if let Some(f) = &self.field {
            f.validate()?;
            if f.map == super::MapSource::Walkable && self.geometry.is_none() {
                return Err(Error::Invalid {
                    name: "field.map".into(),
                    reason: "the walkable raster (the map when `map` is not given) needs `[geometry] walkable`".into(),
                });
            }
        }
        if self.groups.is_empty() {
            return Err(Error::Invalid {
                name: "groups".into(),
                reason: "a scenario needs at least one group".into(),
            });
        }
        if let Some(d) = &self.world.density {
            positive("world.density.neighbours", d.neighbours)?;
            positive("world.density.radius", d.radius)?;
        }
        if let Some(rho) = self.world.agents_per_area {
            positive("world.agents_per_area", rho)?;
        }
        if let Some(size) = self.world.size {
            positive("world.size", size.x)?;
            positive("world.size", size.y)?;
        }
        if self.world.kind != WorldKind::Open
            && self.world.size.is_none()
            && self.world.density.is_none()
            && self.world.agents_per_area.is_none()
        {
            return Err(Error::Invalid {
                name: "world.size".into(),
                reason: "a torus or bounded world needs `size`, `density` or `agents_per_area`"
                    .into(),
            });
        }
        for (i, g) in self.groups.iter().enumerate() {
            in_group(i, g.params.validate())?;
            in_group(i, non_negative("initial_speed", g.initial_speed))?;
            match &g.spawn {
                Spawn::Uniform if self.world.kind == WorldKind::Open && self.geometry.is_none() => {
                    return Err(Error::Invalid {
                        name: "spawn".into(),
                        reason: "uniform spawn needs a torus or bounded world".into(),
                    });
                }
                Spawn::Rect { min, max } => {
                    for v in [min.x, min.y, max.x, max.y] {
                        finite("spawn.rect", v)?;
                    }
                    if min.x > max.x || min.y > max.y {
                        return Err(Error::Invalid {
                            name: "spawn.rect".into(),
                            reason: "min must not exceed max".into(),
                        });
                    }
                }
                Spawn::Disc { center, radius } => {
                    finite("spawn.center", center.x)?;
                    finite("spawn.center", center.y)?;
                    non_negative("spawn.radius", *radius)?;
                }
                Spawn::Points { points } => {
                    for p in points {
                        finite("spawn.points", p.x)?;
                        finite("spawn.points", p.y)?;
                    }
                }
                Spawn::Grid {
                    origin,
                    spacing,
                    columns,
                    ..
                } => {
                    finite_vec("spawn.origin", *origin)?;
                    finite_vec("spawn.spacing", *spacing)?;
                    if *columns == 0 {
                        return Err(Error::NotPositive {
                            name: "spawn.columns",
                            value: 0.0,
                        });
                    }
                }
                Spawn::Circle {
                    center,
                    radius,
                    per,
                } => {
                    finite("spawn.center", center.x)?;
                    finite("spawn.center", center.y)?;
                    non_negative("spawn.radius", *radius)?;
                    if *per == Some(0) {
                        return Err(Error::NotPositive {
                            name: "spawn.per",
                            value: 0.0,
                        });
                    }
                }
                Spawn::Spread { min, max, distance } => {
                    finite_vec("spawn.min", *min)?;
                    finite_vec("spawn.max", *max)?;
                    non_negative("spawn.distance", *distance)?;
                    crate::error::in_range("spawn.distance", *distance, 0.0, 1e6, "[0, 1e6]")?;
                    if min.x > max.x || min.y > max.y {
                        return Err(Error::Invalid {
                            name: "spawn".into(),
                            reason: "min must not exceed max".into(),
                        });
                    }
                    // An impossible request fails here, before any agent is placed.
                    in_group(
                        i,
                        crate::spawn::spread_fits(g.count_of(), *min, *max, *distance),
                    )?;
                }
                Spawn::Layout if self.layout.is_none() => {
                    return Err(Error::Invalid {
                        name: "spawn".into(),
                        reason: "`kind = \"layout\"` needs a [layout] table".into(),
                    });
                }
                Spawn::Uniform | Spawn::Layout => {}
                Spawn::FreeCells if self.field.is_none() => {
                    return Err(Error::Invalid {
                        name: "spawn".into(),
                        reason: "`free_cells` spawning needs a `[field]`".into(),
                    });
                }
                Spawn::FreeCells => {}
            }
        }
        for (i, g) in self.groups.iter().enumerate() {
            in_group(
                i,
                match g.goal {
                    Some(AgentGoal::Antipode { center }) => finite_vec("goal.center", center),
                    Some(AgentGoal::Point { point }) => finite_vec("goal.point", point),
                    Some(AgentGoal::Offset { by }) => finite_vec("goal.by", by),
                    None => Ok(Vec2::ZERO),
                },
            )?;
        }
        for f in &self.formations {
            f.validate(self.groups.len())?;
        }
        for (k, e) in self.exits.iter().enumerate() {
            e.validate()
                .map_err(|e| at_path(format!("exits[{k}]"), e))?;
        }
        if let Some(l) = &self.layout {
            l.validate()?;
        }
        self.measurements.validate()?;
        if let Some(g) = &self.geometry {
            g.check_world(self.bounds()?)?;
        }
        Ok(())
    }

    /// The total agent count at the scenario's own size.
    #[must_use]
    pub fn agent_count(&self) -> usize {
        self.groups
            .iter()
            .map(GroupSpec::count_of)
            .fold(0usize, usize::saturating_add)
    }

    /// The same scenario scaled to `total` agents: scalable groups share what the fixed ones leave,
    /// in proportion to their counts (each keeps at least one agent); with
    /// `world.scale = "tiles"`, copies of the whole scenario side by side, each with its share.
    ///
    /// # Errors
    /// [`Error::NotPositive`] for `total == 0`; [`Error::Invalid`] when `total` is smaller than
    /// the fixed groups need.
    pub fn with_agents(mut self, total: usize) -> Result<Self> {
        if total == 0 {
            return Err(Error::NotPositive {
                name: "agents",
                value: 0.0,
            });
        }
        if total > crate::error::MAX_AGENTS {
            return Err(Error::OutOfRange {
                name: "agents",
                value: total as f64,
                range: "[1, 100000000]",
            });
        }
        if self.world.scale == WorldScale::Tiles {
            return self.tiled(total);
        }
        let fixed: usize = self
            .groups
            .iter()
            .filter(|g| g.fixed || matches!(g.spawn, Spawn::Points { .. }))
            .map(GroupSpec::count_of)
            .fold(0usize, usize::saturating_add);
        let scalable: Vec<usize> = self
            .groups
            .iter()
            .enumerate()
            .filter(|(_, g)| !(g.fixed || matches!(g.spawn, Spawn::Points { .. })))
            .map(|(i, _)| i)
            .collect();
        if scalable.is_empty() {
            if total == fixed {
                return Ok(self);
            }
            return Err(Error::Invalid {
                name: "agents".into(),
                reason: format!(
                    "every group of this scenario has a fixed count ({fixed} agents in all); scale it by editing the file"
                ),
            });
        }
        if total < fixed.saturating_add(scalable.len()) {
            return Err(Error::Invalid {
                name: "agents".into(),
                reason: format!(
                    "{total} is too few: this scenario needs at least {}",
                    fixed + scalable.len()
                ),
            });
        }
        let left = total - fixed;
        let weight = scalable
            .iter()
            .map(|&i| self.groups[i].count.max(1) as f64)
            .sum::<f64>();
        let mut given = 0;
        for (k, &i) in scalable.iter().enumerate() {
            let n = if k + 1 == scalable.len() {
                left - given
            } else {
                ((left as f64 * self.groups[i].count.max(1) as f64 / weight).round() as usize)
                    .clamp(1, left - given - (scalable.len() - k - 1))
            };
            self.groups[i].count = n;
            given += n;
        }
        Ok(self)
    }

    /// The world's bounds for the current agent count. With a `[geometry]` and a `[world]`
    /// that is open without a size, the walled world `[0, max]` of the area's bounding box
    /// when the area lies at non-negative coordinates, otherwise the open plane (the area's
    /// walls hold the agents either way).
    ///
    /// # Errors
    /// As [`Bounds::torus`] for a bad size; [`Error::OutOfRange`] when `density` or
    /// `agents_per_area` would make a side longer than
    /// [`MAX_DERIVED_SIDE`](crate::limits::MAX_DERIVED_SIDE).
    pub fn bounds(&self) -> Result<Bounds> {
        let size = match (
            self.world.size,
            self.world.density,
            self.world.agents_per_area,
        ) {
            (Some(s), _, _) => s,
            (None, Some(d), _) => {
                let area = self.agent_count() as f64
                    * std::f64::consts::PI
                    * f64::from(d.radius)
                    * f64::from(d.radius)
                    / f64::from(d.neighbours);
                derived_side("world.density", area.sqrt().max(f64::from(d.radius)))?
            }
            (None, None, Some(rho)) => derived_side(
                "world.agents_per_area",
                (self.agent_count() as f64 / f64::from(rho)).sqrt(),
            )?,
            (None, None, None) => Vec2::ZERO,
        };
        if let Some(g) = &self.geometry
            && self.world.kind == WorldKind::Open
            && size == Vec2::ZERO
        {
            // The walls of the area hold the agents; a walled world to its bounding box also
            // gives `uniform` spawns and `containment` their rectangle.
            let (min, max) = (g.walkable.min(), g.walkable.max());
            if min.x >= 0.0 && min.y >= 0.0 {
                return Bounds::bounded(max.x, max.y);
            }
            return Ok(Bounds::Open);
        }
        match self.world.kind {
            WorldKind::Open => Ok(Bounds::Open),
            WorldKind::Bounded => Bounds::bounded(size.x, size.y),
            WorldKind::Torus => Bounds::torus(size.x, size.y),
        }
    }

    /// An estimate of the memory the built world will need, bytes: agents at
    /// [`BYTES_PER_AGENT`](crate::limits::BYTES_PER_AGENT), field cells and their channels,
    /// obstacles and gravity points, plus [`BASE_BYTES`](crate::limits::BASE_BYTES).
    #[must_use]
    pub fn memory_estimate(&self) -> u64 {
        use crate::limits::{BASE_BYTES, BYTES_PER_AGENT, BYTES_PER_CELL, BYTES_PER_CHANNEL_CELL};
        let agents = (self.agent_count() as u64).saturating_mul(BYTES_PER_AGENT);
        let field = self.field.as_ref().map_or(0, |f| {
            let per_cell = BYTES_PER_CELL + f.channels.len() as u64 * BYTES_PER_CHANNEL_CELL;
            f.cell_estimate(self.geometry.as_ref().map(|g| &g.walkable))
                .saturating_mul(per_cell)
        });
        let obstacles = (self.obstacles.circles.len()
            + self.obstacles.walls.len()
            + self
                .obstacles
                .polygons
                .iter()
                .map(|p| p.points.len())
                .sum::<usize>()
            + self
                .obstacles
                .random_circles
                .as_ref()
                .map_or(0, |r| r.count)
            + self
                .geometry
                .as_ref()
                .map_or(0, |g| g.walkable.vertex_count())
            + self
                .exits
                .iter()
                .filter_map(|e| e.polygon.as_ref())
                .map(crate::geometry::Walkable::vertex_count)
                .sum::<usize>()
            + self.gravity.points.len()
            + self.gravity.random.as_ref().map_or(0, |r| r.count)) as u64;
        BASE_BYTES
            .saturating_add(agents)
            .saturating_add(field)
            .saturating_add(obstacles.saturating_mul(64))
    }

    /// Builds the world: groups, then agents spawned group by group from the seed. The memory
    /// estimate is checked first against the tightest bound this process runs under (the
    /// machine's available memory, `ulimit -v`, the control group's limit:
    /// [`crate::limits::memory_ceiling`]), where known.
    ///
    /// # Errors
    /// The variant naming the first bad value (a spawn region outside the world, say);
    /// [`Error::OutOfMemory`] when the estimate exceeds that bound, naming it.
    pub fn build(&self) -> Result<World> {
        self.build_under(crate::limits::memory_ceiling())
    }

    /// [`Scenario::build`] with the memory estimate checked against `memory` bytes (`None`:
    /// not checked).
    ///
    /// # Errors
    /// As [`Scenario::build`].
    pub fn build_within(&self, memory: Option<u64>) -> Result<World> {
        self.build_under(memory.map(crate::limits::MemoryCeiling::given))
    }

    /// [`Scenario::build`] with the memory estimate checked against `ceiling` (`None`: not
    /// checked).
    ///
    /// # Errors
    /// As [`Scenario::build`].
    pub fn build_under(&self, ceiling: Option<crate::limits::MemoryCeiling>) -> Result<World> {
        if self.layout.is_some() {
            return self.expanded()?.build_under(ceiling);
        }
        self.validate()?;
        if let Some(ceiling) = ceiling {
            crate::limits::check_memory_under(
                &format!("scenario {}", self.name),
                self.memory_estimate(),
                ceiling,
            )?;
        }
        let bounds = self.bounds()?;
        let mut world = World::builder().bounds(bounds).seed(self.seed).build()?;
        world.set_index(self.world.index);
        if let Some(k) = self.world.reorder_every {
            world.set_reorder_every(k);
        }
        for (k, t) in self.targets.iter().enumerate() {
            world
                .add_target_point(*t)
                .map_err(|e| at_path(format!("targets[{k}]"), e))?;
        }
        for p in &self.paths {
            world.add_path(p.clone())?;
        }
        self.obstacles.apply(&mut world, self.seed)?;
        if let Some(g) = &self.geometry {
            world.set_walkable(g.walkable.clone())?;
        }
        for e in &self.exits {
            world.add_exit(e.clone())?;
        }
        for g in &self.groups {
            world.add_group(g.params.clone())?;
        }
        let field = match &self.field {
            Some(f) => Some(f.add_to(&mut world, self.seed)?),
            None => None,
        };
        if let (Some(f), Some(id)) = (&self.field, field) {
            f.check_walkers(&world, id, &self.groups)?;
        }
        world.try_reserve_agents(self.agent_count())?;
        let mut spread = crate::spawn::Spread::default();
        let mut free_cells = None;
        for (gi, g) in self.groups.iter().enumerate() {
            let mut rng = ChaCha8Rng::seed_from_u64(
                self.seed ^ (0x5eed_0000_u64 + gi as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15),
            );
            let n = g.count_of();
            for k in 0..n {
                let position = match &g.spawn {
                    Spawn::Points { points } => points[k],
                    &Spawn::Circle {
                        center,
                        radius,
                        per,
                    } => circle_point(center, radius, per, k, n),
                    &Spawn::Grid {
                        origin,
                        spacing,
                        columns,
                        transpose,
                    } => {
                        let (along, across) = ((k % columns) as f32, (k / columns) as f32);
                        let cell = if transpose {
                            Vec2::new(across, along)
                        } else {
                            Vec2::new(along, across)
                        };
                        origin + cell * spacing
                    }
                    &Spawn::Spread { min, max, distance } => {
                        // Draws outside the circles and, with a walkable area, inside it and
                        // clear of its walls: a draw in a hole is drawn again.
                        let accept = |p: Vec2| {
                            !world.obstacles().inside_circle(p)
                                && super::geometry::spawn_ok(&world, p, g.params.radius)
                        };
                        spread.place(&mut rng, (min, max), distance, accept)
                            .ok_or_else(|| Error::Invalid {
                                name: format!("groups[{gi}].spawn"),
                                reason: format!(
                                    "no room for agent {k} of {n} at {distance} from the others in [{}, {}] x [{}, {}]",
                                    min.x, max.x, min.y, max.y
                                ),
                            })?
                    }
                    _ => g.spawn_point(&mut rng, bounds, &world, &mut free_cells)?,
                };
                // A walled world has no room outside it, and explicit points must be in the world;
                // random regions on a torus wrap around.
                let placed = matches!(
                    g.spawn,
                    Spawn::Points { .. }
                        | Spawn::Circle { .. }
                        | Spawn::Grid { .. }
                        | Spawn::Spread { .. }
                );
                let strict = matches!(bounds, Bounds::Bounded { .. }) || placed;
                if strict && !bounds.contains(position) {
                    return Err(Error::Invalid {
                        name: format!("groups[{gi}].spawn"),
                        reason: format!(
                            "({}, {}) lies outside the world {bounds:?}",
                            position.x, position.y
                        ),
                    });
                }
                let mut position = bounds.wrap(position);
                let radius = g.params.radius;
                if placed && !super::geometry::spawn_ok(&world, position, radius) {
                    return Err(super::geometry::spawn_error(
                        &world, gi, k, position, radius,
                    ));
                }
                // Random spawns that land inside an obstacle (or, with a walkable area, outside
                // it or within the agent's radius of a wall) are drawn again.
                let mut tries = 0;
                while !placed
                    && (world.obstacles().inside_circle(position)
                        || !super::geometry::spawn_ok(&world, position, radius))
                {
                    tries += 1;
                    if tries > 1000 {
                        let within = if world.walkable().is_some() {
                            " inside the walkable area, clear of its walls by the agent radius"
                        } else {
                            " outside the obstacles"
                        };
                        return Err(Error::Invalid {
                            name: format!("groups[{gi}].spawn"),
                            reason: format!("no free spot found{within} in 1000 draws"),
                        });
                    }
                    position =
                        bounds.wrap(g.spawn_point(&mut rng, bounds, &world, &mut free_cells)?);
                }
                let heading = rng.random::<f32>() * 2.0 * PI;
                let velocity = Vec2::from_angle(heading) * g.initial_speed.min(g.params.max_speed);
                let id = world.add_agent(AgentInit {
                    position,
                    velocity,
                    orientation: heading,
                    group: gi,
                    ..AgentInit::default()
                })?;
                if let Some(goal) = &g.goal {
                    world.set_target(id, goal.of(position))?;
                }
            }
        }
        self.gravity.apply(&mut world, self.seed)?;
        if !self.formations.is_empty() {
            let by_group = super::group::members_by_group(&world);
            for f in &self.formations {
                f.add_with(&mut world, &by_group)?;
            }
        }
        if let (Some(f), Some(id)) = (&self.field, field) {
            f.finish(&mut world, id)?;
        }
        Ok(world)
    }
}

/// A square world of side `side`, derived from a density key.
fn derived_side(name: &'static str, side: f64) -> Result<Vec2> {
    let max = crate::limits::MAX_DERIVED_SIDE;
    if !(side.is_finite() && side <= f64::from(max)) {
        return Err(Error::OutOfRange {
            name,
            value: side,
            range: "a world side of at most 1e6 (lower the agent count or raise the density)",
        });
    }
    Ok(Vec2::splat(side as f32))
}

impl GroupSpec {
    /// A random spawn position (for [`Spawn::Points`], the first point); `free_cells` holds the
    /// index of the field's free cells once a `free_cells` spawn needed it.
    fn spawn_point(
        &self,
        rng: &mut ChaCha8Rng,
        bounds: Bounds,
        world: &World,
        free_cells: &mut Option<crate::spawn::FreeCells>,
    ) -> Result<Vec2> {
        Ok(match &self.spawn {
            Spawn::FreeCells => super::fields::free_point(world, rng, free_cells)?,
            Spawn::Uniform => match world.walkable() {
                Some(a) => crate::spawn::sample_rect(rng, a.min(), a.max()),
                None => {
                    crate::spawn::sample_rect(rng, Vec2::ZERO, bounds.size().unwrap_or(Vec2::ONE))
                }
            },
            Spawn::Rect { min, max } => crate::spawn::sample_rect(rng, *min, *max),
            Spawn::Disc { center, radius } => crate::spawn::sample_ring(rng, *center, 0.0, *radius),
            Spawn::Points { points } => points.first().copied().unwrap_or(Vec2::ZERO),
            &Spawn::Circle {
                center,
                radius,
                per,
            } => circle_point(center, radius, per, 0, self.count.max(1)),
            Spawn::Grid { origin, .. } => *origin,
            Spawn::Spread { min, max, .. } => crate::spawn::sample_rect(rng, *min, *max),
            Spawn::Layout => Vec2::ZERO,
        })
    }

    /// The number of agents this group spawns.
    #[must_use]
    pub fn count_of(&self) -> usize {
        match &self.spawn {
            Spawn::Points { points } => points.len(),
            _ => self.count,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SMALL: &str = r#"
name = "t"
[world]
kind = "torus"
size = [50, 50]
[[groups]]
count = 10
max_speed = 3
steering = { behaviours = [{ kind = "wander", weight = 1 }] }
"#;

    #[test]
    fn parses_and_scales() {
        let s = Scenario::from_toml(SMALL, "t.toml").unwrap();
        assert_eq!(s.agent_count(), 10);
        let s = s.with_agents(123).unwrap();
        assert_eq!(s.build().unwrap().len(), 123);
    }

    #[test]
    fn unknown_keys_name_line_and_column() {
        let text = SMALL.replace("max_speed = 3", "max_sped = 3");
        let err = Scenario::from_toml(&text, "t.toml").unwrap_err();
        let msg = err.to_string();
        assert!(msg.starts_with("t.toml:"), "{msg}");
        assert!(msg.contains("max_sped"), "{msg}");
        match err {
            Error::Scenario {
                location: Some((line, _)),
                ..
            } => assert!(line >= 5, "line {line}"),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn bad_values_are_errors() {
        let text = SMALL.replace("max_speed = 3", "max_speed = -3");
        let msg = Scenario::from_toml(&text, "t.toml")
            .unwrap_err()
            .to_string();
        assert!(msg.contains("max_speed"), "{msg}");
    }

    #[test]
    fn line_col_counts_from_one() {
        assert_eq!(line_col("ab\ncd", 0), (1, 1));
        assert_eq!(line_col("ab\ncd", 4), (2, 2));
    }
}
