//! `feedscope fit-stribeck`: good tables (force and torque, one and two directions, paper 001
//! Table 2), the documented outputs, and real malformed files failing with exit code 2 and
//! file:line.
use std::path::Path;

use feedscope::units::feed_mm_min_to_m_s;

use crate::util::{feedscope, run, stderr, stdout};

/// Friction magnitude of a known curve (F_c 173 N, F_s 241 N, v_s 37 mm/min, σ 16000 N·s/m),
/// feed in mm/min.
fn truth_n(feed_mm_min: f64) -> f64 {
    let v = feed_mm_min_to_m_s(feed_mm_min.abs());
    173.0 + 68.0 * (-(feed_mm_min.abs() / 37.0).powi(2)).exp() + 16_000.0 * v
}

/// 18 log-spaced feeds 5-600 mm/min; with `signed`, backward rows carry negative feeds and
/// friction 10 % higher; a deterministic ±1 N ripple stands in for noise.
fn force_table(signed: bool) -> String {
    let mut s = String::from("# synthetic\nfeed_mm_min,force_n\n");
    for k in 0..18 {
        let f = 5.0 * 120f64.powf(k as f64 / 17.0);
        let ripple = if k % 2 == 0 { 1.0 } else { -1.0 };
        s.push_str(&format!("{f:.4},{:.4}\n", truth_n(f) + ripple));
        if signed {
            s.push_str(&format!("{:.4},{:.4}\n", -f, -(1.1 * truth_n(f) - ripple)));
        }
    }
    s
}

fn fit(dir: &Path, table: &str, extra: &[&str]) -> std::process::Output {
    std::fs::write(dir.join("t.csv"), table).unwrap();
    let mut c = feedscope(dir);
    c.args(["fit-stribeck", "t.csv", "--out", "out"])
        .args(extra);
    run(c)
}

fn json(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("out/stribeck.json")).unwrap()).unwrap()
}

