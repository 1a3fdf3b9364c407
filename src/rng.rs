//! A counter-based random stream keyed by (seed, agent id, frame, stream).
//!
//! Steering runs in parallel, so randomness must not come from a shared generator: the numbers an
//! agent draws in a frame are a pure function of the world seed, the agent's stable id, the frame
//! number and a small stream tag. The same seed therefore gives the same bits on any number of
//! threads and in any storage order. The mixer is SplitMix64's finaliser applied to a combined
//! key, which passes the usual avalanche tests and costs a few multiplications.

/// The stream tags of the crate's own draws, one per independent use, so that no two uses of
/// the same (seed, agent, frame) ever see the same numbers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum Stream {
    /// Per-frame behaviour randomness: wander, Vicsek noise.
    Steer = 0,
    /// The initial wander angle of a new agent (frame 0).
    Spawn = 1,
    /// A follower's fixed spread around its slot behind the leader (frame 0).
    Spread = 0x6772_0001,
    /// The perturbation of an ORCA agent's preferred velocity (per frame).
    Orca = 0x6f72_0001,
    /// A pedestrian's desired speed (frame 0, drawn once for the agent's life).
    DesiredSpeed = 0x7065_0001,
    /// A pedestrian's pre-movement time (frame 0, drawn once for the agent's life).
    Premovement = 0x7065_0002,
}

/// The random numbers of one agent in one frame.
#[derive(Clone, Copy, Debug)]
pub struct AgentRng {
    key: u64,
    counter: u64,
}

#[inline(always)]
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The part of every agent's key that depends on the world's seed and the frame only: computed
/// once per frame, it leaves [`agent_key`] one mix per agent (the same bits as [`AgentRng::new`]).
#[inline]
#[must_use]
pub(crate) fn frame_key(seed: u64, frame: u64) -> u64 {
    seed ^ mix(frame.wrapping_add(0x9e37_79b9_7f4a_7c15))
}

/// The key of agent `id`'s stream `stream` from the frame's [`frame_key`].
#[inline(always)]
#[must_use]
pub(crate) fn agent_key(frame_key: u64, id: u32, stream: u32) -> u64 {
    mix(frame_key ^ mix(u64::from(id) | (u64::from(stream) << 32)))
}

/// The `counter`-th (from 1) uniform number in `[0, 1)` of the stream with key `key`: what
/// [`AgentRng::unit`] returns on its `counter`-th draw, written for lanes (no state).
#[inline(always)]
#[must_use]
pub(crate) fn unit_at(key: u64, counter: u64) -> f32 {
    let bits = mix(key.wrapping_add(counter.wrapping_mul(0x9e37_79b9_7f4a_7c15)));
    // 24 bits: the same value through `i32`, whose conversion to float vector units have.
    ((bits >> 40) as i32) as f32 * (1.0 / (1u64 << 24) as f32)
}

impl AgentRng {
    /// The stream for agent `id` in frame `frame` of a world seeded with `seed`; `stream` separates
    /// independent uses within one frame (wander, spawn jitter, ...).
    #[inline]
    #[must_use]
    pub fn new(seed: u64, id: u32, frame: u64, stream: u32) -> Self {
        AgentRng {
            key: agent_key(frame_key(seed, frame), id, stream),
            counter: 0,
        }
    }

    /// The next 64 random bits.
    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        self.counter = self.counter.wrapping_add(1);
        mix(self
            .key
            .wrapping_add(self.counter.wrapping_mul(0x9e37_79b9_7f4a_7c15)))
    }

    /// A uniform number in `[0, 1)` with 24 random bits.
    #[inline]
    pub fn unit(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }

    /// A number in `(-1, 1)` peaked at 0: the difference of two uniforms (the "random binomial" of
    /// kinematic wander).
    #[inline]
    pub fn binomial(&mut self) -> f32 {
        self.unit() - self.unit()
    }

    /// A uniform number in `[-1, 1)`.
    #[inline]
    pub fn signed(&mut self) -> f32 {
        self.unit() * 2.0 - 1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a = AgentRng::new(7, 3, 10, 0).next_u64();
        assert_eq!(a, AgentRng::new(7, 3, 10, 0).next_u64());
        assert_ne!(a, AgentRng::new(7, 4, 10, 0).next_u64());
        assert_ne!(a, AgentRng::new(7, 3, 11, 0).next_u64());
        assert_ne!(a, AgentRng::new(8, 3, 10, 0).next_u64());
        assert_ne!(a, AgentRng::new(7, 3, 10, 1).next_u64());
    }

    #[test]
    fn lane_helpers_equal_the_stream() {
        for (seed, id, frame, stream) in [
            (7, 3, 10, 0),
            (u64::MAX, u32::MAX, 1 << 40, 5),
            (0, 0, 0, 0),
        ] {
            let mut r = AgentRng::new(seed, id, frame, stream);
            let key = agent_key(frame_key(seed, frame), id, stream);
            for counter in 1..5 {
                assert_eq!(r.unit().to_bits(), unit_at(key, counter).to_bits());
            }
        }
    }

    #[test]
    fn binomial_is_centred() {
        let mut sum = 0.0;
        let mut r = AgentRng::new(1, 1, 1, 0);
        for _ in 0..10_000 {
            let b = r.binomial();
            assert!(b > -1.0 && b < 1.0);
            sum += b;
        }
        assert!((sum / 10_000.0).abs() < 0.02);
    }
}
