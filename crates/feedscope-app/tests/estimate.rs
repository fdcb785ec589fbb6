//! `estimate` through the application layer: the streaming engine and the whole read of a
//! file give one friction CSV and one summary, the trace held in memory gives the same
//! strokes, the twin's friction comes back along the travel, and settings errors name their
//! field.
use std::path::Path;

use feedscope::diag::{Code, Diagnostic};
use feedscope::estimate::{MoveKind, PositionSmoothing, StrokeSummary};
use feedscope::sim::{simulate, FrictionParams, MeanLevel, SamplingMode, SimConfig, SimOutput};
use feedscope::verdict::{StrokeVerdict, Support};
use feedscope::ErrorKind;
use feedscope_app::estimate::{
    estimate_recording, number_list, parse_cutoff, stroke_warnings, verdict_reasons,
    EstimateOptions, EstimateRequest, ReadMode,
};
use feedscope_app::{FrontEnd, Quiet, Recording};
use feedscope_io::trace::{write_csv, Layout};

/// Truth of the twin: an 8 mm lead and a 450 kg table (neither paper's machine), sampled at
/// 2 kHz, forward and backward at two feeds, with a mean level that rises along the travel.
fn twin() -> (SimConfig, SimOutput) {
    let mut cfg = SimConfig::default();
    cfg.axis.lead_mm = 8.0;
    cfg.axis.table_mass_kg = 450.0;
    cfg.axis.travel_min_mm = Some(-5.0);
    cfg.axis.travel_max_mm = Some(125.0);
    cfg.sampling.mode = SamplingMode::Synchronous;
    cfg.sampling.synchronous_rate_hz = 2000.0;
    cfg.motion.start_mm = 0.0;
    cfg.motion.strokes = [(120.0, 600.0), (0.0, 600.0), (120.0, 1500.0), (0.0, 1500.0)]
        .into_iter()
        .map(|(to_mm, feed_mm_min)| feedscope::sim::StrokeConfig {
            to_mm,
            feed_mm_min,
            dwell_s: 0.5,
        })
        .collect();
    let mut friction = FrictionParams::default_for(&cfg.axis);
    friction.forward = MeanLevel {
        offset_n: 140.0,
        trend_n_per_mm: 0.2,
        bumps: Vec::new(),
    };
    friction.backward = MeanLevel {
        offset_n: 170.0,
        trend_n_per_mm: -0.1,
        bumps: Vec::new(),
    };
    cfg.friction = Some(friction);
    let out = simulate(&cfg, &mut |_| {}).unwrap();
    (cfg, out)
}

fn write_files(dir: &Path, cfg: &SimConfig, out: &SimOutput) {
    let f = std::fs::File::create(dir.join("trace.csv")).unwrap();
    write_csv(&out.trace, f, Layout::Long).unwrap();
    std::fs::write(
        dir.join("axis.toml"),
        toml::to_string_pretty(&cfg.axis).unwrap(),
    )
    .unwrap();
}

