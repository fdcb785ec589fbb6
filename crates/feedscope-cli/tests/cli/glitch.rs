//! Position glitches and bad channel names in real files (issue #10): an isolated absurd
//! sample is dropped with a warning naming its time and line, a jump that does not come back
//! and a bad channel name are refused with exit 2 naming the line, and nothing stored is lost.
use std::path::Path;

use crate::estimate::{good_long_trace, AXIS};
use crate::util::{expect_bad_input, feedscope, run, stderr, stdout};

/// Position samples per second of [`wide_500hz`].
const RATE_HZ: f64 = 500.0;

/// A wide trace at 500 Hz: 0.5 s dwell, 0 → 20 mm at 600 mm/min, 0.5 s dwell, back, 0.5 s
/// dwell; current ±0.8 A with a ripple of one screw lead (10 mm). `z` writes the position cell
/// of sample k (position in mm): sample k is on line k + 2.
fn wide_500hz(z: impl Fn(usize, f64) -> String) -> String {
    let pos = |t: f64| -> (f64, f64) {
        match t {
            t if t < 0.5 => (0.0, 0.0),
            t if t < 2.5 => (10.0 * (t - 0.5), 1.0),
            t if t < 3.0 => (20.0, 0.0),
            t if t < 5.0 => (20.0 - 10.0 * (t - 3.0), -1.0),
            _ => (0.0, 0.0),
        }
    };
    let mut s = String::from("time_s,position_mm,current_a\n");
    for k in 0..(5.5 * RATE_HZ) as usize {
        let t = k as f64 / RATE_HZ;
        let (mm, dir) = pos(t);
        let amps = dir * (0.8 + 0.05 * (2.0 * std::f64::consts::PI * mm / 10.0).sin());
        s.push_str(&format!("{t:.6},{},{amps:.6}\n", z(k, mm)));
    }
    s
}

fn plain(_: usize, mm: f64) -> String {
    format!("{mm:.4}")
}

/// The test axis with a rapid rate of 15 m/min: the speed limit is 18.75 m/min.
fn axis_with_rapid() -> String {
    format!("{AXIS}rapid_rate_mm_min = 15000\n")
}

fn setup(dir: &Path, trace: &str) {
    std::fs::write(dir.join("axis.toml"), AXIS).unwrap();
    std::fs::write(dir.join("rapid.toml"), axis_with_rapid()).unwrap();
    std::fs::write(dir.join("trace.csv"), trace).unwrap();
}

/// `estimate --format json` on `trace.csv` in `dir`: exit 0 and the strokes' lengths (mm).
fn stroke_lengths(dir: &Path) -> Vec<f64> {
    let mut c = feedscope(dir);
    c.args([
        "estimate",
        "trace.csv",
        "--axis",
        "axis.toml",
        "-o",
        "f.csv",
        "--format",
        "json",
    ]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    v["strokes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["length_mm"].as_f64().unwrap())
        .collect()
}

/// `analyze trace.csv --axis AXIS`: exit 0, its stderr and the number of strokes analysed.
fn analyze(dir: &Path, axis: &str) -> (String, usize) {
    let mut c = feedscope(dir);
    c.args(["analyze", "trace.csv", "--axis", axis, "--out", "a"]);
    let o = run(c);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("a/analysis.json")).unwrap())
            .unwrap();
    // Analysed strokes and those withheld by the data verdict (a short piece of a split
    // stroke supports no profile) together: the strokes the estimate found.
    let count = |k: &str| json[k].as_array().map_or(0, Vec::len);
    (err, count("strokes") + count("withheld"))
}

