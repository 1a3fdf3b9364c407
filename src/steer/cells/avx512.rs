//! The flock's lane kernel on AVX-512: two agents of a cell per 16-lane vector.
//!
//! [`super::shared`] sums a cell buffer in [`KLANES`] lanes per agent. Here the low half of each
//! vector is one agent's lanes and the high half another's, so one pass over the buffer serves
//! two agents with the same instruction count as one pass of the 8-lane kernel.
//!
//! Invariant: each half gives the bits the 8-lane kernel gives its agent. Every lane does the
//! same IEEE operations on the same operands in the same order (no fused multiply-add, exact
//! division); where the 8-lane kernel keeps a term by a mask (a bitwise and) and adds, this kernel
//! adds under a mask, which is the same value because an accumulator starts at +0 and so is never
//! -0 (adding or subtracting a zero then leaves it as it is); the halves are reduced as [`super::tree_sum`]
//! reduces the lanes. `tests/flocking.rs` and `tests/determinism.rs` compare the paths.

use std::arch::x86_64::*;

use glam::Vec2;

use super::{Agent, CellBuf, KLANES, Query, VICSEK};
use crate::steer::plan::{ALI, SEP};
use crate::steering::NeighbourSums;

/// The sums of the leading pairs of `agents` (all of them but an odd last one) into `out`, when
/// the query has the flock's shape; returns how many agents it served (0 for other shapes).
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
pub(super) fn pairs(
    buf: &CellBuf,
    q: &Query,
    agents: &[Agent],
    out: &mut [NeighbourSums],
) -> usize {
    if q.mode & 8 != 0 || q.mode == VICSEK {
        return 0;
    }
    let m = agents.len() / 2 * 2;
    for (ab, o) in agents[..m]
        .chunks_exact(2)
        .zip(out[..m].chunks_exact_mut(2))
    {
        let (a, b) = (q.at(&ab[0]), q.at(&ab[1]));
        let (sa, sb) = match q.mode {
            0 => shared_pair::<0, false, false>(buf, &a, &b),
            1 => shared_pair::<1, false, false>(buf, &a, &b),
            2 => shared_pair::<2, false, false>(buf, &a, &b),
            4 => shared_pair::<0, true, false>(buf, &a, &b),
            5 => shared_pair::<1, true, false>(buf, &a, &b),
            6 => shared_pair::<2, true, false>(buf, &a, &b),
            16 => shared_pair::<0, false, true>(buf, &a, &b),
            17 => shared_pair::<1, false, true>(buf, &a, &b),
            18 => shared_pair::<2, false, true>(buf, &a, &b),
            20 => shared_pair::<0, true, true>(buf, &a, &b),
            21 => shared_pair::<1, true, true>(buf, &a, &b),
            _ => shared_pair::<2, true, true>(buf, &a, &b),
        };
        (o[0], o[1]) = (sa, sb);
    }
    m
}

/// `a` in the low half, `b` in the high half.
#[inline]
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
fn halves(a: f32, b: f32) -> __m512 {
    _mm512_insertf32x8::<1>(_mm512_set1_ps(a), _mm256_set1_ps(b))
}

/// A block of `KLANES` candidate values in both halves.
#[inline]
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
fn both(v: &[f32]) -> __m512 {
    let v: &[f32; KLANES] = v.try_into().expect("a whole block");
    _mm512_broadcast_f32x8(_mm256_set_ps(
        v[7], v[6], v[5], v[4], v[3], v[2], v[1], v[0],
    ))
}

/// The lanes of one half summed as [`super::tree_sum`] sums them: halves, quarters, the pair.
#[inline]
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
fn tree<const H: i32>(v: __m512) -> f32 {
    let a = _mm512_extractf32x8_ps::<H>(v);
    let h = _mm_add_ps(_mm256_castps256_ps128(a), _mm256_extractf128_ps::<1>(a));
    let q = _mm_add_ps(h, _mm_movehl_ps(h, h));
    _mm_cvtss_f32(_mm_add_ss(q, _mm_movehdup_ps(q)))
}

