//! Fuzzes the ASCII map parser: any bytes either give a typed error or a grid whose size,
//! goals and spawns agree with the text, and which prints back to a map that parses to the
//! same grid.
#![no_main]

use libfuzzer_sys::fuzz_target;
use throng::field::OccupancyGrid;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(map) = OccupancyGrid::parse_ascii(text, "fuzz.map") else {
        return;
    };
    let g = &map.grid;
    assert!(g.width() > 0 && g.height() > 0);
    assert!(map.goals.iter().chain(&map.spawns).all(|&(x, y)| g.is_free(x, y)));
    let again = OccupancyGrid::parse_ascii(&g.to_ascii(&map.goals, &map.spawns), "again")
        .expect("a printed map parses");
    assert_eq!(&again.grid, g);
    assert_eq!(again.goals.len(), map.goals.len());
});