#[test]
fn force_table_both_directions_writes_documented_files() {
    let d = tempfile::tempdir().unwrap();
    let o = fit(d.path(), &force_table(true), &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = json(d.path());
    let mut top: Vec<&String> = j.as_object().unwrap().keys().collect();
    top.sort();
    assert_eq!(
        top,
        [
            "delta",
            "directions",
            "efficiency",
            "input",
            "lead_mm",
            "source"
        ]
    );
    assert_eq!(j["input"], "force_n");
    let dirs = j["directions"].as_array().unwrap();
    assert_eq!(dirs.len(), 2);
    let mut keys: Vec<&String> = dirs[0].as_object().unwrap().keys().collect();
    keys.sort();
    insta::assert_snapshot!("fit_stribeck_direction_keys", format!("{keys:?}"));
    let mut pkeys: Vec<&String> = dirs[0]["params"].as_object().unwrap().keys().collect();
    pkeys.sort();
    assert_eq!(
        pkeys,
        ["delta", "fc_n", "fs_n", "sigma_n_s_per_m", "vs_mm_min"]
    );
    for (d, scale) in [(&dirs[0], 1.0), (&dirs[1], 1.1)] {
        let p = &d["params"];
        let fc = p["fc_n"].as_f64().unwrap();
        let vs = p["vs_mm_min"].as_f64().unwrap();
        let sigma = p["sigma_n_s_per_m"].as_f64().unwrap();
        // ±1 N ripple on ~200 N: within 2 % / 10 % / 5 % as the library round trips
        assert!((fc / (173.0 * scale) - 1.0).abs() < 0.02, "{d}");
        assert!((vs / 37.0 - 1.0).abs() < 0.10, "{d}");
        assert!((sigma / (16_000.0 * scale) - 1.0).abs() < 0.05, "{d}");
        let u = &d["uncertainty"]["fc_n"];
        assert!(u["std_error"].as_f64().unwrap() > 0.0);
        assert_eq!(u["ci95"].as_array().unwrap().len(), 2);
        assert_eq!(d["points"], 18);
        assert!(d["nonconventional"]["ranges"]
            .as_array()
            .unwrap()
            .is_empty());
    }
    assert_eq!(dirs[0]["direction"], "forward");
    assert_eq!(dirs[1]["direction"], "backward");
    let svg = std::fs::read_to_string(d.path().join("out/stribeck.svg")).unwrap();
    assert!(svg.contains("feed (mm/min)") && svg.contains("friction (N)"));
    assert!(svg.contains("backward Stribeck fit"));
    let text = stdout(&o);
    let header = text.lines().next().unwrap();
    insta::assert_snapshot!("fit_stribeck_table_header", header);
    assert!(
        text.contains("forward") && text.contains("backward"),
        "{text}"
    );
}

/// Eq. 15 with a direction column and η: the friction in the JSON is 2π·η·T/p.
#[test]
fn torque_table_uses_eq15_with_efficiency() {
    let d = tempfile::tempdir().unwrap();
    let mut t = String::from("direction,feed_mm_min,torque_nm\n");
    let lead_m = 0.008;
    let eta = 0.9;
    for k in 0..12 {
        let f = 5.0 * 120f64.powf(k as f64 / 11.0);
        let torque = truth_n(f) * lead_m / (2.0 * std::f64::consts::PI * eta);
        t.push_str(&format!("forward,{f:.6},{torque:.9}\n"));
    }
    let o = fit(
        d.path(),
        &t,
        &["--lead-mm", "8", "--efficiency", "0.9", "--format", "json"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(j["input"], "torque_nm");
    let dir = &j["directions"][0];
    for p in dir["data"].as_array().unwrap() {
        let feed = p["feed_mm_min"].as_f64().unwrap();
        let f = p["friction_n"].as_f64().unwrap();
        // torque written with 9 decimals: 1e-9·2π/0.008 ≈ 1e-6 N
        assert!((f - truth_n(feed)).abs() < 1e-5, "{feed}: {f}");
    }
    // noise-free data: the fit is exact
    assert!((dir["params"]["fc_n"].as_f64().unwrap() - 173.0).abs() < 1e-3);
    assert_eq!(j["directions"].as_array().unwrap().len(), 1);
}

/// Paper 001 Table 2 (mean torque at 17 feeds, lead 12 mm) against its Table 3 (F_c 658.89 N,
/// F_s 815.75 N, delt 40.17, v_s 0.071 m/min): v_s, F_s/F_c and delt/F_c (delt read as
/// N·min/m) agree within 3 %; the absolute forces depend on an efficiency the paper does not
/// state (η ≈ 0.83 reproduces them). With δ free the same data leave δ, F_s and v_s
/// unidentified, and the output says so.
#[test]
fn paper_001_table_2_gives_table_3_shape() {
    let d = tempfile::tempdir().unwrap();
    let table = "feed_mm_min,torque_nm\n50,1.73\n100,1.57\n200,1.48\n300,1.44\n400,1.50\n\
                 500,1.55\n1000,1.65\n2000,1.74\n3000,1.81\n4000,1.93\n5000,2.03\n6000,2.09\n\
                 7000,2.16\n8000,2.24\n9000,2.31\n10000,2.36\n11000,2.50\n";
    let o = fit(d.path(), table, &["--lead-mm", "12"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let p = &json(d.path())["directions"][0]["params"];
    let (fc, fs) = (p["fc_n"].as_f64().unwrap(), p["fs_n"].as_f64().unwrap());
    let vs = p["vs_mm_min"].as_f64().unwrap();
    let delt_n_min_per_m = p["sigma_n_s_per_m"].as_f64().unwrap() / 60.0;
    assert!((vs / 71.0 - 1.0).abs() < 0.03, "{p}");
    assert!(((fs / fc) / (815.75 / 658.89) - 1.0).abs() < 0.03, "{p}");
    assert!(
        ((delt_n_min_per_m / fc) / (40.17 / 658.89) - 1.0).abs() < 0.03,
        "{p}"
    );

    // δ free: one feed below v_s cannot pin δ, F_s and v_s (SE(F_s) came out ≈ 2e9 N); the
    // δ-free curve is refused and the curve with δ = 2 reported, with the reason on stderr
    let fixed = json(d.path())["directions"][0]["params"].clone();
    let o = fit(d.path(), table, &["--lead-mm", "12", "--delta", "free"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let dir = &json(d.path())["directions"][0];
    assert_eq!(dir["model"], "stribeck");
    assert_eq!(dir["params"], fixed);
    assert_eq!(dir["params"]["delta"], 2.0);
    assert!(dir["uncertainty"]["delta"].is_null());
    let code = dir["reductions"][0]["code"].as_str().unwrap();
    assert!(
        matches!(code, "ill-conditioned" | "absurd-uncertainty"),
        "{code}"
    );
    let f_max = 2.0 * std::f64::consts::PI * 2.50 / 0.012;
    for k in ["fc_n", "fs_n", "static_excess_n"] {
        let se = dir["uncertainty"][k]["std_error"].as_f64().unwrap();
        assert!(se < f_max, "{k}: {se}");
    }
    let err = stderr(&o);
    assert!(
        err.contains("forward: model Stribeck curve")
            && err.contains("a Stribeck curve with delta free (5 parameters) is not determined"),
        "{err}"
    );
}

#[test]
fn delta_free_reports_its_uncertainty() {
    let d = tempfile::tempdir().unwrap();
    let o = fit(d.path(), &force_table(false), &["--delta", "free"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = json(d.path());
    assert_eq!(j["delta"], "free");
    let u = &j["directions"][0]["uncertainty"]["delta"];
    assert!(u["std_error"].as_f64().unwrap() > 0.0, "{u}");
    let bad = fit(d.path(), &force_table(false), &["--delta", "-1"]);
    assert_eq!(bad.status.code(), Some(2));
}

/// A planted fall between 150 and 300 mm/min is reported in the JSON and on stdout.
#[test]
fn nonconventional_fall_is_reported() {
    let d = tempfile::tempdir().unwrap();
    let mut s = String::from("feed_mm_min,force_n\n");
    for k in 0..18 {
        let f = 5.0 * 120f64.powf(k as f64 / 17.0);
        let fall = 80.0 * ((f - 150.0) / 150.0).clamp(0.0, 1.0);
        s.push_str(&format!("{f:.4},{:.4}\n", truth_n(f) - fall));
    }
    let o = fit(d.path(), &s, &["--noise-n", "1.7"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = &json(d.path())["directions"][0]["nonconventional"]["ranges"];
    assert_eq!(r.as_array().unwrap().len(), 1, "{r}");
    let from = r[0]["from_mm_min"].as_f64().unwrap();
    let to = r[0]["to_mm_min"].as_f64().unwrap();
    assert!(
        from > 100.0 && from < 200.0 && to > 250.0 && to < 460.0,
        "{r}"
    );
    assert!(stdout(&o).contains("non-conventional"), "{}", stdout(&o));
}

/// Malformed files fail with exit code 2 and name the file and line.
#[test]
fn malformed_tables_exit_2_with_file_and_line() {
    let cases: [(&str, &[&str], &str); 8] = [
        (
            "speed,force_n\n10,100\n",
            &[],
            "t.csv:1: no `feed_mm_min` column",
        ),
        (
            "feed_mm_min,friction\n10,100\n",
            &[],
            "t.csv:1: no `torque_nm` or `force_n`",
        ),
        (
            "# c\nfeed_mm_min,force_n\n10,100\n20,abc\n",
            &[],
            "t.csv:4: column `force_n`: `abc` is not a number",
        ),
        (
            "feed_mm_min,force_n\n10,100\nNaN,90\n",
            &[],
            "t.csv:3: column `feed_mm_min`: NaN is not finite",
        ),
        (
            "feed_mm_min,force_n\n10,100\n20\n",
            &[],
            "t.csv:3: 1 fields",
        ),
        (
            "feed_mm_min,force_n\n10,100\n10,95\n10.05,97\n",
            &[],
            "forward direction has 1 distinct feed (10 mm/min, 3 rows)",
        ),
        (
            "feed_mm_min,torque_nm\n10,1\n20,1\n30,1\n40,1\n50,1\n",
            &["--lead-mm", "0"],
            "--lead-mm must be positive",
        ),
        (
            "feed_mm_min,torque_nm\n10,1\n20,1\n30,1\n40,1\n50,1\n",
            &[],
            "needs --lead-mm",
        ),
    ];
    for (table, extra, want) in cases {
        let d = tempfile::tempdir().unwrap();
        let o = fit(d.path(), table, extra);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{table:?}: {err}");
        assert!(err.contains(want), "{table:?}: {err}");
        // nothing half-written
        assert!(!d.path().join("out/stribeck.json").exists());
    }
    // a file that does not exist
    let d = tempfile::tempdir().unwrap();
    let mut c = feedscope(d.path());
    c.args(["fit-stribeck", "missing.csv", "--out", "out"]);
    let o = run(c);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

#[test]
fn fit_stribeck_help() {
    let d = tempfile::tempdir().unwrap();
    let mut c = feedscope(d.path());
    c.args(["fit-stribeck", "--help"]);
    let o = run(c);
    assert!(o.status.success());
    insta::assert_snapshot!("fit_stribeck_help", stdout(&o));
}

/// Every number in a text (JSON, console): the tokens that parse as f64.
fn numbers(text: &str) -> Vec<f64> {
    text.split(|c: char| !(c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '+')))
        .filter_map(|t| t.parse::<f64>().ok())
        .filter(|x| x.is_finite())
        .collect()
}

/// Six rows at two feeds passed the old row count (more rows than parameters) and fitted four
/// parameters to two distinct speeds. Now the least-squares line F = Fc + σ·v is reported,
/// the console names the model and why, and no absurd number is written.
#[test]
fn two_feed_table_reports_the_coulomb_viscous_line() {
    let d = tempfile::tempdir().unwrap();
    let table = "feed_mm_min,force_n\n600,181\n600,183.5\n600,185\n\
                 3000,228\n3000,231\n3000,229.5\n";
    let o = fit(d.path(), table, &[]);
    let (out, err) = (stdout(&o), stderr(&o));
    assert_eq!(o.status.code(), Some(0), "{err}");
    for needle in [
        "forward: model Coulomb + viscous (F = Fc + sigma*v)",
        "a Stribeck curve (4 parameters) is not determined: it needs at least 4 distinct \
         feeds; the data have 2 (600 and 3000 mm/min)",
        "measure at least 4 distinct feeds per direction",
    ] {
        assert!(err.contains(needle), "`{needle}` not in: {err}");
    }
    let j = json(d.path());
    let dir = &j["directions"][0];
    assert_eq!(dir["model"], "coulomb-viscous");
    assert_eq!(dir["reductions"][0]["code"], "too-few-feeds");
    let p = &dir["params"];
    assert!(p["fs_n"].is_null() && p["vs_mm_min"].is_null() && p["delta"].is_null());
    // the line through the two means 183.1667 N and 229.5 N
    let (m1, m2) = (549.5 / 3.0, 688.5 / 3.0);
    let sigma = (m2 - m1) / (2400.0 / 60_000.0);
    let fc = m1 - sigma * 600.0 / 60_000.0;
    assert!((p["fc_n"].as_f64().unwrap() - fc).abs() < 1e-9 * fc, "{p}");
    assert!((p["sigma_n_s_per_m"].as_f64().unwrap() - sigma).abs() < 1e-9 * sigma);
    // 4 residual degrees of freedom: standard errors of Fc and σ
    assert!(dir["uncertainty"]["fc_n"]["std_error"].as_f64().unwrap() > 0.0);
    assert!(dir["uncertainty"]["fs_n"].is_null());
    let row = out.lines().nth(1).unwrap();
    assert!(row.starts_with("forward") && row.contains(" - "), "{out}");
    let text = std::fs::read_to_string(d.path().join("out/stribeck.json")).unwrap();
    for (name, t) in [("stdout", &out), ("stderr", &err), ("stribeck.json", &text)] {
        let worst = numbers(t).into_iter().fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(worst < 1e6, "{name}: {worst}");
    }
}

/// One distinct feed (repeated rows) is refused: a level mixes Coulomb and viscous friction.
#[test]
fn one_feed_table_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let o = fit(
        d.path(),
        "feed_mm_min,force_n\n600,181\n600,183\n600,185\n600,184\n600,182\n600,186\n",
        &[],
    );
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("the forward direction has 1 distinct feed (600 mm/min, 6 rows)")
            && err.contains("a Stribeck curve at least 4"),
        "{err}"
    );
    assert!(!d.path().join("out/stribeck.json").exists());
}
