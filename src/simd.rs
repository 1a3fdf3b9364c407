//! The processors the SIMD kernels are compiled for: the `multiversion` target lists, each in
//! one place. A kernel names its list with `#[apply(float_kernel!)]` (and the like) where it
//! would write `#[multiversion(targets(...))]`; the macro writes that attribute, so the clones
//! are the ones the attribute written out by hand would give.
//!
//! At run time `multiversion` picks the first listed target the processor has, else the
//! baseline x86-64 build. Invariant: every clone does the same operations in the same order per
//! lane as the baseline (no fused multiply-add where the baseline has none), so a result never
//! depends on the processor; the lists only decide which processors get vector code.
//!
//! The AVX-512 target names AVX-512 F, VL, BW and DQ, but multiversion 0.9 adds the Ice Lake
//! extensions to every AVX-512 target (BITALG, IFMA, VBMI, VBMI2, VNNI, VPOPCNTDQ, GFNI, VAES,
//! VPCLMULQDQ; unless the build sets `--cfg multiversion_allow_slow_avx512`): those clones run on
//! Ice Lake and the later Intel parts with AVX-512, and on Zen 4, whose 512-bit units do not slow
//! the clock much; Skylake-SP and Cascade Lake take the AVX2 clone.

pub(crate) use macro_rules_attribute::apply;

/// The list of the floating-point kernels (steering sums, flocking terms, the integrator, the
/// world's walls): AVX-512, AVX2 + FMA and AVX. AVX's 256-bit float operations already double
/// the baseline's lanes, so processors with AVX but no AVX2 get a clone too.
macro_rules! float_kernel {
    ($($item:tt)*) => {
        #[::multiversion::multiversion(targets(
            "x86_64+avx2+fma+avx512f+avx512vl+avx512bw+avx512dq",
            "x86_64+avx2+fma",
            "x86_64+avx"
        ))]
        $($item)*
    };
}
pub(crate) use float_kernel;

/// The list of ORCA's filter and perturbations: AVX-512 and AVX2 + FMA only. Their lanes work on
/// integers as much as on floats (candidate ids, the random streams' 64-bit products), and
/// 256-bit integer operations start with AVX2: an AVX clone would run most of the work as the
/// baseline does, so none is compiled.
macro_rules! integer_kernel {
    ($($item:tt)*) => {
        #[::multiversion::multiversion(targets(
            "x86_64+avx2+fma+avx512f+avx512vl+avx512bw+avx512dq",
            "x86_64+avx2+fma"
        ))]
        $($item)*
    };
}
pub(crate) use integer_kernel;

/// The list of the grid's cell keys: AVX-512, AVX2 + FMA and SSE4.1. What the lanes need there
/// is a float-to-integer truncation, which SSE4.1 has (`roundps`) and the baseline does not
/// (it calls libm's `truncf` per value); the SSE4.1 clone serves every processor without AVX2,
/// AVX ones included, so there is no AVX clone.
macro_rules! rounding_kernel {
    ($($item:tt)*) => {
        #[::multiversion::multiversion(targets(
            "x86_64+avx2+fma+avx512f+avx512vl+avx512bw+avx512dq",
            "x86_64+avx2+fma",
            "x86_64+sse4.1"
        ))]
        $($item)*
    };
}
pub(crate) use rounding_kernel;