#[test]
fn streamed_whole_and_memory_give_one_result_with_the_twins_friction() {
    let (cfg, out) = twin();
    let d = tempfile::tempdir().unwrap();
    write_files(d.path(), &cfg, &out);
    let request = |read: ReadMode, name: &str| EstimateRequest {
        input: d.path().join("trace.csv"),
        axis: d.path().join("axis.toml"),
        output: d.path().join(name),
        options: EstimateOptions {
            read,
            ..EstimateOptions::default()
        },
    };
    // The streaming engine (asked for: it must not fall back) and the whole read.
    let streamed = request(ReadMode::Stream, "streamed.csv")
        .run(&Quiet)
        .unwrap();
    let whole = request(ReadMode::Whole, "whole.csv").run(&Quiet).unwrap();
    let json = |r| serde_json::to_value(r).unwrap();
    assert_eq!(json(&streamed.report), json(&whole.report));
    streamed.csv.commit().unwrap();
    whole.csv.commit().unwrap();
    let csv = std::fs::read(d.path().join("streamed.csv")).unwrap();
    assert_eq!(csv, std::fs::read(d.path().join("whole.csv")).unwrap());
    // The CSV holds one row per resampled point of every stroke.
    let rows = csv.iter().filter(|&&b| b == b'\n').count() - 1;
    let points: usize = streamed.report.strokes.iter().map(|s| s.points).sum();
    assert_eq!(rows, points);

    // The trace held in memory: the same summary, and every stroke's arrays.
    let axis = feedscope_io::axis::load(&d.path().join("axis.toml")).unwrap();
    let (trace, read) = feedscope_io::trace::read_trace_file_with(
        &d.path().join("trace.csv"),
        &Default::default(),
        &feedscope::trace::GlitchParams::for_axis(&axis),
    )
    .unwrap();
    let source = d.path().join("trace.csv").display().to_string();
    let held = Recording::borrowed(&trace, source, read);
    let mem = estimate_recording(&held, &axis, &EstimateOptions::default(), &Quiet).unwrap();
    assert_eq!(json(&mem.report), json(&whole.report));

    // Four measuring strokes, each within 0.1 % of the true mean friction (0.013 % seen), and
    // along the travel within twice the stroke's own predicted noise floor RMS (1.0 to 1.5
    // times seen: the effort noise passes through Eq. 5).
    let truth = &out.truth.friction;
    let measuring: Vec<_> = mem
        .strokes
        .iter()
        .filter(|s| s.summary.kind == MoveKind::Measuring)
        .collect();
    assert_eq!(measuring.len(), 4, "{:?}", mem.report.skipped);
    for s in measuring {
        let n = s.friction_n.len() as f64;
        let true_f: Vec<f64> = s
            .position_m
            .iter()
            .zip(&s.velocity_m_s)
            .map(|(&z, &v)| truth.friction_n(z, v))
            .collect();
        let true_mean = true_f.iter().sum::<f64>() / n;
        let mean = s.friction_n.iter().sum::<f64>() / n;
        let rms = (s
            .friction_n
            .iter()
            .zip(&true_f)
            .map(|(f, t)| (f - t).powi(2))
            .sum::<f64>()
            / n)
            .sqrt();
        let what = format!(
            "stroke {} ({:?}, {:.0} mm/min)",
            s.summary.stroke, s.summary.direction, s.summary.feed_mm_min
        );
        assert!(
            (mean - true_mean).abs() < 1e-3 * true_mean.abs(),
            "{what}: mean {mean:.2} N, truth {true_mean:.2} N"
        );
        let floor = s.summary.noise_floor.total_n;
        assert!(
            rms < 2.0 * floor,
            "{what}: RMS error {rms:.2} N against a noise floor of {floor:.2} N"
        );
        assert!((s.summary.mean_friction_n - mean).abs() < 1e-9 * mean.abs());
    }
}

/// A front end that spells fields as `<field>`, to see that messages use its spelling.
struct Angle;
impl FrontEnd for Angle {
    fn name(&self, field: &str) -> String {
        format!("<{field}>")
    }
    fn spell(&self, field: &str, value: &str) -> String {
        format!("<{field}={value}>")
    }
}

