//! Left-packing a block of eight candidates: the offsets and indices of the lanes within a
//! radius are written to consecutive slots, in lane order, without a branch per lane.
//!
//! [`pack_scalar`] is the reference; [`pack_avx2`] does the same with one permutation per
//! output (a table maps the 8-bit mask of kept lanes to the order of their lanes), so a block
//! costs the same whatever it keeps. Both write all eight slots from `count` on (the slots past
//! the kept ones hold leftovers that the next block or the caller's padding overwrites), so the
//! output buffers need eight slots of room past the last kept one.
//!
//! Invariant: both give the same kept lanes, in the same order, with the same bits (the offset
//! `x - p` and the test `dx * dx + dy * dy <= r_sq` are the same IEEE operations, no fused
//! multiply-add).

// The loads and stores of the AVX2 path take pointers. Measured on the pedestrian corridor
// (docs/notes/performance-history.md): the branch per kept lane cost more than the model's own pair terms.
#![expect(
    unsafe_code,
    reason = "AVX2 loads and stores of whole blocks, bounds asserted"
)]

/// Lanes per block.
pub(crate) const LANES: usize = 8;

/// One block of candidates and the test they pass.
pub(crate) struct Block<'a> {
    /// The candidates' coordinates.
    pub xs: &'a [f32; LANES],
    /// y.
    pub ys: &'a [f32; LANES],
    /// Their indices.
    pub js: &'a [u32; LANES],
    /// Lanes at or past this one are not candidates.
    pub left: usize,
}

/// Where the kept lanes go, and what they are tested against.
pub(crate) struct Packed<'a> {
    /// `x - p.x` of the kept lanes.
    pub rx: &'a mut [f32],
    /// `y - p.y`.
    pub ry: &'a mut [f32],
    /// Their indices.
    pub js: &'a mut [u32],
    /// The query point.
    pub p: (f32, f32),
    /// The squared radius.
    pub r_sq: f32,
    /// An index never kept (the querying agent itself).
    pub me: u32,
}

/// Keeps the lanes of `b` within the radius whose index is not `out.me`, from slot `count` on;
/// returns the new count. The reference for [`pack_avx2`].
#[inline(always)]
pub(crate) fn pack_scalar(b: &Block, out: &mut Packed, mut count: usize) -> usize {
    for l in 0..LANES {
        let (dx, dy) = (b.xs[l] - out.p.0, b.ys[l] - out.p.1);
        let j = b.js[l];
        out.rx[count] = dx;
        out.ry[count] = dy;
        out.js[count] = j;
        let keep = (dx * dx + dy * dy <= out.r_sq) & (l < b.left) & (j != out.me);
        count += usize::from(keep);
    }
    count
}

/// For each 8-bit mask, the lanes it has set in ascending order, one per byte from the lowest
/// (the unused bytes are zero).
const ORDER: [u64; 256] = {
    let mut table = [0u64; 256];
    let mut m = 0;
    while m < 256 {
        let (mut k, mut l, mut v) = (0, 0, 0u64);
        while l < 8 {
            if m & (1 << l) != 0 {
                v |= (l as u64) << (8 * k);
                k += 1;
            }
            l += 1;
        }
        table[m] = v;
        m += 1;
    }
    table
};

/// [`pack_scalar`] in AVX2 lanes.
///
/// # Safety
/// The CPU must have AVX2, and each of `out.rx`, `out.ry`, `out.js` must have at least
/// `count + LANES` slots.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) unsafe fn pack_avx2(b: &Block, out: &mut Packed, count: usize) -> usize {
    use std::arch::x86_64::*;
    assert!(out.rx.len().min(out.ry.len()).min(out.js.len()) >= count + LANES);
    // SAFETY: the blocks are 8 lanes each; the stores stay within the slots asserted above.
    unsafe {
        let x = _mm256_loadu_ps(b.xs.as_ptr());
        let y = _mm256_loadu_ps(b.ys.as_ptr());
        let j = _mm256_loadu_si256(b.js.as_ptr().cast());
        let dx = _mm256_sub_ps(x, _mm256_set1_ps(out.p.0));
        let dy = _mm256_sub_ps(y, _mm256_set1_ps(out.p.1));
        let d2 = _mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy));
        let near =
            _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(d2, _mm256_set1_ps(out.r_sq))) as u32;
        let me = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(
            j,
            _mm256_set1_epi32(out.me as i32),
        ))) as u32;
        let live = (1u32 << b.left.min(LANES)) - 1;
        let mask = near & !me & live;
        let order = _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(ORDER[mask as usize] as i64));
        let at = count;
        _mm256_storeu_ps(
            out.rx.as_mut_ptr().add(at),
            _mm256_permutevar8x32_ps(dx, order),
        );
        _mm256_storeu_ps(
            out.ry.as_mut_ptr().add(at),
            _mm256_permutevar8x32_ps(dy, order),
        );
        _mm256_storeu_si256(
            out.js.as_mut_ptr().add(at).cast(),
            _mm256_permutevar8x32_epi32(j, order),
        );
        count + mask.count_ones() as usize
    }
}

