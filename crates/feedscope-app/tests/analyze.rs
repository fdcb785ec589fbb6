//! `analyze` through the application layer: a request from files and the same trace held in
//! memory give one report (`analysis.json`), the twin's fluctuation components come back at
//! their orders and amplitudes, and settings errors name their field.
use std::path::Path;

use feedscope::estimate::Direction;
use feedscope::order::Segment;
use feedscope::sim::{
    simulate, Component, ComponentDirection, FrictionParams, MeanLevel, SamplingMode, SimConfig,
    SimOutput,
};
use feedscope::ErrorKind;
use feedscope_app::analyze::{analyze_recording, AnalyzeOptions, AnalyzeRequest};
use feedscope_app::{FrontEnd, Quiet, Recording};
use feedscope_io::trace::{write_csv, Layout};

/// Truth of the twin: a 12 mm lead and a 300 kg table (neither the paper's lathe), sampled
/// at 1 kHz, with a mean level that has a trend and two fluctuation components.
const TREND_FORWARD_N_PER_MM: f64 = 0.12;
const COMPONENTS: [(f64, f64); 2] = [(1.0, 15.0), (2.5, 9.0)];

fn twin() -> (SimConfig, SimOutput) {
    let mut cfg = SimConfig::default();
    cfg.axis.lead_mm = 12.0;
    cfg.axis.table_mass_kg = 300.0;
    cfg.sampling.mode = SamplingMode::Synchronous;
    cfg.sampling.synchronous_rate_hz = 1000.0;
    let mut friction = FrictionParams::default_for(&cfg.axis);
    friction.forward = MeanLevel {
        offset_n: 180.0,
        trend_n_per_mm: TREND_FORWARD_N_PER_MM,
        bumps: Vec::new(),
    };
    friction.backward = MeanLevel {
        offset_n: 220.0,
        trend_n_per_mm: 0.0,
        bumps: Vec::new(),
    };
    friction.components = COMPONENTS
        .iter()
        .map(|&(order, amplitude_n)| Component {
            order,
            amplitude_n,
            phase_deg: 30.0,
            direction: ComponentDirection::Both,
            cause: String::new(),
        })
        .collect();
    cfg.friction = Some(friction);
    let out = simulate(&cfg, &mut |_| {}).unwrap();
    (cfg, out)
}

fn write_files(dir: &Path, cfg: &SimConfig, out: &SimOutput) {
    let f = std::fs::File::create(dir.join("trace.csv")).unwrap();
    write_csv(&out.trace, f, Layout::Wide).unwrap();
    std::fs::write(
        dir.join("axis.toml"),
        toml::to_string_pretty(&cfg.axis).unwrap(),
    )
    .unwrap();
}

#[test]
fn files_and_memory_give_one_report_with_the_twins_components() {
    let (cfg, out) = twin();
    let d = tempfile::tempdir().unwrap();
    write_files(d.path(), &cfg, &out);
    let request = AnalyzeRequest {
        input: d.path().join("trace.csv"),
        axis: d.path().join("axis.toml"),
        ..AnalyzeRequest::default()
    };
    let from_files = request.run(&Quiet).unwrap();
    let axis = feedscope_io::axis::load(&request.axis).unwrap();
    let (trace, read) = feedscope_io::trace::read_trace_file_with(
        &request.input,
        &Default::default(),
        &feedscope::trace::GlitchParams::for_axis(&axis),
    )
    .unwrap();
    let source = request.input.display().to_string();
    let held = Recording::borrowed(&trace, source, read);
    let from_memory = analyze_recording(&held, &axis, &AnalyzeOptions::default(), &Quiet).unwrap();
    assert_eq!(
        serde_json::to_value(&from_files.report).unwrap(),
        serde_json::to_value(&from_memory.report).unwrap()
    );

    let report = &from_files.report;
    assert!(!report.strokes.is_empty());
    assert_eq!(report.strokes.len(), from_files.study.analyses.len());
    for s in &report.strokes {
        // Each component is found over the whole stroke, within 5 % of its amplitude.
        for &(order, amplitude_n) in &COMPONENTS {
            let found = s
                .fluctuation
                .components
                .iter()
                .filter(|c| c.segment == Segment::Whole)
                .find(|c| (c.order - order).abs() < 0.1)
                .unwrap_or_else(|| panic!("stroke {}: no component at order {order}", s.stroke));
            assert!(
                (found.amplitude_n - amplitude_n).abs() < 0.05 * amplitude_n,
                "stroke {}: order {order} reads {:.2} N, truth {amplitude_n} N",
                s.stroke,
                found.amplitude_n
            );
        }
        // The linear trend of the IAFV is the mean level's: friction is signed by direction.
        let truth = match s.direction {
            Direction::Forward => TREND_FORWARD_N_PER_MM,
            Direction::Backward => 0.0,
        };
        let slope = s.iafv.linear.slope_n_per_mm.abs();
        assert!(
            (slope - truth).abs() < 0.01,
            "stroke {}: trend {slope:.3} N/mm, truth {truth}",
            s.stroke
        );
    }
    // The CSV writers hold one row per component and per order of Table 2.
    let n_components: usize = report
        .strokes
        .iter()
        .map(|s| s.fluctuation.components.len())
        .sum();
    assert_eq!(report.components_csv().lines().count(), n_components + 1);
    assert_eq!(
        report.order_scan_csv().lines().count(),
        report.order_scan_table.rows.len() + 1
    );
}

