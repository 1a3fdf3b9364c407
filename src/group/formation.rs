//! Formation shapes, their slots in the anchor's local frame, and steering to a moving slot.
//!
//! Slots are offsets in the anchor's local frame (x forward along its heading, y to its left; see
//! [`crate::steering::Basis`]). Generated shapes are laid out for exactly the number of members,
//! so a formation that loses or gains members re-forms without gaps; a custom shape fills its
//! offsets in the order given. The layouts are pure functions of `(shape, n, spacing)`.

use std::f32::consts::{PI, TAU};

use glam::Vec2;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result, finite_vec, non_negative, positive};
use crate::vector::{predict_position, truncate};

/// The index of a formation added to a world with `World::add_formation`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(transparent)]
pub struct FormationId(pub u32);

/// The shape of a formation. In scenario files: `"line"`, `"column"`, `"wedge"`, `"circle"`,
/// `"box"` or `{ custom = [[x, y], ...] }`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FormationShape {
    /// Side by side, centred on the reference point (a rank).
    #[default]
    Line,
    /// One behind the other, the first on the reference point (a file).
    Column,
    /// A V: the first member on the reference point, the others alternately behind-left and
    /// behind-right.
    Wedge,
    /// Evenly on a circle around the reference point (neighbours `spacing` apart, radius at least
    /// `spacing`), the first slot straight behind.
    Circle,
    /// Rows of `ceil(sqrt(n))`, the first row on the reference point, the last row centred.
    Box,
    /// Given offsets (local frame, before `spacing`-independent `offset` is added), filled in order.
    Custom(Vec<Vec2>),
}

/// A formation's layout parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FormationParams {
    /// The shape. Default: line.
    pub shape: FormationShape,
    /// Distance between neighbouring slots (> 0; unused by custom shapes). Default: 2.
    pub spacing: f32,
    /// The shape's reference point in the anchor's local frame (x forward, y left); `[-3, 0]`
    /// puts the formation 3 units behind its anchor. Default: `[0, 0]`.
    pub offset: Vec2,
    /// Re-run the slot assignment every this many frames (0: only when members join or leave).
    /// Default: 0.
    pub reassign_every: u64,
}

impl Default for FormationParams {
    fn default() -> Self {
        FormationParams {
            shape: FormationShape::Line,
            spacing: 2.0,
            offset: Vec2::ZERO,
            reassign_every: 0,
        }
    }
}

impl FormationParams {
    /// Checks the numbers and that the shape has slots.
    ///
    /// # Errors
    /// [`Error::NotPositive`] for a bad spacing, [`Error::NonFinite`] for a bad offset,
    /// [`Error::Invalid`] for a custom shape without offsets.
    pub fn validate(&self) -> Result<()> {
        positive("formation.spacing", self.spacing)?;
        finite_vec("formation.offset", self.offset)?;
        if let FormationShape::Custom(offsets) = &self.shape {
            if offsets.is_empty() {
                return Err(Error::Invalid {
                    name: "formation.shape".into(),
                    reason: "a custom formation needs at least one slot offset".into(),
                });
            }
            for o in offsets {
                finite_vec("formation.custom", *o)?;
            }
        }
        Ok(())
    }

    /// The most members the shape holds (`usize::MAX` for generated shapes).
    #[must_use]
    pub fn capacity(&self) -> usize {
        match &self.shape {
            FormationShape::Custom(o) => o.len(),
            _ => usize::MAX,
        }
    }

    /// The `n` slots of the formation in the anchor's local frame, `offset` included.
    ///
    /// # Errors
    /// [`Error::Invalid`] when a custom shape has fewer than `n` offsets.
    pub fn slots(&self, n: usize) -> Result<Vec<Vec2>> {
        if n > self.capacity() {
            return Err(Error::Invalid {
                name: "formation".into(),
                reason: format!(
                    "{n} members but the custom shape has {} slots",
                    self.capacity()
                ),
            });
        }
        let mut v = slot_offsets(&self.shape, n, self.spacing);
        for s in &mut v {
            *s += self.offset;
        }
        Ok(v)
    }
}

/// The first `n` slots of `shape` with neighbours `spacing` apart, in the local frame (x forward,
/// y left), without the formation's offset. A custom shape gives at most its own offsets.
#[must_use]
pub fn slot_offsets(shape: &FormationShape, n: usize, spacing: f32) -> Vec<Vec2> {
    let centred = |k: usize, count: usize| ((count as f32 - 1.0) * 0.5 - k as f32) * spacing;
    match shape {
        FormationShape::Line => (0..n).map(|k| Vec2::new(0.0, centred(k, n))).collect(),
        FormationShape::Column => (0..n)
            .map(|k| Vec2::new(-(k as f32) * spacing, 0.0))
            .collect(),
        FormationShape::Wedge => (0..n)
            .map(|k| {
                let rank = k.div_ceil(2) as f32;
                let side = if k % 2 == 1 { 1.0 } else { -1.0 };
                Vec2::new(-rank * spacing, side * rank * spacing)
            })
            .collect(),
        FormationShape::Circle => {
            let radius = if n >= 2 {
                (spacing / (2.0 * (PI / n as f32).sin())).max(spacing)
            } else {
                spacing
            };
            (0..n)
                .map(|k| Vec2::from_angle(PI + TAU * k as f32 / n as f32) * radius)
                .collect()
        }
        FormationShape::Box => {
            let cols = (n as f32).sqrt().ceil().max(1.0) as usize;
            (0..n)
                .map(|k| {
                    let (row, col) = (k / cols, k % cols);
                    let in_row = cols.min(n - row * cols);
                    Vec2::new(-(row as f32) * spacing, centred(col, in_row))
                })
                .collect()
        }
        FormationShape::Custom(offsets) => offsets.iter().take(n).copied().collect(),
    }
}

