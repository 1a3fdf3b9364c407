//! Agent counts and the world's size: the total count, scaling to `--agents N`
//! ([`Scenario::with_agents`]) and the bounds, which a `density` or `agents_per_area` key
//! derives from the count.
//!
//! Invariants: scaling by counts keeps fixed groups (and `points` spawns) as written and gives
//! every other group at least one agent, the shares summing to exactly `N`; a derived world
//! side never exceeds [`MAX_DERIVED_SIDE`](crate::limits::MAX_DERIVED_SIDE).

use glam::Vec2;

use crate::bounds::Bounds;
use crate::error::{Error, Result};

use super::{GroupSpec, Scenario, Spawn, WorldKind, WorldScale};

impl Scenario {
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
