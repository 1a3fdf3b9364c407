//! A stable counting sort of point indices by a small integer key, in parallel for large N: the
//! rebuild of [`super::GridIndex`] (key: the cell) and of [`super::HashGrid`] (key: the bucket).
//!
//! # Passes
//!
//! Given each point's key in `0..keys`:
//!
//! 1. Per chunk of points: a histogram of *coarse buckets*, runs of `2^shift` consecutive keys
//!    chosen so that there are at most [`BUCKETS`] of them; prefix sums over (bucket, chunk) give
//!    every chunk its own slots in every bucket.
//! 2. Per chunk: scatter `key << 32 | index` into those slots. Few buckets means few write
//!    streams, which stay in cache even when the points come in random order. Slots of different
//!    chunks interleave, so this buffer holds relaxed atomics (plain stores on x86) rather than
//!    `unsafe`.
//! 3. Per bucket: a counting sort by key inside the bucket (its keys' counters fit in cache),
//!    writing `start`, `order` and the sorted positions. Buckets own disjoint output ranges, so
//!    they run in parallel (`rayon::join` over halves of the buckets).
//!
//! Up to [`DIRECT_MAX_POINTS`] points and [`DIRECT_MAX_KEYS`] keys the sort is instead one count
//! per key, their prefix sums and one scatter, on the calling thread
//! ([`CountingSort::sort_direct`]): at those sizes the passes' per-bucket work costs more than
//! their cache-friendliness and their second thread save. Up to [`ROWS_MAX_POINTS`] points (and
//! [`DIRECT_MAX_KEYS`] keys) it is one level on the rayon pool, a row of counts per chunk of
//! points ([`CountingSort::sort_rows`]).
//!
//! Before either of the parallel ways, a sort of [`RANGES_MIN_POINTS`] points or more tries
//! [`CountingSort::sort_ranges`]: when the points come nearly in their keys' order (agents
//! between two reorders by cell), each task sorts the points of one range of keys in one level,
//! as the direct way does, straight into its own range of the outputs; it declines, writing
//! nothing, when the tasks would read many points more than once.
//!
//! # Invariants
//!
//! * `order` is the stable sort of `0..N` by key: the points of one key in ascending index order,
//!   whatever the number of chunks, so the result does not depend on the thread count.
//! * `rank` is the inverse of `order`: point `i` sits at `order[rank[i]]`. Each way writes it
//!   where it places a point (in point order in the one-level ways), so a caller that maps
//!   points to their sorted positions reads it instead of scattering the order itself.
//! * `start` holds its prefix sums, `keys + 1` long with `start[0] = 0`; the sorted positions
//!   follow `order`, then the caller's padding (`pad.0` entries of `pad.1`: zeros for the grid,
//!   `f32::MAX` for the hash grid).
//! * Buffers are reused: once warm, a sort of the same size allocates nothing.
//! * The positions come through a generic closure, so the inner loops are specialised for each
//!   caller's layout (no dynamic dispatch).

use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};

use rayon::prelude::*;

/// Coarse buckets at most: few enough that the scatter writes to cache-resident streams.
const BUCKETS: usize = 1024;
/// A worker sorts at least this many points' buckets before splitting further.
const LEAF_POINTS: u32 = 16 * 1024;
/// The most chunks the points are split into.
const MAX_PARTS: usize = 64;
/// Points and keys up to which the sort runs in one level on the calling thread
/// ([`CountingSort::sort_direct`]): its counters (1 MiB at most) and outputs stay in cache, and
/// it costs a few instructions per point and key where the two levels cost dozens per point.
const DIRECT_MAX_POINTS: usize = 1 << 16;
/// See [`DIRECT_MAX_POINTS`]; also the most keys [`CountingSort::sort_rows`] takes.
const DIRECT_MAX_KEYS: usize = 1 << 18;
/// Points up to which more than [`DIRECT_MAX_POINTS`] are sorted in one level on the rayon pool
/// ([`CountingSort::sort_rows`]), as far as it was measured quicker than the two levels
/// (docs/PERFORMANCE.md, "Tuning constants").
const ROWS_MAX_POINTS: usize = 1 << 20;

/// Sorted positions per task of the last pass of [`CountingSort::sort_rows`].
const ORDER_CHUNK: usize = 16 * 1024;

