//! The fused neighbour traversal: every flocking, repulsion and Vicsek sum of an agent in one pass.
//!
//! Two paths compute the same [`NeighbourSums`]:
//!
//! - the **scalar reference** asks the [`NeighbourIndex`] for the neighbours within the largest
//!   radius (ascending index order, so every backend gives bit-identical sums) and accumulates
//!   them one by one; it also serves neighbour caps, and repulsion where the cell batch does not
//!   (`cells`: repulsion alone, with a whole exponent up to 4);
//! - the **grid kernel** reads the neighbour cells of the uniform grid as contiguous runs of
//!   the grid's cell-ordered positions (padded with a block of zeros) and cell-ordered copies of
//!   the velocities and groups, eight lanes at a time, with runtime CPU-feature dispatch (clones
//!   for AVX-512, AVX2 + FMA and AVX, the first the processor has, else the baseline x86-64
//!   build, SSE2). It sums in a different order than the reference, so the two agree to
//!   rounding, not bit for bit; each is deterministic and independent of the thread count.

use glam::Vec2;
use rayon::prelude::*;

use super::spec::{ALI, COH, FlatSpec, NeighbourSpec, QueryAgent, SEP};
use crate::agents::{AgentOrder, Agents};
use crate::bounds::Bounds;
use crate::gravity::distance_power;
use crate::simd::{apply, float_kernel};
use crate::spatial::{GridIndex, Neighbour, NeighbourIndex, SORTED_PAD, SpatialIndex};
use crate::steering::NeighbourSums;

/// SIMD width of the grid kernel.
pub(crate) const LANES: usize = 8;

// The grid kernel here and the cell batch's gather (`cells::gather::append_motion`) read the grid's
// sorted positions in whole blocks of `LANES`, up to `LANES - 1` values past a run's end: the
// grid's padding must hold them.
const _: () = assert!(SORTED_PAD >= LANES);

/// `x.is_finite() && x > 0.0` as two ordered comparisons, which vectorise (the class test
/// behind `is_finite` compiles to scalar bit tests per lane).
#[inline(always)]
pub(crate) fn positive_finite(x: f32) -> bool {
    (x > 0.0) & (x <= f32::MAX)
}

/// Cell-ordered copies of what the kernel reads besides the positions (which the grid keeps in
/// that order, [`GridIndex::sorted_padded`]), padded with `LANES` zeros so that a block of eight
/// lanes never reads past the end.
#[derive(Debug, Default)]
pub(crate) struct SortedCopies {
    pub vx: Vec<f32>,
    pub vy: Vec<f32>,
    pub g: Vec<f32>,
    /// Unit headings (velocity, or orientation at rest), filled only when some plan needs them.
    pub hx: Vec<f32>,
    pub hy: Vec<f32>,
    /// Whether `hx` and `hy` hold this frame's headings.
    pub headings: bool,
    /// Whether `g` holds zeros alone (the last fill had one group).
    g_zero: bool,
    /// The agents' order the copies were filled for.
    order: AgentOrder,
}

/// `dst[k] = f(order[k])` for every `k`, in parallel chunks, with `LANES` zeros of padding.
fn gather_into(dst: &mut Vec<f32>, order: &[u32], f: impl Fn(usize) -> f32 + Sync) {
    const CHUNK: usize = 8192;
    let n = order.len();
    dst.resize(n + LANES, 0.0);
    dst[n..].fill(0.0);
    dst[..n]
        .par_chunks_mut(CHUNK)
        .zip(order.par_chunks(CHUNK))
        .for_each(|(d, o)| {
            for (d, &j) in d.iter_mut().zip(o) {
                *d = f(j as usize);
            }
        });
}

