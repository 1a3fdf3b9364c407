//! The cases against measured crowds (`exp-*`): the Juelich experiments as JuPedSim's former
//! validation suite published them (docs/VALIDATION.md names the sources and every assumption).
//!
//! Each case reproduces a setup as far as the data describes it, measures what the experiment
//! measured the way PedPy measures it (Voronoi density and speed in the stated area, or the flow
//! through a bottleneck), bins the samples by density (or groups them by width) and compares
//! each bin's mean speed (or flow) with the experiment's: a check per bin, passing within
//! [`TOLERANCE`]. The experiments' figures are embedded here as derived values only (per bin:
//! the mean speed and the number of rows); `tests/validation.rs` recomputes them from the data
//! files when `../shared/experiments/` is present.
//!
//! Invariants: a bin is judged only where both the experiment and the simulation have at least
//! [`MIN_SAMPLES`] samples, and a case fails when fewer than [`MIN_COVERAGE`] of the
//! experiment's bins could be judged, so that a model which never reaches the dense bins does
//! not pass by leaving them out.

use std::cell::RefCell;

use glam::Vec2;

use super::{BinError, Check, Options, Outcome, Run, Runs, Series, Size, middle_flow, scenario};
use crate::error::Result;
use crate::measure::voronoi::voronoi_1d;
use crate::scenario::{Scenario, Spawn};

/// The largest relative error of a bin's mean speed (or a width's flow) that passes.
pub const TOLERANCE: f64 = 0.15;

/// The fewest samples a bin needs on each side to be judged.
pub const MIN_SAMPLES: usize = 5;

/// The smallest share of the experiment's bins (with enough rows) that must be judged.
pub const MIN_COVERAGE: f64 = 0.6;

/// A reference bin: `(lo, hi, mean speed m/s, rows)`.
pub type RefBin = (f64, f64, f64, usize);

/// `unidirectional/ug-180-*.txt` (8 runs, 442 rows): speed by Voronoi density, bins of 0.5.
pub const UNIDIRECTIONAL: &[RefBin] = &[
    (0.0, 0.5, 1.1077, 84),
    (0.5, 1.0, 0.9406, 49),
    (1.0, 1.5, 0.7025, 60),
    (1.5, 2.0, 0.561, 50),
    (2.0, 2.5, 0.4178, 37),
    (2.5, 3.0, 0.3491, 20),
    (3.0, 3.5, 0.2259, 44),
    (3.5, 4.0, 0.1685, 49),
    (4.0, 4.5, 0.0635, 35),
    (4.5, 5.0, 0.0426, 6),
];

/// `single-file/n*.dat` (12 runs): speed by one-dimensional Voronoi density, bins of 0.25.
pub const SINGLE_FILE: &[RefBin] = &[
    (0.25, 0.5, 1.1298, 38),
    (0.5, 0.75, 0.9285, 343),
    (0.75, 1.0, 0.8578, 486),
    (1.0, 1.25, 0.5415, 302),
    (1.25, 1.5, 0.3534, 307),
    (1.5, 1.75, 0.2524, 159),
    (1.75, 2.0, 0.1549, 257),
    (2.0, 2.25, 0.095, 320),
    (2.25, 2.5, 0.0512, 320),
    (2.5, 2.75, 0.0385, 150),
    (2.75, 3.0, 0.0057, 64),
];

/// `bidirectional/bot-360-*.dat` (7 runs): speed by Voronoi density, bins of 0.5.
pub const BIDIRECTIONAL: &[RefBin] = &[
    (0.0, 0.5, 1.4991, 31),
    (0.5, 1.0, 1.3243, 54),
    (1.0, 1.5, 1.054, 43),
    (1.5, 2.0, 0.7761, 61),
    (2.0, 2.5, 0.5761, 62),
    (2.5, 3.0, 0.4607, 39),
    (3.0, 3.5, 0.3981, 14),
];

/// `t-junction/ko-*_id_1.dat` (the area after the merge, "front"; 7 runs).
pub const T_JUNCTION_FRONT: &[RefBin] = &[
    (0.0, 0.5, 1.2583, 1),
    (0.5, 1.0, 1.2413, 48),
    (1.0, 1.5, 1.0252, 26),
    (1.5, 2.0, 0.8546, 57),
    (2.0, 2.5, 0.7482, 78),
    (2.5, 3.0, 0.6859, 11),
    (3.0, 3.5, 0.6937, 1),
];

