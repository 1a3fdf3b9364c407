//! A scenario as its file states it, in child modules by concern: the schema of its tables
//! (`schema`), reading it from TOML (`parse`), the checks of every value (`validate`), agent
//! counts and the world's size (`scale`), a `[layout]` written out (`expand`), the memory
//! estimate (`memory`), the build of a [`World`](crate::world::World) (`build`), the placement
//! of its agents (`spawn`), and the stages and journeys its groups walk (`stages`: their schema;
//! `journeys`: their checks and build).
//!
//! Invariant: a scenario is validated whole before anything is built, and the error names
//! the first bad key with its path (`groups[2].spawn.count`).

mod build;
mod expand;
mod journeys;
mod memory;
mod parse;
mod scale;
mod schema;
mod spawn;
mod stages;
mod validate;

pub use schema::{
    AgentGoal, DensitySpec, GroupSpec, Scenario, Spawn, WorldKind, WorldScale, WorldSpec,
};
pub use stages::{JourneySpec, StageSpec, TransitionKind, TransitionSpec};
