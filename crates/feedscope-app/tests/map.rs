//! `map` through the application layer: a test set read from its index and the same set held
//! in memory give one report, the twin's Stribeck friction comes back at a position, a run
//! that cannot be read is listed (and said) while the others are mapped, and settings errors
//! name their field.
use std::path::Path;
use std::sync::Mutex;

use feedscope::estimate::Direction;
use feedscope::sim::{
    simulate, DynamicsMode, FrictionParams, MeanLevel, SimConfig, StrokeConfig, VelocityTerm,
};
use feedscope::ErrorKind;
use feedscope_app::map::{map_set, ExportCurve, MapOptions, MapRequest};
use feedscope_app::{FrontEnd, Quiet};
use feedscope_io::test_set::read_index;
use feedscope_io::trace::{write_csv, Layout};

/// Truth of the twin: a 12 mm lead and a 300 kg table (neither paper's drive), levels
/// 150 + 0.3·z forward and 175 − 0.2·z backward, a static excess of 45 N with a Stribeck
/// velocity of 35 mm/min, 1500 N·s/m viscous, no fluctuation.
const EXCESS_N: f64 = 45.0;
const VS_MM_MIN: f64 = 35.0;
const SIGMA: f64 = 1500.0;
const FEEDS: [f64; 6] = [8.0, 20.0, 45.0, 110.0, 300.0, 800.0];
const AT_MM: f64 = 36.0;

fn level_n(direction: Direction, z_mm: f64) -> f64 {
    match direction {
        Direction::Forward => 150.0 + 0.3 * z_mm,
        Direction::Backward => 175.0 - 0.2 * z_mm,
    }
}

fn twin_friction() -> FrictionParams {
    FrictionParams {
        sign_smoothing_mm_s: 0.01,
        forward: MeanLevel {
            offset_n: 150.0,
            trend_n_per_mm: 0.3,
            bumps: vec![],
        },
        backward: MeanLevel {
            offset_n: 175.0,
            trend_n_per_mm: -0.2,
            bumps: vec![],
        },
        velocity: VelocityTerm {
            static_excess_n: EXCESS_N,
            stribeck_velocity_mm_min: VS_MM_MIN,
            shape_exponent: 2.0,
            viscous_n_s_per_m: SIGMA,
        },
        components: vec![],
    }
}

/// 6 feeds × 2 repeats of 24 → 48 mm (two leads) and back, sampled every 20 ms with
/// jitter, with `index.csv` (and `extra` lines appended) and `axis.toml`.
fn twin_set(dir: &Path, extra: &str) {
    std::fs::create_dir_all(dir.join("runs")).unwrap();
    let mut index = String::from("file,feed_mm_min,repeat\n");
    let mut axis = None;
    for (i, &f) in FEEDS.iter().enumerate() {
        for r in 1..=2u32 {
            let mut c = SimConfig {
                seed: 500 + 10 * i as u64 + u64::from(r),
                friction: Some(twin_friction()),
                ..SimConfig::default()
            };
            c.axis.lead_mm = 12.0;
            c.axis.table_mass_kg = 300.0;
            c.dynamics.mode = DynamicsMode::Ideal;
            c.motion.start_mm = 24.0;
            c.motion.strokes = vec![
                StrokeConfig {
                    to_mm: 48.0,
                    feed_mm_min: f,
                    dwell_s: 0.5,
                },
                StrokeConfig {
                    to_mm: 24.0,
                    feed_mm_min: f,
                    dwell_s: 0.0,
                },
            ];
            c.sampling.position.interval_ms = 20.0;
            c.sampling.position.jitter_ms = 0.5;
            c.sampling.effort.interval_ms = 20.0;
            c.sampling.effort.jitter_ms = 0.5;
            c.sampling.effort.start_offset_ms = 10.0;
            c.truth.interval_ms = 1000.0;
            let out = simulate(&c, &mut |_| {}).unwrap();
            let name = format!("runs/f{f}_r{r}.csv");
            write_csv(
                &out.trace,
                std::fs::File::create(dir.join(&name)).unwrap(),
                Layout::Long,
            )
            .unwrap();
            index.push_str(&format!("{name},{f},{r}\n"));
            axis = Some(out.truth.axis);
        }
    }
    index.push_str(extra);
    std::fs::write(dir.join("index.csv"), index).unwrap();
    std::fs::write(
        dir.join("axis.toml"),
        toml::to_string(&axis.unwrap()).unwrap(),
    )
    .unwrap();
}

