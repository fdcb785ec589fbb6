//! Malformed inputs found by fuzzing (issue #19; `crates/feedscope-fuzz`): each is refused
//! as bad input (exit 2) with a message naming the file and what is wrong, never exit 1,
//! never a silently wrong result.
use std::path::Path;

use crate::estimate::good_long_trace;
use crate::util::expect_bad_input;

const AXIS: &str = "lead_mm = 10\ntable_mass_kg = 100\ninertia_kgm2 = 0.001\n\
                    damping_nms_per_rad = 0.001\ntorque_constant_nm_per_a = 1.5\n";

fn write(dir: &Path, name: &str, bytes: &[u8]) {
    std::fs::write(dir.join(name), bytes).unwrap();
}

/// A text file with one byte that is not UTF-8 in its middle.
fn not_utf8(text: &str) -> Vec<u8> {
    let mut b = text.as_bytes().to_vec();
    b.insert(b.len() / 2, 0xFF);
    b
}

#[test]
fn a_non_utf8_axis_file_is_bad_input() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "trace.csv", good_long_trace().as_bytes());
    write(d.path(), "axis.toml", &not_utf8(AXIS));
    expect_bad_input(
        d.path(),
        &[
            "estimate",
            "trace.csv",
            "--axis",
            "axis.toml",
            "-o",
            "f.csv",
        ],
        &["axis.toml", "UTF-8"],
    );
}

#[test]
fn a_non_utf8_stribeck_table_is_bad_input() {
    let d = tempfile::tempdir().unwrap();
    write(
        d.path(),
        "t.csv",
        &not_utf8("feed_mm_min,force_n\n600,250\n-600,-245\n1200,262\n-1200,-260\n"),
    );
    expect_bad_input(
        d.path(),
        &["fit-stribeck", "t.csv", "--out", "out"],
        &["t.csv", "UTF-8"],
    );
}

#[test]
fn a_non_utf8_friction_csv_is_bad_input() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "axis.toml", AXIS.as_bytes());
    write(
        d.path(),
        "f.csv",
        &not_utf8(
            "stroke,direction,position_mm,time_s,velocity_mm_s,accel_mm_s2,current_a,friction_n\n\
             1,forward,0.000000,0.000000,1.0,0.0,1.0,100.0\n",
        ),
    );
    expect_bad_input(
        d.path(),
        &["analyze", "f.csv", "--axis", "axis.toml", "--out", "b"],
        &["f.csv", "UTF-8"],
    );
}

#[test]
fn one_current_sample_of_1e300_is_refused_naming_its_line() {
    let d = tempfile::tempdir().unwrap();
    let good = good_long_trace();
    // The 40th current row holds 1e300 A.
    let mut seen = 0;
    let bad: String = good
        .lines()
        .enumerate()
        .map(|(k, l)| {
            if l.contains(",current_a,") {
                seen += 1;
                if seen == 40 {
                    let t = l.split(',').next().unwrap();
                    return (k, format!("{t},current_a,1e300\n"));
                }
            }
            (k, format!("{l}\n"))
        })
        .map(|(_, l)| l)
        .collect();
    let line = bad.lines().position(|l| l.ends_with(",1e300")).unwrap() + 1;
    write(d.path(), "axis.toml", AXIS.as_bytes());
    write(d.path(), "trace.csv", bad.as_bytes());
    expect_bad_input(
        d.path(),
        &[
            "estimate",
            "trace.csv",
            "--axis",
            "axis.toml",
            "-o",
            "f.csv",
        ],
        &[&format!("trace.csv:{line}:"), "current_a", "1e300"],
    );
}

#[test]
fn positions_times_1e4_are_refused_before_any_allocation_grows() {
    let d = tempfile::tempdir().unwrap();
    let bad: String = good_long_trace()
        .lines()
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            if f.len() == 3 && f[1] == "position_mm" {
                let v: f64 = f[2].parse().unwrap();
                format!("{},position_mm,{}\n", f[0], v * 1e4)
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    write(d.path(), "axis.toml", AXIS.as_bytes());
    write(d.path(), "trace.csv", bad.as_bytes());
    expect_bad_input(
        d.path(),
        &[
            "estimate",
            "trace.csv",
            "--axis",
            "axis.toml",
            "-o",
            "f.csv",
        ],
        &["trace.csv:", "position", "which no feed axis reaches"],
    );
    assert!(!d.path().join("f.csv").exists());
}

#[test]
fn a_hertz_constant_of_1e308_is_refused_naming_the_key() {
    let d = tempfile::tempdir().unwrap();
    write(
        d.path(),
        "drive.toml",
        b"[nut]\nhertz_constant_n_per_m1_5 = 1e308\n",
    );
    expect_bad_input(
        d.path(),
        &["dynamics", "--config", "drive.toml", "--out", "o"],
        &["nut.hertz_constant_n_per_m1_5", "1e308"],
    );
}

#[test]
fn a_drive_whose_masses_make_no_positive_definite_matrix_is_bad_input() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "drive.toml", b"[screw]\ndensity_kg_m3 = 1e-300\n");
    expect_bad_input(
        d.path(),
        &["dynamics", "--config", "drive.toml", "--out", "o"],
        &["screw.density_kg_m3"],
    );
}

#[test]
fn a_preload_fraction_of_1e300_is_refused_naming_the_key() {
    // Found by the `drive` target: an unbounded key overflowed the stiffness matrix, whose NaN
    // eigenvalues were reported as natural frequencies of 0.0 Hz.
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "drive.toml", b"[nut]\npreload_fraction = 1e300\n");
    expect_bad_input(
        d.path(),
        &["dynamics", "--config", "drive.toml", "--out", "o"],
        &["nut.preload_fraction", "1e300"],
    );
}

#[test]
fn a_subnormal_feed_in_a_stribeck_table_is_refused_naming_its_line() {
    // Found by the `stribeck_table` target: 1e-320 mm/min became 0 m/s and was accepted.
    let d = tempfile::tempdir().unwrap();
    write(
        d.path(),
        "t.csv",
        b"feed_mm_min,force_n\n600,250\n-600,-245\n1e-320,262\n-1200,-260\n",
    );
    expect_bad_input(
        d.path(),
        &["fit-stribeck", "t.csv", "--out", "out"],
        &["t.csv:4:", "1e-320"],
    );
}
