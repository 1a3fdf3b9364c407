//! The pair terms of both pedestrian models over all of an agent's neighbours at once: loops
//! with branch-free bodies, which the compiler turns into SIMD lanes (the speed model's over
//! fixed blocks of [`LANES`], so that an agent with a single block of neighbours gets lanes
//! too), and a polynomial exponential ([`exp_poly`](super::approx::exp_poly)).
//!
//! Each element gets what the scalar term gives ([`SocialForce::pair`], [`Cfsm::repulsion`],
//! [`Cfsm::spacing`]), with the same operations in the same order, except that `exp` is the
//! polynomial (within 2 ulp of the correctly rounded value over the range the models use) and
//! the contact terms are computed with `max(overlap, 0)` instead of a branch, which adds exact
//! zeros out of contact. The scalar functions stay the reference: the tests below hold each
//! element to them. The sums run in [`LANES`] accumulators added in a fixed order at the end
//! ([`lane_sum`]), so they depend on the neighbours' order only; the spacing is exact (a
//! minimum does not depend on the order).
//!
//! Invariants: the slices are padded to whole blocks of [`LANES`]; elements at or beyond the
//! neighbour count contribute exact zeros to the sums and nothing to the spacing; every result
//! is finite for finite inputs, as for the scalar terms (the exponent is capped as
//! [`super::exp_capped`] caps it).

use super::approx::exp_poly;
use super::{Cfsm, SocialForce, Spacing};

/// The block width the slices are padded to.
pub(crate) const LANES: usize = 8;

/// The sum of `x` (a whole number of blocks) in [`LANES`] accumulators, added in a fixed order.
#[inline(always)]
#[must_use]
pub(crate) fn lane_sum(x: &[f32]) -> f32 {
    let mut acc = [0.0f32; LANES];
    for block in x.chunks_exact(LANES) {
        for l in 0..LANES {
            acc[l] += block[l];
        }
    }
    ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]))
}

/// An agent `i`'s neighbours, padded to whole blocks of [`LANES`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct Neighbours<'a> {
    /// How many of the elements are neighbours (the rest is padding).
    pub count: usize,
    /// `x_j - x_i`, x.
    pub rx: &'a [f32],
    /// `x_j - x_i`, y.
    pub ry: &'a [f32],
    /// `r_i + r_j`.
    pub reach: &'a [f32],
    /// The x component of the direction at zero distance: `1` when `i`'s id is the smaller,
    /// else `-1` (what [`super::away`] picks).
    pub side: &'a [f32],
}

/// The distance of a pair and the unit vector from `j` to `i` ([`super::away`]), from `rel =
/// x_j - x_i`.
#[inline(always)]
fn distance_and_away(rx: f32, ry: f32, side: f32) -> (f32, f32, f32) {
    let (dx, dy) = (-rx, -ry);
    let d = (dx * dx + dy * dy).sqrt();
    let apart = d > 1e-6;
    let nx = if apart { dx / d } else { side };
    let ny = if apart { dy / d } else { 0.0 * side };
    (d, nx, ny)
}

