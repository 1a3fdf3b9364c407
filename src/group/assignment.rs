//! Slot assignment: which member takes which slot, minimising the total distance.
//!
//! [`assign_min_cost`] is the Hungarian method (Kuhn-Munkres with potentials, O(rows^2 * cols))
//! over an `f64` cost matrix; it is sequential and deterministic: the same matrix always gives
//! the same assignment. [`assign_slots`] builds the matrix of Euclidean distances between member
//! positions and slot positions.

use glam::Vec2;

use crate::error::{Error, Result};

/// The assignment of `rows` workers to `cols >= rows` jobs with the least total cost: entry `r` of
/// the result is the column given to row `r` (all distinct). `cost` is row-major,
/// `rows * cols` long.
///
/// # Examples
/// ```
/// use throng::group::assign_min_cost;
/// # fn main() -> throng::Result<()> {
/// let cost = [4.0, 1.0, 3.0, 2.0, 0.0, 5.0, 3.0, 2.0, 2.0];
/// assert_eq!(assign_min_cost(&cost, 3, 3)?, vec![1, 0, 2]);
/// # Ok(())
/// # }
/// ```
///
/// # Errors
/// [`Error::Invalid`] when `rows > cols` or the matrix has the wrong length,
/// [`Error::NonFinite`] for a NaN or infinite cost.
pub fn assign_min_cost(cost: &[f64], rows: usize, cols: usize) -> Result<Vec<usize>> {
    if rows > cols {
        return Err(Error::Invalid {
            name: "assignment".into(),
            reason: format!("{rows} members but only {cols} slots"),
        });
    }
    if cost.len() != rows * cols {
        return Err(Error::Invalid {
            name: "assignment".into(),
            reason: format!(
                "cost matrix has {} entries, expected {rows} x {cols}",
                cost.len()
            ),
        });
    }
    if let Some(c) = cost.iter().find(|c| !c.is_finite()) {
        return Err(Error::NonFinite {
            name: "assignment cost",
            value: *c,
        });
    }
    Ok(hungarian(cost, rows, cols))
}

/// The Hungarian method on a validated matrix (1-based potentials; column 0 is a sentinel).
fn hungarian(a: &[f64], n: usize, m: usize) -> Vec<usize> {
    let mut u = vec![0.0_f64; n + 1];
    let mut v = vec![0.0_f64; m + 1];
    // p[j]: the row (1-based) holding column j; 0 when free.
    let mut p = vec![0_usize; m + 1];
    let mut way = vec![0_usize; m + 1];
    let mut minv = vec![0.0_f64; m + 1];
    let mut used = vec![false; m + 1];
    for i in 1..=n {
        p[0] = i;
        let mut j0 = 0;
        minv.fill(f64::INFINITY);
        used.fill(false);
        loop {
            used[j0] = true;
            let i0 = p[j0];
            let mut delta = f64::INFINITY;
            let mut j1 = 0;
            for j in 1..=m {
                if !used[j] {
                    let cur = a[(i0 - 1) * m + (j - 1)] - u[i0] - v[j];
                    if cur < minv[j] {
                        minv[j] = cur;
                        way[j] = j0;
                    }
                    if minv[j] < delta {
                        delta = minv[j];
                        j1 = j;
                    }
                }
            }
            for j in 0..=m {
                if used[j] {
                    u[p[j]] += delta;
                    v[j] -= delta;
                } else {
                    minv[j] -= delta;
                }
            }
            j0 = j1;
            if p[j0] == 0 {
                break;
            }
        }
        loop {
            let j1 = way[j0];
            p[j0] = p[j1];
            j0 = j1;
            if j0 == 0 {
                break;
            }
        }
    }
    let mut out = vec![0; n];
    for j in 1..=m {
        if p[j] != 0 {
            out[p[j] - 1] = j - 1;
        }
    }
    out
}

/// The assignment of members (at `members`) to slots (at `slots`, at least as many) that
/// minimises the sum of straight-line distances: entry `k` is member `k`'s slot.
///
/// # Errors
/// As [`assign_min_cost`]: more members than slots, or a NaN position.
pub fn assign_slots(members: &[Vec2], slots: &[Vec2]) -> Result<Vec<usize>> {
    let cost = distance_matrix(members, slots, |a, b| b - a);
    assign_min_cost(&cost, members.len(), slots.len())
}

/// The row-major matrix of `|offset(member, slot)|` in `f64`.
pub(crate) fn distance_matrix(
    members: &[Vec2],
    slots: &[Vec2],
    offset: impl Fn(Vec2, Vec2) -> Vec2,
) -> Vec<f64> {
    let mut cost = Vec::with_capacity(members.len() * slots.len());
    for &m in members {
        for &s in slots {
            let d = offset(m, s);
            cost.push(f64::from(d.x).hypot(f64::from(d.y)));
        }
    }
    cost
}

/// The total cost of an assignment (`assignment[r]` is row `r`'s column).
#[must_use]
pub fn assignment_cost(cost: &[f64], cols: usize, assignment: &[usize]) -> f64 {
    assignment
        .iter()
        .enumerate()
        .map(|(r, &c)| cost[r * cols + c])
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rectangular_and_degenerate() {
        assert_eq!(assign_min_cost(&[], 0, 0).unwrap(), Vec::<usize>::new());
        assert_eq!(assign_min_cost(&[5.0, 1.0, 3.0], 1, 3).unwrap(), vec![1]);
        assert!(assign_min_cost(&[1.0, 2.0], 2, 1).is_err());
        assert!(assign_min_cost(&[f64::NAN], 1, 1).is_err());
        // All costs equal: still a permutation.
        let a = assign_min_cost(&[1.0; 9], 3, 3).unwrap();
        let mut s = a.clone();
        s.sort_unstable();
        assert_eq!(s, vec![0, 1, 2]);
    }

    #[test]
    fn slots_swap_when_crossed() {
        let m = [Vec2::new(0.0, 0.0), Vec2::new(10.0, 0.0)];
        let s = [Vec2::new(10.0, 1.0), Vec2::new(0.0, 1.0)];
        assert_eq!(assign_slots(&m, &s).unwrap(), vec![1, 0]);
    }
}
