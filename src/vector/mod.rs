//! Vector helpers that steering, group movement and obstacles share: a vehicle's local frame
//! ([`Basis`]), truncation of a request to a maximum length ([`truncate`],
//! [`truncate_robust`]) and the predicted meeting point of a pursuit ([`predict_position`]).
//!
//! A leaf: it depends on nothing else in the crate, so that [`crate::steering`] and
//! [`crate::group`] can both use it without depending on each other through it.
//! [`crate::steering`] re-exports every item.

use glam::Vec2;

mod basis;

pub use basis::Basis;

/// [`truncate`] for requests that may have overflowed: infinite components keep their direction
/// at length `max`, a square length that overflows is rescaled first, and NaN components (an
/// undefined request) give zero.
#[must_use]
pub fn truncate_robust(v: Vec2, max: f32) -> Vec2 {
    if v.is_nan() {
        return Vec2::ZERO;
    }
    if !v.is_finite() {
        let dir = Vec2::new(
            if v.x.is_infinite() { v.x.signum() } else { 0.0 },
            if v.y.is_infinite() { v.y.signum() } else { 0.0 },
        );
        return dir.normalize_or_zero() * max;
    }
    let len_sq = v.length_squared();
    if len_sq.is_finite() {
        return if len_sq > max * max {
            v * (max / len_sq.sqrt())
        } else {
            v
        };
    }
    // Finite components whose square overflows: rescale before measuring.
    (v / v.abs().max_element()).normalize_or_zero() * max
}

/// Returns `v` shortened to at most `max` (unchanged when already shorter).
#[inline]
#[must_use]
pub fn truncate(v: Vec2, max: f32) -> Vec2 {
    let len_sq = v.length_squared();
    if len_sq > max * max {
        if len_sq.is_finite() {
            v * (max / len_sq.sqrt())
        } else {
            truncate_robust(v, max)
        }
    } else {
        v
    }
}

/// Where a target moving at `target_velocity` will be when an agent at `position` moving at
/// `speed` could reach it: the prediction time is `distance / speed`, capped at `max_prediction`
/// seconds (Millington's pursue).
#[inline]
#[must_use]
pub fn predict_position(
    position: Vec2,
    speed: f32,
    target: Vec2,
    target_velocity: Vec2,
    max_prediction: f32,
) -> Vec2 {
    let distance = (target - position).length();
    let t = if speed <= distance / max_prediction {
        max_prediction
    } else {
        distance / speed
    };
    target + target_velocity * t
}
