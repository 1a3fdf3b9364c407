//! The neighbour index: every agent-agent interaction asks it "who is near this point?".
//!
//! [`NeighbourIndex`] is the contract; [`SpatialIndex`] dispatches it over three backends once per
//! call (an enum, not a `dyn` call per agent):
//!
//! * [`GridIndex`]: a uniform grid of cell lists rebuilt by a counting sort in O(N), in parallel for
//!   large N. The default, and the fastest at crowd densities.
//! * [`KdTreeIndex`]: a k-d tree ([kiddo]), for very uneven densities.
//! * [`BruteIndex`]: the O(N^2) reference every other backend is tested against.
//!
//! Beside them, [`HashGrid`] hashes cells of the query's size into a table of about `2 N`
//! buckets for worlds far larger than the query (ORCA's candidates in a sparse open world);
//! it hands out runs of candidates and is tested against brute force in the same way.
//!
//! # Invariants
//!
//! * The index is rebuilt from positions once per step ([`NeighbourIndex::rebuild`]); queries
//!   read that snapshot only.
//! * The offset reported for a neighbour is always [`Bounds::offset`]`(query point, neighbour)`:
//!   the minimum image on a torus. Its squared length is [`Vec2::length_squared`] of that offset,
//!   and a point is a neighbour exactly when that value is `<= r * r`. Backends may gather
//!   candidates with a slightly larger radius but apply this one filter, so every backend returns
//!   the same set with bit-identical offsets.
//! * Radius queries list neighbours in ascending index order, whatever the backend; so sums over
//!   them are bit-identical across backends and thread counts. k-nearest queries sort by
//!   `(dist_sq, index)`.
//! * Each point is reported at most once, even when the query radius exceeds the world on a torus.
//!
//! Positions must be finite; on a torus or in a walled world they should lie in the world (as
//! [`Bounds::wrap`] leaves them). Points slightly outside a walled world are still found.
//!
//! [kiddo]: https://docs.rs/kiddo

use std::fmt;
use std::str::FromStr;

use glam::Vec2;
use serde::{Deserialize, Serialize};

use crate::bounds::Bounds;
use crate::error::Error;

mod brute;
mod candidates;
mod grid;
mod hash;
mod kdtree;
mod sort;

pub use brute::BruteIndex;
pub(crate) use candidates::CellCandidates;
pub use grid::GridIndex;
pub(crate) use grid::SORTED_PAD;
pub(crate) use hash::farthest_move;
pub use hash::{HashGrid, Runs};
pub use kdtree::KdTreeIndex;

/// One neighbour found by a query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Neighbour {
    /// The neighbour's index in the position slices given to [`NeighbourIndex::rebuild`].
    pub index: u32,
    /// `bounds.offset(query_point, neighbour_position)`: from the query point to the neighbour,
    /// the minimum image on a torus.
    pub offset: Vec2,
    /// `offset.length_squared()`.
    pub dist_sq: f32,
}

/// The contract every neighbour-index backend keeps.
///
/// See the [module docs](self) for the ordering and metric guarantees.
pub trait NeighbourIndex {
    /// Rebuilds the index from the positions `(xs[i], ys[i])`.
    ///
    /// `max_radius` is the largest radius the caller intends to query with; backends may use it
    /// to size their structure (the grid's cells), but every query radius stays correct.
    ///
    /// # Panics
    /// If `xs` and `ys` differ in length, or hold more than `u32::MAX` points.
    fn rebuild(&mut self, xs: &[f32], ys: &[f32], bounds: Bounds, max_radius: f32);

    /// Every `j != i` with `dist_sq <= r * r` from point `i`, written into `out` (cleared first) in
    /// ascending index order.
    ///
    /// # Panics
    /// If `i` is not an indexed point.
    fn neighbours_of(&self, i: usize, r: f32, out: &mut Vec<Neighbour>);

    /// Every `j` with `dist_sq <= r * r` from the point `p`, written into `out` (cleared first) in
    /// ascending index order.
    ///
    /// On a torus `p` must lie in the world (wrap it with [`Bounds::wrap`] first).
    fn neighbours_at(&self, p: Vec2, r: f32, out: &mut Vec<Neighbour>);

    /// Up to `k` nearest points within `r` of `p`, leaving out `exclude` if given, written into
    /// `out` (cleared first) sorted by `(dist_sq, index)`: the same as sorting the result of
    /// [`neighbours_at`](Self::neighbours_at) that way and keeping the first `k` (a cap in the
    /// manner of RVO2's `maxNeighbors`).
    fn k_nearest_at(
        &self,
        p: Vec2,
        k: usize,
        r: f32,
        exclude: Option<usize>,
        out: &mut Vec<Neighbour>,
    ) {
        self.neighbours_at(p, r, out);
        keep_k_nearest(out, k, exclude);
    }

