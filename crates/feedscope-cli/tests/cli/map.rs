//! `feedscope map`: a small simulated test set in a temp dir; failures by name, exit codes,
//! golden headers of the compensation table and keys of `stribeck.json`.
use std::path::Path;

use feedscope::sim::{simulate, DynamicsMode, SimConfig, StrokeConfig};
use feedscope_io::trace::{write_csv, Layout};

use crate::util::{expect_bad_input, feedscope, run, stderr, stdout};

const FEEDS: [f64; 4] = [15.0, 45.0, 135.0, 400.0];

/// Traces of 4 feeds × 2 repeats (25 → 45 mm and back) under `runs/`, the axis file and an
/// index `index.csv` with relative paths, plus `extra` lines appended to the index.
fn setup(dir: &Path, extra: &str) {
    setup_feeds(dir, &FEEDS, extra);
}

/// As [`setup`], with the given feeds.
fn setup_feeds(dir: &Path, feeds: &[f64], extra: &str) {
    std::fs::create_dir_all(dir.join("runs")).unwrap();
    let mut index = String::from("# test set\nfile,feed_mm_min,repeat,operator\n");
    let mut axis = None;
    for (i, &f) in feeds.iter().enumerate() {
        for r in 1..=2u32 {
            let mut c = SimConfig {
                seed: 100 + 10 * i as u64 + r as u64,
                ..SimConfig::default()
            };
            c.dynamics.mode = DynamicsMode::Ideal;
            c.motion.start_mm = 25.0;
            c.motion.strokes = vec![
                StrokeConfig {
                    to_mm: 45.0,
                    feed_mm_min: f,
                    dwell_s: 0.5,
                },
                StrokeConfig {
                    to_mm: 25.0,
                    feed_mm_min: f,
                    dwell_s: 0.0,
                },
            ];
            c.sampling.position.interval_ms = 20.0;
            c.sampling.position.jitter_ms = 0.5;
            c.sampling.effort.interval_ms = 20.0;
            c.sampling.effort.jitter_ms = 0.5;
            c.sampling.effort.start_offset_ms = 10.0;
            c.truth.interval_ms = 1000.0;
            let out = simulate(&c, &mut |_| {}).unwrap();
            let name = format!("runs/f{f}_r{r}.csv");
            write_csv(
                &out.trace,
                std::fs::File::create(dir.join(&name)).unwrap(),
                Layout::Long,
            )
            .unwrap();
            index.push_str(&format!("{name},{f},{r},sim\n"));
            axis = Some(out.truth.axis);
        }
    }
    index.push_str(extra);
    std::fs::write(dir.join("index.csv"), index).unwrap();
    std::fs::write(
        dir.join("axis.toml"),
        toml::to_string(&axis.unwrap()).unwrap(),
    )
    .unwrap();
}

fn header_lines(path: &Path, n: usize) -> String {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .take(n)
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn map_reports_failed_runs_by_name_and_writes_everything() {
    let d = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(d.path().join("runs")).unwrap();
    std::fs::write(
        d.path().join("runs/bad.csv"),
        "time_s,channel,value\n0.0,position_mm,x\n",
    )
    .unwrap();
    setup(
        d.path(),
        "runs/missing.csv,45,3,sim\nruns/bad.csv,135,3,sim\n",
    );
    let mut c = feedscope(d.path());
    c.args([
        "map",
        "index.csv",
        "--axis",
        "axis.toml",
        "--out",
        "m",
        "--positions",
        "30,40",
    ]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("run runs/missing.csv failed"), "{err}");
    assert!(err.contains("run runs/bad.csv failed"), "{err}");
    let text = stdout(&o);
    assert!(text.contains("8 of 10 runs mapped"), "{text}");
    let m = d.path().join("m");
    for f in [
        "stribeck.json",
        "stribeck_profile.csv",
        "compensation.csv",
        "compensation_forward.csv",
        "compensation_backward.csv",
        "map.json",
        "ppocm.csv",
        "repeatability.csv",
        "runs.csv",
        "friction_vs_feed.svg",
        "map_forward.svg",
        "map_backward.svg",
        "iafv_repeats.svg",
        "mvoiaf.svg",
    ] {
        assert!(m.join(f).exists(), "{f} missing");
    }
    insta::assert_snapshot!(
        "map_compensation_header",
        header_lines(&m.join("compensation.csv"), 7)
    );
    insta::assert_snapshot!(
        "map_compensation_forward_header",
        header_lines(&m.join("compensation_forward.csv"), 8)
    );
    let first_line = |f: &str| {
        std::fs::read_to_string(m.join(f))
            .unwrap()
            .lines()
            .find(|l| !l.starts_with('#'))
            .unwrap()
            .to_string()
    };
    insta::assert_snapshot!(
        "map_table_headers",
        [
            "stribeck_profile.csv",
            "ppocm.csv",
            "repeatability.csv",
            "runs.csv"
        ]
        .map(first_line)
        .join("\n")
    );
    // Keys of stribeck.json, recursively (first element of lists).
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(m.join("stribeck.json")).unwrap()).unwrap();
    fn keys(v: &serde_json::Value, prefix: &str, out: &mut Vec<String>) {
        match v {
            serde_json::Value::Object(o) => {
                for (k, x) in o {
                    let p = format!("{prefix}.{k}");
                    out.push(p.clone());
                    keys(x, &p, out);
                }
            }
            serde_json::Value::Array(a) => {
                if let Some(x) = a.first() {
                    keys(x, &format!("{prefix}[]"), out);
                }
            }
            _ => {}
        }
    }
    let mut k = Vec::new();
    keys(&v, "", &mut k);
    insta::assert_snapshot!("map_stribeck_json_keys", k.join("\n"));
    let dirs = v["directions"].as_array().unwrap();
    assert_eq!(dirs.len(), 2);
    for dj in dirs {
        let pos = dj["positions"].as_array().unwrap();
        assert_eq!(pos.len(), 2);
        assert!((pos[0]["position_mm"].as_f64().unwrap() - 30.0).abs() < 1e-12);
        assert!(pos[0]["fc_n"]["value"].as_f64().unwrap() > 100.0);
        assert_eq!(dj["feeds_mm_min"].as_array().unwrap().len(), 4);
    }
    let runs = std::fs::read_to_string(m.join("runs.csv")).unwrap();
    assert!(runs.contains("runs/missing.csv,45,3,failed"), "{runs}");
    assert!(runs.contains("runs/bad.csv,135,3,failed"), "{runs}");
}

