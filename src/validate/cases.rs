//! The cases of the validation suite and their scenarios.

use super::{
    Case, Check, Options, Outcome, Run, Runs, Series, Size, middle_flow, scenario, weidmann,
};
use crate::error::Result;
use crate::scenario::Scenario;

/// The validation scenarios: `(file stem, TOML text)`.
pub(super) const SCENARIOS: &[(&str, &str)] = &[
    (
        "rimea-01-corridor",
        include_str!("../../scenarios/validation/rimea-01-corridor.toml"),
    ),
    (
        "fundamental-diagram",
        include_str!("../../scenarios/validation/fundamental-diagram.toml"),
    ),
    (
        "rimea-05-premovement",
        include_str!("../../scenarios/validation/rimea-05-premovement.toml"),
    ),
    (
        "rimea-06-corner",
        include_str!("../../scenarios/validation/rimea-06-corner.toml"),
    ),
    (
        "rimea-07-speeds",
        include_str!("../../scenarios/validation/rimea-07-speeds.toml"),
    ),
    (
        "rimea-09-4-exits",
        include_str!("../../scenarios/validation/rimea-09-4-exits.toml"),
    ),
    (
        "rimea-09-2-exits",
        include_str!("../../scenarios/validation/rimea-09-2-exits.toml"),
    ),
    (
        "rimea-10-escape-routes",
        include_str!("../../scenarios/validation/rimea-10-escape-routes.toml"),
    ),
    (
        "rimea-11-route-choice",
        include_str!("../../scenarios/validation/rimea-11-route-choice.toml"),
    ),
    (
        "rimea-12-bottlenecks",
        include_str!("../../scenarios/validation/rimea-12-bottlenecks.toml"),
    ),
    (
        "rimea-15-short",
        include_str!("../../scenarios/validation/rimea-15-short.toml"),
    ),
    (
        "rimea-15-corner",
        include_str!("../../scenarios/validation/rimea-15-corner.toml"),
    ),
    (
        "rimea-15-long",
        include_str!("../../scenarios/validation/rimea-15-long.toml"),
    ),
    (
        "bottleneck",
        include_str!("../../scenarios/validation/bottleneck.toml"),
    ),
    (
        "exp-unidirectional",
        include_str!("../../scenarios/validation/exp-unidirectional.toml"),
    ),
    (
        "exp-single-file",
        include_str!("../../scenarios/validation/exp-single-file.toml"),
    ),
    (
        "exp-bidirectional",
        include_str!("../../scenarios/validation/exp-bidirectional.toml"),
    ),
    (
        "exp-t-junction",
        include_str!("../../scenarios/validation/exp-t-junction.toml"),
    ),
];