    /// How many points the index holds.
    fn len(&self) -> usize;

    /// Whether the index holds no points.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Which backend a [`SpatialIndex`] uses; named `grid`, `kdtree` or `brute` in scenario files
/// and on the command line.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum IndexKind {
    /// A uniform grid rebuilt by counting sort ([`GridIndex`]). The default.
    #[default]
    Grid,
    /// A k-d tree ([`KdTreeIndex`]).
    #[serde(alias = "kd_tree")]
    KdTree,
    /// Every pair checked ([`BruteIndex`]): the reference, O(N^2).
    Brute,
}

impl IndexKind {
    /// Every kind, in the order of the documentation.
    pub const ALL: [IndexKind; 3] = [IndexKind::Grid, IndexKind::KdTree, IndexKind::Brute];

    /// The kind's name: `grid`, `kdtree` or `brute`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            IndexKind::Grid => "grid",
            IndexKind::KdTree => "kdtree",
            IndexKind::Brute => "brute",
        }
    }
}

impl fmt::Display for IndexKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for IndexKind {
    type Err = Error;

    /// Parses `grid`, `kdtree` (also `kd_tree`, `kd-tree`) or `brute`, ignoring ASCII case.
    fn from_str(s: &str) -> Result<Self, Error> {
        match s.trim().to_ascii_lowercase().as_str() {
            "grid" => Ok(IndexKind::Grid),
            "kdtree" | "kd_tree" | "kd-tree" => Ok(IndexKind::KdTree),
            "brute" => Ok(IndexKind::Brute),
            _ => Err(Error::Invalid {
                name: "spatial index".to_string(),
                reason: format!("unknown kind {s:?}; expected grid, kdtree or brute"),
            }),
        }
    }
}

/// A neighbour index of any kind: enum dispatch over the backends.
#[derive(Clone, Debug)]
pub enum SpatialIndex {
    /// A uniform grid.
    Grid(GridIndex),
    /// A k-d tree.
    KdTree(KdTreeIndex),
    /// Brute force.
    Brute(BruteIndex),
}

impl Default for SpatialIndex {
    fn default() -> Self {
        SpatialIndex::new(IndexKind::default())
    }
}

impl SpatialIndex {
    /// An empty index of the given kind.
    ///
    /// # Examples
    /// ```
    /// use glam::Vec2;
    /// use throng::{Bounds, IndexKind, NeighbourIndex, SpatialIndex};
    ///
    /// let mut index = SpatialIndex::new("grid".parse::<IndexKind>()?);
    /// let xs = [0.5, 9.5, 5.0];
    /// let ys = [1.0, 1.0, 5.0];
    /// index.rebuild(&xs, &ys, Bounds::torus(10.0, 10.0)?, 2.0);
    /// let mut out = Vec::new();
    /// index.neighbours_of(0, 2.0, &mut out);
    /// assert_eq!(out.len(), 1);
    /// assert_eq!(out[0].index, 1);
    /// assert_eq!(out[0].offset, Vec2::new(-1.0, 0.0)); // across the seam
    /// # Ok::<(), throng::Error>(())
    /// ```
    #[must_use]
    pub fn new(kind: IndexKind) -> Self {
        match kind {
            IndexKind::Grid => SpatialIndex::Grid(GridIndex::default()),
            IndexKind::KdTree => SpatialIndex::KdTree(KdTreeIndex::default()),
            IndexKind::Brute => SpatialIndex::Brute(BruteIndex::default()),
        }
    }

    /// Which backend this is.
    #[must_use]
    pub fn kind(&self) -> IndexKind {
        match self {
            SpatialIndex::Grid(_) => IndexKind::Grid,
            SpatialIndex::KdTree(_) => IndexKind::KdTree,
            SpatialIndex::Brute(_) => IndexKind::Brute,
        }
    }

    /// The grid, when this is one (for kernels that read its cells directly).
    #[must_use]
    pub fn as_grid(&self) -> Option<&GridIndex> {
        match self {
            SpatialIndex::Grid(g) => Some(g),
            _ => None,
        }
    }
}

macro_rules! dispatch {
    ($self:ident, $x:ident => $e:expr) => {
        match $self {
            SpatialIndex::Grid($x) => $e,
            SpatialIndex::KdTree($x) => $e,
            SpatialIndex::Brute($x) => $e,
        }
    };
}

impl NeighbourIndex for SpatialIndex {
    fn rebuild(&mut self, xs: &[f32], ys: &[f32], bounds: Bounds, max_radius: f32) {
        dispatch!(self, ix => ix.rebuild(xs, ys, bounds, max_radius));
    }

    fn neighbours_of(&self, i: usize, r: f32, out: &mut Vec<Neighbour>) {
        dispatch!(self, ix => ix.neighbours_of(i, r, out));
    }

