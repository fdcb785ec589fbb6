//! `feedscope simulate`: files, headers, bad input.
use std::path::Path;

use crate::util::{feedscope, run, stderr, stdout};

/// A short program (0 → 5 mm at 600 mm/min) so the debug binary finishes quickly.
const SHORT: &str = "seed = 7\n\
[motion]\nlead_in_s = 0.2\nlead_out_s = 0.2\n\
[[motion.stroke]]\nto_mm = 5\nfeed_mm_min = 600\n";

fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn first_line(p: &Path) -> String {
    std::fs::read_to_string(p)
        .unwrap()
        .lines()
        .next()
        .unwrap_or_default()
        .to_string()
}

#[test]
fn writes_four_files_with_documented_headers() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write(tmp.path(), "sim.toml", SHORT);
    let mut c = feedscope(tmp.path());
    c.args(["simulate", "--config"])
        .arg(&cfg)
        .args(["--out", "out"]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = tmp.path().join("out");
    assert_eq!(first_line(&out.join("trace.csv")), "time_s,channel,value");
    assert_eq!(
        first_line(&out.join("truth.csv")),
        "time_s,position_mm,velocity_mm_s,accel_mm_s2,friction_n"
    );
    // axis.toml is a valid axis file for `feedscope estimate --axis`
    let axis_text = std::fs::read_to_string(out.join("axis.toml")).unwrap();
    let axis = feedscope::axis::AxisParams::parse(
        &axis_text,
        feedscope::axis::ConfigFormat::Toml,
        "axis.toml",
    )
    .unwrap();
    assert!((axis.lead_mm - 10.0).abs() < 1e-12);
    // truth.json holds the model and the strokes
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("truth.json")).unwrap()).unwrap();
    assert!(
        json["friction"]["params"]["component"]
            .as_array()
            .unwrap()
            .len()
            >= 8
    );
    assert_eq!(json["strokes"][0]["direction"], "forward");
    assert!((json["strokes"][0]["end_mm"].as_f64().unwrap() - 5.0).abs() < 1e-12);
    // no temporary file left behind
    let names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), 4, "{names:?}");
}

#[test]
fn seed_changes_the_trace_and_wide_layout_needs_synchronous() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write(tmp.path(), "sim.toml", SHORT);
    let trace = |out: &str, seed: &str| {
        let mut c = feedscope(tmp.path());
        c.args(["simulate", "--config"])
            .arg(&cfg)
            .args(["--out", out, "--seed", seed]);
        let o = run(c);
        assert!(o.status.success(), "{}", stderr(&o));
        std::fs::read_to_string(tmp.path().join(out).join("trace.csv")).unwrap()
    };
    assert_eq!(trace("a", "3"), trace("b", "3"));
    assert_ne!(trace("a", "3"), trace("c", "4"));

    let mut c = feedscope(tmp.path());
    c.args(["simulate", "--config"])
        .arg(&cfg)
        .args(["--out", "w", "--layout", "wide"]);
    let o = run(c);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("synchronous"), "{}", stderr(&o));
    assert!(!tmp.path().join("w").exists());

    let sync = format!("{SHORT}[sampling]\nmode = \"synchronous\"\nsynchronous_rate_hz = 100\n");
    let cfg2 = write(tmp.path(), "sync.toml", &sync);
    let mut c = feedscope(tmp.path());
    c.args(["simulate", "--config"])
        .arg(&cfg2)
        .args(["--out", "w", "--layout", "wide"]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        first_line(&tmp.path().join("w/trace.csv")),
        "time_s,position_mm,current_a"
    );
}

#[test]
fn bad_config_exits_2_names_key_and_writes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    for (text, key) in [
        (
            "[[motion.stroke]]\nto_mm = 5\nfeed_mm_min = -600\n",
            "motion.stroke[0].feed_mm_min",
        ),
        (
            "[[motion.stroke]]\nto_mm = 500\nfeed_mm_min = 600\n",
            "motion.stroke[0].to_mm",
        ),
        (
            "[sampling.effort]\ninterval_ms = 0\n",
            "sampling.effort.interval_ms",
        ),
        ("[motion]\nstart_mmm = 1\n", "start_mmm"),
    ] {
        let cfg = write(tmp.path(), "bad.toml", text);
        let mut c = feedscope(tmp.path());
        c.args(["simulate", "--config"])
            .arg(&cfg)
            .args(["--out", "out"]);
        let o = run(c);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(
            stderr(&o).contains(key),
            "expected `{key}` in {}",
            stderr(&o)
        );
        assert!(!tmp.path().join("out").exists());
    }
    // a missing config file is bad input as well
    let mut c = feedscope(tmp.path());
    c.args(["simulate", "--config", "nope.toml", "--out", "out"]);
    let o = run(c);
    assert_eq!(o.status.code(), Some(2));
    assert!(!tmp.path().join("out").exists());
}

