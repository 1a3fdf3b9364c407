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

impl FlowField {
    /// [`FlowField::sample`] at the first `len` of `N` points at once (zero in the other lanes),
    /// the same bits in every lane: the cells and
    /// bilinear weights computed lane by lane, each lane's own cell, its 3x3 block's walls and
    /// the four blended directions gathered, then the blend and the wall rules with each case
    /// computed in every lane and the lane's own selected (a cell the scalar path skips leaves
    /// the sum as it was).
    #[inline(always)]
    pub(crate) fn sample_lanes<const N: usize>(
        &self,
        px: &[f32; N],
        py: &[f32; N],
        len: usize,
    ) -> ([f32; N], [f32; N]) {
        let l = &self.lattice;
        let (width, height) = (l.width as usize, l.height as usize);
        // In lanes: `cell_space`, `cell_coords`' test and cell, the block's corner and weights.
        let (mut inside, mut cx, mut cy) = ([false; N], [0_u32; N], [0_u32; N]);
        let (mut fx, mut fy, mut ox, mut oy) = ([0.0_f32; N], [0.0_f32; N], [0_i32; N], [0_i32; N]);
        for k in 0..N {
            let u = l.cell_space(Vec2::new(px[k], py[k]));
            inside[k] = u.x >= 0.0 && u.y >= 0.0 && u.x <= width as f32 && u.y <= height as f32;
            cx[k] = (u.x as u32).min(l.width - 1);
            cy[k] = (u.y as u32).min(l.height - 1);
            let g = u - 0.5;
            let (bx, by) = (floor(g.x), floor(g.y));
            (fx[k], fy[k]) = (g.x - bx, g.y - by);
            ox[k] = bx as i32 - cx[k] as i32;
            oy[k] = by as i32 - cy[k] as i32;
        }
        // Per lane (the first `len`): whether the scalar path blends at all, the open cells of
        // the 3x3 block around the own cell (bit `3 (dy + 1) + dx + 1`), the four blended
        // cells' directions (zero where skipped) and whether each counts, the own cell's
        // direction.
        let mut valid = [false; N];
        let mut open = [0_u16; N];
        let (mut dx, mut dy, mut on) = ([[0.0_f32; N]; 4], [[0.0_f32; N]; 4], [[false; N]; 4]);
        let (mut odx, mut ody) = ([0.0_f32; N], [0.0_f32; N]);
        let stride = l.stride;
        let continuous = !self.dirs.is_empty();
        const BLOCK: [(i32, i32); 4] = [(0, 0), (1, 0), (0, 1), (1, 1)];
        for k in 0..len.min(N) {
            if !inside[k] {
                continue;
            }
            let c = l.index(cx[k], cy[k]);
            if self.codes[c] >= 8 {
                continue;
            }
            valid[k] = true;
            debug_assert!((-1..=0).contains(&ox[k]) && (-1..=0).contains(&oy[k]));
            // The padded lattice has a cell on every side of an interior one.
            let mut block = [NONE; 9];
            for (r, row) in block.chunks_exact_mut(3).enumerate() {
                let start = c + r * stride - stride - 1;
                row.copy_from_slice(&self.codes[start..start + 3]);
            }
            let mut bits = 0_u16;
            for (b, &code) in block.iter().enumerate() {
                bits |= u16::from(code != NONE) << b;
            }
            open[k] = bits;
            let at = |rx: i32, ry: i32| (3 * (ry + 1) + rx + 1) as usize;
            let is_open = |rx: i32, ry: i32| (bits >> at(rx, ry)) & 1 == 1;
            let dir = |rx: i32, ry: i32| {
                if continuous {
                    self.dirs[(c + (ry + 1) as usize * stride + (rx + 1) as usize) - stride - 1]
                } else {
                    unit(block[at(rx, ry)])
                }
            };
            for (j, (bx, by)) in BLOCK.into_iter().enumerate() {
                let (rx, ry) = (ox[k] + bx, oy[k] + by);
                let counts =
                    is_open(rx, ry) && (rx == 0 || ry == 0 || (is_open(rx, 0) && is_open(0, ry)));
                let d = if counts { dir(rx, ry) } else { Vec2::ZERO };
                (dx[j][k], dy[j][k], on[j][k]) = (d.x, d.y, counts);
            }
            let d = dir(0, 0);
            (odx[k], ody[k]) = (d.x, d.y);
        }
        // In lanes: the blend, then the wall rules, as `sample` orders them.
        let (mut rx_out, mut ry_out) = ([0.0_f32; N], [0.0_f32; N]);
        for k in 0..N {
            let w = [
                (1.0 - fx[k]) * (1.0 - fy[k]),
                fx[k] * (1.0 - fy[k]),
                (1.0 - fx[k]) * fy[k],
                fx[k] * fy[k],
            ];
            let (mut vx, mut vy) = (0.0_f32, 0.0_f32);
            for j in 0..4 {
                let (sx, sy) = (vx + w[j] * dx[j][k], vy + w[j] * dy[j][k]);
                vx = if on[j][k] { sx } else { vx };
                vy = if on[j][k] { sy } else { vy };
            }
            let (odx, ody) = (odx[k], ody[k]);
            let back = vx * odx + vy * ody <= 0.0;
            let bits = open[k];
            let is_open = |rx: i32, ry: i32| (bits >> (3 * (ry + 1) + rx + 1)) & 1 == 1;
            let sx = if vx > 0.0 { 1 } else { -1 };
            let sy = if vy > 0.0 { 1 } else { -1 };
            if vx != 0.0 && !is_open(sx, 0) {
                vx = 0.0;
            }
            if vy != 0.0 && !is_open(0, sy) {
                vy = 0.0;
            }
            if vx != 0.0 && vy != 0.0 && !is_open(sx, sy) {
                if vx.abs() < vy.abs() {
                    vx = 0.0;
                } else {
                    vy = 0.0;
                }
            }
            // `try_normalize`, kept when it leans along the own direction.
            let rcp = 1.0 / (vx * vx + vy * vy).sqrt();
            let (nx, ny) = (vx * rcp, vy * rcp);
            let keep = rcp.is_finite() && rcp > 0.0 && nx * odx + ny * ody > 0.0 && !back;
            let (rx, ry) = if keep { (nx, ny) } else { (odx, ody) };
            (rx_out[k], ry_out[k]) = if valid[k] { (rx, ry) } else { (0.0, 0.0) };
        }
        (rx_out, ry_out)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::{Cell, Neighbourhood, OccupancyGrid};

    /// A grid of `w` x `h` cells of size `cell` from `origin`, about a third walls (a fixed
    /// pseudo-random pattern), and its goals.
    fn grid(w: u32, h: u32, cell: f32, origin: Vec2) -> (OccupancyGrid, Vec<(u32, u32)>) {
        let mut g = OccupancyGrid::new(w, h)
            .unwrap()
            .with_geometry(cell, origin)
            .unwrap();
        let mut s = 0x9e37_79b9_u32;
        let goals = vec![(1, 1), (w - 2, h / 2)];
        for y in 0..h {
            for x in 0..w {
                s ^= s << 13;
                s ^= s >> 17;
                s ^= s << 5;
                if s.is_multiple_of(3) && !goals.contains(&(x, y)) {
                    g.set(x, y, Cell::Wall).unwrap();
                }
            }
        }
        (g, goals)
    }

    /// Points over the grid and a margin around it: pseudo-random ones, cell corners, centres
    /// and edges (where the blend's corner and the own cell change), and the far edges.
    fn points(w: u32, h: u32, cell: f32, origin: Vec2) -> Vec<Vec2> {
        let mut v = Vec::new();
        let mut s = 0x2545_f491_u32;
        let mut unit = || {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            s as f32 / u32::MAX as f32
        };
        let (sw, sh) = (w as f32 * cell, h as f32 * cell);
        for _ in 0..4000 {
            let p = Vec2::new(unit() * (sw + 4.0) - 2.0, unit() * (sh + 4.0) - 2.0);
            v.push(origin + p);
        }
        for y in 0..=2 * h {
            for x in 0..=2 * w {
                let p = Vec2::new(x as f32, y as f32) * (0.5 * cell);
                v.extend([
                    origin + p,
                    origin + p + Vec2::splat(1e-4),
                    origin + p - 1e-4,
                ]);
            }
        }
        v.extend([
            origin + Vec2::new(sw, sh),
            origin + Vec2::new(sw, 0.3),
            origin,
        ]);
        v
    }

    #[test]
    fn the_lanes_sample_gives_the_scalar_samples_bits() {
        for (cell, origin) in [
            (1.0, Vec2::ZERO),
            (2.0, Vec2::new(-3.5, 7.25)),
            (0.7, Vec2::ONE),
        ] {
            let (w, h) = (23, 17);
            let (g, goals) = grid(w, h, cell, origin);
            let potential = PotentialField::bfs(&g, &goals, 0.9, Neighbourhood::Eight).unwrap();
            let four = PotentialField::bfs(&g, &goals, 0.9, Neighbourhood::Four).unwrap();
            let distance = DistanceField::fast_marching(&g, &goals).unwrap();
            let flows = [
                FlowField::from_potential(&potential),
                FlowField::from_potential(&four),
                FlowField::from_distance(&distance),
            ];
            let pts = points(w, h, cell, origin);
            for flow in &flows {
                let mut blended = 0;
                for block in pts.chunks(8) {
                    let (mut px, mut py) = ([0.0; 8], [0.0; 8]);
                    for (k, p) in block.iter().enumerate() {
                        (px[k], py[k]) = (p.x, p.y);
                    }
                    let (sx, sy) = flow.sample_lanes(&px, &py, block.len());
                    for (k, p) in block.iter().enumerate() {
                        let s = flow.sample(*p);
                        assert_eq!(
                            (sx[k].to_bits(), sy[k].to_bits()),
                            (s.x.to_bits(), s.y.to_bits()),
                            "at {p}: lanes ({}, {}), scalar {s}",
                            sx[k],
                            sy[k]
                        );
                        // Count the samples that are not a cell's own unit step.
                        blended += usize::from(s.x != 0.0 && s.y != 0.0 && s.x.abs() != s.y.abs());
                    }
                }
                assert!(blended > 100, "the points exercise the blend: {blended}");
            }
        }
    }
}
