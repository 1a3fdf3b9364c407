//! [`Scenario::validate`]: every value of a parsed scenario against its range, and the keys
//! that need one another (a `uniform` spawn needs a walled or wrapped world, `free_cells` a
//! `[field]`).
//!
//! Invariant: the checks run in the file's order and stop at the first bad value, whose error
//! names its key with the path into the scenario (`groups[2].max_speed`, `exits[0]`).

use glam::Vec2;

use crate::error::{Error, Result, finite, finite_vec, non_negative, positive};

use super::{AgentGoal, Scenario, Spawn, WorldKind, WorldSpec};

/// An error of group `i`'s table, its message led by the group's path (`groups[0]`).
fn in_group<T>(i: usize, r: Result<T>) -> Result<T> {
    r.map_err(|e| at_path(format!("groups[{i}]"), e))
}

/// `e` as an error of the scenario key at `path`: "invalid groups[0]: orca.time_horizon must
/// ...". Errors that already name their place (a scenario or map file's) stay as they are.
pub(super) fn at_path(path: String, e: Error) -> Error {
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

impl Scenario {
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
            if f.map == crate::scenario::MapSource::Walkable && self.geometry.is_none() {
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
        self.world.validate()?;
        for (i, g) in self.groups.iter().enumerate() {
            in_group(i, g.params.validate())?;
            in_group(i, non_negative("initial_speed", g.initial_speed))?;
            in_group(i, self.check_spawn(&g.spawn))?;
            if let Spawn::Spread { min, max, distance } = &g.spawn {
                // An impossible request fails here, before any agent is placed.
                in_group(
                    i,
                    crate::spawn::spread_fits(g.count_of(), *min, *max, *distance),
                )?;
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
        self.check_journeys()
    }
    /// Checks a group's spawn region and that the scenario has what it needs (a walled or
    /// wrapped world or a walkable area for `uniform`, a `[layout]`, a `[field]`).
    ///
    /// # Errors
    /// The variant naming the `spawn` key.
    fn check_spawn(&self, spawn: &Spawn) -> Result<()> {
        match spawn {
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
        Ok(())
    }
}

impl WorldSpec {
    /// Checks the world's size keys, and that a torus or bounded world has one.
    ///
    /// # Errors
    /// The variant naming the `world.` key.
    fn validate(&self) -> Result<()> {
        if let Some(d) = &self.density {
            positive("world.density.neighbours", d.neighbours)?;
            positive("world.density.radius", d.radius)?;
        }
        if let Some(rho) = self.agents_per_area {
            positive("world.agents_per_area", rho)?;
        }
        if let Some(size) = self.size {
            positive("world.size", size.x)?;
            positive("world.size", size.y)?;
        }
        if self.kind != WorldKind::Open
            && self.size.is_none()
            && self.density.is_none()
            && self.agents_per_area.is_none()
        {
            return Err(Error::Invalid {
                name: "world.size".into(),
                reason: "a torus or bounded world needs `size`, `density` or `agents_per_area`"
                    .into(),
            });
        }
        Ok(())
    }
}
