//! `feedscope identify`: a simulated triangular-wave test end to end, the comparison with
//! constant-speed groups, and refusals with exit code 2.
use std::f64::consts::PI;
use std::path::Path;

use feedscope::plan::{
    strokes_program, triangle_program, Limits, StrokeTestParams, TriangleParams,
};
use feedscope::sim::{
    simulate_profile, DynamicsMode, FrictionParams, MeanLevel, MotionProfile, SamplingMode,
    SimConfig, VelocityTerm,
};
use feedscope::trace::EffortKind;
use feedscope_io::trace::{write_csv, Layout};

use crate::util::{feedscope, run, stderr, stdout};

const AXIS: &str = "name = \"ident Z\"\nlead_mm = 12\ntable_mass_kg = 180\n\
    inertia_kgm2 = 0.0025\ndamping_nms_per_rad = 0\ntorque_constant_nm_per_a = 1.2\n";

/// Truth: F_c 180 N, F_s 250 N, v_s 90 mm/min, σ 3500 N·s/m, no ripple; 1 kHz synchronous
/// torque, 10 nm position quantum.
fn cfg(sync: bool) -> SimConfig {
    let mut c = SimConfig {
        axis: feedscope::axis::AxisParams::parse(AXIS, feedscope::axis::ConfigFormat::Toml, "a")
            .unwrap(),
        ..SimConfig::default()
    };
    c.axis.travel_min_mm = Some(0.0);
    c.axis.travel_max_mm = Some(450.0);
    let level = MeanLevel {
        offset_n: 180.0,
        trend_n_per_mm: 0.0,
        bumps: vec![],
    };
    c.friction = Some(FrictionParams {
        sign_smoothing_mm_s: 0.01,
        forward: level.clone(),
        backward: level,
        velocity: VelocityTerm {
            static_excess_n: 70.0,
            stribeck_velocity_mm_min: 90.0,
            shape_exponent: 2.0,
            viscous_n_s_per_m: 3500.0,
        },
        components: vec![],
    });
    c.dynamics.mode = DynamicsMode::Ideal;
    if sync {
        c.sampling.mode = SamplingMode::Synchronous;
        c.sampling.effort_kind = EffortKind::TorqueNm;
    } else {
        for s in [
            &mut c.sampling.position.interval_ms,
            &mut c.sampling.effort.interval_ms,
        ] {
            *s = 8.0;
        }
        c.sampling.position.jitter_ms = 0.5;
        c.sampling.effort.jitter_ms = 0.5;
        c.sampling.effort.start_offset_ms = 4.0;
    }
    c.sampling.position.quantum_mm = 1e-5;
    c
}

fn write_trace(path: &Path, c: &SimConfig, profile: &dyn MotionProfile, layout: Layout) {
    let out = simulate_profile(c, profile, &mut |_| {}).unwrap();
    let f = std::fs::File::create(path).unwrap();
    write_csv(&out.trace, f, layout).unwrap();
}

fn triangle_trace(dir: &Path) {
    let p = triangle_program(
        &TriangleParams {
            window_min_mm: 50.0,
            window_max_mm: 150.0,
            feed_max_mm_min: 6000.0,
            levels: 8,
            min_cruise_s: 1.0,
            vs_guess_mm_min: 90.0,
            ..TriangleParams::default()
        },
        &Limits::default(),
    )
    .unwrap();
    std::fs::write(dir.join("axis.toml"), AXIS).unwrap();
    write_trace(&dir.join("tri.csv"), &cfg(true), &p, Layout::Wide);
}

fn rel(a: &serde_json::Value, b: f64) -> f64 {
    (a.as_f64().unwrap() - b).abs() / b
}

#[test]
fn identify_recovers_simulated_parameters_and_writes_plot() {
    let d = tempfile::tempdir().unwrap();
    triangle_trace(d.path());
    let mut c = feedscope(d.path());
    c.args([
        "identify",
        "tri.csv",
        "--axis",
        "axis.toml",
        "-o",
        "ident.json",
    ]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("J total"), "{}", stdout(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("ident.json")).unwrap())
            .unwrap();
    let k = 0.012 / (2.0 * PI);
    let m = &v["motor"];
    assert!(
        rel(&m["j_total_kgm2"], 0.0025 + 180.0 * k * k) < 0.05,
        "{m}"
    );
    assert!(rel(&m["tc_nm"], 180.0 * k) < 0.05, "{m}");
    assert!(rel(&m["ts_nm"], 250.0 * k) < 0.05, "{m}");
    assert!(rel(&m["sigma_nm_s_per_m"], 3500.0 * k) < 0.05, "{m}");
    assert!(rel(&m["vs_mm_min"], 90.0) < 0.10, "{m}");
    let f = &v["force"];
    assert!(
        rel(&f["fc_n"], 180.0) < 0.05 && rel(&f["fs_n"], 250.0) < 0.05,
        "{f}"
    );
    assert!(rel(&f["sigma_n_s_per_m"], 3500.0) < 0.05, "{f}");
    for key in [
        "tc_nm",
        "ts_nm",
        "vs_mm_min",
        "sigma_nm_s_per_m",
        "j_total_kgm2",
    ] {
        assert!(v["std_error"][key].as_f64().unwrap() > 0.0, "{key}");
    }
    assert!(v["diagnostics"]["residual_rms_nm"].as_f64().unwrap() < 0.02);
    let svg = std::fs::read_to_string(d.path().join("ident.svg")).unwrap();
    assert!(svg.contains("torque (N·m)") && svg.contains("time (s)"));
}

