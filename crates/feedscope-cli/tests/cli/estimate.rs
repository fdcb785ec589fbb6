//! `feedscope estimate`: good runs, golden headers, and real malformed files.
use std::path::Path;

use crate::util::{feedscope, run, stderr, stdout};

pub const AXIS: &str = "name = \"test Z\"\nlead_mm = 10\ntable_mass_kg = 300\n\
    inertia_kgm2 = 0.002\ndamping_nms_per_rad = 0\ntorque_constant_nm_per_a = 1.5\n";

/// Forward 0→50 mm and back at 100 mm/min, 72 ms position and 71 ms current sampling.
pub fn good_long_trace() -> String {
    let z = |t: f64| -> f64 {
        if t < 1.0 {
            0.0
        } else if t < 31.0 {
            100.0 * (t - 1.0) / 60.0
        } else if t < 32.0 {
            50.0
        } else if t < 62.0 {
            50.0 - 100.0 * (t - 32.0) / 60.0
        } else {
            0.0
        }
    };
    let mut rows: Vec<(f64, String)> = Vec::new();
    let mut t = 0.0;
    while t < 63.0 {
        rows.push((t, format!("{t:.6},position_mm,{:.3}", z(t))));
        t += 0.072;
    }
    let mut t = 0.03;
    while t < 63.0 {
        let v = if t > 1.0 && t < 31.0 {
            1.0
        } else if t > 32.0 && t < 62.0 {
            -1.0
        } else {
            0.0
        };
        let f = v * (200.0 + 10.0 * (2.0 * std::f64::consts::PI * 3.0 * z(t) / 10.0).sin());
        let amps = f / (2.0 * std::f64::consts::PI / 0.01) / 1.5;
        rows.push((t, format!("{t:.6},current_a,{amps:.6}")));
        t += 0.071;
    }
    rows.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut s = String::from("# made by the test suite\ntime_s,channel,value\n");
    for (_, r) in rows {
        s.push_str(&r);
        s.push('\n');
    }
    s
}

fn setup(dir: &Path, trace: &[u8]) {
    std::fs::write(dir.join("axis.toml"), AXIS).unwrap();
    std::fs::write(dir.join("trace.csv"), trace).unwrap();
}

#[test]
fn estimate_writes_csv_json_svg() {
    let d = tempfile::tempdir().unwrap();
    setup(d.path(), good_long_trace().as_bytes());
    let mut c = feedscope(d.path());
    c.args([
        "estimate",
        "trace.csv",
        "--axis",
        "axis.toml",
        "-o",
        "f.csv",
    ]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = std::fs::read_to_string(d.path().join("f.csv")).unwrap();
    let header = csv.lines().next().unwrap();
    insta::assert_snapshot!("estimate_csv_header", header);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("f.json")).unwrap()).unwrap();
    let strokes = json["strokes"].as_array().unwrap();
    assert_eq!(strokes.len(), 2);
    assert_eq!(strokes[0]["direction"], "forward");
    assert_eq!(strokes[1]["direction"], "backward");
    // The mean of 200 N + a 3-per-lead ripple over whole leads is 200 N (±0.5 N: the stroke
    // is not an integer number of ripple periods).
    let m0 = strokes[0]["mean_friction_n"].as_f64().unwrap();
    let m1 = strokes[1]["mean_friction_n"].as_f64().unwrap();
    assert!(
        (m0 - 200.0).abs() < 0.5 && (m1 + 200.0).abs() < 0.5,
        "{m0} {m1}"
    );
    let mut keys: Vec<&String> = strokes[0].as_object().unwrap().keys().collect();
    keys.sort();
    insta::assert_snapshot!("estimate_summary_stroke_keys", format!("{keys:?}"));
    let svg = std::fs::read_to_string(d.path().join("f.svg")).unwrap();
    assert!(svg.contains("position (mm)"));
    assert!(stdout(&o).contains("forward"));
}

#[test]
fn estimate_json_format_on_stdout() {
    let d = tempfile::tempdir().unwrap();
    setup(d.path(), good_long_trace().as_bytes());
    let mut c = feedscope(d.path());
    c.args([
        "estimate",
        "trace.csv",
        "--axis",
        "axis.toml",
        "-o",
        "f.csv",
        "--format",
        "json",
        "--no-plot",
    ]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["strokes"].as_array().unwrap().len(), 2);
    assert!(!d.path().join("f.svg").exists());
}

