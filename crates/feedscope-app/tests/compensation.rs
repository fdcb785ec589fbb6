//! Controller exports through the application layer: the settings are checked before
//! anything is read, each refusal naming its field in the front end's spelling; a Stribeck
//! fit's request makes the files it asks for, and the requests' serde form carries the
//! export settings beside the others.
use feedscope::ErrorKind;
use feedscope_app::compensation::{ExportKind, ExportOptions, DEFAULT_POINTS};
use feedscope_app::map::{ExportCurve, MapRequest};
use feedscope_app::stribeck::FitStribeckRequest;
use feedscope_app::FrontEnd;

/// Spells fields as the command line does: `--export-points`, `--export tf5200`.
struct Flags;
impl FrontEnd for Flags {
    fn name(&self, field: &str) -> String {
        format!("--{}", field.replace('_', "-"))
    }
    fn spell(&self, field: &str, value: &str) -> String {
        format!("{} {value}", self.name(field))
    }
}

fn with(kinds: &[ExportKind]) -> ExportOptions {
    ExportOptions {
        kinds: kinds.to_vec(),
        ..ExportOptions::default()
    }
}

#[test]
fn export_settings_are_refused_naming_their_field() {
    use ExportKind::{Sinumerik, Table, Tf5200};
    let tf = |o: ExportOptions| ExportOptions {
        tf5200_out_unit_a: Some(0.001),
        ..o
    };
    let cases: Vec<(ExportOptions, &str, &str)> = vec![
        (
            ExportOptions {
                export_points: Some(10),
                ..ExportOptions::default()
            },
            "export_points",
            "--export-points is used only with --export",
        ),
        (
            ExportOptions {
                tf5200_max_points: Some(30),
                ..with(&[Table])
            },
            "tf5200_max_points",
            "--tf5200-max-points is used only with --export tf5200",
        ),
        (
            ExportOptions {
                circle_radius_mm: Some(5.0),
                ..with(&[Tf5200])
            },
            "circle_radius_mm",
            "--circle-radius-mm is used only with --export sinumerik",
        ),
        (
            ExportOptions {
                export_points: Some(1),
                ..with(&[Table])
            },
            "export_points",
            "--export-points 1: a table needs at least 2 points",
        ),
        (
            ExportOptions {
                export_points: Some(513),
                ..with(&[Table])
            },
            "export_points",
            "--export-points 513: the table holds at most 512 points",
        ),
        (
            tf(ExportOptions {
                export_points: Some(21),
                ..with(&[Tf5200])
            }),
            "export_points",
            "--export-points 21 exceeds frict_comp.max_points 20 (P-COMP-00062) of --export \
             tf5200; give --tf5200-max-points if the CNC is configured for more entries",
        ),
        (
            tf(ExportOptions {
                tf5200_max_points: Some(1),
                ..with(&[Tf5200])
            }),
            "tf5200_max_points",
            "--tf5200-max-points 1: must lie in 2..=",
        ),
        (
            with(&[Tf5200]),
            "tf5200_out_unit_a",
            "--export tf5200 needs the unit of frict_comp.table[i].out, which the TF5200 \
             documentation leaves to the drive (the unit of dig_drv.act_torque): give \
             --tf5200-out-unit-a (amperes per unit, e.g. 0.001 for mA) or --tf5200-out-unit-nm",
        ),
        (
            ExportOptions {
                tf5200_out_unit_nm: Some(-1.0),
                ..tf(with(&[Tf5200]))
            },
            "tf5200_out_unit_nm",
            "--tf5200-out-unit-nm -1: must be a positive number",
        ),
        (
            ExportOptions {
                speed_loop_hz: Some(f64::NAN),
                ..with(&[Sinumerik])
            },
            "speed_loop_hz",
            "--speed-loop-hz NaN: must be a positive number",
        ),
        (
            ExportOptions {
                sinumerik_axis: Some("1X".into()),
                ..with(&[Sinumerik])
            },
            "sinumerik_axis",
            "--sinumerik-axis `1X`: expected an axis identifier such as AX1 or Z1 (letters, \
             digits, underscore; a letter first)",
        ),
    ];
    for (options, field, message) in cases {
        let e = options.validate(&Flags).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::BadInput, "{e}");
        assert_eq!(e.field(), Some(field), "{e}");
        assert!(e.to_string().starts_with(message), "{e}\nnot {message}");
    }
    // No export: nothing to plan. Kinds given twice are written once, in a fixed order.
    assert_eq!(ExportOptions::default().validate(&Flags).unwrap(), None);
    let plan = tf(with(&[Table, Tf5200, Table]))
        .validate(&Flags)
        .unwrap()
        .unwrap();
    assert_eq!(plan.kinds, [Tf5200, Table]);
    assert_eq!(plan.points, DEFAULT_POINTS);
    assert!(plan.sinumerik.is_none() && plan.tf5200.is_some());
    let plan = with(&[Sinumerik]).validate(&Flags).unwrap().unwrap();
    assert_eq!(plan.sinumerik.unwrap().0, "AX1");
}

