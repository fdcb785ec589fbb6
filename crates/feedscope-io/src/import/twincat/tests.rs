use super::*;

/// An export in the layout of TwinCAT 3 Scope 3.4 (tab, separate time columns, decimal comma,
/// the PC's German date text), with three channels: position (mm), torque (Nm) and a set
/// position at half the rate that ends early.
fn export(sep: char, rows: &[&str]) -> String {
    let header = [
        "Name\tAxis_X.ActPos\tName\tAxis_X.ActTorque\tName\tAxis_X.SetPos",
        "SymbolComment\t\tSymbolComment\t\tSymbolComment\t",
        "Data-Type\tREAL64\tData-Type\tREAL64\tData-Type\tREAL64",
        "SampleTime[ms]\t1\tSampleTime[ms]\t1\tSampleTime[ms]\t2",
        "SymbolName\tMAIN.Axis_X.NcToPlc.ActPos\tSymbolName\tMAIN.Axis_X.ActTorque\tSymbolName\tMAIN.Axis_X.NcToPlc.SetPos",
        "Offset\t0\tOffset\t0\tOffset\t0",
        "ScaleFactor\t1\tScaleFactor\t1\tScaleFactor\t1",
        "Unit\tmm (Length)\tUnit\tNm (Torque)\tUnit\tmm (Length)",
        "Unit ScaleFactor\t1\tUnit ScaleFactor\t1\tUnit ScaleFactor\t1",
        "Unit Offset\t0\tUnit Offset\t0\tUnit Offset\t0",
    ];
    let mut s = String::new();
    s.push_str("Name\tscope\nFile\tC:\\scope\\x.csv\n");
    s.push_str("Starttime of export\t132959733843760000\tMontag, 2. Mai 2022\t15:56:24.376\n");
    s.push_str("Endtime of export\t132959733853750000\tMontag, 2. Mai 2022\t15:56:25.375\n\n\n");
    for h in header {
        s.push_str(h);
        s.push('\n');
    }
    s.push('\n');
    for r in rows {
        s.push_str(r);
        s.push('\n');
    }
    if sep != '\t' {
        s = s.replace('\t', &sep.to_string());
    }
    s
}

const ROWS: [&str; 6] = [
    "0\t10\t0\t0,5\t0\t10",
    "1\t10,001\t1\t0,52\t2\t10,002",
    "2\t10,002\t2\t0,54\t4\t10,004",
    "3\t10,003\t3\t0,56",
    "4\t10,004\t4\t0,58",
    "5\t10,005\t5\t0,6",
];

fn parse(text: &str, p: &TwincatParams) -> Result<TwincatImport, ImportError> {
    parse_twincat(text.as_bytes(), "s.csv", p)
}

#[test]
fn filetime_is_100ns_since_1601_utc() {
    // The pytcs sample: 2022-05-02 15:56:24.376 CEST.
    let t = filetime_to_timestamp(132_959_733_843_760_000);
    assert_eq!(t.to_string(), "2022-05-02T13:56:24.376Z");
    assert_eq!(timestamp_to_filetime(t), Some(132_959_733_843_760_000));
    assert_eq!(filetime_to_timestamp(0).unix_s, -11_644_473_600);
}

#[test]
fn position_and_torque_found_by_unit_with_decimal_comma() {
    let text = export('\t', &ROWS);
    let e = parse(&text, &TwincatParams::default()).unwrap_err();
    // Two length channels: the position must be named.
    assert!(
        e.to_string()
            .contains("2 channels could be the position (Axis_X.ActPos, Axis_X.SetPos); name one with --position"),
        "{e}"
    );
    let p = TwincatParams {
        position: Some("MAIN.Axis_X.NcToPlc.ActPos".into()),
        ..Default::default()
    };
    let imp = parse(&text, &p).unwrap();
    let t = &imp.imported.trace;
    assert_eq!(t.effort_kind, EffortKind::TorqueNm);
    assert_eq!(t.position_m.len(), 6);
    assert!((t.position_m.value[5] - 0.010005).abs() < 1e-15);
    assert!((t.effort.value[1] - 0.52).abs() < 1e-15);
    assert!((t.effort.time_s[5] - 0.005).abs() < 1e-15);
    assert_eq!(
        imp.imported.report.time_zero.unwrap().to_string(),
        "2022-05-02T13:56:24.376Z"
    );
    assert_eq!(
        imp.imported.report.position.source_key,
        "`Axis_X.ActPos` (MAIN.Axis_X.NcToPlc.ActPos) (mm: Unit `mm (Length)`)"
    );
    assert_eq!(imp.listing.decimal, Some(','));
    assert!(!imp.listing.header.shared_time());
}

