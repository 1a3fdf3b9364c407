//! The lane kernels: every agent of a cell summed over the cell's gathered buffer in [`KLANES`]
//! lanes (two agents per 16-lane vector on AVX-512, [`avx512`]), one body per query shape
//! (the flock's, any flocking shape, Vicsek's, repulsion's per whole exponent), chosen once per
//! call, the sums written into the task's [`Runs`].
//!
//! View cones are tested without a square root: for a cosine `c < 0` a neighbour at offset `d`
//! is seen when `h . d >= 0` or `(h . d)^2 <= c^2 |d|^2`, for `c >= 0` when both `h . d >= 0`
//! and `(h . d)^2 >= c^2 |d|^2`: the same test as `h . d >= c |d|` up to rounding at the cone's
//! edge.
//!
//! Invariants: every body gives the masked sums of the scalar reference bit for bit, on every
//! dispatch target; an agent's sums depend only on the buffer and its own numbers.

use multiversion::target::target_cfg;

use super::KLANES;
use super::gather::CellBuf;
use super::runs::{Reduced, Runs};
use crate::plans::spec::{ALI, COH, FlatSpec, NeighbourSpec, QueryAgent, SEP};
use crate::simd::{apply, float_kernel};

#[cfg(target_arch = "x86_64")]
mod avx512;

/// The agents of one kernel call, as columns of one length: a run of the grid's cell-ordered
/// positions and copies, or a batch's arrays.
#[derive(Clone, Copy)]
pub(super) struct AgentCols<'a> {
    pub(super) x: &'a [f32],
    pub(super) y: &'a [f32],
    /// Unit headings; `None` when no query reads them (no view cone), which the kernel then
    /// takes as zeros.
    pub(super) h: Option<(&'a [f32], &'a [f32])>,
    pub(super) g: &'a [f32],
}

impl AgentCols<'_> {
    /// The number of agents.
    fn len(&self) -> usize {
        self.x.len()
    }

    /// QueryAgent `k`.
    #[inline(always)]
    fn at(&self, k: usize) -> QueryAgent {
        let (hx, hy) = self.h.map_or((0.0, 0.0), |(hx, hy)| (hx[k], hy[k]));
        QueryAgent {
            x: self.x[k],
            y: self.y[k],
            hx,
            hy,
            g: self.g[k],
        }
    }
}

/// Where a kernel call writes its agents' sums in the task's [`Runs`]: at consecutive slots from
/// `start`, or at the slots listed.
#[derive(Clone, Copy)]
pub(super) struct Slots<'a> {
    pub(super) start: usize,
    pub(super) list: Option<&'a [usize]>,
}

impl Slots<'_> {
    /// The slot of agent `k`.
    #[inline(always)]
    fn at(&self, k: usize) -> usize {
        self.list.map_or(self.start + k, |l| l[k])
    }
}

/// The cell kernels' view of the query: the agent's own numbers, the spec's [`FlatSpec`] with
/// the view cones as squared cosines and shapes, and the kernel body that serves them.
#[derive(Clone, Copy, Debug)]
pub(super) struct Query {
    /// The querying agent (zeros in a template, see [`Query::at`]).
    me: QueryAgent,
    /// The spec's radii, cosines and groups.
    flat: FlatSpec,
    /// Squared view cosine per slot.
    c2: [f32; 3],
    /// Per slot: 0 all round, 1 a cone wider than a half plane (cos < 0), 2 narrower.
    cone: [u8; 3],
    /// The Vicsek neighbourhood's squared radius (`VICSEK` mode).
    vicsek_r_sq: f32,
    /// Repulsion's strength and squared radius (`REPEL` modes).
    repel: (f32, f32),
    /// The kernel body that serves this shape.
    pub(super) mode: u8,
}

/// The kernel mode of the Vicsek sum.
pub(super) const VICSEK: u8 = 32;
/// The kernel mode of the repulsion sum with exponent 0; `REPEL + e` for a whole exponent `e`
/// up to 4 ([`crate::gravity::whole_power`]).
pub(super) const REPEL: u8 = 64;

impl Query {
    /// The query of agent `a`: this template with the agent's own numbers.
    #[inline(always)]
    fn at(&self, a: &QueryAgent) -> Query {
        Query { me: *a, ..*self }
    }

