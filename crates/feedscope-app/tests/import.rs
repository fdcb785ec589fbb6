//! A controller export made a trace through the application layer, on the repository's real
//! excerpts (`crates/feedscope-cli/tests/data/import/`, see its README for their sources): a
//! request body is the JSON a server would take (a misspelt key refused), the Okuma SHDR log's
//! Z1 axis becomes a trace that reads back with the counted samples, its report is the JSON
//! layout, and bad options and missing axes are named in the front end's spelling with
//! nothing written.
use std::path::PathBuf;

use feedscope::ErrorKind;
use feedscope_app::import::{ImportRequest, ImportSource, Listing};
use feedscope_app::{FrontEnd, Quiet};

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../feedscope-cli/tests/data/import")
        .join(name)
}

/// The command line's spelling.
struct Flags;
impl FrontEnd for Flags {
    fn name(&self, field: &str) -> String {
        format!("--{}", field.replace('_', "-"))
    }
}

#[test]
fn a_request_body_converts_the_okuma_log_and_its_report_is_the_layout() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("z1.csv");
    let body = serde_json::json!({
        "source": {"shdr": {
            "log": data("okuma_head640.txt"),
            "devices": data("okuma_Devices.xml"),
            "axis": "Z1",
            "params": {"torque_per_load_nm": 20.0}
        }},
        "output": out,
    });
    let request: ImportRequest = serde_json::from_value(body.clone()).unwrap();
    let done = request.run(&Quiet).unwrap();
    let (trace, _) =
        feedscope_io::trace::read_trace_file(&out, &feedscope_io::trace::ReadOptions::default())
            .unwrap();
    assert_eq!(trace.position_m.len(), done.import.position.samples);
    assert_eq!(trace.effort.len(), done.import.effort.samples);
    assert!(
        done.import.position.samples > 10,
        "{:?}",
        done.import.position
    );
    assert_eq!(done.effort_column, "torque_nm");
    // The report's serde form: what `import` would return as JSON.
    let json = serde_json::to_value(&done).unwrap();
    let keys: Vec<&str> = json
        .as_object()
        .unwrap()
        .keys()
        .map(String::as_str)
        .collect();
    assert_eq!(keys, ["effort_column", "import", "notes", "output"]);
    let import = json["import"].as_object().unwrap();
    for k in [
        "source_name",
        "time_zero",
        "time_zero_rule",
        "position",
        "effort",
        "effort_rule",
        "warnings",
    ] {
        assert!(import.contains_key(k), "{k} missing: {import:?}");
    }
    assert!(
        json["import"]["time_zero"].is_string(),
        "{}",
        json["import"]["time_zero"]
    );

    // A misspelt key of a request body is refused, not ignored.
    let mut bad = body;
    bad["source"]["shdr"]["params"]["torque_per_load"] = 20.0.into();
    let e = serde_json::from_value::<ImportRequest>(bad).unwrap_err();
    assert!(e.to_string().contains("torque_per_load"), "{e}");

    // Listing needs no axis and names the axes there are.
    let source = ImportSource::Shdr {
        log: data("okuma_head640.txt"),
        devices: data("okuma_Devices.xml"),
        device: None,
        axis: None,
        params: Default::default(),
    };
    match source.list(&Flags).unwrap() {
        Listing::Shdr { log, .. } => assert!(!log.series.is_empty()),
        other => panic!("{other:?}"),
    }
}

#[test]
fn bad_options_and_a_missing_axis_are_named_and_nothing_is_written() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("x.csv");
    let umich = |rate_hz: f64, axis: Option<&str>| ImportRequest {
        source: ImportSource::Umich {
            file: data("umich_experiment_01_head120.csv"),
            axis: axis.map(str::to_string),
            params: feedscope_io::import::umich::UmichParams {
                rate_hz,
                ..Default::default()
            },
        },
        output: out.clone(),
        keep_empty_channels: false,
    };
    let e = umich(0.0, Some("X")).run(&Flags).unwrap_err();
    assert_eq!(
        (e.kind(), e.field()),
        (ErrorKind::BadInput, Some("rate_hz"))
    );
    assert!(e.to_string().starts_with("--rate-hz 0 must be"), "{e}");
    let e = umich(10.0, None).run(&Flags).unwrap_err();
    assert_eq!(e.field(), Some("axis"));
    assert!(e.to_string().starts_with("--axis is required"), "{e}");
    let shdr = ImportRequest {
        source: ImportSource::Shdr {
            log: data("okuma_head640.txt"),
            devices: data("okuma_Devices.xml"),
            device: None,
            axis: Some("Z1".into()),
            params: feedscope_io::import::shdr::ShdrConvertParams {
                torque_per_load_nm: Some(f64::NAN),
                ..Default::default()
            },
        },
        output: out.clone(),
        keep_empty_channels: false,
    };
    let e = shdr.run(&Flags).unwrap_err();
    assert_eq!(e.field(), Some("torque_per_load_nm"));
    assert!(!out.exists());
    // The real file converts at 10 Hz: 120 rows.
    let done = umich(10.0, Some("X")).run(&Flags).unwrap();
    assert_eq!(done.import.position.samples, 120);
    assert!((done.import.position.median_interval_s - 0.1).abs() < 1e-12);
}