/// Run estimate on `trace` (and `axis`), expect exit 2, every `needles` in stderr, and no
/// output files; an earlier good output must survive.
fn expect_bad(trace: &[u8], axis: Option<&str>, needles: &[&str]) {
    let d = tempfile::tempdir().unwrap();
    setup(d.path(), trace);
    if let Some(a) = axis {
        std::fs::write(d.path().join("axis.toml"), a).unwrap();
    }
    std::fs::write(d.path().join("f.csv"), "earlier result\n").unwrap();
    let mut c = feedscope(d.path());
    c.args([
        "estimate",
        "trace.csv",
        "--axis",
        "axis.toml",
        "-o",
        "f.csv",
    ]);
    let o = run(c);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "stderr: {err}");
    for n in needles {
        assert!(err.contains(n), "`{n}` not in: {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
    let mut names: Vec<String> = std::fs::read_dir(d.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["axis.toml", "f.csv", "trace.csv"], "leftover files");
    assert_eq!(
        std::fs::read_to_string(d.path().join("f.csv")).unwrap(),
        "earlier result\n"
    );
}

fn replace_line(s: &str, line_no: usize, with: &str) -> String {
    s.lines()
        .enumerate()
        .map(|(k, l)| if k + 1 == line_no { with } else { l })
        .collect::<Vec<_>>()
        .join("\n")
        + "\n"
}

#[test]
fn bad_empty_file() {
    expect_bad(b"", None, &["trace.csv", "no header"]);
}

#[test]
fn bad_only_comments() {
    expect_bad(b"# nothing here\n\n# still nothing\n", None, &["no header"]);
}

#[test]
fn bad_header_without_time() {
    expect_bad(
        b"t,channel,value\n0,position_mm,1\n",
        None,
        &["trace.csv:1", "time_s"],
    );
}

#[test]
fn bad_non_numeric_value() {
    let s = replace_line(&good_long_trace(), 40, "2.0,position_mm,1.2.3");
    expect_bad(
        s.as_bytes(),
        None,
        &["trace.csv:40", "value", "1.2.3", "not a number"],
    );
}

#[test]
fn bad_nan_value() {
    let s = replace_line(&good_long_trace(), 41, "2.0,current_a,NaN");
    expect_bad(s.as_bytes(), None, &["trace.csv:41", "not finite"]);
}

#[test]
fn bad_infinite_time() {
    let s = replace_line(&good_long_trace(), 42, "inf,current_a,0.1");
    expect_bad(s.as_bytes(), None, &["trace.csv:42", "time", "not finite"]);
}

#[test]
fn bad_time_backwards() {
    let s = good_long_trace();
    let lines: Vec<&str> = s.lines().collect();
    // Put an early position sample late in the file.
    let mut out: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
    out.insert(100, "0.5,position_mm,0".into());
    let s = out.join("\n") + "\n";
    expect_bad(
        s.as_bytes(),
        None,
        &["trace.csv:101", "position", "strictly increase"],
    );
}

#[test]
fn bad_time_repeated() {
    let s = good_long_trace();
    let mut lines: Vec<String> = s.lines().map(String::from).collect();
    let dup = lines[50].clone();
    lines.insert(51, dup);
    let s = lines.join("\n") + "\n";
    expect_bad(s.as_bytes(), None, &["trace.csv:52", "does not come after"]);
}

#[test]
fn bad_missing_current() {
    let s: String = good_long_trace()
        .lines()
        .filter(|l| !l.contains("current_a"))
        .map(|l| format!("{l}\n"))
        .collect();
    expect_bad(
        s.as_bytes(),
        None,
        &["current_a", "channels seen: position"],
    );
}

#[test]
fn bad_missing_position_with_typo() {
    let s = good_long_trace().replace("position_mm", "positon_mm");
    expect_bad(s.as_bytes(), None, &["position_mm", "positon_mm"]);
}

#[test]
fn bad_too_few_samples() {
    expect_bad(
        b"time_s,position_mm,current_a\n0,0,1\n1,1,1\n2,2,1\n",
        None,
        &["3 samples", "at least 4"],
    );
}

#[test]
fn bad_axis_never_moves() {
    let mut s = String::from("time_s,position_mm,current_a\n");
    for k in 0..100 {
        s.push_str(&format!("{},12.5,0.3\n", k as f64 * 0.07));
    }
    expect_bad(s.as_bytes(), None, &["never moves"]);
}

#[test]
fn bad_field_count() {
    let s = replace_line(&good_long_trace(), 30, "1.9,current_a,0.1,7");
    expect_bad(
        s.as_bytes(),
        None,
        &["trace.csv:30", "expected 3", "found 4"],
    );
}

#[test]
fn bad_truncated_last_line() {
    let mut s = good_long_trace();
    s.push_str("63.5,position_m");
    expect_bad(s.as_bytes(), None, &["expected 3", "found 2"]);
}

#[test]
fn bad_ambiguous_effort() {
    let mut s = String::from("time_s,position_mm,current_a,torque_nm\n");
    for k in 0..100 {
        s.push_str(&format!("{},{},0.3,0.5\n", k as f64 * 0.07, k));
    }
    expect_bad(s.as_bytes(), None, &["both `current_a` and `torque_nm`"]);
}

#[test]
fn bad_binary_garbage() {
    let bytes: Vec<u8> = (0..4096u32)
        .map(|k| (k.wrapping_mul(2_654_435_761) >> 13) as u8)
        .collect();
    expect_bad(&bytes, None, &["trace.csv"]);
}

#[test]
fn bad_no_steady_stroke() {
    // Moves, but only a 0.5 mm wiggle: no stroke of at least 1 mm.
    let mut s = String::from("time_s,position_mm,current_a\n");
    for k in 0..200 {
        let t = k as f64 * 0.07;
        s.push_str(&format!("{t},{},0.3\n", 0.25 * (t).sin()));
    }
    expect_bad(s.as_bytes(), None, &["no steady stroke"]);
}

#[test]
fn bad_axis_negative_lead() {
    expect_bad(
        good_long_trace().as_bytes(),
        Some(&AXIS.replace("lead_mm = 10", "lead_mm = -10")),
        &["axis.toml", "lead_mm", "greater than zero"],
    );
}

#[test]
fn bad_axis_zero_torque_constant() {
    expect_bad(
        good_long_trace().as_bytes(),
        Some(&AXIS.replace(
            "torque_constant_nm_per_a = 1.5",
            "torque_constant_nm_per_a = 0",
        )),
        &["torque_constant_nm_per_a"],
    );
}

#[test]
fn bad_axis_missing_key() {
    expect_bad(
        good_long_trace().as_bytes(),
        Some(&AXIS.replace("table_mass_kg = 300\n", "")),
        &["axis.toml", "table_mass_kg"],
    );
}

#[test]
fn bad_axis_not_toml() {
    expect_bad(
        good_long_trace().as_bytes(),
        Some("lead_mm = = 3\n"),
        &["axis.toml"],
    );
}

#[test]
fn missing_trace_file_is_exit_2() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("axis.toml"), AXIS).unwrap();
    let mut c = feedscope(d.path());
    c.args(["estimate", "nope.csv", "--axis", "axis.toml"]);
    let o = run(c);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("nope.csv"));
}