/// Every case, in the order `throng validate` runs them.
pub const CASES: &[Case] = &[
    Case {
        id: "rimea-01",
        title: "RiMEA 1: keeping the walking speed in a corridor",
        about: "One pedestrian at 1.33 m/s along a corridor 2 m wide and 40 m long. RiMEA: \
                the 40 m take 26 to 34 s.",
        run: rimea_01,
    },
    Case {
        id: "rimea-04",
        title: "RiMEA 4 and Weidmann: the fundamental diagram",
        about: "A corridor 4 m wide whose first 90 m hold the crowd at 0.5 to 5 persons/m^2 \
                (random placement up to 3, a lattice above), all at 1.34 m/s; classic density \
                and mean speed in 10 x 4 m over t 10 to 30 s. Criteria: the speed within 15% of \
                Weidmann's at the measured density for 0.5 to 3 persons/m^2, and falling with \
                the density. Quick: 0.5, 1, 2 and 3 persons/m^2 only.",
        run: rimea_04,
    },
    Case {
        id: "rimea-05",
        title: "RiMEA 5: pre-movement times",
        about: "10 pedestrians in a room 8 x 5 m with a 1 m door, each waiting a pre-movement \
                time drawn uniformly from 10 to 100 s. RiMEA: each starts at its own time; \
                here: every one stands still until its time and walks within 0.1 s after it, \
                every time within 10 to 100 s, and everyone out.",
        run: rimea_05,
    },
    Case {
        id: "rimea-06",
        title: "RiMEA 6: movement around a corner",
        about: "20 pedestrians walk around a left corner of a corridor 2 m wide. RiMEA: they go \
                round it without passing through walls; here also: all reach the exit within \
                120 s.",
        run: rimea_06,
    },
    Case {
        id: "rimea-07",
        title: "RiMEA 7: the distribution of walking speeds",
        about: "50 adults with desired speeds drawn from Weidmann's distribution (normal, mean \
                1.34 m/s, sd 0.26, truncated to 0.56 to 2.12) walk 40 m in free lanes. RiMEA: the \
                walked speeds follow the distribution; here: a Kolmogorov-Smirnov distance below \
                the 5% critical value 1.36 / sqrt(n), every speed within the truncation.",
        run: rimea_07,
    },
    Case {
        id: "rimea-09",
        title: "RiMEA 9: a large room emptied through four and then two exits",
        about: "1,000 pedestrians leave a room 30 x 20 m through four exits 1 m wide, then with \
                the two exits of one long wall locked. RiMEA: about twice as long; the criterion \
                (JuPedSim's test) 1.6 to 2.4 times. Quick: 500 pedestrians (the doors still \
                jam, which is what the ratio is about).",
        run: rimea_09,
    },
    Case {
        id: "rimea-10",
        title: "RiMEA 10: allocated escape routes",
        about: "23 pedestrians in twelve rooms on both sides of a corridor 1 m wide (doors \
                0.9 m) leave by two exits: the occupants of the four rooms on each side nearest \
                the main exit are allocated to it, the others to the secondary exit at the \
                corridor's end, even where the other exit is nearer (JuPedSim's geometry of the \
                guideline's floor). RiMEA: each uses the exit allocated to it; here: everyone \
                out, and every pedestrian through its own exit and not the other.",
        run: rimea_10,
    },
    Case {
        id: "rimea-11",
        title: "RiMEA 11: the choice of escape route",
        about: "1,000 pedestrians in the left part of a room 30 x 20 m leave through two exits \
                1 m wide in its upper wall, one nearer than the other; each chooses an exit by \
                its travel time through the crowd and keeps it unless the other becomes 25% \
                quicker (choose_exit). RiMEA: most take the nearer exit and some the other; \
                here: everyone out, more than half through the nearer exit and at least 5% \
                through the other. Quick: 500 pedestrians.",
        run: rimea_11,
    },
    Case {
        id: "rimea-12",
        title: "RiMEA 12: the effect of bottlenecks",
        about: "150 pedestrians walk from a room through a corridor 1 m wide and 5 m long into a \
                second room and out through its 1 m exit. RiMEA: the jam forms in the first room \
                only (not an exclusion criterion); here as JuPedSim's test: the flow through the \
                last exit at least that out of the corridor less 0.05 persons/s, and everyone \
                out.",
        run: rimea_12,
    },
    Case {
        id: "rimea-15",
        title: "RiMEA 15: a large crowd around a corner",
        about: "500 pedestrians at 1 m/s leave a start area 20 x 6 m along a corridor 20 m wide: \
                44 m straight, 75.4 m straight, and 34 m then a corner then 10 m. RiMEA: the \
                corner's time lies between the two straight ones. Quick: 250 pedestrians.",
        run: rimea_15,
    },
    Case {
        id: "rimea-16",
        title: "RiMEA 16: the single-file fundamental diagram",
        about: "Pedestrians (0.36 m long) in one line in a corridor 0.6 m wide, the first 90 m \
                at 0.375 to 2.625 persons/m, all at 1.13 m/s; one-dimensional Voronoi density \
                and speed in 2 m over t 10 to 30 s (the runs of exp-single-file). RiMEA 4.x: \
                the speed-density relation in single file, beside empirical data; here: the \
                free speed within 5% when sparse, no rise of the speed from one 0.25 \
                persons/m bin to the next above 0.02 m/s, every bin to 2.75 persons/m reached. \
                Quick: as full.",
        run: super::experiments::rimea_16,
    },
    Case {
        id: "bottleneck",
        title: "Bottleneck flow against its width",
        about: "JuPedSim's bottleneck experiment: 200 pedestrians leave a room 10 x 10 m through \
                a corridor b m wide and 4 m long, b from 0.8 to 2.5 m; J over the middle 60% of \
                the crossings of the entrance. Criteria: J/b within 1.5 to 2.1 persons/(m s) for \
                b >= 1.2 m (the experiments of Seyfried et al. 2009, Kretz et al. 2006 and Liddle \
                et al. 2011 report about 1.6 to 2.0), and J growing with b. Quick: b = 1.2 and \
                2.0 m.",
        run: bottleneck,
    },
    Case {
        id: "exp-unidirectional",
        title: "Juelich unidirectional corridor: speed against Voronoi density",
        about: "A corridor 1.8 m wide whose first 90 m hold the crowd at 0.3 to 4 persons/m^2, \
                all at 1.11 m/s (the experiment's speed below 0.5 persons/m^2); Voronoi \
                density and speed (PedPy's) in 6 x 1.8 m over t 10 to 30 s, binned by 0.5 \
                persons/m^2, against the UNI_CORR runs ug-180-*. Criterion: each bin's mean speed \
                within 15% of the experiment's, at least 60% of its bins judged. Quick: 0.3, 1, \
                1.5, 2.5, 3.5 and 4 persons/m^2.",
        run: super::experiments::exp_unidirectional,
    },
    Case {
        id: "exp-single-file",
        title: "Juelich single file: speed against line density",
        about: "Pedestrians (0.36 m long) in one line in a corridor 0.6 m wide, the first 90 m \
                at the centre of each bin from 0.375 to 2.625 persons/m, all at 1.13 m/s; \
                one-dimensional Voronoi density and speed in 2 m over t 10 to 30 s, binned by \
                0.25 persons/m, against runs n14 to n70. Criterion: each bin within 15%, at \
                least 60% judged. Quick: as full (the runs are short).",
        run: super::experiments::exp_single_file,
    },
    Case {
        id: "exp-bidirectional",
        title: "Juelich bidirectional corridor: speed against Voronoi density",
        about: "A corridor 3.6 m wide, x 20 to 80 m filled at 0.5 to 3 persons/m^2 on a lattice \
                whose columns walk alternately right and left at 1.5 m/s; Voronoi density and \
                speed in 6 x 3.6 m over t 5 to 20 s, binned by 0.5, against the BI_CORR runs \
                bot-360-*. Criterion: each bin within 15%, at least 60% judged. Quick: 0.5, 1, 2 \
                and 3 persons/m^2.",
        run: super::experiments::exp_bidirectional,
    },
    Case {
        id: "exp-t-junction",
        title: "Juelich T-junction: speed against Voronoi density before and after the merge",
        about: "Corridors 2.4 m wide: two crowds at 1 to 3 persons/m^2 in the arms of the main \
                corridor walk to the junction and merge into the branch at 1.23 m/s; Voronoi \
                density and speed in the experiment's three 2 x 2.4 m areas (left and right arm \
                pooled, and after the merge) over t 10 to 50 s, binned by 0.5, against the runs \
                ko-240-*. Criterion: each bin within 15%, at least 60% judged. Quick: 1 and 3 \
                persons/m^2.",
        run: super::experiments::exp_t_junction,
    },
    Case {
        id: "exp-bottleneck-width",
        title: "Bottleneck flow against its width, per width against the experiments",
        about: "The bottleneck case's room (10 x 10 m, 200 pedestrians, corridor 4 m long) at \
                b = 0.8 to 2.5 m; J over the middle 60% of the first crossings of the \
                entrance, against the mean of Kretz et al. 2006, Seyfried et al. 2009 and the \
                2006 EG runs at that width. Criterion: J within 15% per width. Quick: b = 1.0 \
                and 1.6 m.",
        run: super::experiments::exp_bottleneck_width,
    },
];

