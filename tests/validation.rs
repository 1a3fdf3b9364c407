//! The validation suite at its quick size: every case passes with the default pedestrian
//! parameters, the same on 1 and 2 threads, and its failures are reported as failures.

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
fn rimea_06_twenty_pedestrians_go_round_the_corner() {
    passes("rimea-06");
}

#[test]
fn rimea_07_walked_speeds_follow_the_distribution() {
    passes("rimea-07");
}

#[test]
fn rimea_09_two_exits_take_about_twice_as_long_as_four() {
    passes("rimea-09");
}

#[test]
fn rimea_12_no_jam_at_the_last_exit() {
    passes("rimea-12");
}

#[test]
fn rimea_15_the_corner_lies_between_the_straight_corridors() {
    passes("rimea-15");
}

#[test]
fn bottleneck_flow_lies_in_the_experiments_band() {
    passes("bottleneck");
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