/// `dst_x[k] = src_x[order[k]]` and `dst_y[k] = src_y[order[k]]` for every `k`, in parallel
/// chunks, with `LANES` zeros of padding: both columns in one pass over the order, whose indices
/// are clamped below the length (a select, instead of a bounds-check branch per load; the order
/// is a permutation, so the clamp never changes an index).
fn gather_pair_into(
    (dst_x, dst_y): (&mut Vec<f32>, &mut Vec<f32>),
    order: &[u32],
    (src_x, src_y): (&[f32], &[f32]),
) {
    const CHUNK: usize = 8192;
    let n = order.len();
    for d in [&mut *dst_x, &mut *dst_y] {
        d.resize(n + LANES, 0.0);
        d[n..].fill(0.0);
    }
    let last = src_x.len().min(src_y.len()).saturating_sub(1);
    if n == 0 {
        return;
    }
    let (src_x, src_y) = (&src_x[..=last], &src_y[..=last]);
    dst_x[..n]
        .par_chunks_mut(CHUNK)
        .zip(dst_y[..n].par_chunks_mut(CHUNK))
        .zip(order.par_chunks(CHUNK))
        .for_each(|((dx, dy), o)| {
            let dy = &mut dy[..dx.len()];
            for (k, &j) in o.iter().enumerate().take(dx.len()) {
                // An index past the sources means an order of another set of agents (a stale
                // grid).
                debug_assert!((j as usize) <= last, "order index {j} past {last}");
                let j = (j as usize).min(last);
                dx[k] = src_x[j];
                dy[k] = src_y[j];
            }
        });
}

impl SortedCopies {
    /// The agents' order the copies were last filled for ([`AgentOrder::NONE`] before the first).
    pub(crate) fn order(&self) -> AgentOrder {
        self.order
    }

    /// Fills the copies in the grid's order from the agents' buffers (the unit headings only
    /// when `headings`), for the agents' current order. With `one_group` (every agent in group
    /// 0) the groups are zeros, which stay from the previous fill when it had them too and the
    /// number of agents is the same.
    pub(crate) fn fill(
        &mut self,
        grid: &GridIndex,
        agents: &Agents,
        headings: bool,
        one_group: bool,
    ) {
        let order = grid.order();
        self.order = agents.order();
        let (vel_x, vel_y, group) = (&agents.vel_x, &agents.vel_y, &agents.group);
        let SortedCopies {
            vx,
            vy,
            g,
            g_zero,
            hx,
            hy,
            headings: filled,
            order: _,
        } = self;
        rayon::join(
            || {
                if !one_group {
                    gather_into(g, order, |j| group[j] as f32);
                } else if !*g_zero || g.len() != order.len() + LANES {
                    g.clear();
                    g.resize(order.len() + LANES, 0.0);
                }
                *g_zero = one_group;
            },
            || {
                gather_pair_into((vx, vy), order, (vel_x, vel_y));
            },
        );
        *filled = headings;
        if headings {
            unit_headings((vx, vy), (hx, hy), order, &agents.orientation);
        }
    }
}

/// `(hx, hy) = (vx, vy) / |(vx, vy)|` where that is defined (glam's `try_normalize`: the
/// reciprocal length, when positive and finite); returns whether some velocity has no direction.
#[apply(float_kernel!)]
fn unit_lanes((vx, vy): (&[f32], &[f32]), (hx, hy): (&mut [f32], &mut [f32])) -> bool {
    let n = hx.len();
    let (hy, vx, vy) = (&mut hy[..n], &vx[..n], &vy[..n]);
    let mut rest = false;
    for k in 0..n {
        let rcp = 1.0 / (vx[k] * vx[k] + vy[k] * vy[k]).sqrt();
        rest |= !positive_finite(rcp);
        (hx[k], hy[k]) = (vx[k] * rcp, vy[k] * rcp);
    }
    rest
}

/// The unit headings of the cell-ordered velocities `(vx, vy)` into `(hx, hy)` (same padding),
/// as [`unit_heading`] computes them, in parallel chunks ([`unit_headings_at`]).
fn unit_headings(
    (vx, vy): (&[f32], &[f32]),
    (hx, hy): (&mut Vec<f32>, &mut Vec<f32>),
    order: &[u32],
    orientation: &[f32],
) {
    const CHUNK: usize = 8192;
    let n = order.len();
    for h in [&mut *hx, &mut *hy] {
        h.resize(n + LANES, 0.0);
        h[n..].fill(0.0);
    }
    (hx[..n].par_chunks_mut(CHUNK), hy[..n].par_chunks_mut(CHUNK))
        .into_par_iter()
        .enumerate()
        .for_each(|(c, (hx, hy))| {
            let positions = c * CHUNK..c * CHUNK + hx.len();
            unit_headings_at((vx, vy), positions, (hx, hy), order, orientation);
        });
}