#[test]
fn identify_compare_reports_both_sets() {
    let d = tempfile::tempdir().unwrap();
    triangle_trace(d.path());
    let strokes = strokes_program(
        &StrokeTestParams {
            from_mm: 100.0,
            to_mm: 160.0,
            feeds_mm_min: vec![20.0, 45.0, 90.0, 180.0, 400.0, 900.0, 2000.0, 4000.0],
            repeats: 1,
            dwell_s: 0.5,
            accel_mm_s2: 1000.0,
        },
        &Limits::default(),
    )
    .unwrap();
    write_trace(
        &d.path().join("groups.csv"),
        &cfg(false),
        &strokes,
        Layout::Long,
    );
    let mut c = feedscope(d.path());
    c.args([
        "identify",
        "tri.csv",
        "--axis",
        "axis.toml",
        "--compare",
        "groups.csv",
        "--no-plot",
        "--format",
        "json",
    ]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    let g = &v["compare"];
    assert_eq!(g["groups"].as_array().unwrap().len(), 16);
    let k = 0.012 / (2.0 * PI);
    assert!(rel(&g["motor"]["tc_nm"], 180.0 * k) < 0.05, "{g}");
    assert!(
        rel(&g["motor"]["sigma_nm_s_per_m"], 3500.0 * k) < 0.05,
        "{g}"
    );
    assert!(g["difference_percent"]["tc"].as_f64().unwrap().abs() < 5.0);
}

/// Back and forth at one feed: the trace cannot separate a Stribeck curve; exit 2 with a
/// clear reason and no output file.
#[test]
fn one_speed_trace_is_not_identifiable() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("axis.toml"), AXIS).unwrap();
    let p = strokes_program(
        &StrokeTestParams {
            from_mm: 10.0,
            to_mm: 40.0,
            feeds_mm_min: vec![600.0],
            repeats: 2,
            dwell_s: 0.5,
            accel_mm_s2: 1000.0,
        },
        &Limits::default(),
    )
    .unwrap();
    write_trace(&d.path().join("one.csv"), &cfg(true), &p, Layout::Wide);
    let mut c = feedscope(d.path());
    c.args(["identify", "one.csv", "--axis", "axis.toml"]);
    let o = run(c);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("not identifiable"), "{}", stderr(&o));
    assert!(!d.path().join("ident.json").exists());
    // `history add` says it once too (its error quoted the refusal and then chained it)
    let mut c = feedscope(d.path());
    c.args([
        "history",
        "add",
        "one.csv",
        "--axis",
        "axis.toml",
        "--kind",
        "triangle",
        "--store",
        "h.db",
    ]);
    let o = run(c);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_eq!(
        stderr(&o).matches("not identifiable").count(),
        1,
        "{}",
        stderr(&o)
    );
}

/// Forward only, several feeds: no reversal; exit 2.
#[test]
fn trace_without_reversal_is_not_identifiable() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("axis.toml"), AXIS).unwrap();
    let mut s = String::from("time_s,position_mm,torque_nm\n");
    for i in 0..20_000 {
        let t = i as f64 * 1e-3;
        // accelerating forward from 0 to 2400 mm/min: many speeds, one direction
        let z = 1.0 * t * t;
        s.push_str(&format!("{t:.3},{z:.6},{:.4}\n", 0.35 + 0.01 * t));
    }
    std::fs::write(d.path().join("fwd.csv"), s).unwrap();
    let mut c = feedscope(d.path());
    c.args(["identify", "fwd.csv", "--axis", "axis.toml"]);
    let o = run(c);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("reversal"), "{}", stderr(&o));
}