#[test]
fn settings_errors_name_their_field() {
    let cases: [(EstimateOptions, &str, &str); 4] = [
        (
            EstimateOptions {
                samples_per_lead: 0,
                ..EstimateOptions::default()
            },
            "samples_per_lead",
            "<samples_per_lead> = 0 is not in 1..=1000000",
        ),
        (
            EstimateOptions {
                position_cutoff_hz: PositionSmoothing::CutoffHz(-3.0),
                ..EstimateOptions::default()
            },
            "position_cutoff_hz",
            "<position_cutoff_hz>: `-3` is not `auto`, `off` or a cut-off in Hz (a number above 0)",
        ),
        (
            EstimateOptions {
                position_cutoff_hz: PositionSmoothing::CutoffHz(f64::INFINITY),
                ..EstimateOptions::default()
            },
            "position_cutoff_hz",
            "<position_cutoff_hz>: `inf` is not `auto`, `off` or a cut-off in Hz (a number above 0)",
        ),
        (
            EstimateOptions {
                program_axis: '1',
                ..EstimateOptions::default()
            },
            "program_axis",
            "<program_axis>: `1` is not an axis address (a letter such as Z)",
        ),
    ];
    for (options, field, message) in cases {
        let e = options.params(&Angle).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::BadInput);
        assert_eq!(e.field(), Some(field));
        assert_eq!(e.to_string(), message);
    }
    assert_eq!(
        parse_cutoff(" 25.5 "),
        Ok(PositionSmoothing::CutoffHz(25.5))
    );
    assert_eq!(parse_cutoff("none"), Ok(PositionSmoothing::Off));
    assert!(parse_cutoff("0").is_err());
    // An empty path is refused before anything is read.
    let e = EstimateRequest::default().validate(&Angle).unwrap_err();
    assert_eq!(e.field(), Some("input"));
    assert_eq!(e.to_string(), "<input> names no file");
}

#[test]
fn a_request_body_is_the_requests_serde_form() {
    let body = r#"{"input": "t.csv", "axis": "a.toml", "output": "f.csv",
                   "position_cutoff_hz": 40, "effort": "torque", "read": "whole",
                   "end_condition": "natural", "effort_sign": "magnitude"}"#;
    let r: EstimateRequest = serde_json::from_str(body).unwrap();
    assert_eq!(
        r.options.position_cutoff_hz,
        PositionSmoothing::CutoffHz(40.0)
    );
    assert_eq!(r.options.read, ReadMode::Whole);
    assert_eq!(r.options.samples_per_lead, 1024);
    let back: EstimateRequest = serde_json::from_str(&serde_json::to_string(&r).unwrap()).unwrap();
    assert_eq!(back, r);
    let off: EstimateRequest =
        serde_json::from_str(r#"{"input": "t.csv", "position_cutoff_hz": "off"}"#).unwrap();
    assert_eq!(off.options.position_cutoff_hz, PositionSmoothing::Off);
    for bad in [
        r#"{"input": "t.csv", "samples_per_led": 12}"#,
        r#"{"input": "t.csv", "position_cutoff_hz": "sometimes"}"#,
        r#"{"input": "t.csv", "read": "lazy"}"#,
    ] {
        assert!(
            serde_json::from_str::<EstimateRequest>(bad).is_err(),
            "{bad}"
        );
    }
}

#[test]
fn a_stream_that_cannot_be_vouched_for_is_refused_naming_the_read() {
    let (cfg, out) = twin();
    let d = tempfile::tempdir().unwrap();
    write_files(d.path(), &cfg, &out);
    // An NC program labels the strokes, which needs every move: no streaming.
    std::fs::write(d.path().join("p.nc"), "G1 Z120. F600.\nG1 Z0.\n").unwrap();
    let request = EstimateRequest {
        input: d.path().join("trace.csv"),
        axis: d.path().join("axis.toml"),
        output: d.path().join("f.csv"),
        options: EstimateOptions {
            read: ReadMode::Stream,
            program: Some(d.path().join("p.nc")),
            ..EstimateOptions::default()
        },
    };
    let e = request.run(&Angle).err().expect("refused");
    assert_eq!(e.kind(), ErrorKind::BadInput);
    assert_eq!(e.field(), Some("read"), "{e}");
    assert!(
        e.to_string().ends_with(
            "cannot estimate while reading (an NC program labels the strokes); use \
             <read=auto> or whole"
        ),
        "{e}"
    );
    // Nothing was left behind.
    assert!(!d.path().join("f.csv").exists());
    // A program that moves another axis names the field that chooses it.
    let request = EstimateRequest {
        options: EstimateOptions {
            program_axis: 'x',
            read: ReadMode::Auto,
            ..request.options
        },
        ..request
    };
    let e = request.run(&Angle).err().expect("refused");
    assert_eq!(e.field(), Some("program_axis"));
    assert!(
        e.to_string()
            .ends_with("no block moves axis X (use <program_axis>)"),
        "{e}"
    );
}

