//! The NC programs of the friction tests through the application layer: paper 000's stroke
//! test planned from a default request (its run time and sample counts are the hand
//! calculation of the CLI's `prints_run_time_and_samples`), a triangular wave from a request
//! body, the program written whole and its report as the JSON layout and text; every setting
//! the request checks itself is refused naming the field in the front end's spelling.
use std::path::PathBuf;

use feedscope::axis::{AxisParams, ConfigFormat};
use feedscope::plan::TestKind;
use feedscope::sim::RampShape;
use feedscope::ErrorKind;
use feedscope_app::plan::{PlanRequest, PlanTest, StrokesTest, TriangleTest};
use feedscope_app::{FrontEnd, Quiet};

/// The command line's spelling.
struct Flags;
impl FrontEnd for Flags {
    fn name(&self, field: &str) -> String {
        format!("--{}", field.replace('_', "-"))
    }
}

#[test]
fn the_stroke_test_of_paper_000_is_planned_and_written() {
    // 0 → 410 mm at 5, 20 and 80 mm/min, 3 pairs each, 1 s dwells, jerk-limited at 20 m/s³:
    // 38 763.1715 s (to the 4 decimals the check compares), ⌊38 763.1715 / 0.072⌋ + 1
    // samples at the assumed 72 ms.
    let planned = PlanRequest::default().plan(None, &Quiet).unwrap();
    let r = &planned.report;
    assert_eq!(r.test, TestKind::Strokes);
    assert_eq!(r.moves.len(), 18);
    assert_eq!(r.samples_per_channel, 538_378);
    assert!(
        (r.run_time_s - 38_763.171_5).abs() < 1e-3,
        "{}",
        r.run_time_s
    );
    assert_eq!(r.jerk_mm_s3, Some(20_000.0));
    assert!(r.warnings.is_empty(), "{:?}", r.warnings);
    // Without an output the layout has no `output` key (Python's `Plan.to_dict()`).
    let json = serde_json::to_value(r).unwrap();
    assert!(json.get("output").is_none(), "{json}");
    assert_eq!(json["ramp"], "jerk_limited");
    assert_eq!(
        r.text().lines().nth(1),
        Some(
            "expected run time 38763.2 s (646.05 min) at 1000 mm/s², jerk-limited ramps, \
             20000 mm/s³"
        )
    );

    // Written: the file holds the program, the report names it.
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("test.nc");
    let written = PlanRequest {
        output: Some(out.clone()),
        ramp: RampShape::Trapezoid,
        ..PlanRequest::default()
    }
    .run(&Quiet)
    .unwrap();
    assert_eq!(std::fs::read_to_string(&out).unwrap(), written.gcode);
    assert_eq!(
        written.report.output.as_deref(),
        Some(out.display().to_string().as_str())
    );
    assert_eq!(written.report.samples_per_channel, 538_376);
    let text = written.report.text();
    assert!(
        text.starts_with(&format!(
            "{}: 18 moves over 0.000 to 410.000 mm at 3 feed(s)\n",
            out.display()
        )),
        "{text}"
    );
    assert!(text.contains(", trapezoid ramps\n"), "{text}");
}

