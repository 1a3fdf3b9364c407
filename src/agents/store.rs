//! The agents' structure-of-arrays storage ([`Agents`]), what a new agent starts with
//! ([`AgentInit`]), and the plain columns a checkpoint keeps.
//!
//! Invariants: every column has one entry per agent, index `i` of each describing the same
//! agent; ids are handed out in order, never reused, and map back to indices both ways; every
//! change of the storage order (an addition, a removal, a reorder) gives the agents a new
//! [`AgentOrder`] stamp, so that copies built for the old order are refused.

use super::order::AgentOrder;
pub use crate::id::AgentId;
use glam::Vec2;
use serde::{Deserialize, Serialize};

/// The initial state of an agent to add.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AgentInit {
    /// Position in world units. Default: the origin.
    pub position: Vec2,
    /// Velocity in units per second (truncated to the agent's maximum speed when it is added).
    /// Default: zero.
    pub velocity: Vec2,
    /// Orientation in radians, counter-clockwise from +x. Default: 0.
    pub orientation: f32,
    /// Angular velocity in radians per second. Default: 0.
    pub rotation: f32,
    /// Index of the agent's group. Default: 0.
    pub group: usize,
    /// Overrides the group's maximum speed for this agent. Default: none.
    pub max_speed: Option<f32>,
    /// Overrides the group's radius for this agent. Default: none.
    pub radius: Option<f32>,
    /// The agent's desired walking speed under a pedestrian model, m/s ([`crate::ped`]).
    /// Default: drawn from the group's pedestrian distribution (Weidmann's when the group has
    /// no pedestrian model) by the agent's id and the world's seed.
    pub desired_speed: Option<f32>,
}

impl Default for AgentInit {
    fn default() -> Self {
        AgentInit {
            position: Vec2::ZERO,
            velocity: Vec2::ZERO,
            orientation: 0.0,
            rotation: 0.0,
            group: 0,
            max_speed: None,
            radius: None,
            desired_speed: None,
        }
    }
}

impl AgentInit {
    /// An agent of group `group` at `position`, at rest.
    #[must_use]
    pub fn at(position: Vec2, group: usize) -> Self {
        AgentInit {
            position,
            group,
            ..Self::default()
        }
    }
}

const NO_INDEX: u32 = u32::MAX;
/// Bit set in `overrides` when the agent has its own max speed.
pub(crate) const OVERRIDE_SPEED: u8 = 1;
/// Bit set in `overrides` when the agent has its own radius.
pub(crate) const OVERRIDE_RADIUS: u8 = 2;

/// Structure-of-arrays agent storage.
///
/// Index `i` of every buffer describes the same agent; [`Agents::id`] gives its stable id and
/// [`Agents::index_of`] maps back.
#[derive(Clone, Debug, Default)]
pub struct Agents {
    pub(crate) pos_x: Vec<f32>,
    pub(crate) pos_y: Vec<f32>,
    pub(crate) vel_x: Vec<f32>,
    pub(crate) vel_y: Vec<f32>,
    pub(crate) orientation: Vec<f32>,
    pub(crate) rotation: Vec<f32>,
    /// Wander-circle angle per agent (state of Reynolds' wander).
    pub(crate) wander: Vec<f32>,
    pub(crate) group: Vec<u32>,
    pub(crate) max_speed: Vec<f32>,
    pub(crate) radius: Vec<f32>,
    /// Desired walking speed (pedestrian models).
    pub(crate) desired_speed: Vec<f32>,
    pub(crate) overrides: Vec<u8>,
    /// How many agents have [`OVERRIDE_SPEED`] set. While it is zero, every agent's maximum
    /// speed is its group's (the world keeps the others' at their group's value), so a pass
    /// may take the group's value instead of reading the column through an order.
    own_speeds: usize,
    /// Whether some agent's rotation may be other than `+0.0` (when false, every one is: the
    /// integrator then neither reads nor writes them while no agent turns).
    turning: bool,
    /// Per-agent target point .
    pub(crate) target_x: Vec<f32>,
    pub(crate) target_y: Vec<f32>,
    pub(crate) ids: Vec<AgentId>,
    /// `index_of[id]` is the agent's storage index, or `NO_INDEX` once removed.
    index_of: Vec<u32>,
    scratch_f32: Vec<f32>,
    /// The second half of the columns' scratch ([`Agents::reorder`]).
    scratch_f32b: Vec<f32>,
    scratch_u32: Vec<u32>,
    scratch_u8: Vec<u8>,
    scratch_ids: Vec<AgentId>,
    /// The arrangement of the buffers, new after every change of order ([`AgentOrder`]).
    order: AgentOrder,
}