/// `t-junction/ko-*_id_2.dat` and `_id_3.dat` (the two arms before the merge; 7 runs each).
pub const T_JUNCTION_ARMS: &[RefBin] = &[
    (0.0, 0.5, 1.2348, 79),
    (0.5, 1.0, 0.9782, 87),
    (1.0, 1.5, 0.7784, 50),
    (1.5, 2.0, 0.5534, 26),
    (2.0, 2.5, 0.393, 94),
    (2.5, 3.0, 0.3524, 60),
    (3.0, 3.5, 0.3216, 25),
];

/// Flow J (1/s) by bottleneck width b (m): the mean of `2006Kretz.txt`, `2009Seyfried.txt` and
/// `2006EG.txt` at each width (as JuPedSim's former test averaged them), `(b, J, values)`.
pub const BOTTLENECK: &[(f64, f64, usize)] = &[
    (0.8, 1.3872, 4),
    (0.9, 1.6032, 5),
    (1.0, 1.8582, 6),
    (1.1, 2.0555, 2),
    (1.2, 2.2214, 5),
    (1.6, 2.842, 1),
    (2.0, 3.549, 1),
    (2.5, 5.116, 1),
];

/// Samples binned by their `x`.
struct Binned {
    width: f64,
    sums: Vec<f64>,
    counts: Vec<usize>,
}

impl Binned {
    fn new(width: f64) -> Binned {
        Binned {
            width,
            sums: Vec::new(),
            counts: Vec::new(),
        }
    }

    fn add(&mut self, x: f64, y: f64) {
        if !(x.is_finite() && y.is_finite() && x >= 0.0) {
            return;
        }
        let k = (x / self.width) as usize;
        if self.sums.len() <= k {
            self.sums.resize(k + 1, 0.0);
            self.counts.resize(k + 1, 0);
        }
        self.sums[k] += y;
        self.counts[k] += 1;
    }

    /// The mean and count of the bin starting at `lo`.
    fn at(&self, lo: f64) -> (Option<f64>, usize) {
        let k = (lo / self.width + 0.5) as usize;
        match self.counts.get(k) {
            Some(&n) if n > 0 => (Some(self.sums[k] / n as f64), n),
            _ => (None, 0),
        }
    }

    /// The bins' means as points `[centre, mean]`.
    fn points(&self) -> Vec<[f64; 2]> {
        (0..self.counts.len())
            .filter(|&k| self.counts[k] >= MIN_SAMPLES)
            .map(|k| {
                [
                    (k as f64 + 0.5) * self.width,
                    self.sums[k] / self.counts[k] as f64,
                ]
            })
            .collect()
    }
}

/// The checks of `binned` against `reference`: one per bin judged, then the coverage; records
/// every bin's error in `runs`.
fn judge(
    what: &str,
    unit: &str,
    reference: &[RefBin],
    binned: &Binned,
    runs: &mut Runs,
) -> Vec<Check> {
    let mut checks = Vec::new();
    let (mut judged, mut eligible) = (0, 0);
    for &(lo, hi, speed, rows) in reference {
        let (measured, samples) = binned.at(lo);
        let enough = rows >= MIN_SAMPLES && samples >= MIN_SAMPLES;
        let error = measured.filter(|_| enough).map(|m| (m - speed) / speed);
        runs.errors.push(BinError {
            quantity: what.into(),
            lo,
            hi,
            reference: speed,
            reference_samples: rows,
            measured,
            samples,
            relative_error: error,
        });
        eligible += usize::from(rows >= MIN_SAMPLES);
        if let (Some(e), Some(m)) = (error, measured) {
            judged += 1;
            checks.push(Check::new(
                &format!(
                    "{what} at {lo} to {hi} {unit}: {m:.3} against {speed:.3} ({samples} samples)"
                ),
                format!("relative error within {TOLERANCE}"),
                Some(e),
                "",
                e.abs() <= TOLERANCE,
            ));
        }
    }
    let coverage = judged as f64 / eligible.max(1) as f64;
    checks.push(Check::new(
        &format!("{what}: share of the experiment's bins judged ({judged} of {eligible})"),
        format!("at least {MIN_COVERAGE}"),
        Some(coverage),
        "",
        coverage >= MIN_COVERAGE,
    ));
    checks
}

