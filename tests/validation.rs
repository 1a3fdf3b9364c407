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
