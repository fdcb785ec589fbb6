//! `--export tf5200|sinumerik|table` of `feedscope fit-stribeck` and `feedscope map`: golden
//! files from a fixed twin case, the twin's round trip (known Stribeck parameters → simulated
//! traces → map → exported table ≈ truth), and bad input refused with exit code 2 and nothing
//! written.
use std::path::Path;

use feedscope::sim::{
    Bump, Component, ComponentDirection, DynamicsMode, FrictionParams, MeanLevel, SimConfig,
    StrokeConfig, VelocityTerm,
};
use feedscope::units::feed_mm_min_to_m_s;
use feedscope_io::trace::{write_csv, Layout};

use crate::util::{expect_bad_input, feedscope, run, stderr};

/// The twin's velocity term (not any paper's): F_s − F_c = 85 N, v_s = 45 mm/min,
/// σ = 7000 N·s/m, δ = 2 (as `crates/feedscope/tests/roundtrip/map.rs`).
const EXCESS_N: f64 = 85.0;
const VS_MM_MIN: f64 = 45.0;
const SIGMA: f64 = 7000.0;

fn velocity_term_n(feed_mm_min: f64) -> f64 {
    EXCESS_N * (-(feed_mm_min / VS_MM_MIN).powi(2)).exp() + SIGMA * feed_mm_min_to_m_s(feed_mm_min)
}

/// The twin's axis (the simulator's default lathe Z: 10 mm lead, k_e 1.82 N·m/A).
fn axis_toml() -> String {
    toml::to_string(&SimConfig::default().axis).unwrap()
}

/// The fixed twin case: exact steady-speed friction of the twin at 12 log-spaced feeds
/// 9-900 mm/min, forward on a 260 N level, backward on 310 N (negative feeds and forces).
fn twin_table() -> String {
    let mut s = String::from("# twin: Fc 260 N forward, 310 N backward; Fs - Fc 85 N; vs 45 mm/min; sigma 7000 N*s/m\nfeed_mm_min,force_n\n");
    for k in 0..12 {
        let f = 9.0 * 100f64.powf(k as f64 / 11.0);
        s.push_str(&format!("{f:.6},{:.6}\n", 260.0 + velocity_term_n(f)));
        s.push_str(&format!("{:.6},{:.6}\n", -f, -(310.0 + velocity_term_n(f))));
    }
    s
}

fn fit_export(dir: &Path, table: &str, extra: &[&str]) -> std::process::Output {
    std::fs::write(dir.join("t.csv"), table).unwrap();
    std::fs::write(dir.join("axis.toml"), axis_toml()).unwrap();
    let mut c = feedscope(dir);
    c.args([
        "fit-stribeck",
        "t.csv",
        "--out",
        "out",
        "--axis",
        "axis.toml",
    ])
    .args(extra);
    run(c)
}

/// Rows of the generic table: (direction, velocity mm/min, friction N, torque N·m, current A).
fn table_rows(path: &Path) -> Vec<(String, [f64; 4])> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .map(|l| {
            let mut it = l.split(',');
            let d = it.next().unwrap().to_string();
            let x: Vec<f64> = it.map(|s| s.parse().unwrap()).collect();
            (d, [x[0], x[1], x[2], x[3]])
        })
        .collect()
}

