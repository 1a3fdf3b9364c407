//! Flow (vector) fields: per cell, the direction to its best neighbour, computed once.
//!
//! This is the optimisation of the potential-field notes: an agent reads one direction from its
//! own cell instead of comparing all its neighbours. A [`FlowField`] is built from a
//! [`PotentialField`] (best = the neighbour an agent climbs to) or an [`IntegrationField`] (best =
//! the cheapest neighbour), with the same corner rule and tie order as those fields, or from a
//! [`DistanceField`]: then each cell also keeps the continuous direction of steepest descent,
//! which is what it blends and returns, while its step code (for [`FlowField::next_cell`]) is the
//! nearest allowed neighbour.
//!
//! Agents in continuous space call [`FlowField::sample`]: the directions of the four cells
//! around the point are blended bilinearly, using only cells the point's own cell may step to
//! (so a direction never leaks through a wall's corner), and the blend is then cleared of any
//! component that points into a wall next to the point's cell. The result is a unit vector or
//! zero with a positive component along the own cell's direction (else that direction itself);
//! moving along it by less than one cell never enters a wall.
//!
//! Invariants: directions are unit vectors, one of the eight unit steps except in a flow of a
//! distance field; goal cells, walls and unreachable cells have no direction; building is
//! parallel over rows and deterministic.

use glam::Vec2;
use rayon::prelude::*;

use super::distance::DistanceField;
use super::integration::IntegrationField;
use super::lattice::{DIAGONAL_SIDES, DIRECTIONS, Lattice, UNIT};
use super::potential::{PotentialField, UNSET, WALL};

/// Direction code of a goal cell.
const GOAL: u8 = 8;
/// Direction code of a wall, an unreachable cell or the border.
const NONE: u8 = 9;

/// The direction from every cell to its best neighbour.
#[derive(Clone, Debug, PartialEq)]
pub struct FlowField {
    lattice: Lattice,
    /// Padded direction codes: `0..8` index [`DIRECTIONS`], then `GOAL` or `NONE`.
    codes: Vec<u8>,
    /// Padded continuous unit directions (zero where the code has none), for a flow of a
    /// [`DistanceField`]; empty otherwise, when a cell's direction is its code's unit step.
    dirs: Vec<Vec2>,
}

impl FlowField {
    /// The flow of a potential field: each cell points to the neighbour an agent climbs to.
    ///
    /// # Examples
    /// ```
    /// # fn main() -> throng::Result<()> {
    /// use glam::Vec2;
    /// use throng::field::{FlowField, Neighbourhood, OccupancyGrid, PotentialField};
    /// let map = OccupancyGrid::parse_ascii("...G\n", "<map>")?;
    /// let field = PotentialField::bfs(&map.grid, &map.goals, 0.9, Neighbourhood::Four)?;
    /// let flow = FlowField::from_potential(&field);
    /// assert_eq!(flow.direction(0, 0), Vec2::X);
    /// assert_eq!(flow.sample(Vec2::new(1.2, 0.5)), Vec2::X);
    /// # Ok(()) }
    /// ```
    #[must_use]
    pub fn from_potential(field: &PotentialField) -> Self {
        let mut flow = FlowField {
            lattice: field.lattice,
            codes: Vec::new(),
            dirs: Vec::new(),
        };
        flow.rebuild_from_potential(field);
        flow
    }

    /// Rebuilds this flow in place from `field` (as [`FlowField::from_potential`], reusing the
    /// buffer when the size is unchanged).
    pub fn rebuild_from_potential(&mut self, field: &PotentialField) {
        use super::lattice::Neighbourhood;
        let l = field.lattice;
        self.lattice = l;
        self.dirs = Vec::new();
        if self.codes.len() != l.len {
            self.codes = vec![NONE; l.len];
        }
        let steps = &field.steps[..];
        let eight = field.neighbourhood == Neighbourhood::Eight;
        let (w, h) = (l.width as usize, l.height as usize);
        self.codes
            .par_chunks_mut(l.stride)
            .enumerate()
            .with_min_len(16)
            .for_each(|(row, out)| {
                if row == 0 || row > h {
                    out.fill(NONE);
                    return;
                }
                out[0] = NONE;
                out[w + 1] = NONE;
                let base = row * l.stride;
                for (x, o) in out[1..=w].iter_mut().enumerate() {
                    *o = potential_code(steps, base + x + 1, &l.offsets, eight);
                }
            });
    }

    /// The flow of an integration field: each cell points to its cheapest allowed neighbour.
    #[must_use]
    pub fn from_integration(field: &IntegrationField) -> Self {
        let lattice = field.lattice;
        let codes = build(&lattice, |p| {
            let c = field.cost[p];
            if c == 0.0 {
                GOAL
            } else if !c.is_finite() {
                NONE
            } else {
                field.best_from(p).map_or(NONE, |q| code_of(&lattice, p, q))
            }
        });
        FlowField {
            lattice,
            codes,
            dirs: Vec::new(),
        }
    }