/// The unit headings of the agents at grid positions `positions` into `(hx, hy)` (one value
/// per position), as [`unit_heading`] computes them: in vector lanes from the cell-ordered
/// velocities `(vx, vy)`, then the agents at rest (no direction) along their orientations
/// (`orientation` in storage order, `order` the grid's).
pub(crate) fn unit_headings_at(
    (vx, vy): (&[f32], &[f32]),
    positions: std::ops::Range<usize>,
    (hx, hy): (&mut [f32], &mut [f32]),
    order: &[u32],
    orientation: &[f32],
) {
    let (vx, vy) = (&vx[positions.clone()], &vy[positions.clone()]);
    if unit_lanes((vx, vy), (&mut *hx, &mut *hy)) {
        for (k, &j) in order[positions].iter().enumerate() {
            if !positive_finite(1.0 / (vx[k] * vx[k] + vy[k] * vy[k]).sqrt()) {
                let h = Vec2::from_angle(orientation[j as usize]);
                (hx[k], hy[k]) = (h.x, h.y);
            }
        }
    }
}

/// The querying agent, as the traversal sees it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Querier {
    pub position: Vec2,
    pub velocity: Vec2,
    /// Unit heading for view cones.
    pub heading: Vec2,
    pub group: u32,
}

/// Scalar reference: the sums from the index's neighbour list.
pub(crate) fn sums_scalar(
    index: &SpatialIndex,
    i: usize,
    me: &Querier,
    spec: &NeighbourSpec,
    agents: &Agents,
    buf: &mut Vec<Neighbour>,
) -> NeighbourSums {
    let (vel_x, vel_y, group) = (&agents.vel_x, &agents.vel_y, &agents.group);
    match spec.cap {
        Some(k) => index.k_nearest_at(me.position, k as usize, spec.query_r, Some(i), buf),
        None => index.neighbours_of(i, spec.query_r, buf),
    }
    let mut s = NeighbourSums::default();
    for nb in buf.iter() {
        let j = nb.index as usize;
        let (d, d2) = (nb.offset, nb.dist_sq);
        s.count += 1.0;
        let same = group[j] == me.group;
        let dist = d2.sqrt();
        let dot = me.heading.dot(d);
        let sees = |b: usize| {
            spec.on[b]
                && d2 <= spec.r_sq[b]
                && (!spec.same[b] || same)
                && (spec.cos[b] <= -1.0 || dot >= spec.cos[b] * dist)
        };
        if sees(SEP) && d2 > 0.0 {
            s.separation -= d / d2;
        }
        if sees(ALI) {
            s.alignment += Vec2::new(vel_x[j], vel_y[j]);
            s.alignment_count += 1.0;
        }
        if sees(COH) {
            s.cohesion += d;
            s.cohesion_count += 1.0;
        }
        if let Some((strength, exponent, r_sq)) = spec.repel
            && d2 <= r_sq
            && d2 > 0.0
        {
            s.repulsion -= d / dist * (strength / distance_power(dist, d2, exponent));
        }
        if let Some(r_sq) = spec.vicsek_r_sq
            && d2 <= r_sq
        {
            s.heading += unit_heading(agents, j);
        }
    }
    s
}

/// Agent `j`'s unit velocity, or its unit orientation when it is at rest.
#[inline]
pub(crate) fn unit_heading(agents: &Agents, j: usize) -> Vec2 {
    agents
        .velocity(j)
        .try_normalize()
        .unwrap_or_else(|| Vec2::from_angle(agents.orientation[j]))
}

/// Everything the lane kernel needs about the query: the agent's own numbers, the spec's
/// [`FlatSpec`] and the torus.
#[derive(Clone, Copy, Debug)]
struct KernelQuery {
    /// The querying agent.
    me: QueryAgent,
    /// The spec's radii, cosines and groups.
    flat: FlatSpec,
    /// Per slot: all round (no view cone).
    full: [bool; 3],
    /// Half the torus side per axis (infinite when the world does not wrap) and the side.
    half_w: f32,
    half_h: f32,
    w: f32,
    h: f32,
}