/// The state buffers of [`Agents`] as plain columns (a checkpoint's agents), in storage order.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub(crate) struct AgentColumns {
    pub(crate) pos_x: Vec<f32>,
    pub(crate) pos_y: Vec<f32>,
    pub(crate) vel_x: Vec<f32>,
    pub(crate) vel_y: Vec<f32>,
    pub(crate) orientation: Vec<f32>,
    pub(crate) rotation: Vec<f32>,
    pub(crate) wander: Vec<f32>,
    pub(crate) group: Vec<u32>,
    pub(crate) max_speed: Vec<f32>,
    pub(crate) radius: Vec<f32>,
    /// Absent from checkpoints written before pedestrian models: drawn again on load.
    #[serde(default)]
    pub(crate) desired_speed: Vec<f32>,
    pub(crate) overrides: Vec<u8>,
    pub(crate) target_x: Vec<f32>,
    pub(crate) target_y: Vec<f32>,
    pub(crate) ids: Vec<AgentId>,
}

/// Elements per parallel task of [`permute`] and [`uniform`]; shorter columns are gathered on
/// the calling thread (a fork per column cost more than the gather at a few thousand agents).
const PERMUTE_CHUNK: usize = 16 * 1024;

/// The bits of a column's value, for [`uniform`]: `+0.0` and `-0.0` differ, as they do to a
/// permutation.
trait Bits: Copy + Send + Sync {
    /// The value's bits.
    fn bits(self) -> u32;
}

impl Bits for f32 {
    fn bits(self) -> u32 {
        self.to_bits()
    }
}

impl Bits for u32 {
    fn bits(self) -> u32 {
        self
    }
}

impl Bits for u8 {
    fn bits(self) -> u32 {
        u32::from(self)
    }
}

/// Whether every value of `v` has the first one's bits (an empty column too): such a column is
/// every permutation of itself. Chunks are compared without a branch per value, in parallel for
/// long columns, and the first chunk that differs ends the scan.
fn uniform<T: Bits>(v: &[T]) -> bool {
    use rayon::prelude::*;
    let Some(&first) = v.first() else {
        return true;
    };
    let first = first.bits();
    let same = |c: &[T]| c.iter().fold(0, |acc, x| acc | (x.bits() ^ first)) == 0;
    if v.len() <= PERMUTE_CHUNK {
        same(v)
    } else {
        v.par_chunks(PERMUTE_CHUNK).all(same)
    }
}

/// [`permute`], unless the column is [`uniform`] (a column many worlds hold one value in: the
/// rotations of agents that do not turn, the groups and the flags of a world of one group, a
/// group's speed limit and radius), which it leaves as it is: the same values, without the
/// gather and the write of a column.
fn permute_column<T: Bits>(v: &mut Vec<T>, perm: &[u32], scratch: &mut Vec<T>) {
    if !uniform(v) {
        permute(v, perm, scratch);
    }
}

/// `v[k] = old v[perm[k]]`, gathered into `scratch` (in parallel chunks for long columns), which
/// then becomes `v`; no allocation once `scratch` has grown to size.
fn permute<T: Copy + Send + Sync>(v: &mut Vec<T>, perm: &[u32], scratch: &mut Vec<T>) {
    use rayon::prelude::*;
    const CHUNK: usize = PERMUTE_CHUNK;
    let src = &v[..];
    scratch.clear();
    if perm.len() <= CHUNK {
        scratch.extend(perm.iter().map(|&p| src[p as usize]));
    } else {
        scratch.resize(perm.len(), src[0]);
        scratch
            .par_chunks_mut(CHUNK)
            .zip(perm.par_chunks(CHUNK))
            .for_each(|(out, perm)| {
                for (o, &p) in out.iter_mut().zip(perm) {
                    *o = src[p as usize];
                }
            });
    }
    std::mem::swap(v, scratch);
}

