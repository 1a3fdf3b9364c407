//! Branch-free polynomial forms of `exp` and `tanh` that the pedestrian models share: the same
//! bits on every platform and in every vector lane (where `f32::exp` and `f32::tanh` are the
//! platform's C library's), each within 2 ulp of the correctly rounded value over the range the
//! models read (held by the tests below).

/// `exp(x)` for `x` capped at 60 (as [`super::exp_capped`]) and floored at -87 (where `exp`
/// leaves the normal numbers; every term the models scale by it is then negligible): Cody and
/// Waite's range reduction `x = n ln 2 + r` and Cephes' degree-6 polynomial for `exp(r)`,
/// scaled by `2^n` through the exponent bits. Branch-free, with plain multiplies and adds (no
/// fused operations), so a loop of it vectorises and every code path gives the same bits.
#[inline(always)]
#[must_use]
pub(crate) fn exp_poly(x: f32) -> f32 {
    let x = x.clamp(-87.0, 60.0);
    let n = (x * std::f32::consts::LOG2_E + 0.5).floor();
    // ln 2 in two parts: 0.693_359_4 is 355 / 512 exactly as an f32.
    let r = x - n * 0.693_359_4 - n * -2.121_944_4e-4;
    let p = ((((1.987_569_1e-4 * r + 1.398_199_9e-3) * r + 8.333_452e-3) * r + 4.166_579_6e-2) * r
        + 0.166_666_65)
        * r
        + 0.5;
    let y = p * (r * r) + r + 1.0;
    // n lies in [-126, 87], so `n + 127` is a normal number's biased exponent. It is read from
    // the bits of `1.5 * 2^23 + n` (exact, one unit in its last place), which stays in lanes
    // where a float-to-integer cast would not.
    let biased = (n + 12_582_912.0).to_bits() - (0x4B40_0000 - 127);
    y * f32::from_bits(biased << 23)
}

/// `tanh(x)` for `x >= 0` (and `+inf`), within 2 ulp of the correctly rounded value: an odd
/// polynomial below 0.55 (`x P(x^2)`, degree 11, a least-squares fit at Chebyshev nodes within
/// 1e-9 of `tanh` before rounding), `1 - 2 / (exp(2x) + 1)` through [`exp_poly`] above, where
/// the subtraction loses at most one bit. Branch-free in its arithmetic and the same on every
/// platform, where `f32::tanh` is the platform's C library's.
#[inline(always)]
#[must_use]
pub(crate) fn tanh_poly(x: f32) -> f32 {
    let u = x * x;
    let p = ((((-6.272_607_5e-3 * u + 2.107_025_3e-2) * u - 5.385_186_5e-2) * u + 1.333_258e-1)
        * u
        - 3.333_331_6e-1)
        * u;
    let small = x + x * p;
    let large = 1.0 - 2.0 / (exp_poly(x + x) + 1.0);
    if x < 0.55 { small } else { large }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ulps(a: f32, b: f32) -> u32 {
        (i64::from(a.to_bits()) - i64::from(b.to_bits())).unsigned_abs() as u32
    }

    #[test]
    fn polynomial_tanh_is_within_two_ulp_of_tanh() {
        let mut worst = 0;
        let mut x = 0.0_f32;
        while x <= 20.0 {
            let want = f64::from(x).tanh() as f32;
            worst = worst.max(ulps(tanh_poly(x), want));
            x += if x < 1e-3 { 1.3e-7 } else { 1.3e-4 };
        }
        assert!(worst <= 2, "worst error {worst} ulp");
        assert_eq!(tanh_poly(0.0), 0.0);
        assert_eq!((tanh_poly(30.0), tanh_poly(f32::INFINITY)), (1.0, 1.0));
        // Rising everywhere the speed function reads it.
        let mut last = 0.0;
        for k in 1..200_000 {
            let y = tanh_poly(k as f32 * 5e-5);
            assert!(y >= last, "falls at {}", k as f32 * 5e-5);
            last = y;
        }
    }

    #[test]
    fn polynomial_exp_is_within_two_ulp_of_exp() {
        let mut worst = 0;
        let mut x = -87.0_f32;
        while x <= 60.0 {
            let want = f64::from(x).exp() as f32;
            worst = worst.max(ulps(exp_poly(x), want));
            x += 0.000_37;
        }
        assert!(worst <= 2, "worst error {worst} ulp");
        // Capped and floored like the scalar terms: finite, and tiny below the floor.
        assert_eq!(exp_poly(1e9), exp_poly(60.0));
        assert!(exp_poly(f32::MAX).is_finite() && exp_poly(f32::MIN).is_finite());
        assert!(exp_poly(-1e9) > 0.0 && exp_poly(-1e9) < 1e-37);
        assert_eq!((exp_poly(0.0), exp_poly(-0.0)), (1.0, 1.0));
    }
}