#[test]
fn fit_stribeck_exports_golden_files() {
    let d = tempfile::tempdir().unwrap();
    let o = fit_export(
        d.path(),
        &twin_table(),
        &[
            "--export",
            "tf5200,sinumerik",
            "--export",
            "table",
            "--tf5200-out-unit-a",
            "0.001",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("frict_comp_tf5200.txt: 20 entries"), "{err}");
    assert!(err.contains("STARTING VALUES"), "{err}");
    let out = d.path().join("out");
    let read = |f: &str| std::fs::read_to_string(out.join(f)).unwrap();
    insta::assert_snapshot!("export_tf5200", read("frict_comp_tf5200.txt"));
    insta::assert_snapshot!("export_sinumerik", read("frict_comp_sinumerik.txt"));
    insta::assert_snapshot!("export_table", read("frict_comp_table.csv"));
    // The twin is exact: the rows are the truth at their velocities (to the 1e-6 printed).
    let rows = table_rows(&out.join("frict_comp_table.csv"));
    assert_eq!(rows.len(), 40);
    for (dir, [v, f, t, i]) in &rows {
        let level = if dir == "forward" { 260.0 } else { 310.0 };
        let truth = level + velocity_term_n(*v);
        assert!((f - truth).abs() < 1e-4, "{dir} {v}: {f} vs {truth}");
        // T = F·p/(2π), i = T/k_e on the twin axis (10 mm, 1.82 N·m/A)
        assert!((t - f * 0.010 / (2.0 * std::f64::consts::PI)).abs() < 2e-6);
        assert!((i - t / 1.82).abs() < 2e-6);
    }
}

/// Known Stribeck parameters → fit of a table with a ±1 N ripple (the noise stand-in of the
/// fit-stribeck tests) → exported rows within the fit's accuracy of the truth.
#[test]
fn fit_stribeck_round_trip_within_the_fit_accuracy() {
    let d = tempfile::tempdir().unwrap();
    let mut s = String::from("feed_mm_min,force_n\n");
    for k in 0..18 {
        let f = 5.0 * 120f64.powf(k as f64 / 17.0);
        let ripple = if k % 2 == 0 { 1.0 } else { -1.0 };
        s.push_str(&format!(
            "{f:.4},{:.4}\n",
            260.0 + velocity_term_n(f) + ripple
        ));
    }
    let o = fit_export(
        d.path(),
        &s,
        &["--export", "table", "--export-points", "12"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let rows = table_rows(&d.path().join("out/frict_comp_table.csv"));
    assert_eq!(rows.len(), 12);
    assert!((rows[0].1[0] - 5.0).abs() < 1e-3 && (rows[11].1[0] - 600.0).abs() < 1e-2);
    for (_, [v, f, ..]) in &rows {
        let truth = 260.0 + velocity_term_n(*v);
        // ±1 N of ripple on ~300 N: the fit is within about 1 N of the truth (0.5 %).
        assert!((f - truth).abs() < 0.005 * truth, "{v}: {f} vs {truth}");
    }
}

/// The twin's friction: levels 260 + 0.4·z (with a bump) forward and 310 − 0.3·z backward,
/// the velocity term above, 3 N of ripple at orders 2 and 3.7.
fn twin_friction() -> FrictionParams {
    let comp = |order: f64, phase_deg: f64| Component {
        order,
        amplitude_n: 3.0,
        phase_deg,
        direction: ComponentDirection::Both,
        cause: String::new(),
    };
    FrictionParams {
        sign_smoothing_mm_s: 0.01,
        forward: MeanLevel {
            offset_n: 260.0,
            trend_n_per_mm: 0.4,
            bumps: vec![Bump {
                center_mm: 45.0,
                width_mm: 8.0,
                height_n: 25.0,
            }],
        },
        backward: MeanLevel {
            offset_n: 310.0,
            trend_n_per_mm: -0.3,
            bumps: vec![],
        },
        velocity: VelocityTerm {
            static_excess_n: EXCESS_N,
            stribeck_velocity_mm_min: VS_MM_MIN,
            shape_exponent: 2.0,
            viscous_n_s_per_m: SIGMA,
        },
        components: vec![comp(2.0, 30.0), comp(3.7, 100.0)],
    }
}

const MAP_FEEDS: [f64; 6] = [12.0, 25.0, 50.0, 100.0, 250.0, 600.0];

/// A test set of the twin: 6 feeds × 2 repeats of 25 → 45 mm and back, sampled every 20 ms,
/// with `index.csv` and `axis.toml`.
fn twin_set(dir: &Path) {
    std::fs::create_dir_all(dir.join("runs")).unwrap();
    let mut index = String::from("file,feed_mm_min,repeat\n");
    for (i, &f) in MAP_FEEDS.iter().enumerate() {
        for r in 1..=2u32 {
            let mut c = SimConfig {
                seed: 300 + 10 * i as u64 + r as u64,
                friction: Some(twin_friction()),
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
            let out = feedscope::sim::simulate(&c, &mut |_| {}).unwrap();
            let name = format!("runs/f{f}_r{r}.csv");
            write_csv(
                &out.trace,
                std::fs::File::create(dir.join(&name)).unwrap(),
                Layout::Long,
            )
            .unwrap();
            index.push_str(&format!("{name},{f},{r}\n"));
        }
    }
    std::fs::write(dir.join("index.csv"), index).unwrap();
    std::fs::write(dir.join("axis.toml"), axis_toml()).unwrap();
}

fn map_args<'a>(out: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut a = vec![
        "map",
        "index.csv",
        "--axis",
        "axis.toml",
        "--out",
        out,
        "--positions",
        "35",
    ];
    a.extend_from_slice(extra);
    a
}

/// The twin's round trip through `map`: the exported table's friction at its velocities is
/// within the map's usual accuracy of the truth at the exported position (both curves), the
/// TF5200 block holds the mean of the directions, and bad export input is refused.
#[test]
fn map_round_trip_and_refusals() {
    let d = tempfile::tempdir().unwrap();
    twin_set(d.path());
    let z = 35.0;
    let truth = |dir: &str, v: f64| {
        let level = if dir == "forward" {
            260.0 + 0.4 * z + 25.0 * (-0.5 * ((z - 45.0) / 8.0f64).powi(2)).exp()
        } else {
            310.0 - 0.3 * z
        };
        level + velocity_term_n(v)
    };
    for (out, curve) in [("m1", "stribeck"), ("m2", "map")] {
        let mut c = feedscope(d.path());
        c.args(map_args(
            out,
            &[
                "--export",
                "table,tf5200,sinumerik",
                "--export-position-mm",
                "35",
                "--export-curve",
                curve,
                "--tf5200-out-unit-a",
                "0.001",
            ],
        ));
        let o = run(c);
        assert!(o.status.success(), "{curve}: {}", stderr(&o));
        let m = d.path().join(out);
        let rows = table_rows(&m.join("frict_comp_table.csv"));
        assert_eq!(rows.len(), 40);
        let mut worst = 0.0f64;
        for (dir, [v, f, ..]) in &rows {
            let t = truth(dir, *v);
            worst = worst.max((f - t).abs() / t);
        }
        // Within the map's usual accuracy (docs/friction-map.md): the Stribeck fit at a
        // position recovers the twin's parameters to a fraction of a per cent (0.24 % worst
        // here), the map's section misses part of the Stribeck knee (1.4 % here, within the
        // 1.9 % stated for the map, tested at 4 % in the library's round trip).
        let tolerance = if curve == "stribeck" { 0.01 } else { 0.03 };
        assert!(worst < tolerance, "{curve}: worst relative error {worst}");
        eprintln!("{curve}: worst relative error of the exported table {worst:.4}");
        let tf = std::fs::read_to_string(m.join("frict_comp_tf5200.txt")).unwrap();
        assert!(tf.contains("frict_comp.table_entries        20"), "{tf}");
        assert!(tf.contains("at 35.000 mm"), "{tf}");
        let sn = std::fs::read_to_string(m.join("frict_comp_sinumerik.txt")).unwrap();
        assert!(sn.contains("$MA_FRICT_COMP_CONST_MAX[AX1]="), "{sn}");
    }

    // Refusals: exit 2, the flag named, nothing new written.
    let p = d.path();
    expect_bad_input(
        p,
        &map_args("x1", &["--export", "table", "--export-position-mm", "80"]),
        &["--export-position-mm"],
    );
    expect_bad_input(
        p,
        &map_args("x2", &["--export", "table", "--export-points", "1"]),
        &["--export-points 1"],
    );
    expect_bad_input(
        p,
        &map_args(
            "x3",
            &[
                "--export",
                "tf5200",
                "--tf5200-out-unit-a",
                "0.001",
                "--export-points",
                "21",
            ],
        ),
        &["P-COMP-00062", "--tf5200-max-points"],
    );
    expect_bad_input(
        p,
        &map_args("x4", &["--export", "tf5200"]),
        &["--tf5200-out-unit-a"],
    );
    expect_bad_input(
        p,
        &map_args("x5", &["--export-position-mm", "35"]),
        &["used only with --export"],
    );
    for x in ["x1", "x2", "x3", "x4", "x5"] {
        assert!(!p.join(x).exists(), "{x} was written");
    }
}

#[test]
fn fit_stribeck_export_refusals() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    std::fs::write(p.join("t.csv"), twin_table()).unwrap();
    std::fs::write(p.join("axis.toml"), axis_toml()).unwrap();
    let base = ["fit-stribeck", "t.csv", "--out", "o"];
    let with = |extra: &[&'static str]| -> Vec<&'static str> {
        let mut a = base.to_vec();
        a.extend_from_slice(extra);
        a
    };
    expect_bad_input(p, &with(&["--export", "table"]), &["--export needs --axis"]);
    expect_bad_input(
        p,
        &with(&["--axis", "axis.toml", "--tf5200-out-unit-a", "0.001"]),
        &["--tf5200-out-unit-a is used only with --export tf5200"],
    );
    expect_bad_input(
        p,
        &with(&[
            "--axis",
            "axis.toml",
            "--export",
            "tf5200",
            "--tf5200-out-unit-a",
            "1000",
        ]),
        &["--export tf5200", "too coarse"],
    );
    expect_bad_input(
        p,
        &with(&[
            "--axis",
            "axis.toml",
            "--lead-mm",
            "12",
            "--export",
            "table",
        ]),
        &["--lead-mm 12 disagrees with lead_mm = 10"],
    );
    // An axis file without the torque constant: the key is named.
    let axis = axis_toml().replace("torque_constant_nm_per_a = 1.82\n", "");
    std::fs::write(p.join("bad_axis.toml"), axis).unwrap();
    expect_bad_input(
        p,
        &with(&["--axis", "bad_axis.toml", "--export", "table"]),
        &["torque_constant_nm_per_a"],
    );
    // Two feeds give a Coulomb + viscous line: a table, but no SINUMERIK starting values.
    std::fs::write(
        p.join("two.csv"),
        "feed_mm_min,force_n\n50,300\n50,301\n500,330\n500,331\n",
    )
    .unwrap();
    expect_bad_input(
        p,
        &[
            "fit-stribeck",
            "two.csv",
            "--out",
            "o",
            "--axis",
            "axis.toml",
            "--export",
            "sinumerik",
        ],
        &[
            "--export sinumerik",
            "breakaway friction",
            "coulomb-viscous",
        ],
    );
    assert!(
        !p.join("o").join("stribeck.json").exists(),
        "outputs written on a refusal"
    );
    let mut c = feedscope(p);
    c.args([
        "fit-stribeck",
        "two.csv",
        "--out",
        "o2",
        "--axis",
        "axis.toml",
        "--export",
        "table",
        "--export-points",
        "3",
    ]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let rows = table_rows(&p.join("o2/frict_comp_table.csv"));
    assert_eq!(rows.len(), 3);
    let text = std::fs::read_to_string(p.join("o2/frict_comp_table.csv")).unwrap();
    assert!(text.contains("coulomb-viscous fit"), "{text}");
}