/// A corridor scenario `name` with its first `length` metres at `rho` persons/m^2 over its
/// `width`: random placement up to 3 persons/m^2 (the file's `spread`), above it a triangular
/// lattice (rows along the corridor 0.42 m apart or more, every other one shifted by half a
/// step), as JuPedSim's fundamental-diagram peer places them.
pub(super) fn corridor(name: &str, rho: f64, length: f32, width: f32) -> Result<Scenario> {
    let mut s = scenario(name)?;
    let n = (rho * f64::from(length * width)).round() as usize;
    if rho <= 3.0 {
        s.groups[0].count = n;
        return Ok(s);
    }
    let rows = ((width - 0.42) / 0.42).floor() as usize + 1;
    let dy = (width - 0.42) / (rows - 1) as f32;
    let per_row = n.div_ceil(rows);
    let dx = length / per_row as f32;
    let mut odd = s.groups[0].clone();
    let even = &mut s.groups[0];
    even.count = per_row * rows.div_ceil(2);
    even.spawn = Spawn::Grid {
        origin: Vec2::new(0.25, 0.21),
        spacing: Vec2::new(dx, 2.0 * dy),
        columns: per_row,
        transpose: false,
    };
    odd.count = per_row * (rows / 2);
    odd.spawn = Spawn::Grid {
        origin: Vec2::new(0.25 + dx / 2.0, 0.21 + dy),
        spacing: Vec2::new(dx, 2.0 * dy),
        columns: per_row,
        transpose: false,
    };
    s.groups.push(odd);
    Ok(s)
}

/// Every observed frame's Voronoi density and speed of area `area` into `binned`.
fn bin_area(o: &super::Outcome, area: usize, binned: &mut Binned) {
    for (_, frames) in &o.area_frames {
        if let Some(v) = frames[area].voronoi
            && v.density > 0.0
        {
            binned.add(v.density, v.speed);
        }
    }
}

/// The series of a case's fundamental diagram beside the experiment's.
fn diagrams(runs: &mut Runs, name: &str, x: &str, binned: &Binned, reference: &[RefBin]) {
    runs.series.push(Series {
        name: format!("{name} (simulated)"),
        x: x.into(),
        y: "speed (m/s)".into(),
        points: binned.points(),
    });
    runs.series.push(Series {
        name: format!("{name} (experiment)"),
        x: x.into(),
        y: "speed (m/s)".into(),
        points: reference
            .iter()
            .filter(|b| b.3 >= MIN_SAMPLES)
            .map(|b| [0.5 * (b.0 + b.1), b.2])
            .collect(),
    });
}

pub(super) fn exp_unidirectional(opt: &Options, runs: &mut Runs) -> Result<Vec<Check>> {
    let densities: &[f64] = match opt.size {
        Size::Full => &[0.3, 0.6, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0],
        Size::Quick => &[0.3, 1.0, 1.5, 2.5, 3.5, 4.0],
    };
    let mut binned = Binned::new(0.5);
    for &rho in densities {
        let o = Run::new(runs, opt).run(corridor("exp-unidirectional", rho, 90.0, 1.8)?)?;
        bin_area(&o, 0, &mut binned);
    }
    diagrams(
        runs,
        "unidirectional corridor",
        "Voronoi density (1/m^2)",
        &binned,
        UNIDIRECTIONAL,
    );
    Ok(judge("speed", "1/m^2", UNIDIRECTIONAL, &binned, runs))
}

/// The free speed of the single-file runs, m/s (the experiment's mean below 0.5 persons/m).
const SINGLE_FILE_SPEED: f64 = 1.13;

