//! A controller export made a trace through the application layer, on the repository's real
//! excerpts (`crates/feedscope-cli/tests/data/import/`, see its README for their sources): a
//! request body is the JSON a server would take (a misspelt key refused), the Okuma SHDR log's
//! Z1 axis becomes a trace that reads back with the counted samples, its report is the JSON
//! layout, bad options and missing axes are named in the front end's spelling with nothing
//! written, and a listing and a report read as the plain text the front ends print.
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

/// A listing's plain text is the front ends' shared view: the UMich excerpt's axes with the
/// range of each column (the lines `feedscope import umich --list` prints, golden in the CLI's
/// tests), and the TwinCAT hint names the options in the front end's spelling.
#[test]
fn a_listing_reads_as_text_in_the_front_ends_spelling() {
    let umich = ImportSource::Umich {
        file: data("umich_experiment_12_head120.csv"),
        axis: None,
        params: Default::default(),
    };
    let text = umich.list(&Quiet).unwrap().text(&Quiet);
    let lines: Vec<&str> = text.lines().collect();
    assert!(
        lines[0].starts_with("UMich CSV ")
            && lines[0].ends_with(
                "umich_experiment_12_head120.csv: 48 columns, 120 rows, line endings CR; \
                 at 10 Hz: 0.000 to 11.900 s"
            ),
        "{text}"
    );
    assert_eq!(
        lines[1..5],
        [
            "axes (3):",
            "  X1: 120 samples",
            "    X1_ActualPosition    141 to 198 mm",
            "    X1_CurrentFeedback   -6.27 to 6.68 A",
        ],
        "{text}"
    );
    assert_eq!(lines.len(), 14, "{text}");
    assert!(
        text.ends_with("    Z1_OutputCurrent     0 to 0 A\n"),
        "{text}"
    );

    // A TwinCAT export with no default channel: the hint names the options as the user
    // spells them.
    let twincat = ImportSource::Twincat {
        file: PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../feedscope-cli/tests/data/controllers/tc3_scope_shared_time_head60.csv"),
        params: Default::default(),
    };
    let listing = twincat.list(&Quiet).unwrap();
    let hint = |front: &dyn FrontEnd| {
        listing
            .text(front)
            .lines()
            .find(|l| l.starts_with("no default"))
            .map(str::to_string)
    };
    assert_eq!(
        hint(&Flags).as_deref(),
        Some("no default position or effort: name the channel(s) with --position / --effort")
    );
    assert_eq!(
        hint(&Quiet).as_deref(),
        Some("no default position or effort: name the channel(s) with `position` / `effort`")
    );
}

/// What an import wrote reads as the summary `feedscope import` prints: the file, each
/// channel's samples and source, the effort rule and time 0.
#[test]
fn an_import_report_reads_as_text() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("x.csv");
    let request = ImportRequest {
        source: ImportSource::Umich {
            file: data("umich_experiment_01_head120.csv"),
            axis: Some("X".into()),
            params: Default::default(),
        },
        output: out.clone(),
        keep_empty_channels: false,
    };
    let text = request.run(&Quiet).unwrap().text();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(
        lines[0],
        format!(
            "wrote {} (long layout: position_mm, current_a)",
            out.display()
        )
    );
    assert!(
        lines[1].starts_with("  position_mm      120 samples  0.000 to 11.900 s  median interval 0.100 s  from X1_ActualPosition"),
        "{text}"
    );
    assert!(
        lines[2].starts_with("  current_a        120 samples"),
        "{text}"
    );
    assert!(lines[3].starts_with("  effort: "), "{text}");
    assert!(lines[4].starts_with("  time zero: "), "{text}");
    assert_eq!(lines.len(), 5, "{text}");
}
