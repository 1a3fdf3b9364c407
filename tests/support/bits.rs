//! The agents' state as bits, for the suites that compare runs bit for bit.

use throng::World;

/// Every agent's id with the bits of its position and velocity, in ascending id order (the same
/// for any storage order).
pub fn by_id(w: &World) -> Vec<(u32, [u32; 4])> {
    let a = w.agents();
    let mut v: Vec<_> = (0..a.len())
        .map(|i| {
            let (p, q) = (a.position(i), a.velocity(i));
            (a.id(i).0, [p.x, p.y, q.x, q.y].map(f32::to_bits))
        })
        .collect();
    v.sort_unstable();
    v
}