    /// Whether some slot in use has a view cone (the kernel reads the agent's unit heading).
    pub(super) fn needs_headings(&self) -> bool {
        (0..3).any(|b| self.flat.r_sq[b] >= 0.0 && self.cone[b] != 0)
    }

    /// Whether some slot counts only the agent's own group (the kernel reads groups).
    pub(super) fn needs_groups(&self) -> bool {
        !self.flat.any_group.iter().all(|&a| a)
    }

    /// The query template of a neighbour spec (the agent's own numbers are filled in later).
    pub(super) fn of(spec: &NeighbourSpec, one_group: bool) -> Query {
        let flat = spec.flat(one_group);
        let FlatSpec {
            q_sq,
            r_sq,
            cos,
            any_group,
        } = flat;
        let cone = cos.map(|c| {
            if c <= -1.0 {
                0
            } else if c < 0.0 {
                1
            } else {
                2
            }
        });
        let c2 = cos.map(|c| c * c);
        let groups = !any_group.iter().all(|&a| a);
        // The common shape (a flock): separation all round, alignment and cohesion sharing one
        // neighbourhood. Everything else takes the general body.
        let shared = cone[SEP] == 0
            && r_sq[ALI] == r_sq[COH]
            && cone[ALI] == cone[COH]
            && c2[ALI] == c2[COH]
            && any_group[ALI] == any_group[COH];
        let exponent = spec
            .repel
            .and_then(|(_, e, _)| crate::gravity::whole_exponent(e));
        let mode = if let Some(e) = exponent {
            REPEL + e
        } else if spec.vicsek_r_sq.is_some() {
            VICSEK
        } else if shared {
            cone[ALI] | (u8::from(groups) << 2) | (u8::from(q_sq == r_sq[ALI]) << 4)
        } else {
            8 | u8::from(groups)
        };
        Query {
            me: QueryAgent::default(),
            flat,
            c2,
            cone,
            vicsek_r_sq: spec.vicsek_r_sq.unwrap_or(-1.0),
            repel: spec.repel.map_or((0.0, -1.0), |(s, _, r_sq)| (s, r_sq)),
            mode,
        }
    }
}

/// The sums of every agent of `agents` over one cell buffer, written into `runs` at `slots`.
///
/// Where the processor has AVX-512, the flock's shape runs two agents at a time, one per half of
/// a 16-lane vector ([`avx512::pairs`]); each half gives the bits of the 8-lane kernel, so the
/// sums are the same on every dispatch target (which processors get which clone: `crate::simd`).
#[apply(float_kernel!)]
pub(super) fn kernel_cell(
    buf: &CellBuf,
    q: &Query,
    agents: &AgentCols,
    slots: Slots,
    runs: &mut Runs,
) {
    // Also true in every version when the build itself targets a CPU with AVX-512 (`-C
    // target-cpu=native` on such a machine): the binary then runs only where it is present.
    #[target_cfg(all(
        target_arch = "x86_64",
        target_feature = "avx512f",
        target_feature = "avx512dq",
        target_feature = "avx512vl",
        target_feature = "avx2",
        target_feature = "fma"
    ))]
    #[expect(
        unsafe_code,
        reason = "a call to a `#[target_feature]` function from a function that does not list \
                  the features; it has them, from its target or from the build's (without the \
                  block, a build with `-C target-cpu=native` on an AVX-512 machine fails)"
    )]
    fn pairs(buf: &CellBuf, q: &Query, agents: &AgentCols, slots: Slots, runs: &mut Runs) -> usize {
        // SAFETY: this function is compiled only where AVX-512F, DQ and VL, AVX2 and FMA are
        // enabled (in the version for multiversion's AVX-512 target, chosen at run time only
        // where the processor has them, or in every version of a build whose own target has
        // them): the features `avx512::pairs` needs.
        unsafe { avx512::pairs(buf, q, agents, slots, runs) }
    }
    #[target_cfg(not(all(
        target_arch = "x86_64",
        target_feature = "avx512f",
        target_feature = "avx512dq",
        target_feature = "avx512vl",
        target_feature = "avx2",
        target_feature = "fma"
    )))]
    fn pairs(_: &CellBuf, _: &Query, _: &AgentCols, _: Slots, _: &mut Runs) -> usize {
        0
    }
    let paired = pairs(buf, q, agents, slots, runs);
    // The body is chosen once per call, then runs for every agent: each arm its own loop, with
    // the body called directly, so that it is inlined and compiled for this target (called
    // through a pointer, a body is the baseline build).
    macro_rules! each {
        ($body:expr) => {
            for k in paired..agents.len() {
                runs.set(slots.at(k), &$body(buf, &q.at(&agents.at(k))));
            }
        };
    }
    match q.mode {
        0 => each!(shared::<0, false, false>),
        1 => each!(shared::<1, false, false>),
        2 => each!(shared::<2, false, false>),
        4 => each!(shared::<0, true, false>),
        5 => each!(shared::<1, true, false>),
        6 => each!(shared::<2, true, false>),
        16 => each!(shared::<0, false, true>),
        17 => each!(shared::<1, false, true>),
        18 => each!(shared::<2, false, true>),
        20 => each!(shared::<0, true, true>),
        21 => each!(shared::<1, true, true>),
        22 => each!(shared::<2, true, true>),
        8 => each!(general::<false>),
        VICSEK => each!(vicsek),
        REPEL => each!(repel::<0>),
        65 => each!(repel::<1>),
        66 => each!(repel::<2>),
        67 => each!(repel::<3>),
        68 => each!(repel::<4>),
        _ => each!(general::<true>),
    }
}