/// A front end that spells fields as `<field>`, to see that messages use its spelling.
struct Angle;
impl FrontEnd for Angle {
    fn name(&self, field: &str) -> String {
        format!("<{field}>")
    }
}

#[test]
fn settings_errors_name_their_field() {
    let cases: [(AnalyzeOptions, &str, &str); 6] = [
        (
            AnalyzeOptions {
                samples_per_lead: 0,
                ..AnalyzeOptions::default()
            },
            "samples_per_lead",
            "<samples_per_lead> 0 is not in 1..=1000000",
        ),
        (
            AnalyzeOptions {
                breaks_mm: Some(vec![100.0]),
                orders: Some(vec![3]),
                ..AnalyzeOptions::default()
            },
            "orders",
            "<orders> needs one order per interval: 1 breakpoints make 2 intervals, 1 orders \
             given",
        ),
        (
            AnalyzeOptions {
                breaks_mm: Some(vec![100.0]),
                ..AnalyzeOptions::default()
            },
            "breaks_mm",
            "<breaks_mm> needs <orders> (one per interval)",
        ),
        (
            AnalyzeOptions {
                orders: Some(vec![3, 4]),
                ..AnalyzeOptions::default()
            },
            "orders",
            "<orders> without <breaks_mm> takes one order",
        ),
        (
            AnalyzeOptions {
                segments: Some(0),
                ..AnalyzeOptions::default()
            },
            "segments",
            "<segments> must be at least 1",
        ),
        (
            AnalyzeOptions {
                segment_length_mm: Some(f64::NAN),
                ..AnalyzeOptions::default()
            },
            "segment_length_mm",
            "<segment_length_mm> must be a positive length",
        ),
    ];
    for (options, field, message) in cases {
        let e = options.study_params(&Angle).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::BadInput);
        assert_eq!(e.field(), Some(field));
        assert_eq!(e.to_string(), message);
    }
    let e = AnalyzeRequest::default().validate(&Quiet).unwrap_err();
    assert_eq!(e.field(), Some("input"));
}

#[test]
fn a_request_is_the_json_a_server_would_take() {
    let body = r#"{"input": "t.csv", "axis": "a.toml", "breaks_mm": [80.0], "orders": [3, 4]}"#;
    let request: AnalyzeRequest = serde_json::from_str(body).unwrap();
    assert_eq!(request.options.orders, Some(vec![3, 4]));
    assert_eq!(
        request.options.samples_per_lead,
        AnalyzeOptions::default().samples_per_lead
    );
    let typo = r#"{"input": "t.csv", "axis": "a.toml", "segmnets": 3}"#;
    assert!(serde_json::from_str::<AnalyzeRequest>(typo).is_err());
}