/// The single-file line at the centre of each 0.25 persons/m bin from 0.375 to 2.625: every
/// sample of one-dimensional Voronoi density and speed in x 45 to 47 m over t 10 to 30 s.
fn single_file(opt: &Options, runs: &mut Runs) -> Result<Binned> {
    // A line of the speed model keeps its spacing: each run fills the bin of its density, so
    // the runs sit at the bins' centres, quick or full.
    let densities: [f64; 10] = [
        0.375, 0.625, 0.875, 1.125, 1.375, 1.625, 1.875, 2.125, 2.375, 2.625,
    ];
    let binned = RefCell::new(Binned::new(0.25));
    for rho in densities {
        let mut s = scenario("exp-single-file")?;
        let spacing = (1.0 / rho) as f32;
        let columns = (89.8 * rho).floor() as usize + 1;
        s.groups[0].count = columns;
        s.groups[0].spawn = Spawn::Grid {
            origin: Vec2::new(0.2, 0.3),
            spacing: Vec2::new(spacing, 1.0),
            columns,
            transpose: false,
        };
        let every = (0.1 / f64::from(s.dt)).round().max(1.0) as u64;
        Run::new(runs, opt).run_until(s, |w| {
            let t = w.time();
            if (10.0..=30.0).contains(&t) && w.frame().is_multiple_of(every) {
                let a = w.agents();
                let xs: Vec<f64> = a.pos_x().iter().map(|&x| f64::from(x)).collect();
                let vs: Vec<f64> = a.vel_x().iter().map(|&v| f64::from(v)).collect();
                let f = voronoi_1d(&xs, &vs, (45.0, 47.0));
                if f.density > 0.0 {
                    binned.borrow_mut().add(f.density, f.speed);
                }
            }
            false
        })?;
    }
    Ok(binned.into_inner())
}

pub(super) fn exp_single_file(opt: &Options, runs: &mut Runs) -> Result<Vec<Check>> {
    let binned = single_file(opt, runs)?;
    diagrams(
        runs,
        "single file",
        "Voronoi density (1/m)",
        &binned,
        SINGLE_FILE,
    );
    Ok(judge("speed", "1/m", SINGLE_FILE, &binned, runs))
}

/// RiMEA 16 (version 4.x): the single-file fundamental diagram. The guideline asks for the
/// speed-density relation of pedestrians in one line, set beside empirical single-file data;
/// its criteria are qualitative, so the checks are: the line walks at its free speed when
/// sparse (within 5% at 0.25 to 0.5 persons/m), its speed never rises from one density bin to
/// the next by more than 0.02 m/s, and every density bin from 0.25 to 2.75 persons/m is
/// reached. The comparison bin by bin with the Juelich runs is `exp-single-file`'s.
pub(super) fn rimea_16(opt: &Options, runs: &mut Runs) -> Result<Vec<Check>> {
    let binned = single_file(opt, runs)?;
    let points = binned.points();
    let free = binned.at(0.25).0.map(|v| v / SINGLE_FILE_SPEED);
    let rising = points
        .windows(2)
        .filter(|w| w[1][1] > w[0][1] + 0.02)
        .count();
    let reached = (0..10)
        .filter(|&k| binned.at(0.25 * (k + 1) as f64).1 >= MIN_SAMPLES)
        .count();
    diagrams(
        runs,
        "single file (RiMEA 16)",
        "Voronoi density (1/m)",
        &binned,
        SINGLE_FILE,
    );
    Ok(vec![
        Check::within(
            "speed at 0.25 to 0.5 persons/m over the free speed 1.13 m/s",
            free,
            0.95,
            1.05,
            "",
        ),
        Check::new(
            "increases of the speed from one density bin to the next",
            "none above 0.02 m/s".into(),
            Some(rising as f64),
            "",
            rising == 0,
        ),
        Check::new(
            "density bins of 0.25 to 2.75 persons/m reached (with enough samples)",
            "all 10".into(),
            Some(reached as f64),
            "",
            reached == 10,
        ),
    ])
}

pub(super) fn exp_bidirectional(opt: &Options, runs: &mut Runs) -> Result<Vec<Check>> {
    let densities: &[f64] = match opt.size {
        Size::Full => &[0.5, 1.0, 1.5, 2.0, 2.5, 3.0],
        Size::Quick => &[0.5, 1.0, 2.0, 3.0],
    };
    let mut binned = Binned::new(0.5);
    for &rho in densities {
        let mut s = scenario("exp-bidirectional")?;
        let (length, width) = (60.0_f32, 3.6_f32);
        let rows = ((width - 0.42) / 0.42).floor() as usize + 1;
        let dy = (width - 0.42) / (rows - 1) as f32;
        let n = (rho * f64::from(length * width)).round() as usize;
        // Columns alternate: even ones walk right, odd ones left.
        let columns = n.div_ceil(rows).div_ceil(2).max(1);
        let dx = length / (2 * columns) as f32;
        for (g, shift) in [(0, 0.0), (1, dx)] {
            s.groups[g].count = columns * rows;
            s.groups[g].spawn = Spawn::Grid {
                origin: Vec2::new(20.0 + dx / 2.0 + shift, 0.21),
                spacing: Vec2::new(2.0 * dx, dy),
                columns,
                transpose: false,
            };
        }
        let o = Run::new(runs, opt).run(s)?;
        bin_area(&o, 0, &mut binned);
    }
    diagrams(
        runs,
        "bidirectional corridor",
        "Voronoi density (1/m^2)",
        &binned,
        BIDIRECTIONAL,
    );
    Ok(judge("speed", "1/m^2", BIDIRECTIONAL, &binned, runs))
}

