//! `formation`, `leader` and `antigravity` scale with `--agents` as `flock` does: by more
//! squads in a larger world at the same density (`world.scale = "tiles"`), not by one denser
//! crowd; and a formation of 100,000 agents sets up in seconds.

use std::time::{Duration, Instant};

use throng::scenario::{self, Scenario};

/// Mean number of other agents within `r`, over a sample of agents (brute force).
fn mean_neighbours(w: &throng::World, r: f32) -> f64 {
    let a = w.agents();
    let n = a.len();
    let step = (n / 400).max(1);
    let (mut sum, mut count) = (0usize, 0usize);
    for i in (0..n).step_by(step) {
        let p = a.position(i);
        sum += (0..n)
            .filter(|&j| j != i && w.bounds().distance_sq(p, a.position(j)) < r * r)
            .count();
        count += 1;
    }
    sum as f64 / count as f64
}

fn built(name: &str, agents: usize) -> throng::World {
    scenario::builtin(name)
        .unwrap()
        .with_agents(agents)
        .unwrap()
        .build()
        .unwrap()
}

#[test]
fn leader_and_antigravity_keep_their_density_at_ten_times_the_agents() {
    for (name, base) in [("leader", 41 * 4), ("antigravity", 1000)] {
        let small = built(name, base);
        let large = built(name, base * 10);
        assert_eq!(large.len(), base * 10);
        let (a, b) = (mean_neighbours(&small, 5.0), mean_neighbours(&large, 5.0));
        assert!(
            b < a * 1.5 + 1.0,
            "{name}: {a:.1} neighbours at {base}, {b:.1} at ten times that"
        );
    }
}

#[test]
fn formation_grows_by_squads_not_by_squad_size() {
    let file = scenario::builtin("formation").unwrap();
    let largest = file.groups.iter().map(|g| g.count_of()).max().unwrap();
    let s = file.with_agents(5_700).unwrap();
    assert_eq!(s.agent_count(), 5_700);
    assert!(
        s.formations.len() >= 400,
        "{} formations",
        s.formations.len()
    );
    let w = s.build().unwrap();
    let biggest = w
        .formations()
        .iter()
        .map(|f| f.members().len())
        .max()
        .unwrap();
    assert!(
        biggest <= largest + 1,
        "a squad of {biggest} (the file's largest: {largest})"
    );
}

#[test]
fn a_hundred_thousand_agent_formation_sets_up_in_seconds() {
    let t = Instant::now();
    let mut w = built("formation", 100_000);
    w.step(1.0 / 30.0).unwrap();
    assert_eq!(w.len(), 100_000);
    assert!(
        t.elapsed() < Duration::from_secs(20),
        "took {:?}",
        t.elapsed()
    );
}

#[test]
fn tiles_are_refused_without_a_size() {
    let text = "[world]\nkind = \"torus\"\ndensity = { neighbours = 5, radius = 2 }\nscale = \"tiles\"\n[[groups]]\ncount = 4\n";
    let s = Scenario::from_toml(text, "t.toml").unwrap();
    assert!(s.with_agents(40).is_err());
    // At or below the file's own count it scales by counts.
    let s = Scenario::from_toml(text, "t.toml").unwrap();
    assert_eq!(s.with_agents(3).unwrap().agent_count(), 3);
}

#[test]
fn a_field_tiles_only_as_an_ascii_map_that_covers_the_tile() {
    let with = |size: &str, map: &str, channels: &str| {
        format!(
            "[world]\nkind = \"bounded\"\nsize = {size}\nscale = \"tiles\"\n[field]\nmap = {map}\nchannels = {channels}\n[[groups]]\ncount = 4\nspawn = {{ kind = \"free_cells\" }}\n"
        )
    };
    let ascii = "{ ascii = \"..G\\n.#.\\n\" }";
    let tiled = |text: String| {
        Scenario::from_toml(&text, "t.toml")
            .unwrap()
            .with_agents(12)
    };
    let s = tiled(with("[3, 2]", ascii, "[\"map\", { cells = [[0, 0]] }]")).unwrap();
    let w = s.build().unwrap();
    let grid = w.field(0).unwrap().grid();
    // Three copies on 2 x 2 tiles: the fourth tile is walls.
    assert_eq!((grid.width(), grid.height()), (6, 4));
    assert_eq!(grid.free_count(), 3 * 5);
    assert_eq!(
        w.field(0).unwrap().goals(1).unwrap(),
        &[(0, 0), (3, 0), (0, 2)]
    );
    for (size, map, channels) in [
        ("[4, 2]", ascii, "[\"map\"]"),
        (
            "[3, 2]",
            "{ caves = { width = 3, height = 2, obstacles = 0.1 } }",
            "[{ random = 1 }]",
        ),
        ("[3, 2]", ascii, "[{ exit = 0 }]"),
    ] {
        let e = tiled(with(size, map, channels)).unwrap_err();
        assert!(e.to_string().contains("world.scale"), "{size} {map}: {e}");
    }
}