#[test]
fn a_triangle_request_body_takes_its_window_from_the_axis() {
    let body = serde_json::json!({
        "test": {"triangle": {"feed_max_mm_min": 8000.0, "levels": 6}},
        "sample_rate_hz": 1000.0,
        "dialect": "siemens",
    });
    let request: PlanRequest = serde_json::from_value(body.clone()).unwrap();
    // An axis whose travel is the window of the CLI's golden `plan triangle --from 40 --to
    // 160`: without `from_mm` / `to_mm` the window is the travel.
    let axis = AxisParams::parse(
        "name = \"test Z\"\nlead_mm = 10\ntable_mass_kg = 300\ninertia_kgm2 = 0.002\n\
         damping_nms_per_rad = 0\ntorque_constant_nm_per_a = 1.5\ntravel_min_mm = 40\n\
         travel_max_mm = 160\n",
        ConfigFormat::Toml,
        "axis.toml",
    )
    .unwrap();
    let planned = request.plan(Some(&axis), &Quiet).unwrap();
    let r = &planned.report;
    assert_eq!(r.test, TestKind::Triangle);
    assert_eq!(r.feeds_mm_min.len(), 6, "{:?}", r.feeds_mm_min);
    assert!(
        r.span_mm.0 >= 40.0 && r.span_mm.1 <= 160.0,
        "{:?}",
        r.span_mm
    );
    assert!((r.sample_interval_s - 1e-3).abs() < 1e-15);
    // As the golden Siemens program of the CLI's tests says in its header.
    assert_eq!(r.samples_per_channel, 22_989);
    assert!(
        planned
            .gcode
            .contains("\n; EXPECTED SAMPLES PER CHANNEL 22989 AT 1.000 MS\n"),
        "{}",
        planned.gcode
    );

    // Without the axis there is no window: named as the user spells it.
    let e = request.plan(None, &Flags).unwrap_err();
    assert_eq!(
        (e.kind(), e.field()),
        (ErrorKind::BadInput, Some("from_mm"))
    );
    assert_eq!(
        e.to_string(),
        "--from-mm is needed (or travel_min_mm in the axis file / --travel-min-mm)"
    );
    let no_feed = PlanRequest {
        test: PlanTest::Triangle(TriangleTest {
            from_mm: Some(0.0),
            to_mm: Some(200.0),
            ..TriangleTest::default()
        }),
        ..PlanRequest::default()
    };
    let e = no_feed.plan(None, &Flags).unwrap_err();
    assert_eq!(e.field(), Some("feed_max_mm_min"));

    // A misspelt key of a request body is refused, not ignored.
    let mut bad = body;
    bad["test"]["triangle"]["level"] = 6.into();
    let e = serde_json::from_value::<PlanRequest>(bad).unwrap_err();
    assert!(e.to_string().contains("level"), "{e}");
}

#[test]
fn validate_names_the_bad_field() {
    let check = |request: PlanRequest, field: &str, message: &str| {
        let e = request.validate(&Flags).unwrap_err();
        assert_eq!((e.kind(), e.field()), (ErrorKind::BadInput, Some(field)));
        assert_eq!(e.to_string(), message);
        // `plan` and `run` check first, and write nothing.
        assert!(request.plan(None, &Flags).is_err());
    };
    for ms in [0.0, -72.0, f64::NAN] {
        check(
            PlanRequest {
                sample_interval_ms: Some(ms),
                ..PlanRequest::default()
            },
            "sample_interval_ms",
            &format!("--sample-interval-ms {ms}: must be > 0"),
        );
    }
    check(
        PlanRequest {
            sample_rate_hz: Some(0.0),
            ..PlanRequest::default()
        },
        "sample_rate_hz",
        "--sample-rate-hz 0: must be > 0",
    );
    check(
        PlanRequest {
            approach_feed_mm_min: Some(-5.0),
            ..PlanRequest::default()
        },
        "approach_feed_mm_min",
        "--approach-feed-mm-min -5: must be > 0",
    );
    check(
        PlanRequest {
            ramp: RampShape::Bell,
            jerk_mm_s3: Some(1000.0),
            ..PlanRequest::default()
        },
        "jerk_mm_s3",
        "--jerk-mm-s3 applies only to `ramp` = \"jerk_limited\" (trapezoid and bell ramps have \
         no jerk limit)",
    );
    assert!(PlanRequest::default().validate(&Flags).is_ok());

    // The planner's own checks name the setting or the limit; nothing is written.
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("t.nc");
    let e = PlanRequest {
        jerk_mm_s3: Some(0.0),
        output: Some(out.clone()),
        ..PlanRequest::default()
    }
    .run(&Flags)
    .unwrap_err();
    assert_eq!(e.field(), Some("jerk_mm_s3"));
    assert!(e.to_string().starts_with("--jerk-mm-s3: "), "{e}");
    let e = PlanRequest {
        test: PlanTest::Strokes(StrokesTest {
            to_mm: 420.0,
            ..StrokesTest::default()
        }),
        travel_max_mm: Some(410.0),
        output: Some(out.clone()),
        ..PlanRequest::default()
    }
    .run(&Flags)
    .unwrap_err();
    assert!(e.to_string().contains("travel_max_mm = 410"), "{e}");
    let e = PlanRequest {
        axis: Some(PathBuf::from("no-such-axis.toml")),
        output: Some(out.clone()),
        ..PlanRequest::default()
    }
    .run(&Flags)
    .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::BadInput);
    assert!(!out.exists());
}
