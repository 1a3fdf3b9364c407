//! A task's waiting sums: the columns in which the kernel leaves every batched agent's neighbour
//! sums (indexed from the task's first grid position) until the task's cells are done, and the
//! agent's own contribution taken out of them in lanes.
//!
//! Invariants: a column holds [`CELL_CHUNK`] values on whole cache lines, so a slot checked once
//! against it needs no further bounds checks; [`Runs::without_self_run`] gives the bits of
//! [`without_self`](crate::plans::neighbours::without_self) per agent.

use glam::Vec2;

use super::CELL_CHUNK;
use crate::plans::spec::{ALI, COH};
use crate::steering::NeighbourSums;

/// One agent's kernel sums, reduced: separation x and y, alignment x and y, alignment's count,
/// cohesion x and y, cohesion's count, neighbours within the query radius. A Vicsek sum holds
/// the summed unit headings in alignment's place and their number in the last.
pub(super) type Reduced = [f32; 9];

/// The [`NeighbourSums`] of a flocking query's reduced sums.
#[inline(always)]
pub(super) fn flock_sums(r: &Reduced) -> NeighbourSums {
    let [sx, sy, ax, ay, an, cx, cy, cn, n] = *r;
    NeighbourSums {
        separation: Vec2::new(sx, sy),
        alignment: Vec2::new(ax, ay),
        alignment_count: an,
        cohesion: Vec2::new(cx, cy),
        cohesion_count: cn,
        repulsion: Vec2::ZERO,
        count: n,
        heading: Vec2::ZERO,
    }
}

/// One column of [`Runs`]: a task's agents at most, so that an index checked once against
/// [`CELL_CHUNK`] needs no further bounds checks, on whole cache lines (`crate::cache_lines`: the
/// flocking terms read and write the columns in 64-byte vectors).
pub(super) type Column = Box<AlignedColumn>;

/// [`CELL_CHUNK`] values starting on a cache line.
#[derive(Debug)]
#[repr(C, align(64))]
pub(super) struct AlignedColumn([f32; CELL_CHUNK]);

impl std::ops::Deref for AlignedColumn {
    type Target = [f32; CELL_CHUNK];
    fn deref(&self) -> &[f32; CELL_CHUNK] {
        &self.0
    }
}

impl std::ops::DerefMut for AlignedColumn {
    fn deref_mut(&mut self) -> &mut [f32; CELL_CHUNK] {
        &mut self.0
    }
}

/// A zeroed [`Column`] (8 KiB on the heap).
fn column() -> Column {
    Box::new(AlignedColumn([0.0; CELL_CHUNK]))
}

/// The sums and state of a task's agents, in columns indexed from the task's first grid
/// position: the kernel writes every batched or summed agent's sums here; `mark` is the agent's
/// group plus one where they wait for the flocking terms or Vicsek turns, 0 elsewhere (a summed
/// agent's sums are read back at once, by `task::Outputs::settle`).
#[derive(Debug)]
pub(super) struct Runs {
    pub(super) mark: Box<[u32; CELL_CHUNK]>,
    pub(super) sep: [Column; 2],
    pub(super) ali: [Column; 2],
    pub(super) ali_n: Column,
    pub(super) coh: [Column; 2],
    pub(super) coh_n: Column,
    pub(super) vel: [Column; 2],
    pub(super) max_speed: Column,
    pub(super) count: Column,
    /// Agent ids (Vicsek runs: each agent's random stream).
    pub(super) id: Box<[u32; CELL_CHUNK]>,
    /// The weighted sum of the terms, per agent.
    pub(super) total: [Column; 2],
}

impl Default for Runs {
    fn default() -> Self {
        Runs {
            mark: vec![0; CELL_CHUNK]
                .into_boxed_slice()
                .try_into()
                .expect("CELL_CHUNK marks"),
            sep: [column(), column()],
            ali: [column(), column()],
            ali_n: column(),
            coh: [column(), column()],
            coh_n: column(),
            vel: [column(), column()],
            max_speed: column(),
            count: column(),
            id: vec![0; CELL_CHUNK]
                .into_boxed_slice()
                .try_into()
                .expect("CELL_CHUNK ids"),
            total: [column(), column()],
        }
    }
}

impl Runs {
    /// No agent of the first `n` waiting.
    pub(super) fn clear(&mut self, n: usize) {
        self.mark[..n].fill(0);
    }

    /// Writes the kernel's sums of the agent at slot `j`, the agent itself still in them (as
    /// the kernel summed its buffer).
    #[inline(always)]
    pub(super) fn set(&mut self, j: usize, r: &Reduced) {
        assert!(j < CELL_CHUNK, "a slot of the task");
        let [sx, sy, ax, ay, an, cx, cy, cn, n] = *r;
        (self.sep[0][j], self.sep[1][j]) = (sx, sy);
        (self.ali[0][j], self.ali[1][j]) = (ax, ay);
        self.ali_n[j] = an;
        (self.coh[0][j], self.coh[1][j]) = (cx, cy);
        self.coh_n[j] = cn;
        self.count[j] = n;
    }

