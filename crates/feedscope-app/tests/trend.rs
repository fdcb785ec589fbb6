//! The trend of an axis through the application layer, over a real SQLite store: a rise of
//! the Coulomb friction after a stable baseline is flagged, a steady axis is not, the stored
//! axis file's thresholds are in force unless a thresholds file overrides them, and unknown
//! names and bad settings are refused naming their field in the front end's spelling. The
//! report page and the history's export and migration read the same store.
use feedscope::history::Status;
use feedscope::ErrorKind;
use feedscope_app::trend::{axis_trend, TrendOptions};
use feedscope_app::{FrontEnd, Quiet};
use feedscope_store::time::format_rfc3339;
use feedscope_store::{IndicatorRow, NewTest, SqliteStore, Store, TestKind};

/// A triangle test of `machine` `axis` on day `day` with Coulomb friction `fc_n` (N) and an
/// axis file whose `[thresholds]` put `fc_n`'s upper limit at `fc_upper_n`.
fn test(machine: &str, axis: &str, day: usize, fc_n: f64, fc_upper_n: f64) -> NewTest {
    let time_s = 1.8e9 + day as f64 * 86_400.0;
    let axis_params = serde_json::json!({
        "lead_mm": 10.0, "table_mass_kg": 200.0, "inertia_kgm2": 2e-3,
        "damping_nms_per_rad": 1e-3, "torque_constant_nm_per_a": 1.0,
        "thresholds": {"fc_n": {"upper": fc_upper_n}}
    });
    NewTest {
        machine: machine.into(),
        axis: axis.into(),
        axis_params: feedscope_store::Stored::from_json(&axis_params.to_string()),
        time_utc: format_rfc3339(time_s),
        time_s,
        kind: TestKind::Triangle,
        source: format!("day{day}.csv"),
        content_sha256: format!("{machine}-{axis}-{day}"),
        program: None,
        reference: false,
        compensation_ref: None,
        identified: None,
        intervals: Vec::new(),
        components: Vec::new(),
        indicators: vec![IndicatorRow {
            name: "fc_n".into(),
            value: fc_n,
            std_error: Some(0.5),
            unit: "N".into(),
        }],
        curves: None,
    }
}

/// Twelve tests of lathe Z (ten steady at about 100 N, then a rise to 125 N) and six steady
/// ones of lathe X.
fn store(dir: &std::path::Path) -> SqliteStore {
    let mut s = SqliteStore::open(&dir.join("h.db")).unwrap();
    // A deterministic scatter of ±1 N around the baseline.
    let scatter = [0.4, -0.8, 1.0, -0.3, 0.7, -1.0, 0.2, 0.9, -0.6, -0.5];
    for (day, ds) in scatter.iter().enumerate() {
        s.add(&test("lathe", "Z", day, 100.0 + ds, 150.0)).unwrap();
    }
    s.add(&test("lathe", "Z", 10, 124.0, 150.0)).unwrap();
    s.add(&test("lathe", "Z", 11, 125.0, 150.0)).unwrap();
    for (day, ds) in scatter.iter().take(6).enumerate() {
        s.add(&test("lathe", "X", day, 80.0 + ds, 150.0)).unwrap();
    }
    s
}

