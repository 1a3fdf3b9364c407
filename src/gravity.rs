//! Anti-gravity movement (potential-field motion planning): gravity points that repel or attract.
//!
//! Each point pushes an agent with `strength / distance^exponent` along the bearing from the point
//! to the agent: a positive strength repels, a negative one attracts. The total force is the sum
//! over the points within each point's cut-off `radius`; points are kept in a uniform grid, so an
//! agent only visits the points near it, never all of them. Points can be static, move on a
//! script (a constant velocity, an orbit), or ride on an agent.
//!
//! Two paths give the total force: [`GravityField::force_at`], the reference, queries the grid
//! for the points within the largest cut-off and sums them in ascending point order;
//! [`GravityField::force_near`], in a world that does not wrap, reads the list of the points whose
//! cut-off reaches the agent's cell of a second, finer grid (built when the points are indexed,
//! each list in ascending point order) and sums the same terms in the same order: a point
//! beyond its cut-off adds `+0`, which leaves the sum as it is, so the two give the same bits.
//!
//! [`antigravity_seek`] is the anti-gravity seek:
//! `normalize(normalize(target - p) + total_force)`.
//!
//! Powers of the distance (`distance_power`): whole exponents 0 to 4 are exact products of the
//! distance and its square (the square as the offset's squared length), any other exponent is
//! `powf`; agent repulsion (`plans::neighbours` and the cell batch's kernel) uses the same
//! function, so the lane forms give its bits.

use glam::Vec2;
use serde::{Deserialize, Serialize};

use crate::agents::AgentId;
use crate::bounds::Bounds;
use crate::error::{Error, Result, finite, finite_vec, non_negative, positive};
use crate::spatial::{GridIndex, Neighbour, NeighbourIndex};

/// How a gravity point moves.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Motion {
    /// It stays where it is.
    #[default]
    Static,
    /// It moves at a constant velocity (wrapping or clamped by the world's bounds).
    Linear {
        /// Units per second.
        velocity: Vec2,
    },
    /// It circles `center` at `orbit_radius`, `angular_speed` radians per second.
    Orbit {
        /// Centre of the orbit.
        center: Vec2,
        /// Radius of the orbit.
        orbit_radius: f32,
        /// Radians per second (the sign gives the direction).
        angular_speed: f32,
    },
    /// It sits on an agent (and vanishes when the agent is removed).
    Agent {
        /// The agent.
        agent: AgentId,
    },
}

/// A gravity point.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GravityPoint {
    /// Where it is now.
    pub position: Vec2,
    /// Force at distance 1; positive repels, negative attracts.
    pub strength: f32,
    /// The `n` of `strength / distance^n` (>= 0). Default: 2.
    #[serde(default = "two")]
    pub exponent: f32,
    /// Cut-off (> 0): agents farther away feel nothing from this point.
    pub radius: f32,
    /// How it moves. Default: static.
    #[serde(default)]
    pub motion: Motion,
}

fn two() -> f32 {
    2.0
}

impl GravityPoint {
    /// A static point.
    #[must_use]
    pub fn fixed(position: Vec2, strength: f32, exponent: f32, radius: f32) -> Self {
        GravityPoint {
            position,
            strength,
            exponent,
            radius,
            motion: Motion::Static,
        }
    }

    /// Checks the numbers.
    ///
    /// # Errors
    /// [`Error::NonFinite`], [`Error::Negative`] or [`Error::NotPositive`] naming the parameter.
    pub fn validate(&self) -> Result<()> {
        crate::error::coordinate("gravity.position", self.position)?;
        finite("gravity.strength", self.strength)?;
        non_negative("gravity.exponent", self.exponent)?;
        positive("gravity.radius", self.radius)?;
        if let Motion::Orbit {
            center,
            orbit_radius,
            angular_speed,
        } = self.motion
        {
            crate::error::coordinate("gravity.motion.center", center)?;
            non_negative("gravity.motion.orbit_radius", orbit_radius)?;
            finite("gravity.motion.angular_speed", angular_speed)?;
        }
        if let Motion::Linear { velocity } = self.motion {
            finite_vec("gravity.motion.velocity", velocity)?;
        }
        Ok(())
    }