#[test]
fn wide_layout_and_bare_cr_work() {
    let d = tempfile::tempdir().unwrap();
    let mut s = String::from("time_s,position_mm,torque_nm\r");
    for k in 0..2000 {
        let t = k as f64 * 0.01;
        let z = if t < 1.0 { 0.0 } else { 2.0 * (t - 1.0) };
        let tq = if t > 1.0 {
            100.0 * 0.01 / (2.0 * std::f64::consts::PI)
        } else {
            0.0
        };
        s.push_str(&format!("{t},{z},{tq}\r"));
    }
    setup(d.path(), s.as_bytes());
    let mut c = feedscope(d.path());
    c.args([
        "estimate",
        "trace.csv",
        "--axis",
        "axis.toml",
        "-o",
        "f.csv",
        "--no-plot",
    ]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = std::fs::read_to_string(d.path().join("f.csv")).unwrap();
    assert!(csv.starts_with(
        "stroke,direction,position_mm,time_s,velocity_mm_s,accel_mm_s2,torque_nm,friction_n"
    ));
    // 100 N constant friction from torque, without k_e (a constant effort reads as coarsely
    // quantised: the stroke's one mean-level row, or its profile's rows, carry it).
    let f: f64 = csv
        .lines()
        .nth(1)
        .unwrap()
        .rsplit(',')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!((f - 100.0).abs() < 1e-3, "{f}");
}

#[test]
fn help_is_stable() {
    let d = tempfile::tempdir().unwrap();
    let mut c = feedscope(d.path());
    c.args(["estimate", "--help"]);
    let o = run(c);
    assert!(o.status.success());
    insta::assert_snapshot!("estimate_help", stdout(&o));
}

/// Found by fuzzing: printing into a closed pipe (`feedscope estimate ... | head -1`) panicked
/// with exit 101 after the outputs were written. The reader leaving is not an error: exit 0, no
/// panic message, the outputs complete.
#[test]
fn closed_stdout_ends_quietly() {
    let d = tempfile::tempdir().unwrap();
    setup(d.path(), good_long_trace().as_bytes());
    let mut c = feedscope(d.path());
    c.args([
        "estimate",
        "trace.csv",
        "--axis",
        "axis.toml",
        "-o",
        "f.csv",
    ])
    .stdout(std::process::Stdio::piped())
    .stderr(std::process::Stdio::piped());
    let mut child = c.spawn().unwrap();
    // Close the read end before the child prints its table.
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(d.path().join("f.json").exists() && d.path().join("f.svg").exists());
}

/// A current counted against the position (negated here): `estimate` says so in the verdict
/// (`effort-sign-reversed`, in its printed verdict too) and `--effort-sign negated` gives back, to the
/// last printed digit, the friction of the correctly signed trace.
#[test]
fn effort_counted_against_the_position() {
    let d = tempfile::tempdir().unwrap();
    let good = good_long_trace();
    let negated: String = good
        .lines()
        .map(|l| match l.split_once(",current_a,") {
            Some((t, v)) => format!("{t},current_a,{}\n", -v.parse::<f64>().unwrap()),
            None => format!("{l}\n"),
        })
        .collect();
    setup(d.path(), good.as_bytes());
    std::fs::write(d.path().join("neg.csv"), negated).unwrap();
    let est = |trace: &str, out: &str, extra: &[&str]| {
        let mut c = feedscope(d.path());
        c.args(["estimate", trace, "--axis", "axis.toml", "-o", out]);
        c.args(extra);
        let o = run(c);
        assert!(o.status.success(), "{}", stderr(&o));
        let json: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(d.path().join(out.replace(".csv", ".json"))).unwrap(),
        )
        .unwrap();
        // No `reasons` key when there are none.
        let codes: Vec<String> = json["verdict"]["reasons"]
            .as_array()
            .map(|rs| {
                rs.iter()
                    .map(|r| r["code"].as_str().unwrap().to_string())
                    .collect()
            })
            .unwrap_or_default();
        let csv = std::fs::read_to_string(d.path().join(out)).unwrap();
        (codes, csv, format!("{}{}", stdout(&o), stderr(&o)))
    };
    let (codes, right, _) = est("trace.csv", "right.csv", &[]);
    assert!(
        !codes.contains(&"effort-sign-reversed".to_string()),
        "{codes:?}"
    );
    let (codes, _, err) = est("neg.csv", "wrong.csv", &[]);
    assert!(
        codes.contains(&"effort-sign-reversed".to_string()),
        "{codes:?}"
    );
    assert!(err.contains("--effort-sign negated"), "{err}");
    let (codes, turned, _) = est("neg.csv", "turned.csv", &["--effort-sign", "negated"]);
    assert!(
        !codes.contains(&"effort-sign-reversed".to_string()),
        "{codes:?}"
    );
    // Every column as printed, but the current, which is the file's own (negated) one.
    let (r, t): (Vec<&str>, Vec<&str>) = (right.lines().collect(), turned.lines().collect());
    assert_eq!(r.len(), t.len());
    assert_eq!(r[0], t[0]);
    let current = r[0].split(',').position(|c| c == "current_a").unwrap();
    for (lr, lt) in r[1..].iter().zip(&t[1..]) {
        let (fr, ft): (Vec<&str>, Vec<&str>) = (lr.split(',').collect(), lt.split(',').collect());
        for (k, (a, b)) in fr.iter().zip(&ft).enumerate() {
            if k == current {
                let (a, b): (f64, f64) = (a.parse().unwrap(), b.parse().unwrap());
                assert!((a + b).abs() <= 1e-6, "current {a} against {b}");
            } else {
                assert_eq!(a, b, "column {k}: {lr} against {lt}");
            }
        }
    }
}