/// The grid kernel: sums over the neighbour cells of `me`, read as contiguous runs.
pub(crate) fn sums_grid(
    grid: &GridIndex,
    sorted: &SortedCopies,
    bounds: Bounds,
    me: &Querier,
    spec: &NeighbourSpec,
    one_group: bool,
) -> NeighbourSums {
    // On a torus, offsets need the minimum image only when the gathered cells reach across a
    // seam; away from the seams the plain difference is already the minimum image.
    let (half_w, half_h, w, h) = match bounds {
        Bounds::Torus { size } => {
            let reach = grid.cell_size() + Vec2::splat(spec.query_r * 1.001);
            let p = me.position;
            let inside = p.x - reach.x >= 0.0
                && p.x + reach.x < size.x
                && p.y - reach.y >= 0.0
                && p.y + reach.y < size.y
                && reach.x <= 0.5 * size.x
                && reach.y <= 0.5 * size.y;
            if inside {
                (f32::INFINITY, f32::INFINITY, 0.0, 0.0)
            } else {
                (0.5 * size.x, 0.5 * size.y, size.x, size.y)
            }
        }
        _ => (f32::INFINITY, f32::INFINITY, 0.0, 0.0),
    };
    let flat: FlatSpec = spec.flat(one_group);
    let q = KernelQuery {
        me: QueryAgent {
            x: me.position.x,
            y: me.position.y,
            hx: me.heading.x,
            hy: me.heading.y,
            g: me.group as f32,
        },
        flat,
        full: flat.cos.map(|c| c <= -1.0),
        half_w,
        half_h,
        w,
        h,
    };
    let wrapping = half_w.is_finite();
    let mode = u8::from(q.full.iter().any(|f| !f))
        | (u8::from(wrapping) << 1)
        | (u8::from(q.flat.any_group.iter().all(|&a| a)) << 2);
    let mut runs = [(0u32, 0u32); MAX_RUNS];
    let mut nr = 0;
    let mut total = NeighbourSums::default();
    let flush = |runs: &[(u32, u32)], total: &mut NeighbourSums| {
        let part = kernel(runs, (grid.sorted_padded(), sorted), &q, mode);
        add_sums(total, &part);
    };
    if wrapping {
        grid.for_each_run(me.position, spec.query_r, |r| {
            runs[nr] = (r.start as u32, r.end as u32);
            nr += 1;
            if nr == MAX_RUNS {
                flush(&runs, &mut total);
                nr = 0;
            }
        });
    } else {
        // No seam in reach: the window of cells is a rectangle, each of its rows one run.
        let rg = Vec2::splat(spec.query_r * 1.001 + 1e-6);
        let (c0, r0) = grid.cell_of(me.position - rg);
        let (c1, r1) = grid.cell_of(me.position + rg);
        let starts = grid.cell_start();
        let cols = grid.cells_x() as usize;
        for row in r0 as usize..r1 as usize + 1 {
            runs[nr] = (
                starts[row * cols + c0 as usize],
                starts[row * cols + c1 as usize + 1],
            );
            nr += 1;
            if nr == MAX_RUNS {
                flush(&runs, &mut total);
                nr = 0;
            }
        }
    }
    if nr > 0 {
        flush(&runs[..nr], &mut total);
    }
    without_self(total, me.velocity, spec)
}

/// Sums over a neighbourhood that held the querying agent itself (offset zero, its own
/// velocity) with its contributions taken out again.
#[inline]
pub(crate) fn without_self(
    mut s: NeighbourSums,
    velocity: Vec2,
    spec: &NeighbourSpec,
) -> NeighbourSums {
    s.count -= 1.0;
    if spec.on[ALI] {
        s.alignment -= velocity;
        s.alignment_count -= 1.0;
    }
    if spec.on[COH] {
        s.cohesion_count -= 1.0;
    }
    s
}

/// Runs handed to the kernel at once.
const MAX_RUNS: usize = 16;

fn add_sums(total: &mut NeighbourSums, part: &NeighbourSums) {
    total.separation += part.separation;
    total.alignment += part.alignment;
    total.alignment_count += part.alignment_count;
    total.cohesion += part.cohesion;
    total.cohesion_count += part.cohesion_count;
    total.count += part.count;
}

#[apply(float_kernel!)]
fn kernel(
    runs: &[(u32, u32)],
    s: ((&[f32], &[f32]), &SortedCopies),
    q: &KernelQuery,
    mode: u8,
) -> NeighbourSums {
    match mode {
        0 => kernel_body::<false, false, false>(runs, s, q),
        1 => kernel_body::<true, false, false>(runs, s, q),
        2 => kernel_body::<false, true, false>(runs, s, q),
        3 => kernel_body::<true, true, false>(runs, s, q),
        4 => kernel_body::<false, false, true>(runs, s, q),
        5 => kernel_body::<true, false, true>(runs, s, q),
        6 => kernel_body::<false, true, true>(runs, s, q),
        _ => kernel_body::<true, true, true>(runs, s, q),
    }
}

