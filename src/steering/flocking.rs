//! Reynolds flocking: separation, alignment and cohesion from neighbour sums.
//!
//! The world gathers every flocking sum of an agent in one fused neighbour traversal
//! ([`NeighbourSums`]); the functions here turn those sums into steering. Each returns the force
//! `desired_velocity - velocity` (dynamic model); [`desired`] gives the kinematic form.

use glam::Vec2;

/// Everything one fused neighbour traversal gathers for one agent.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NeighbourSums {
    /// Sum over separation neighbours of `-offset / distance^2` (away from each, weighted 1 / d).
    pub separation: Vec2,
    /// Sum of the alignment neighbours' velocities.
    pub alignment: Vec2,
    /// Number of alignment neighbours.
    pub alignment_count: f32,
    /// Sum of the offsets to the cohesion neighbours.
    pub cohesion: Vec2,
    /// Number of cohesion neighbours.
    pub cohesion_count: f32,
    /// Sum of repulsion forces (`strength / d^n` away from each neighbour).
    pub repulsion: Vec2,
    /// Neighbours within the largest query radius (all groups).
    pub count: f32,
    /// Sum of the unit velocities (the unit orientation for agents at rest) of the Vicsek
    /// neighbours, every group, the agent itself excluded.
    pub heading: Vec2,
}

/// The desired velocity of full speed along `direction` (zero for a zero direction).
#[inline]
#[must_use]
pub fn desired(direction: Vec2, max_speed: f32) -> Vec2 {
    direction.normalize_or_zero() * max_speed
}

#[inline]
fn steer_along(direction: Vec2, velocity: Vec2, max_speed: f32) -> Vec2 {
    if direction == Vec2::ZERO {
        Vec2::ZERO
    } else {
        desired(direction, max_speed) - velocity
    }
}

/// Separation force: full speed away from the crowding neighbours.
#[inline]
#[must_use]
pub fn separation(sums: &NeighbourSums, velocity: Vec2, max_speed: f32) -> Vec2 {
    steer_along(sums.separation, velocity, max_speed)
}

/// Alignment force: full speed along the neighbours' mean velocity.
#[inline]
#[must_use]
pub fn alignment(sums: &NeighbourSums, velocity: Vec2, max_speed: f32) -> Vec2 {
    if sums.alignment_count == 0.0 {
        return Vec2::ZERO;
    }
    steer_along(sums.alignment / sums.alignment_count, velocity, max_speed)
}

/// Cohesion force: full speed towards the neighbours' centre.
#[inline]
#[must_use]
pub fn cohesion(sums: &NeighbourSums, velocity: Vec2, max_speed: f32) -> Vec2 {
    if sums.cohesion_count == 0.0 {
        return Vec2::ZERO;
    }
    steer_along(sums.cohesion / sums.cohesion_count, velocity, max_speed)
}

/// The Vicsek model's new heading: the direction of `sum` (the unit velocities within the
/// radius; `+x` when they cancel out or the sum is not finite) turned by `turn` radians. A
/// rotation of the normalised sum by the turn's sine and cosine (the crate's polynomial ones),
/// the same as the unit vector at the sum's angle plus the turn, without the arctangent.
#[inline]
#[must_use]
pub fn vicsek_heading(sum: Vec2, turn: f32) -> Vec2 {
    let u = sum.try_normalize().unwrap_or(Vec2::X);
    let (s, c) = super::trig::sin_cos(turn);
    Vec2::new(u.x * c - u.y * s, u.x * s + u.y * c)
}

/// The polarisation of a set of velocities: the length of the mean unit velocity, 1 when all move
/// the same way and near 0 when headings are random. Agents at rest are left out.
#[must_use]
pub fn polarisation(vel_x: &[f32], vel_y: &[f32]) -> f32 {
    let mut sum = Vec2::ZERO;
    let mut n = 0usize;
    for (&x, &y) in vel_x.iter().zip(vel_y) {
        if let Some(u) = Vec2::new(x, y).try_normalize() {
            sum += u;
            n += 1;
        }
    }
    if n == 0 { 0.0 } else { sum.length() / n as f32 }
}