/// Lane accumulators of the neighbour kernels, gathered once the loop is done (inside the loop
/// they are separate locals, which stay in registers).
#[derive(Clone, Copy)]
struct Acc {
    sx: [f32; KLANES],
    sy: [f32; KLANES],
    ax: [f32; KLANES],
    ay: [f32; KLANES],
    an: [f32; KLANES],
    cx: [f32; KLANES],
    cy: [f32; KLANES],
    cn: [f32; KLANES],
    n: [f32; KLANES],
}

impl Acc {
    /// The lanes summed (as trees); `shared`: cohesion counts the alignment neighbours.
    #[inline(always)]
    fn reduced(&self, shared: bool) -> Reduced {
        let an = tree_sum(&self.an);
        [
            tree_sum(&self.sx),
            tree_sum(&self.sy),
            tree_sum(&self.ax),
            tree_sum(&self.ay),
            an,
            tree_sum(&self.cx),
            tree_sum(&self.cy),
            if shared { an } else { tree_sum(&self.cn) },
            tree_sum(&self.n),
        ]
    }
}

/// 1.0 when `b`, else 0.0: masks as floats, "and" as a product.
#[inline(always)]
fn one_if(b: bool) -> f32 {
    if b { 1.0 } else { 0.0 }
}

/// `x` when `m`, else `+0`, as a bitwise and with the mask (one vector instruction: a branch or
/// a select here can compile to masked stores of the accumulators).
#[inline(always)]
fn keep(m: bool, x: f32) -> f32 {
    f32::from_bits(x.to_bits() & 0u32.wrapping_sub(u32::from(m)))
}

/// Whether the view cone of kind `CONE` (0 all round, 1 wider than a half plane, 2 narrower)
/// admits an offset with `dot = h . d`, squared length `d2`, squared cosine `c2`.
#[inline(always)]
fn in_cone<const CONE: u8>(c2: f32, dot: f32, d2: f32) -> bool {
    match CONE {
        0 => true,
        1 => (dot >= 0.0) | (dot * dot <= c2 * d2),
        _ => (dot >= 0.0) & (dot * dot >= c2 * d2),
    }
}

/// The sum of the lanes of `a`, as a tree (halves, then quarters, then the pair).
#[inline(always)]
fn tree_sum(a: &[f32; KLANES]) -> f32 {
    let h: [f32; 4] = std::array::from_fn(|i| a[i] + a[i + 4]);
    let q: [f32; 2] = std::array::from_fn(|i| h[i] + h[i + 2]);
    q[0] + q[1]
}