#[test]
fn print_default_config_round_trips() {
    let tmp = tempfile::tempdir().unwrap();
    let mut c = feedscope(tmp.path());
    c.args(["simulate", "--print-default-config"]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    for key in [
        "feed_mm_min",
        "interval_ms",
        "quantum_mm",
        "step_ms",
        "[[friction.component]]",
    ] {
        assert!(text.contains(key), "{key} missing");
    }
    let parsed = feedscope::sim::SimConfig::from_toml_str(&text).unwrap();
    assert_eq!(parsed, feedscope::sim::SimConfig::default());
}

#[test]
fn help_mentions_units_and_files() {
    let tmp = tempfile::tempdir().unwrap();
    let mut c = feedscope(tmp.path());
    c.args(["simulate", "--help"]);
    let o = run(c);
    assert!(o.status.success());
    let h = stdout(&o);
    for s in ["--out", "--seed", "--layout", "truth.csv", "mm/min"] {
        assert!(h.contains(s), "{s} missing from help");
    }
}

/// Issue 30 end to end: a config with bell ramps and a feed modulated by ±60 % (60 mm/min, 1.5 s)
/// simulates, and `estimate` of that trace finds one stroke per direction (no pause), lists the
/// feed range of both, and exits 0.
#[test]
fn modulated_feed_with_bell_ramps_estimates_one_stroke_per_direction() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write(
        tmp.path(),
        "sim.toml",
        "seed = 3\n\
         [motion]\nstart_mm = 20\nramp = \"bell\"\nlead_in_s = 0.3\nlead_out_s = 0.3\n\
         [motion.modulation]\nrelative_amplitude = 0.6\nperiod_s = 1.5\n\
         [[motion.stroke]]\nto_mm = 50\nfeed_mm_min = 60\ndwell_s = 0.5\n\
         [[motion.stroke]]\nto_mm = 20\nfeed_mm_min = 60\n\
         [sampling]\nmode = \"synchronous\"\nsynchronous_rate_hz = 250\n",
    );
    let mut c = feedscope(tmp.path());
    c.args(["simulate", "--config"])
        .arg(&cfg)
        .args(["--out", "out"]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut c = feedscope(tmp.path());
    c.args([
        "estimate",
        "out/trace.csv",
        "--axis",
        "out/axis.toml",
        "-o",
        "friction.csv",
    ]);
    let o = run(c);
    let (out, err) = (stdout(&o), stderr(&o));
    assert!(o.status.success(), "{err}");
    assert!(
        out.contains("feed varies along strokes"),
        "no feed range in {out}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(tmp.path().join("friction.json")).unwrap())
            .unwrap();
    let strokes = json["strokes"].as_array().unwrap();
    assert_eq!(strokes.len(), 2, "{json:#}");
    for s in strokes {
        let len = s["length_mm"].as_f64().unwrap();
        let (lo, hi) = (
            s["feed_min_mm_min"].as_f64().unwrap(),
            s["feed_max_mm_min"].as_f64().unwrap(),
        );
        assert!(len >= 0.95 * 30.0, "{s:#}");
        assert!(lo < 40.0 && hi > 80.0, "{s:#}");
    }
    let zones = json["zones"].as_array().unwrap();
    assert!(
        zones.iter().all(|z| z["kind"] != "pause"),
        "a pause in a stroke that never stops: {zones:#?}"
    );
    // `analyze` says that each stroke's mean profile mixes the feeds it ran at.
    let mut c = feedscope(tmp.path());
    c.args([
        "analyze",
        "out/trace.csv",
        "--axis",
        "out/axis.toml",
        "--out",
        "analysis",
    ]);
    let o = run(c);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert_eq!(
        err.matches("the feed varied from").count(),
        2,
        "one warning per stroke: {err}"
    );
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(tmp.path().join("analysis/analysis.json")).unwrap(),
    )
    .unwrap();
    let codes = json.to_string().matches("feed-varies-along-stroke").count();
    assert_eq!(codes, 2, "the warning's code in analysis.json");
}