#[test]
fn absurd_position_mid_stroke_keeps_the_full_stroke() {
    // The case: one 1e308 in a 20 mm stroke used to cut it to a few mm, silently.
    let d = tempfile::tempdir().unwrap();
    setup(d.path(), &wide_500hz(plain));
    let clean = stroke_lengths(d.path());
    assert_eq!(clean.len(), 2, "{clean:?}");
    // The velocity jumps at once here (no ramp), so the smoothed position needs its settling
    // margins at both ends (a third of the steady time) after its speed has settled.
    assert!(clean.iter().all(|&l| l > 10.0), "{clean:?}");
    // sample 700 (t = 1.4 s, line 702), mid forward stroke
    let glitch = wide_500hz(|k, mm| {
        if k == 700 {
            "1e308".into()
        } else {
            plain(k, mm)
        }
    });
    std::fs::write(d.path().join("trace.csv"), &glitch).unwrap();
    // One sample fewer moves the stroke ends by a few resampling steps (10 µm each) at most.
    let got = stroke_lengths(d.path());
    assert_eq!(got.len(), clean.len(), "{got:?}");
    for (g, c) in got.iter().zip(&clean) {
        assert!((g - c).abs() < 0.05, "{got:?} vs {clean:?}");
    }
    // A command that prints read warnings names the count, the time and the line.
    let (err, strokes) = analyze(d.path(), "axis.toml");
    assert_eq!(strokes, 2);
    assert!(
        err.contains(
            "warning: trace.csv: dropped 1 position sample as a logger glitch (an isolated \
             jump beyond 200000 mm/min and back) at t = 1.4 s (line 702)"
        ),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn five_mm_spike_at_500_hz_is_dropped_with_the_axis_rapid_rate() {
    let d = tempfile::tempdir().unwrap();
    let spike = wide_500hz(|k, mm| plain(k, if k == 700 { mm + 5.0 } else { mm }));
    setup(d.path(), &spike);
    // 5 mm in 2 ms is 150 m/min: within the default 200 m/min, so it splits the stroke ...
    let (err, strokes) = analyze(d.path(), "axis.toml");
    assert!(!err.contains("warning: trace.csv: dropped"), "{err}");
    assert_eq!(strokes, 3);
    // ... but far above 1.25 × the axis' 15 m/min rapid rate: dropped, named, stroke whole.
    let (err, strokes) = analyze(d.path(), "rapid.toml");
    assert!(
        err.contains("dropped 1 position sample")
            && err.contains("beyond 18750 mm/min")
            && err.contains("at t = 1.4 s (line 702)"),
        "{err}"
    );
    assert_eq!(strokes, 2);
    // estimate: the same warning, the sample in the JSON summary, two whole strokes
    let mut c = feedscope(d.path());
    c.args([
        "estimate",
        "trace.csv",
        "--axis",
        "rapid.toml",
        "-o",
        "f.csv",
    ]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("at t = 1.4 s (line 702)"),
        "{}",
        stderr(&o)
    );
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.path().join("f.json")).unwrap()).unwrap();
    assert_eq!(json["strokes"].as_array().unwrap().len(), 2);
    assert_eq!(json["dropped_position_samples"][0]["line"], 702);
    assert!((json["max_axis_speed_mm_min"].as_f64().unwrap() - 18750.0).abs() < 1e-6);
    // history add reads the same way and says so too
    let mut c = feedscope(d.path());
    c.args([
        "history",
        "--db",
        "h.db",
        "add",
        "--kind",
        "strokes",
        "--axis",
        "rapid.toml",
        "trace.csv",
        "--time",
        "2026-01-12T08:00:00Z",
    ]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("at t = 1.4 s (line 702)"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn several_glitches_are_counted_and_the_first_named() {
    let d = tempfile::tempdir().unwrap();
    let bad = [300, 700, 701, 1200, 1800, 2000, 2300];
    setup(
        d.path(),
        &wide_500hz(|k, mm| {
            if bad.contains(&k) {
                "-99999".into()
            } else {
                plain(k, mm)
            }
        }),
    );
    let (err, strokes) = analyze(d.path(), "axis.toml");
    assert_eq!(strokes, 2);
    assert!(
        err.contains(
            "dropped 7 position samples as logger glitches (isolated jumps beyond 200000 \
             mm/min and back) at t = 0.6 s (line 302), 1.4 s (line 702), 1.402 s (line 703), \
             2.4 s (line 1202), 3.6 s (line 1802) and 2 more"
        ),
        "{err}"
    );
    // one warning line, not one per sample
    assert_eq!(err.matches("warning: trace.csv").count(), 1, "{err}");
}

#[test]
fn jump_that_does_not_come_back_is_refused() {
    let d = tempfile::tempdir().unwrap();
    // from sample 900 (t = 1.8 s, line 902) on, 50 mm further: a re-homing or joined files
    let jump = wide_500hz(|k, mm| plain(k, if k >= 900 { mm + 50.0 } else { mm }));
    setup(d.path(), &jump);
    let needles = [
        "trace.csv:902:",
        "jumps by 50.02 mm",
        "between t = 1.798 s and t = 1.8 s",
        "1500600 mm/min",
        "does not come back",
    ];
    let estimate = [
        "estimate",
        "trace.csv",
        "--axis",
        "axis.toml",
        "-o",
        "f.csv",
    ];
    expect_bad_input(d.path(), &estimate, &needles);
    expect_bad_input(d.path(), &estimate, &["above the limit of 200000 mm/min"]);
    assert!(!d.path().join("f.csv").exists());
    let analyze = ["analyze", "trace.csv", "--axis", "rapid.toml", "--out", "a"];
    expect_bad_input(d.path(), &analyze, &needles);
    expect_bad_input(d.path(), &analyze, &["above the limit of 18750 mm/min"]);
    // nothing already stored is lost: a good test stays, the bad one is not added
    std::fs::write(d.path().join("good.csv"), wide_500hz(plain)).unwrap();
    let add = |trace: &str, time: &str| {
        let mut c = feedscope(d.path());
        c.args([
            "history",
            "--db",
            "h.db",
            "add",
            "--kind",
            "strokes",
            "--axis",
            "rapid.toml",
            trace,
            "--time",
            time,
        ]);
        run(c)
    };
    let o = add("good.csv", "2026-01-12T08:00:00Z");
    assert!(o.status.success(), "{}", stderr(&o));
    let o = add("trace.csv", "2026-01-13T08:00:00Z");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("trace.csv:902:"), "{}", stderr(&o));
    let mut c = feedscope(d.path());
    c.args(["history", "--db", "h.db", "list", "--format", "json"]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let sources: Vec<&str> = v
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["source"].as_str().unwrap())
        .collect();
    assert_eq!(sources, ["good.csv"]);
}

/// The long-layout trace of the estimate tests with `row` inserted after line 100.
fn long_with_row(row: &str) -> String {
    let mut out = String::new();
    for (k, l) in good_long_trace().lines().enumerate() {
        out.push_str(l);
        out.push('\n');
        if k + 1 == 100 {
            out.push_str(row);
            out.push('\n');
        }
    }
    out
}

#[test]
fn million_character_channel_name_is_refused_naming_the_line() {
    let d = tempfile::tempdir().unwrap();
    setup(
        d.path(),
        &long_with_row(&format!("3.5,{},1.0", "x".repeat(1_000_000))),
    );
    let args = [
        "estimate",
        "trace.csv",
        "--axis",
        "axis.toml",
        "-o",
        "f.csv",
    ];
    expect_bad_input(
        d.path(),
        &args,
        &["trace.csv:101:", "channel name", "1000000 bytes long"],
    );
    // the message quotes the name, shortened
    let mut c = feedscope(d.path());
    c.args(args);
    let err = stderr(&run(c));
    assert!(err.len() < 1000, "{} bytes of stderr", err.len());
}

#[test]
fn control_character_in_a_channel_name_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let args = [
        "estimate",
        "trace.csv",
        "--axis",
        "axis.toml",
        "-o",
        "f.csv",
    ];
    // an escape sequence in the long layout's channel name: named, and not sent to the terminal
    setup(d.path(), &long_with_row("3.5,speed\u{1b}[2J,1.0"));
    expect_bad_input(
        d.path(),
        &args,
        &["trace.csv:101:", "U+001B", "speed\\u{1b}[2J"],
    );
    let mut c = feedscope(d.path());
    c.args(args);
    assert!(!stderr(&run(c)).contains('\u{1b}'));
    // a wide header column
    let wide = wide_500hz(plain).replacen("current_a", "current_a,no\u{7}te", 1);
    let wide: String = wide
        .lines()
        .enumerate()
        .map(|(k, l)| if k == 0 { l.to_string() } else { format!("{l},") } + "\n")
        .collect();
    std::fs::write(d.path().join("trace.csv"), wide).unwrap();
    expect_bad_input(d.path(), &args, &["trace.csv:1:", "bad header", "U+0007"]);
}