    /// The flocking sums held at slot `j`.
    #[inline(always)]
    pub(super) fn sums_at(&self, j: usize) -> NeighbourSums {
        flock_sums(&[
            self.sep[0][j],
            self.sep[1][j],
            self.ali[0][j],
            self.ali[1][j],
            self.ali_n[j],
            self.coh[0][j],
            self.coh[1][j],
            self.coh_n[j],
            self.count[j],
        ])
    }

    /// [`without_self`](crate::plans::neighbours::without_self) over the agents at `range`,
    /// whose velocities are `(vx, vy)`: the same subtractions in lanes, so the same bits; the
    /// velocities go to `vel`.
    pub(super) fn without_self_run(
        &mut self,
        range: std::ops::Range<usize>,
        (vx, vy): (&[f32], &[f32]),
        on: [bool; 3],
    ) {
        let n = range.len();
        let (vx, vy) = (&vx[..n], &vy[..n]);
        self.vel[0][range.clone()].copy_from_slice(vx);
        self.vel[1][range.clone()].copy_from_slice(vy);
        for c in &mut self.count[range.clone()] {
            *c -= 1.0;
        }
        if on[ALI] {
            let [ax, ay] = &mut self.ali;
            let (ax, ay) = (&mut ax[range.clone()], &mut ay[range.clone()]);
            let ay = &mut ay[..ax.len()];
            for k in 0..n.min(ax.len()) {
                ax[k] -= vx[k];
                ay[k] -= vy[k];
            }
            for c in &mut self.ali_n[range.clone()] {
                *c -= 1.0;
            }
        }
        if on[COH] {
            for c in &mut self.coh_n[range] {
                *c -= 1.0;
            }
        }
    }
}

#[cfg(test)]
pub(super) mod tests {
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;
    use crate::plans::neighbours::{LANES, without_self};
    use crate::plans::spec::{NeighbourSpec, SEP};

    /// The bits of every sum.
    pub(in crate::plans::cells) fn bits(s: &NeighbourSums) -> [u32; 9] {
        reduced_of(s).map(f32::to_bits)
    }

    /// The reduced form of `s`, as the kernel writes it.
    pub(in crate::plans::cells) fn reduced_of(s: &NeighbourSums) -> Reduced {
        [
            s.separation.x,
            s.separation.y,
            s.alignment.x,
            s.alignment.y,
            s.alignment_count,
            s.cohesion.x,
            s.cohesion.y,
            s.cohesion_count,
            s.count,
        ]
    }

    /// Neighbour sums with every field [`Runs`] holds random (counts whole, as the kernel counts),
    /// the others zero.
    fn random_sums(rng: &mut ChaCha8Rng) -> NeighbourSums {
        let mut v = || Vec2::new(rng.random_range(-50.0..50.0), rng.random_range(-50.0..50.0));
        let (separation, alignment, cohesion) = (v(), v(), v());
        NeighbourSums {
            separation,
            alignment,
            alignment_count: f32::from(rng.random_range(1u8..40)),
            cohesion,
            cohesion_count: f32::from(rng.random_range(1u8..40)),
            count: f32::from(rng.random_range(1u8..80)),
            ..NeighbourSums::default()
        }
    }

    #[test]
    fn without_self_over_a_run_equals_without_self_per_agent_bit_for_bit() {
        // Every pattern of the separation, alignment and cohesion flags; a run that starts inside
        // the columns and whose length is a multiple of no vector width, with slots on both
        // sides of it that must keep their sums.
        let mut rng = ChaCha8Rng::seed_from_u64(12);
        let range = 3..3 + 4 * LANES + 5;
        let slots = range.end + 4;
        for pattern in 0..8u8 {
            let on = [SEP, ALI, COH].map(|b| pattern & (1 << b) != 0);
            let spec = NeighbourSpec {
                on,
                ..NeighbourSpec::default()
            };
            let sums: Vec<NeighbourSums> = (0..slots).map(|_| random_sums(&mut rng)).collect();
            let mut runs = Runs::default();
            for (j, s) in sums.iter().enumerate() {
                runs.set(j, &reduced_of(s));
            }
            let vel: Vec<Vec2> = range
                .clone()
                .map(|_| Vec2::new(rng.random_range(-4.0..4.0), rng.random_range(-4.0..4.0)))
                .collect();
            let (vx, vy): (Vec<f32>, Vec<f32>) = vel.iter().map(|v| (v.x, v.y)).unzip();
            runs.without_self_run(range.clone(), (&vx, &vy), on);
            for (j, s) in sums.iter().enumerate() {
                let want = match j.checked_sub(range.start) {
                    Some(k) if range.contains(&j) => {
                        let got_vel = [runs.vel[0][j], runs.vel[1][j]].map(f32::to_bits);
                        assert_eq!(got_vel, [vel[k].x, vel[k].y].map(f32::to_bits), "slot {j}");
                        without_self(*s, vel[k], &spec)
                    }
                    _ => *s,
                };
                let got = runs.sums_at(j);
                assert_eq!(
                    bits(&got),
                    bits(&want),
                    "on {on:?}, slot {j}: {got:?} vs {want:?}"
                );
            }
        }
    }
}