pub(super) fn exp_t_junction(opt: &Options, runs: &mut Runs) -> Result<Vec<Check>> {
    let densities: &[f64] = match opt.size {
        Size::Full => &[1.0, 2.0, 3.0],
        Size::Quick => &[1.0, 3.0],
    };
    let (mut arms, mut front) = (Binned::new(0.5), Binned::new(0.5));
    for &rho in densities {
        let mut s = scenario("exp-t-junction")?;
        // Each arm's crowd fills 20.79 x 1.98 m (0.21 m from the walls).
        let n = (rho * 20.79 * 1.98).round() as usize;
        for g in &mut s.groups {
            g.count = n;
        }
        let o = Run::new(runs, opt).run(s)?;
        bin_area(&o, 0, &mut arms);
        bin_area(&o, 1, &mut arms);
        bin_area(&o, 2, &mut front);
    }
    diagrams(
        runs,
        "T-junction arms",
        "Voronoi density (1/m^2)",
        &arms,
        T_JUNCTION_ARMS,
    );
    diagrams(
        runs,
        "T-junction after the merge",
        "Voronoi density (1/m^2)",
        &front,
        T_JUNCTION_FRONT,
    );
    let mut checks = judge("arms: speed", "1/m^2", T_JUNCTION_ARMS, &arms, runs);
    checks.extend(judge(
        "after the merge: speed",
        "1/m^2",
        T_JUNCTION_FRONT,
        &front,
        runs,
    ));
    Ok(checks)
}

/// The bottleneck scenario with a corridor `b` m wide, run to its end.
pub(super) fn bottleneck_of_width(b: f64, opt: &Options, runs: &mut Runs) -> Result<Outcome> {
    let mut s = scenario("bottleneck")?;
    if let Some(layout) = &mut s.layout {
        layout.set_width(b as f32);
    }
    Run::new(runs, opt).run(s)
}

pub(super) fn exp_bottleneck_width(opt: &Options, runs: &mut Runs) -> Result<Vec<Check>> {
    let widths: &[f64] = match opt.size {
        Size::Full => &[0.8, 0.9, 1.0, 1.1, 1.2, 1.6, 2.0, 2.5],
        Size::Quick => &[1.0, 1.6],
    };
    let mut checks = Vec::new();
    let mut points = Vec::new();
    for &b in widths {
        let Some(&(_, reference, values)) = BOTTLENECK.iter().find(|r| (r.0 - b).abs() < 1e-9)
        else {
            continue;
        };
        let o = bottleneck_of_width(b, opt, runs)?;
        let j = middle_flow(&o.crossings, 0);
        if let Some(j) = j {
            points.push([b, j]);
        }
        let error = j.map(|j| (j - reference) / reference);
        runs.errors.push(BinError {
            quantity: "flow J (1/s) by width (m)".into(),
            lo: b,
            hi: b,
            reference,
            reference_samples: values,
            measured: j,
            samples: usize::from(j.is_some()),
            relative_error: error,
        });
        checks.push(Check::new(
            &format!(
                "J at b = {b} m: {} against {reference:.3} 1/s ({} left inside)",
                j.map_or("-".into(), |j| format!("{j:.3}")),
                o.inside
            ),
            format!("relative error within {TOLERANCE}"),
            error,
            "",
            error.is_some_and(|e| e.abs() <= TOLERANCE),
        ));
    }
    runs.series.push(Series {
        name: "bottleneck flow (simulated)".into(),
        x: "width b (m)".into(),
        y: "J (1/s)".into(),
        points,
    });
    runs.series.push(Series {
        name: "bottleneck flow (experiments)".into(),
        x: "width b (m)".into(),
        y: "J (1/s)".into(),
        points: BOTTLENECK.iter().map(|r| [r.0, r.1]).collect(),
    });
    Ok(checks)
}
