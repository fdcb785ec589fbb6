//! `feedscope plan`: golden G-code for both dialects and both tests, limits, printed timing.
use std::path::Path;

use crate::util::{expect_bad_input, feedscope, run, stderr, stdout};

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

/// The printed run time is the hand calculation of paper 000's test (see the library tests
/// `run_time_follows_the_ramp_shape` and `run_time_matches_hand_calculation`): with the
/// default jerk-limited ramps at 20 m/s³ each stroke takes L/v + 2·√(v/j), 38 763.1715 s
/// in all and ⌊38 763.1715/0.072⌋ + 1 = 538 378 samples; with trapezoid ramps L/v + v/a,
/// 38 763.0105 s and 538 376 samples.
#[test]
fn prints_run_time_and_samples() {
    let d = tempfile::tempdir().unwrap();
    let o = plan(d.path(), STROKES);
    let out = stdout(&o);
    assert!(
        out.contains("expected run time 38763.2 s (646.05 min) at 1000 mm/s², jerk-limited ramps, 20000 mm/s³"),
        "{out}"
    );
    assert!(
        out.contains("expected samples per channel 538378 at 72.000 ms"),
        "{out}"
    );
    let mut a = STROKES.to_vec();
    a.extend(["--format", "json"]);
    let o = plan(d.path(), &a);
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["moves"].as_array().unwrap().len(), 18);
    assert_eq!(v["samples_per_channel"], 538378);
    assert_eq!(v["ramp"], "jerk_limited");
    assert_eq!(v["jerk_mm_s3"], 20000.0);
    let mut a = STROKES.to_vec();
    a.extend(["--ramp", "trapezoid"]);
    let out = stdout(&plan(d.path(), &a));
    assert!(out.contains("expected run time 38763.0 s"), "{out}");
    assert!(out.contains("trapezoid ramps"), "{out}");
    assert!(
        out.contains("expected samples per channel 538376 at"),
        "{out}"
    );
    // a softer jerk lengthens every ramp: 12·(√(5/60/j) + √(20/60/j) + √(80/60/j)) with
    // j = 500 mm/s³ is 1.08 s more than the 18 dwells and cruises
    let mut a = STROKES.to_vec();
    a.extend(["--jerk-mm-s3", "500"]);
    let out = stdout(&plan(d.path(), &a));
    assert!(out.contains("expected run time 38764.1 s"), "{out}");
}

#[test]
fn bad_ramp_options_are_refused() {
    let d = tempfile::tempdir().unwrap();
    for extra in [
        ["--ramp", "bell", "--jerk-mm-s3", "1000"].as_slice(),
        ["--jerk-mm-s3", "0"].as_slice(),
    ] {
        let mut a = STROKES.to_vec();
        a.extend(extra);
        let o = plan(d.path(), &a);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains("--jerk-mm-s3"), "{}", stderr(&o));
        assert!(!d.path().join("test.nc").exists());
    }
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

/// A triangular-wave test planned for an acquisition too slow for its ramps is written with a
/// warning, and the warning is right: the planned program run on the twin (another machine
/// than the check's default drive: 16 mm lead, 600 kg, X axis of a mill) at 72 ms polling is
/// refused by `identify`; planned and sampled at 500 Hz it identifies, without a warning.
#[test]
fn triangle_warns_when_the_acquisition_cannot_identify_it() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path();
    let args = |rate: Option<&'static str>| {
        let mut a = vec![
            "triangle",
            "--from",
            "40",
            "--to",
            "160",
            "--feed-max",
            "6000",
            "--fanuc-machine",
            "mill",
            "--axis-letter",
            "X",
            "--accel-mm-s2",
            "1500",
            "--jerk-mm-s3",
            "30000",
            "--format",
            "json",
            "-o",
            "test.nc",
        ];
        if let Some(r) = rate {
            a.extend(["--sample-rate-hz", r]);
        }
        a
    };
    let simulate_and_identify = |sampling: &str| {
        let cfg = format!(
            "seed = 11\n[axis]\nlead_mm = 16.0\ntable_mass_kg = 600.0\ninertia_kgm2 = 0.0025\n\
             damping_nms_per_rad = 0.0015\ntorque_constant_nm_per_a = 1.1\n\
             rapid_rate_mm_min = 24000.0\n[motion]\nstart_mm = 100.0\n\
             acceleration_mm_s2 = 1500.0\njerk_mm_s3 = 30000.0\nprogram_axis = \"X\"\n\
             program_file = \"test.nc\"\n[sampling]\n{sampling}\n[truth]\ninterval_ms = 100.0\n"
        );
        std::fs::write(dir.join("sim.toml"), cfg).unwrap();
        let mut c = feedscope(dir);
        c.args(["simulate", "--config", "sim.toml", "--out", "s"]);
        let o = run(c);
        assert!(o.status.success(), "{}", stderr(&o));
        let mut c = feedscope(dir);
        c.args([
            "identify",
            "s/trace.csv",
            "--axis",
            "s/axis.toml",
            "-o",
            "id",
        ]);
        run(c)
    };

    let o = plan(dir, &args(None));
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("at 72.000 ms per sample (13.9 Hz) this test cannot be identified")
            && err.contains("72 ms polling was assumed")
            && err.contains("identifies J from about"),
        "{err}"
    );
    let json: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(json["warnings"].as_array().unwrap().len(), 1, "{json:#}");
    let o = simulate_and_identify("mode = \"asynchronous\"");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("not identifiable"), "{}", stderr(&o));

    let o = plan(dir, &args(Some("500")));
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));
    let json: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert!(json["warnings"].as_array().unwrap().is_empty(), "{json:#}");
    let o = simulate_and_identify("mode = \"synchronous\"\nsynchronous_rate_hz = 500.0");
    assert!(o.status.success(), "{}", stderr(&o));
}

/// A sampling interval that is no interval is refused naming the option, and nothing is written.
#[test]
fn bad_sample_interval_is_refused() {
    let d = tempfile::tempdir().unwrap();
    for ms in ["0", "-72", "NaN"] {
        let opt = format!("--sample-interval-ms={ms}");
        expect_bad_input(
            d.path(),
            &[
                "plan",
                "triangle",
                "--from",
                "0",
                "--to",
                "200",
                "--feed-max",
                "3000",
                &opt,
                "-o",
                "t.nc",
            ],
            &["--sample-interval-ms", "must be > 0"],
        );
        assert!(!d.path().join("t.nc").exists());
    }
}