#[test]
fn map_strict_and_all_failed_exit_1() {
    let d = tempfile::tempdir().unwrap();
    setup(d.path(), "runs/missing.csv,45,3,sim\n");
    let mut c = feedscope(d.path());
    c.args([
        "map",
        "index.csv",
        "--axis",
        "axis.toml",
        "--out",
        "m",
        "--strict",
    ]);
    let o = run(c);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("--strict"));
    assert!(
        d.path().join("m/compensation.csv").exists(),
        "outputs still written"
    );

    std::fs::write(
        d.path().join("only_missing.csv"),
        "file,feed_mm_min,repeat\na.csv,10,1\nb.csv,20,1\n",
    )
    .unwrap();
    let mut c = feedscope(d.path());
    c.args([
        "map",
        "only_missing.csv",
        "--axis",
        "axis.toml",
        "--out",
        "m2",
    ]);
    let o = run(c);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("all 2 runs"), "{}", stderr(&o));
}

#[test]
fn map_bad_input_exit_2() {
    let d = tempfile::tempdir().unwrap();
    setup(d.path(), "");
    let map = |extra: &[&str], needles: &[&str]| {
        let mut args = vec!["map", "index.csv", "--axis", "axis.toml"];
        args.extend_from_slice(extra);
        expect_bad_input(d.path(), &args, needles);
    };
    // A position outside the mapped travel (26-44 mm) is named.
    map(
        &["--out", "m", "--positions", "30,80"],
        &["80", "outside the mapped travel"],
    );
    // Outside the axis travel: refused before any estimation.
    map(
        &["--positions", "-5"],
        &["-5 mm is outside the axis travel"],
    );
    // A table feed beyond the measured feeds without --extrapolate.
    map(&["--out", "m", "--table-feeds", "15,1000"], &["1000"]);
    let mut c = feedscope(d.path());
    c.args([
        "map",
        "index.csv",
        "--axis",
        "axis.toml",
        "--out",
        "m",
        "--table-feeds",
        "15,1000",
        "--extrapolate",
        "--format",
        "json",
    ]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let summary: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(summary["runs_ok"], 8);
    // Four feeds: feed polynomial of order 4 − 2.
    assert_eq!(summary["directions"][0]["feed_order"], 2);
    assert!(std::fs::read_to_string(d.path().join("m/compensation.csv"))
        .unwrap()
        .contains("EXTRAPOLATED"));
    // A malformed index names its line.
    std::fs::write(
        d.path().join("bad_index.csv"),
        "file,feed_mm_min,repeat\na.csv,fast,1\n",
    )
    .unwrap();
    expect_bad_input(
        d.path(),
        &["map", "bad_index.csv", "--axis", "axis.toml"],
        &["bad_index.csv:2"],
    );
}

#[test]
fn map_help() {
    let d = tempfile::tempdir().unwrap();
    let mut c = feedscope(d.path());
    c.args(["map", "--help"]);
    let o = run(c);
    assert!(o.status.success());
    insta::assert_snapshot!("map_help", stdout(&o));
}

/// A test set measured at one feed: refused with a clear message and exit code 2 before any
/// output is written (it used to panic while plotting, exit 101, outputs half-written).
#[test]
fn map_with_one_feed_is_refused_and_writes_nothing() {
    let d = tempfile::tempdir().unwrap();
    setup_feeds(d.path(), &[135.0], "");
    expect_bad_input(
        d.path(),
        &["map", "index.csv", "--axis", "axis.toml", "--out", "m"],
        &[
            "index.csv",
            "a map needs at least two feeds; this test set has only 135 mm/min",
        ],
    );
    assert!(!d.path().join("m").exists(), "nothing written");
}

/// Every number in a text (JSON, CSV, console): the tokens that parse as f64.
fn numbers(text: &str) -> Vec<f64> {
    text.split(|c: char| !(c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '+')))
        .filter_map(|t| t.parse::<f64>().ok())
        .filter(|x| x.is_finite())
        .collect()
}

