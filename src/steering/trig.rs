//! Sine and cosine as a polynomial, the same on every platform and in vector lanes.
//!
//! `f32::sin_cos` is the platform's C library's, which differs between systems and cannot be
//! evaluated in lanes. [`sin_cos`] reduces the angle by multiples of pi/2 in three parts
//! (Cody and Waite: each product exact for `|x| <= LIMIT`), then evaluates the minimax
//! polynomials of Cephes' `sinf` and `cosf` on [-pi/4, pi/4]; beyond [`LIMIT`] (and for NaN and
//! infinities) it defers to `f32::sin_cos`. [`sin_cos_reduced`] is the polynomial path alone,
//! branch-free, for lanes: a caller checks [`in_range`] and takes [`sin_cos`] for the rest, which
//! gives the same bits as the lanes wherever both apply.

/// The largest `|x|` the polynomial path serves: `x` over pi/2 rounds to a whole number of at
/// most 13 bits, so its product with the first part of pi/2 (8 bits) is exact.
pub(crate) const LIMIT: f32 = 8192.0;

/// Whether [`sin_cos_reduced`] serves `x` (false for NaN and infinities).
#[inline(always)]
#[must_use]
pub(crate) fn in_range(x: f32) -> bool {
    x.abs() <= LIMIT
}

/// `(sin x, cos x)` within 1.5e-7 of the exact values (measured in the tests below), for every
/// `x`; the polynomial path for `|x| <= LIMIT`.
#[inline(always)]
#[must_use]
pub(crate) fn sin_cos(x: f32) -> (f32, f32) {
    if in_range(x) {
        sin_cos_reduced(x)
    } else {
        x.sin_cos()
    }
}

/// `(sin x, cos x)` for `|x| <= LIMIT` by the polynomial path, without a branch: the quadrant is
/// read from the bits of `1.5 * 2^23 + x * 2 / pi` (the float rounds `x * 2 / pi` to the nearest
/// whole number, ties to even), which stays in lanes where a float-to-integer cast would not.
/// Outside that range the result is meaningless but finite or NaN, never a panic.
#[inline(always)]
#[must_use]
pub(crate) fn sin_cos_reduced(x: f32) -> (f32, f32) {
    const MAGIC: f32 = 12_582_912.0;
    // pi / 2 in three parts: 1.5703125 (8 bits), then the remainder in two.
    const DP1: f32 = 1.570_312_5;
    const DP2: f32 = 4.837_513e-4;
    const DP3: f32 = 7.549_79e-8;
    let t = x * std::f32::consts::FRAC_2_PI + MAGIC;
    let q = t.to_bits();
    let j = t - MAGIC;
    let y = ((x - j * DP1) - j * DP2) - j * DP3;
    let z = y * y;
    let s = y + y * z * ((-1.951_529_6e-4 * z + 8.332_161e-3) * z - 1.666_665_5e-1);
    let c = 1.0 - 0.5 * z + z * z * ((2.443_315_7e-5 * z - 1.388_731_6e-3) * z + 4.166_664_6e-2);
    // Quadrant q: (sin, cos) = (s, c), (c, -s), (-s, -c), (-c, s).
    let swap = q & 1 == 1;
    let (sin, cos) = if swap { (c, s) } else { (s, c) };
    let sin = f32::from_bits(sin.to_bits() ^ ((q & 2) << 30));
    let cos = f32::from_bits(cos.to_bits() ^ ((q.wrapping_add(1) & 2) << 30));
    (sin, cos)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The largest error of `sin_cos` against the f64 functions over `n` points of `[lo, hi]`.
    fn worst(lo: f32, hi: f32, n: u32) -> f64 {
        let mut worst = 0.0_f64;
        for k in 0..=n {
            let x = lo + (hi - lo) * (k as f32 / n as f32);
            let (s, c) = sin_cos(x);
            let (ws, wc) = f64::from(x).sin_cos();
            worst = worst.max((f64::from(s) - ws).abs().max((f64::from(c) - wc).abs()));
        }
        worst
    }

    #[test]
    fn polynomial_is_within_one_and_a_half_e_minus_7() {
        assert!(
            worst(-7.0, 7.0, 2_000_000) < 1.5e-7,
            "{}",
            worst(-7.0, 7.0, 2_000_000)
        );
        assert!(worst(-LIMIT, LIMIT, 2_000_000) < 1.5e-7);
        // Quadrant boundaries and their neighbours.
        for k in -40..=40 {
            let b = k as f32 * std::f32::consts::FRAC_PI_2;
            for x in [b, b.next_up(), b.next_down()] {
                let (s, c) = sin_cos(x);
                let (ws, wc) = f64::from(x).sin_cos();
                assert!((f64::from(s) - ws).abs() < 1.5e-7 && (f64::from(c) - wc).abs() < 1.5e-7);
            }
        }
    }

    #[test]
    fn exact_points_and_symmetry() {
        assert_eq!(sin_cos(0.0), (0.0, 1.0));
        for k in 0..10_000 {
            let x = k as f32 * 0.000_731;
            let (s, c) = sin_cos(x);
            let (ns, nc) = sin_cos(-x);
            assert_eq!((ns, nc), (-s, c), "{x}");
        }
    }

    #[test]
    fn beyond_the_limit_and_non_finite_defer_to_the_library() {
        for x in [LIMIT.next_up(), 1e6, -3e7, f32::MAX] {
            assert_eq!(sin_cos(x), x.sin_cos());
        }
        for x in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let (s, c) = sin_cos(x);
            assert!(s.is_nan() && c.is_nan());
        }
    }
}