/// One half's sums, as [`super::Acc::sums`] with a shared alignment and cohesion count.
#[inline]
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
fn sums<const H: i32>(acc: &[__m512; 8]) -> NeighbourSums {
    let [sx, sy, ax, ay, an, cx, cy, n] = *acc;
    let alignment_count = tree::<H>(an);
    NeighbourSums {
        separation: Vec2::new(tree::<H>(sx), tree::<H>(sy)),
        alignment: Vec2::new(tree::<H>(ax), tree::<H>(ay)),
        alignment_count,
        cohesion: Vec2::new(tree::<H>(cx), tree::<H>(cy)),
        cohesion_count: alignment_count,
        repulsion: Vec2::ZERO,
        count: tree::<H>(n),
        heading: Vec2::ZERO,
    }
}

/// [`super::shared`] for agents `a` and `b` (one template: the same radii, cones and group
/// rules) over one cell buffer.
#[inline]
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
fn shared_pair<const CONE: u8, const GROUPS: bool, const Q_AC: bool>(
    buf: &CellBuf,
    a: &Query,
    b: &Query,
) -> (NeighbourSums, NeighbourSums) {
    let zero = _mm512_setzero_ps();
    let one = _mm512_set1_ps(1.0);
    let tiny = _mm512_set1_ps(f32::MIN_POSITIVE);
    let r_sep = _mm512_set1_ps(a.r_sq[SEP]);
    let r_ac = _mm512_set1_ps(a.r_sq[ALI]);
    let q_sq = _mm512_set1_ps(a.q_sq);
    let c2 = _mm512_set1_ps(a.c2[ALI]);
    let (sep_any, ac_any) = (a.any_group[SEP], a.any_group[ALI]);
    let (qx, qy) = (halves(a.x, b.x), halves(a.y, b.y));
    let (qhx, qhy, qg) = (halves(a.hx, b.hx), halves(a.hy, b.hy), halves(a.g, b.g));
    let (mut sx, mut sy, mut ax, mut ay) = (zero, zero, zero, zero);
    let (mut an, mut cx, mut cy, mut n) = (zero, zero, zero, zero);
    for (xs, ys, vxs, vys, gs) in buf.blocks() {
        let dx = _mm512_sub_ps(both(xs), qx);
        let dy = _mm512_sub_ps(both(ys), qy);
        let d2 = _mm512_add_ps(_mm512_mul_ps(dx, dx), _mm512_mul_ps(dy, dy));
        let (g_sep, g_ac): (__mmask16, __mmask16) = if GROUPS {
            let same = _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(both(gs), qg);
            (
                if sep_any { !0 } else { same },
                if ac_any { !0 } else { same },
            )
        } else {
            (!0, !0)
        };
        let ms = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(d2, r_sep)
            & _mm512_cmp_ps_mask::<_CMP_GT_OQ>(d2, zero)
            & g_sep;
        let inv = _mm512_div_ps(one, _mm512_max_ps(d2, tiny));
        sx = _mm512_mask_sub_ps(sx, ms, sx, _mm512_mul_ps(dx, inv));
        sy = _mm512_mask_sub_ps(sy, ms, sy, _mm512_mul_ps(dy, inv));
        let in_r = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(d2, r_ac);
        let view: __mmask16 = match CONE {
            0 => !0,
            _ => {
                let dot = _mm512_add_ps(_mm512_mul_ps(qhx, dx), _mm512_mul_ps(qhy, dy));
                let ahead = _mm512_cmp_ps_mask::<_CMP_GE_OQ>(dot, zero);
                let (dd, cd) = (_mm512_mul_ps(dot, dot), _mm512_mul_ps(c2, d2));
                if CONE == 1 {
                    ahead | _mm512_cmp_ps_mask::<_CMP_LE_OQ>(dd, cd)
                } else {
                    ahead & _mm512_cmp_ps_mask::<_CMP_GE_OQ>(dd, cd)
                }
            }
        };
        let ma = in_r & view & g_ac;
        ax = _mm512_mask_add_ps(ax, ma, ax, both(vxs));
        ay = _mm512_mask_add_ps(ay, ma, ay, both(vys));
        an = _mm512_mask_add_ps(an, ma, an, one);
        cx = _mm512_mask_add_ps(cx, ma, cx, dx);
        cy = _mm512_mask_add_ps(cy, ma, cy, dy);
        let counted = if Q_AC {
            in_r
        } else {
            _mm512_cmp_ps_mask::<_CMP_LE_OQ>(d2, q_sq)
        };
        n = _mm512_mask_add_ps(n, counted, n, one);
    }
    let acc = [sx, sy, ax, ay, an, cx, cy, n];
    (sums::<0>(&acc), sums::<1>(&acc))
}
