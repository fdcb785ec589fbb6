//! Parquet traces end to end: `simulate --trace NAME.parquet`, then `estimate` on it.
use std::path::Path;

use crate::util::{feedscope, run, stderr};

/// 0 → 30 → 0 mm at 1200 mm/min: two steady strokes, short enough for a quick test.
const SIM: &str = "seed = 11\n\
[motion]\nlead_in_s = 0.2\nlead_out_s = 0.2\n\
[[motion.stroke]]\nto_mm = 30\nfeed_mm_min = 1200\n\
[[motion.stroke]]\nto_mm = 0\nfeed_mm_min = 1200\n";

fn simulate(dir: &Path, out: &str, trace: &str, extra: &[&str]) {
    let mut c = feedscope(dir);
    c.args([
        "simulate", "--config", "sim.toml", "--out", out, "--trace", trace,
    ])
    .args(extra);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// `estimate` on `trace` with the simulated axis; the JSON summary.
fn estimate(dir: &Path, trace: &str, axis: &str, output: &str) -> serde_json::Value {
    let mut c = feedscope(dir);
    c.args(["estimate", trace, "--axis", axis, "-o", output, "--no-plot"]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let json = dir.join(output).with_extension("json");
    serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap()
}

fn strokes(v: &serde_json::Value) -> Vec<(String, f64)> {
    v["strokes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| {
            (
                s["direction"].as_str().unwrap().to_string(),
                s["mean_friction_n"].as_f64().unwrap(),
            )
        })
        .collect()
}

#[test]
fn simulate_parquet_then_estimate_matches_csv() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("sim.toml"), SIM).unwrap();
    simulate(d.path(), "p", "trace.parquet", &[]);
    simulate(d.path(), "c", "trace.csv", &[]);
    let p_bytes = std::fs::read(d.path().join("p/trace.parquet")).unwrap();
    assert_eq!(&p_bytes[..4], b"PAR1");
    let names: Vec<String> = std::fs::read_dir(d.path().join("p"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), 4, "{names:?}");
    assert!(!d.path().join("p/trace.csv").exists());

    let from_pq = strokes(&estimate(
        d.path(),
        "p/trace.parquet",
        "p/axis.toml",
        "fp.csv",
    ));
    let from_csv = strokes(&estimate(d.path(), "c/trace.csv", "c/axis.toml", "fc.csv"));
    assert_eq!(from_pq.len(), 2, "{from_pq:?}");
    assert_eq!(from_pq.len(), from_csv.len());
    for ((dp, fp), (dc, fc)) in from_pq.iter().zip(&from_csv) {
        assert_eq!(dp, dc);
        // The CSV rounds to 6 decimals (1 µs, 1 nm, 1 µA); Parquet keeps every bit. At
        // 20 mm/s, 0.5 µs of time rounding is 10 nm of apparent position noise, which moved
        // the mean friction by 1.1e-6 (relative) in one stroke; 1e-5 bounds it.
        assert!(
            (fp - fc).abs() <= 1e-5 * fc.abs(),
            "{dp}: parquet {fp} N vs csv {fc} N"
        );
    }

    // The same samples through either format give the same summary: the CSV's trace, as
    // read, written to Parquet by the library.
    let (t, _) = feedscope_io::trace::read_trace_file(
        &d.path().join("c/trace.csv"),
        &feedscope_io::trace::ReadOptions::default(),
    )
    .unwrap();
    let f = std::fs::File::create(d.path().join("c/trace.parquet")).unwrap();
    feedscope_io::trace::write_parquet(&t, f, feedscope_io::trace::Layout::Long).unwrap();
    let same = strokes(&estimate(
        d.path(),
        "c/trace.parquet",
        "c/axis.toml",
        "fs.csv",
    ));
    for ((ds, fs), (dc, fc)) in same.iter().zip(&from_csv) {
        assert_eq!(ds, dc);
        // Identical input, identical arithmetic: only the JSON's shortest round-trip
        // printing stands between them, which is exact.
        assert!(
            (fs - fc).abs() <= 1e-12 * fc.abs(),
            "{ds}: {fs} N vs {fc} N"
        );
    }
}

