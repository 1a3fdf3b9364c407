//! The two movement models of the reference notes and the vectorised integrator.
//!
//! - **Kinematic**: a behaviour yields a desired velocity and a rotation. The velocity is set
//!   directly (clamped to the maximum speed), the position moves by the *new* velocity, and the
//!   orientation either follows the velocity or integrates the rotation.
//! - **Dynamic** (steering): a behaviour yields a force; the world turns it into a linear
//!   acceleration `force / mass` clamped to the maximum acceleration, and an angular acceleration
//!   clamped to its maximum. The update is the classic Newton-Euler step, in its textbook order:
//!   `position += velocity * dt`; `orientation += rotation * dt (mod 2pi)` or, when the group faces
//!   its velocity, the orientation of that (pre-update) velocity; `velocity += linear * dt`;
//!   `rotation += angular * dt`; then the speed is clamped (`velocity *= max / |velocity|`) and the
//!   rotation clamped to the maximum rotation. Optional drag scales the new velocity by
//!   `max(0, 1 - drag * dt)`.
//!
//! [`integrate`] runs each agent's step, one branch-free function, over blocks of 8 agents
//! loaded from contiguous `f32` slices, in parallel chunks and under runtime dispatch (clones for
//! AVX-512, AVX2 + FMA and AVX, the first the processor has, else the baseline x86-64 build);
//! [`integrate_scalar`] calls the same function one agent at a time, the reference the lanes are
//! tested against bit for bit (the compiler's vectorisation keeps the operations and their order;
//! no fused multiply-add is formed).

mod integrate;

pub(crate) use integrate::integrate_then;
pub use integrate::{
    IntegrationParams, MotionState, REST_ROTATION, REST_SPEED, SteeringBuffers, integrate,
    integrate_scalar, wrap_orientation,
};

use serde::{Deserialize, Serialize};

/// Which movement model a group uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MovementModel {
    /// Velocity is set directly from the behaviours' desired velocity.
    Kinematic,
    /// Behaviours produce forces; Newton-Euler integration with limits (default).
    #[default]
    Dynamic,
}

/// How an agent's orientation evolves.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OrientationMode {
    /// Orientation is the direction of the velocity (kept when at rest). Default.
    #[default]
    FaceVelocity,
    /// Orientation integrates the rotation (needed by kinematic wander and by face/align).
    Integrate,
}
