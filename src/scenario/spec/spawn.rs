//! Spawning: where each group's agents start (every [`Spawn`] kind), their initial heading and
//! speed, and their own goals or journeys.
//!
//! Invariants: each group draws from its own random stream, derived from the seed and the
//! group's index, so adding a group changes no other group's positions; explicitly placed
//! agents (points, circle, grid, spread) must lie in the world and clear of obstacles, or the
//! build fails naming the group; random spawns that land in an obstacle are drawn again, at
//! most 1,000 times.

use std::f32::consts::PI;

use glam::Vec2;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::agents::AgentInit;
use crate::bounds::Bounds;
use crate::error::{Error, Result};
use crate::world::World;

use super::{GroupSpec, Scenario, Spawn};

impl Scenario {
    /// Spawns every group's agents into `world`, group by group in order, each group from its
    /// own random stream of the seed, and sets their goals.
    ///
    /// # Errors
    /// [`Error::Invalid`] naming the group's `spawn` when an agent cannot be placed: outside
    /// the world, in an obstacle or wall, or no room left for a `spread` spawn.
    pub(super) fn spawn_agents(&self, world: &mut World, bounds: Bounds) -> Result<()> {
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
                                && crate::scenario::geometry::spawn_ok(world, p, g.params.radius)
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
                    _ => g.spawn_point(&mut rng, bounds, world, &mut free_cells)?,
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
                if placed && !crate::scenario::geometry::spawn_ok(world, position, radius) {
                    return Err(crate::scenario::geometry::spawn_error(
                        world, gi, k, position, radius,
                    ));
                }
                // Random spawns that land inside an obstacle (or, with a walkable area, outside
                // it or within the agent's radius of a wall) are drawn again.
                let mut tries = 0;
                while !placed
                    && (world.obstacles().inside_circle(position)
                        || !crate::scenario::geometry::spawn_ok(world, position, radius))
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
                        bounds.wrap(g.spawn_point(&mut rng, bounds, world, &mut free_cells)?);
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
                if let Some((journey, stage)) = self.journey_of(g) {
                    world.set_journey(id, journey, stage).map_err(|e| {
                        super::validate::at_path(format!("groups[{gi}].journey"), e)
                    })?;
                }
            }
        }
        Ok(())
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
            Spawn::FreeCells => crate::scenario::fields::free_point(world, rng, free_cells)?,
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
}