    /// The force this point exerts on an agent at offset `d` from the point (`d = agent - point`,
    /// under the world's metric): zero beyond the cut-off or at the point itself.
    #[inline]
    #[must_use]
    pub fn force(&self, d: Vec2) -> Vec2 {
        let d_sq = d.length_squared();
        if d_sq > self.radius * self.radius || d_sq == 0.0 {
            return Vec2::ZERO;
        }
        let dist = d_sq.sqrt();
        d / dist * (self.strength / distance_power(dist, d_sq, self.exponent))
    }
}

/// `exponent` as a whole number from 0 to 4, the exponents [`distance_power`] takes as exact
/// products, or `None`.
#[inline]
#[must_use]
pub(crate) fn whole_exponent(exponent: f32) -> Option<u8> {
    (0..=4u8).find(|&e| f32::from(e) == exponent)
}

/// `dist^E` for a whole exponent `E` from 0 to 4, from the distance `dist` and its square
/// `d_sq` (the offset's squared length): 1, `dist`, `d_sq`, `d_sq * dist`, `d_sq * d_sq`.
#[inline(always)]
#[must_use]
pub(crate) fn whole_power<const E: u8>(dist: f32, d_sq: f32) -> f32 {
    match E {
        0 => 1.0,
        1 => dist,
        2 => d_sq,
        3 => d_sq * dist,
        _ => d_sq * d_sq,
    }
}

/// `dist^exponent` for the distance `dist` whose square is `d_sq`: [`whole_power`] for whole
/// exponents from 0 to 4, `powf` otherwise.
#[inline]
#[must_use]
pub(crate) fn distance_power(dist: f32, d_sq: f32, exponent: f32) -> f32 {
    match whole_exponent(exponent) {
        Some(0) => whole_power::<0>(dist, d_sq),
        Some(1) => whole_power::<1>(dist, d_sq),
        Some(2) => whole_power::<2>(dist, d_sq),
        Some(3) => whole_power::<3>(dist, d_sq),
        Some(_) => whole_power::<4>(dist, d_sq),
        None => dist.powf(exponent),
    }
}

/// The anti-gravity seek direction: `normalize(normalize(target - position) + force)` (zero when both
/// vanish).
#[inline]
#[must_use]
pub fn antigravity_seek(position: Vec2, target: Vec2, force: Vec2) -> Vec2 {
    ((target - position).normalize_or_zero() + force).normalize_or_zero()
}

/// Cells of a uniform grid over the reach of a field's points, each with the points whose
/// cut-off disc reaches it, in ascending point order (a point's disc is widened by a margin
/// far above rounding, so that every agent within a point's cut-off lies in a cell that lists
/// the point).
#[derive(Clone, Debug, Default)]
struct CellLists {
    /// The grid's lower corner and the reciprocal of its cell side.
    origin: Vec2,
    inv: f32,
    /// Cells per axis (none before the first build, or in a world that wraps).
    nx: usize,
    ny: usize,
    /// Per cell, the start of its list in `points`; one more than the cells.
    starts: Vec<u32>,
    points: Vec<u32>,
}

/// The largest number of cells of [`CellLists`]; a wider field takes wider cells.
const MAX_LIST_CELLS: f32 = (1 << 20) as f32;

impl CellLists {
    /// The cell side's share of the largest cut-off.
    const SIDE: f32 = 0.5;

    /// A point's cut-off widened by the margin.
    fn reach(radius: f32) -> f32 {
        radius * 1.001 + 1e-3
    }