/// The check that all `n` pedestrians left through the exits.
fn all_out(o: &Outcome, n: usize) -> Check {
    Check::within(
        "pedestrians out",
        Some(o.left as f64),
        n as f64,
        n as f64,
        "",
    )
}

/// The crossing time of agent `id` at `line` (its first).
fn crossing(o: &Outcome, line: usize, id: u32) -> Option<f64> {
    o.crossings
        .iter()
        .find(|c| c.0 == line && c.1 == id)
        .map(|c| c.2)
}

fn rimea_01(opt: &Options, runs: &mut Runs) -> Result<Vec<Check>> {
    let o = Run::new(runs, opt).run(scenario("rimea-01-corridor")?)?;
    let t = crossing(&o, 0, 0)
        .zip(crossing(&o, 1, 0))
        .map(|(a, b)| b - a);
    Ok(vec![Check::within(
        "time for 40 m at 1.33 m/s",
        t,
        26.0,
        34.0,
        "s",
    )])
}

/// The fundamental-diagram corridor at density `rho` (4 m wide, the crowd in its first 90 m).
fn fd_scenario(rho: f64) -> Result<Scenario> {
    super::experiments::corridor("fundamental-diagram", rho, 90.0, 4.0)
}

fn rimea_04(opt: &Options, runs: &mut Runs) -> Result<Vec<Check>> {
    let densities: &[f64] = match opt.size {
        Size::Full => &[0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0],
        Size::Quick => &[0.5, 1.0, 2.0, 3.0],
    };
    let mut checks = Vec::new();
    let mut points = Vec::new();
    for &rho in densities {
        let o = Run::new(runs, opt).run(fd_scenario(rho)?)?;
        let area = &o.report.areas[0];
        let (d, v) = (area.mean_density, area.mean_speed);
        if let (Some(d), Some(v)) = (d, v) {
            points.push([d, v]);
        }
        if rho <= 3.0 {
            let ratio = d.zip(v).map(|(d, v)| v / weidmann(d));
            checks.push(Check::within(
                &format!(
                    "speed / Weidmann's at {rho} persons/m^2 (measured {})",
                    d.map_or("-".into(), |d| format!("{d:.2}"))
                ),
                ratio,
                0.85,
                1.15,
                "",
            ));
        }
    }
    let rising = points
        .windows(2)
        .filter(|w| w[1][1] > w[0][1] + 0.02)
        .count();
    checks.push(Check::new(
        "increases of the speed from one density to the next",
        "none above 0.02 m/s".into(),
        Some(rising as f64),
        "",
        rising == 0 && points.len() == densities.len(),
    ));
    runs.series.push(Series {
        name: "fundamental diagram".into(),
        x: "density (1/m^2)".into(),
        y: "speed (m/s)".into(),
        points,
    });
    Ok(checks)
}

