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
fn tiles_are_refused_without_a_size_or_with_a_field() {
    let text = "[world]\nkind = \"torus\"\ndensity = { neighbours = 5, radius = 2 }\nscale = \"tiles\"\n[[groups]]\ncount = 4\n";
    let s = Scenario::from_toml(text, "t.toml").unwrap();
    assert!(s.with_agents(40).is_err());
    // At or below the file's own count it scales by counts.
    let s = Scenario::from_toml(text, "t.toml").unwrap();
    assert_eq!(s.with_agents(3).unwrap().agent_count(), 3);
}
