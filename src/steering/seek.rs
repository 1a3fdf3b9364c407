//! Seek, flee and arrive, in the dynamic (force) and kinematic (velocity) forms.

use glam::Vec2;

use super::behaviour::ArriveParams;

/// Dynamic seek: the force that turns `velocity` into full speed towards `target`.
///
/// Returns zero once the agent is within `threshold` of the target (Reynolds and Buckland's vehicle seek).
#[inline]
#[must_use]
pub fn seek(position: Vec2, velocity: Vec2, target: Vec2, max_speed: f32, threshold: f32) -> Vec2 {
    let to = target - position;
    let d_sq = to.length_squared();
    if d_sq <= threshold * threshold || d_sq == 0.0 {
        return Vec2::ZERO;
    }
    to * (max_speed / d_sq.sqrt()) - velocity
}

/// Dynamic flee: the force that turns `velocity` into full speed away from `threat`, applied only
/// while the threat is closer than `panic_distance` (use `f32::INFINITY` for always).
///
/// Coincident points give zero (there is no direction to flee in).
#[inline]
#[must_use]
pub fn flee(
    position: Vec2,
    velocity: Vec2,
    threat: Vec2,
    max_speed: f32,
    panic_distance: f32,
) -> Vec2 {
    let away = position - threat;
    let d_sq = away.length_squared();
    if d_sq >= panic_distance * panic_distance || d_sq == 0.0 {
        return Vec2::ZERO;
    }
    away * (max_speed / d_sq.sqrt()) - velocity
}

/// Dynamic arrive: full speed far away, proportionally slower inside `slow_radius`, and braking to
/// rest inside `target_radius`. The force reaches the wanted velocity in `time_to_target` seconds.
#[inline]
#[must_use]
pub fn arrive(
    position: Vec2,
    velocity: Vec2,
    target: Vec2,
    max_speed: f32,
    p: &ArriveParams,
) -> Vec2 {
    let to = target - position;
    let dist = to.length();
    if dist <= p.target_radius {
        return -velocity / p.time_to_target;
    }
    let speed = if dist > p.slow_radius {
        max_speed
    } else {
        max_speed * dist / p.slow_radius
    };
    let desired = to * (speed / dist);
    (desired - velocity) / p.time_to_target
}

/// Kinematic seek (reference notes): full speed straight at the target; zero within `threshold`.
#[inline]
#[must_use]
pub fn kinematic_seek(position: Vec2, target: Vec2, max_speed: f32, threshold: f32) -> Vec2 {
    let to = target - position;
    let d_sq = to.length_squared();
    if d_sq <= threshold * threshold || d_sq == 0.0 {
        return Vec2::ZERO;
    }
    to * (max_speed / d_sq.sqrt())
}

/// Kinematic flee: full speed straight away from the threat while it is within `panic_distance`.
#[inline]
#[must_use]
pub fn kinematic_flee(position: Vec2, threat: Vec2, max_speed: f32, panic_distance: f32) -> Vec2 {
    let away = position - threat;
    let d_sq = away.length_squared();
    if d_sq >= panic_distance * panic_distance || d_sq == 0.0 {
        return Vec2::ZERO;
    }
    away * (max_speed / d_sq.sqrt())
}

/// Kinematic arrive (reference notes): inside `slow_radius` the velocity is the remaining offset
/// divided by `time_to_target`, clamped to `max_speed`; outside it, full speed; inside
/// `target_radius`, rest.
#[inline]
#[must_use]
pub fn kinematic_arrive(position: Vec2, target: Vec2, max_speed: f32, p: &ArriveParams) -> Vec2 {
    let to = target - position;
    let dist = to.length();
    if dist <= p.target_radius {
        return Vec2::ZERO;
    }
    if dist < p.slow_radius {
        let v = to / p.time_to_target;
        super::truncate(v, max_speed)
    } else {
        to * (max_speed / dist)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seek_points_at_the_target() {
        let f = seek(Vec2::ZERO, Vec2::ZERO, Vec2::new(10.0, 0.0), 2.0, 0.0);
        assert_eq!(f, Vec2::new(2.0, 0.0));
        assert_eq!(
            seek(Vec2::ZERO, Vec2::ZERO, Vec2::new(0.1, 0.0), 2.0, 0.5),
            Vec2::ZERO
        );
    }

    #[test]
    fn flee_respects_panic_distance() {
        assert_eq!(
            flee(Vec2::ZERO, Vec2::ZERO, Vec2::new(10.0, 0.0), 1.0, 5.0),
            Vec2::ZERO
        );
        assert_eq!(
            flee(Vec2::ZERO, Vec2::ZERO, Vec2::new(1.0, 0.0), 1.0, 5.0),
            Vec2::new(-1.0, 0.0)
        );
    }

    #[test]
    fn kinematic_arrive_slows_inside_radius() {
        let p = ArriveParams {
            target_radius: 0.1,
            slow_radius: 4.0,
            time_to_target: 0.5,
        };
        assert_eq!(
            kinematic_arrive(Vec2::ZERO, Vec2::new(1.0, 0.0), 10.0, &p),
            Vec2::new(2.0, 0.0)
        );
        assert_eq!(
            kinematic_arrive(Vec2::ZERO, Vec2::new(100.0, 0.0), 10.0, &p),
            Vec2::new(10.0, 0.0)
        );
        assert_eq!(
            kinematic_arrive(Vec2::ZERO, Vec2::new(0.05, 0.0), 10.0, &p),
            Vec2::ZERO
        );
    }
}