fn rimea_06(opt: &Options, runs: &mut Runs) -> Result<Vec<Check>> {
    let o = Run::new(runs, opt).run(scenario("rimea-06-corner")?)?;
    Ok(vec![
        all_out(&o, 20),
        Check::within(
            "time until the last is out",
            o.evacuation_time,
            0.0,
            120.0,
            "s",
        ),
    ])
}

/// The standard normal distribution function, `(1 + erf(x / sqrt 2)) / 2` (Abramowitz and
/// Stegun 7.1.26, absolute error below 1.5e-7).
fn normal_cdf(x: f64) -> f64 {
    let z = x.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * z);
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let erf = 1.0 - poly * (-z * z).exp();
    if x >= 0.0 {
        0.5 * (1.0 + erf)
    } else {
        0.5 * (1.0 - erf)
    }
}

/// The Kolmogorov-Smirnov distance of `sample` from the normal distribution `(mean, sd)`
/// truncated to `[lo, hi]`.
fn ks_truncated_normal(sample: &mut [f64], mean: f64, sd: f64, lo: f64, hi: f64) -> f64 {
    sample.sort_by(f64::total_cmp);
    let (a, b) = (normal_cdf((lo - mean) / sd), normal_cdf((hi - mean) / sd));
    let cdf = |x: f64| ((normal_cdf((x.clamp(lo, hi) - mean) / sd) - a) / (b - a)).clamp(0.0, 1.0);
    let n = sample.len() as f64;
    sample
        .iter()
        .enumerate()
        .map(|(k, &x)| {
            let f = cdf(x);
            (f - k as f64 / n).abs().max(((k + 1) as f64 / n - f).abs())
        })
        .fold(0.0, f64::max)
}