/// Points per block whose least and greatest key [`CountingSort::sort_ranges`] records.
const RANGE_BLOCK: usize = 4096;
/// Tasks of [`CountingSort::sort_ranges`] per part: more than one, so that a thread on a
/// slower core leaves some of its share to the other.
const RANGE_TASKS_PER_PART: usize = 2;
/// Sorts after [`CountingSort::sort_ranges`] found the points too far from their keys' order
/// before it tries again.
const RANGES_RETRY: u32 = 2;
/// Points from which [`CountingSort::sort`] tries [`CountingSort::sort_ranges`]: quicker than the
/// rows for many points nearly in their keys' order, slower for fewer (docs/PERFORMANCE.md, "Tuning constants").
const RANGES_MIN_POINTS: usize = 1 << 19;
/// The most runs of keys whose owning task [`CountingSort::sort_ranges`] looks up in a table.
const OWNER_RUNS: usize = 4096;
/// An entry of that table for a run of keys that more than one task owns.
const STRADDLES: u8 = u8::MAX;

/// A counting sort by key with its outputs and reusable scratch.
#[derive(Clone, Debug, Default)]
pub(super) struct CountingSort {
    /// Prefix sums of the points per key, `keys + 1` long.
    pub(super) start: Vec<u32>,
    /// Point indices sorted by key, ascending within a key.
    pub(super) order: Vec<u32>,
    /// x coordinates in `order`, then the padding.
    pub(super) sorted_x: Vec<f32>,
    /// y coordinates in `order`, then the padding.
    pub(super) sorted_y: Vec<f32>,
    /// `rank[i]`: the position of point `i` in `order`.
    pub(super) rank: Ranks,
    /// Scratch: points per coarse bucket, as prefix sums.
    bucket_start: Vec<u32>,
    /// Scratch: per chunk of points, a histogram of coarse buckets, then write cursors.
    histogram: Vec<u32>,
    /// Scratch: `key << 32 | index` grouped by coarse bucket.
    pairs: Pairs,
    /// Scratch: point indices in their slots ([`CountingSort::sort_rows`]).
    slots: Slots,
    /// Scratch: per block of points, a bit for each task whose keys it holds
    /// ([`CountingSort::sort_ranges`]).
    blocks: Vec<u128>,
    /// Scratch: per run of `2^shift` keys, the task that owns them all, or [`STRADDLES`].
    owner: Vec<u8>,
    /// Scratch: the tasks of [`CountingSort::sort_ranges`].
    tasks: Vec<RangeTask>,
    /// Sorts left before [`CountingSort::sort_ranges`] is tried again.
    ranges_wait: u32,
}

/// A task of [`CountingSort::sort_ranges`]: a range of keys, its points and their positions.
#[derive(Clone, Copy, Debug, Default)]
struct RangeTask {
    /// Its place among the tasks (its bit in a block's mask).
    index: u32,
    /// Its first key; its keys end at the next task's first key.
    first_key: u32,
    /// Its points.
    points: u32,
    /// The position of its first point in the order.
    base: u32,
}

/// Scratch space for the bucket scatter; cloning gives an empty one.
#[derive(Debug, Default)]
struct Pairs(Vec<AtomicU64>);

impl Clone for Pairs {
    fn clone(&self) -> Self {
        Pairs::default()
    }
}

/// Scratch space for the rows' scatter; cloning gives an empty one.
#[derive(Debug, Default)]
struct Slots(Vec<AtomicU32>);

impl Clone for Slots {
    fn clone(&self) -> Self {
        Slots::default()
    }
}

/// The sorted position of each point: relaxed atomics, because the two-level way writes them
/// from its buckets in any point order (plain stores and loads on x86).
#[derive(Debug, Default)]
pub(super) struct Ranks(pub(super) Vec<AtomicU32>);

impl Clone for Ranks {
    fn clone(&self) -> Self {
        let values = self.0.iter().map(|r| r.load(Ordering::Relaxed));
        Ranks(values.map(AtomicU32::new).collect())
    }
}

impl CountingSort {
    /// An empty sort whose `start` covers `keys` keys holding no point.
    pub(super) fn with_keys(keys: usize) -> Self {
        CountingSort {
            start: vec![0; keys + 1],
            ..CountingSort::default()
        }
    }

