//! Scenario files: a whole simulation described in TOML, and the built-in scenarios.
//!
//! A scenario names the world (bounds, size or a target density, or a walkable area as WKT
//! in `[geometry]`), the groups (how many agents,
//! where they spawn, their movement model, limits and behaviours), the seed, the time step and the
//! number of steps, and the stages and journeys its pedestrians walk. Unknown keys are errors, reported with the file, line and column. The
//! built-in scenarios are the TOML files of the repository's `scenarios/` folder, embedded in the
//! crate; `docs/SCENARIOS.md` documents every key.
//!
//! Agent counts scale: `--agents N` (or [`Scenario::with_agents`]) shares `N` among the groups in
//! proportion to their `count`s, except groups marked `fixed`; with `world.scale = "tiles"` the
//! whole scenario is repeated side by side instead (`tiles`).
//!
//! Values can be changed before parsing by dotted paths into the table
//! ([`Scenario::from_toml_with`], `overrides`), so that a sweep validates every variant exactly
//! as a file.

mod builtin;
mod fields;
mod geometry;
mod group;
mod layout;
mod obstacles;
mod overrides;
mod spec;
mod tiles;
mod transform;

pub use builtin::{BUILTIN, builtin, builtin_names, builtin_text};
pub use fields::{FieldSpec, GoalSpec, MapSource, WalkerSpec};
pub use geometry::GeometrySpec;
pub use group::{AgentRef, FormationSpec, Members};
pub use layout::Layout;
pub use obstacles::{GravitySpec, ObstacleSpec, PolygonSpec, RandomCircles, RandomGravity};
pub use overrides::set_path;
pub use spec::{
    AgentGoal, DensitySpec, GroupSpec, JourneySpec, Scenario, Spawn, StageSpec, TransitionKind,
    TransitionSpec, WorldKind, WorldScale, WorldSpec,
};
pub use transform::PlaneMap;