    /// Rebuilds the lists for `points` (two passes: counts, then the lists, each point's in
    /// ascending order).
    fn rebuild(&mut self, points: &[GravityPoint], max_radius: f32) {
        self.starts.clear();
        self.points.clear();
        (self.nx, self.ny) = (0, 0);
        if points.is_empty() {
            return;
        }
        let (mut lo, mut hi) = (Vec2::INFINITY, Vec2::NEG_INFINITY);
        for p in points {
            let r = Vec2::splat(Self::reach(p.radius));
            (lo, hi) = (lo.min(p.position - r), hi.max(p.position + r));
        }
        let extent = hi - lo;
        let side = (Self::SIDE * Self::reach(max_radius))
            .max((extent.x * extent.y / MAX_LIST_CELLS).sqrt())
            .max(extent.max_element() / 4096.0);
        if !(side.is_finite() && side > 0.0) {
            return;
        }
        let count = |len: f32| ((len / side).floor() as usize).saturating_add(1).min(4097);
        (self.origin, self.inv) = (lo, 1.0 / side);
        (self.nx, self.ny) = (count(extent.x), count(extent.y));
        let mut counts = vec![0u32; self.nx * self.ny + 1];
        for p in points {
            self.cells_of(p, side, |c| counts[c + 1] += 1);
        }
        for c in 1..counts.len() {
            counts[c] += counts[c - 1];
        }
        let mut next = counts.clone();
        let mut lists = vec![0u32; counts[counts.len() - 1] as usize];
        for (k, p) in points.iter().enumerate() {
            self.cells_of(p, side, |c| {
                lists[next[c] as usize] = k as u32;
                next[c] += 1;
            });
        }
        (self.starts, self.points) = (counts, lists);
    }

    /// Calls `f` with every cell that point `p`'s widened disc reaches: the cells of its
    /// bounding square but those whose nearest point lies beyond the disc (cells of side
    /// `side`).
    fn cells_of(&self, p: &GravityPoint, side: f32, mut f: impl FnMut(usize)) {
        let r = Self::reach(p.radius);
        let (c0, r0) = self.cell(p.position - Vec2::splat(r));
        let (c1, r1) = self.cell(p.position + Vec2::splat(r));
        for row in r0..=r1 {
            for col in c0..=c1 {
                let corner = self.origin + Vec2::new(col as f32, row as f32) * side;
                let nearest = p.position.clamp(corner, corner + Vec2::splat(side));
                if nearest.distance_squared(p.position) <= r * r * 1.001 {
                    f(row * self.nx + col);
                }
            }
        }
    }

    /// The cell of `p`, clamped into the grid.
    fn cell(&self, p: Vec2) -> (usize, usize) {
        let at = (p - self.origin) * self.inv;
        let clamp = |v: f32, n: usize| (v.max(0.0) as usize).min(n - 1);
        (clamp(at.x, self.nx), clamp(at.y, self.ny))
    }

    /// The list of the cell holding `p` (empty outside the grid or before a build).
    #[inline]
    fn at(&self, p: Vec2) -> &[u32] {
        let at = (p - self.origin) * self.inv;
        let inside = at.x >= 0.0 && at.y >= 0.0 && at.x < self.nx as f32 && at.y < self.ny as f32;
        if !inside {
            return &[];
        }
        let c = at.y as usize * self.nx + at.x as usize;
        match (self.starts.get(c), self.starts.get(c + 1)) {
            (Some(&a), Some(&b)) => &self.points[a as usize..b as usize],
            _ => &[],
        }
    }
}

/// All gravity points of a world, indexed for cut-off queries.
#[derive(Clone, Debug, Default)]
pub struct GravityField {
    points: Vec<GravityPoint>,
    index: GridIndex,
    xs: Vec<f32>,
    ys: Vec<f32>,
    max_radius: f32,
    dirty: bool,
    /// The points per cell, in a world that does not wrap ([`GravityField::force_near`]).
    lists: CellLists,
}

impl GravityField {
    /// The points.
    #[must_use]
    pub fn points(&self) -> &[GravityPoint] {
        &self.points
    }

    /// Whether there are no points.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Adds a point; returns its index.
    ///
    /// # Errors
    /// As [`GravityPoint::validate`].
    pub fn add(&mut self, p: GravityPoint) -> Result<usize> {
        p.validate()?;
        self.points.push(p);
        self.dirty = true;
        Ok(self.points.len() - 1)
    }

    /// Moves point `k` to `position`.
    ///
    /// # Errors
    /// [`Error::Invalid`] for an unknown point, [`Error::NonFinite`] for a bad position.
    pub fn set_position(&mut self, k: usize, position: Vec2) -> Result<()> {
        crate::error::coordinate("gravity.position", position)?;
        let count = self.points.len();
        let p = self.points.get_mut(k).ok_or_else(|| Error::Invalid {
            name: "gravity point".into(),
            reason: format!("no point {k} (there are {count})"),
        })?;
        p.position = position;
        self.dirty = true;
        Ok(())
    }

