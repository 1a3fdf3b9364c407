//! Cache lines and the vector loops over long columns.
//!
//! A `Vec<f32>` of more than about 128 KiB comes from `mmap` and starts 16 bytes into a cache
//! line (glibc's chunk header), so a loop that moves 64 bytes at a time (the AVX-512 clones)
//! splits every load and store across two lines. Such loops start with a short piece up to the
//! first line of their main column, after which the whole blocks move whole lines (the other
//! columns, allocated alike, mostly line up too). Every loop split this way works element by
//! element or reduces in an order-free way (a maximum, an "or"), so the split changes no result.

/// `f32` values per cache line.
pub(crate) const F32_PER_LINE: usize = 16;

/// How many values of `v` come before its first cache line (0 when it starts on one).
#[inline]
pub(crate) fn lead(v: &[f32]) -> usize {
    let at = v.as_ptr() as usize / size_of::<f32>();
    ((F32_PER_LINE - at % F32_PER_LINE) % F32_PER_LINE).min(v.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lead_reaches_the_first_line_or_the_end() {
        let v = vec![0.0_f32; 100];
        for start in 0..40 {
            for len in [0, 1, 5, 15, 16, 17, 60] {
                let s = &v[start..start + len];
                let k = lead(s);
                assert!(
                    k < F32_PER_LINE && k <= len,
                    "start {start}, len {len}: {k}"
                );
                if k < len {
                    assert_eq!(s[k..].as_ptr() as usize % 64, 0, "start {start}, len {len}");
                }
                // Nothing on a line is skipped: one value fewer would not reach it.
                if k > 0 {
                    assert_ne!(s[k - 1..].as_ptr() as usize % 64, 0);
                }
            }
        }
    }
}
