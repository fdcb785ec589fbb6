//! A test analysed for the history through the application layer: a stroke test of the twin
//! becomes a row whose mean-friction indicators are the truth's, storing it twice is one
//! test, and bad options name their field.
use feedscope::estimate::Direction;
use feedscope::sim::{simulate, FrictionParams, MeanLevel, SamplingMode, SimConfig, StrokeConfig};
use feedscope::study::TestKind;
use feedscope::ErrorKind;
use feedscope_app::history::{AddOptions, AddReport, AddRequest};
use feedscope_app::{FrontEnd, Quiet};
use feedscope_io::trace::{write_csv, Layout};
use feedscope_store::{SqliteStore, Store};

/// A 6 mm lead and a 90 kg slide at 4 kHz, forward and back at 400 mm/min over 60 mm, with
/// a flat mean level per direction (forward 120 N, backward 135 N).
fn files(dir: &std::path::Path) {
    let mut cfg = SimConfig::default();
    cfg.axis.name = Some("slide Y".into());
    cfg.axis.lead_mm = 6.0;
    cfg.axis.table_mass_kg = 90.0;
    cfg.axis.travel_min_mm = Some(-2.0);
    cfg.axis.travel_max_mm = Some(62.0);
    cfg.sampling.mode = SamplingMode::Synchronous;
    cfg.sampling.synchronous_rate_hz = 4000.0;
    cfg.motion.start_mm = 0.0;
    cfg.motion.strokes = [60.0, 0.0]
        .into_iter()
        .map(|to_mm| StrokeConfig {
            to_mm,
            feed_mm_min: 400.0,
            dwell_s: 0.5,
        })
        .collect();
    let mut friction = FrictionParams::default_for(&cfg.axis);
    for (level, offset_n) in [
        (&mut friction.forward, 120.0),
        (&mut friction.backward, 135.0),
    ] {
        *level = MeanLevel {
            offset_n,
            trend_n_per_mm: 0.0,
            bumps: Vec::new(),
        };
    }
    cfg.friction = Some(friction);
    let out = simulate(&cfg, &mut |_| {}).unwrap();
    write_csv(
        &out.trace,
        std::fs::File::create(dir.join("t.csv")).unwrap(),
        Layout::Long,
    )
    .unwrap();
    std::fs::write(
        dir.join("slide.toml"),
        toml::to_string_pretty(&cfg.axis).unwrap(),
    )
    .unwrap();
    let truth = out.truth.friction.clone();
    // The true mean friction over the travel at the test feed, per direction, for the check
    // below (the twin's components, from the axis's geometry, average out over it).
    let v = 400.0 / 60.0 * 1e-3;
    let mean = |v: f64| {
        (0..=6000)
            .map(|k| truth.friction_n(k as f64 * 1e-5, v))
            .sum::<f64>()
            / 6001.0
    };
    std::fs::write(dir.join("truth.txt"), format!("{}\n{}", mean(v), mean(-v))).unwrap();
}

#[test]
fn a_stroke_test_becomes_a_row_with_the_truths_mean_friction() {
    let d = tempfile::tempdir().unwrap();
    files(d.path());
    let request = AddRequest {
        trace: d.path().join("t.csv"),
        axis: d.path().join("slide.toml"),
        options: AddOptions {
            machine: "mill 3".into(),
            time: Some("2026-11-21T14:30:00Z".into()),
            interval_mm: 20.0,
            ..AddOptions::default()
        },
    };
    let analysed = request.prepare(&Quiet).unwrap();
    let t = &analysed.test;
    assert_eq!((t.machine.as_str(), t.axis.as_str()), ("mill 3", "slide Y"));
    assert_eq!(t.time_utc, "2026-11-21T14:30:00Z");
    assert_eq!(t.kind, TestKind::Strokes);
    assert!(
        analysed.verdict[0].starts_with("data verdict: a friction profile"),
        "{:?}",
        analysed.verdict
    );
    let truth: Vec<f64> = std::fs::read_to_string(d.path().join("truth.txt"))
        .unwrap()
        .lines()
        .map(|l| l.parse().unwrap())
        .collect();
    // One mean-friction indicator per 20 mm interval and direction, each within 0.5 % of
    // the truth's mean over the travel (flat mean level; 0.2 % seen).
    for (dir, true_n) in [
        (Direction::Forward, truth[0]),
        (Direction::Backward, truth[1]),
    ] {
        let means: Vec<_> = t
            .indicators
            .iter()
            .filter(|i| i.name.starts_with(&format!("mean_n/{}/", dir.as_str())))
            .collect();
        assert!(means.len() >= 2, "{dir:?}: {:?}", t.indicators);
        for m in means {
            assert!(
                (m.value.abs() - true_n.abs()).abs() < 0.005 * true_n.abs(),
                "{}: {} N against {true_n} N",
                m.name,
                m.value
            );
        }
    }
    // Stored twice: one test, the second a duplicate.
    let mut store = SqliteStore::open(&d.path().join("h.db")).unwrap();
    let first = AddReport::new(t, store.add(t).unwrap());
    let again = AddReport::new(t, store.add(t).unwrap());
    assert!(!first.duplicate && again.duplicate);
    assert_eq!(first.id, again.id);
    let json = serde_json::to_value(&first).unwrap();
    assert_eq!(
        json["indicators"].as_array().unwrap().len(),
        t.indicators.len()
    );
}

struct Angle;
impl FrontEnd for Angle {
    fn name(&self, field: &str) -> String {
        format!("<{field}>")
    }
}

#[test]
fn bad_options_name_their_field() {
    for (options, field, message) in [
        (
            AddOptions {
                interval_mm: 0.0,
                ..AddOptions::default()
            },
            "interval_mm",
            "<interval_mm> must be a positive length",
        ),
        (
            AddOptions {
                time: Some("yesterday".into()),
                ..AddOptions::default()
            },
            "time",
            "<time> \"yesterday\" is not an RFC 3339 time such as 2026-11-21T14:30:00Z",
        ),
    ] {
        let e = options.validate(&Angle).unwrap_err();
        assert_eq!((e.kind(), e.field()), (ErrorKind::BadInput, Some(field)));
        assert_eq!(e.to_string(), message);
    }
    // A trace that is not there is the user's input, named.
    let d = tempfile::tempdir().unwrap();
    files(d.path());
    let request = AddRequest {
        trace: d.path().join("missing.csv"),
        axis: d.path().join("slide.toml"),
        options: AddOptions::default(),
    };
    let e = request.prepare(&Angle).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::BadInput);
    assert!(e.to_string().contains("missing.csv"), "{e}");
}