/// The flock's shape: separation all round; alignment and cohesion share radius, cone and
/// group rule, so they share one mask and one count (and, when `Q_AC`, the query radius is
/// theirs, so the neighbour count shares their radius test). Masks are booleans and terms are
/// kept by them ([`keep`], one vector instruction each). Adding a selected
/// `+0` leaves an accumulator as it is, and so does subtracting `dx * 0 = ±0` from separation:
/// the accumulators start at `+0` and so are never `-0`. The sums are the masked products of the
/// scalar reference, bit for bit.
#[inline(always)]
fn shared<const CONE: u8, const GROUPS: bool, const Q_AC: bool>(
    buf: &CellBuf,
    q: &Query,
) -> Reduced {
    shared_over::<CONE, GROUPS, Q_AC>(buf, q, (&buf.vx, &buf.vy))
}

/// [`shared`] with `motion` summed as alignment's values in the velocities' place.
#[inline(always)]
fn shared_over<const CONE: u8, const GROUPS: bool, const Q_AC: bool>(
    buf: &CellBuf,
    q: &Query,
    motion: (&[f32], &[f32]),
) -> Reduced {
    let z = [0.0_f32; KLANES];
    let (mut sx, mut sy, mut ax, mut ay, mut an, mut cx, mut cy, mut n) = (z, z, z, z, z, z, z, z);
    let (r_sep, r_ac, c2) = (q.flat.r_sq[SEP], q.flat.r_sq[ALI], q.c2[ALI]);
    let (sep_any, ac_any) = (q.flat.any_group[SEP], q.flat.any_group[ALI]);
    for (xs, ys, vxs, vys, gs) in buf.blocks_of(motion) {
        for l in 0..KLANES {
            let dx = xs[l] - q.me.x;
            let dy = ys[l] - q.me.y;
            let d2 = dx * dx + dy * dy;
            let (g_sep, g_ac) = if GROUPS {
                let same = gs[l] == q.me.g;
                (sep_any | same, ac_any | same)
            } else {
                (true, true)
            };
            let ms = (d2 <= r_sep) & (d2 > 0.0) & g_sep;
            let inv = 1.0 / d2.max(f32::MIN_POSITIVE);
            let inv = keep(ms, inv);
            sx[l] -= dx * inv;
            sy[l] -= dy * inv;
            let dot = q.me.hx * dx + q.me.hy * dy;
            let in_r = d2 <= r_ac;
            let view = match CONE {
                0 => true,
                1 => (dot >= 0.0) | (dot * dot <= c2 * d2),
                _ => (dot >= 0.0) & (dot * dot >= c2 * d2),
            };
            let ma = in_r & view & g_ac;
            ax[l] += keep(ma, vxs[l]);
            ay[l] += keep(ma, vys[l]);
            an[l] += keep(ma, 1.0);
            cx[l] += keep(ma, dx);
            cy[l] += keep(ma, dy);
            n[l] += keep(if Q_AC { in_r } else { d2 <= q.flat.q_sq }, 1.0);
        }
    }
    Acc {
        sx,
        sy,
        ax,
        ay,
        an,
        cx,
        cy,
        cn: z,
        n,
    }
    .reduced(true)
}

/// The Vicsek sum: the unit headings of every agent within the radius, the agent itself included
/// (in alignment's place), and their number (in the last). The flock's kernel with the headings in
/// the velocities' place, alignment's radius the Vicsek radius, all round, any group, and
/// separation off: its alignment sum and count are the masked sums of the headings and of ones over
/// the neighbourhood in eight lanes (a kernel of its own, with three accumulators, came out of the
/// compiler as pairs of lanes and took twice the instructions).
#[inline(always)]
fn vicsek(buf: &CellBuf, q: &Query) -> Reduced {
    let r = q.vicsek_r_sq;
    let flock = Query {
        flat: FlatSpec {
            q_sq: r,
            r_sq: [-1.0, r, r],
            cos: [-1.0; 3],
            any_group: [true; 3],
        },
        c2: [1.0; 3],
        cone: [0; 3],
        ..*q
    };
    shared_over::<0, false, true>(buf, &flock, (&buf.hx, &buf.hy))
}