/// Records what the layer says, for the assertions.
#[derive(Default)]
struct Listener {
    notices: Mutex<Vec<String>>,
    last_progress: Mutex<Option<(usize, usize)>>,
}

impl FrontEnd for Listener {
    fn notice(&self, message: &str) {
        self.notices.lock().unwrap().push(message.to_string());
    }
    fn progress(&self, _what: &str, done: usize, total: usize) {
        *self.last_progress.lock().unwrap() = Some((done, total));
    }
    fn name(&self, field: &str) -> String {
        format!("--{}", field.replace('_', "-"))
    }
}

#[test]
fn index_and_memory_give_one_map_with_the_twins_stribeck_friction() {
    let d = tempfile::tempdir().unwrap();
    // A run whose file is missing: listed as failed, said as a notice, the rest mapped.
    twin_set(d.path(), "runs/missing.csv,300,3\n");
    let request = MapRequest {
        index: d.path().join("index.csv"),
        axis: d.path().join("axis.toml"),
        options: MapOptions {
            positions_mm: Some(vec![AT_MM]),
            ..MapOptions::default()
        },
        ..MapRequest::default()
    };
    let listener = Listener::default();
    let from_files = request.run(&listener).unwrap();
    let set = read_index(&request.index).unwrap();
    let axis = feedscope_io::axis::load(&request.axis).unwrap();
    let in_memory = map_set(&set, &axis, &request.options, &Quiet).unwrap();
    assert_eq!(json(&from_files.report), json(&in_memory.report));
    assert_eq!(json(&from_files.stribeck), json(&in_memory.stribeck));

    let summary = &from_files.report.summary;
    assert_eq!((summary.runs, summary.runs_ok), (13, 12));
    assert_eq!(summary.failed.len(), 1);
    assert!(summary.failed[0].file.ends_with("missing.csv"));
    let notices = listener.notices.lock().unwrap();
    assert!(
        notices
            .iter()
            .any(|n| n.contains("missing.csv") && n.contains("failed")),
        "{notices:?}"
    );
    assert_eq!(*listener.last_progress.lock().unwrap(), Some((13, 13)));

    // The Stribeck fit at the position recovers the twin's parameters.
    assert_eq!(from_files.stribeck.directions.len(), 2);
    for dir in &from_files.stribeck.directions {
        assert_eq!(dir.feeds_mm_min, FEEDS.to_vec());
        let [at] = &dir.positions[..] else {
            panic!("one position asked for");
        };
        assert!((at.position_mm - AT_MM).abs() < 1e-9);
        assert_eq!(at.error, None, "{:?}", dir.direction);
        let value = |e: &Option<feedscope_app::map::PositionEstimate>| e.as_ref().unwrap().value;
        let fc = value(&at.fc_n);
        let excess = value(&at.static_excess_n);
        let vs = value(&at.vs_mm_min);
        let sigma = value(&at.sigma_n_s_per_m);
        let level = level_n(dir.direction, AT_MM);
        eprintln!(
            "{:?}: fc {fc:.2} ({level:.2}), excess {excess:.2}, vs {vs:.2}, sigma {sigma:.0}",
            dir.direction
        );
        // Measured: within 0.15 N of the level, 0.15 N of the excess, 0.1 mm/min of v_s and
        // 1.2 % of σ (which only the top feeds see: 1500 N·s/m is 20 N at 800 mm/min). The
        // bounds leave about twice that; a wrong sign, scale or unit misses all of them.
        assert!((fc - level).abs() < 0.002 * level, "fc {fc} vs {level}");
        assert!(
            (excess - EXCESS_N).abs() < 0.02 * EXCESS_N,
            "excess {excess}"
        );
        assert!((vs - VS_MM_MIN).abs() < 0.02 * VS_MM_MIN, "vs {vs}");
        assert!((sigma - SIGMA).abs() < 0.05 * SIGMA, "sigma {sigma}");
        // Standard errors are given and are not larger than the quantity.
        let se = at.fc_n.as_ref().unwrap().std_error.unwrap();
        assert!(se.is_finite() && se > 0.0 && se < 0.01 * fc, "fc se {se}");
    }

    // The export at the position: per direction the Stribeck curve, equal to the truth there.
    let export = from_files
        .export_at(Some(AT_MM), ExportCurve::Stribeck, &Quiet)
        .unwrap();
    assert_eq!(export.table.len(), 2);
    assert!(export.source.contains("36.000 mm"), "{}", export.source);
    // And the files it writes: each named once, none empty.
    let files = from_files.files().unwrap();
    let names: Vec<&str> = files.iter().map(|(n, _)| n.as_str()).collect();
    for want in [
        "map.json",
        "stribeck.json",
        "runs.csv",
        "stribeck_profile.csv",
    ] {
        assert_eq!(names.iter().filter(|n| **n == want).count(), 1, "{names:?}");
    }
    assert!(files.iter().all(|(_, text)| !text.is_empty()));
    let runs_csv = &files.iter().find(|(n, _)| n == "runs.csv").unwrap().1;
    assert_eq!(runs_csv.lines().count(), 14, "{runs_csv}");
}