    /// The flow of a distance field: each cell keeps its direction of steepest descent (the
    /// upwind negative gradient of the distance), so agents head straight for the goal or the
    /// next wall corner on the way, at any angle; its step code is the allowed neighbour nearest
    /// to the goals.
    ///
    /// # Examples
    /// ```
    /// # fn main() -> throng::Result<()> {
    /// use throng::field::{DistanceField, FlowField, OccupancyGrid};
    /// let grid = OccupancyGrid::new(30, 30)?;
    /// let flow = FlowField::from_distance(&DistanceField::fast_marching(&grid, &[(0, 0)])?);
    /// // From (20, 10) the goal lies at about 26.6 degrees below the -x axis, not at 45.
    /// let d = flow.direction(20, 10);
    /// assert!((d.y / d.x - 0.5).abs() < 0.1, "{d}");
    /// # Ok(()) }
    /// ```
    #[must_use]
    pub fn from_distance(field: &DistanceField) -> Self {
        let mut flow = FlowField {
            lattice: field.lattice,
            codes: Vec::new(),
            dirs: Vec::new(),
        };
        flow.rebuild_from_distance(field);
        flow
    }

    /// Rebuilds this flow in place from `field` (as [`FlowField::from_distance`], reusing the
    /// buffers when the size is unchanged).
    pub fn rebuild_from_distance(&mut self, field: &DistanceField) {
        let l = field.lattice;
        self.lattice = l;
        self.codes.clear();
        self.codes.resize(l.len, NONE);
        self.dirs.clear();
        self.dirs.resize(l.len, Vec2::ZERO);
        let dist = &field.distance[..];
        let (w, h) = (l.width as usize, l.height as usize);
        self.codes
            .par_chunks_mut(l.stride)
            .zip(self.dirs.par_chunks_mut(l.stride))
            .enumerate()
            .with_min_len(16)
            .for_each(|(row, (codes, dirs))| {
                if row == 0 || row > h {
                    return;
                }
                let base = row * l.stride;
                for x in 1..=w {
                    let p = base + x;
                    let t = dist[p];
                    codes[x] = if t == 0.0 {
                        GOAL
                    } else if !t.is_finite() {
                        NONE
                    } else {
                        distance_code(dist, p, &l.offsets)
                    };
                    // On a ridge between goals the gradient can point at a cell no nearer than
                    // this one (two goals diagonal to each other): then the best neighbour's
                    // step, so that following the flow always descends.
                    let d = field.descent(p);
                    let (dx, dy) = (d.x.round() as isize, d.y.round() as isize);
                    let ahead = p.wrapping_add_signed(dx + dy * l.stride as isize);
                    dirs[x] = if codes[x] < 8 && dist[ahead] >= t {
                        UNIT[codes[x] as usize]
                    } else {
                        d
                    };
                }
            });
    }

    /// Number of columns.
    #[must_use]
    pub fn width(&self) -> u32 {
        self.lattice.width
    }

    /// Number of rows.
    #[must_use]
    pub fn height(&self) -> u32 {
        self.lattice.height
    }

    /// The cell containing world point `p`, or `None` outside the grid.
    #[must_use]
    pub fn world_to_cell(&self, p: Vec2) -> Option<(u32, u32)> {
        self.lattice.world_to_cell(p)
    }

    /// World position of the centre of cell `(x, y)`.
    #[must_use]
    pub fn cell_center(&self, x: u32, y: u32) -> Vec2 {
        self.lattice.cell_center(x, y)
    }

    /// Whether `(x, y)` is a goal cell.
    #[must_use]
    pub fn is_goal(&self, x: u32, y: u32) -> bool {
        self.lattice
            .checked_index(x, y)
            .is_some_and(|p| self.codes[p] == GOAL)
    }

    /// Whether world point `p` lies in a goal cell (`false` outside the grid).
    #[must_use]
    #[inline]
    pub fn is_goal_at(&self, p: Vec2) -> bool {
        self.lattice
            .world_to_cell(p)
            .is_some_and(|(x, y)| self.codes[self.lattice.index(x, y)] == GOAL)
    }

    /// Whether a goal can be reached from `(x, y)` (goals included).
    #[must_use]
    pub fn is_reachable(&self, x: u32, y: u32) -> bool {
        self.lattice
            .checked_index(x, y)
            .is_some_and(|p| self.codes[p] != NONE)
    }

