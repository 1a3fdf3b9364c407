//! The model adapter: the one place that turns behaviour outputs into the integrator's input.
//!
//! Behaviours speak two languages. Dynamic steering functions return a **force**; kinematic ones
//! return a **desired velocity**. Some behaviours (avoidance, containment, evasion) only have a
//! force form, others (paths, formations, slots) only a desired velocity. [`Adapter`] converts
//! between the two for one profile's model, and [`Adapter::finish`] turns the combined request
//! into what the integrator reads: the desired velocity itself (kinematic), or `force / mass`
//! clamped to the maximum acceleration (dynamic), with the overflow guard that keeps a request's
//! direction at the limit when its magnitude overflowed and drops requests that are undefined.
//!
//! Invariant: the output of [`Adapter::finish`] is finite, and for the dynamic model within the
//! profile's acceleration limits.

use glam::Vec2;

use super::neighbours::LANES;
use crate::error::MAX_SPEED;
use crate::movement::MovementModel;
use crate::profile::Profile;
use crate::steering::{self, PrioritySum, Steering};

/// One profile's conversions between forces, desired velocities and the integrator's input.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Adapter {
    /// The kinematic model (desired velocities) rather than the dynamic one (forces).
    pub kinematic: bool,
    pub mass: f32,
    pub max_acceleration: f32,
    pub max_angular_acceleration: f32,
    pub max_rotation: f32,
}

impl Adapter {
    /// The adapter of a profile.
    pub(crate) fn of(p: &Profile) -> Self {
        Adapter {
            kinematic: p.model == MovementModel::Kinematic,
            mass: p.mass,
            max_acceleration: p.max_acceleration,
            max_angular_acceleration: p.max_angular_acceleration,
            max_rotation: p.max_rotation,
        }
    }

    /// A force-only behaviour's request: the force (dynamic), or the velocity it would leave the
    /// agent with (kinematic: `force + velocity`).
    #[inline]
    pub(crate) fn force_request(&self, force: Vec2, velocity: Vec2) -> Vec2 {
        if self.kinematic {
            force + velocity
        } else {
            force
        }
    }

    /// A desired velocity reached at once: itself (kinematic) or `desired - velocity` (dynamic).
    #[inline]
    pub(crate) fn toward(&self, desired: Vec2, velocity: Vec2) -> Vec2 {
        if self.kinematic {
            desired
        } else {
            desired - velocity
        }
    }

    /// A desired velocity reached in `time_to_target` seconds: itself (kinematic) or the force
    /// `(desired - velocity) * mass / time_to_target` (dynamic).
    #[inline]
    pub(crate) fn towards(&self, desired: Vec2, velocity: Vec2, time_to_target: f32) -> Steering {
        if self.kinematic {
            Steering::linear(desired)
        } else {
            Steering::linear((desired - velocity) * (self.mass / time_to_target))
        }
    }

    /// The running budget of Reynolds' prioritised sum: the maximum speed and rotation
    /// (kinematic), or the largest force and angular acceleration (dynamic).
    #[inline]
    pub(crate) fn budget(&self, max_speed: f32) -> PrioritySum {
        if self.kinematic {
            PrioritySum::new(max_speed, self.max_rotation)
        } else {
            PrioritySum::new(
                self.max_acceleration * self.mass,
                self.max_angular_acceleration,
            )
        }
    }

    /// The combined request turned into the integrator's input: the desired velocity and
    /// rotation (kinematic), or the acceleration `force / mass` clamped to the maximum and the
    /// angular acceleration clamped (dynamic).
    #[inline]
    pub(crate) fn finish(&self, total: Steering) -> Steering {
        let out = if self.kinematic {
            total
        } else {
            Steering {
                linear: steering::truncate(total.linear / self.mass, self.max_acceleration),
                angular: total.angular.clamp(
                    -self.max_angular_acceleration,
                    self.max_angular_acceleration,
                ),
            }
        };
        // A finite square implies finite components, and NaN fails it; kinematic requests need
        // it for the integrator's speed clamp, dynamic ones are already truncated.
        if out.linear.length_squared().is_finite() && out.angular.is_finite() {
            return out;
        }
        self.finish_overflow(total)
    }

    /// [`Adapter::finish`] for `LANES` linear requests at once: [`Adapter::finish_run`] over
    /// all the lanes (a constant trip count; lanes not in use give results nobody reads).
    #[inline(always)]
    pub(crate) fn finish_lanes(
        &self,
        tx: [f32; LANES],
        ty: [f32; LANES],
    ) -> ([f32; LANES], [f32; LANES]) {
        let (mut ox, mut oy) = (tx, ty);
        self.finish_run((&tx, &ty), (&mut ox, &mut oy));
        (ox, oy)
    }

    /// [`Adapter::finish`] for the linear requests `(tx, ty)` of a run of agents, written to
    /// `(ox, oy)`: the same operations in the same order in long loops, so each agent equals the
    /// scalar result bit for bit; agents whose request overflowed take the scalar path.
    #[inline(always)]
    pub(crate) fn finish_run(
        &self,
        (tx, ty): (&[f32], &[f32]),
        (ox, oy): (&mut [f32], &mut [f32]),
    ) {
        let n = ox.len();
        let (tx, ty, oy) = (&tx[..n], &ty[..n], &mut oy[..n]);
        if self.kinematic {
            ox.copy_from_slice(tx);
            oy.copy_from_slice(ty);
        } else {
            let (mass, max) = (self.mass, self.max_acceleration);
            for k in 0..n {
                // `truncate(total / mass, max)`.
                let (vx, vy) = (tx[k] / mass, ty[k] / mass);
                let len_sq = vx * vx + vy * vy;
                let over = len_sq > max * max;
                let s = max / len_sq.sqrt();
                ox[k] = if over { vx * s } else { vx };
                oy[k] = if over { vy * s } else { vy };
            }
        }
        // A request whose square length overflowed after the division by the mass takes
        // `truncate_robust` there and a scale of zero here: a non-zero request whose result is
        // zero goes to the per-agent finish too (as does, needlessly but rarely, one that the
        // division took below the smallest float).
        let inexact = |k: usize, ox: &[f32], oy: &[f32]| {
            let lost = (ox[k] == 0.0) & (oy[k] == 0.0) & ((tx[k] != 0.0) | (ty[k] != 0.0));
            lost | !(ox[k] * ox[k] + oy[k] * oy[k]).is_finite()
        };
        let mut exact = true;
        for k in 0..n {
            exact &= !inexact(k, ox, oy);
        }
        if !exact {
            for k in 0..n {
                if inexact(k, ox, oy) {
                    let s = self.finish(Steering::linear(Vec2::new(tx[k], ty[k])));
                    (ox[k], oy[k]) = (s.linear.x, s.linear.y);
                }
            }
        }
    }

    /// [`Adapter::finish`] for requests whose magnitude overflowed (a gravity point almost on
    /// top of an agent, a tiny mass): their direction kept at the limit; undefined ones
    /// (infinity minus infinity) do nothing.
    #[cold]
    fn finish_overflow(&self, total: Steering) -> Steering {
        let (lin_max, ang_max, raw) = if self.kinematic {
            (MAX_SPEED, self.max_rotation, total.linear)
        } else {
            (
                self.max_acceleration,
                self.max_angular_acceleration,
                total.linear / self.mass,
            )
        };
        Steering {
            linear: steering::truncate_robust(raw, lin_max),
            angular: if total.angular.is_nan() {
                0.0
            } else {
                total.angular.clamp(-ang_max, ang_max)
            },
        }
    }
}