/// Every `f32` column of the store, as an array of mutable borrows.
macro_rules! f32_columns {
    ($self:ident) => {
        [
            &mut $self.pos_x,
            &mut $self.pos_y,
            &mut $self.vel_x,
            &mut $self.vel_y,
            &mut $self.orientation,
            &mut $self.rotation,
            &mut $self.wander,
            &mut $self.max_speed,
            &mut $self.radius,
            &mut $self.desired_speed,
            &mut $self.target_x,
            &mut $self.target_y,
        ]
    };
}

macro_rules! for_each_buffer {
    ($self:ident, $f:ident) => {
        for v in f32_columns!($self) {
            $f(v);
        }
    };
}

/// From this many agents, [`Agents::reorder`] gathers two halves of the columns on two
/// threads, each half into a scratch column of its own (below, a fork costs more than it
/// saves).
const COLUMNS_APART: usize = 4096;

impl Agents {
    /// An empty store.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of live agents.
    #[must_use]
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// Whether there are no agents.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// Reserves room for `additional` more agents in every buffer.
    pub(crate) fn try_reserve(&mut self, additional: usize) -> crate::Result<()> {
        use crate::error::try_reserve;
        let mut result = Ok(());
        let mut f32s = |v: &mut Vec<f32>| {
            if result.is_ok() {
                result = try_reserve(v, additional, "agents");
            }
        };
        for_each_buffer!(self, f32s);
        result?;
        try_reserve(&mut self.group, additional, "agents")?;
        try_reserve(&mut self.overrides, additional, "agents")?;
        try_reserve(&mut self.ids, additional, "agents")?;
        try_reserve(&mut self.index_of, additional, "agents")
    }

    /// Appends an agent whose values were already validated and resolved; returns its new id.
    pub(crate) fn push(
        &mut self,
        init: &AgentInit,
        max_speed: f32,
        radius: f32,
        wander: f32,
        desired_speed: f32,
    ) -> AgentId {
        let id = AgentId(
            u32::try_from(self.index_of.len()).expect("more than 4 billion agents ever added"),
        );
        let index = u32::try_from(self.ids.len()).expect("more than 4 billion live agents");
        self.index_of.push(index);
        self.pos_x.push(init.position.x);
        self.pos_y.push(init.position.y);
        self.vel_x.push(init.velocity.x);
        self.vel_y.push(init.velocity.y);
        self.orientation.push(init.orientation);
        self.rotation.push(init.rotation);
        self.turning |= init.rotation.to_bits() != 0;
        self.wander.push(wander);
        self.group.push(init.group as u32);
        self.max_speed.push(max_speed);
        self.radius.push(radius);
        self.desired_speed.push(desired_speed);
        let mut flags = 0;
        if init.max_speed.is_some() {
            flags |= OVERRIDE_SPEED;
            self.own_speeds += 1;
        }
        if init.radius.is_some() {
            flags |= OVERRIDE_RADIUS;
        }
        self.overrides.push(flags);
        self.target_x.push(init.position.x);
        self.target_y.push(init.position.y);
        self.ids.push(id);
        self.order = AgentOrder::fresh();
        id
    }

    /// Removes an agent by storage index, moving the last agent into its place.
    pub(crate) fn swap_remove(&mut self, index: usize) -> AgentId {
        let id = self.ids[index];
        if self.overrides[index] & OVERRIDE_SPEED != 0 {
            self.own_speeds -= 1;
        }
        let swap = |v: &mut Vec<f32>| {
            v.swap_remove(index);
        };
        for_each_buffer!(self, swap);
        self.group.swap_remove(index);
        self.overrides.swap_remove(index);
        self.ids.swap_remove(index);
        self.index_of[id.0 as usize] = NO_INDEX;
        if index < self.ids.len() {
            let moved = self.ids[index];
            self.index_of[moved.0 as usize] = index as u32;
        }
        self.order = AgentOrder::fresh();
        id
    }