/// Packs block `at..at + LANES` of a run of sorted points, of which the first `left` (from
/// `at`, all eight when `left >= LANES`) are candidates: positions `xs`, `ys` read whole (the
/// caller's arrays are padded), indices from `order` (past its end as `out.me`, which is never
/// kept); in AVX2 lanes when `avx2` (the CPU's), else by [`pack_scalar`]. Returns the new
/// count.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn pack_block(
    xs: &[f32; LANES],
    ys: &[f32; LANES],
    order: &[u32],
    at: usize,
    left: usize,
    out: &mut Packed,
    count: usize,
    avx2: bool,
) -> usize {
    let mut tail = [out.me; LANES];
    let whole = order.get(at..at + LANES).and_then(|o| o.try_into().ok());
    let js = whole.unwrap_or_else(|| {
        tail[..order.len() - at].copy_from_slice(&order[at..]);
        &tail
    });
    pack_lanes(&Block { xs, ys, js, left }, out, count, avx2)
}

/// Keeps the lanes of `block` as [`pack_scalar`] does: in AVX2 lanes when `avx2` (the CPU's).
/// Returns the new count.
#[inline(always)]
pub(crate) fn pack_lanes(block: &Block, out: &mut Packed, count: usize, avx2: bool) -> usize {
    #[cfg(target_arch = "x86_64")]
    if avx2 {
        // SAFETY: `avx2` is the CPU's; `pack_avx2` asserts the room it writes.
        return unsafe { pack_avx2(block, out, count) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = avx2;
    pack_scalar(block, out, count)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::AgentRng;

    #[test]
    fn the_table_lists_each_masks_lanes_in_order() {
        for (m, &v) in ORDER.iter().enumerate() {
            let lanes: Vec<u64> = (0..m.count_ones()).map(|k| (v >> (8 * k)) & 0xff).collect();
            let want: Vec<u64> = (0..8).filter(|l| m & (1 << l) != 0).collect();
            assert_eq!(lanes, want, "mask {m:#010b}");
        }
    }

    /// Random blocks (points on and off the circle's edge, the agent itself, short tails) give
    /// the same kept lanes with the same bits on both paths.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_packs_as_the_scalar_reference() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        let mut rng = AgentRng::new(11, 0, 0, 0);
        let n = 4000 * LANES;
        let (mut a, mut b) = (
            [vec![0.0f32; n + LANES], vec![0.0f32; n + LANES]],
            [vec![0.0f32; n + LANES], vec![0.0f32; n + LANES]],
        );
        let (mut ja, mut jb) = (vec![0u32; n + LANES], vec![0u32; n + LANES]);
        let (mut ca, mut cb) = (0, 0);
        let r = 2.0f32;
        let p = (3.25f32, -1.5f32);
        let mut kept_any_partial = false;
        for k in 0..n / LANES {
            let mut xs = [0.0f32; LANES];
            let mut ys = [0.0f32; LANES];
            let mut js = [0u32; LANES];
            for l in 0..LANES {
                let angle = rng.unit() * std::f32::consts::TAU;
                // A fifth of the points on the edge itself.
                let d = if rng.unit() < 0.2 {
                    r
                } else {
                    3.0 * rng.unit()
                };
                xs[l] = p.0 + d * angle.cos();
                ys[l] = p.1 + d * angle.sin();
                js[l] = (k * LANES + l) as u32 % 97;
            }
            let block = Block {
                xs: &xs,
                ys: &ys,
                js: &js,
                left: if k % 5 == 0 { k % LANES } else { LANES },
            };
            let before = ca;
            let [ax, ay] = &mut a;
            ca = pack_scalar(
                &block,
                &mut Packed {
                    rx: ax,
                    ry: ay,
                    js: &mut ja,
                    p,
                    r_sq: r * r,
                    me: 5,
                },
                ca,
            );
            let [bx, by] = &mut b;
            // SAFETY: AVX2 is present; the buffers have `n + LANES` slots.
            cb = unsafe {
                pack_avx2(
                    &block,
                    &mut Packed {
                        rx: bx,
                        ry: by,
                        js: &mut jb,
                        p,
                        r_sq: r * r,
                        me: 5,
                    },
                    cb,
                )
            };
            assert_eq!(ca, cb, "block {k}");
            kept_any_partial |= ca - before > 0 && ca - before < LANES;
        }
        assert!(kept_any_partial && ca > n / 8);
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&a[0][..ca]), bits(&b[0][..cb]));
        assert_eq!(bits(&a[1][..ca]), bits(&b[1][..cb]));
        assert_eq!(ja[..ca], jb[..cb]);
        assert!(!ja[..ca].contains(&5));
    }
}
