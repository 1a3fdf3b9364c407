//! Shared, seeded setup for the benches.

#![allow(dead_code)]

use throng::Bounds;

/// Mean number of neighbours within the query radius at flocking density.
pub const FLOCK_NEIGHBOURS: f32 = 18.0;

/// A square torus holding `n` agents at a density where each has about `neighbours` others
/// within `radius`: `area = n * pi * radius^2 / neighbours`.
#[must_use]
pub fn flock_world(n: usize, radius: f32, neighbours: f32) -> Bounds {
    let side = (n as f32 * std::f32::consts::PI * radius * radius / neighbours).sqrt();
    Bounds::torus(side, side).expect("a positive side")
}

/// `n` positions spread uniformly over `bounds` (which must have a size), from a fixed seed.
#[must_use]
pub fn uniform_points(n: usize, bounds: Bounds, seed: u64) -> (Vec<f32>, Vec<f32>) {
    let size = bounds.size().expect("a bounded world");
    let mut state = seed;
    // SplitMix64: small, fast and good enough to scatter points.
    let mut next = move || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 40) as f32 / (1u64 << 24) as f32
    };
    (0..n)
        .map(|_| bounds.wrap(glam::Vec2::new(next() * size.x, next() * size.y)))
        .map(|p| (p.x, p.y))
        .unzip()
}