    /// The unit direction of cell `(x, y)`; zero on goals, walls, unreachable cells and outside.
    #[must_use]
    pub fn direction(&self, x: u32, y: u32) -> Vec2 {
        self.lattice
            .checked_index(x, y)
            .map_or(Vec2::ZERO, |p| self.dir(p))
    }

    /// The unit direction of padded cell `p` (zero where it has none).
    #[inline]
    fn dir(&self, p: usize) -> Vec2 {
        match self.dirs.get(p) {
            Some(&d) => d,
            None => unit(self.codes[p]),
        }
    }

    /// The cell `(x, y)`'s direction leads to, or `None` where it has none.
    #[must_use]
    pub fn next_cell(&self, x: u32, y: u32) -> Option<(u32, u32)> {
        let p = self.lattice.checked_index(x, y)?;
        let c = self.codes[p];
        (c < 8).then(|| self.lattice.coords(self.lattice.step(p, c as usize)))
    }

    /// The flow at world point `p`: a unit vector, or zero on a goal cell, outside the grid, and
    /// in cells that cannot reach a goal. See the module docs for the blending and wall rules.
    ///
    /// Where every neighbour of `p`'s cell has a direction or is a goal (most of an open
    /// area), no wall rule can apply: the four cells are blended without their checks, in the
    /// same order and with the same arithmetic as [`FlowField::sample_general`], so the bits
    /// are the same.
    #[must_use]
    #[inline]
    pub fn sample(&self, p: Vec2) -> Vec2 {
        let l = &self.lattice;
        let Some((cx, cy)) = l.world_to_cell(p) else {
            return Vec2::ZERO;
        };
        let c = l.index(cx, cy);
        if self.codes[c] >= 8 {
            return Vec2::ZERO;
        }
        let s = l.stride;
        // The padded border is NONE, so the 3 x 3 block round an interior cell is in range.
        let open = |row: usize| self.codes[row - 1..=row + 1].iter().all(|&k| k != NONE);
        if !(open(c - s) && open(c) && open(c + s)) {
            return self.sample_general(p);
        }
        let g = l.cell_space(p) - 0.5;
        let (bx, by) = (floor(g.x), floor(g.y));
        let (fx, fy) = (g.x - bx, g.y - by);
        let ox = bx as i64 - i64::from(cx);
        let oy = by as i64 - i64::from(cy);
        let q = c.wrapping_add_signed(ox as isize + oy as isize * s as isize);
        let mut v = Vec2::ZERO;
        v += (1.0 - fx) * (1.0 - fy) * self.dir(q);
        v += fx * (1.0 - fy) * self.dir(q + 1);
        v += (1.0 - fx) * fy * self.dir(q + s);
        v += fx * fy * self.dir(q + s + 1);
        let own_dir = self.dir(c);
        if v.dot(own_dir) <= 0.0 {
            return own_dir;
        }
        match v.try_normalize() {
            Some(r) if r.dot(own_dir) > 0.0 => r,
            _ => own_dir,
        }
    }

    /// [`FlowField::sample`] with every wall rule checked at every point: the reference its
    /// open-area path is tested against, and its path next to walls.
    #[must_use]
    pub fn sample_general(&self, p: Vec2) -> Vec2 {
        let l = &self.lattice;
        let Some((cx, cy)) = l.world_to_cell(p) else {
            return Vec2::ZERO;
        };
        let c = l.index(cx, cy);
        let own = self.codes[c];
        if own >= 8 {
            return Vec2::ZERO;
        }
        let open = |q: usize| self.codes[q] != NONE;
        // Bilinear weights over the 2x2 block of cell centres around `p`.
        let g = l.cell_space(p) - 0.5;
        let (bx, by) = (floor(g.x), floor(g.y));
        let (fx, fy) = (g.x - bx, g.y - by);
        // Offsets of the block's lower-left cell from the own cell: each 0 or -1.
        let ox = bx as i64 - i64::from(cx);
        let oy = by as i64 - i64::from(cy);
        let mut v = Vec2::ZERO;
        for (dx, dy, w) in [
            (0, 0, (1.0 - fx) * (1.0 - fy)),
            (1, 0, fx * (1.0 - fy)),
            (0, 1, (1.0 - fx) * fy),
            (1, 1, fx * fy),
        ] {
            let (rx, ry) = (ox + dx, oy + dy); // relative to the own cell, in -1..=1
            let q = c.wrapping_add_signed(rx as isize + ry as isize * l.stride as isize);
            if !open(q) {
                continue;
            }
            if rx != 0 && ry != 0 {
                // Diagonal: only when both cells it passes are open.
                let sx = c.wrapping_add_signed(rx as isize);
                let sy = c.wrapping_add_signed(ry as isize * l.stride as isize);
                if !open(sx) || !open(sy) {
                    continue;
                }
            }
            v += w * self.dir(q);
        }
        let own_dir = self.dir(c);
        if v.dot(own_dir) <= 0.0 {
            return own_dir;
        }
        // Clear components that point into walls next to the own cell.
        let sx: isize = if v.x > 0.0 { 1 } else { -1 };
        let sy: isize = if v.y > 0.0 { 1 } else { -1 };
        let stride = l.stride as isize;
        if v.x != 0.0 && !open(c.wrapping_add_signed(sx)) {
            v.x = 0.0;
        }
        if v.y != 0.0 && !open(c.wrapping_add_signed(sy * stride)) {
            v.y = 0.0;
        }
        if v.x != 0.0 && v.y != 0.0 && !open(c.wrapping_add_signed(sx + sy * stride)) {
            if v.x.abs() < v.y.abs() {
                v.x = 0.0;
            } else {
                v.y = 0.0;
            }
        }
        // Clearing may leave only a sideways part (the blend leaned into a wall): then the own
        // cell's direction is the only safe progress.
        match v.try_normalize() {
            Some(r) if r.dot(own_dir) > 0.0 => r,
            _ => own_dir,
        }
    }
}