impl Cfsm {
    /// [`Cfsm::repulsion_under`] the anisotropy `lambda` of every neighbour on an agent with
    /// the preferred direction `(ex, ey)` into `fx`, `fy` (zero beyond the count) and the pair
    /// distances into `dist`; all as long as the neighbours' slices.
    ///
    /// Block by block, each a fixed [`LANES`] wide, so that a single block (the usual count in
    /// a sparse crowd) runs in vector lanes: a loop over the whole slices vectorises only from
    /// two blocks on and leaves one block to scalar code. Every element gets the operations of
    /// `repulsion_lanes_reference` (the tests' reference) in the same order: the same bits.
    #[inline(always)]
    pub(crate) fn repulsion_lanes(
        &self,
        nb: &Neighbours,
        fx: &mut [f32],
        fy: &mut [f32],
        dist: &mut [f32],
        (ex, ey): (f32, f32),
        lambda: f32,
    ) {
        let (s, range) = (self.strength_neighbour, self.range_neighbour);
        let ins = nb.rx.chunks_exact(LANES).zip(nb.ry.chunks_exact(LANES));
        let ins = ins.zip(
            nb.reach
                .chunks_exact(LANES)
                .zip(nb.side.chunks_exact(LANES)),
        );
        let outs = dist.chunks_exact_mut(LANES);
        let outs = outs.zip(fx.chunks_exact_mut(LANES).zip(fy.chunks_exact_mut(LANES)));
        let mut left = nb.count;
        for (((rx, ry), (reach, side)), (dist, (fx, fy))) in ins.zip(outs) {
            let block = |x: &[f32]| -> [f32; LANES] { x.try_into().expect("a block") };
            let (rx, ry, reach, side) = (block(rx), block(ry), block(reach), block(side));
            let mut out = [[0.0f32; LANES]; 3];
            for l in 0..LANES {
                let (d, nx, ny) = distance_and_away(rx[l], ry[l], side[l]);
                let w = lambda + (1.0 - lambda) * (0.5 - 0.5 * (ex * nx + ey * ny));
                let m = s * exp_poly((reach[l] - d) / range) * w;
                let valid = l < left;
                out[0][l] = d;
                out[1][l] = if valid { nx * m } else { 0.0 };
                out[2][l] = if valid { ny * m } else { 0.0 };
            }
            dist.copy_from_slice(&out[0]);
            fx.copy_from_slice(&out[1]);
            fy.copy_from_slice(&out[2]);
            left = left.saturating_sub(LANES);
        }
    }

    /// The smallest [`Cfsm::spacing_to`] along the unit direction `(ex, ey)` over the
    /// neighbours, given their distances `dist` (`INFINITY` when none is ahead), and how many
    /// of them lie behind ([`Cfsm::is_behind`], the pressure's count).
    ///
    /// The spacing's kind is a constant of the loop and each block a fixed [`LANES`] wide, so
    /// that one block runs in vector lanes; every lane gets the operations of
    /// `min_spacing_lanes_reference` (the tests' reference), and a minimum and a count of
    /// ones do not depend on how the lanes are grouped: the same bits.
    #[inline(always)]
    #[must_use]
    pub(crate) fn min_spacing_lanes(
        &self,
        e: (f32, f32),
        nb: &Neighbours,
        dist: &[f32],
    ) -> (f32, f32) {
        if self.spacing == Spacing::Contact {
            min_spacing_blocks::<true>(e, nb, dist, self.path_width)
        } else {
            min_spacing_blocks::<false>(e, nb, dist, self.path_width)
        }
    }
}

/// The slope of a neighbour's share of "behind" in the cosine of its angle from the
/// direction ([`behind_lanes`]): the share runs from 1 to 0 as the cosine runs from `-0.5 /
/// BEHIND_RAMP` to `0.5 / BEHIND_RAMP` (within 11.5 degrees of beside).
pub(crate) const BEHIND_RAMP: f32 = 2.5;

/// How much of the neighbourhood lies behind the unit direction `(ex, ey)`, counted
/// continuously: each neighbour at the angle `phi` from it counts `clamp(1/2 - BEHIND_RAMP cos
/// phi, 0, 1)` (1 behind, 0 ahead, 1/2 exactly beside and at zero distance, a ramp within 11.5
/// degrees of beside), so that a neighbour beside (a lattice's) does not flip the count on a
/// rounding. In lanes, block by block.
#[inline(always)]
#[must_use]
pub(crate) fn behind_lanes((ex, ey): (f32, f32), nb: &Neighbours) -> f32 {
    let mut behind = [0.0f32; LANES];
    let mut left = nb.count as f32;
    for (rx, ry) in nb.rx.chunks_exact(LANES).zip(nb.ry.chunks_exact(LANES)) {
        for l in 0..LANES {
            let (x, y) = (rx[l], ry[l]);
            let d = (x * x + y * y).sqrt();
            // Divided in every lane and the zero distance selected after, so that the block stays
            // in vector lanes (a branch around the division kept it scalar).
            let cos = (ex * x + ey * y) / d;
            let cos = if d > 0.0 { cos } else { 0.0 };
            let real = (l as f32) < left;
            let h = (0.5 - BEHIND_RAMP * cos).clamp(0.0, 1.0);
            behind[l] += if real { h } else { 0.0 };
        }
        left -= LANES as f32;
    }
    behind.into_iter().sum()
}

