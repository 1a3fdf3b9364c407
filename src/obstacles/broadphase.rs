//! A static uniform grid over obstacles, so that an agent only looks at the obstacles near it.

use glam::Vec2;

use super::{Circle, Wall};

/// Cell lists of circle and wall ids over the obstacles' bounding box. Queries outside the box
/// clamp to its edge cells, which is exact because every obstacle lies inside the box.
#[derive(Clone, Debug, Default)]
pub struct ObstacleGrid {
    origin: Vec2,
    cell: f32,
    cols: usize,
    rows: usize,
    /// `starts[c]..starts[c + 1]` indexes `items` for cell `c`.
    starts: Vec<u32>,
    /// Ids, circles as `id`, walls as `id | WALL`.
    items: Vec<u32>,
}

const WALL: u32 = 1 << 31;

impl ObstacleGrid {
    /// Rebuilds the grid for these obstacles.
    pub fn rebuild(&mut self, circles: &[Circle], walls: &[Wall]) {
        let mut lo = Vec2::splat(f32::INFINITY);
        let mut hi = Vec2::splat(f32::NEG_INFINITY);
        let mut size_sum = 0.0_f32;
        for c in circles {
            lo = lo.min(c.center - c.radius);
            hi = hi.max(c.center + c.radius);
            size_sum += 2.0 * c.radius;
        }
        for w in walls {
            lo = lo.min(w.a.min(w.b));
            hi = hi.max(w.a.max(w.b));
            size_sum += (w.b - w.a).length().min(10.0);
        }
        let count = circles.len() + walls.len();
        if count == 0 {
            *self = Self::default();
            return;
        }
        let extent = (hi - lo).max(Vec2::splat(1e-3));
        // Cells about twice the mean obstacle size, at most ~4 cells per obstacle overall.
        let mean = (size_sum / count as f32).max(1e-3);
        let min_cell = (extent.x * extent.y / (4.0 * count as f32).max(1.0)).sqrt();
        let cell = (2.0 * mean).max(min_cell).max(1e-3);
        self.origin = lo;
        self.cell = cell;
        self.cols = ((extent.x / cell).ceil() as usize).clamp(1, 4096);
        self.rows = ((extent.y / cell).ceil() as usize).clamp(1, 4096);
        let n = self.cols * self.rows;
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); n];
        for (i, c) in circles.iter().enumerate() {
            self.for_cells(c.center - c.radius, c.center + c.radius, |k| {
                lists[k].push(i as u32)
            });
        }
        for (i, w) in walls.iter().enumerate() {
            // Cells of the segment's bounding box that the segment's swept box can touch.
            self.for_cells(w.a.min(w.b), w.a.max(w.b), |k| {
                lists[k].push(i as u32 | WALL)
            });
        }
        self.starts.clear();
        self.items.clear();
        self.starts.push(0);
        for l in &lists {
            self.items.extend_from_slice(l);
            self.starts.push(self.items.len() as u32);
        }
    }

    fn cell_of(&self, p: Vec2) -> (usize, usize) {
        let f = (p - self.origin) / self.cell;
        let cx = if f.x > 0.0 {
            (f.x as usize).min(self.cols - 1)
        } else {
            0
        };
        let cy = if f.y > 0.0 {
            (f.y as usize).min(self.rows - 1)
        } else {
            0
        };
        (cx, cy)
    }

    fn for_cells(&self, lo: Vec2, hi: Vec2, mut f: impl FnMut(usize)) {
        let (c0, r0) = self.cell_of(lo);
        let (c1, r1) = self.cell_of(hi);
        for r in r0..r1 + 1 {
            for c in c0..c1 + 1 {
                f(r * self.cols + c);
            }
        }
    }

    /// The ids of the circles and walls that may lie within `r` of `p`, each once, ascending
    /// (the buffers are cleared first).
    pub fn near(&self, p: Vec2, r: f32, circles: &mut Vec<u32>, walls: &mut Vec<u32>) {
        circles.clear();
        walls.clear();
        if self.items.is_empty() {
            return;
        }
        self.visit(p, r, |c| circles.push(c), |w| walls.push(w));
        // A cell lists each obstacle once, circles and walls each ascending (`rebuild` adds
        // them in id order), so only a query over several cells needs sorting.
        if self.cell_of(p - r) != self.cell_of(p + r) {
            for v in [circles, walls] {
                v.sort_unstable();
                v.dedup();
            }
        }
    }

    /// Calls `circle(id)` / `wall(id)` for every obstacle that may lie within `r` of `p` (an id
    /// may come more than once).
    pub fn visit(&self, p: Vec2, r: f32, mut circle: impl FnMut(u32), mut wall: impl FnMut(u32)) {
        if self.items.is_empty() {
            return;
        }
        self.for_cells(p - r, p + r, |k| {
            for &id in &self.items[self.starts[k] as usize..self.starts[k + 1] as usize] {
                if id & WALL == 0 {
                    circle(id)
                } else {
                    wall(id & !WALL)
                }
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::AgentRng;

    #[test]
    fn near_lists_each_candidate_once_ascending_in_one_cell_or_many() {
        let mut rng = AgentRng::new(3, 0, 0, 0);
        let mut p = || Vec2::new(50.0 * rng.unit(), 20.0 * rng.unit());
        let circles: Vec<Circle> = (0..30).map(|_| Circle::new(p(), 0.5)).collect();
        let walls: Vec<Wall> = (0..40).map(|_| Wall { a: p(), b: p() }).collect();
        let mut grid = ObstacleGrid::default();
        grid.rebuild(&circles, &walls);
        let (mut c, mut w) = (Vec::new(), Vec::new());
        for k in 0..400 {
            let q = p() * 1.2 - Vec2::splat(2.0);
            let r = [0.0, 0.5, 2.0, 30.0][k % 4];
            grid.near(q, r, &mut c, &mut w);
            let (mut want_c, mut want_w) = (Vec::new(), Vec::new());
            grid.visit(q, r, |i| want_c.push(i), |i| want_w.push(i));
            for v in [&mut want_c, &mut want_w] {
                v.sort_unstable();
                v.dedup();
            }
            assert_eq!((&c, &w), (&want_c, &want_w), "at {q} within {r}");
        }
    }
}