#[test]
fn a_rise_after_the_baseline_is_flagged_and_a_steady_axis_is_not() {
    let d = tempfile::tempdir().unwrap();
    let s = store(d.path());
    let options = TrendOptions::default();
    // The stored axis file reads as one (so its thresholds are the ones in force below).
    let stored = s.axis_params("lathe", "Z").unwrap();
    assert!(
        matches!(&stored, Some(feedscope_store::Stored::Read(p)) if p.thresholds.contains_key("fc_n")),
        "{stored:?}"
    );
    let z = axis_trend(&s, "lathe", Some("Z"), &options, Default::default(), &Quiet).unwrap();
    assert_eq!(z.tests.len(), 12);
    let fc = z
        .trends
        .iter()
        .find(|t| t.indicator.name() == "fc_n")
        .expect("an fc_n trend");
    assert!(
        (fc.baseline.mean - 100.0).abs() < 0.5,
        "{}",
        fc.baseline.mean
    );
    assert!(fc.change_percent > 20.0, "{}", fc.change_percent);
    assert_ne!(fc.status, Status::Ok);
    assert!(z.needs_attention());
    // Below the stored axis file's upper limit (150 N): no threshold crossed; a thresholds
    // file that puts the limit at 120 N overrides it.
    assert_ne!(fc.status, Status::ThresholdCrossed);
    let th = d.path().join("th.toml");
    std::fs::write(&th, "[thresholds]\nfc_n = { upper = 120.0 }\n").unwrap();
    let strict = TrendOptions {
        thresholds: Some(th),
        ..TrendOptions::default()
    };
    let from_file = strict.file_thresholds().unwrap();
    let z = axis_trend(&s, "lathe", Some("Z"), &strict, from_file, &Quiet).unwrap();
    let fc = z
        .trends
        .iter()
        .find(|t| t.indicator.name() == "fc_n")
        .unwrap();
    assert_eq!(fc.status, Status::ThresholdCrossed);
    // What --fail-on-warning ends with: the indicators not ok, the crossed threshold first.
    match z.outcome() {
        feedscope_app::Outcome::Attention(s) => {
            assert!(s.contains("of lathe/Z not ok: fc_n threshold"), "{s}")
        }
        o => panic!("{o:?}"),
    }

    let x = axis_trend(&s, "lathe", Some("X"), &options, Default::default(), &Quiet).unwrap();
    assert!(!x.needs_attention(), "{:?}", x.trends);
    assert_eq!(x.outcome(), feedscope_app::Outcome::Done);
    // The report is the JSON layout: machine, axis, tests, trends, skipped, profiles,
    // diagnosis.
    let json = serde_json::to_value(&x).unwrap();
    let keys: Vec<&str> = json
        .as_object()
        .unwrap()
        .keys()
        .map(String::as_str)
        .collect();
    assert_eq!(
        keys,
        [
            "axis",
            "diagnosis",
            "machine",
            "profiles",
            "skipped",
            "tests",
            "trends"
        ]
    );
}

/// The report page is built from the same trends: what is not ok comes first, every indicator
/// has its row and chart, no triangle parameters are invented where none were identified, and
/// a machine named as markup is shown as text in the HTML.
#[test]
fn the_report_page_leads_with_what_needs_attention_and_escapes_names() {
    let d = tempfile::tempdir().unwrap();
    let mut s = store(d.path());
    let options = TrendOptions::default();
    let z = axis_trend(&s, "lathe", Some("Z"), &options, Default::default(), &Quiet).unwrap();
    let page = feedscope_app::report::page(&s, &z, options.baseline_tests).unwrap();
    assert_eq!((page.machine.as_str(), page.axis.as_str()), ("lathe", "Z"));
    assert_eq!(page.tests.len(), 12);
    assert_eq!(page.rows.len(), z.trends.len());
    assert_eq!(page.trend_charts.len(), z.trends.len());
    assert!(page.trend_charts.iter().all(|c| c.svg.contains("<svg")));
    assert_eq!(page.warnings.first().map(|r| r.name.as_str()), Some("fc_n"));
    let not_ok: usize = page
        .counts
        .iter()
        .filter(|(k, _)| k != "ok")
        .map(|(_, n)| n)
        .sum();
    assert_eq!(not_ok, page.warnings.len());
    // Only triangle tests with no identified parameters stored: nothing to show, not zeros.
    assert!(page.params.is_empty() && page.stribeck.is_none() && page.profile.is_none());
    assert!(!page.no_baseline && !page.diagnosis.is_empty());

    let name = "<script>alert(1)</script>";
    for day in 0..3 {
        s.add(&test(name, "Z", day, 90.0, 150.0)).unwrap();
    }
    let t = axis_trend(&s, name, Some("Z"), &options, Default::default(), &Quiet).unwrap();
    let html = feedscope_app::report::render(&s, &t, options.baseline_tests).unwrap();
    assert!(
        !html.contains(name),
        "the machine's name reached the HTML as markup"
    );
    assert!(html.contains("&lt;script&gt;alert(1)&lt;&#x2f;script&gt;"));
    // Three tests are fewer than a baseline needs: said, and no clean bill of health.
    let page = feedscope_app::report::page(&s, &t, options.baseline_tests).unwrap();
    assert!(page.no_baseline, "{:?}", page.diagnosis);
    assert!(
        page.diagnosis[0].starts_with("No baseline yet"),
        "{:?}",
        page.diagnosis
    );
}