    /// The storage index of a live agent.
    #[must_use]
    pub fn index_of(&self, id: AgentId) -> Option<usize> {
        match self.index_of.get(id.0 as usize) {
            Some(&i) if i != NO_INDEX => Some(i as usize),
            _ => None,
        }
    }

    /// Whether `id` names a live agent.
    #[must_use]
    pub fn contains(&self, id: AgentId) -> bool {
        self.index_of(id).is_some()
    }

    /// The id of the agent at storage index `index`.
    ///
    /// # Panics
    /// When `index >= len()`.
    #[must_use]
    pub fn id(&self, index: usize) -> AgentId {
        self.ids[index]
    }

    /// Ids in storage order.
    #[must_use]
    pub fn ids(&self) -> &[AgentId] {
        &self.ids
    }

    /// Position x coordinates in storage order.
    #[must_use]
    pub fn pos_x(&self) -> &[f32] {
        &self.pos_x
    }

    /// Position y coordinates in storage order.
    #[must_use]
    pub fn pos_y(&self) -> &[f32] {
        &self.pos_y
    }

    /// Velocity x components in storage order.
    #[must_use]
    pub fn vel_x(&self) -> &[f32] {
        &self.vel_x
    }

    /// Velocity y components in storage order.
    #[must_use]
    pub fn vel_y(&self) -> &[f32] {
        &self.vel_y
    }

    /// Orientations (radians, in `[0, 2pi)`) in storage order.
    #[must_use]
    pub fn orientations(&self) -> &[f32] {
        &self.orientation
    }

    /// Angular velocities (radians per second) in storage order.
    #[must_use]
    pub fn rotations(&self) -> &[f32] {
        &self.rotation
    }

    /// Group indices in storage order.
    #[must_use]
    pub fn groups(&self) -> &[u32] {
        &self.group
    }

    /// Effective maximum speeds (group value or per-agent override) in storage order.
    #[must_use]
    pub fn max_speeds(&self) -> &[f32] {
        &self.max_speed
    }

    /// Desired walking speeds of the pedestrian models, m/s, in storage order.
    #[must_use]
    pub fn desired_speeds(&self) -> &[f32] {
        &self.desired_speed
    }

    /// Effective radii (group value or per-agent override) in storage order.
    #[must_use]
    pub fn radii(&self) -> &[f32] {
        &self.radius
    }

    /// Position of the agent at storage index `i`.
    #[inline]
    #[must_use]
    pub fn position(&self, i: usize) -> Vec2 {
        Vec2::new(self.pos_x[i], self.pos_y[i])
    }

    /// The own target point of the agent at storage index `i` (its position when it was added,
    /// until [`crate::World::set_target`] or a scenario's goal sets another).
    #[inline]
    #[must_use]
    pub fn target(&self, i: usize) -> Vec2 {
        Vec2::new(self.target_x[i], self.target_y[i])
    }

    /// Velocity of the agent at storage index `i`.
    #[inline]
    #[must_use]
    pub fn velocity(&self, i: usize) -> Vec2 {
        Vec2::new(self.vel_x[i], self.vel_y[i])
    }