fn rimea_07(opt: &Options, runs: &mut Runs) -> Result<Vec<Check>> {
    let s = scenario("rimea-07-speeds")?;
    let n = s.groups[0].count;
    let ds = s.groups[0]
        .params
        .pedestrian
        .map(|p| p.desired_speed)
        .unwrap_or_default();
    let o = Run::new(runs, opt).run(s)?;
    let mut speeds: Vec<f64> = (0..n as u32)
        .filter_map(|id| {
            let t = crossing(&o, 1, id)? - crossing(&o, 0, id)?;
            (t > 0.0).then(|| 40.0 / t)
        })
        .collect();
    let (lo, hi) = (f64::from(ds.min), f64::from(ds.max));
    let inside = speeds
        .iter()
        .filter(|&&v| (lo - 0.01..=hi + 0.01).contains(&v))
        .count();
    let critical = 1.36 / (n as f64).sqrt();
    let d = ks_truncated_normal(&mut speeds, f64::from(ds.mean), f64::from(ds.sd), lo, hi);
    let mean = speeds.iter().sum::<f64>() / speeds.len().max(1) as f64;
    runs.series.push(Series {
        name: "walked speeds".into(),
        x: "rank".into(),
        y: "speed (m/s)".into(),
        points: speeds
            .iter()
            .enumerate()
            .map(|(k, &v)| [k as f64, v])
            .collect(),
    });
    Ok(vec![
        Check::within(
            "speeds measured",
            Some(speeds.len() as f64),
            n as f64,
            n as f64,
            "",
        ),
        Check::within(
            &format!("speeds within [{lo:.2}, {hi:.2}] m/s (mean {mean:.3} m/s)"),
            Some(inside as f64),
            n as f64,
            n as f64,
            "",
        ),
        Check::new(
            "Kolmogorov-Smirnov distance from the distribution",
            format!("below {critical:.3} (5% level)"),
            Some(d),
            "",
            d < critical,
        ),
    ])
}

fn rimea_05(opt: &Options, runs: &mut Runs) -> Result<Vec<Check>> {
    let s = scenario("rimea-05-premovement")?;
    let n = s.groups[0].count;
    let seed = s.seed.wrapping_add(opt.seed_offset);
    let pm = s.groups[0]
        .params
        .pedestrian
        .and_then(|p| p.premovement)
        .ok_or_else(|| crate::Error::Invalid {
            name: "rimea-05-premovement".into(),
            reason: "the scenario has no pre-movement times".into(),
        })?;
    let o = Run::new(runs, opt).run(s)?;
    // Each agent's drawn time and the time it first moved, by id.
    let pairs: Vec<(f64, Option<f64>)> = (0..n as u32)
        .map(|id| {
            let t = f64::from(pm.draw(seed, id));
            (t, o.moved.get(id as usize).copied().flatten())
        })
        .collect();
    let on_time = pairs
        .iter()
        .filter(|(t, m)| m.is_some_and(|m| m >= *t && m <= t + 0.1))
        .count();
    let early = pairs
        .iter()
        .filter(|(t, m)| m.is_some_and(|m| m < *t))
        .count();
    let within = pairs
        .iter()
        .filter(|(t, _)| (f64::from(pm.min)..=f64::from(pm.max)).contains(t))
        .count();
    let (first, last) = pairs
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), (t, _)| {
            (a.min(*t), b.max(*t))
        });
    runs.series.push(Series {
        name: "pre-movement times".into(),
        x: "drawn time (s)".into(),
        y: "first move (s)".into(),
        points: pairs
            .iter()
            .filter_map(|&(t, m)| m.map(|m| [t, m]))
            .collect(),
    });
    Ok(vec![
        Check::within(
            &format!(
                "drawn times within [{}, {}] s (first {first:.1} s, last {last:.1} s)",
                pm.min, pm.max
            ),
            Some(within as f64),
            n as f64,
            n as f64,
            "",
        ),
        Check::within(
            "pedestrians that moved before their time",
            Some(early as f64),
            0.0,
            0.0,
            "",
        ),
        Check::within(
            "pedestrians that started within 0.1 s after their time",
            Some(on_time as f64),
            n as f64,
            n as f64,
            "",
        ),
        all_out(&o, n),
    ])
}