/// A history copied into another store comes back whole (rows, results, typed axis files and
/// a document another version wrote, unchanged); a second run copies nothing; the same store
/// as source and target is refused in the front end's spelling; the export is one row per
/// indicator value with names quoted in the CSV.
#[test]
fn a_history_migrates_whole_and_exports_as_one_table() {
    use feedscope_app::store::StoreSpec;
    use feedscope_app::transfer::{export, export_csv, migrate, MigrateReport};
    use feedscope_store::{Filter, Stored};
    let d = tempfile::tempdir().unwrap();
    let mut s = store(d.path());
    let mut odd = test("mill, \"old\"", "X", 0, 70.0, 150.0);
    odd.axis_params = Stored::from_json("{\"lead_mm\":5.0,\"spindle_colour\":\"red\"}");
    s.add(&odd).unwrap();
    let from = StoreSpec::parse(&d.path().join("h.db").display().to_string());
    let to = StoreSpec::parse(&d.path().join("copy.db").display().to_string());
    let mut target = SqliteStore::open(&d.path().join("copy.db")).unwrap();
    let n = migrate(&s, &from, &mut target, &to, &Flags).unwrap();
    assert_eq!(
        n,
        MigrateReport {
            tests: 19,
            added: 19,
            already_there: 0
        }
    );
    let all = Filter::default();
    let (a, b) = (s.list(&all).unwrap(), target.list(&all).unwrap());
    assert_eq!(
        serde_json::to_value(&a).unwrap(),
        serde_json::to_value(&b).unwrap()
    );
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(
            serde_json::to_value(s.get(x.id).unwrap()).unwrap(),
            serde_json::to_value(target.get(y.id).unwrap()).unwrap()
        );
    }
    for (m, ax) in [("lathe", "Z"), ("lathe", "X"), ("mill, \"old\"", "X")] {
        assert_eq!(
            s.axis_params(m, ax).unwrap(),
            target.axis_params(m, ax).unwrap()
        );
    }
    assert!(matches!(
        target.axis_params("mill, \"old\"", "X").unwrap(),
        Some(Stored::Unread { .. })
    ));
    let again = migrate(&s, &from, &mut target, &to, &Flags).unwrap();
    assert_eq!((again.added, again.already_there), (0, 19));
    let e = migrate(&s, &from, &mut target, &from, &Flags).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::BadInput);
    assert!(
        e.to_string()
            .starts_with("--from and --to are the same store"),
        "{e}"
    );

    let rows = export(&s, &from, &all).unwrap();
    assert_eq!(rows.len(), 19, "one fc_n value per test");
    assert!(rows.iter().all(|r| r.indicator == "fc_n" && r.unit == "N"));
    let csv = export_csv(&rows);
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[0], feedscope_app::transfer::EXPORT_CSV_HEADER);
    assert_eq!(lines.len(), 20);
    assert!(
        csv.contains("\"mill, \"\"old\"\"\",X,"),
        "a name with a comma and quotes is one quoted field: {csv}"
    );
}

/// The command line's spelling: fields are flags, the machine defaults to the only one.
struct Flags;
impl FrontEnd for Flags {
    fn name(&self, field: &str) -> String {
        format!("--{}", field.replace('_', "-"))
    }
    fn how_to_add(&self) -> String {
        "`feedscope history add`".into()
    }
}