    /// Reorders storage so that new index `k` holds the agent that was at `perm[k]`. Ids move with
    /// their agents. `perm` must be a permutation of `0..len()`.
    ///
    /// # Panics
    /// When `perm.len() != len()` (a debug assertion also checks it is a permutation).
    pub fn reorder(&mut self, perm: &[u32]) {
        assert_eq!(perm.len(), self.len(), "permutation length");
        self.order = AgentOrder::fresh();
        let mut columns = f32_columns!(self);
        // Seven of the twelve float columns beside the groups and flags, five beside the ids
        // and their index (a scatter by id, which costs about two columns): two halves of about
        // equal work (the measurement: docs/PERFORMANCE.md, "Tuning constants"). Uniform columns are left as they are (a scan
        // instead of a gather and a write); the threads then share the rest of the gathers'
        // chunks.
        let half = columns.len() / 2 + 1;
        let (first, second) = columns.split_at_mut(half);
        let (scratch, group, scratch_u32) = (
            &mut self.scratch_f32,
            &mut self.group,
            &mut self.scratch_u32,
        );
        let (overrides, scratch_u8) = (&mut self.overrides, &mut self.scratch_u8);
        let one = move || {
            for v in first {
                permute_column(v, perm, scratch);
            }
            permute_column(group, perm, scratch_u32);
            permute_column(overrides, perm, scratch_u8);
        };
        let (scratch, ids, scratch_ids) =
            (&mut self.scratch_f32b, &mut self.ids, &mut self.scratch_ids);
        let index_of = &mut self.index_of;
        let other = move || {
            for v in second {
                permute_column(v, perm, scratch);
            }
            permute(ids, perm, scratch_ids);
            for (k, id) in ids.iter().enumerate() {
                index_of[id.0 as usize] = k as u32;
            }
        };
        if perm.len() >= COLUMNS_APART {
            rayon::join(one, other);
        } else {
            one();
            other();
        }
        // A repeated index would repeat an id, whose first place the second overwrote (checked
        // here rather than before, where it would take a buffer of its own).
        debug_assert!(
            self.ids
                .iter()
                .enumerate()
                .all(|(k, id)| self.index_of[id.0 as usize] == k as u32),
            "not a permutation"
        );
    }

    /// A store holding `columns` in their order, with `ids_issued` ids handed out so far.
    /// The caller has validated every value; ids must be distinct and below `ids_issued`
    /// (checked here too, returning the first offending id).
    pub(crate) fn from_columns(
        columns: AgentColumns,
        ids_issued: usize,
    ) -> std::result::Result<Self, AgentId> {
        let mut index_of = vec![NO_INDEX; ids_issued];
        for (k, id) in columns.ids.iter().enumerate() {
            match index_of.get_mut(id.0 as usize) {
                Some(slot) if *slot == NO_INDEX => *slot = k as u32,
                _ => return Err(*id),
            }
        }
        let AgentColumns {
            pos_x,
            pos_y,
            vel_x,
            vel_y,
            orientation,
            rotation,
            wander,
            group,
            max_speed,
            radius,
            desired_speed,
            overrides,
            target_x,
            target_y,
            ids,
        } = columns;
        let turning = rotation.iter().any(|r| r.to_bits() != 0);
        Ok(Agents {
            pos_x,
            pos_y,
            vel_x,
            vel_y,
            orientation,
            rotation,
            wander,
            group,
            max_speed,
            radius,
            desired_speed,
            turning,
            own_speeds: overrides
                .iter()
                .filter(|&&o| o & OVERRIDE_SPEED != 0)
                .count(),
            overrides,
            target_x,
            target_y,
            ids,
            index_of,
            order: AgentOrder::fresh(),
            ..Agents::default()
        })
    }

    /// Gives agent `i` a maximum speed of its own.
    pub(crate) fn set_own_max_speed(&mut self, i: usize, max_speed: f32) {
        self.max_speed[i] = max_speed;
        if self.overrides[i] & OVERRIDE_SPEED == 0 {
            self.overrides[i] |= OVERRIDE_SPEED;
            self.own_speeds += 1;
        }
    }

    /// Whether every agent's rotation is `+0.0`.
    #[must_use]
    pub(crate) fn rotations_at_rest(&self) -> bool {
        !self.turning
    }

    /// Records whether some rotation the integrator wrote is other than `+0.0`.
    pub(crate) fn set_turning(&mut self, turning: bool) {
        self.turning = turning;
    }

    /// Whether no agent has a maximum speed of its own: every agent's is then its group's.
    #[must_use]
    pub(crate) fn speeds_of_groups(&self) -> bool {
        self.own_speeds == 0
    }