/// `v.floor()` for `v > -2^31` without a libm call on targets lacking SSE4.1.
#[inline]
fn floor(v: f32) -> f32 {
    let t = v as i32 as f32;
    if t > v { t - 1.0 } else { t }
}

/// The direction code of padded cell `p` of a potential field with step counts `steps`: the
/// first neighbour in [`DIRECTIONS`] order with the fewest steps, fewer than `p`'s, that may be
/// stepped to (a diagonal needs both sides not walls), as
/// [`PotentialField::best_neighbour`].
#[inline]
fn potential_code(steps: &[u32], p: usize, o: &[isize; 8], eight: bool) -> u8 {
    let own = steps[p];
    if own == 0 {
        return GOAL;
    }
    if own >= UNSET {
        return NONE;
    }
    // `best` starts below UNSET, so walls and unreached cells are never taken.
    let mut best = own;
    let mut code = NONE;
    for (k, &off) in o[..4].iter().enumerate() {
        let s = steps[p.wrapping_add_signed(off)];
        if s < best {
            best = s;
            code = k as u8;
        }
    }
    if eight {
        for (k, &(a, b)) in DIAGONAL_SIDES.iter().enumerate() {
            let s = steps[p.wrapping_add_signed(o[k + 4])];
            if s < best
                && steps[p.wrapping_add_signed(o[a])] != WALL
                && steps[p.wrapping_add_signed(o[b])] != WALL
            {
                best = s;
                code = (k + 4) as u8;
            }
        }
    }
    code
}

/// The direction code of reachable non-goal padded cell `p` of a distance field `dist`: the
/// first neighbour in [`DIRECTIONS`] order with the smallest distance, smaller than `p`'s, that
/// may be stepped to (a diagonal needs both sides reachable).
#[inline]
fn distance_code(dist: &[f32], p: usize, o: &[isize; 8]) -> u8 {
    let mut best = dist[p];
    let mut code = NONE;
    for (k, &off) in o.iter().enumerate() {
        let d = dist[p.wrapping_add_signed(off)];
        if d >= best {
            continue;
        }
        if k >= 4 {
            let (a, b) = DIAGONAL_SIDES[k - 4];
            if !dist[p.wrapping_add_signed(o[a])].is_finite()
                || !dist[p.wrapping_add_signed(o[b])].is_finite()
            {
                continue;
            }
        }
        best = d;
        code = k as u8;
    }
    code
}

#[inline]
fn unit(code: u8) -> Vec2 {
    if code < 8 {
        UNIT[code as usize]
    } else {
        Vec2::ZERO
    }
}

fn code_of(lattice: &Lattice, p: usize, q: usize) -> u8 {
    let k = lattice
        .offsets
        .iter()
        .position(|&o| p.wrapping_add_signed(o) == q);
    debug_assert!(k.is_some() && k.unwrap() < DIRECTIONS.len());
    k.map_or(NONE, |k| k as u8)
}

fn build(lattice: &Lattice, code: impl Fn(usize) -> u8 + Sync) -> Vec<u8> {
    let mut codes = vec![NONE; lattice.len];
    let stride = lattice.stride;
    let w = lattice.width as usize;
    codes
        .par_chunks_mut(stride)
        .enumerate()
        .with_min_len(16)
        .for_each(|(row, out)| {
            if row == 0 || row > lattice.height as usize {
                return;
            }
            for (x, o) in out[1..=w].iter_mut().enumerate() {
                *o = code(row * stride + x + 1);
            }
        });
    codes
}
