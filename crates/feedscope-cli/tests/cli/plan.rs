//! `feedscope plan`: golden G-code for both dialects and both tests, limits, printed timing.
use std::path::Path;

use crate::util::{feedscope, run, stderr, stdout};

const AXIS: &str = "name = \"test Z\"\nlead_mm = 10\ntable_mass_kg = 300\n\
    inertia_kgm2 = 0.002\ndamping_nms_per_rad = 0\ntorque_constant_nm_per_a = 1.5\n\
    travel_min_mm = 0\ntravel_max_mm = 410\n";

fn plan(dir: &Path, args: &[&str]) -> std::process::Output {
    std::fs::write(dir.join("axis.toml"), AXIS).unwrap();
    let mut c = feedscope(dir);
    c.arg("plan").args(args);
    run(c)
}

fn gcode(args: &[&str]) -> String {
    let d = tempfile::tempdir().unwrap();
    let o = plan(d.path(), args);
    assert!(o.status.success(), "{}", stderr(&o));
    std::fs::read_to_string(d.path().join("test.nc")).unwrap()
}

const STROKES: &[&str] = &[
    "strokes",
    "--axis",
    "axis.toml",
    "--from",
    "0",
    "--to",
    "410",
    "--feeds",
    "5,20,80",
    "--repeats",
    "3",
    "--dwell-s",
    "1",
    "-o",
    "test.nc",
];

const TRIANGLE: &[&str] = &[
    "triangle",
    "--axis",
    "axis.toml",
    "--from",
    "40",
    "--to",
    "160",
    "--feed-max",
    "8000",
    "--levels",
    "6",
    "--sample-rate-hz",
    "1000",
    "-o",
    "test.nc",
];

#[test]
fn strokes_fanuc_golden() {
    insta::assert_snapshot!("plan_strokes_fanuc", gcode(STROKES));
}

#[test]
fn strokes_siemens_golden() {
    let mut a = STROKES.to_vec();
    a.extend(["--dialect", "siemens"]);
    insta::assert_snapshot!("plan_strokes_siemens", gcode(&a));
}

#[test]
fn triangle_fanuc_mill_golden() {
    let mut a = TRIANGLE.to_vec();
    a.extend([
        "--fanuc-machine",
        "mill",
        "--axis-letter",
        "Y",
        "--program-number",
        "4242",
    ]);
    insta::assert_snapshot!("plan_triangle_fanuc_mill", gcode(&a));
}

#[test]
fn triangle_siemens_golden() {
    let mut a = TRIANGLE.to_vec();
    a.extend(["--dialect", "siemens"]);
    insta::assert_snapshot!("plan_triangle_siemens", gcode(&a));
}

/// The printed run time is the hand calculation of paper 000's test (see the library test
/// `run_time_matches_hand_calculation`): 38 763.0 s, and ⌊38 763.0105/0.072⌋ + 1 samples.
#[test]
fn prints_run_time_and_samples() {
    let d = tempfile::tempdir().unwrap();
    let o = plan(d.path(), STROKES);
    let out = stdout(&o);
    assert!(out.contains("expected run time 38763.0 s"), "{out}");
    assert!(
        out.contains("expected samples per channel 538376 at 72.000 ms"),
        "{out}"
    );
    let mut a = STROKES.to_vec();
    a.extend(["--format", "json"]);
    let o = plan(d.path(), &a);
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["moves"].as_array().unwrap().len(), 18);
    assert_eq!(v["samples_per_channel"], 538376);
}

#[test]
fn travel_limit_from_axis_file_is_enforced() {
    let d = tempfile::tempdir().unwrap();
    let mut a = STROKES.to_vec();
    a[6] = "420";
    let o = plan(d.path(), &a);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("travel_max_mm = 410"), "{}", stderr(&o));
    assert!(!d.path().join("test.nc").exists());
    // a flag overrides the file
    a.extend(["--travel-max", "500"]);
    assert!(plan(d.path(), &a).status.success());
}

#[test]
fn feed_limit_is_enforced() {
    let d = tempfile::tempdir().unwrap();
    let mut a = STROKES.to_vec();
    a.extend(["--feed-limit", "50"]);
    let o = plan(d.path(), &a);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("feed limit"), "{}", stderr(&o));
}

#[test]
fn triangle_window_outside_travel_names_the_limit() {
    let d = tempfile::tempdir().unwrap();
    let mut a = TRIANGLE.to_vec();
    a[4] = "-5";
    let o = plan(d.path(), &a);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("travel_min_mm"), "{}", stderr(&o));
}

#[test]
fn plan_help() {
    for sub in ["strokes", "triangle"] {
        let d = tempfile::tempdir().unwrap();
        let mut c = feedscope(d.path());
        c.args(["plan", sub, "--help"]);
        let o = run(c);
        assert!(o.status.success());
        insta::assert_snapshot!(format!("plan_{sub}_help"), stdout(&o));
    }
}

#[test]
fn approach_feed_is_used_and_limited() {
    let mut a = STROKES.to_vec();
    a.extend(["--approach-feed", "500"]);
    assert!(gcode(&a).contains("\nG01 Z0.000 F500.0\nG04 P1000\n"));
    let d = tempfile::tempdir().unwrap();
    a.extend(["--feed-limit", "100"]);
    let o = plan(d.path(), &a);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("feed limit"), "{}", stderr(&o));
}