    /// Advances scripted motion by `dt` and moves agent-borne points to their agents
    /// (`agent_position` looks an agent up); then reindexes if anything moved.
    pub fn advance(
        &mut self,
        dt: f32,
        time: f64,
        bounds: Bounds,
        agent_position: impl Fn(AgentId) -> Option<Vec2>,
    ) {
        for p in &mut self.points {
            match p.motion {
                Motion::Static => {}
                Motion::Linear { velocity } => {
                    p.position = bounds.wrap(p.position + velocity * dt);
                    self.dirty = true;
                }
                Motion::Orbit {
                    center,
                    orbit_radius,
                    angular_speed,
                } => {
                    let a = (f64::from(angular_speed) * time) as f32;
                    p.position = bounds.wrap(center + Vec2::from_angle(a) * orbit_radius);
                    self.dirty = true;
                }
                Motion::Agent { agent } => {
                    if let Some(pos) = agent_position(agent)
                        && pos != p.position
                    {
                        p.position = pos;
                        self.dirty = true;
                    }
                }
            }
        }
        if self.dirty {
            self.reindex(bounds);
        }
    }

    fn reindex(&mut self, bounds: Bounds) {
        self.xs.clear();
        self.ys.clear();
        self.max_radius = 0.0;
        for p in &self.points {
            self.xs.push(p.position.x);
            self.ys.push(p.position.y);
            self.max_radius = self.max_radius.max(p.radius);
        }
        // Points may sit outside a walled world (they only push); index them in an open grid then.
        let b = if bounds.is_torus() {
            bounds
        } else {
            Bounds::Open
        };
        self.index
            .rebuild(&self.xs, &self.ys, b, self.max_radius.max(1e-3));
        if bounds.is_torus() {
            self.lists = CellLists::default();
        } else {
            self.lists.rebuild(&self.points, self.max_radius);
        }
        self.dirty = false;
    }

    /// Makes sure the index matches the points.
    pub fn prepare(&mut self, bounds: Bounds) {
        if self.dirty {
            self.reindex(bounds);
        }
    }

    /// The total force at `position`, summed over the points within their cut-offs in ascending
    /// point order (`buf` is scratch). On a torus the offsets are minimum images.
    pub fn force_at(&self, position: Vec2, buf: &mut Vec<Neighbour>) -> Vec2 {
        if self.points.is_empty() {
            return Vec2::ZERO;
        }
        self.index.neighbours_at(position, self.max_radius, buf);
        let mut f = Vec2::ZERO;
        for nb in buf.iter() {
            let p = &self.points[nb.index as usize];
            // The index's offset runs from the agent to the point (the minimum image on a torus).
            f += p.force(-nb.offset);
        }
        f
    }

    /// [`GravityField::force_at`], bit for bit: in a world that does not wrap, the sum over
    /// the list of the points whose cut-off reaches `position`'s cell, in ascending point order
    /// (each point's term is the reference's; a point beyond its cut-off adds `+0`, and the sum,
    /// which starts at `+0`, is never `-0`, so such a term changes no bit); on a torus,
    /// `force_at` itself (`buf` is its scratch).
    pub fn force_near(&self, position: Vec2, buf: &mut Vec<Neighbour>) -> Vec2 {
        if self.lists.nx == 0 {
            return self.force_at(position, buf);
        }
        self.force_from_lists(position)
    }

