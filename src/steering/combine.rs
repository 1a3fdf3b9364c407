//! Combining several steering requests into one.

use glam::Vec2;

use super::{Steering, truncate};

/// Weighted sum of `(request, weight)` pairs (the vehicle notes average seek and flee this way).
#[must_use]
pub fn weighted_sum(parts: impl IntoIterator<Item = (Steering, f32)>) -> Steering {
    parts
        .into_iter()
        .fold(Steering::ZERO, |acc, (s, w)| acc + s.scaled(w))
}

/// Reynolds' prioritised, truncated running sum: requests are taken in order and each may use
/// only what is left of the `budget` (the length of the linear part): the first behaviours get
/// the force budget first, and a request that does not fit whole is shortened to fit. Angular
/// parts are summed and clamped to `angular_budget` the same way.
#[must_use]
pub fn priority_sum(
    parts: impl IntoIterator<Item = Steering>,
    budget: f32,
    angular_budget: f32,
) -> Steering {
    let mut acc = PrioritySum::new(budget, angular_budget);
    for s in parts {
        if !acc.push(s) {
            break;
        }
    }
    acc.total()
}

/// The running state of [`priority_sum`], for callers that compute requests one at a time and
/// want to stop as soon as the budget is spent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrioritySum {
    linear: Vec2,
    angular: f32,
    budget: f32,
    angular_budget: f32,
}

impl PrioritySum {
    /// An empty sum with the given budgets.
    #[must_use]
    pub fn new(budget: f32, angular_budget: f32) -> Self {
        PrioritySum {
            linear: Vec2::ZERO,
            angular: 0.0,
            budget,
            angular_budget,
        }
    }

    /// Adds the next request; returns whether any budget is left for later ones.
    pub fn push(&mut self, s: Steering) -> bool {
        let left = self.budget - self.linear.length();
        if left > 0.0 {
            self.linear += truncate(s.linear, left);
        }
        let left_ang = self.angular_budget - self.angular.abs();
        if left_ang > 0.0 {
            self.angular += s.angular.clamp(-left_ang, left_ang);
        }
        self.budget - self.linear.length() > 0.0 || self.angular_budget - self.angular.abs() > 0.0
    }

    /// The sum so far.
    #[must_use]
    pub fn total(&self) -> Steering {
        Steering {
            linear: self.linear,
            angular: self.angular,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_request_gets_the_budget() {
        let s = priority_sum(
            [
                Steering::linear(Vec2::new(3.0, 0.0)),
                Steering::linear(Vec2::new(0.0, 10.0)),
            ],
            4.0,
            1.0,
        );
        // The second request gets only the 1 unit of magnitude left over.
        assert_eq!(s.linear, Vec2::new(3.0, 1.0));
        let t = priority_sum(
            [
                Steering::linear(Vec2::new(5.0, 0.0)),
                Steering::linear(Vec2::new(0.0, 10.0)),
            ],
            4.0,
            1.0,
        );
        assert_eq!(
            t.linear,
            Vec2::new(4.0, 0.0),
            "later requests get nothing once the budget is spent"
        );
    }

    #[test]
    fn weighted_sum_averages() {
        let s = weighted_sum([
            (Steering::linear(Vec2::X), 0.8),
            (Steering::linear(Vec2::Y), 0.8),
        ]);
        assert_eq!(s.linear, Vec2::new(0.8, 0.8));
    }
}