/// [`Cfsm::min_spacing_lanes`] for one kind of spacing (`CONTACT`: [`Spacing::Contact`]) and
/// the path's half-width `width` as a fraction of `l_ij` ([`Cfsm::path_width`]; at 1 the
/// product is `l_ij` exactly).
#[inline(always)]
fn min_spacing_blocks<const CONTACT: bool>(
    (ex, ey): (f32, f32),
    nb: &Neighbours,
    dist: &[f32],
    width: f32,
) -> (f32, f32) {
    // The side offset scaled to the path's width (exactly the offset at width 1).
    let to_width = 1.0 / width;
    let mut best = [f32::INFINITY; LANES];
    let mut behind = [0.0f32; LANES];
    let mut left = nb.count as f32;
    let blocks = nb.rx.chunks_exact(LANES).zip(nb.ry.chunks_exact(LANES));
    let blocks = blocks.zip(dist.chunks_exact(LANES).zip(nb.reach.chunks_exact(LANES)));
    for ((rx, ry), (dist, reach)) in blocks {
        let block = |x: &[f32]| -> [f32; LANES] { x.try_into().expect("a block") };
        let (rx, ry, dist, reach) = (block(rx), block(ry), block(dist), block(reach));
        for l in 0..LANES {
            let (x, y) = (rx[l], ry[l]);
            let along = ex * x + ey * y;
            let side = (-ey * x + ex * y).abs();
            let wide = side * to_width;
            let real = (l as f32) < left;
            let ahead =
                real & ((x != 0.0) | (y != 0.0)) & (along >= 0.0) & (side <= reach[l] * width);
            let s = if CONTACT {
                along - (reach[l] * reach[l] - wide * wide).max(0.0).sqrt()
            } else {
                dist[l] - reach[l]
            };
            best[l] = if ahead & (s < best[l]) { s } else { best[l] };
            behind[l] += if real & (along < 0.0) { 1.0 } else { 0.0 };
        }
        left -= LANES as f32;
    }
    let spacing = best
        .into_iter()
        .fold(f32::INFINITY, |m, v| if v < m { v } else { m });
    (spacing, behind.into_iter().sum())
}