/// How a member (or a leader's follower) steers to its moving slot.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SlotParams {
    /// Within this distance of the slot only the slot's velocity is matched (>= 0; 0: the
    /// approach is proportional all the way in). Default: 0.
    pub target_radius: f32,
    /// Within this distance the approach speed scales down linearly (> 0). Default: 3.
    pub slow_radius: f32,
    /// Seconds over which the wanted velocity is reached, dynamic model (> 0). Default: 0.2.
    pub time_to_target: f32,
    /// Longest look-ahead when predicting where the slot will be, seconds (>= 0). Default: 0.5.
    pub max_prediction: f32,
}

impl Default for SlotParams {
    fn default() -> Self {
        SlotParams {
            target_radius: 0.0,
            slow_radius: 3.0,
            time_to_target: 0.2,
            max_prediction: 0.5,
        }
    }
}

impl SlotParams {
    /// Checks the numbers.
    ///
    /// # Errors
    /// [`Error::Negative`], [`Error::NotPositive`] or [`Error::NonFinite`].
    pub fn validate(&self) -> Result<()> {
        non_negative("slot.target_radius", self.target_radius)?;
        positive("slot.slow_radius", self.slow_radius)?;
        positive("slot.time_to_target", self.time_to_target)?;
        non_negative("slot.max_prediction", self.max_prediction)?;
        Ok(())
    }
}

/// Offset pursuit of a moving slot, as a desired velocity: the slot's own velocity (velocity
/// matching) plus an arrive-style approach to where the slot will be when the agent could reach
/// it at full speed (`distance / max_speed`, at most `max_prediction` seconds ahead). On a
/// straight run the approach term vanishes as the agent settles, so it rides on its slot
/// without lag; the look-ahead shrinks with the distance, so it adds no offset there.
#[must_use]
pub fn slot_velocity(
    position: Vec2,
    slot: Vec2,
    slot_velocity: Vec2,
    max_speed: f32,
    p: &SlotParams,
) -> Vec2 {
    let predicted = if p.max_prediction > 0.0 {
        predict_position(position, max_speed, slot, slot_velocity, p.max_prediction)
    } else {
        slot
    };
    let to = predicted - position;
    let dist = to.length();
    let approach = if dist <= p.target_radius {
        Vec2::ZERO
    } else {
        to * (max_speed * (dist / p.slow_radius).min(1.0) / dist)
    };
    truncate(slot_velocity + approach, max_speed)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn min_gap(s: &[Vec2]) -> f32 {
        let mut g = f32::INFINITY;
        for i in 0..s.len() {
            for j in i + 1..s.len() {
                g = g.min(s[i].distance(s[j]));
            }
        }
        g
    }

    #[test]
    fn shapes_have_n_distinct_slots_spacing_apart() {
        for shape in [
            FormationShape::Line,
            FormationShape::Column,
            FormationShape::Wedge,
            FormationShape::Circle,
            FormationShape::Box,
        ] {
            for n in 1..20 {
                let s = slot_offsets(&shape, n, 2.0);
                assert_eq!(s.len(), n);
                if n > 1 {
                    assert!(min_gap(&s) >= 2.0 - 1e-3, "{shape:?} {n}: {}", min_gap(&s));
                }
            }
        }
        assert_eq!(
            slot_offsets(&FormationShape::Line, 3, 2.0),
            vec![Vec2::new(0.0, 2.0), Vec2::ZERO, Vec2::new(0.0, -2.0)]
        );
    }

    #[test]
    fn custom_shapes_fill_in_order_and_need_slots() {
        let p = FormationParams {
            shape: FormationShape::Custom(vec![Vec2::X, Vec2::Y]),
            offset: Vec2::new(-1.0, 0.0),
            ..FormationParams::default()
        };
        assert_eq!(p.slots(1).unwrap(), vec![Vec2::ZERO]);
        assert!(p.slots(3).is_err());
        let empty = FormationParams {
            shape: FormationShape::Custom(vec![]),
            ..FormationParams::default()
        };
        assert!(matches!(empty.validate(), Err(Error::Invalid { .. })));
    }

    #[test]
    fn settled_member_matches_slot_velocity() {
        let v = slot_velocity(Vec2::ZERO, Vec2::ZERO, Vec2::X, 3.0, &SlotParams::default());
        assert_eq!(v, Vec2::X);
    }
}