/// `s` with its first group's count scaled for the quick size.
fn sized(mut s: Scenario, opt: &Options, quick: usize) -> Scenario {
    if opt.size == Size::Quick {
        s.groups[0].count = quick;
    }
    s
}

fn rimea_09(opt: &Options, runs: &mut Runs) -> Result<Vec<Check>> {
    let n = if opt.size == Size::Quick { 500 } else { 1000 };
    let four = Run::new(runs, opt).run(sized(scenario("rimea-09-4-exits")?, opt, n))?;
    let two = Run::new(runs, opt).run(sized(scenario("rimea-09-2-exits")?, opt, n))?;
    let ratio = two
        .evacuation_time
        .zip(four.evacuation_time)
        .map(|(a, b)| a / b);
    Ok(vec![
        Check::within(
            "time with four exits",
            four.evacuation_time,
            0.0,
            1000.0,
            "s",
        ),
        Check::within("time with two exits", two.evacuation_time, 0.0, 1000.0, "s"),
        Check::within("ratio of the times", ratio, 1.6, 2.4, ""),
    ])
}

/// How many agents crossed `line` (each counted once).
fn crossed(o: &Outcome, line: usize) -> usize {
    let mut ids: Vec<u32> = o
        .crossings
        .iter()
        .filter(|c| c.0 == line)
        .map(|c| c.1)
        .collect();
    ids.sort_unstable();
    ids.dedup();
    ids.len()
}

fn rimea_10(opt: &Options, runs: &mut Runs) -> Result<Vec<Check>> {
    let s = scenario("rimea-10-escape-routes")?;
    // Agents are numbered in the order of the groups; a group's name ends in its exit (line 0
    // crosses the main exit, line 1 the secondary).
    let allocated: Vec<usize> = s
        .groups
        .iter()
        .flat_map(|g| {
            let line = usize::from(!g.params.name.ends_with("-main"));
            std::iter::repeat_n(line, g.count)
        })
        .collect();
    let o = Run::new(runs, opt).run(s)?;
    let mut checks = vec![all_out(&o, allocated.len())];
    for (line, exit) in [(0, "main"), (1, "secondary")] {
        let mine: Vec<u32> = (0..allocated.len() as u32)
            .filter(|&id| allocated[id as usize] == line)
            .collect();
        let kept = mine
            .iter()
            .filter(|&&id| crossing(&o, line, id).is_some() && crossing(&o, 1 - line, id).is_none())
            .count();
        checks.push(Check::within(
            &format!(
                "allocated to the {exit} exit and left through it ({kept} of {})",
                mine.len()
            ),
            Some(kept as f64),
            mine.len() as f64,
            mine.len() as f64,
            "",
        ));
    }
    Ok(checks)
}

fn rimea_11(opt: &Options, runs: &mut Runs) -> Result<Vec<Check>> {
    let n = if opt.size == Size::Quick { 500 } else { 1000 };
    let o = Run::new(runs, opt).run(sized(scenario("rimea-11-route-choice")?, opt, n))?;
    let (near, far) = (crossed(&o, 0), crossed(&o, 1));
    let share = |k: usize| Some(k as f64 / n as f64);
    Ok(vec![
        all_out(&o, n),
        Check::within(
            "time until the last is out",
            o.evacuation_time,
            0.0,
            1000.0,
            "s",
        ),
        Check::new(
            &format!("share through the nearer exit ({near} of {n})"),
            "> 0.5 (most prefer the nearer exit)".into(),
            share(near),
            "",
            share(near).is_some_and(|s| s > 0.5),
        ),
        Check::new(
            &format!("share through the other exit ({far} of {n})"),
            ">= 0.05 (some choose the other)".into(),
            share(far),
            "",
            share(far).is_some_and(|s| s >= 0.05),
        ),
    ])
}

fn rimea_12(opt: &Options, runs: &mut Runs) -> Result<Vec<Check>> {
    let o = Run::new(runs, opt).run(scenario("rimea-12-bottlenecks")?)?;
    let (corridor, exit) = (middle_flow(&o.crossings, 0), middle_flow(&o.crossings, 1));
    let d = exit.zip(corridor).map(|(e, c)| e - c);
    Ok(vec![
        all_out(&o, 150),
        Check::new(
            &format!(
                "exit flow less corridor flow ({} and {} 1/s)",
                fmt(exit),
                fmt(corridor)
            ),
            ">= -0.05 1/s (no jam at the last exit)".into(),
            d,
            "1/s",
            d.is_some_and(|d| d >= -0.05),
        ),
    ])
}

