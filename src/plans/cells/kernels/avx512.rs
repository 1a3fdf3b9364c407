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
//! -0 (adding or subtracting a zero then leaves it as it is); the halves are reduced as
//! [`super::tree_sum`] reduces the lanes ([`reduce`], all eight accumulators at once).
//! `tests/flocking.rs` and `tests/determinism.rs` compare the paths, and so does the unit test
//! `every_dispatch_target_gives_the_scalar_lanes_bits_for_every_flock_shape`; the unit test
//! `reduce_gives_tree_sum_bits_per_half_and_accumulator` compares [`reduce`] with `tree_sum`.
//! All of them reach this code only on a processor with AVX-512.
//!
//! Where a 16-lane operation costs two 8-lane ones (Zen 4 splits them), the pairing saves
//! instructions, not arithmetic: an odd last agent therefore takes the 8-lane kernel rather than
//! both halves of a vector.

use std::arch::x86_64::*;

use super::{AgentCols, CellBuf, KLANES, Query, QueryAgent, Reduced, Runs, Slots, VICSEK};
use crate::plans::spec::{ALI, SEP};

/// The sums of the leading pairs of `agents` (all of them but an odd last one) into `runs` at
/// `slots`, when the query has the flock's shape; returns how many agents it served (0 for
/// other shapes).
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
pub(super) fn pairs(
    buf: &CellBuf,
    q: &Query,
    agents: &AgentCols,
    slots: Slots,
    runs: &mut Runs,
) -> usize {
    if q.mode & 8 != 0 || q.mode >= VICSEK {
        return 0;
    }
    let pair = |a: &QueryAgent, b: &QueryAgent| {
        let (a, b) = (q.at(a), q.at(b));
        match q.mode {
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
        }
    };
    let m = agents.len() / 2 * 2;
    for k in (0..m).step_by(2) {
        let [ra, rb] = pair(&agents.at(k), &agents.at(k + 1));
        runs.set(slots.at(k), &reduced(&ra));
        runs.set(slots.at(k + 1), &reduced(&rb));
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

/// Every accumulator's two halves summed, as [`super::tree_sum`] sums eight lanes (lane `i` plus
/// lane `i + 4`, then `i` plus `i + 2`, then the pair), for all of them at once: three levels of
/// shuffles and adds over the eight accumulators instead of a tree per half and accumulator.
/// Returns `[[agent a's sums], [agent b's sums]]` in the accumulators' order.
#[inline]
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
fn reduce(acc: &[__m512; 8]) -> [[f32; 8]; 2] {
    // Level 1, per accumulator and half: lanes 0..4 plus lanes 4..8. With the 128-bit blocks
    // of `p` as p0 p1 (a) p2 p3 (b): [p0 + p1, p2 + p3, q0 + q1, q2 + q3].
    let l1 = |p: __m512, q: __m512| {
        _mm512_add_ps(
            _mm512_shuffle_f32x4::<0b10_00_10_00>(p, q),
            _mm512_shuffle_f32x4::<0b11_01_11_01>(p, q),
        )
    };
    // Level 2, within each 128-bit block of `p` and of `q`: [p0 + p2, p1 + p3, q0 + q2, q1 + q3].
    let l2 = |p: __m512, q: __m512| {
        _mm512_add_ps(
            _mm512_shuffle_ps::<0b01_00_01_00>(p, q),
            _mm512_shuffle_ps::<0b11_10_11_10>(p, q),
        )
    };
    // Level 3, within each block: [p0 + p1, p2 + p3, q0 + q1, q2 + q3].
    let l3 = |p: __m512, q: __m512| {
        _mm512_add_ps(
            _mm512_shuffle_ps::<0b10_00_10_00>(p, q),
            _mm512_shuffle_ps::<0b11_01_11_01>(p, q),
        )
    };
    let [s0, s1, s2, s3, s4, s5, s6, s7] = *acc;
    // Blocks: [s0 a, s0 b, s1 a, s1 b], [s2 a, s2 b, s3 a, s3 b], ...
    let (a, b, c, d) = (l1(s0, s1), l1(s2, s3), l1(s4, s5), l1(s6, s7));
    // Block k of l2(a, b): the level-2 pairs of a's block k, then of b's block k.
    let (e, f) = (l2(a, b), l2(c, d));
    // Block k of l3(e, f): [a_k, b_k, c_k, d_k] summed, where block k of `a` is
    // (k = 0) s0 a, (1) s0 b, (2) s1 a, (3) s1 b.
    let r = l3(e, f);
    let mut out = [0.0_f32; 16];
    #[expect(
        unsafe_code,
        reason = "a store of the 16 lanes into an array (the intrinsic takes a raw pointer)"
    )]
    // SAFETY: `out` holds 16 `f32`, the 64 bytes the unaligned store writes.
    unsafe {
        _mm512_storeu_ps(out.as_mut_ptr(), r);
    }
    // Lane 4k + j: accumulator pair j (j = 0: s0/s1 from `a`, 1: s2/s3, 2: s4/s5, 3: s6/s7),
    // block k of its level-1 vector (k = 0: first accumulator of agent a, 1: of agent b,
    // 2: second accumulator of agent a, 3: of agent b).
    let at = |acc: usize, agent: usize| out[4 * (2 * (acc % 2) + agent) + acc / 2];
    [
        std::array::from_fn(|k| at(k, 0)),
        std::array::from_fn(|k| at(k, 1)),
    ]
}