    /// Sorts the points `0..key.len()` by `key` (each `< keys`) into `start`, `order`,
    /// `sorted_x` and `sorted_y` (`pos(i)` is point `i`'s position; `pad.0` entries of `pad.1`
    /// follow the sorted positions), using `parts` chunks of points (1 = on this thread; more:
    /// on the current rayon pool). The result does not depend on `parts`.
    ///
    /// The caller guarantees `key.len() <= u32::MAX`.
    pub(super) fn sort<P>(
        &mut self,
        key: &[u32],
        keys: usize,
        pos: P,
        parts: usize,
        pad: (usize, f32),
    ) where
        P: Fn(usize) -> (f32, f32) + Sync,
    {
        let n = key.len();
        debug_assert!(u32::try_from(n).is_ok(), "{n} points exceed u32");
        debug_assert!(
            key.iter().all(|&k| (k as usize) < keys),
            "a key out of range"
        );
        let parts = parts.clamp(1, MAX_PARTS);
        // Every way writes the same outputs; sized here once (a way that declines leaves their
        // values to the next).
        self.resize_outputs(n, pad);
        let input = Input {
            key,
            keys,
            pos,
            parts,
        };
        let few = n <= DIRECT_MAX_POINTS || parts == 1;
        if few && keys <= DIRECT_MAX_KEYS {
            self.sort_direct(input);
        } else if n >= RANGES_MIN_POINTS && parts > 1 && self.sort_ranges(&input) {
            // Sorted in ranges of keys.
        } else if n <= ROWS_MAX_POINTS && keys <= DIRECT_MAX_KEYS {
            self.sort_rows(input);
        } else {
            self.sort_levels(input);
        }
    }

    /// Whether the last sort was one in ranges of keys ([`CountingSort::sort_ranges`]).
    #[cfg(test)]
    pub(super) fn took_ranges(&self) -> bool {
        !self.tasks.is_empty() && self.ranges_wait == 0
    }