impl SocialForce {
    /// [`SocialForce::pair`] of every neighbour, whose velocities are `(vx, vy)`, into `fx`,
    /// `fy` (zero beyond the count), for `i`'s velocity `v` and preferred direction `e`.
    ///
    /// Without `TOUCH` the contact terms (body force and sliding friction) are left out and the
    /// velocities are not read: for neighbours that do not touch `i` that gives the same bits
    /// (the terms are exact zeros there) but for the sign of a zero element, which no sum
    /// starting at `+0` sees, and it saves two divisions per neighbour.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn pair_lanes<const TOUCH: bool>(
        &self,
        nb: &Neighbours,
        (vx, vy): (&[f32], &[f32]),
        v: (f32, f32),
        (ex, ey): (f32, f32),
        dt: f32,
        fx: &mut [f32],
        fy: &mut [f32],
    ) {
        let ins = nb.rx.iter().zip(nb.ry).zip(nb.reach.iter().zip(nb.side));
        let ins = ins.zip(vx.iter().zip(vy));
        for (k, ((((&rx, &ry), (&reach, &side)), (&vjx, &vjy)), (fx, fy))) in
            ins.zip(fx.iter_mut().zip(fy.iter_mut())).enumerate()
        {
            let (d, nx, ny) = distance_and_away(rx, ry, side);
            let overlap = reach - d;
            let cos_phi = -(nx * ex + ny * ey);
            let w = self.lambda + (1.0 - self.lambda) * 0.5 * (1.0 + cos_phi);
            let valid = k < nb.count;
            if !TOUCH {
                let normal = self.a * w * exp_poly(overlap / self.b);
                *fx = if valid { nx * normal } else { 0.0 };
                *fy = if valid { ny * normal } else { 0.0 };
                continue;
            }
            let contact = overlap.max(0.0);
            let normal = self.a * w * exp_poly(overlap / self.b) + self.k * contact;
            let (tx, ty) = (-ny, nx);
            let c = self.kappa * contact;
            let c = c / (1.0 + 2.0 * c * dt / self.mass);
            let slide = c * ((vjx - v.0) * tx + (vjy - v.1) * ty);
            *fx = if valid { tx * slide + nx * normal } else { 0.0 };
            *fy = if valid { ty * slide + ny * normal } else { 0.0 };
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec2;

    use super::*;
    use crate::rng::AgentRng;

    /// Random neighbours, padded: distances from 0 (coincident) to past the cut-off, overlaps,
    /// velocities; `(rx, ry, reach, side, vx, vy)`.
    fn neighbours(seed: u64, count: usize) -> [Vec<f32>; 6] {
        let mut rng = AgentRng::new(seed, 0, 0, 0);
        let n = count.div_ceil(LANES) * LANES;
        let mut v: [Vec<f32>; 6] = Default::default();
        for k in 0..n {
            let d = if k % 7 == 3 {
                Vec2::ZERO
            } else {
                Vec2::new(rng.signed(), rng.signed()) * 2.0 * rng.unit()
            };
            v[0].push(d.x);
            v[1].push(d.y);
            v[2].push(0.3 + 0.3 * rng.unit());
            v[3].push(if k % 2 == 0 { 1.0 } else { -1.0 });
            v[4].push(2.0 * rng.signed());
            v[5].push(2.0 * rng.signed());
        }
        v
    }

    fn as_neighbours<'a>(
        count: usize,
        rx: &'a [f32],
        ry: &'a [f32],
        reach: &'a [f32],
        side: &'a [f32],
    ) -> Neighbours<'a> {
        Neighbours {
            count,
            rx,
            ry,
            reach,
            side,
        }
    }

    /// [`Cfsm::repulsion_lanes`] as one loop over the whole slices (as it was before its blocks):
    /// the reference they are held to, bit for bit.
    fn repulsion_lanes_reference(
        cf: &Cfsm,
        nb: &Neighbours,
        fx: &mut [f32],
        fy: &mut [f32],
        dist: &mut [f32],
        (ex, ey): (f32, f32),
        lambda: f32,
    ) {
        let (s, range) = (cf.strength_neighbour, cf.range_neighbour);
        let ins = nb.rx.iter().zip(nb.ry).zip(nb.reach.iter().zip(nb.side));
        let outs = dist.iter_mut().zip(fx.iter_mut().zip(fy.iter_mut()));
        for (k, (((&rx, &ry), (&reach, &side)), (dist, (fx, fy)))) in ins.zip(outs).enumerate() {
            let (d, nx, ny) = distance_and_away(rx, ry, side);
            let w = lambda + (1.0 - lambda) * (0.5 - 0.5 * (ex * nx + ey * ny));
            let m = s * exp_poly((reach - d) / range) * w;
            let valid = k < nb.count;
            *dist = d;
            *fx = if valid { nx * m } else { 0.0 };
            *fy = if valid { ny * m } else { 0.0 };
        }
    }

    /// [`Cfsm::min_spacing_lanes`] with the spacing's kind read per lane (as it was before its
    /// blocks): the reference they are held to, bit for bit.
    #[must_use]
    fn min_spacing_lanes_reference(
        cf: &Cfsm,
        (ex, ey): (f32, f32),
        nb: &Neighbours,
        dist: &[f32],
    ) -> (f32, f32) {
        let contact = cf.spacing == Spacing::Contact;
        let width = cf.path_width;
        let to_width = 1.0 / width;
        let mut best = [f32::INFINITY; LANES];
        let mut behind = [0.0f32; LANES];
        let mut left = nb.count as f32;
        let blocks = nb.rx.chunks_exact(LANES).zip(nb.ry.chunks_exact(LANES));
        let blocks = blocks.zip(dist.chunks_exact(LANES).zip(nb.reach.chunks_exact(LANES)));
        for ((rx, ry), (dist, reach)) in blocks {
            for l in 0..LANES {
                let (x, y) = (rx[l], ry[l]);
                let along = ex * x + ey * y;
                let side = (-ey * x + ex * y).abs();
                let wide = side * to_width;
                let real = (l as f32) < left;
                let ahead =
                    real & ((x != 0.0) | (y != 0.0)) & (along >= 0.0) & (side <= reach[l] * width);
                let s = if contact {
                    along - (reach[l] * reach[l] - wide * wide).max(0.0).sqrt()
                } else {
                    dist[l] - reach[l]
                };
                // `f32::min` for a non-NaN `best`, in a form that stays in lanes.
                best[l] = if ahead & (s < best[l]) { s } else { best[l] };
                behind[l] += if real & (along < 0.0) { 1.0 } else { 0.0 };
            }
            left -= LANES as f32;
        }
        let spacing = best
            .into_iter()
            .fold(f32::INFINITY, |m, v| if v < m { v } else { m });
        (spacing, behind.into_iter().sum())
    }

    #[test]
    fn speed_model_blocks_give_the_bits_of_one_loop_over_the_slices() {
        let mut rng = AgentRng::new(12, 0, 0, 0);
        for (seed, count) in [(1, 0), (2, 1), (3, 4), (4, 8), (5, 13), (6, 40)] {
            let [rx, ry, reach, side, _, _] = neighbours(seed, count);
            let nb = as_neighbours(count, &rx, &ry, &reach, &side);
            let n = rx.len();
            let mut got = [vec![f32::NAN; n], vec![f32::NAN; n], vec![f32::NAN; n]];
            let mut want = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
            for (anisotropy, spacing, path_width) in [
                (1.0, Spacing::Centre, 1.0),
                (0.8, Spacing::Contact, 1.0),
                (0.8, Spacing::Contact, 0.6),
            ] {
                let cf = Cfsm {
                    anisotropy,
                    spacing,
                    path_width,
                    ..Cfsm::default()
                };
                for e in [Vec2::ZERO, Vec2::X, Vec2::new(-0.6, 0.8)] {
                    let [fx, fy, dist] = &mut got;
                    cf.repulsion_lanes(&nb, fx, fy, dist, (e.x, e.y), anisotropy);
                    let [wx, wy, wd] = &mut want;
                    repulsion_lanes_reference(&cf, &nb, wx, wy, wd, (e.x, e.y), anisotropy);
                    for k in 0..n {
                        for (g, w) in got.iter().zip(&want) {
                            assert_eq!(g[k].to_bits(), w[k].to_bits(), "{k} of {count}");
                        }
                    }
                }
                for _ in 0..20 {
                    let e = Vec2::from_angle(rng.unit() * std::f32::consts::TAU);
                    let (s, behind) = cf.min_spacing_lanes((e.x, e.y), &nb, &got[2]);
                    let (ws, wb) = min_spacing_lanes_reference(&cf, (e.x, e.y), &nb, &got[2]);
                    assert_eq!(
                        (s.to_bits(), behind.to_bits()),
                        (ws.to_bits(), wb.to_bits())
                    );
                    // The continuous count: within 1/2 of the count of those behind per
                    // neighbour, and the same sum one by one.
                    let share = behind_lanes((e.x, e.y), &nb);
                    assert!((share - behind).abs() <= 0.5 * count as f32 + 1e-3);
                    let one_by_one: f32 = (0..count)
                        .map(|k| {
                            let rel = Vec2::new(rx[k], ry[k]);
                            let cos = if rel == Vec2::ZERO {
                                0.0
                            } else {
                                e.dot(rel) / rel.length()
                            };
                            (0.5 - BEHIND_RAMP * cos).clamp(0.0, 1.0)
                        })
                        .sum();
                    assert!(
                        (share - one_by_one).abs() < 1e-4 * (1.0 + count as f32),
                        "{share}"
                    );
                }
            }
        }
    }

    fn ids(side: f32) -> (u32, u32) {
        if side > 0.0 { (0, 1) } else { (1, 0) }
    }

    fn close(a: Vec2, b: Vec2) -> bool {
        (a - b).length() <= 1e-5 * (1.0 + b.length())
    }

    #[test]
    fn social_force_lanes_without_contact_terms_give_the_same_bits_apart() {
        let mut rng = AgentRng::new(11, 0, 0, 0);
        for (seed, count) in [(5, 3), (6, 8), (7, 21)] {
            let [mut rx, mut ry, reach, side, vx, vy] = neighbours(seed, count);
            // Everyone moved out of reach of the body (the padding stays at zero distance).
            for k in 0..count {
                let d = Vec2::new(rx[k], ry[k]);
                let out = d.normalize_or(Vec2::X) * (reach[k] * 1.01 + d.length());
                (rx[k], ry[k]) = (out.x, out.y);
            }
            let nb = as_neighbours(count, &rx, &ry, &reach, &side);
            let n = rx.len();
            let (mut fx, mut fy) = (vec![0.0; n], vec![0.0; n]);
            let (mut gx, mut gy) = (vec![0.0; n], vec![0.0; n]);
            for lambda in [1.0, 0.3] {
                let sf = SocialForce {
                    lambda,
                    ..SocialForce::default()
                };
                let v = (rng.signed(), rng.signed());
                let e = Vec2::from_angle(rng.unit() * std::f32::consts::TAU);
                let vel = (&vx[..], &vy[..]);
                sf.pair_lanes::<true>(&nb, vel, v, (e.x, e.y), 0.01, &mut fx, &mut fy);
                // Velocities the no-contact form must not read.
                let junk = vec![f32::NAN; n];
                sf.pair_lanes::<false>(&nb, (&junk, &junk), v, (e.x, e.y), 0.01, &mut gx, &mut gy);
                for k in 0..n {
                    assert_eq!((gx[k] + 0.0).to_bits(), (fx[k] + 0.0).to_bits());
                    assert_eq!((gy[k] + 0.0).to_bits(), (fy[k] + 0.0).to_bits());
                }
                assert_eq!(lane_sum(&gx).to_bits(), lane_sum(&fx).to_bits());
                assert_eq!(lane_sum(&gy).to_bits(), lane_sum(&fy).to_bits());
            }
        }
    }

    #[test]
    fn social_force_lanes_match_the_scalar_pair_term() {
        let mut rng = AgentRng::new(9, 0, 0, 0);
        for (seed, count) in [(1, 1), (2, 8), (3, 13), (4, 40)] {
            let [rx, ry, reach, side, vx, vy] = neighbours(seed, count);
            let nb = as_neighbours(count, &rx, &ry, &reach, &side);
            let (mut fx, mut fy) = (vec![0.0; rx.len()], vec![0.0; rx.len()]);
            for lambda in [1.0, 0.3] {
                let sf = SocialForce {
                    lambda,
                    ..SocialForce::default()
                };
                let v = Vec2::new(rng.signed(), rng.signed());
                let e = Vec2::from_angle(rng.unit() * std::f32::consts::TAU);
                for dt in [0.0, 0.01] {
                    let vel = (&vx[..], &vy[..]);
                    sf.pair_lanes::<true>(&nb, vel, (v.x, v.y), (e.x, e.y), dt, &mut fx, &mut fy);
                    for k in 0..rx.len() {
                        let got = Vec2::new(fx[k], fy[k]);
                        if k >= count {
                            assert_eq!(got, Vec2::ZERO);
                            continue;
                        }
                        let d = -Vec2::new(rx[k], ry[k]);
                        let vj = Vec2::new(vx[k], vy[k]);
                        let want = sf.pair(d, v, vj, reach[k], e, ids(side[k]), dt);
                        assert!(close(got, want), "{got} {want} at {d}");
                    }
                    let want: Vec2 = (0..count).map(|k| Vec2::new(fx[k], fy[k])).sum();
                    let got = Vec2::new(lane_sum(&fx), lane_sum(&fy));
                    assert!(close(got, want), "{got} {want}");
                }
            }
        }
    }

    #[test]
    fn speed_model_lanes_match_the_scalar_repulsion_and_spacing() {
        let cf = Cfsm::default();
        let mut rng = AgentRng::new(8, 0, 0, 0);
        for (seed, count) in [(1, 0), (2, 1), (3, 8), (4, 13), (5, 40)] {
            let [rx, ry, reach, side, _, _] = neighbours(seed, count);
            let nb = as_neighbours(count, &rx, &ry, &reach, &side);
            let n = rx.len();
            let (mut fx, mut fy, mut dist) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
            let isotropic_and_not = [1.0, 0.8].map(|anisotropy| Cfsm { anisotropy, ..cf });
            for (e0, cf) in [Vec2::ZERO, Vec2::X, Vec2::new(-0.6, 0.8)]
                .into_iter()
                .flat_map(|e0| isotropic_and_not.map(|cf| (e0, cf)))
            {
                for lambda in [cf.anisotropy, 0.0, 0.3] {
                    let e = (e0.x, e0.y);
                    cf.repulsion_lanes(&nb, &mut fx, &mut fy, &mut dist, e, lambda);
                    for k in 0..n {
                        let rel = Vec2::new(rx[k], ry[k]);
                        assert_eq!(dist[k], rel.length());
                        let got = Vec2::new(fx[k], fy[k]);
                        if k < count {
                            let ids = ids(side[k]);
                            let want = cf.repulsion_under(-rel, reach[k], ids, e0, lambda);
                            assert!(close(got, want), "{got} {want} at {rel}");
                            if lambda == cf.anisotropy {
                                assert_eq!(want, cf.repulsion(-rel, reach[k], ids, e0));
                            }
                        } else {
                            assert_eq!(got, Vec2::ZERO);
                        }
                    }
                }
            }
            // The spacing is exactly the scalar minimum, whatever the direction.
            let kinds = [Spacing::Centre, Spacing::Contact]
                .into_iter()
                .flat_map(|spacing| [1.0, 0.6].map(|path_width| (spacing, path_width)));
            for (spacing, path_width) in kinds {
                let cf = Cfsm {
                    spacing,
                    path_width,
                    ..cf
                };
                for _ in 0..20 {
                    let e = Vec2::from_angle(rng.unit() * std::f32::consts::TAU);
                    let (got, behind) = cf.min_spacing_lanes((e.x, e.y), &nb, &dist);
                    let want = (0..count)
                        .filter_map(|k| cf.spacing_to(Vec2::new(rx[k], ry[k]), e, reach[k]))
                        .fold(f32::INFINITY, f32::min);
                    assert_eq!(got.to_bits(), want.to_bits(), "{spacing:?}");
                    let want_behind = (0..count)
                        .filter(|&k| Cfsm::is_behind(Vec2::new(rx[k], ry[k]), e))
                        .count();
                    assert_eq!(behind, want_behind as f32);
                }
            }
        }
    }
}