/// Paper 000's logger (asynchronous, every 72 ms) on a wave with 0.1 s ramps: exit 2 with the
/// figures that decide it (rows, the longest acceleration phase in ms and samples, what a row
/// needs) and only advice the data do not already meet; no output file.
#[test]
fn polled_short_ramps_are_refused_with_the_figures() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("axis.toml"), AXIS).unwrap();
    let p = triangle_program(
        &TriangleParams {
            window_min_mm: 0.0,
            window_max_mm: 400.0,
            feed_max_mm_min: 6000.0,
            levels: 8,
            min_cruise_s: 10.0,
            vs_guess_mm_min: 90.0,
            ..TriangleParams::default()
        },
        &Limits::default(),
    )
    .unwrap();
    let mut c = cfg(false);
    for s in [
        &mut c.sampling.position.interval_ms,
        &mut c.sampling.effort.interval_ms,
    ] {
        *s = 72.0;
    }
    c.sampling.position.jitter_ms = 3.0;
    c.sampling.effort.jitter_ms = 3.0;
    c.sampling.effort.start_offset_ms = 30.0;
    write_trace(&d.path().join("polled.csv"), &c, &p, Layout::Long);
    let mut cmd = feedscope(d.path());
    cmd.args(["identify", "polled.csv", "--axis", "axis.toml"]);
    let o = run(cmd);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    for needle in [
        "no usable acceleration",
        "rows see the acceleration",
        "at least 10 needed",
        "The longest acceleration phase in one direction lasts",
        "samples at 13.9 Hz",
        "a row needs",
        "plan gentler ramps",
    ] {
        assert!(err.contains(needle), "missing {needle:?} in {err}");
    }
    // never the old advice that a faster trace would already meet
    assert!(!err.contains("80 Hz"), "{err}");
    assert!(!d.path().join("ident.json").exists());
}

#[test]
fn bad_parameter_is_exit_2() {
    let d = tempfile::tempdir().unwrap();
    triangle_trace(d.path());
    let mut c = feedscope(d.path());
    c.args(["identify", "tri.csv", "--axis", "axis.toml", "--delta", "0"]);
    let o = run(c);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("delta"), "{}", stderr(&o));
}

/// The axis file of [`AXIS`] without the inertia and the damping: what a user knows before
/// the test (lead, table mass, torque constant).
const AXIS_NO_J: &str = "name = \"ident Z\"\nlead_mm = 12\ntable_mass_kg = 180\n\
    torque_constant_nm_per_a = 1.2\n";

/// `identify` and `history add --kind triangle` accept an axis file without
/// `inertia_kgm2`/`damping_nms_per_rad` (J is what they identify); `estimate`, `history add
/// --kind strokes` and `identify --compare` still need them and say so (exit 2, key named).
#[test]
fn axis_without_inertia_is_enough_to_identify() {
    let d = tempfile::tempdir().unwrap();
    triangle_trace(d.path());
    std::fs::write(d.path().join("axis-no-j.toml"), AXIS_NO_J).unwrap();
    let mut c = feedscope(d.path());
    c.args([
        "identify",
        "tri.csv",
        "--axis",
        "axis-no-j.toml",
        "--no-plot",
    ]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("gives no inertia"), "{}", stdout(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("ident.json")).unwrap())
            .unwrap();
    assert!(v["axis_j_total_kgm2"].is_null(), "{v}");
    // 1 kHz, 10 nm, ideal dynamics: J within 1 % (the joint fit's target)
    let k = 0.012 / (2.0 * PI);
    assert!(
        rel(&v["motor"]["j_total_kgm2"], 0.0025 + 180.0 * k * k) < 0.01,
        "{v}"
    );

    let needs = |args: &[&str]| {
        let mut c = feedscope(d.path());
        c.args(args);
        let o = run(c);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(
            e.contains("inertia_kgm2") && e.contains("axis-no-j.toml"),
            "{args:?}: {e}"
        );
    };
    needs(&[
        "estimate",
        "tri.csv",
        "--axis",
        "axis-no-j.toml",
        "-o",
        "f.csv",
    ]);
    needs(&[
        "identify",
        "tri.csv",
        "--axis",
        "axis-no-j.toml",
        "--compare",
        "tri.csv",
    ]);
    needs(&[
        "history",
        "--db",
        "h.db",
        "add",
        "tri.csv",
        "--kind",
        "strokes",
        "--axis",
        "axis-no-j.toml",
    ]);

    let mut c = feedscope(d.path());
    c.args([
        "history",
        "--db",
        "h.db",
        "add",
        "tri.csv",
        "--kind",
        "triangle",
        "--axis",
        "axis-no-j.toml",
    ]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut c = feedscope(d.path());
    c.args(["history", "--db", "h.db", "export", "--format", "csv"]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let j_row = stdout(&o)
        .lines()
        .find(|l| l.contains(",j_total_kgm2,"))
        .map(str::to_string)
        .unwrap_or_else(|| panic!("no J row in {}", stdout(&o)));
    let j: f64 = j_row.split(',').nth(6).unwrap().parse().unwrap();
    assert!((j / (0.0025 + 180.0 * k * k) - 1.0).abs() < 0.01, "{j_row}");
}

#[test]
fn identify_help() {
    let d = tempfile::tempdir().unwrap();
    let mut c = feedscope(d.path());
    c.args(["identify", "--help"]);
    let o = run(c);
    assert!(o.status.success());
    insta::assert_snapshot!("identify_help", stdout(&o));
}
