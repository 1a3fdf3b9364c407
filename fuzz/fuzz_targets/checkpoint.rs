//! Fuzzes the checkpoint loader. The first byte chooses what the rest is: a whole file (`0`),
//! which exercises the header and checksum checks, or a payload (anything else) that gets a
//! valid header and checksum, so that mutations reach the decoder and the world's validation.
//! Loading must return an error or a world whose agent buffers are finite and that steps
//! without a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use throng::World;
use throng::checkpoint::{FORMAT_VERSION, MAGIC};

fn sealed(payload: &[u8]) -> Vec<u8> {
    let mut b = Vec::with_capacity(24 + payload.len());
    b.extend_from_slice(&MAGIC);
    b.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    b.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    let mut c = crc32fast::Hasher::new();
    c.update(&b[..20]);
    c.update(payload);
    b.extend_from_slice(&c.finalize().to_le_bytes());
    b.extend_from_slice(payload);
    b
}

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let bytes = if mode == 0 {
        rest.to_vec()
    } else {
        sealed(rest)
    };
    if let Ok(mut w) = World::load(&bytes[..]) {
        let a = w.agents();
        for s in [a.pos_x(), a.pos_y(), a.vel_x(), a.vel_y(), a.orientations()] {
            assert!(
                s.iter().all(|x| x.is_finite()),
                "a loaded buffer holds a non-finite value"
            );
        }
        for _ in 0..2 {
            let _ = w.step(0.05);
        }
    }
});
