//! Fuzzes the scenario parser and builder: any bytes either give a typed error or a world
//! whose first steps keep every agent buffer finite. Worlds are built within 64 MiB, so a
//! large but valid scenario is refused by the memory estimate instead of exhausting memory.
#![no_main]

use libfuzzer_sys::fuzz_target;
use throng::scenario::Scenario;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(s) = Scenario::from_toml(text, "fuzz.toml") else {
        return;
    };
    // Keep a case short: a few steps of at most a few thousand agents.
    if s.agent_count() > 5_000 {
        return;
    }
    let Ok(mut world) = s.build_within(Some(64 << 20)) else {
        return;
    };
    for _ in 0..3 {
        if world.step(s.dt).is_err() {
            return;
        }
        let a = world.agents();
        for v in [a.pos_x(), a.pos_y(), a.vel_x(), a.vel_y(), a.orientations()] {
            assert!(v.iter().all(|x| x.is_finite()), "a non-finite agent value");
        }
    }
});