/// `pairs` forward and backward strokes of 20 mm at 200 mm/min with 1 s dwells, 72 ms
/// position and 71 ms current sampling (200 N of friction with a 10 N ripple), after the header lines `facts`.
fn many_strokes_trace(pairs: usize, facts: &str) -> String {
    let (len, v, dwell) = (20.0, 200.0 / 60.0, 1.0);
    let leg = len / v + dwell;
    let end = 2.0 * pairs as f64 * leg + dwell;
    // Position (mm) and velocity sign at t: dwell, move, dwell, move back ...
    let at = |t: f64| -> (f64, f64) {
        let k = (t / leg).floor();
        let u = t - k * leg;
        let back = k as usize % 2 == 1;
        if t >= end - dwell || u < dwell {
            (if back { len } else { 0.0 }, 0.0)
        } else if back {
            (len - v * (u - dwell), -1.0)
        } else {
            (v * (u - dwell), 1.0)
        }
    };
    let mut rows: Vec<(f64, String)> = Vec::new();
    let mut t = 0.0;
    while t < end {
        rows.push((t, format!("{t:.6},position_mm,{:.3}", at(t).0)));
        t += 0.072;
    }
    let mut t = 0.03;
    while t < end {
        // A 3-per-lead ripple of 10 N: a constant effort reads as coarsely quantised.
        let (z, sign) = at(t);
        let f = sign * (200.0 + 10.0 * (2.0 * std::f64::consts::PI * 3.0 * z / 10.0).sin());
        let amps = f / (2.0 * std::f64::consts::PI / 0.01) / 1.5;
        rows.push((t, format!("{t:.6},current_a,{amps:.6}")));
        t += 0.071;
    }
    rows.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut s = format!("{facts}time_s,channel,value\n");
    for (_, r) in rows {
        s.push_str(&r);
        s.push('\n');
    }
    s
}

