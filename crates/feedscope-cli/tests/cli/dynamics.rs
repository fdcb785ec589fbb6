//! `feedscope dynamics`: the example drive runs and writes its files with the documented
//! headers; a bad drive file fails with exit code 2 and names the key.

use std::path::PathBuf;

use crate::util::{feedscope, run, stderr, stdout};

fn example() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/drive.toml")
}

fn first_line(path: &std::path::Path) -> String {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .next()
        .unwrap_or_default()
        .to_owned()
}

#[test]
fn dynamics_example_writes_documented_files() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let mut cmd = feedscope(dir.path());
    cmd.arg("dynamics")
        .arg("--config")
        .arg(example())
        .arg("--out")
        .arg(&out);
    let o = run(cmd);
    assert!(o.status.success(), "stderr: {}", stderr(&o));
    let text = stdout(&o);
    assert!(text.contains("static first frequency"), "{text}");
    assert!(text.contains("rear bearing unloads at"), "{text}");
    assert!(text.contains("resonance risks"), "{text}");

    assert_eq!(
        first_line(&out.join("frequency_vs_feed.csv")),
        "feed_mm_min,mode,frequency_hz"
    );
    assert_eq!(
        first_line(&out.join("frequency_vs_position.csv")),
        "feed_mm_min,position_mm,mode,frequency_hz"
    );
    assert_eq!(
        first_line(&out.join("resonance.csv")),
        "harmonic,feed_mm_min,frequency_hz,mode,margin_hz,order,feed_low_mm_min,feed_high_mm_min"
    );
    // 200 feeds × 3 modes + header
    let feed_rows = std::fs::read_to_string(out.join("frequency_vs_feed.csv"))
        .unwrap()
        .lines()
        .count();
    assert_eq!(feed_rows, 601);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("dynamics.json")).unwrap()).unwrap();
    let f0 = json["static_first_hz"].as_f64().unwrap();
    assert!((f0 - 108.0).abs() < 0.1, "{f0}");
    assert!(json["bearing_unload"]["feed_mm_min"].as_f64().unwrap() > 0.0);
    assert!(json["static_modes"]["modes"].as_array().unwrap().len() == 3);
    // JSON shape (golden: the documented top-level keys)
    let mut keys: Vec<&String> = json.as_object().unwrap().keys().collect();
    keys.sort();
    assert_eq!(
        keys,
        [
            "bearing_unload",
            "breakaway_first_hz",
            "feed_sweep",
            "lead_mm",
            "mode_shapes",
            "name",
            "peak_feed_mm_min",
            "peak_first_hz",
            "position_mm",
            "position_sweeps",
            "resonances",
            "ripple",
            "static_first_hz",
            "static_modes",
        ]
    );
    // 3 positions × 4 feeds of the example, each with node coordinates and shapes
    let shapes = json["mode_shapes"].as_array().unwrap();
    assert_eq!(shapes.len(), 12);
    assert!(shapes[1]["joints"]["feed_m_s"].as_f64().unwrap() > 0.0);
    assert_eq!(
        shapes[0]["modes"][0]["axial"].as_array().unwrap().len(),
        shapes[0]["node_positions_m"].as_array().unwrap().len()
    );
    for svg in ["frequency_vs_feed.svg", "frequency_vs_position.svg"] {
        let s = std::fs::read_to_string(out.join(svg)).unwrap();
        assert!(
            s.starts_with("<svg") && s.contains("frequency (Hz)"),
            "{svg}"
        );
    }
}

#[test]
fn dynamics_json_summary_on_stdout() {
    let dir = tempfile::tempdir().unwrap();
    let mut cmd = feedscope(dir.path());
    cmd.args(["dynamics", "--format", "json", "--out", "o", "--config"])
        .arg(example());
    let o = run(cmd);
    assert!(o.status.success(), "stderr: {}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert!(v["breakaway_first_hz"].as_f64().unwrap() > v["static_first_hz"].as_f64().unwrap());
    assert!(!v["resonances"].as_array().unwrap().is_empty());
}

#[test]
fn dynamics_bad_config_exits_2_naming_the_key() {
    let dir = tempfile::tempdir().unwrap();
    for (body, key) in [
        ("[table]\nmass_kg = -216.0\n", "table.mass_kg"),
        ("[screw]\nlenght_mm = 1400.0\n", "lenght_mm"),
        ("[sweep]\nposition_mm = 2000.0\n", "sweep.position_mm"),
    ] {
        let cfg = dir.path().join("bad.toml");
        std::fs::write(&cfg, body).unwrap();
        let mut cmd = feedscope(dir.path());
        cmd.args(["dynamics", "--out", "o", "--config"]).arg(&cfg);
        let o = run(cmd);
        assert_eq!(o.status.code(), Some(2), "{body}: {}", stderr(&o));
        assert!(stderr(&o).contains(key), "{key}: {}", stderr(&o));
        assert!(
            !dir.path().join("o").exists(),
            "no output before validation"
        );
    }
    let mut cmd = feedscope(dir.path());
    cmd.args(["dynamics", "--out", "o", "--config", "missing.toml"]);
    let o = run(cmd);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("missing.toml"));
}

#[test]
fn dynamics_help_names_the_options() {
    let dir = tempfile::tempdir().unwrap();
    let mut cmd = feedscope(dir.path());
    cmd.args(["dynamics", "--help"]);
    let o = run(cmd);
    assert!(o.status.success());
    let h = stdout(&o);
    for opt in ["--config <FILE>", "--out <DIR>", "--format <FORMAT>"] {
        assert!(h.contains(opt), "{opt}: {h}");
    }
}