    /// Copies of the state buffers, in storage order.
    pub(crate) fn to_columns(&self) -> AgentColumns {
        AgentColumns {
            pos_x: self.pos_x.clone(),
            pos_y: self.pos_y.clone(),
            vel_x: self.vel_x.clone(),
            vel_y: self.vel_y.clone(),
            orientation: self.orientation.clone(),
            rotation: self.rotation.clone(),
            wander: self.wander.clone(),
            group: self.group.clone(),
            max_speed: self.max_speed.clone(),
            radius: self.radius.clone(),
            desired_speed: self.desired_speed.clone(),
            overrides: self.overrides.clone(),
            target_x: self.target_x.clone(),
            target_y: self.target_y.clone(),
            ids: self.ids.clone(),
        }
    }

    /// The arrangement of the agents in storage: a new value after every reorder, addition or
    /// removal. A copy of the agents' data in storage order is valid while it was made for the
    /// current order.
    #[must_use]
    pub fn order(&self) -> AgentOrder {
        self.order
    }

    /// Total number of ids ever handed out (live or removed).
    #[must_use]
    pub fn ids_issued(&self) -> usize {
        self.index_of.len()
    }

    /// Heap bytes held by the store (buffers' capacity, scratch included).
    #[must_use]
    pub fn heap_bytes(&self) -> usize {
        let f32s =
            self.pos_x.capacity() * 12 + self.scratch_f32.capacity() + self.scratch_f32b.capacity();
        f32s * 4
            + (self.group.capacity() + self.scratch_u32.capacity()) * 4
            + self.overrides.capacity()
            + self.scratch_u8.capacity()
            + (self.ids.capacity() + self.scratch_ids.capacity() + self.index_of.capacity()) * 4
    }
}

/// The largest of `v` and 0 (`f32::max`, so NaN is passed over), in eight interleaved lanes
/// rather than one chain of dependent comparisons. The maximum does not depend on the order,
/// so this is the sequential fold's value (up to the sign of a zero).
pub(crate) fn largest(v: &[f32]) -> f32 {
    let (blocks, rest) = v.as_chunks::<8>();
    let mut acc = [0.0_f32; 8];
    for b in blocks {
        for (a, &x) in acc.iter_mut().zip(b) {
            *a = a.max(x);
        }
    }
    acc.into_iter()
        .chain(rest.iter().copied())
        .fold(0.0, f32::max)
}