/// Minimum image of one lane's difference (identity when `half` is infinite).
#[inline(always)]
fn wrap(d: f32, half: f32, side: f32) -> f32 {
    if d > half {
        d - side
    } else if d < -half {
        d + side
    } else {
        d
    }
}

/// 1.0 when `b`, else 0.0.
#[inline(always)]
fn one_if(b: bool) -> f32 {
    if b { 1.0 } else { 0.0 }
}

#[inline(always)]
fn kernel_body<const VIEW: bool, const WRAP: bool, const ALL_GROUPS: bool>(
    runs: &[(u32, u32)],
    ((xs, ys), s): ((&[f32], &[f32]), &SortedCopies),
    q: &KernelQuery,
) -> NeighbourSums {
    let z = [0.0_f32; LANES];
    let (mut sx, mut sy, mut ax, mut ay, mut an, mut cx, mut cy, mut cn, mut n) =
        (z, z, z, z, z, z, z, z, z);
    let lane_id: [f32; LANES] = std::array::from_fn(|l| l as f32);
    for &(a, b) in runs {
        let (a, b) = (a as usize, b as usize);
        // Whole blocks of eight, the last one reaching into the padding.
        let end = a + (b - a).div_ceil(LANES) * LANES;
        let blocks = xs[a..end]
            .chunks_exact(LANES)
            .zip(ys[a..end].chunks_exact(LANES))
            .zip(s.vx[a..end].chunks_exact(LANES))
            .zip(s.vy[a..end].chunks_exact(LANES))
            .zip(s.g[a..end].chunks_exact(LANES));
        let mut left = (b - a) as f32;
        for ((((xs, ys), vxs), vys), gs) in blocks {
            // Masks are 0.0 / 1.0 floats and "and" is a product: plain float arithmetic that the
            // compiler turns into one vector instruction per operation.
            for l in 0..LANES {
                let valid = one_if(lane_id[l] < left);
                let (dx, dy) = if WRAP {
                    (
                        wrap(xs[l] - q.me.x, q.half_w, q.w),
                        wrap(ys[l] - q.me.y, q.half_h, q.h),
                    )
                } else {
                    (xs[l] - q.me.x, ys[l] - q.me.y)
                };
                let d2 = dx * dx + dy * dy;
                let same = if ALL_GROUPS {
                    1.0
                } else {
                    one_if(gs[l] == q.me.g)
                };
                let (dot, dist) = if VIEW {
                    (q.me.hx * dx + q.me.hy * dy, d2.sqrt())
                } else {
                    (0.0, 0.0)
                };
                let sees = |b: usize| {
                    let group = if q.flat.any_group[b] { 1.0 } else { same };
                    let view = if !VIEW || q.full[b] {
                        1.0
                    } else {
                        one_if(dot >= q.flat.cos[b] * dist)
                    };
                    valid * one_if(d2 <= q.flat.r_sq[b]) * group * view
                };
                let ms = sees(SEP) * one_if(d2 > 0.0);
                let ma = sees(ALI);
                let mc = sees(COH);
                let inv = 1.0 / d2.max(f32::MIN_POSITIVE);
                sx[l] -= ms * (dx * inv);
                sy[l] -= ms * (dy * inv);
                ax[l] += ma * vxs[l];
                ay[l] += ma * vys[l];
                an[l] += ma;
                cx[l] += mc * dx;
                cy[l] += mc * dy;
                cn[l] += mc;
                n[l] += valid * one_if(d2 <= q.flat.q_sq);
            }
            left -= LANES as f32;
        }
    }
    let hsum = |a: &[f32; LANES]| a.iter().fold(0.0_f32, |s, v| s + v);
    NeighbourSums {
        separation: Vec2::new(hsum(&sx), hsum(&sy)),
        alignment: Vec2::new(hsum(&ax), hsum(&ay)),
        alignment_count: hsum(&an),
        cohesion: Vec2::new(hsum(&cx), hsum(&cy)),
        cohesion_count: hsum(&cn),
        repulsion: Vec2::ZERO,
        count: hsum(&n),
        heading: Vec2::ZERO,
    }
}
