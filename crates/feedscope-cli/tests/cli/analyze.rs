//! `feedscope analyze`: files, golden headers, input from `estimate`, bad options.
use std::path::Path;

use feedscope::sim::{simulate, SimConfig, StrokeConfig};
use feedscope_io::trace::{write_csv, Layout};

use crate::util::{feedscope, run, stderr, stdout};

/// A short simulated test (20 → 120 mm and back at 200 mm/min) with its axis file.
fn setup(dir: &Path) {
    let mut c = SimConfig::default();
    c.motion.start_mm = 20.0;
    c.motion.strokes = vec![
        StrokeConfig {
            to_mm: 120.0,
            feed_mm_min: 200.0,
            dwell_s: 1.0,
        },
        StrokeConfig {
            to_mm: 20.0,
            feed_mm_min: 200.0,
            dwell_s: 0.0,
        },
    ];
    let out = simulate(&c, &mut |_| {}).unwrap();
    write_csv(
        &out.trace,
        std::fs::File::create(dir.join("trace.csv")).unwrap(),
        Layout::Long,
    )
    .unwrap();
    std::fs::write(
        dir.join("axis.toml"),
        toml::to_string(&out.truth.axis).unwrap(),
    )
    .unwrap();
}

#[test]
fn analyze_trace_writes_tables_and_plots() {
    let d = tempfile::tempdir().unwrap();
    setup(d.path());
    let mut c = feedscope(d.path());
    c.args(["analyze", "trace.csv", "--axis", "axis.toml", "--out", "a"]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let a = d.path().join("a");
    for f in [
        "analysis.json",
        "friction.csv",
        "components.csv",
        "order_scan.csv",
        "friction_iafv.svg",
        "spectra_heatmap_forward.svg",
        "spectrum_backward.svg",
    ] {
        assert!(a.join(f).exists(), "{f} missing");
    }
    let first = |f: &str| {
        std::fs::read_to_string(a.join(f))
            .unwrap()
            .lines()
            .next()
            .unwrap()
            .to_string()
    };
    insta::assert_snapshot!(
        "analyze_headers",
        format!(
            "{}\n{}\n{}",
            first("friction.csv"),
            first("components.csv"),
            first("order_scan.csv")
        )
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(a.join("analysis.json")).unwrap()).unwrap();
    let mut keys: Vec<&String> = json.as_object().unwrap().keys().collect();
    keys.sort();
    let mut stroke_keys: Vec<&String> = json["strokes"][0].as_object().unwrap().keys().collect();
    stroke_keys.sort();
    insta::assert_snapshot!("analyze_json_keys", format!("{keys:?}\n{stroke_keys:?}"));
    // The shaft 1x component is found and named in the whole-stroke table.
    let comps = std::fs::read_to_string(a.join("components.csv")).unwrap();
    assert!(comps
        .lines()
        .any(|l| l.contains(",all,") && l.contains("shaft 1x")));
    assert!(stdout(&o).contains("Table 2"));
}

#[test]
fn analyze_reads_estimate_output_and_takes_user_breaks() {
    let d = tempfile::tempdir().unwrap();
    setup(d.path());
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
    assert!(run(c).status.success());
    let mut c = feedscope(d.path());
    c.args([
        "analyze",
        "f.csv",
        "--axis",
        "axis.toml",
        "--out",
        "b",
        "--breaks",
        "60",
        "--orders",
        "2,3",
        "--format",
        "json",
    ]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    let breaks = v["strokes"][0]["iafv"]["poly"]["breaks_mm"]
        .as_array()
        .unwrap();
    assert_eq!(breaks.len(), 3);
    assert!((breaks[1].as_f64().unwrap() - 60.0).abs() < 1e-9);
}

#[test]
fn analyze_bad_orders_and_breaks_exit_2() {
    let d = tempfile::tempdir().unwrap();
    setup(d.path());
    for (args, needle) in [
        (
            vec!["--breaks", "60", "--orders", "2"],
            "one order per interval",
        ),
        (vec!["--breaks", "500", "--orders", "2,2"], "500"),
        (vec!["--segments", "0"], "--segments"),
    ] {
        let mut c = feedscope(d.path());
        c.args([
            "analyze",
            "trace.csv",
            "--axis",
            "axis.toml",
            "--out",
            "bad",
        ]);
        c.args(&args);
        let o = run(c);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
        assert!(!d.path().join("bad").join("analysis.json").exists());
    }
}