#[test]
fn listing_counts_channels_of_different_lengths() {
    let l = list_twincat_from(export('\t', &ROWS).as_bytes(), "s.csv").unwrap();
    assert_eq!(l.header.separator_name(), "tab");
    assert_eq!(l.header.scope_name.as_deref(), Some("scope"));
    assert_eq!(l.header.channels.len(), 3);
    assert_eq!(l.header.channels[2].sample_time_ms(), Some(2.0));
    assert_eq!(
        l.counts.iter().map(|c| c.samples).collect::<Vec<_>>(),
        [6, 6, 3]
    );
    assert_eq!(l.counts[2].span_s, Some((0.0, 0.004)));
    assert_eq!(l.rows, 6);
    assert!(l.header.notes.is_empty(), "{:?}", l.header.notes);
}

#[test]
fn shared_time_columns() {
    let mut text = export(';', &[]);
    // "Exclude double timestamps": position and torque share one time column.
    text = text
        .lines()
        .map(|l| {
            let f: Vec<&str> = l.split(';').collect();
            if f.len() == 6 {
                format!("{};{};{};{};{}\n", f[0], f[1], f[3], f[4], f[5])
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    text.push_str("0;1,5;0,1;0;7\n1;1,6;0,2;2;7,1\n2;1,7;0,3\n3;1,8;0,4\n");
    let l = list_twincat_from(text.as_bytes(), "s.csv").unwrap();
    assert!(l.header.shared_time(), "{:?}", l.header.channels);
    assert_eq!(
        l.header
            .channels
            .iter()
            .map(|c| (c.time_col, c.value_col))
            .collect::<Vec<_>>(),
        [(0, 1), (0, 2), (3, 4)]
    );
    let p = TwincatParams {
        position: Some("Axis_X.ActPos".into()),
        ..Default::default()
    };
    let imp = parse(&text, &p).unwrap();
    assert_eq!(imp.imported.trace.effort.len(), 4);
    assert!((imp.imported.trace.effort.value[3] - 0.4).abs() < 1e-15);
}

fn err(text: &str) -> String {
    let p = TwincatParams {
        position: Some("Axis_X.ActPos".into()),
        ..Default::default()
    };
    parse(text, &p).unwrap_err().to_string()
}

#[test]
fn a_comma_separator_with_a_decimal_comma_is_refused_naming_the_line() {
    // The first data row is line 18 (4 file lines, 2 blank, 10 header rows, 1 blank).
    let e = err(&export(',', &ROWS));
    assert!(
        e.starts_with("s.csv:18: 7 fields, the header has 6 columns: the export uses ',' as separator and a decimal comma"),
        "{e}"
    );
}

#[test]
fn a_comma_separator_with_a_decimal_point_reads_and_skips_the_header_rows_it_splits() {
    let rows: Vec<String> = ROWS.iter().map(|r| r.replace(',', ".")).collect();
    let rows: Vec<&str> = rows.iter().map(String::as_str).collect();
    let text = export(',', &rows).replace("SampleTime[ms],2", "SampleTime[ms],0,5");
    let imp = parse(
        &text,
        &TwincatParams {
            position: Some("Axis_X.ActPos".into()),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(imp.imported.trace.position_m.len(), 6);
    let notes = &imp.listing.header.notes;
    assert!(
        notes.iter().any(|n| n
            .starts_with("line 10: header row `SampleTime[ms]` does not line up")
            && n.contains("a decimal comma with ',' as separator?")),
        "{notes:?}"
    );
    assert_eq!(imp.position.sample_time_ms(), None);
}

#[test]
fn bad_data_names_line_and_channel() {
    let with = |row: usize, text: &str| {
        let mut r: Vec<&str> = ROWS.to_vec();
        r[row] = text;
        export('\t', &r)
    };
    let cases = [
        (with(2, "2\t10,0x2\t2\t0,54"), "s.csv:20: channel `Axis_X.ActPos`: `10,0x2` is not a number"),
        (with(2, "2\tNaN\t2\t0,54"), "s.csv:20: channel `Axis_X.ActPos`: `NaN` is not finite"),
        (with(2, "2\t10,002\t2\tinf"), "s.csv:20: channel `Axis_X.ActTorque`: `inf` is not finite"),
        (with(2, "2\t10.002\t2\t0,54"), "s.csv:20: channel `Axis_X.ActPos`: `10.002` uses '.' as decimal mark, line 18 used ','"),
        (with(2, "2\t1.000,5\t2\t0,54"), "has both '.' and ','"),
        (with(2, "1\t10,002\t2\t0,54"), "s.csv:20: channel `Axis_X.ActPos`: time 1 ms is not after the previous sample's 1 ms: time not increasing"),
        (with(2, "2\t\t2\t0,54"), "s.csv:20: channel `Axis_X.ActPos` has a time but no value"),
        (with(2, " \t10,002\t2\t0,54"), "s.csv:20: channel `Axis_X.ActPos` has a value but no time"),
        (with(2, "2\t200000\t2\t0,54"), "s.csv:20: channel `Axis_X.ActPos` at 2 ms: position 200000 mm is beyond ±1e5 mm"),
        (with(2, "2\t10,002\t2\t2000000"), "s.csv:20: channel `Axis_X.ActTorque` at 2 ms: torque 2000000 N·m is beyond ±1e6 N·m"),
        (with(2, "2\t10,002\t2\t0,54\t4\t10,004\t9"), "s.csv:20: 7 fields, the header has 6 columns"),
    ];
    for (text, want) in cases {
        let e = err(&text);
        assert!(e.contains(want), "want `{want}` in: {e}");
    }
}

#[test]
fn bad_headers_and_channels() {
    assert!(matches!(
        parse("", &TwincatParams::default()).unwrap_err(),
        ImportError::Empty { .. }
    ));
    let e = err("time_s,channel,value\n0,position_mm,1\n");
    assert!(
        e.starts_with(
            "s.csv:1: `time_s,channel,value` is not the first line of a TwinCAT Scope export"
        ),
        "{e}"
    );
    let e = err("Name\tscope\nFile\tx\n");
    assert!(
        e.contains("s.csv:2: the file ends before the channel header"),
        "{e}"
    );
    let text = export('\t', &ROWS);
    let cut = text.find("Unit\tmm").unwrap();
    assert!(err(&text[..cut]).contains("the file ends in the channel header: no data"));
    let p = TwincatParams {
        position: Some("Axis_Y.ActPos".into()),
        ..Default::default()
    };
    let e = parse(&text, &p).unwrap_err().to_string();
    assert_eq!(
        e,
        "s.csv: axis `position`: no channel `Axis_Y.ActPos`; channels: Axis_X.ActPos [mm \
         (Length)], Axis_X.ActTorque [Nm (Torque)], Axis_X.SetPos [mm (Length)]"
    );
    // Without units, a flag is needed.
    let no_units = text.replace(
        "Unit\tmm (Length)\tUnit\tNm (Torque)",
        "Unit\t(None)\tUnit\t(None)",
    );
    let e = err(&no_units);
    assert!(
        e.contains("channel `Axis_X.ActPos` has no unit (`(None)`); give --position-unit"),
        "{e}"
    );
    let p = TwincatParams {
        position: Some("Axis_X.ActPos".into()),
        position_unit: Some(PositionUnit::Millimetre),
        effort_unit: Some(EffortUnit::Ampere),
        ..Default::default()
    };
    let imp = parse(&no_units, &p).unwrap();
    assert_eq!(imp.imported.trace.effort_kind, EffortKind::CurrentA);
    // A percentage is not a torque.
    let pct = text.replace("Nm (Torque)", "% (Percent)");
    assert!(
        err(&pct).contains("no channel is recognisably the effort"),
        "{}",
        err(&pct)
    );
    let p = TwincatParams {
        position: Some("Axis_X.ActPos".into()),
        effort: Some("Axis_X.ActTorque".into()),
        ..Default::default()
    };
    let e = parse(&pct, &p).unwrap_err().to_string();
    assert!(
        e.contains("has unit `% (Percent)`, not a current or torque"),
        "{e}"
    );
}

#[test]
fn a_cut_last_line_is_truncation() {
    let text = export('\t', &ROWS);
    let cut = text.trim_end().rfind("\t0,6").unwrap();
    let e = err(&text[..cut + 1]);
    assert!(
        e.contains("s.csv:23: the last line is cut short (3 cells, the line before has 4, no line break at the end): truncated file"),
        "{e}"
    );
}

#[test]
fn scaled_channels_warn() {
    let text = export('\t', &ROWS).replace(
        "ScaleFactor\t1\tScaleFactor\t1",
        "ScaleFactor\t1\tScaleFactor\t0,01",
    );
    let imp = parse(
        &text,
        &TwincatParams {
            position: Some("Axis_X.ActPos".into()),
            ..Default::default()
        },
    )
    .unwrap();
    let w = &imp.imported.report.warnings;
    assert!(
        w.iter()
            .any(|d| d.code == Code::ScaledChannel
                && d.message.contains("declares ScaleFactor 0,01")),
        "{w:?}"
    );
}

fn synthetic(kind: EffortKind, n: usize, dt: f64, offset: f64) -> Trace {
    let t: Vec<f64> = (0..n).map(|k| k as f64 * dt).collect();
    let te: Vec<f64> = t.iter().map(|x| x + offset).collect();
    Trace {
        position_m: Channel {
            value: t
                .iter()
                .map(|&x| 0.1 + 0.01 * x - 1e-9 * (x * 77.0).sin())
                .collect(),
            time_s: t.clone(),
        },
        effort: Channel {
            value: t.iter().map(|&x| (x * 13.0).sin() * 3.0).collect(),
            time_s: te,
        },
        effort_kind: kind,
        facts: RecordingFacts::default(),
    }
}

#[test]
fn the_writer_round_trips_in_every_layout() {
    for (sep, comma, shared, eof, offset) in [
        ('\t', false, false, false, 0.0),
        ('\t', true, true, true, 0.0),
        (';', true, false, false, 0.0004),
        (',', false, true, false, 0.0),
        (' ', false, false, true, 0.0),
        (':', true, false, false, 0.0),
    ] {
        for kind in [EffortKind::CurrentA, EffortKind::TorqueNm] {
            let tr = synthetic(kind, 300, 0.001, offset);
            let params = TwincatWriteParams {
                separator: sep,
                decimal_comma: comma,
                shared_time: shared,
                eof_line: eof,
                ..Default::default()
            };
            let mut csv = Vec::new();
            write_twincat_csv(&tr, &params, &mut csv).unwrap();
            let label = format!("{sep:?} comma {comma} shared {shared}");
            // A space-separated export splits `mm (Length)`: its Unit row is not used (as in
            // real exports), the units come from flags.
            let read = if sep == ' ' {
                TwincatParams {
                    position_unit: Some(PositionUnit::Millimetre),
                    effort_unit: Some(match kind {
                        EffortKind::CurrentA => EffortUnit::Ampere,
                        EffortKind::TorqueNm => EffortUnit::NewtonMetre,
                    }),
                    ..Default::default()
                }
            } else {
                TwincatParams::default()
            };
            let imp =
                parse_twincat(&csv[..], "w.csv", &read).unwrap_or_else(|e| panic!("{label}: {e}"));
            assert_eq!(
                imp.listing.header.shared_time(),
                shared && offset == 0.0,
                "{label}"
            );
            assert_eq!(imp.listing.eof_marker, eof, "{label}");
            let back = &imp.imported.trace;
            assert_eq!(back.effort_kind, kind);
            // 6 decimals: 5e-7 mm (5e-10 m) and 5e-7 A or N·m; times 5e-7 ms.
            for (a, b, q) in [
                (&tr.position_m, &back.position_m, 5e-10),
                (&tr.effort, &back.effort, 5e-7),
            ] {
                assert_eq!(a.len(), b.len(), "{label}");
                for k in 0..a.len() {
                    assert!(
                        (a.time_s[k] - b.time_s[k]).abs() <= 5e-10 + 1e-15,
                        "{label} {k}"
                    );
                    assert!((a.value[k] - b.value[k]).abs() <= q + 1e-15, "{label} {k}");
                }
            }
            assert_eq!(
                imp.imported.report.time_zero,
                Some(TwincatWriteParams::default().start),
                "{label}"
            );
        }
    }
    let bad = TwincatWriteParams {
        separator: ',',
        decimal_comma: true,
        ..Default::default()
    };
    let tr = synthetic(EffortKind::CurrentA, 10, 0.001, 0.0);
    assert!(write_twincat_csv(&tr, &bad, Vec::new()).is_err());
}

#[test]
fn a_header_split_at_the_separator_is_refused() {
    // A space-separated export of a channel named with a space: the header has one column more
    // than the data.
    let text = export(' ', &["0 1 0 2", "1 1,1 1 2,1"]).replace("Axis_X.SetPos", "Set Pos");
    let e = list_twincat_from(text.as_bytes(), "s.csv")
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("s.csv:18: the first data row has 4 fields but the channel header 7 columns"),
        "{e}"
    );
}

#[test]
fn quoted_fields_are_unquoted() {
    assert_eq!(
        split_fields(
            r#""Starttime of export" 132959733843760000 "Montag, 2. Mai 2022" 15:56"#,
            ' '
        ),
        [
            "Starttime of export",
            "132959733843760000",
            "Montag, 2. Mai 2022",
            "15:56"
        ]
    );
    assert_eq!(
        split_fields("a; b ;\"c;\"\"d\"\"\";", ';'),
        ["a", "b", "c;\"d\"", ""]
    );
    assert_eq!(split_fields(" \t1", '\t'), ["", "1"]);
}