    /// The sum over the list of `position`'s cell ([`GravityField::force_near`]).
    #[inline]
    fn force_from_lists(&self, position: Vec2) -> Vec2 {
        let mut f = Vec2::ZERO;
        for &k in self.lists.at(position) {
            let p = &self.points[k as usize];
            // As the index computes the offset from the agent to the point in an open world.
            f += p.force(-Bounds::Open.offset(position, p.position));
        }
        f
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn force_follows_the_formula() {
        let p = GravityPoint::fixed(Vec2::ZERO, 2000.0, 2.0, 1000.0);
        let f = p.force(Vec2::new(10.0, 0.0));
        assert!(
            (f - Vec2::new(20.0, 0.0)).length() < 1e-4,
            "2000 / 10^2 along +x: {f}"
        );
        let attract = GravityPoint {
            strength: -2000.0,
            ..p
        };
        assert!(attract.force(Vec2::new(10.0, 0.0)).x < 0.0);
        assert_eq!(
            p.force(Vec2::new(2000.0, 0.0)),
            Vec2::ZERO,
            "beyond the cut-off"
        );
    }

    #[test]
    fn indexed_sum_equals_the_plain_sum() {
        let mut g = GravityField::default();
        let mut plain = Vec2::ZERO;
        let at = Vec2::new(50.0, 50.0);
        for k in 0..200 {
            let pos = Vec2::new((k * 37 % 100) as f32, (k * 53 % 100) as f32);
            let p = GravityPoint::fixed(
                pos,
                10.0 + k as f32,
                1.0 + (k % 3) as f32,
                5.0 + (k % 20) as f32,
            );
            g.add(p).unwrap();
            plain += p.force(at - pos);
        }
        g.prepare(Bounds::Open);
        let f = g.force_at(at, &mut Vec::new());
        assert!(
            (f - plain).length() <= 1e-4 * plain.length().max(1.0),
            "{f} vs {plain}"
        );
    }

    #[test]
    fn the_cell_lists_give_the_reference_sum_bit_for_bit() {
        // Fields of few and many points, cut-offs from tiny to wide, exponents whole and not,
        // attracting and repelling; agents inside, on the edges of and outside the points'
        // reach, at points themselves and on cut-offs. The lists' sum (the fast path, which
        // must be built in a world that does not wrap) equals `force_at` bit for bit; on a
        // torus `force_near` is `force_at`.
        let mut seed = 0x9e37_79b9_u32;
        let mut unit = move || {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            (seed >> 8) as f32 / (1 << 24) as f32
        };
        let (mut compared, mut pushed) = (0, 0);
        for case in 0..60 {
            let bounds = if case % 5 == 4 {
                Bounds::Torus {
                    size: Vec2::splat(300.0),
                }
            } else {
                Bounds::Bounded {
                    size: Vec2::splat(300.0),
                }
            };
            let mut g = GravityField::default();
            let count = [1, 3, 20, 200][case % 4];
            let mut points = Vec::new();
            for k in 0..count {
                let p = GravityPoint::fixed(
                    Vec2::new(unit() * 300.0, unit() * 300.0),
                    (unit() - 0.3) * 100.0,
                    [2.0, 1.0, 2.5, 0.0, 3.0][k % 5],
                    [0.5, 5.0, 40.0, 120.0][(k + case) % 4] * (0.5 + unit()),
                );
                g.add(p).unwrap();
                points.push(p);
            }
            g.prepare(bounds);
            assert_eq!(
                g.lists.nx > 0,
                !bounds.is_torus(),
                "lists built off a torus"
            );
            let buf = &mut Vec::new();
            for k in 0..400 {
                let at = match k % 4 {
                    0 => points[k % count].position,
                    1 => {
                        let p = points[k % count];
                        p.position + Vec2::new(p.radius, 0.0)
                    }
                    _ => Vec2::new(unit() * 340.0 - 20.0, unit() * 340.0 - 20.0),
                };
                let want = g.force_at(at, buf);
                let got = g.force_near(at, buf);
                assert_eq!(
                    got.to_array().map(f32::to_bits),
                    want.to_array().map(f32::to_bits),
                    "case {case}, at {at}: {got} vs {want}"
                );
                if !bounds.is_torus() {
                    let lists = g.force_from_lists(at);
                    assert_eq!(
                        lists.to_array().map(f32::to_bits),
                        want.to_array().map(f32::to_bits)
                    );
                    compared += 1;
                    pushed += usize::from(want != Vec2::ZERO);
                }
            }
        }
        assert!(
            compared > 10_000 && pushed > 5_000,
            "{compared} compared, {pushed} pushed"
        );
    }

    #[test]
    fn seek_combination_is_a_unit_vector() {
        let d = antigravity_seek(Vec2::ZERO, Vec2::new(10.0, 0.0), Vec2::new(0.0, 3.0));
        assert!((d.length() - 1.0).abs() < 1e-6);
        assert!(d.y > d.x, "a strong push dominates the direction");
    }
}
