//! The scenario's schema: [`Scenario`] and the types of its tables (world, groups, spawn
//! regions, agent goals), with their defaults and how a group's table splits into placement
//! keys and profile keys.
//!
//! Invariant: every table rejects unknown keys, the group's table included (its placement keys
//! and its profile keys are read apart, as serde's `flatten` would ignore unknown keys).

use glam::Vec2;
use serde::{Deserialize, Serialize};

use crate::scenario::fields::FieldSpec;
use crate::scenario::layout::Layout;
use crate::scenario::{FormationSpec, GeometrySpec, GravitySpec, ObstacleSpec};
use crate::spatial::IndexKind;
use crate::world::Profile;

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
    pub formations: Vec<FormationSpec>,
    /// Obstacles: circles, walls, polygons, random circles. Default: none.
    #[serde(default)]
    pub obstacles: ObstacleSpec,
    /// Anti-gravity points. Default: none.
    #[serde(default)]
    pub gravity: GravitySpec,
    /// A grid field (goal channels, walls, walkers). Default: none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub field: Option<FieldSpec>,
    /// Exits: `{ min = [x, y], max = [x, y] }` rectangles or `{ polygon = "POLYGON (...)" }`
    /// through which agents leave the world. Default: none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub exits: Vec<crate::world::Exit>,
    /// A generated pedestrian geometry (`kind = "corridor"` or `"bottleneck"`), written out as
    /// walls, exits and a field when the world is built. Default: none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layout: Option<Layout>,
    /// Measurement lines and areas and the summary's time window (`[measurements]`).
    /// Default: none.
    #[serde(default, skip_serializing_if = "no_measurements")]
    pub measurements: crate::measure::MeasurementSpec,
    /// The walkable area (`[geometry] walkable = "POLYGON (...)"`). Default: none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub geometry: Option<GeometrySpec>,
    /// Stages (`[[stages]]`): waypoints, exits, queues, waiting sets and direct steering
    /// stages, named for the journeys. Default: none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub stages: Vec<super::StageSpec>,
    /// Journeys (`[[journeys]]`): stages chained by transitions, which groups walk with
    /// their `journey` key. Default: none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub journeys: Vec<super::JourneySpec>,
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
    /// The journey the group's agents walk, by name. With it, the profile's defaults are
    /// those of [`Profile::journey_walkers`](crate::profile::Profile::journey_walkers) of the
    /// group's pedestrian model. Default: none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub journey: Option<String>,
    /// The stage of the journey the agents start at, by name. Default: the journey's first.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stage: Option<String>,
    /// The profile.
    #[serde(flatten)]
    pub params: Profile,
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
    #[serde(default)]
    journey: Option<String>,
    #[serde(default)]
    stage: Option<String>,
}

impl<'de> Deserialize<'de> for GroupSpec {
    /// Splits the table into placement keys and profile keys so that both reject unknown keys
    /// (serde's `flatten` would silently ignore them).
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        use serde::de::Error as _;
        let mut table = toml::Table::deserialize(d)?;
        let mut placement = toml::Table::new();
        for key in [
            "count",
            "fixed",
            "spawn",
            "initial_speed",
            "goal",
            "journey",
            "stage",
        ] {
            if let Some(v) = table.remove(key) {
                placement.insert(key.to_string(), v);
            }
        }
        let p = GroupPlacement::deserialize(toml::Value::Table(placement))
            .map_err(|e| D::Error::custom(e.message()))?;
        if p.journey.is_some() {
            // A group on a journey starts from the journey walkers' profile of its model.
            let model = table
                .get("pedestrian")
                .and_then(|p| p.get("model"))
                .and_then(toml::Value::as_str)
                .and_then(crate::ped::Model::parse)
                .unwrap_or_default();
            let mut base = toml::Table::try_from(crate::profile::Profile::journey_walkers(model))
                .map_err(|e| D::Error::custom(e.to_string()))?;
            merge(&mut base, table);
            table = base;
        }
        let params = Profile::deserialize(toml::Value::Table(table))
            .map_err(|e| D::Error::custom(e.message()))?;
        Ok(GroupSpec {
            count: p.count,
            fixed: p.fixed,
            spawn: p.spawn,
            initial_speed: p.initial_speed,
            goal: p.goal,
            journey: p.journey,
            stage: p.stage,
            params,
        })
    }
}

/// `over` written onto `base`, key by key: tables merged, anything else replaced.
fn merge(base: &mut toml::Table, over: toml::Table) {
    for (k, v) in over {
        match (base.get_mut(&k), v) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            (_, v) => {
                base.insert(k, v);
            }
        }
    }
}

impl GroupSpec {
    /// The number of agents this group spawns.
    #[must_use]
    pub fn count_of(&self) -> usize {
        match &self.spawn {
            Spawn::Points { points } => points.len(),
            _ => self.count,
        }
    }
}