/// One agent's sums from its reduced accumulators, as [`super::Acc::reduced`] gives them with a
/// shared alignment and cohesion count.
#[inline]
fn reduced(r: &[f32; 8]) -> Reduced {
    let [sx, sy, ax, ay, an, cx, cy, n] = *r;
    [sx, sy, ax, ay, an, cx, cy, an, n]
}

/// [`super::shared`] for agents `a` and `b` (one template: the same radii, cones and group
/// rules) over one cell buffer.
#[inline]
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
fn shared_pair<const CONE: u8, const GROUPS: bool, const Q_AC: bool>(
    buf: &CellBuf,
    a: &Query,
    b: &Query,
) -> [[f32; 8]; 2] {
    let zero = _mm512_setzero_ps();
    let one = _mm512_set1_ps(1.0);
    let tiny = _mm512_set1_ps(f32::MIN_POSITIVE);
    let r_sep = _mm512_set1_ps(a.flat.r_sq[SEP]);
    let r_ac = _mm512_set1_ps(a.flat.r_sq[ALI]);
    let q_sq = _mm512_set1_ps(a.flat.q_sq);
    let c2 = _mm512_set1_ps(a.c2[ALI]);
    let (sep_any, ac_any) = (a.flat.any_group[SEP], a.flat.any_group[ALI]);
    let (qx, qy) = (halves(a.me.x, b.me.x), halves(a.me.y, b.me.y));
    let (qhx, qhy, qg) = (
        halves(a.me.hx, b.me.hx),
        halves(a.me.hy, b.me.hy),
        halves(a.me.g, b.me.g),
    );
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
    reduce(&[sx, sy, ax, ay, an, cx, cy, n])
}

#[cfg(test)]
mod tests {
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;
    use crate::plans::cells::kernels::tree_sum;

    /// [`reduce`] of eight accumulators given as 16 lanes each.
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    fn reduce_lanes(lanes: &[[f32; 16]; 8]) -> [[f32; 8]; 2] {
        let acc = lanes.map(|l| {
            let half = |h: usize| {
                _mm256_set_ps(
                    l[h + 7],
                    l[h + 6],
                    l[h + 5],
                    l[h + 4],
                    l[h + 3],
                    l[h + 2],
                    l[h + 1],
                    l[h],
                )
            };
            _mm512_insertf32x8::<1>(_mm512_castps256_ps512(half(0)), half(8))
        });
        reduce(&acc)
    }

    /// Runs only on a processor with AVX-512 F, DQ and VL, AVX2 and FMA (the features `reduce`
    /// is compiled for); elsewhere it returns at once and checks nothing.
    #[test]
    fn reduce_gives_tree_sum_bits_per_half_and_accumulator() {
        let features = [
            std::arch::is_x86_feature_detected!("avx512f"),
            std::arch::is_x86_feature_detected!("avx512dq"),
            std::arch::is_x86_feature_detected!("avx512vl"),
            std::arch::is_x86_feature_detected!("avx2"),
            std::arch::is_x86_feature_detected!("fma"),
        ];
        if features.contains(&false) {
            return;
        }
        // Magnitudes far apart, so that a different order of additions rounds differently.
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut lane = || {
            let sign = if rng.random_range(0u8..2) == 0 {
                1.0
            } else {
                -1.0
            };
            sign * rng.random_range(1.0f32..2.0) * 2.0f32.powi(rng.random_range(-12..12))
        };
        for case in 0..2000 {
            let lanes: [[f32; 16]; 8] = std::array::from_fn(|_| std::array::from_fn(|_| lane()));
            #[expect(
                unsafe_code,
                reason = "a call to a `#[target_feature]` function from one without the features"
            )]
            // SAFETY: the processor has every feature `reduce_lanes` enables (checked above).
            let got = unsafe { reduce_lanes(&lanes) };
            for (half, got) in got.iter().enumerate() {
                for (k, l) in lanes.iter().enumerate() {
                    let lanes: &[f32; KLANES] = l[8 * half..8 * half + 8].try_into().expect("8");
                    let want = tree_sum(lanes);
                    assert_eq!(
                        got[k].to_bits(),
                        want.to_bits(),
                        "case {case}, half {half}, accumulator {k}: {} vs {want}",
                        got[k]
                    );
                }
            }
        }
    }
}
