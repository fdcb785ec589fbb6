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
        // 1200 mm in 72 ms: the glitch screen refuses the jump (naming its line) before
        // the bound of a feed axis (100 m) is reached
        &["trace.csv:33:", "the position jumps by 1200 mm"],
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

/// A trace whose positions lie beyond the travel the axis file declares (here 0-40 mm: the
/// stroke goes to 50 mm) is refused naming the line and the travel, before any estimate.
#[test]
fn positions_outside_the_declared_travel_are_refused_naming_the_line() {
    let d = tempfile::tempdir().unwrap();
    write(
        d.path(),
        "axis.toml",
        format!("{AXIS}travel_min_mm = 0\ntravel_max_mm = 40\n").as_bytes(),
    );
    write(d.path(), "trace.csv", good_long_trace().as_bytes());
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
        &[
            "trace.csv:",
            "outside the axis travel [0, 40] mm",
            "travel_max_mm",
        ],
    );
    assert!(!d.path().join("f.csv").exists());
    // within the travel (0-60 mm) the same trace is estimated
    write(
        d.path(),
        "axis.toml",
        format!("{AXIS}travel_min_mm = 0\ntravel_max_mm = 60\n").as_bytes(),
    );
    let mut c = crate::util::feedscope(d.path());
    c.args([
        "estimate",
        "trace.csv",
        "--axis",
        "axis.toml",
        "-o",
        "f.csv",
    ]);
    let o = crate::util::run(c);
    assert!(o.status.success(), "{}", crate::util::stderr(&o));
}

/// A CSV cut off in the middle of its last line (an interrupted copy) is read, with a warning
/// naming the line, and the summary records it: never a silently shorter recording.
#[test]
fn a_cut_csv_is_read_with_a_warning_naming_its_last_line() {
    let d = tempfile::tempdir().unwrap();
    let full = good_long_trace();
    // cut inside the second stroke, in the middle of the value of a row (a cut channel
    // name would be a malformed row, refused naming its line)
    let line_start = full[..full.len() * 3 / 4].rfind('\n').unwrap() + 1;
    let line = &full[line_start..line_start + full[line_start..].find('\n').unwrap()];
    let value_at = line_start + line.rfind(',').unwrap() + 1;
    let cut = &full[..value_at + 2];
    assert!(!cut.ends_with('\n'));
    let last_line = cut.lines().count();
    write(d.path(), "axis.toml", AXIS.as_bytes());
    write(d.path(), "trace.csv", cut.as_bytes());
    let mut c = crate::util::feedscope(d.path());
    c.args([
        "estimate",
        "trace.csv",
        "--axis",
        "axis.toml",
        "-o",
        "f.csv",
    ]);
    let o = crate::util::run(c);
    let err = crate::util::stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains(&format!(
            "warning: trace.csv: the last line (line {last_line}) has no line end"
        )),
        "{err}"
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("f.json")).unwrap()).unwrap();
    assert_eq!(v["unterminated_last_line"], last_line as u64);
    // the whole file has none
    write(d.path(), "trace.csv", full.as_bytes());
    let mut c = crate::util::feedscope(d.path());
    c.args([
        "estimate",
        "trace.csv",
        "--axis",
        "axis.toml",
        "-o",
        "f.csv",
    ]);
    let o = crate::util::run(c);
    assert!(!crate::util::stderr(&o).contains("no line end"));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("f.json")).unwrap()).unwrap();
    assert!(v.get("unterminated_last_line").is_none());
}

/// Issue 34 item 11: a time of −1e-300 after one of 0 is named as it was written, not with
/// 300 zeros.
#[test]
fn a_time_of_minus_1e300_is_named_in_short_form() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "axis.toml", AXIS.as_bytes());
    write(
        d.path(),
        "trace.csv",
        b"time_s,channel,value\n0,position_mm,1\n-1e-300,position_mm,2\n",
    );
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
        &[
            "trace.csv:3:",
            "time -1e-300 s does not come after the previous sample at 0 s",
        ],
    );
}
