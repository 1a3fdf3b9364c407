//! What a group asks of the fused neighbour traversal: the behaviour slots (separation,
//! alignment, cohesion), the [`NeighbourSpec`] a plan compiles from its profile, and its
//! flattened form ([`FlatSpec`]) that the per-agent grid kernel and the cell batch's kernels
//! both read, with the querying agent's numbers ([`QueryAgent`]), so that the two queries share
//! their fields and flatten a spec in one place; with the `oracle` feature, the
//! record of a spec's sums for the neighbour oracle (so that `oracle` names nothing of `steer`).
//!
//! Invariant: slot `b` of every array is behaviour [`SEP`], [`ALI`] or [`COH`].

/// Behaviour slots of the fused neighbour pass: separation, alignment, cohesion.
pub(crate) const SEP: usize = 0;
pub(crate) const ALI: usize = 1;
pub(crate) const COH: usize = 2;

/// What one group asks of the fused neighbour traversal.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct NeighbourSpec {
    /// Whether the group needs neighbours at all.
    pub active: bool,
    /// The largest radius of the group's neighbour behaviours.
    pub query_r: f32,
    /// Which of separation, alignment, cohesion the group uses.
    pub on: [bool; 3],
    /// Squared radii.
    pub r_sq: [f32; 3],
    /// View cosines (-1: all round).
    pub cos: [f32; 3],
    /// Own group only.
    pub same: [bool; 3],
    /// Repulsion `(strength, exponent, radius^2)`.
    pub repel: Option<(f32, f32, f32)>,
    /// The Vicsek neighbourhood, squared radius (every group, the agent itself included).
    pub vicsek_r_sq: Option<f32>,
    /// Neighbour cap.
    pub cap: Option<u32>,
}

impl NeighbourSpec {
    /// Whether the cell batch can evaluate this group's Vicsek sums (no repulsion, no cap).
    pub(crate) fn batch_ok(&self) -> bool {
        self.repel.is_none() && self.cap.is_none()
    }

    /// Whether the SIMD grid kernels can serve this group (they do not do repulsion, Vicsek
    /// sums or caps).
    pub(crate) fn kernel_ok(&self) -> bool {
        self.repel.is_none() && self.cap.is_none() && self.vicsek_r_sq.is_none()
    }

    /// Whether the cell batch can sum this group's neighbours for the group's per-agent or lane
    /// evaluation: the flocking sums the lane kernels serve, or repulsion alone (no flocking
    /// term, no Vicsek sum, no cap) with a whole exponent from 0 to 4, which the batch's
    /// repulsion kernel sums; any other repulsion is summed by the scalar traversal.
    pub(crate) fn summed_ok(&self) -> bool {
        match self.repel {
            None => self.kernel_ok(),
            Some((_, exponent, _)) => {
                self.cap.is_none()
                    && self.vicsek_r_sq.is_none()
                    && !self.on.iter().any(|&on| on)
                    && crate::gravity::whole_exponent(exponent).is_some()
            }
        }
    }
}

/// The querying agent's own numbers as the lane kernels read them: position, unit heading
/// (zeros where no view cone reads it) and group, as floats.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct QueryAgent {
    pub x: f32,
    pub y: f32,
    pub hx: f32,
    pub hy: f32,
    pub g: f32,
}

/// A [`NeighbourSpec`] flattened to the plain numbers the lane kernels compare against, for
/// the per-agent grid kernel ([`super::neighbours`]) and the cell batch's kernels
/// ([`super::cells`]) alike.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FlatSpec {
    /// The query radius, squared.
    pub q_sq: f32,
    /// Squared radius per slot (-1 when the slot is off).
    pub r_sq: [f32; 3],
    /// View cosine per slot (-1: all round).
    pub cos: [f32; 3],
    /// Per slot: any group counts (the slot is not limited to the agent's own group, or the
    /// world has one group).
    pub any_group: [bool; 3],
}

impl NeighbourSpec {
    /// This spec flattened for the kernels; `one_group` when the world has a single group.
    #[inline]
    pub(crate) fn flat(&self, one_group: bool) -> FlatSpec {
        FlatSpec {
            q_sq: self.query_r * self.query_r,
            r_sq: [0, 1, 2].map(|b| if self.on[b] { self.r_sq[b] } else { -1.0 }),
            cos: self.cos,
            any_group: self.same.map(|s| !s || one_group),
        }
    }
}

#[cfg(feature = "oracle")]
impl NeighbourSpec {
    /// The oracle's record of `sums` used by `model` for agent `id` at `position` under this
    /// spec, in radii and cosines.
    pub(crate) fn summed(
        &self,
        model: &'static str,
        (agent, position): (u32, glam::Vec2),
        sums: crate::steering::NeighbourSums,
    ) -> crate::oracle::Summed {
        crate::oracle::Summed {
            model,
            agent,
            position,
            query_radius: self.query_r,
            hoods: [0, 1, 2].map(|b| {
                self.on[b].then(|| crate::oracle::Hood {
                    radius: self.r_sq[b].sqrt(),
                    view_cos: self.cos[b],
                    same_group: self.same[b],
                })
            }),
            repulsion: self.repel.map(|(s, e, r_sq)| (s, e, r_sq.sqrt())),
            vicsek_radius: self.vicsek_r_sq.map(f32::sqrt),
            cap: self.cap,
            sums,
        }
    }
}