    fn neighbours_at(&self, p: Vec2, r: f32, out: &mut Vec<Neighbour>) {
        dispatch!(self, ix => ix.neighbours_at(p, r, out));
    }

    fn k_nearest_at(
        &self,
        p: Vec2,
        k: usize,
        r: f32,
        exclude: Option<usize>,
        out: &mut Vec<Neighbour>,
    ) {
        dispatch!(self, ix => ix.k_nearest_at(p, k, r, exclude, out));
    }

    fn len(&self) -> usize {
        dispatch!(self, ix => ix.len())
    }
}

impl From<GridIndex> for SpatialIndex {
    fn from(g: GridIndex) -> Self {
        SpatialIndex::Grid(g)
    }
}

impl From<KdTreeIndex> for SpatialIndex {
    fn from(t: KdTreeIndex) -> Self {
        SpatialIndex::KdTree(t)
    }
}

impl From<BruteIndex> for SpatialIndex {
    fn from(b: BruteIndex) -> Self {
        SpatialIndex::Brute(b)
    }
}

/// Relative and absolute slack by which candidate gathering widens a radius, so that rounding in
/// cell or tree arithmetic never loses a point the exact filter accepts.
const SLACK: f32 = 1e-5;

/// The radius to gather candidates with: `|r|` widened by [`SLACK`] relative to `r` and to
/// `scale`, the magnitude of the coordinates involved.
#[inline]
fn gather_radius(r: f32, scale: f32) -> f32 {
    let r = r.abs();
    r + SLACK * (r + scale) + f32::MIN_POSITIVE
}

/// The exact test every backend applies: the neighbour record for `q` seen from `p`, if
/// `dist_sq <= r_sq`.
#[inline]
fn exact(bounds: &Bounds, p: Vec2, q: Vec2, index: u32, r_sq: f32) -> Option<Neighbour> {
    let offset = bounds.offset(p, q);
    let dist_sq = offset.length_squared();
    (dist_sq <= r_sq).then_some(Neighbour {
        index,
        offset,
        dist_sq,
    })
}

/// Index as `u32`, the type neighbour records carry.
#[inline]
fn to_u32(n: usize) -> u32 {
    u32::try_from(n).expect("a neighbour index holds at most u32::MAX points")
}

/// Drops `exclude`, keeps the `k` smallest by `(dist_sq, index)`, and sorts them so.
pub(crate) fn keep_k_nearest(out: &mut Vec<Neighbour>, k: usize, exclude: Option<usize>) {
    if let Some(x) = exclude {
        out.retain(|n| n.index as usize != x);
    }
    let by_distance =
        |a: &Neighbour, b: &Neighbour| a.dist_sq.total_cmp(&b.dist_sq).then(a.index.cmp(&b.index));
    if k == 0 {
        out.clear();
        return;
    }
    if out.len() > k {
        out.select_nth_unstable_by(k - 1, by_distance);
        out.truncate(k);
    }
    out.sort_unstable_by(by_distance);
}

/// A magnitude for the coordinates of a point set: the largest absolute coordinate, and the
/// world's sides when it has them.
fn coordinate_scale(xs: &[f32], ys: &[f32], bounds: &Bounds) -> f32 {
    let m = xs.iter().chain(ys).fold(0.0_f32, |m, &v| m.max(v.abs()));
    bounds.size().map_or(m, |s| m.max(s.x).max(s.y))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kind_names_round_trip() {
        for kind in IndexKind::ALL {
            assert_eq!(kind.to_string().parse::<IndexKind>().unwrap(), kind);
            let toml = format!("k = \"{kind}\"");
            #[derive(Deserialize)]
            struct K {
                k: IndexKind,
            }
            assert_eq!(toml::from_str::<K>(&toml).unwrap().k, kind);
        }
        assert_eq!(IndexKind::default(), IndexKind::Grid);
        assert_eq!("KD-Tree".parse::<IndexKind>().unwrap(), IndexKind::KdTree);
        assert!(matches!(
            "octree".parse::<IndexKind>(),
            Err(Error::Invalid { .. })
        ));
    }

    #[test]
    fn k_nearest_breaks_ties_by_index() {
        let n = |index, dist_sq| Neighbour {
            index,
            offset: Vec2::ZERO,
            dist_sq,
        };
        let mut v = vec![n(5, 1.0), n(2, 1.0), n(7, 0.5), n(1, 3.0), n(3, 1.0)];
        keep_k_nearest(&mut v, 3, Some(7));
        assert_eq!(v.iter().map(|n| n.index).collect::<Vec<_>>(), [2, 3, 5]);
        keep_k_nearest(&mut v, 0, None);
        assert!(v.is_empty());
    }
}