/// A test set at two feeds cannot determine a 4-parameter Stribeck curve (it used to print
/// Fs − Fc ≈ 2.6e9 N with exit 0 and "warnings 4"): the Coulomb + viscous line through the two
/// mean friction values is reported, the console says which model and why, and no absurd
/// number appears anywhere.
#[test]
fn map_with_two_feeds_reports_the_coulomb_viscous_line() {
    let d = tempfile::tempdir().unwrap();
    setup_feeds(d.path(), &[135.0, 400.0], "");
    let mut c = feedscope(d.path());
    c.args([
        "map",
        "index.csv",
        "--axis",
        "axis.toml",
        "--out",
        "m",
        "--positions",
        "30,40",
    ]);
    let o = run(c);
    let (out, err) = (stdout(&o), stderr(&o));
    assert_eq!(o.status.code(), Some(0), "{err}");
    for needle in [
        "forward (every position): model Coulomb + viscous (F = Fc + sigma*v)",
        "backward (every position): model Coulomb + viscous (F = Fc + sigma*v)",
        "a Stribeck curve (4 parameters) is not determined: it needs at least 4 distinct \
         feeds; the data have 2 (135 and 400 mm/min)",
        "measure at least 4 distinct feeds per direction",
        // every warning's text, not a count
        "warning: forward at 30.000 mm: 2 points for 2 parameters: no standard errors",
    ] {
        assert!(err.contains(needle), "`{needle}` not in: {err}");
    }
    assert!(out.contains("coulomb-viscous"), "{out}");
    let m = d.path().join("m");
    let json = std::fs::read_to_string(m.join("stribeck.json")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let feeds_m_s = [135.0 / 60_000.0, 400.0 / 60_000.0];
    for dj in v["directions"].as_array().unwrap() {
        for p in dj["positions"].as_array().unwrap() {
            assert_eq!(p["model"], "coulomb-viscous", "{p}");
            assert!(p["fs_n"].is_null() && p["vs_mm_min"].is_null(), "{p}");
            assert_eq!(p["reductions"][0]["code"], "too-few-feeds", "{p}");
            assert_eq!(p["warnings"][0]["code"], "few-points", "{p}");
            let fc = p["fc_n"]["value"].as_f64().unwrap();
            let sigma = p["sigma_n_s_per_m"]["value"].as_f64().unwrap();
            // the line passes through both points (the JSON keeps ~17 digits)
            for (k, &vk) in feeds_m_s.iter().enumerate() {
                let f = p["friction_n"][k].as_f64().unwrap();
                assert!((fc + sigma * vk - f).abs() < 1e-6 * f, "{p}");
            }
            assert!(fc > 50.0 && fc < 1000.0, "{p}");
        }
    }
    let profile = std::fs::read_to_string(m.join("stribeck_profile.csv")).unwrap();
    let rows: Vec<&str> = profile
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .collect();
    assert!(!rows.is_empty());
    assert!(
        rows.iter().all(|l| l.contains(",coulomb-viscous,")),
        "{profile}"
    );
    let map_json = std::fs::read_to_string(m.join("map.json")).unwrap();
    for (name, text) in [
        ("stdout", &out),
        ("stderr", &err),
        ("stribeck.json", &json),
        ("stribeck_profile.csv", &profile),
        ("map.json", &map_json),
    ] {
        // friction here is a few hundred N, σ a few 1e4 N·s/m: 1e6 is absurd in any unit used
        let worst = numbers(text)
            .into_iter()
            .fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(worst < 1e6, "{name}: {worst}");
    }
}