fn fmt(v: Option<f64>) -> String {
    v.map_or("-".into(), |v| format!("{v:.3}"))
}

fn rimea_15(opt: &Options, runs: &mut Runs) -> Result<Vec<Check>> {
    let mut t = Vec::new();
    for name in ["rimea-15-short", "rimea-15-corner", "rimea-15-long"] {
        let o = Run::new(runs, opt).run(sized(scenario(name)?, opt, 250))?;
        t.push(o.evacuation_time);
    }
    let ordered = matches!(t[..], [Some(a), Some(b), Some(c)] if a <= b && b <= c);
    Ok(vec![
        Check::within("time along 44 m", t[0], 0.0, 1000.0, "s"),
        Check::within("time around the corner", t[1], 0.0, 1000.0, "s"),
        Check::within("time along 75.4 m", t[2], 0.0, 1000.0, "s"),
        Check::new(
            "corner between the straight ones",
            format!("{} <= corner <= {} s", fmt(t[0]), fmt(t[2])),
            t[1],
            "s",
            ordered,
        ),
    ])
}

fn bottleneck(opt: &Options, runs: &mut Runs) -> Result<Vec<Check>> {
    let widths: &[f64] = match opt.size {
        Size::Full => &[0.8, 1.0, 1.2, 1.6, 2.0, 2.5],
        Size::Quick => &[1.2, 2.0],
    };
    let mut checks = Vec::new();
    let mut points = Vec::new();
    for &b in widths {
        let o = super::experiments::bottleneck_of_width(b, opt, runs)?;
        let j = middle_flow(&o.crossings, 0);
        if let Some(j) = j {
            points.push([b, j / b]);
        }
        let name = format!(
            "J/b at b = {b} m (J {} 1/s, {} left in {:.0} s)",
            fmt(j),
            o.inside,
            o.time
        );
        if b >= 1.2 {
            checks.push(Check::within(&name, j.map(|j| j / b), 1.5, 2.1, "1/(m s)"));
        } else {
            checks.push(Check::new(
                &name,
                "measured (no criterion below 1.2 m)".into(),
                j.map(|j| j / b),
                "1/(m s)",
                true,
            ));
        }
    }
    let falls = points
        .windows(2)
        .filter(|w| w[1][0] * w[1][1] < w[0][0] * w[0][1])
        .count();
    checks.push(Check::new(
        "decreases of J from one width to the next",
        "none".into(),
        Some(falls as f64),
        "",
        falls == 0 && points.len() == widths.len(),
    ));
    runs.series.push(Series {
        name: "bottleneck".into(),
        x: "width b (m)".into(),
        y: "J/b (1/(m s))".into(),
        points,
    });
    Ok(checks)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_cdf_and_ks_by_hand() {
        assert!((normal_cdf(0.0) - 0.5).abs() < 1e-7);
        assert!((normal_cdf(1.0) - 0.841_344_746).abs() < 2e-7);
        assert!((normal_cdf(-1.96) - 0.024_997_9).abs() < 2e-7);
        // One point at the median: distance 1/2.
        assert!((ks_truncated_normal(&mut [1.34], 1.34, 0.26, 0.56, 2.12) - 0.5).abs() < 1e-6);
        // Points at the quantiles k/n + 1/(2n): distance 1/(2n).
        let mut s: Vec<f64> = (0..4)
            .map(|k| {
                let p = (k as f64 + 0.5) / 4.0;
                // Bisect the untruncated quantile.
                let (mut lo, mut hi) = (-10.0, 10.0);
                for _ in 0..100 {
                    let m = 0.5 * (lo + hi);
                    if normal_cdf(m) < p { lo = m } else { hi = m }
                }
                lo
            })
            .collect();
        assert!((ks_truncated_normal(&mut s, 0.0, 1.0, -50.0, 50.0) - 0.125).abs() < 1e-6);
    }
}
