//! The validation suite at its quick size with the default pedestrian parameters: the cases
//! that pass (RiMEA 1, 4, 5, 6, 7, 10, 12, 15 and the bottleneck's flow at 1.2 and 2 m), and the
//! same report on 1 and 2 threads. RiMEA 9 (about 2 minutes even at its quick size) runs with
//! `throng validate rimea-09`, and RiMEA 11 (whose split between two equal doors stays near one
//! half whatever the exit choice: docs/VALIDATION.md) with `throng validate rimea-11`.

use throng::validate::{self, Options, Size};

fn quick() -> Options {
    Options {
        size: Size::Quick,
        ..Options::default()
    }
}

/// Runs case `id` at the quick size and asserts that every check passed, printing the
/// failing ones.
fn passes(id: &str) {
    let report = validate::run_case(validate::case(id).unwrap(), &quick()).unwrap();
    let failed: Vec<_> = report.checks.iter().filter(|c| !c.pass).collect();
    assert!(failed.is_empty(), "{id}: {failed:#?}");
    assert!(report.pass && report.steps > 0);
}

#[test]
fn rimea_01_one_pedestrian_keeps_its_speed() {
    passes("rimea-01");
}

#[test]
fn rimea_04_the_fundamental_diagram_follows_weidmann() {
    passes("rimea-04");
}

#[test]
fn rimea_05_each_pedestrian_waits_its_premovement_time() {
    passes("rimea-05");
}

#[test]
fn rimea_06_twenty_pedestrians_go_round_the_corner() {
    passes("rimea-06");
}

#[test]
fn rimea_07_walked_speeds_follow_the_distribution() {
    passes("rimea-07");
}

#[test]
fn rimea_10_everyone_leaves_through_the_exit_allocated_to_them() {
    passes("rimea-10");
}

#[test]
fn rimea_12_no_jam_at_the_last_exit() {
    passes("rimea-12");
}

/// The case's report at the quick size.
fn report(id: &str) -> validate::CaseReport {
    validate::run_case(validate::case(id).unwrap(), &quick()).unwrap()
}

#[test]
fn bottleneck_flow_is_in_the_experiments_band_and_grows_with_the_width() {
    // 1.5 to 2.1 persons/(m s) at b = 1.2 and 2 m (JuPedSim's speed model: 1.10 and 1.12).
    let r = report("bottleneck");
    let failed: Vec<_> = r.checks.iter().filter(|c| !c.pass).collect();
    assert!(failed.is_empty(), "{failed:#?}");
    let points = &r.series[0].points;
    assert_eq!(points.len(), 2, "{r:#?}");
    assert!(points[1][0] * points[1][1] > points[0][0] * points[0][1]);
}

#[test]
fn rimea_15_the_corner_takes_between_the_short_and_the_long_way() {
    // Quickest-path routing spreads the crowd round the corner; routed by the distance alone it
    // jams at the inner edge and takes longer than the long way.
    passes("rimea-15");
}

#[test]
fn rimea_16_the_single_file_slows_with_its_density() {
    passes("rimea-16");
}

#[test]
fn a_case_reports_the_same_on_one_and_two_threads() {
    let case = validate::case("rimea-12").unwrap();
    let run = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| validate::run_case(case, &quick()).unwrap())
    };
    assert_eq!(run(1), run(2));
}

#[test]
fn unknown_cases_are_errors_naming_the_known_ones() {
    let e = validate::case("rimea-99").unwrap_err().to_string();
    assert!(e.contains("rimea-99") && e.contains("rimea-01"), "{e}");
}

#[test]
fn bottleneck_flow_per_width_is_within_15_percent_of_the_experiments() {
    passes("exp-bottleneck-width");
}

