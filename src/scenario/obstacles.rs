//! Scenario keys for obstacles and gravity points.

use glam::Vec2;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result, finite_vec, non_negative, positive};
use crate::gravity::GravityPoint;
use crate::obstacles::{Circle, Wall};
use crate::world::World;

/// The `[obstacles]` table.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ObstacleSpec {
    /// Circles: `{ center = [x, y], radius = r }`.
    pub circles: Vec<Circle>,
    /// Walls: `{ a = [x, y], b = [x, y] }`.
    pub walls: Vec<Wall>,
    /// Polygons (walls along their edges): `{ points = [[x, y], ...], closed = true }`.
    pub polygons: Vec<PolygonSpec>,
    /// Circles placed at random from the scenario's seed.
    pub random_circles: Option<RandomCircles>,
}

/// A polyline of walls.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PolygonSpec {
    /// Corner points.
    pub points: Vec<Vec2>,
    /// Whether the last point joins the first. Default: true.
    #[serde(default = "yes")]
    pub closed: bool,
}

fn yes() -> bool {
    true
}

/// Random circles in a region, none overlapping a keep-clear disc.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RandomCircles {
    /// How many.
    pub count: usize,
    /// Smallest radius (> 0).
    pub min_radius: f32,
    /// Largest radius (>= `min_radius`).
    pub max_radius: f32,
    /// Lower corner of the region the centres fall in.
    pub min: Vec2,
    /// Upper corner of that region.
    pub max: Vec2,
    /// Discs `{ center = [x, y], radius = r }` that circles must stay out of (spawn areas,
    /// targets). Default: none.
    #[serde(default)]
    pub keep_clear: Vec<Circle>,
}

/// The `[gravity]` table: anti-gravity points.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GravitySpec {
    /// Points: `{ position = [x, y], strength = s, exponent = n, radius = r, motion = {...} }`.
    pub points: Vec<GravityPoint>,
    /// Points placed at random from the scenario's seed.
    pub random: Option<RandomGravity>,
}

/// Random static gravity points in a region.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RandomGravity {
    /// How many.
    pub count: usize,
    /// Strength of each (positive repels).
    pub strength: f32,
    /// Exponent of each. Default: 2.
    #[serde(default = "two")]
    pub exponent: f32,
    /// Cut-off of each (> 0).
    pub radius: f32,
    /// Lower corner of the region.
    pub min: Vec2,
    /// Upper corner of the region.
    pub max: Vec2,
    /// Discs points must stay out of. Default: none.
    #[serde(default)]
    pub keep_clear: Vec<Circle>,
}

fn two() -> f32 {
    2.0
}

/// Checks a count against its ceiling.
pub(crate) fn at_most(name: &'static str, n: usize, max: usize, range: &'static str) -> Result<()> {
    if n > max {
        return Err(Error::OutOfRange {
            name,
            value: n as f64,
            range,
        });
    }
    Ok(())
}

fn region(min: Vec2, max: Vec2) -> Result<()> {
    finite_vec("region.min", min)?;
    finite_vec("region.max", max)?;
    if min.x > max.x || min.y > max.y {
        return Err(Error::Invalid {
            name: "region".into(),
            reason: "min must not exceed max".into(),
        });
    }
    Ok(())
}

/// A point in `[min, max]` outside every keep-clear disc (grown by `margin`), or an error after
/// many tries.
fn place(
    rng: &mut ChaCha8Rng,
    min: Vec2,
    max: Vec2,
    keep_clear: &[Circle],
    margin: f32,
) -> Result<Vec2> {
    for _ in 0..10_000 {
        let p = Vec2::new(
            min.x + rng.random::<f32>() * (max.x - min.x),
            min.y + rng.random::<f32>() * (max.y - min.y),
        );
        if keep_clear
            .iter()
            .all(|c| c.center.distance(p) >= c.radius + margin)
        {
            return Ok(p);
        }
    }
    Err(Error::Invalid {
        name: "random placement".into(),
        reason: "the keep-clear discs leave no room in the region".into(),
    })
}