#[test]
fn simulate_parquet_wide_layout() {
    let d = tempfile::tempdir().unwrap();
    let sync = format!("{SIM}[sampling]\nmode = \"synchronous\"\nsynchronous_rate_hz = 500\n");
    std::fs::write(d.path().join("sim.toml"), sync).unwrap();
    simulate(d.path(), "w", "trace.parquet", &["--layout", "wide"]);
    let v = estimate(d.path(), "w/trace.parquet", "w/axis.toml", "f.csv");
    assert_eq!(strokes(&v).len(), 2);
}

#[test]
fn truncated_parquet_exits_2_names_the_file_and_writes_nothing() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("sim.toml"), SIM).unwrap();
    simulate(d.path(), "p", "trace.parquet", &[]);
    let bytes = std::fs::read(d.path().join("p/trace.parquet")).unwrap();
    std::fs::write(d.path().join("cut.parquet"), &bytes[..bytes.len() / 2]).unwrap();
    let before: Vec<_> = std::fs::read_dir(d.path()).unwrap().collect();
    let mut c = feedscope(d.path());
    c.args([
        "estimate",
        "cut.parquet",
        "--axis",
        "p/axis.toml",
        "-o",
        "f.csv",
    ]);
    let o = run(c);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("cut.parquet"), "{err}");
    assert!(err.contains("Parquet"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    let after: Vec<_> = std::fs::read_dir(d.path()).unwrap().collect();
    assert_eq!(before.len(), after.len(), "an output file was left behind");
    assert!(!d.path().join("f.csv").exists());
}

#[test]
fn trace_name_must_be_a_plain_file_name() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("sim.toml"), SIM).unwrap();
    for bad in ["sub/trace.parquet", "truth.csv"] {
        let mut c = feedscope(d.path());
        c.args([
            "simulate", "--config", "sim.toml", "--out", "o", "--trace", bad,
        ]);
        let o = run(c);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains("--trace"), "{}", stderr(&o));
        assert!(!d.path().join("o").exists());
    }
}

/// Damage to a page that the Parquet decoder itself would panic on (it does on some corrupt
/// pages) or reserve gigabytes for is reported like any other bad input: exit 2 and the file
/// named, without a panic message. Since the page headers are checked before decoding, every
/// single-byte damage of a header is refused by that check; one that still reaches a decoder
/// panic is caught by the reader's guard.
#[test]
fn damaged_parquet_pages_are_a_clean_error() {
    use feedscope_io::trace::{parse_trace, ReadOptions};
    let d = tempfile::tempdir().unwrap();
    let sync = format!("{SIM}[sampling]\nmode = \"synchronous\"\nsynchronous_rate_hz = 50\n");
    std::fs::write(d.path().join("sim.toml"), sync).unwrap();
    simulate(d.path(), "w", "trace.parquet", &["--layout", "wide"]);
    let good = std::fs::read(d.path().join("w/trace.parquet")).unwrap();
    // The first single-byte damage, from the end (page data and footer), that the decoder
    // answers with a panic or the page check refuses.
    let refused = |e: &feedscope_io::trace::TraceError| {
        let m = e.to_string();
        m.contains("the decoder failed") || m.contains("the page header at byte")
    };
    let damaged = (4..good.len())
        .rev()
        .flat_map(|k| [0xff, 0x00].map(|v| (k, v)))
        .map(|(k, v)| {
            let mut b = good.clone();
            b[k] = v;
            b
        })
        .find(|b| parse_trace(b, "d.parquet", &ReadOptions::default()).is_err_and(|e| refused(&e)))
        .expect("some single-byte damage of a page header is refused");
    std::fs::write(d.path().join("d.parquet"), damaged).unwrap();
    let mut c = feedscope(d.path());
    c.args([
        "estimate",
        "d.parquet",
        "--axis",
        "w/axis.toml",
        "-o",
        "f.csv",
    ]);
    let o = run(c);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("d.parquet"), "{err}");
    assert!(
        err.contains("the decoder failed") || err.contains("the page header at byte"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    assert!(!d.path().join("f.csv").exists());
}