/// Every `exp-*` case reports, per bin of the experiment, the experiment's value beside the
/// simulation's and the relative error (the JSON's `errors`), and judges the bins that have
/// samples on both sides. The quick size reaches as many of the experiment's bins as the
/// criterion asks of the full size, so that it can pass.
#[test]
fn experiment_cases_report_their_errors_per_bin() {
    for id in [
        "exp-single-file",
        "exp-bidirectional",
        "exp-unidirectional",
        "exp-t-junction",
    ] {
        let r = report(id);
        assert!(!r.errors.is_empty(), "{id}");
        let coverage: Vec<_> = r
            .checks
            .iter()
            .filter(|c| c.name.contains("share of the experiment's bins judged"))
            .collect();
        assert!(!coverage.is_empty(), "{id}: {:#?}", r.checks);
        for c in coverage {
            assert!(c.pass, "{id}: {c:#?}");
        }
        for e in &r.errors {
            if let (Some(m), Some(err)) = (e.measured, e.relative_error) {
                assert!(
                    (err - (m - e.reference) / e.reference).abs() < 1e-12,
                    "{e:?}"
                );
                assert!(e.samples >= validate::MIN_SAMPLES, "{e:?}");
            }
        }
        assert!(
            r.errors.iter().any(|e| e.relative_error.is_some()),
            "{id}: {r:#?}"
        );
    }
}

/// The experiments' figures embedded in the crate are those of the data files in
/// `../shared/experiments/` (when that folder is present): per bin, the mean speed and the row
/// count; per bottleneck width, the mean flow of the three series.
#[test]
fn embedded_experiment_figures_match_the_data_files() {
    let root = std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/experiments"
    ));
    if !root.is_dir() {
        eprintln!("skipped: {} is not present", root.display());
        return;
    }
    let rows = |pattern: &dyn Fn(&str) -> bool, folder: &str| -> Vec<(f64, f64)> {
        let mut files: Vec<_> = std::fs::read_dir(root.join(folder))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| pattern(&p.file_name().unwrap().to_string_lossy()))
            .collect();
        files.sort();
        let mut out = Vec::new();
        for f in files {
            let text = String::from_utf8_lossy(&std::fs::read(&f).unwrap()).into_owned();
            for line in text.lines() {
                let v: Vec<f64> = line
                    .split(|c: char| c.is_whitespace() || c == ',')
                    .filter(|s| !s.is_empty())
                    .map_while(|s| s.parse().ok())
                    .collect();
                if v.len() >= 2 && !line.trim_start().starts_with('#') {
                    out.push((v[0], v[1]));
                }
            }
        }
        out
    };
    let check = |name: &str, data: Vec<(f64, f64)>, bins: &[validate::RefBin]| {
        for &(lo, hi, mean, n) in bins {
            let inside: Vec<f64> = data
                .iter()
                .filter(|r| r.0 >= lo && r.0 < hi)
                .map(|r| r.1)
                .collect();
            assert_eq!(inside.len(), n, "{name} {lo}..{hi}");
            let m = inside.iter().sum::<f64>() / n as f64;
            assert!(
                (m - mean).abs() < 6e-5,
                "{name} {lo}..{hi}: {m} against {mean}"
            );
        }
    };
    check(
        "unidirectional",
        rows(&|_| true, "unidirectional"),
        validate::UNIDIRECTIONAL,
    );
    check(
        "single file",
        rows(&|_| true, "single-file"),
        validate::SINGLE_FILE,
    );
    check(
        "bidirectional",
        rows(&|_| true, "bidirectional"),
        validate::BIDIRECTIONAL,
    );
    check(
        "T-junction front",
        rows(
            &|n| n.starts_with("ko-") && n.ends_with("_id_1.dat"),
            "t-junction",
        ),
        validate::T_JUNCTION_FRONT,
    );
    check(
        "T-junction arms",
        rows(
            &|n| n.starts_with("ko-") && (n.ends_with("_id_2.dat") || n.ends_with("_id_3.dat")),
            "t-junction",
        ),
        validate::T_JUNCTION_ARMS,
    );
    let mut widths: Vec<(f64, f64)> = rows(&|_| true, "bottleneck-kretz");
    widths.extend(rows(
        &|n| n == "2009Seyfried.txt" || n == "2006EG.txt",
        "bottleneck-other",
    ));
    for &(b, j, n) in validate::BOTTLENECK {
        let at: Vec<f64> = widths
            .iter()
            .filter(|r| (r.0 - b).abs() < 1e-9)
            .map(|r| r.1)
            .collect();
        assert_eq!(at.len(), n, "bottleneck {b}");
        let m = at.iter().sum::<f64>() / n as f64;
        assert!((m - j).abs() < 6e-5, "bottleneck {b}: {m} against {j}");
    }
}