    /// The sort in one level on the current rayon pool, for points that come nearly in their
    /// keys' order (the agents between two reorders by cell): the keys are cut into ranges of
    /// about equal numbers of points (the keys of evenly spaced points), and a task per range
    /// counts and places its own points, as [`CountingSort::sort_direct`] does, reading only
    /// the blocks of points whose keys reach into its range. The tasks own disjoint ranges of
    /// the outputs, so no point passes through scratch space. Returns false, having written
    /// nothing, when the tasks would read more than a quarter of the points twice (then it is
    /// not tried for the next [`RANGES_RETRY`] sorts).
    fn sort_ranges<P>(&mut self, input: &Input<'_, P>) -> bool
    where
        P: Fn(usize) -> (f32, f32) + Sync,
    {
        if self.ranges_wait > 0 {
            self.ranges_wait -= 1;
            return false;
        }
        let (key, keys, parts, pos) = (input.key, input.keys, input.parts, &input.pos);
        let n = key.len();
        if n == 0 {
            return false;
        }
        // The tasks' first keys, ascending.
        let count = parts * RANGE_TASKS_PER_PART;
        debug_assert!(count <= 128 && count < usize::from(STRADDLES));
        self.tasks.clear();
        let mut first = 0;
        for t in 0..count {
            if t > 0 {
                first = key[t * n / count].max(first);
            }
            self.tasks.push(RangeTask {
                index: t as u32,
                first_key: first,
                ..RangeTask::default()
            });
        }
        // The task owning each key: from a table of runs of keys, searched where a run
        // straddles two tasks.
        let tasks = &self.tasks;
        let task_of = |k: u32| tasks.partition_point(|t| t.first_key <= k) - 1;
        let mut shift = 0;
        while keys.div_ceil(1 << shift) > OWNER_RUNS {
            shift += 1;
        }
        self.owner.clear();
        self.owner.extend((0..keys.div_ceil(1 << shift)).map(|r| {
            let (k0, k1) = (r << shift, ((r + 1) << shift).min(keys) - 1);
            let t = task_of(k0 as u32);
            if t == task_of(k1 as u32) {
                t as u8
            } else {
                STRADDLES
            }
        }));
        // Each block's tasks.
        let owner = &self.owner;
        self.blocks.resize(n.div_ceil(RANGE_BLOCK), 0);
        self.blocks
            .par_iter_mut()
            .zip(key.par_chunks(RANGE_BLOCK))
            .with_min_len(16)
            .for_each(|(b, key)| {
                // Most blocks' keys lie within one task's: their least and greatest tell.
                let (lo, hi) = key
                    .iter()
                    .fold((u32::MAX, 0), |(lo, hi), &k| (lo.min(k), hi.max(k)));
                let first = task_of(lo);
                *b = if first == task_of(hi) {
                    1 << first
                } else {
                    key.iter().fold(0, |mask, &k| {
                        let t = owner[(k >> shift) as usize];
                        let t = if t == STRADDLES {
                            task_of(k)
                        } else {
                            usize::from(t)
                        };
                        mask | 1 << t
                    })
                };
            });
        // The points the tasks would read.
        let blocks = &self.blocks;
        let len = |b: usize| RANGE_BLOCK.min(n - b * RANGE_BLOCK);
        let read: usize = (0..blocks.len())
            .map(|b| blocks[b].count_ones() as usize * len(b))
            .sum();
        if read > n + n / 4 {
            self.ranges_wait = RANGES_RETRY;
            return false;
        }

        self.start.resize(keys + 1, 0);
        self.start[0] = 0;
        let sh = RangeShared {
            key,
            keys,
            blocks: &self.blocks,
            rank: &self.rank.0[..n],
            pos,
        };
        // Each task's counts, then its keys' first slots counted from its first position.
        count_ranges(&sh, &mut self.tasks, &mut self.start[1..]);
        let mut run = 0;
        for t in &mut self.tasks {
            t.base = run;
            run += t.points;
        }
        debug_assert_eq!(run as usize, n, "every point in one task");
        // Each task places its points; its keys' ends become the starts of the next keys.
        let out = Out {
            key_end: &mut self.start[1..],
            order: &mut self.order,
            sorted_x: &mut self.sorted_x[..n],
            sorted_y: &mut self.sorted_y[..n],
        };
        place_ranges(&sh, &self.tasks, out);
        true
    }

    /// The sort in one level on the current rayon pool, for many points and few keys: each chunk
    /// of points counts its keys in a row of its own; the rows' prefix sums, key by key, give
    /// each chunk its first slot of each key (chunk order within a key keeps the sort stable);
    /// each chunk scatters its points' indices to its slots; the sorted indices and positions
    /// are then written in order. The same result as [`CountingSort::sort_levels`], quicker
    /// where each row of counts stays in cache (see [`ROWS_MAX_POINTS`]).
    fn sort_rows<P>(&mut self, input: Input<'_, P>)
    where
        P: Fn(usize) -> (f32, f32) + Sync,
    {
        let (key, keys, parts, pos) = (input.key, input.keys, input.parts, &input.pos);
        let n = key.len();
        let chunk_len = n.div_ceil(parts).max(1);
        let chunks = n.div_ceil(chunk_len);
        // Pass 1: per chunk, a count per key.
        count_chunks(
            &mut self.histogram,
            key,
            (chunks, chunk_len),
            (keys, 0),
            true,
        );
        // Pass 2: key by key, each chunk's first slot (its row becomes its write cursors), and
        // the keys' starts.
        column_starts(&mut self.histogram, keys, chunks, &mut self.start);

        // Pass 3: each chunk scatters its points' indices into its slots. The slots of
        // different chunks interleave, so they are relaxed atomics (plain stores on x86).
        // Each point's slot is its rank, written in point order.
        self.slots.0.resize_with(n, || AtomicU32::new(0));
        let slots = &self.slots.0[..n];
        self.histogram
            .par_chunks_mut(keys.max(1))
            .zip(key.par_chunks(chunk_len))
            .zip(self.rank.0[..n].par_chunks(chunk_len))
            .enumerate()
            .with_max_len(1)
            .for_each(|(t, ((row, key), rank))| {
                let first = t * chunk_len;
                for (i, (&k, r)) in key.iter().zip(rank).enumerate() {
                    let slot = &mut row[k as usize];
                    slots[*slot as usize].store((first + i) as u32, Ordering::Relaxed);
                    r.store(*slot, Ordering::Relaxed);
                    *slot += 1;
                }
            });

        // Pass 4: the sorted indices and positions, in order, in tasks of their own size (not
        // the chunks': two threads at different speeds then share the pass by speed).
        self.order
            .par_chunks_mut(ORDER_CHUNK)
            .zip(self.sorted_x[..n].par_chunks_mut(ORDER_CHUNK))
            .zip(self.sorted_y[..n].par_chunks_mut(ORDER_CHUNK))
            .zip(slots.par_chunks(ORDER_CHUNK))
            .with_max_len(1)
            .for_each(|(((order, sx), sy), slots)| {
                for (((o, x), y), s) in order.iter_mut().zip(sx).zip(sy).zip(slots) {
                    let i = s.load(Ordering::Relaxed);
                    *o = i;
                    (*x, *y) = pos(i as usize);
                }
            });
    }

    /// [`CountingSort::sort`] in the passes of the module's documentation, for any size.
    fn sort_levels<P>(&mut self, input: Input<'_, P>)
    where
        P: Fn(usize) -> (f32, f32) + Sync,
    {
        let (key, keys, parts, pos) = (input.key, input.keys, input.parts, &input.pos);
        let n = key.len();
        let parts = parts.clamp(1, MAX_PARTS);
        let parallel = parts > 1;

        // Pass 1: a histogram of coarse buckets (runs of 2^shift keys) per chunk of points.
        let mut shift = 0;
        while (keys + (1 << shift) - 1) >> shift > BUCKETS {
            shift += 1;
        }
        let buckets = (keys + (1 << shift) - 1) >> shift;
        let chunk_len = n.div_ceil(parts).max(1);
        let chunks = n.div_ceil(chunk_len);
        let widths = (buckets, shift);
        count_chunks(
            &mut self.histogram,
            key,
            (chunks, chunk_len),
            widths,
            parallel,
        );
        // Bucket starts, and each chunk's first slot in each bucket: chunk order within a bucket
        // keeps the scatter stable.
        column_starts(&mut self.histogram, buckets, chunks, &mut self.bucket_start);

        // Pass 2: each chunk scatters its `(key, index)` pairs into its own slots. The slots of
        // different chunks interleave, so the pairs are relaxed atomics (plain stores on x86).
        self.pairs.0.resize_with(n, || AtomicU64::new(0));
        let pairs = &self.pairs.0[..n];
        let scatter = |t: usize, row: &mut [u32], key: &[u32]| {
            let first = t * chunk_len;
            for (i, &k) in key.iter().enumerate() {
                let slot = &mut row[(k >> shift) as usize];
                pairs[*slot as usize]
                    .store(u64::from(k) << 32 | (first + i) as u64, Ordering::Relaxed);
                *slot += 1;
            }
        };
        if parallel {
            self.histogram
                .par_chunks_mut(buckets)
                .zip(key.par_chunks(chunk_len))
                .enumerate()
                .for_each(|(t, (row, key))| scatter(t, row, key));
        } else {
            for (t, (row, key)) in self
                .histogram
                .chunks_mut(buckets)
                .zip(key.chunks(chunk_len))
                .enumerate()
            {
                scatter(t, row, key);
            }
        }

        // Pass 3: within each bucket, a counting sort by key, in cache; buckets own disjoint
        // ranges of the outputs, so they run in parallel.
        self.start.resize(keys + 1, 0);
        self.start[0] = 0;
        let shared = Shared {
            bucket_start: &self.bucket_start,
            pairs,
            rank: &self.rank.0[..n],
            pos: &pos,
            shift,
            keys,
            parallel,
        };
        let out = Out {
            key_end: &mut self.start[1..],
            order: &mut self.order,
            sorted_x: &mut self.sorted_x[..n],
            sorted_y: &mut self.sorted_y[..n],
        };
        sort_buckets(&shared, 0, buckets, out);
    }

    /// `order` and `rank` for `n` points, and the sorted positions for `n` then their padding
    /// (`pad.0` entries of `pad.1`), written.
    fn resize_outputs(&mut self, n: usize, (pad, pad_value): (usize, f32)) {
        self.order.resize(n, 0);
        self.rank.0.resize_with(n, AtomicU32::default);
        self.rank.0.truncate(n);
        self.sorted_x.resize(n + pad, 0.0);
        self.sorted_y.resize(n + pad, 0.0);
        self.sorted_x[n..].fill(pad_value);
        self.sorted_y[n..].fill(pad_value);
    }

    /// The sort in one level on this thread, for few points and keys: a count per key, their
    /// prefix sums, one scatter. The same result as [`CountingSort::sort_levels`] (the stable
    /// order is unique), for a fraction of its work where the keys' counters fit in cache: a
    /// hashed grid of 10,000 points (32,768 keys) took 116 instructions a point in the two
    /// levels, 57 in one.
    fn sort_direct<P>(&mut self, input: Input<'_, P>)
    where
        P: Fn(usize) -> (f32, f32),
    {
        let Input { key, keys, pos, .. } = input;
        let n = key.len();
        self.start.clear();
        self.start.resize(keys + 1, 0);
        // `start[k + 1]` counts key `k`, then holds its first slot, then (the scatter's cursor)
        // its end: the start of key `k + 1`.
        let (start, order) = (&mut self.start[..], &mut self.order[..n]);
        let (sx, sy) = (&mut self.sorted_x[..n], &mut self.sorted_y[..n]);
        let rank = &self.rank.0[..n];
        let ends = &mut start[1..];
        for &k in key {
            ends[k as usize] += 1;
        }
        let mut run = 0u32;
        for e in ends.iter_mut() {
            (*e, run) = (run, run + *e);
        }
        for (i, (&k, r)) in key.iter().zip(rank).enumerate() {
            let slot = &mut ends[k as usize];
            let at = *slot as usize;
            r.store(*slot, Ordering::Relaxed);
            *slot += 1;
            let (x, y) = pos(i);
            order[at] = i as u32;
            sx[at] = x;
            sy[at] = y;
        }
    }
}

/// What [`CountingSort::sort`] hands each of its ways: the keys, their number, the positions,
/// the parts to split the points into (the outputs are already sized, padding included).
struct Input<'a, P> {
    key: &'a [u32],
    keys: usize,
    pos: P,
    parts: usize,
}

/// Pass 1 of the sorts: a row of `width` counts per chunk of `chunk_len` points (`chunks` of
/// them), each point counted at its key shifted right by `shift`; on the current rayon pool
/// when `parallel`, a task per chunk.
fn count_chunks(
    histogram: &mut Vec<u32>,
    key: &[u32],
    (chunks, chunk_len): (usize, usize),
    (width, shift): (usize, u32),
    parallel: bool,
) {
    histogram.resize(chunks * width, 0);
    let count = |row: &mut [u32], key: &[u32]| {
        row.fill(0);
        for &k in key {
            row[(k >> shift) as usize] += 1;
        }
    };
    let rows = width.max(1);
    if parallel {
        histogram
            .par_chunks_mut(rows)
            .zip(key.par_chunks(chunk_len))
            .with_max_len(1)
            .for_each(|(row, key)| count(row, key));
    } else {
        for (row, key) in histogram.chunks_mut(rows).zip(key.chunks(chunk_len)) {
            count(row, key);
        }
    }
}

/// Prefix sums over a histogram of `chunks` rows of `width` counts, column by column: each count
/// becomes its chunk's first slot in that column (chunk order within a column keeps the sort
/// stable), and `starts` (`width + 1` long) each column's first slot, then the total.
fn column_starts(histogram: &mut [u32], width: usize, chunks: usize, starts: &mut Vec<u32>) {
    starts.resize(width + 1, 0);
    let mut run = 0u32;
    for c in 0..width {
        starts[c] = run;
        for t in 0..chunks {
            let h = &mut histogram[t * width + c];
            (*h, run) = (run, run + *h);
        }
    }
    starts[width] = run;
}

/// Read-only inputs of [`count_ranges`] and [`place_ranges`].
struct RangeShared<'a, P> {
    key: &'a [u32],
    keys: usize,
    blocks: &'a [u128],
    rank: &'a [AtomicU32],
    pos: &'a P,
}

/// Calls `visit(i, k - range.start)` for each point `i` whose key `k` lies in `range`, the
/// keys of `task`, in ascending order, reading only the blocks that hold some of its keys (and
/// testing each key only in blocks that hold keys of other tasks too).
#[inline(always)]
fn for_each_in<P>(
    sh: &RangeShared<'_, P>,
    task: u32,
    range: &std::ops::Range<u32>,
    mut visit: impl FnMut(usize, usize),
) {
    let bit = 1u128 << task;
    for (b, (&block, key)) in sh.blocks.iter().zip(sh.key.chunks(RANGE_BLOCK)).enumerate() {
        if block & bit == 0 {
            continue;
        }
        let first = b * RANGE_BLOCK;
        if block == bit {
            for (j, &k) in key.iter().enumerate() {
                visit(first + j, (k - range.start) as usize);
            }
        } else {
            for (j, &k) in key.iter().enumerate() {
                if range.contains(&k) {
                    visit(first + j, (k - range.start) as usize);
                }
            }
        }
    }
}

/// Counts each task's points per key into its keys' entries of `ends` (`start[1..]` from the
/// first task's first key), which become the keys' first slots counted from the task's first
/// position; records each task's points. In parallel halves of the tasks.
fn count_ranges<P>(sh: &RangeShared<'_, P>, tasks: &mut [RangeTask], ends: &mut [u32])
where
    P: Sync,
{
    if tasks.len() > 1 {
        let mid = tasks.len() / 2;
        let (ta, tb) = tasks.split_at_mut(mid);
        let (ea, eb) = ends.split_at_mut((tb[0].first_key - ta[0].first_key) as usize);
        rayon::join(|| count_ranges(sh, ta, ea), || count_ranges(sh, tb, eb));
        return;
    }
    let range = tasks[0].first_key..tasks[0].first_key + ends.len() as u32;
    debug_assert!(range.end as usize <= sh.keys);
    ends.fill(0);
    for_each_in(sh, tasks[0].index, &range, |_, k| ends[k] += 1);
    let mut run = 0u32;
    for end in ends.iter_mut() {
        (*end, run) = (run, run + *end);
    }
    tasks[0].points = run;
}

/// Places each task's points in `out` (from the first task's first key and position) at their
/// keys' slots, writes their ranks, and leaves each key's entry of `ends` at its end, counted
/// from the first position. In parallel halves of the tasks.
fn place_ranges<P>(sh: &RangeShared<'_, P>, tasks: &[RangeTask], out: Out<'_>)
where
    P: Fn(usize) -> (f32, f32) + Sync,
{
    if tasks.len() > 1 {
        let mid = tasks.len() / 2;
        let (ta, tb) = tasks.split_at(mid);
        let (a, b) = out.split_at(
            (tb[0].first_key - ta[0].first_key) as usize,
            (tb[0].base - ta[0].base) as usize,
        );
        rayon::join(|| place_ranges(sh, ta, a), || place_ranges(sh, tb, b));
        return;
    }
    let Out {
        key_end: ends,
        order,
        sorted_x,
        sorted_y,
    } = out;
    let (first, base) = (tasks[0].first_key, tasks[0].base);
    let range = first..first + ends.len() as u32;
    for_each_in(sh, tasks[0].index, &range, |i, k| {
        let slot = &mut ends[k];
        let at = *slot as usize;
        *slot += 1;
        sh.rank[i].store(base + at as u32, Ordering::Relaxed);
        let (x, y) = (sh.pos)(i);
        order[at] = i as u32;
        sorted_x[at] = x;
        sorted_y[at] = y;
    });
    for end in ends.iter_mut() {
        *end += base;
    }
}

/// Read-only inputs of [`sort_buckets`].
struct Shared<'a, P> {
    bucket_start: &'a [u32],
    pairs: &'a [AtomicU64],
    rank: &'a [AtomicU32],
    pos: &'a P,
    shift: u32,
    keys: usize,
    parallel: bool,
}

/// The outputs of [`sort_buckets`] for a range of buckets: their keys' entries of `start[1..]`,
/// and their points' range of the sorted arrays.
struct Out<'a> {
    key_end: &'a mut [u32],
    order: &'a mut [u32],
    sorted_x: &'a mut [f32],
    sorted_y: &'a mut [f32],
}

impl Out<'_> {
    fn split_at(self, key: usize, point: usize) -> (Self, Self) {
        let (e0, e1) = self.key_end.split_at_mut(key);
        let (o0, o1) = self.order.split_at_mut(point);
        let (x0, x1) = self.sorted_x.split_at_mut(point);
        let (y0, y1) = self.sorted_y.split_at_mut(point);
        (
            Out {
                key_end: e0,
                order: o0,
                sorted_x: x0,
                sorted_y: y0,
            },
            Out {
                key_end: e1,
                order: o1,
                sorted_x: x1,
                sorted_y: y1,
            },
        )
    }
}

