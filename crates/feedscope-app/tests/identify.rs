//! `identify` through the application layer: a request from files and the same traces held in
//! memory give one report (the `ident.json` layout, pinned by a snapshot), fields are named in
//! errors, and the twin's inertia comes back.
use std::path::Path;

use feedscope::plan::{triangle_program, Limits, TriangleParams};
use feedscope::sim::{simulate_profile, DynamicsMode, SamplingMode, SimConfig, SimOutput};
use feedscope::ErrorKind;
use feedscope_app::identify::{identify_recordings, IdentifyOptions, IdentifyRequest};
use feedscope_app::{FrontEnd, Quiet, Recording};
use feedscope_io::trace::{write_csv, Layout};

/// A triangular-wave test on a twin unlike the default lathe: a 16 mm lead, 450 kg table,
/// sampled at 400 Hz with the controller's noise.
fn twin() -> (SimConfig, SimOutput) {
    let mut cfg = SimConfig::default();
    cfg.axis.lead_mm = 16.0;
    cfg.axis.table_mass_kg = 450.0;
    cfg.axis.travel_min_mm = None;
    cfg.axis.travel_max_mm = None;
    cfg.dynamics.mode = DynamicsMode::Servo;
    cfg.sampling.mode = SamplingMode::Synchronous;
    cfg.sampling.synchronous_rate_hz = 400.0;
    let plan = TriangleParams {
        window_min_mm: 0.0,
        window_max_mm: 200.0,
        feed_max_mm_min: 6000.0,
        accel_mm_s2: 800.0,
        ..TriangleParams::default()
    };
    let program = triangle_program(&plan, &Limits::default()).unwrap();
    let out = simulate_profile(&cfg, &program, &mut |_| {}).unwrap();
    (cfg, out)
}

fn write_files(dir: &Path, cfg: &SimConfig, out: &SimOutput) {
    let f = std::fs::File::create(dir.join("tri.csv")).unwrap();
    write_csv(&out.trace, f, Layout::Wide).unwrap();
    std::fs::write(
        dir.join("axis.toml"),
        toml::to_string_pretty(&cfg.axis).unwrap(),
    )
    .unwrap();
}

/// Numbers to 4 significant digits: the snapshot pins the keys (sorted: a `serde_json::Value`
/// map) and the values a user reads, not the last bits of a float.
fn rounded(v: serde_json::Value) -> serde_json::Value {
    use serde_json::Value;
    match v {
        Value::Number(n) => match n.as_f64() {
            Some(x) if n.is_f64() && x != 0.0 => {
                let digits = 3 - x.abs().log10().floor() as i32;
                let s = 10f64.powi(digits);
                serde_json::json!((x * s).round() / s)
            }
            _ => Value::Number(n),
        },
        Value::Array(a) => Value::Array(a.into_iter().map(rounded).collect()),
        Value::Object(m) => Value::Object(m.into_iter().map(|(k, v)| (k, rounded(v))).collect()),
        other => other,
    }
}

#[test]
fn files_and_memory_give_one_report_and_the_twins_inertia() {
    let (cfg, out) = twin();
    let d = tempfile::tempdir().unwrap();
    write_files(d.path(), &cfg, &out);
    let request = IdentifyRequest {
        trace: d.path().join("tri.csv"),
        axis: d.path().join("axis.toml"),
        ..IdentifyRequest::default()
    };
    let from_files = request.run(&Quiet).unwrap();
    let source = request.trace.display().to_string();
    // The CSV holds the trace to its printed digits: the same numbers read back.
    let axis = feedscope_io::axis::load_for_identification(&request.axis).unwrap();
    let (trace, read) = feedscope_io::trace::read_trace_file_with(
        &request.trace,
        &feedscope_io::trace::ReadOptions::default(),
        &feedscope::trace::GlitchParams::for_axis(&axis),
    )
    .unwrap();
    let held = Recording::borrowed(&trace, source.clone(), read);
    let in_memory =
        identify_recordings(&held, None, &axis, &IdentifyOptions::default(), &Quiet).unwrap();
    assert_eq!(from_files.report, in_memory.report);
    let r = &from_files.report;
    let truth = r.axis_j_total_kgm2.unwrap();
    let j = r.set.motor.j_total_kgm2;
    assert!((j - truth).abs() < 0.03 * truth, "J {j} against {truth}");
    assert!(r.set.std_error.j_total_kgm2 < 0.02 * truth);
    assert!(r.set.force.fs_n > r.set.force.fc_n);
    let mut shown = rounded(serde_json::to_value(r).unwrap());
    shown["source"] = "tri.csv".into();
    insta::assert_snapshot!(serde_json::to_string_pretty(&shown).unwrap());
}

#[test]
fn a_bad_request_names_its_field_before_anything_is_read() {
    let missing = IdentifyRequest::default();
    assert_eq!(missing.validate().unwrap_err().field(), Some("trace"));
    let mut r = IdentifyRequest {
        trace: "nowhere.csv".into(),
        axis: "nowhere.toml".into(),
        ..IdentifyRequest::default()
    };
    r.options.params.delta = 0.0;
    let e = r.run(&Quiet).unwrap_err();
    assert_eq!((e.kind(), e.field()), (ErrorKind::BadInput, Some("delta")));
    assert!(e.to_string().contains("`delta` = 0"), "{e}");
    // A request is its JSON body: unknown keys are refused, the settings sit at the top.
    let body =
        r#"{"trace": "t.csv", "axis": "a.toml", "effort": "torque", "params": {"delta": 1.5}}"#;
    let parsed: IdentifyRequest = serde_json::from_str(body).unwrap();
    assert!((parsed.options.params.delta - 1.5).abs() < 1e-12);
    assert!(serde_json::from_str::<IdentifyRequest>(r#"{"trace": "t.csv", "delt": 1}"#).is_err());
}

/// The front end spells the fields its user types.
struct Flags;
impl FrontEnd for Flags {
    fn name(&self, field: &str) -> String {
        format!("--{field}")
    }
    fn spell(&self, field: &str, value: &str) -> String {
        format!("--{field} {value}")
    }
}

#[test]
fn compare_without_the_axis_dynamics_is_refused_naming_the_key_and_the_flag() {
    let (mut cfg, out) = twin();
    cfg.axis.inertia_kgm2 = f64::NAN;
    let d = tempfile::tempdir().unwrap();
    write_files(d.path(), &cfg, &out);
    let text = std::fs::read_to_string(d.path().join("axis.toml")).unwrap();
    let text: String = text
        .lines()
        .filter(|l| !l.starts_with("inertia_kgm2"))
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(d.path().join("axis.toml"), text).unwrap();
    let request = IdentifyRequest {
        trace: d.path().join("tri.csv"),
        axis: d.path().join("axis.toml"),
        compare: Some(d.path().join("tri.csv")),
        ..IdentifyRequest::default()
    };
    let e = request.run(&Flags).unwrap_err();
    assert_eq!(e.field(), Some("compare"));
    let m = e.to_string();
    assert!(
        m.contains("--compare estimates the friction") && m.contains("`inertia_kgm2`"),
        "{m}"
    );
}