/// Whether `a[i] && b[i]` for some `i` (the slices' common length), in blocks that compile
/// to vector ORs, stopping at the first block with a hit.
pub(crate) fn any_both(a: &[bool], b: &[bool]) -> bool {
    a.chunks(256)
        .zip(b.chunks(256))
        .any(|(a, b)| a.iter().zip(b).fold(false, |acc, (&x, &y)| acc | (x & y)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn is_permutation(perm: &[u32]) -> bool {
        let mut seen = vec![false; perm.len()];
        perm.iter().all(|&p| {
            let p = p as usize;
            p < seen.len() && !std::mem::replace(&mut seen[p], true)
        })
    }

    /// The count of agents with a maximum speed of their own follows every push, removal,
    /// own speed given and store rebuilt from columns.
    #[test]
    fn own_speeds_are_counted_through_every_change() {
        let flags = |a: &Agents| {
            a.overrides
                .iter()
                .filter(|&&o| o & OVERRIDE_SPEED != 0)
                .count()
        };
        let mut a = Agents::new();
        for k in 0..12 {
            let init = AgentInit {
                max_speed: (k % 4 == 0).then_some(2.0),
                ..AgentInit::at(Vec2::new(k as f32, 0.0), 0)
            };
            a.push(&init, 1.0, 0.5, 0.0, 1.0);
        }
        assert_eq!((a.own_speeds, flags(&a)), (3, 3));
        a.set_own_max_speed(1, 3.0);
        a.set_own_max_speed(1, 2.5);
        a.set_own_max_speed(4, 3.0);
        assert_eq!((a.own_speeds, flags(&a)), (4, 4));
        for i in [0, 3, 1, 0] {
            a.swap_remove(i);
            assert_eq!(a.own_speeds, flags(&a));
        }
        a.reorder(&(0..a.len() as u32).rev().collect::<Vec<_>>());
        let rebuilt = Agents::from_columns(a.to_columns(), a.ids_issued()).unwrap();
        assert_eq!(rebuilt.own_speeds, flags(&a));
        assert_eq!(a.speeds_of_groups(), flags(&a) == 0);
        while a.own_speeds > 0 {
            let i = a.overrides.iter().position(|&o| o & OVERRIDE_SPEED != 0);
            a.swap_remove(i.unwrap());
        }
        assert!(a.speeds_of_groups() && !a.is_empty());
    }

    /// The lanes give the sequential folds' answers at every length, NaN and zeros included.
    #[test]
    fn largest_and_any_both_equal_their_sequential_forms() {
        let mut rng = crate::rng::AgentRng::new(17, 0, 0, 0);
        for n in (0..40_usize).chain([255, 256, 257, 1000, 4099]) {
            let v: Vec<f32> = (0..n)
                .map(|k| match k % 13 {
                    5 => f32::NAN,
                    7 => -0.0,
                    _ => rng.signed() * 100.0,
                })
                .collect();
            let want = v.iter().copied().fold(0.0_f32, f32::max);
            assert_eq!(largest(&v), want, "n {n}");
            for hit in [None, Some(0), Some(n / 2), Some(n.saturating_sub(1))] {
                let a: Vec<bool> = (0..n).map(|k| k % 3 == 0).collect();
                let b: Vec<bool> = (0..n).map(|k| k % 3 != 0 || Some(k) == hit).collect();
                let want = a.iter().zip(&b).any(|(&x, &y)| x && y);
                assert_eq!(any_both(&a, &b), want, "n {n} hit {hit:?}");
            }
        }
    }

    fn store(n: usize) -> Agents {
        let mut a = Agents::new();
        for i in 0..n {
            a.push(
                &AgentInit::at(Vec2::new(i as f32, 0.0), 0),
                1.0,
                1.0,
                0.0,
                1.34,
            );
        }
        a
    }

    /// Every column moves with its agent, short columns and long ones (gathered in chunks).
    #[test]
    fn reorder_permutes_every_column() {
        for n in [7usize, 5000, 40_000] {
            let f = |c: u32| {
                (0..n)
                    .map(|k| (k as u32 * 16 + c) as f32)
                    .collect::<Vec<f32>>()
            };
            let columns = AgentColumns {
                pos_x: f(0),
                pos_y: f(1),
                vel_x: f(2),
                vel_y: f(3),
                orientation: f(4),
                rotation: f(5),
                wander: f(6),
                group: (0..n as u32).map(|k| k * 3).collect(),
                max_speed: f(7),
                radius: f(8),
                desired_speed: f(9),
                overrides: (0..n).map(|k| k as u8).collect(),
                target_x: f(10),
                target_y: f(11),
                ids: (0..n as u32).map(|k| AgentId(k * 2)).collect(),
            };
            let mut a = Agents::from_columns(columns.clone(), 2 * n).unwrap();
            // A permutation that moves every agent far: k -> (k * 7919 + 13) mod n.
            let perm: Vec<u32> = (0..n).map(|k| ((k * 7919 + 13) % n) as u32).collect();
            assert!(is_permutation(&perm));
            a.reorder(&perm);
            let p = |v: &Vec<f32>| perm.iter().map(|&k| v[k as usize]).collect::<Vec<f32>>();
            let want = AgentColumns {
                pos_x: p(&columns.pos_x),
                pos_y: p(&columns.pos_y),
                vel_x: p(&columns.vel_x),
                vel_y: p(&columns.vel_y),
                orientation: p(&columns.orientation),
                rotation: p(&columns.rotation),
                wander: p(&columns.wander),
                group: perm.iter().map(|&k| columns.group[k as usize]).collect(),
                max_speed: p(&columns.max_speed),
                radius: p(&columns.radius),
                desired_speed: p(&columns.desired_speed),
                overrides: perm
                    .iter()
                    .map(|&k| columns.overrides[k as usize])
                    .collect(),
                target_x: p(&columns.target_x),
                target_y: p(&columns.target_y),
                ids: perm.iter().map(|&k| columns.ids[k as usize]).collect(),
            };
            assert!(a.to_columns() == want, "{n} agents");
            for (k, id) in want.ids.iter().enumerate() {
                assert_eq!(a.index_of(*id), Some(k));
            }
        }
    }

    /// Columns of one value are left as they are, and a column that differs in one value
    /// anywhere (the first chunk, the middle, the last; `-0.0` among `+0.0`) is still permuted:
    /// every column's bits equal the plain gather's.
    #[test]
    fn reorder_moves_nearly_uniform_columns_and_keeps_uniform_ones() {
        for n in [7usize, 5000, 40_000, 70_001] {
            let f = |c: u32| {
                (0..n)
                    .map(|k| (k as u32 * 16 + c) as f32)
                    .collect::<Vec<f32>>()
            };
            let one = |v: f32, odd: Option<(usize, f32)>| {
                let mut c = vec![v; n];
                if let Some((k, w)) = odd {
                    c[k] = w;
                }
                c
            };
            let columns = AgentColumns {
                pos_x: f(0),
                pos_y: f(1),
                vel_x: f(2),
                vel_y: f(3),
                orientation: one(1.5, None),
                rotation: one(0.0, Some((n - 1, -0.0))),
                wander: one(0.0, None),
                group: vec![0; n],
                max_speed: one(4.0, None),
                radius: one(0.4, Some((n / 2, 0.5))),
                desired_speed: one(1.34, Some((0, 1.2))),
                overrides: (0..n).map(|k| u8::from(k == n - 2)).collect(),
                target_x: one(f32::INFINITY, None),
                target_y: one(-0.0, None),
                ids: (0..n as u32).map(AgentId).collect(),
            };
            let mut a = Agents::from_columns(columns.clone(), n).unwrap();
            let perm: Vec<u32> = (0..n).map(|k| ((k * 7919 + 13) % n) as u32).collect();
            assert!(is_permutation(&perm));
            a.reorder(&perm);
            let got = a.to_columns();
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<u32>>();
            let gathered = |v: &[f32]| {
                perm.iter()
                    .map(|&k| v[k as usize].to_bits())
                    .collect::<Vec<u32>>()
            };
            for (name, was, now) in [
                ("pos_x", &columns.pos_x, &got.pos_x),
                ("pos_y", &columns.pos_y, &got.pos_y),
                ("vel_x", &columns.vel_x, &got.vel_x),
                ("vel_y", &columns.vel_y, &got.vel_y),
                ("orientation", &columns.orientation, &got.orientation),
                ("rotation", &columns.rotation, &got.rotation),
                ("wander", &columns.wander, &got.wander),
                ("max_speed", &columns.max_speed, &got.max_speed),
                ("radius", &columns.radius, &got.radius),
                ("desired_speed", &columns.desired_speed, &got.desired_speed),
                ("target_x", &columns.target_x, &got.target_x),
                ("target_y", &columns.target_y, &got.target_y),
            ] {
                assert_eq!(bits(now), gathered(was), "{name}, {n} agents");
            }
            let moved = |v: &[u8]| perm.iter().map(|&k| v[k as usize]).collect::<Vec<u8>>();
            assert_eq!(got.overrides, moved(&columns.overrides), "{n} agents");
            assert_eq!(got.group, columns.group);
            for (k, &p) in perm.iter().enumerate() {
                assert_eq!(got.ids[k], AgentId(p));
                assert_eq!(a.index_of(AgentId(p)), Some(k));
            }
        }
    }

    #[test]
    fn ids_survive_removal_and_reorder() {
        let mut a = store(5);
        let removed = a.swap_remove(1);
        assert_eq!(removed, AgentId(1));
        assert!(!a.contains(AgentId(1)));
        for id in [0, 2, 3, 4] {
            let i = a.index_of(AgentId(id)).unwrap();
            assert_eq!(a.position(i).x, id as f32);
        }
        a.reorder(&[3, 2, 1, 0]);
        for id in [0, 2, 3, 4] {
            let i = a.index_of(AgentId(id)).unwrap();
            assert_eq!(a.position(i).x, id as f32);
            assert_eq!(a.id(i), AgentId(id));
        }
        let new = a.push(&AgentInit::default(), 1.0, 1.0, 0.0, 1.34);
        assert_eq!(new, AgentId(5), "ids are never reused");
    }
}