/// Issue 34 item 9: every one of 8 strokes a direction is drawn and counted in the legend (not
/// the first 6), profiles as lines and mean levels as levels; strokes whose data support only
/// their mean level get one CSV row each, which `analyze` reads as no profile.
#[test]
fn every_stroke_is_plotted_and_mean_levels_are_one_csv_row() {
    for (facts, kind) in [
        ("", "friction along the travel"),
        ("# fact process_load = true\n", "mean level only"),
    ] {
        let d = tempfile::tempdir().unwrap();
        setup(d.path(), many_strokes_trace(8, facts).as_bytes());
        let mut c = feedscope(d.path());
        c.args([
            "estimate",
            "trace.csv",
            "--axis",
            "axis.toml",
            "-o",
            "f.csv",
        ]);
        let o = run(c);
        assert!(o.status.success(), "{}", stderr(&o));
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.path().join("f.json")).unwrap())
                .unwrap();
        let strokes = json["strokes"].as_array().unwrap();
        assert_eq!(strokes.len(), 16, "{facts}{}", stderr(&o));
        let svg = std::fs::read_to_string(d.path().join("f.svg")).unwrap();
        for dir in ["forward", "backward"] {
            let entry = format!("{dir}: 8 of 8 strokes, {kind}");
            assert!(svg.contains(&entry), "{entry}");
        }
        let csv = std::fs::read_to_string(d.path().join("f.csv")).unwrap();
        let rows = csv.lines().count() - 1;
        if facts.is_empty() {
            assert!(rows > 16 * 100, "{rows}");
            // Profiles are lines, without level markers.
            assert_eq!(svg.matches("<circle").count(), 0);
        } else {
            assert_eq!(rows, 16, "{csv}");
            for (row, s) in csv.lines().skip(1).zip(strokes) {
                let want = format!("{},{},,,,,,", s["stroke"], s["direction"].as_str().unwrap());
                assert!(row.starts_with(&want), "{row}");
            }
            // One marker per stroke and one per legend entry.
            assert_eq!(svg.matches("<circle").count(), 16 + 2);
            let mut c = feedscope(d.path());
            c.args(["analyze", "f.csv", "--axis", "axis.toml", "--out", "a"]);
            let o = run(c);
            assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
            assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));
        }
    }
}