/// Sorts the points of buckets `b0..b1` by key (stable) into `out`, and writes their keys' ends.
fn sort_buckets<P>(sh: &Shared<'_, P>, b0: usize, b1: usize, out: Out<'_>)
where
    P: Fn(usize) -> (f32, f32) + Sync,
{
    let first_key = (b0 << sh.shift).min(sh.keys);
    let points = sh.bucket_start[b1] - sh.bucket_start[b0];
    if sh.parallel && b1 - b0 > 1 && points > LEAF_POINTS {
        let bm = usize::midpoint(b0, b1);
        let mid_key = (bm << sh.shift).min(sh.keys);
        let (a, b) = out.split_at(
            mid_key - first_key,
            (sh.bucket_start[bm] - sh.bucket_start[b0]) as usize,
        );
        rayon::join(
            || sort_buckets(sh, b0, bm, a),
            || sort_buckets(sh, bm, b1, b),
        );
        return;
    }
    let base = sh.bucket_start[b0];
    for b in b0..b1 {
        let k0 = (b << sh.shift).min(sh.keys);
        let k1 = ((b + 1) << sh.shift).min(sh.keys);
        let (lo, hi) = (sh.bucket_start[b], sh.bucket_start[b + 1]);
        let pairs = &sh.pairs[lo as usize..hi as usize];
        let ends = &mut out.key_end[k0 - first_key..k1 - first_key];
        ends.fill(0);
        for pair in pairs {
            let k = (pair.load(Ordering::Relaxed) >> 32) as usize;
            ends[k - k0] += 1;
        }
        // Each key's start doubles as its write cursor, which the scatter moves to its end.
        let mut run = lo;
        for end in ends.iter_mut() {
            (*end, run) = (run, run + *end);
        }
        for pair in pairs {
            let pair = pair.load(Ordering::Relaxed);
            let (k, i) = ((pair >> 32) as usize, pair as u32);
            let slot = &mut ends[k - k0];
            let at = (*slot - base) as usize;
            sh.rank[i as usize].store(*slot, Ordering::Relaxed);
            *slot += 1;
            let (x, y) = (sh.pos)(i as usize);
            out.order[at] = i;
            out.sorted_x[at] = x;
            out.sorted_y[at] = y;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The stable sort by key, straightforwardly.
    fn reference(key: &[u32], keys: usize) -> (Vec<u32>, Vec<u32>) {
        let mut order: Vec<u32> = (0..key.len() as u32).collect();
        order.sort_by_key(|&i| key[i as usize]);
        let mut start = vec![0u32; keys + 1];
        for &k in key {
            start[k as usize + 1] += 1;
        }
        for k in 0..keys {
            start[k + 1] += start[k];
        }
        (start, order)
    }

    #[test]
    fn equals_a_stable_sort_for_any_number_of_parts() {
        let mut s = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = |m: u32| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 32) as u32 % m
        };
        // Sorts in ranges declined (points too far from their keys' order).
        let mut declined = 0;
        // Sizes on both sides of the one-level sort's limits, in an order that makes each sort
        // reuse the buffers of a larger or smaller one.
        for (n, keys) in [
            (0, 1),
            (1, 1),
            (5, 3000),
            (40_000, 1),
            (70_000, 5000),
            (70_001, 5000),
            (300_001, 5000),
            (300_001, (1 << 18) + 1),
            (3_001, 300),
            (40_001, (1 << 18) + 1),
            (3_000, 1 << 18),
            (90_000, 1 << 18),
            (60_000, 40_000),
            (65_536, (1 << 18) + 1),
        ] {
            // Half the points share key 0, the rest scattered; or the points nearly in their
            // keys' order (rising keys, each moved by up to one).
            let nearly = n % 2 == 1;
            let key: Vec<u32> = (0..n)
                .map(|i| {
                    if nearly {
                        let k = (i * keys / n.max(1)) as u32 + next(3);
                        k.saturating_sub(1).min(keys as u32 - 1)
                    } else if i % 2 == 0 {
                        0
                    } else {
                        next(keys as u32)
                    }
                })
                .collect();
            let xs: Vec<f32> = (0..n).map(|i| i as f32).collect();
            let ys: Vec<f32> = (0..n).map(|i| -(i as f32)).collect();
            let (start, order) = reference(&key, keys);
            let mut sort = CountingSort::default();
            // The dispatch, then the two levels and the rows whatever the size (the one level
            // on one thread is what the dispatch takes for one part).
            let ways = [1, 2, 3, 4, 7, 64, 100].map(|p| (0, p));
            for (way, parts) in ways
                .into_iter()
                .chain([1, 2, 5].map(|p| (1, p)))
                .chain([2, 3, 7].map(|p| (2, p)))
                .chain([1, 2, 3].map(|p| (3, p)))
            {
                // Outputs left from the way before would hide a way that writes too few.
                for r in &sort.rank.0 {
                    r.store(u32::MAX, Ordering::Relaxed);
                }
                sort.start.fill(u32::MAX);
                sort.order.fill(u32::MAX);
                sort.sorted_x.fill(f32::NAN);
                sort.sorted_y.fill(f32::NAN);
                let pos = |i: usize| (xs[i], ys[i]);
                if way != 0 {
                    // What the dispatch does before it picks a way.
                    sort.resize_outputs(n, (3, f32::MAX));
                }
                let input = Input {
                    key: &key,
                    keys,
                    pos,
                    parts,
                };
                match way {
                    0 => sort.sort(&key, keys, pos, parts, (3, f32::MAX)),
                    1 => sort.sort_levels(input),
                    2 => sort.sort_rows(input),
                    _ => {
                        sort.ranges_wait = 0;
                        let ranged = sort.sort_ranges(&input);
                        // Nearly ordered points are sorted in ranges; the others (from a few
                        // blocks on) are left to the other ways.
                        if nearly && n >= 64 * RANGE_BLOCK {
                            assert!(ranged, "{n} points in {parts} parts not in ranges");
                        }
                        declined += usize::from(!ranged);
                        if !ranged {
                            continue;
                        }
                    }
                }
                assert_eq!(sort.start, start, "{n} points, {parts} parts");
                assert_eq!(sort.order, order, "{n} points, {parts} parts");
                assert_eq!(sort.rank.0.len(), n);
                for (k, &i) in order.iter().enumerate() {
                    assert_eq!(sort.sorted_x[k], xs[i as usize]);
                    assert_eq!(sort.sorted_y[k], ys[i as usize]);
                    assert_eq!(sort.rank.0[i as usize].load(Ordering::Relaxed), k as u32);
                }
                assert_eq!(sort.sorted_x[n..], [f32::MAX; 3]);
                assert_eq!(sort.sorted_y[n..], [f32::MAX; 3]);
            }
        }
        assert!(declined > 0, "every sort in ranges taken");
    }
}
