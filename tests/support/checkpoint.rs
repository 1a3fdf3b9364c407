//! Helpers shared by the checkpoint suites of the library and of the command line.

use throng::World;

/// Everything the issue names for equality, in storage order: ids and the bits of positions,
/// velocities, orientations.
pub fn bits(w: &World) -> Vec<(u32, [u32; 5])> {
    let a = w.agents();
    (0..a.len())
        .map(|i| {
            (
                a.id(i).0,
                [
                    a.pos_x()[i].to_bits(),
                    a.pos_y()[i].to_bits(),
                    a.vel_x()[i].to_bits(),
                    a.vel_y()[i].to_bits(),
                    a.orientations()[i].to_bits(),
                ],
            )
        })
        .collect()
}

pub fn saved(w: &World) -> Vec<u8> {
    let mut bytes = Vec::new();
    w.save(&mut bytes).unwrap();
    bytes
}