/// A report's serde form: reports carry floats, so equal JSON says "the same layout and the
/// same numbers".
fn json<T: serde::Serialize>(report: &T) -> serde_json::Value {
    serde_json::to_value(report).unwrap()
}

#[test]
fn settings_are_named_by_field_before_anything_is_read() {
    let front = Listener::default();
    let base = MapRequest {
        index: "does/not/exist.csv".into(),
        axis: "nor/this.toml".into(),
        ..MapRequest::default()
    };
    let check = |options: MapOptions, field: &str, text: &str| {
        let r = MapRequest {
            options,
            ..base.clone()
        };
        let e = r.run(&front).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::BadInput, "{e}");
        assert_eq!(e.field(), Some(field), "{e}");
        assert!(e.to_string().contains(text), "{e}");
    };
    check(
        MapOptions {
            breaks_mm: Some(vec![30.0]),
            ..MapOptions::default()
        },
        "breaks_mm",
        "--breaks-mm needs --orders",
    );
    check(
        MapOptions {
            breaks_mm: Some(vec![30.0]),
            orders: Some(vec![3]),
            ..MapOptions::default()
        },
        "orders",
        "2 intervals need 2",
    );
    check(
        MapOptions {
            samples_per_lead: 8,
            ..MapOptions::default()
        },
        "samples_per_lead",
        "not in 16..=1000000",
    );
    check(
        MapOptions {
            positions_mm: Some(vec![f64::NAN]),
            ..MapOptions::default()
        },
        "positions_mm",
        "not a finite position",
    );
    check(
        MapOptions {
            table_feeds_mm_min: Some(vec![100.0, -5.0]),
            ..MapOptions::default()
        },
        "table_feeds_mm_min",
        "-5 is not a positive feed",
    );
    check(
        MapOptions {
            position_step_mm: 0.0,
            ..MapOptions::default()
        },
        "position_step_mm",
        "must be positive",
    );
    // An empty path is named too; a file that is not there names the file.
    let e = MapRequest::default().validate(&front).unwrap_err();
    assert_eq!(e.field(), Some("index"));
    let e = base.run(&front).unwrap_err();
    assert!(e.to_string().contains("nor/this.toml"), "{e}");
    // A request body: unknown keys refused, the options flattened beside the paths.
    let r: MapRequest = serde_json::from_str(
        r#"{"index": "i.csv", "axis": "a.toml", "positions_mm": [30, 40], "feed_order": 2}"#,
    )
    .unwrap();
    assert_eq!(r.options.positions_mm, Some(vec![30.0, 40.0]));
    assert_eq!(r.options.feed_order, 2);
    assert!(serde_json::from_str::<MapRequest>(
        r#"{"index": "i.csv", "axis": "a.toml", "position_mm": [30]}"#
    )
    .is_err());
}

#[test]
fn a_set_where_every_run_fails_is_an_error_that_says_so() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(
        d.path().join("index.csv"),
        "file,feed_mm_min,repeat\nnone1.csv,100,1\nnone2.csv,200,1\n",
    )
    .unwrap();
    let mut cfg = SimConfig::default();
    cfg.axis.lead_mm = 12.0;
    std::fs::write(
        d.path().join("axis.toml"),
        toml::to_string(&cfg.axis).unwrap(),
    )
    .unwrap();
    let listener = Listener::default();
    let e = MapRequest {
        index: d.path().join("index.csv"),
        axis: d.path().join("axis.toml"),
        ..MapRequest::default()
    }
    .run(&listener)
    .unwrap_err();
    assert!(e.to_string().contains("all 2 runs"), "{e}");
    assert_eq!(listener.notices.lock().unwrap().len(), 2);
}