/// The repulsion sum with a whole exponent `E`: `-d / |d| * strength / |d|^E` over every
/// candidate within repulsion's radius other than at the agent's own spot (any group, all
/// round), in separation's place, and the candidates within the query radius in the last (the
/// agent itself included). Candidate `k` goes to lane `k % KLANES`, each lane in buffer order,
/// the lanes then summed as trees: the sums of eight lanes of the scalar reference's
/// operations ([`whole_power`] for the power) bit for bit. Each strip of candidates' terms is
/// computed first in one flat loop of vector instructions (a square root and three divisions
/// per candidate; written per lane of a block, the compiler paired the x and y terms instead),
/// then added to the lanes; a term outside the radius is kept as `+0` ([`keep`]), which leaves
/// an accumulator as it is.
///
/// [`whole_power`]: crate::gravity::whole_power
#[inline(always)]
fn repel<const E: u8>(buf: &CellBuf, q: &Query) -> Reduced {
    const STRIP: usize = 8 * KLANES;
    let z = [0.0_f32; KLANES];
    let (mut rx, mut ry, mut n) = (z, z, z);
    let (strength, r_sq) = q.repel;
    let (me_x, me_y, q_sq) = (q.me.x, q.me.y, q.flat.q_sq);
    let len = buf.len;
    let [mut fx, mut fy, mut c] = [[0.0_f32; STRIP]; 3];
    for (xs, ys) in buf.x[..len].chunks(STRIP).zip(buf.y[..len].chunks(STRIP)) {
        let m = xs.len();
        let (ys, tx, ty, tc) = (&ys[..m], &mut fx[..m], &mut fy[..m], &mut c[..m]);
        for k in 0..m {
            let dx = xs[k] - me_x;
            let dy = ys[k] - me_y;
            let d2 = dx * dx + dy * dy;
            let inside = (d2 <= r_sq) & (d2 > 0.0);
            let dist = d2.sqrt();
            let f = strength / crate::gravity::whole_power::<E>(dist, d2);
            tx[k] = keep(inside, dx / dist * f);
            ty[k] = keep(inside, dy / dist * f);
            tc[k] = keep(d2 <= q_sq, 1.0);
        }
        let blocks = tx
            .as_chunks::<KLANES>()
            .0
            .iter()
            .zip(ty.as_chunks::<KLANES>().0)
            .zip(tc.as_chunks::<KLANES>().0);
        for ((bx, by), bc) in blocks {
            for l in 0..KLANES {
                rx[l] -= bx[l];
                ry[l] -= by[l];
                n[l] += bc[l];
            }
        }
    }
    let mut r = [0.0; 9];
    (r[0], r[1], r[8]) = (tree_sum(&rx), tree_sum(&ry), tree_sum(&n));
    r
}