/// The text view's warning lines: a warning on a few strokes is one line per stroke, one
/// repeated on more strokes is one line that lists them, and a profile warning on strokes
/// whose profile is withheld anyway comes last, gathered; the verdict reasons are counted
/// by code. The report's remarks carry them with their kind.
#[test]
fn stroke_warnings_are_gathered_for_people() {
    let (cfg, out) = twin();
    let held = Recording::in_memory(out.trace, "twin");
    let mut report = estimate_recording(&held, &cfg.axis, &EstimateOptions::default(), &Quiet)
        .unwrap()
        .report;
    let template = report.strokes[0].clone();
    let stroke = |n: usize, support: Support, warnings: &[(Code, &str)]| StrokeSummary {
        stroke: n,
        verdict: Some(StrokeVerdict {
            support,
            reasons: if support == Support::MeanLevel {
                vec![Diagnostic::new(Code::StrokeTooShort, format!("short {n}"))]
            } else {
                vec![]
            },
        }),
        warnings: warnings
            .iter()
            .map(|&(c, m)| Diagnostic::new(c, m))
            .collect(),
        ..template.clone()
    };
    let repeated = (Code::FeedVariesAlongStroke, "feed varies");
    let profile = (Code::NoiseFloorHigh, "noisy");
    let strokes = vec![
        stroke(0, Support::Causes, &[repeated, profile]),
        stroke(1, Support::Causes, &[repeated]),
        stroke(2, Support::MeanLevel, &[repeated, profile]),
        stroke(3, Support::MeanLevel, &[repeated, profile]),
        stroke(5, Support::Causes, &[repeated]),
        stroke(6, Support::Causes, &[(Code::RapidsInferred, "one alone")]),
    ];
    let lines = stroke_warnings(&strokes);
    assert_eq!(
        lines,
        [
            // A profile warning where the profile is reported: said for its stroke.
            "stroke 0: noisy".to_string(),
            "stroke 6: one alone".to_string(),
            // On 5 strokes, more than 3: one line.
            "5 stroke(s) (0-3, 5): feed-varies-along-stroke; e.g. stroke 0: feed varies (each \
             in the JSON summary)"
                .to_string(),
            // Moot where only the mean level is reported: gathered, last.
            "2 stroke(s) (2-3), whose profile is withheld anyway (mean level only): \
             noise-floor-high; e.g. stroke 2: noisy (each in the JSON summary)"
                .to_string(),
        ]
    );
    assert_eq!(number_list(&[0, 1, 2, 4, 6, 7]), "0-2, 4, 6-7");
    let reasons = verdict_reasons(&strokes);
    assert_eq!(
        reasons.get(&Code::StrokeTooShort),
        Some(&(2, "stroke 2: short 2".to_string()))
    );
    assert_eq!(reasons.len(), 1);

    // The remarks: each line with its kind; the text view names every stroke.
    report.strokes = strokes;
    report.notes.clear();
    report.verdict.reasons.clear();
    report.skipped.clear();
    report.ignored_rows = 0;
    let remarks = report.remarks();
    assert_eq!(
        remarks[0],
        "verdict: 2 stroke(s) limited by stroke-too-short; e.g. stroke 2: short 2"
    );
    assert_eq!(remarks.len(), 1 + lines.len());
    assert!(remarks[1..]
        .iter()
        .zip(&lines)
        .all(|(r, l)| *r == format!("warning: {l}")));
    let text = report.to_string();
    assert_eq!(text.lines().filter(|l| l.contains("mean-level")).count(), 2);
    assert!(text.contains(&report.verdict.headline()), "{text}");
}
