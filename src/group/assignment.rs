//! Slot assignment: which member takes which slot, minimising the total distance.
//!
//! [`assign_min_cost`] is the Hungarian method (Kuhn-Munkres with potentials, O(rows^2 * cols))
//! over an `f64` cost matrix; it is sequential and deterministic: the same matrix always gives
//! the same assignment. [`assign_slots`] builds the matrix of Euclidean distances between member
//! positions and slot positions.
//!
//! The exact method costs `O(n^3)` time and an `n x n` matrix, too much for large squads.
//! [`assign_slots_local`] keeps it exact up to [`EXACT_MAX`] members; above that it splits
//! members and slots together by recursive coordinate bisection (both sorted along the wider
//! axis, members halved, slots shared in proportion) into blocks of at most [`BLOCK`] members
//! and assigns each block exactly: `O(n log^2 n + n BLOCK^2)` time, `O(n + BLOCK^2)` memory.

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

/// Squads of at most this many members are assigned exactly by [`assign_slots_local`].
pub const EXACT_MAX: usize = 256;
/// The most members in one exactly assigned block of a larger squad.
pub const BLOCK: usize = 64;

/// Slot assignment that scales: exactly as [`assign_slots`] for at most [`EXACT_MAX`] members,
/// otherwise by blocks of nearby members and slots (see the module documentation), close to
/// the least total distance and deterministic.
///
/// # Errors
/// As [`assign_min_cost`]: more members than slots, or a NaN or infinite position.
pub fn assign_slots_local(members: &[Vec2], slots: &[Vec2]) -> Result<Vec<usize>> {
    if members.len() <= EXACT_MAX {
        return assign_slots(members, slots);
    }
    if members.len() > slots.len() {
        return Err(Error::Invalid {
            name: "assignment".into(),
            reason: format!("{} members but only {} slots", members.len(), slots.len()),
        });
    }
    if let Some(p) = members.iter().chain(slots).find(|p| !p.is_finite()) {
        return Err(Error::NonFinite {
            name: "assignment position",
            value: f64::from(if p.x.is_finite() { p.y } else { p.x }),
        });
    }
    let mut m: Vec<usize> = (0..members.len()).collect();
    let mut s: Vec<usize> = (0..slots.len()).collect();
    let mut out = vec![0; members.len()];
    bisect(members, slots, &mut m, &mut s, &mut out);
    Ok(out)
}

/// Assigns the members `m` to the slots `s` (indices into `members` and `slots`, `s` at least
/// as long as `m`), writing `out[member] = slot`.
fn bisect(members: &[Vec2], slots: &[Vec2], m: &mut [usize], s: &mut [usize], out: &mut [usize]) {
    if m.len() <= BLOCK {
        let at: Vec<Vec2> = m.iter().map(|&i| members[i]).collect();
        let to: Vec<Vec2> = s.iter().map(|&j| slots[j]).collect();
        let cost = distance_matrix(&at, &to, |a, b| b - a);
        for (r, c) in hungarian(&cost, at.len(), to.len()).into_iter().enumerate() {
            out[m[r]] = s[c];
        }
        return;
    }
    let (mut lo, mut hi) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
    for p in m
        .iter()
        .map(|&i| members[i])
        .chain(s.iter().map(|&j| slots[j]))
    {
        lo = lo.min(p);
        hi = hi.max(p);
    }
    let along_x = hi.x - lo.x >= hi.y - lo.y;
    let key = |p: Vec2| if along_x { (p.x, p.y) } else { (p.y, p.x) };
    let order = |pts: &[Vec2], a: usize, b: usize| {
        let (ka, kb) = (key(pts[a]), key(pts[b]));
        ka.0.total_cmp(&kb.0)
            .then(ka.1.total_cmp(&kb.1))
            .then(a.cmp(&b))
    };
    m.sort_unstable_by(|&a, &b| order(members, a, b));
    s.sort_unstable_by(|&a, &b| order(slots, a, b));
    let m1 = m.len() / 2;
    let spare = s.len() - m.len();
    // The slots shared in proportion; each half keeps at least as many slots as members.
    let s1 = m1 + (spare * m1).div_ceil(m.len());
    let (m_lo, m_hi) = m.split_at_mut(m1);
    let (s_lo, s_hi) = s.split_at_mut(s1);
    bisect(members, slots, m_lo, s_lo, out);
    bisect(members, slots, m_hi, s_hi, out);
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