/// Any shape: a mask per slot, view cones by their kind per slot.
#[inline(always)]
fn general<const GROUPS: bool>(buf: &CellBuf, q: &Query) -> Reduced {
    let z = [0.0_f32; KLANES];
    let (mut sx, mut sy, mut ax, mut ay, mut an, mut cx, mut cy, mut cn, mut n) =
        (z, z, z, z, z, z, z, z, z);
    for (xs, ys, vxs, vys, gs) in buf.blocks() {
        for l in 0..KLANES {
            let dx = xs[l] - q.me.x;
            let dy = ys[l] - q.me.y;
            let d2 = dx * dx + dy * dy;
            let same = if GROUPS { one_if(gs[l] == q.me.g) } else { 1.0 };
            let dot = q.me.hx * dx + q.me.hy * dy;
            let sees = |b: usize| {
                let group = if !GROUPS || q.flat.any_group[b] {
                    1.0
                } else {
                    same
                };
                let view = match q.cone[b] {
                    0 => 1.0,
                    1 => one_if(in_cone::<1>(q.c2[b], dot, d2)),
                    _ => one_if(in_cone::<2>(q.c2[b], dot, d2)),
                };
                one_if(d2 <= q.flat.r_sq[b]) * group * view
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
            n[l] += one_if(d2 <= q.flat.q_sq);
        }
    }
    Acc {
        sx,
        sy,
        ax,
        ay,
        an,
        cx,
        cy,
        cn,
        n,
    }
    .reduced(false)
}

#[cfg(test)]
mod tests {
    use glam::Vec2;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::super::gather::FAR;
    use super::super::runs::Column;
    use super::super::runs::flock_sums;
    use super::super::runs::tests::bits;
    use super::*;
    use crate::plans::cells::task::CELL_BATCH;
    use crate::steering::NeighbourSums;

    /// The sums of `agents` through the dispatched kernel, read back from the runs; with
    /// `listed`, written at slots given as a list (in reverse order) rather than from slot 0;
    /// without `headings`, the agents' columns hold none (as with no view cone in a frame).
    fn kernel_sums(
        buf: &CellBuf,
        q: &Query,
        agents: &[QueryAgent],
        (listed, headings): (bool, bool),
    ) -> Vec<Reduced> {
        let col = |f: fn(&QueryAgent) -> f32| agents.iter().map(f).collect::<Vec<f32>>();
        let (x, y, hx, hy, g) = (
            col(|a| a.x),
            col(|a| a.y),
            col(|a| a.hx),
            col(|a| a.hy),
            col(|a| a.g),
        );
        let cols = AgentCols {
            x: &x,
            y: &y,
            h: headings.then_some((&hx[..], &hy[..])),
            g: &g,
        };
        let n = agents.len();
        let list: Vec<usize> = (0..n).rev().collect();
        let slots = Slots {
            start: 0,
            list: listed.then_some(&list[..]),
        };
        let mut runs = Runs::default();
        kernel_cell(buf, q, &cols, slots, &mut runs);
        (0..n)
            .map(|k| {
                let j = slots.at(k);
                let c = |v: &Column| v[j];
                [
                    c(&runs.sep[0]),
                    c(&runs.sep[1]),
                    c(&runs.ali[0]),
                    c(&runs.ali[1]),
                    c(&runs.ali_n),
                    c(&runs.coh[0]),
                    c(&runs.coh[1]),
                    c(&runs.coh_n),
                    c(&runs.count),
                ]
            })
            .collect()
    }

    /// A gathered buffer of `m` random candidates (some exactly on the agents, some on the radii)
    /// padded as `gather` pads it.
    fn buffer(rng: &mut ChaCha8Rng, m: usize, agents: &[QueryAgent]) -> CellBuf {
        let padded = m.div_ceil(KLANES) * KLANES;
        let mut b = CellBuf {
            len: padded,
            ..CellBuf::default()
        };
        for k in 0..padded {
            let (x, y, g) = if k >= m {
                (FAR, FAR, -1.0)
            } else if k % 7 == 0 {
                let a = agents[k % agents.len()];
                (a.x, a.y, a.g)
            } else if k % 11 == 0 {
                let a = agents[k % agents.len()];
                (a.x + 2.0, a.y, a.g)
            } else {
                (
                    rng.random_range(-6.0..6.0),
                    rng.random_range(-6.0..6.0),
                    f32::from(rng.random_range(0u8..2)),
                )
            };
            let live = k < m;
            b.x.push(x);
            b.y.push(y);
            b.vx.push(if live {
                rng.random_range(-4.0..4.0)
            } else {
                0.0
            });
            b.vy.push(if live {
                rng.random_range(-4.0..4.0)
            } else {
                0.0
            });
            b.g.push(g);
        }
        b
    }

    /// The Vicsek sums as eight lanes of plain scalar additions, each lane's in buffer order,
    /// the lanes then summed as the kernels sum them.
    fn vicsek_lanes(buf: &CellBuf, a: &QueryAgent, r_sq: f32) -> NeighbourSums {
        let (mut hx, mut hy, mut n) = ([0.0f32; KLANES], [0.0f32; KLANES], [0.0f32; KLANES]);
        for k in 0..buf.len {
            let (dx, dy) = (buf.x[k] - a.x, buf.y[k] - a.y);
            if dx * dx + dy * dy <= r_sq {
                hx[k % KLANES] += buf.hx[k];
                hy[k % KLANES] += buf.hy[k];
                n[k % KLANES] += 1.0;
            }
        }
        NeighbourSums {
            heading: Vec2::new(tree_sum(&hx), tree_sum(&hy)),
            count: tree_sum(&n),
            ..NeighbourSums::default()
        }
    }

    #[test]
    fn vicsek_sums_through_the_flock_kernel_equal_the_scalar_lanes_bit_for_bit() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut seen = 0;
        for case in 0..300 {
            let agents: Vec<QueryAgent> = (0..3)
                .map(|_| QueryAgent {
                    x: rng.random_range(-2.0..2.0),
                    y: rng.random_range(-2.0..2.0),
                    ..QueryAgent::default()
                })
                .collect();
            let m = rng.random_range(1..60);
            let mut buf = buffer(&mut rng, m, &agents);
            // Unit headings; the velocities differ, and no sum may read them.
            let n = buf.x.len();
            (buf.hx, buf.hy) = (vec![0.0; n], vec![0.0; n]);
            for k in 0..n.min(m) {
                let angle: f32 = rng.random_range(0.0..std::f32::consts::TAU);
                (buf.hx[k], buf.hy[k]) = (angle.cos(), angle.sin());
            }
            let r_sq: f32 = [1.0, 4.0, 9.0][case % 3];
            let mut q = Query::of(&NeighbourSpec::default(), true);
            (q.vicsek_r_sq, q.mode) = (r_sq, VICSEK);
            let out = kernel_sums(&buf, &q, &agents, (case % 2 == 0, false));
            for (a, got) in agents.iter().zip(&out) {
                let want = vicsek_lanes(&buf, a, r_sq);
                // The summed headings in alignment's place, the count in the last.
                let got = [got[2], got[3], got[8]].map(f32::to_bits);
                let want_bits = [want.heading.x, want.heading.y, want.count].map(f32::to_bits);
                assert_eq!(got, want_bits, "case {case}: {got:?} vs {want:?}");
                seen += usize::from(want.count > 1.0);
            }
        }
        assert!(seen > 100, "{seen}");
    }

    /// The repulsion sum and the count as eight lanes of the scalar traversal's operations
    /// (`plans::neighbours::sums_scalar`), each lane's in buffer order, the lanes then summed
    /// as the kernels sum them: `[x, y, count]`.
    fn repulsion_lanes(buf: &CellBuf, a: &QueryAgent, (s, e, r_sq): (f32, f32, f32)) -> [f32; 3] {
        let (mut rx, mut ry, mut n) = ([0.0f32; KLANES], [0.0f32; KLANES], [0.0f32; KLANES]);
        for k in 0..buf.len {
            let d = Vec2::new(buf.x[k] - a.x, buf.y[k] - a.y);
            let d2 = d.length_squared();
            if d2 <= r_sq && d2 > 0.0 {
                let dist = d2.sqrt();
                let f = d / dist * (s / crate::gravity::distance_power(dist, d2, e));
                rx[k % KLANES] -= f.x;
                ry[k % KLANES] -= f.y;
            }
            n[k % KLANES] += if d2 <= r_sq { 1.0 } else { 0.0 };
        }
        [tree_sum(&rx), tree_sum(&ry), tree_sum(&n)]
    }

    #[test]
    fn repulsion_sums_equal_the_scalar_lanes_bit_for_bit_for_every_whole_exponent() {
        // Through the dispatched kernel (the best target this processor has), the repulsion
        // query of each whole exponent: candidates on the agents' own spots (no term), on the
        // radius and inside it, cells of more agents than a batch holds.
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut seen = [0usize; 5];
        for case in 0..250 {
            let e = (case % 5) as u8;
            let (strength, r) = (rng.random_range(0.5f32..8.0), 2.0f32);
            let spec = NeighbourSpec {
                active: true,
                query_r: r,
                cos: [-1.0; 3],
                repel: Some((strength, f32::from(e), r * r)),
                ..NeighbourSpec::default()
            };
            let q = Query::of(&spec, case % 2 == 0);
            assert_eq!(q.mode, REPEL + e, "the repulsion body serves exponent {e}");
            let n = rng.random_range(1..2 * CELL_BATCH);
            let agents: Vec<QueryAgent> = (0..n)
                .map(|_| QueryAgent {
                    x: rng.random_range(-2.0..2.0),
                    y: rng.random_range(-2.0..2.0),
                    ..QueryAgent::default()
                })
                .collect();
            let m = rng.random_range(1..150);
            let buf = buffer(&mut rng, m, &agents);
            let out = kernel_sums(&buf, &q, &agents, (case % 3 == 0, false));
            for (a, got) in agents.iter().zip(&out) {
                let want = repulsion_lanes(&buf, a, spec.repel.unwrap());
                let got = [got[0], got[1], got[8]];
                assert_eq!(
                    got.map(f32::to_bits),
                    want.map(f32::to_bits),
                    "case {case}, exponent {e}: {got:?} vs {want:?}"
                );
                seen[e as usize] += usize::from(want[0] != 0.0 && want[2] > 2.0);
            }
        }
        assert!(seen.iter().all(|&k| k > 300), "{seen:?}");
    }

    #[test]
    fn every_dispatch_target_gives_the_scalar_lanes_bits_for_every_flock_shape() {
        // `kernel_cell` runs the best target this processor has (on AVX-512, two agents per
        // vector); `shared` called here is the baseline build of the 8-lane kernel. Every shape
        // of the flock's query: cones of each kind, groups told apart or not, the count on its
        // own radius or on alignment's; odd and even numbers of agents.
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        // Agents with some separation, with some alignment neighbours.
        let mut seen = [0usize; 2];
        for case in 0..200 {
            let (cone, groups, q_ac) = ((case % 3) as u8, case % 6 >= 3, case % 12 >= 6);
            let cos: f32 = [-1.0, -0.5, 0.3][cone as usize];
            let r_ac = 25.0;
            let query = Query {
                me: QueryAgent::default(),
                flat: FlatSpec {
                    q_sq: if q_ac { r_ac } else { 16.0 },
                    r_sq: [4.0, r_ac, r_ac],
                    cos: [-1.0, cos, cos],
                    any_group: [!groups, !groups, !groups],
                },
                c2: [1.0, cos * cos, cos * cos],
                cone: [0, cone, cone],
                vicsek_r_sq: -1.0,
                repel: (0.0, -1.0),
                mode: cone | (u8::from(groups) << 2) | (u8::from(q_ac) << 4),
            };
            // Cells of more agents than a batch holds, as the one-group path passes whole cells.
            let n = rng.random_range(1..2 * CELL_BATCH);
            let mut agents: Vec<QueryAgent> = (0..n)
                .map(|_| {
                    let angle: f32 = rng.random_range(0.0..std::f32::consts::TAU);
                    QueryAgent {
                        x: rng.random_range(-2.0..2.0),
                        y: rng.random_range(-2.0..2.0),
                        hx: angle.cos(),
                        hy: angle.sin(),
                        g: f32::from(rng.random_range(0u8..2)),
                    }
                })
                .collect();
            if case % 5 == 0 {
                // Two agents on one spot.
                agents[n - 1] = agents[0];
            }
            let m = rng.random_range(1..120);
            let buf = buffer(&mut rng, m, &agents);
            // Without a cone no kernel reads the headings: they may be absent.
            let headings = cone != 0 || case % 4 == 0;
            let out = kernel_sums(&buf, &query, &agents, (case % 2 == 1, headings));
            for (a, got) in agents.iter().zip(&out) {
                let q = query.at(a);
                let want = match (cone, groups, q_ac) {
                    (0, false, false) => shared::<0, false, false>(&buf, &q),
                    (1, false, false) => shared::<1, false, false>(&buf, &q),
                    (2, false, false) => shared::<2, false, false>(&buf, &q),
                    (0, true, false) => shared::<0, true, false>(&buf, &q),
                    (1, true, false) => shared::<1, true, false>(&buf, &q),
                    (2, true, false) => shared::<2, true, false>(&buf, &q),
                    (0, false, true) => shared::<0, false, true>(&buf, &q),
                    (1, false, true) => shared::<1, false, true>(&buf, &q),
                    (2, false, true) => shared::<2, false, true>(&buf, &q),
                    (0, true, true) => shared::<0, true, true>(&buf, &q),
                    (1, true, true) => shared::<1, true, true>(&buf, &q),
                    _ => shared::<2, true, true>(&buf, &q),
                };
                let (got, want) = (flock_sums(got), flock_sums(&want));
                assert_eq!(bits(&got), bits(&want), "case {case}: {got:?} vs {want:?}");
                seen[0] += usize::from(want.separation != Vec2::ZERO);
                seen[1] += usize::from(want.alignment_count > 0.0);
            }
        }
        assert!(seen.iter().all(|&k| k > 500), "{seen:?}");
    }
}
