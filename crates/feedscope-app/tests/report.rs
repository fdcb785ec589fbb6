//! The condition report's request: what it refuses before it touches a store, and the page it
//! writes for a stored history (the page's content is pinned by the CLI's report tests and
//! scripts/check-report.sh).
use feedscope_app::report::ReportRequest;
use feedscope_app::store::{Opener, StoreSpec};
use feedscope_app::trend::TrendRequest;
use feedscope_app::Quiet;

#[test]
fn a_report_needs_an_output_and_never_makes_a_database() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("history.db");
    let spec = StoreSpec::Sqlite(db.clone());
    let no_output = ReportRequest::default();
    let e = no_output
        .run(&spec, &Opener::default(), &Quiet)
        .unwrap_err();
    assert_eq!(e.field(), Some("output"), "{e}");
    let request = ReportRequest {
        output: dir.path().join("report.html"),
        ..ReportRequest::default()
    };
    let e = request.run(&spec, &Opener::default(), &Quiet).unwrap_err();
    assert_eq!(e.kind(), feedscope::ErrorKind::BadInput);
    assert!(e.to_string().contains("no database at"), "{e}");
    assert!(!db.exists(), "the report made a database");
    assert!(!request.output.exists());
}

#[test]
fn the_request_reads_from_json_with_the_trend_settings_under_their_key() {
    let r: ReportRequest = serde_json::from_str(
        r#"{"trend": {"machine": "lathe 3", "axis_name": "Z", "baseline_tests": 4},
            "output": "r.html"}"#,
    )
    .unwrap();
    assert_eq!(r.trend.machine.as_deref(), Some("lathe 3"));
    assert_eq!(r.trend.options.baseline_tests, 4);
    assert_eq!(r.output, std::path::PathBuf::from("r.html"));
    let _: TrendRequest = r.trend;
    // A misspelt key is refused, at either level.
    assert!(serde_json::from_str::<ReportRequest>(r#"{"outptu": "x"}"#).is_err());
    assert!(serde_json::from_str::<ReportRequest>(r#"{"trend": {"machin": "x"}}"#).is_err());
}