/// Python's spelling: keywords, and the machine defaults to `"machine"`.
struct Keywords;
impl FrontEnd for Keywords {
    fn name(&self, field: &str) -> String {
        field.to_string()
    }
    fn spell(&self, field: &str, value: &str) -> String {
        format!("{field}=\"{value}\"")
    }
    fn default_machine(&self) -> Option<&str> {
        Some("machine")
    }
}

#[test]
fn unknown_names_and_bad_settings_name_their_field() {
    let d = tempfile::tempdir().unwrap();
    let s = store(d.path());
    let options = TrendOptions::default();
    let run = |machine: &str, axis: Option<&str>, front: &dyn FrontEnd| {
        axis_trend(&s, machine, axis, &options, Default::default(), front).unwrap_err()
    };
    let e = run("mill", None, &Flags);
    assert_eq!(
        (e.kind(), e.field()),
        (ErrorKind::BadInput, Some("machine"))
    );
    assert_eq!(
        e.to_string(),
        "no machine \"mill\" in the database; machines stored: \"lathe\" (axes \"X\" (6 \
         tests), \"Z\" (12 tests)); it is the only one, the default when --machine is not given"
    );
    let e = run("mill", None, &Keywords);
    assert!(
        e.to_string()
            .ends_with("; it is the only one: give machine=\"lathe\""),
        "{e}"
    );
    let e = run("lathe", Some("Y"), &Flags);
    assert_eq!(e.field(), Some("axis_name"));
    assert!(
        e.to_string().ends_with("; choose one with --axis-name"),
        "{e}"
    );
    let e = run("lathe", None, &Keywords);
    assert_eq!(e.field(), Some("axis_name"));
    assert_eq!(
        e.to_string(),
        "machine \"lathe\" has several axes (X, Z): choose one with axis_name"
    );
    // An empty store says how to add a test, in the front end's words.
    let empty = SqliteStore::open(&d.path().join("empty.db")).unwrap();
    let e = axis_trend(&empty, "lathe", None, &options, Default::default(), &Flags).unwrap_err();
    assert_eq!(
        e.to_string(),
        "the database holds no tests yet; store one with `feedscope history add`"
    );
    // Settings are checked before the store is read.
    for (options, field, message) in [
        (
            TrendOptions {
                profile_baseline_tests: 1,
                ..TrendOptions::default()
            },
            "profile_baseline_tests",
            "--profile-baseline-tests 1: the profile baseline needs at least 2 stroke tests \
             (their scatter sets the limits)",
        ),
        (
            TrendOptions {
                profile_limit_sigma: -2.0,
                ..TrendOptions::default()
            },
            "profile_limit_sigma",
            "--profile-limit-sigma -2: must be a positive number of σ",
        ),
        (
            TrendOptions {
                component_false_alarm: 0.5,
                ..TrendOptions::default()
            },
            "component_false_alarm",
            "--component-false-alarm 0.5: must be a probability in (0, 0.5), e.g. 0.001",
        ),
    ] {
        let e =
            axis_trend(&empty, "lathe", None, &options, Default::default(), &Flags).unwrap_err();
        assert_eq!((e.kind(), e.field()), (ErrorKind::BadInput, Some(field)));
        assert_eq!(e.to_string(), message);
    }
    // A thresholds file with an unknown indicator is refused naming the file.
    let th = d.path().join("bad.toml");
    std::fs::write(&th, "[thresholds]\nfriction_n = { upper = 1.0 }\n").unwrap();
    let bad = TrendOptions {
        thresholds: Some(th),
        ..TrendOptions::default()
    };
    let e = bad.file_thresholds().unwrap_err();
    assert_eq!(
        (e.kind(), e.field()),
        (ErrorKind::BadInput, Some("thresholds"))
    );
    assert!(e.to_string().contains("bad.toml"), "{e}");
}