/// F(v) = 260 + 85·exp(−(v/45)²) + 7000·v (N, v in m/s) at 12 feeds per direction.
fn table() -> String {
    let mut s = String::from("feed_mm_min,force_n\n");
    for k in 0..12 {
        let f = 9.0 * 100f64.powf(k as f64 / 11.0);
        let force = 260.0 + 85.0 * (-(f / 45.0f64).powi(2)).exp() + 7000.0 * f / 60_000.0;
        s.push_str(&format!("{f:.6},{force:.6}\n{:.6},{:.6}\n", -f, -force));
    }
    s
}

#[test]
fn a_fit_makes_the_files_it_asks_for_and_needs_an_axis() {
    let d = tempfile::tempdir().unwrap();
    let table_path = d.path().join("t.csv");
    std::fs::write(&table_path, table()).unwrap();
    let axis_path = d.path().join("axis.toml");
    std::fs::write(
        &axis_path,
        toml::to_string(&feedscope::sim::SimConfig::default().axis).unwrap(),
    )
    .unwrap();
    let request = FitStribeckRequest {
        table: table_path.clone(),
        axis: Some(axis_path),
        export: ExportOptions {
            export_points: Some(8),
            ..with(&[ExportKind::Table, ExportKind::Sinumerik])
        },
        ..FitStribeckRequest::default()
    };
    let done = request.run(&Flags).unwrap();
    let names: Vec<&str> = done.exports.iter().map(|f| f.name).collect();
    assert_eq!(names, ["frict_comp_sinumerik.txt", "frict_comp_table.csv"]);
    let table_file = &done.exports[1];
    assert!(
        table_file.summary.starts_with("8 points per direction"),
        "{}",
        table_file.summary
    );
    let csv = String::from_utf8(table_file.bytes.clone()).unwrap();
    assert!(csv.contains("feedscope fit-stribeck"), "{csv}");
    assert!(done.exports[0].summary.contains("STARTING VALUES"));
    // Without an axis there is no conversion into torque and current: refused first.
    let e = FitStribeckRequest {
        axis: None,
        table: "not/read.csv".into(),
        ..request
    }
    .run(&Flags)
    .unwrap_err();
    assert_eq!(e.field(), Some("axis"));
    assert!(
        e.to_string()
            .starts_with("--export needs --axis AXIS.toml:"),
        "{e}"
    );
}

#[test]
fn a_map_requests_export_is_checked_before_anything_is_read() {
    let base = MapRequest {
        index: "not/read.csv".into(),
        axis: "nor/this.toml".into(),
        ..MapRequest::default()
    };
    let only = |r: MapRequest, field: &str| {
        let e = r.validate(&Flags).unwrap_err();
        assert_eq!(e.field(), Some(field), "{e}");
        assert_eq!(
            e.to_string(),
            format!("--{} is used only with --export", field.replace('_', "-"))
        );
    };
    only(
        MapRequest {
            export_position_mm: Some(35.0),
            ..base.clone()
        },
        "export_position_mm",
    );
    only(
        MapRequest {
            export_curve: ExportCurve::Map,
            ..base.clone()
        },
        "export_curve",
    );
    // The export's own settings come before the files are looked at.
    let e = MapRequest {
        export: with(&[ExportKind::Tf5200]),
        ..base.clone()
    }
    .run(&Flags)
    .unwrap_err();
    assert_eq!(e.field(), Some("tf5200_out_unit_a"), "{e}");
    assert!(base.validate(&Flags).is_ok());
}

#[test]
fn the_requests_serde_form_carries_the_export_beside_the_settings() {
    let r: MapRequest = serde_json::from_str(
        r#"{"index": "i.csv", "axis": "a.toml", "positions_mm": [35], "export": ["tf5200",
            "table"], "tf5200_out_unit_a": 0.001, "export_position_mm": 35,
            "export_curve": "map"}"#,
    )
    .unwrap();
    assert_eq!(r.options.positions_mm, Some(vec![35.0]));
    assert_eq!(r.export.kinds, [ExportKind::Tf5200, ExportKind::Table]);
    assert_eq!(r.export.tf5200_out_unit_a, Some(0.001));
    assert_eq!(r.export_curve, ExportCurve::Map);
    let back: MapRequest = serde_json::from_str(&serde_json::to_string(&r).unwrap()).unwrap();
    assert_eq!(back, r);
    let f: FitStribeckRequest = serde_json::from_str(
        r#"{"table": "t.csv", "axis": "a.toml", "export": ["sinumerik"], "delta": "free",
            "sinumerik_axis": "Z1"}"#,
    )
    .unwrap();
    assert_eq!(f.export.kinds, [ExportKind::Sinumerik]);
    assert_eq!(f.export.sinumerik_axis.as_deref(), Some("Z1"));
    for bad in [
        r#"{"index": "i.csv", "export": ["fanuc"]}"#,
        r#"{"index": "i.csv", "export_points_n": 3}"#,
    ] {
        assert!(serde_json::from_str::<MapRequest>(bad).is_err(), "{bad}");
    }
    assert!(
        serde_json::from_str::<FitStribeckRequest>(r#"{"table": "t.csv", "points": 3}"#).is_err()
    );
}
