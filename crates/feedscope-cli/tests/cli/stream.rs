//! `estimate --read`: estimating while reading writes exactly what reading the whole trace
//! first writes, and says why when it cannot vouch for that.
use std::path::Path;

use crate::util::{feedscope, run, stderr, stdout};

/// Strokes back and forth at three feeds on a 5 ms asynchronous twin, 0.1 µm steps.
const TWIN: &str = "seed = 11\n\
[motion]\nstart_mm = 10\nlead_in_s = 0.3\nlead_out_s = 0.3\n\
[[motion.stroke]]\nto_mm = 40\nfeed_mm_min = 300\ndwell_s = 0.3\n\
[[motion.stroke]]\nto_mm = 10\nfeed_mm_min = 300\ndwell_s = 0.3\n\
[[motion.stroke]]\nto_mm = 40\nfeed_mm_min = 1200\ndwell_s = 0.3\n\
[[motion.stroke]]\nto_mm = 10\nfeed_mm_min = 1200\ndwell_s = 0.3\n\
[[motion.stroke]]\nto_mm = 40\nfeed_mm_min = 80\ndwell_s = 0.3\n\
[[motion.stroke]]\nto_mm = 10\nfeed_mm_min = 80\n\
[sampling.position]\ninterval_ms = 5\njitter_ms = 0.2\nquantum_mm = 0.0001\n\
[sampling.effort]\ninterval_ms = 5\njitter_ms = 0.2\nstart_offset_ms = 2.5\n";

fn simulate(dir: &Path) {
    std::fs::write(dir.join("sim.toml"), TWIN).unwrap();
    let mut c = feedscope(dir);
    c.args(["simulate", "--config", "sim.toml", "--out", "twin"]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// `estimate` of `trace` with `--read how`, outputs named after `how`: (exit ok, stdout,
/// stderr).
fn estimate(dir: &Path, trace: &str, axis: &str, how: &str, json: bool) -> (bool, String, String) {
    let mut c = feedscope(dir);
    c.args(["estimate", trace, "--axis", axis, "-o"])
        .arg(format!("{how}.csv"))
        .args(["--read", how]);
    if json {
        c.args(["--format", "json"]);
    }
    let o = run(c);
    (o.status.success(), stdout(&o), stderr(&o))
}

fn same_files(dir: &Path, a: &str, b: &str) {
    for ext in ["csv", "json", "svg"] {
        let (fa, fb) = (
            std::fs::read(dir.join(format!("{a}.{ext}"))).unwrap(),
            std::fs::read(dir.join(format!("{b}.{ext}"))).unwrap(),
        );
        assert!(fa == fb, "{a}.{ext} and {b}.{ext} differ");
    }
}

#[test]
fn streamed_and_whole_reads_write_the_same_files() {
    let d = tempfile::tempdir().unwrap();
    simulate(d.path());
    for json in [false, true] {
        let s = estimate(d.path(), "twin/trace.csv", "twin/axis.toml", "stream", json);
        let w = estimate(d.path(), "twin/trace.csv", "twin/axis.toml", "whole", json);
        assert!(s.0 && w.0, "{}\n{}", s.2, w.2);
        same_files(d.path(), "stream", "whole");
        assert_eq!(s.1, w.1);
        let strokes: serde_json::Value =
            serde_json::from_slice(&std::fs::read(d.path().join("stream.json")).unwrap()).unwrap();
        assert_eq!(strokes["strokes"].as_array().unwrap().len(), 6);
    }
}

/// A wide 500 Hz trace, 0 → 20 mm and back at 600 mm/min, with `glitch` at sample 700.
fn wide_with(glitch: Option<&str>) -> String {
    let mut s = String::from("time_s,position_mm,current_a\n");
    for k in 0..2750usize {
        let t = k as f64 / 500.0;
        let (mm, dir) = match t {
            t if t < 0.5 => (0.0, 0.0),
            t if t < 2.5 => (10.0 * (t - 0.5), 1.0),
            t if t < 3.0 => (20.0, 0.0),
            t if t < 5.0 => (20.0 - 10.0 * (t - 3.0), -1.0),
            _ => (0.0, 0.0),
        };
        let amps = dir * (0.8 + 0.05 * (2.0 * std::f64::consts::PI * mm / 10.0).sin());
        let z = match glitch {
            Some(g) if k == 700 => g.to_string(),
            _ => format!("{mm:.4}"),
        };
        s.push_str(&format!("{t:.6},{z},{amps:.6}\n"));
    }
    s
}

#[test]
fn a_glitch_sends_auto_to_the_whole_read_and_stream_says_why() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("axis.toml"), crate::estimate::AXIS).unwrap();
    std::fs::write(d.path().join("clean.csv"), wide_with(None)).unwrap();
    std::fs::write(d.path().join("glitch.csv"), wide_with(Some("1e308"))).unwrap();
    // Clean: streamed.
    let s = estimate(d.path(), "clean.csv", "axis.toml", "stream", false);
    assert!(s.0, "{}", s.2);
    // With a glitch the stream cannot vouch for its strokes: `auto` reads the whole trace and
    // writes what `whole` writes (the glitch dropped and named); `stream` refuses, saying why.
    let a = estimate(d.path(), "glitch.csv", "axis.toml", "auto", false);
    let w = estimate(d.path(), "glitch.csv", "axis.toml", "whole", false);
    assert!(a.0 && w.0, "{}\n{}", a.2, w.2);
    same_files(d.path(), "auto", "whole");
    assert!(a.2.contains("dropped 1 position sample"), "{}", a.2);
    let mut c = feedscope(d.path());
    c.args([
        "estimate",
        "glitch.csv",
        "--axis",
        "axis.toml",
        "--read",
        "stream",
    ]);
    let o = run(c);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o)
            .contains("cannot estimate while reading (a position beyond the travel: a glitch"),
        "{}",
        stderr(&o)
    );
}