impl ObstacleSpec {
    /// Checks the numbers that serde does not.
    ///
    /// # Errors
    /// The variant naming the first bad value.
    pub fn validate(&self) -> Result<()> {
        if let Some(r) = &self.random_circles {
            at_most(
                "obstacles.random_circles.count",
                r.count,
                crate::limits::MAX_RANDOM_CIRCLES,
                "[0, 1000000]",
            )?;
            positive("random_circles.min_radius", r.min_radius)?;
            positive("random_circles.max_radius", r.max_radius)?;
            if r.max_radius < r.min_radius {
                return Err(Error::Invalid {
                    name: "random_circles".into(),
                    reason: "max_radius is below min_radius".into(),
                });
            }
            region(r.min, r.max)?;
        }
        Ok(())
    }

    /// Adds the obstacles to `world`, random ones drawn from `seed`.
    ///
    /// # Errors
    /// As the world's `add_circle`, `add_wall` and `add_polygon`.
    pub fn apply(&self, world: &mut World, seed: u64) -> Result<()> {
        world.add_circles(&self.circles)?;
        for w in &self.walls {
            world.add_wall(*w)?;
        }
        for p in &self.polygons {
            world.add_polygon(&p.points, p.closed)?;
        }
        world.add_circles(&self.random_list(seed)?)?;
        Ok(())
    }

    /// The random circles drawn from `seed`.
    fn random_list(&self, seed: u64) -> Result<Vec<Circle>> {
        let mut circles = Vec::new();
        if let Some(r) = &self.random_circles {
            let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x0b57_ac1e);
            crate::error::try_reserve(&mut circles, r.count, "random_circles.count")?;
            for _ in 0..r.count {
                let radius = r.min_radius + rng.random::<f32>() * (r.max_radius - r.min_radius);
                let center = place(&mut rng, r.min, r.max, &r.keep_clear, radius)?;
                circles.push(Circle { center, radius });
            }
        }
        Ok(circles)
    }

    /// Draws the random circles from `seed` and lists them with the explicit ones.
    pub(crate) fn materialise(&mut self, seed: u64) -> Result<()> {
        let mut drawn = self.random_list(seed)?;
        self.circles.append(&mut drawn);
        self.random_circles = None;
        Ok(())
    }
}

impl GravitySpec {
    /// Checks the numbers that serde does not.
    ///
    /// # Errors
    /// The variant naming the first bad value.
    pub fn validate(&self) -> Result<()> {
        at_most(
            "gravity points (points and random.count)",
            self.points
                .len()
                .saturating_add(self.random.as_ref().map_or(0, |r| r.count)),
            crate::limits::MAX_GRAVITY_POINTS,
            "[0, 100000]",
        )?;
        for p in &self.points {
            p.validate()?;
        }
        if let Some(r) = &self.random {
            positive("gravity.random.radius", r.radius)?;
            non_negative("gravity.random.exponent", r.exponent)?;
            crate::error::finite("gravity.random.strength", r.strength)?;
            region(r.min, r.max)?;
        }
        Ok(())
    }

    /// Adds the gravity points to `world` (after its agents, so points may ride on them).
    ///
    /// # Errors
    /// As [`World::add_gravity_point`].
    pub fn apply(&self, world: &mut World, seed: u64) -> Result<()> {
        for p in self.points.iter().chain(&self.random_list(seed)?) {
            world.add_gravity_point(*p)?;
        }
        Ok(())
    }

    /// The random points drawn from `seed`.
    fn random_list(&self, seed: u64) -> Result<Vec<GravityPoint>> {
        let mut points = Vec::new();
        if let Some(r) = &self.random {
            let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x9a71_7e5d);
            crate::error::try_reserve(&mut points, r.count, "gravity.random.count")?;
            for _ in 0..r.count {
                let position = place(&mut rng, r.min, r.max, &r.keep_clear, 0.0)?;
                points.push(GravityPoint::fixed(
                    position, r.strength, r.exponent, r.radius,
                ));
            }
        }
        Ok(points)
    }

    /// Draws the random points from `seed` and lists them with the explicit ones.
    pub(crate) fn materialise(&mut self, seed: u64) -> Result<()> {
        let mut drawn = self.random_list(seed)?;
        self.points.append(&mut drawn);
        self.random = None;
        Ok(())
    }
}
