use std::collections::BTreeMap;

use super::*;
use crate::estimate::{Direction, MoveKind, StrokeFriction, StrokeSummary};
use crate::history::{Point, Threshold};
use crate::map::{FeedScale, MapParams, RunFriction, TestRun};
use crate::sim::{simulate, DynamicsMode, SimConfig, StrokeConfig};

/// A synthetic forward stroke of 40 mm on a 10 mm lead with F = 200 + 0.5·z + 3000·v
/// (N, z in mm, v in m/s), as in the map module's example.
fn stroke(feed: f64) -> StrokeFriction {
    let step = 0.01 / 1024.0;
    let z: Vec<f64> = (0..4097).map(|k| 0.01 + k as f64 * step).collect();
    let v = feed / 60_000.0;
    let f: Vec<f64> = z.iter().map(|&z| 200.0 + 500.0 * z + 3000.0 * v).collect();
    let n = z.len();
    StrokeFriction {
        summary: StrokeSummary {
            stroke: 0,
            direction: Direction::Forward,
            feed_mm_min: feed,
            feed_min_mm_min: None,
            feed_max_mm_min: None,
            start_mm: 10.0,
            end_mm: 50.0,
            length_mm: 40.0,
            start_time_s: 0.0,
            end_time_s: 1.0,
            mean_friction_n: 0.0,
            friction_std_n: 0.0,
            position_samples: n,
            effort_samples: n,
            points: n,
            raw_samples_per_lead: 100.0,
            max_order: 40.0,
            position_cutoff_order: None,
            kind: MoveKind::Measuring,
            position_cutoff_hz: None,
            settle_margin_s: 0.0,
            noise_floor: Default::default(),
            mean_friction_se_n: None,
            effort_quantum_n: 0.0,
            verdict: None,
            program_line: None,
            programmed_feed_mm_min: None,
            warnings: vec![],
        },
        time_s: vec![0.0; n],
        velocity_m_s: vec![v; n],
        accel_m_s2: vec![0.0; n],
        effort: vec![0.0; n],
        position_m: z,
        friction_n: f,
    }
}

fn runs(feeds: &[f64]) -> Vec<RunFriction> {
    let mut runs = Vec::new();
    for &feed in feeds {
        for repeat in 1..=2 {
            let run = TestRun {
                name: format!("f{feed}-{repeat}"),
                file: "".into(),
                feed_mm_min: feed,
                repeat,
            };
            runs.push(RunFriction {
                run,
                strokes: vec![stroke(feed)],
                warnings: vec![],
            });
        }
    }
    runs
}

fn linear() -> MapStudyParams {
    MapStudyParams {
        map: MapParams {
            feed_scale: FeedScale::Linear,
            ..MapParams::default()
        },
        ..MapStudyParams::default()
    }
}

#[test]
fn map_study_defaults_positions_grid_and_table_feeds() {
    let s = map_study(&runs(&[100.0, 500.0, 1000.0]), 0.01, &linear()).unwrap();
    let d = &s.map.directions[0];
    // Five default positions: centres of five equal parts of the mapped span.
    let p: Vec<f64> = s.at_positions[0]
        .positions
        .iter()
        .map(|q| q.position_mm)
        .collect();
    assert_eq!(p.len(), 5);
    let part = (d.end_mm - d.start_mm) / 5.0;
    // Rounded to 1 µm.
    assert!((p[0] - (d.start_mm + part / 2.0)).abs() <= 0.5e-3, "{p:?}");
    // The grid: both ends, 1 mm multiples between.
    let g = &s.grids_mm[0];
    assert_eq!(g.first(), Some(&d.start_mm));
    assert_eq!(g.last(), Some(&d.end_mm));
    assert!(g[1..g.len() - 1]
        .iter()
        .all(|z| (z - z.round()).abs() < 1e-9));
    assert_eq!(s.profiles[0].positions.len(), g.len());
    assert_eq!(s.table_feeds_mm_min[0], vec![100.0, 500.0, 1000.0]);
    let (grid, feeds) = s.table_axes(Direction::Forward).unwrap();
    assert_eq!((grid.len(), feeds.len()), (g.len(), 3));
    assert!(s.table_axes(Direction::Backward).is_none());
}

#[test]
fn map_study_refuses_one_feed_and_bad_requests() {
    let e = map_study(&runs(&[250.0]), 0.01, &linear()).unwrap_err();
    assert!(
        matches!(e, StudyError::OneFeed { feed_mm_min, .. } if (feed_mm_min - 250.0).abs() < 1e-9)
    );
    assert_eq!(e.kind(), ErrorKind::BadInput);
    assert!(
        e.to_string().contains("a map needs at least two feeds"),
        "{e}"
    );
    assert!(e.to_string().contains("only 250 mm/min"), "{e}");

    let two = runs(&[100.0, 1000.0]);
    let outside = MapStudyParams {
        positions_mm: Some(vec![30.0, 80.0]),
        ..linear()
    };
    let e = map_study(&two, 0.01, &outside).unwrap_err();
    assert!(matches!(e, StudyError::Position(_)), "{e}");
    let beyond = MapStudyParams {
        table_feeds_mm_min: Some(vec![100.0, 2000.0]),
        ..linear()
    };
    let e = map_study(&two, 0.01, &beyond).unwrap_err();
    assert!(matches!(e, StudyError::TableFeed(_)), "{e}");
    let allowed = MapStudyParams {
        extrapolate: true,
        ..beyond
    };
    assert!(map_study(&two, 0.01, &allowed).is_ok());
    let step = MapStudyParams {
        position_step_mm: 0.0,
        ..linear()
    };
    assert!(matches!(
        map_study(&two, 0.01, &step),
        Err(StudyError::BadParameter {
            name: "position_step_mm",
            ..
        })
    ));
}

fn series(values: &[f64], first_id: i64) -> IndicatorSeries {
    values
        .iter()
        .enumerate()
        .map(|(i, &value)| {
            (
                first_id + i as i64,
                Point {
                    time_s: i as f64 * 86_400.0,
                    value,
                    std_error: None,
                },
            )
        })
        .collect()
}

#[test]
fn axis_trends_orders_skips_and_uses_the_reference() {
    let steady = [100.0, 101.0, 99.0, 100.5, 99.5, 100.0, 100.2];
    let mut s = BTreeMap::new();
    let mean = Indicator::MeanFriction {
        direction: Direction::Forward,
        start_mm: 0.0,
        end_mm: 50.0,
    };
    s.insert(mean.name(), series(&steady, 1));
    s.insert("fs_n".to_string(), series(&steady, 1));
    s.insert("fc_n".to_string(), series(&steady[..2], 1));
    s.insert("no_such_indicator".to_string(), series(&steady, 1));
    let mut params = TrendStudyParams::default();
    assert_eq!(params.baseline_tests, 5);
    params.thresholds.insert(
        "fs_n".into(),
        Threshold {
            upper: Some(99.0),
            lower: None,
        },
    );
    let t = axis_trends(&s, None, &params).unwrap();
    let names: Vec<String> = t.trends.iter().map(|x| x.indicator.name()).collect();
    // Identified parameters before the mean friction, whatever the key order.
    assert_eq!(names[0], "fs_n", "{names:?}");
    assert_eq!(t.trends.len(), 2, "{names:?}");
    assert_eq!(
        t.skipped,
        vec!["fc_n".to_string(), "no_such_indicator".into()]
    );
    assert_ne!(
        t.trends[0].status,
        crate::history::Status::Ok,
        "above its threshold"
    );
    // A reference test: its value is the baseline mean.
    let r = axis_trends(&s, Some(3), &TrendStudyParams::default()).unwrap();
    let fs = r
        .trends
        .iter()
        .find(|x| x.indicator.name() == "fs_n")
        .unwrap();
    assert!(
        (fs.baseline.mean - 99.0).abs() < 1e-12,
        "{}",
        fs.baseline.mean
    );
}

/// A short simulated stroke test: 25 → 45 mm and back at 400 mm/min, ideal servo.
fn stroke_trace() -> (crate::trace::Trace, crate::axis::AxisParams) {
    let mut c = SimConfig {
        seed: 7,
        ..SimConfig::default()
    };
    c.dynamics.mode = DynamicsMode::Ideal;
    c.motion.start_mm = 25.0;
    c.motion.strokes = vec![
        StrokeConfig {
            to_mm: 45.0,
            feed_mm_min: 400.0,
            dwell_s: 0.5,
        },
        StrokeConfig {
            to_mm: 25.0,
            feed_mm_min: 400.0,
            dwell_s: 0.0,
        },
    ];
    let out = simulate(&c, &mut |_| {}).unwrap();
    (out.trace, out.truth.axis)
}

#[test]
fn stroke_test_gives_interval_means_that_cover_the_strokes() {
    let (trace, axis) = stroke_trace();
    let params = StrokeStudyParams {
        interval_mm: 5.0,
        ..StrokeStudyParams::default()
    };
    let t = stroke_test(&trace, &axis, &params).unwrap();
    for d in [Direction::Forward, Direction::Backward] {
        let iv: Vec<&IntervalMean> = t.intervals.iter().filter(|i| i.direction == d).collect();
        // 25-45 mm less the settling margins: the inner 5 mm intervals 30-40 mm at least.
        assert!(iv.len() >= 2, "{d:?}: {iv:?}");
        for i in &iv {
            assert!((i.end_mm - i.start_mm - 5.0).abs() < 1e-12);
            assert!(i.mean_n > 0.0 && i.std_n.is_finite());
        }
        assert_eq!(
            t.curves
                .profiles
                .iter()
                .filter(|p| p.direction == d.as_str())
                .count(),
            1
        );
    }
    // One mean-friction indicator per interval, in the same order, then the components.
    for (i, v) in t.intervals.iter().zip(&t.indicators) {
        assert!(
            matches!(v.indicator, Indicator::MeanFriction { start_mm, .. } if (start_mm - i.start_mm).abs() < 1e-12)
        );
        assert!((v.value - i.mean_n).abs() < 1e-12);
        assert!(v.std_error.is_some());
    }
    assert!(t.indicators[t.intervals.len()..]
        .iter()
        .all(|v| matches!(v.indicator, Indicator::Component { .. })));
    let a = analyze_test(
        &trace,
        &axis,
        TestKind::Strokes,
        &TestStudyParams {
            strokes: params.clone(),
            ..TestStudyParams::default()
        },
    )
    .unwrap();
    assert_eq!(a.kind(), TestKind::Strokes);
    assert_eq!(a.indicators(), &t.indicators[..]);

    let bad = StrokeStudyParams {
        interval_mm: -1.0,
        ..StrokeStudyParams::default()
    };
    let e = stroke_test(&trace, &axis, &bad).unwrap_err();
    assert!(matches!(
        e,
        StudyError::BadParameter {
            name: "interval_mm",
            ..
        }
    ));
    assert_eq!(e.kind(), ErrorKind::BadInput);
}

#[test]
fn a_stroke_trace_is_not_a_triangle_test() {
    let (trace, axis) = stroke_trace();
    let e = triangle_test(&trace, &axis, &TriangleStudyParams::default()).unwrap_err();
    assert!(matches!(e, StudyError::Identify(_)), "{e}");
    assert_eq!(e.kind(), ErrorKind::BadInput);
    assert!(e.to_string().starts_with("identification failed: "), "{e}");
}

#[test]
fn test_kind_words() {
    assert_eq!(TestKind::Strokes.as_str(), "strokes");
    assert_eq!(TestKind::Triangle.as_str(), "triangle");
    assert_eq!(
        serde_json::to_string(&TestKind::Triangle).unwrap(),
        "\"triangle\""
    );
}

#[test]
fn error_kinds_of_the_study_steps() {
    use crate::order::OrderError;
    use crate::profile::ProfileError;
    let stroke = |source| StudyError::Stroke {
        stroke: 1,
        direction: "forward",
        start_mm: 10.0,
        end_mm: 50.0,
        source,
    };
    assert_eq!(
        stroke(ProfileError::RankDeficient { column: 2 }).kind(),
        ErrorKind::BadInput
    );
    assert_eq!(
        stroke(ProfileError::Spectrum(OrderError::Fft("planner".into()))).kind(),
        ErrorKind::Internal
    );
    let e = StudyError::Trend {
        indicator: "fs_n".into(),
        source: crate::history::HistoryError::InvalidParams("lambda".into()),
    };
    assert_eq!(e.kind(), ErrorKind::BadInput);
}

/// The axis of the profile module's example: 10 mm lead.
fn lead_10mm_axis() -> crate::axis::AxisParams {
    crate::axis::AxisParams::parse(
        "lead_mm = 10\ntable_mass_kg = 425\ninertia_kgm2 = 0.004\n\
         damping_nms_per_rad = 0.002\ntorque_constant_nm_per_a = 1.82\n",
        crate::axis::ConfigFormat::Toml,
        "axis.toml",
    )
    .unwrap()
}

/// A synthetic stroke over 20-220 mm (20 leads of 10 mm) at 256 samples per lead:
/// F = sign · (70 + 0.05·(z − 120) + `amp`·cos(2π·`order`·z / lead)) N with z in mm, the sign
/// of paper 000 Eq. 5 (negative backward).
fn ripple_stroke(number: usize, direction: Direction, order: f64, amp: f64) -> StrokeFriction {
    let mut s = stroke(400.0);
    let n = 20 * 256 + 1;
    let step = 0.01 / 256.0;
    let forward = direction == Direction::Forward;
    let z: Vec<f64> = (0..n)
        .map(|k| {
            let i = if forward { k } else { n - 1 - k };
            0.02 + i as f64 * step
        })
        .collect();
    let sign = if forward { 1.0 } else { -1.0 };
    let two_pi = 2.0 * std::f64::consts::PI;
    s.friction_n = z
        .iter()
        .map(|&z| {
            sign * (70.0 + 0.05 * (z * 1e3 - 120.0) + amp * (two_pi * order * z / 0.01).cos())
        })
        .collect();
    s.position_m = z;
    s.time_s = (0..n).map(|k| k as f64 * 1e-3).collect();
    s.velocity_m_s = vec![sign * 400.0 / 60e3; n];
    s.accel_m_s2 = vec![0.0; n];
    s.effort = vec![0.0; n];
    let (start_mm, end_mm) = if forward {
        (20.0, 220.0)
    } else {
        (220.0, 20.0)
    };
    s.summary.stroke = number;
    s.summary.direction = direction;
    s.summary.start_mm = start_mm;
    s.summary.end_mm = end_mm;
    s.summary.length_mm = 200.0;
    s.summary.position_samples = n;
    s.summary.effort_samples = n;
    s.summary.points = n;
    s
}

#[test]
fn analyze_strokes_finds_the_ripple_order_and_amplitude() {
    // Forward: 5 N at order 1 (shaft 1x); backward: 3 N at order 2 (shaft 2x). Both sit on a
    // bin of the whole-stroke spectrum (20 leads: bins 0.05 orders apart), so the window's
    // coherent-gain correction reads the amplitude back up to the leakage of what the IAFV
    // leaves of the slow trend, far below 0.1 % of it: 0.5 % is the tolerance.
    let strokes = vec![
        ripple_stroke(1, Direction::Forward, 1.0, 5.0),
        ripple_stroke(2, Direction::Backward, 2.0, 3.0),
    ];
    let axis = lead_10mm_axis();
    let calls = std::cell::RefCell::new(Vec::new());
    let s = analyze_strokes(
        strokes,
        &axis,
        &AnalyzeStudyParams::default(),
        &|done, total| calls.borrow_mut().push((done, total)),
    )
    .unwrap();
    assert_eq!(calls.into_inner(), vec![(0, 2), (1, 2), (2, 2)]);
    assert_eq!(s.strokes.len(), 2);
    assert_eq!(s.analyses.len(), 2);
    assert_eq!(s.single_polynomials.len(), 2);
    for (k, (order, amp, cause)) in [(1.0, 5.0, "shaft 1x"), (2.0, 3.0, "shaft 2x")]
        .into_iter()
        .enumerate()
    {
        let a = &s.analyses[k];
        assert_eq!(a.direction, s.strokes[k].summary.direction);
        let whole: Vec<_> = a
            .fluctuation
            .components
            .iter()
            .filter(|c| c.segment.is_whole())
            .collect();
        let c = whole
            .iter()
            .max_by(|a, b| a.amplitude_n.total_cmp(&b.amplitude_n))
            .unwrap_or_else(|| panic!("stroke {k}: no component"));
        // The peak's order is interpolated between bins: a fifth of the bin spacing.
        assert!((c.order - order).abs() < 0.01, "stroke {k}: {c:?}");
        assert!(
            (c.amplitude_n - amp).abs() < 0.005 * amp,
            "stroke {k}: {c:?}"
        );
        assert_eq!(c.cause.to_string(), cause);
        assert!(c.trusted);
        // The FFS is the ripple: its RMS is amp/√2 (the IAFV takes the trend, not the ripple,
        // except within about a lead of the ends where the fit bends towards it).
        let rms = (a.ffs_n.iter().map(|x| x * x).sum::<f64>() / a.ffs_n.len() as f64).sqrt();
        assert!(
            (rms - amp / 2f64.sqrt()).abs() < 0.05 * amp,
            "stroke {k}: FFS RMS {rms}"
        );
        // A single polynomial of order ≤ 8 cannot follow 20 or 40 ripple cycles: its residual
        // standard deviation is the ripple's RMS, amp/√2, within 5 %.
        let single = &s.single_polynomials[k];
        assert_eq!(single.poly.orders, vec![a.order_scan.best_order]);
        assert!(
            (single.residual_std_n - amp / 2f64.sqrt()).abs() < 0.05 * amp / 2f64.sqrt(),
            "stroke {k}: {}",
            single.residual_std_n
        );
        // and it is the row of the scan for that order.
        let row = a
            .order_scan
            .rows
            .iter()
            .find(|r| r.order == a.order_scan.best_order)
            .unwrap();
        assert!((row.residual_std_n - single.residual_std_n).abs() < 1e-6 * amp);
    }
    // Table 2: orders 1-8, forward from stroke 1 only, backward from stroke 2 only.
    let t = &s.order_scan_table;
    assert_eq!((t.forward_strokes, t.backward_strokes), (1, 1));
    assert_eq!(
        t.rows.iter().map(|r| r.order).collect::<Vec<_>>(),
        (1..=8).collect::<Vec<_>>()
    );
    for (r, (f, b)) in t.rows.iter().zip(
        s.analyses[0]
            .order_scan
            .rows
            .iter()
            .zip(&s.analyses[1].order_scan.rows),
    ) {
        assert_eq!(r.forward_std_n, Some(f.residual_std_n));
        assert_eq!(r.backward_std_n, Some(b.residual_std_n));
    }
}

#[test]
fn analyze_strokes_table_runs_to_at_least_eight_orders() {
    let mut p = AnalyzeStudyParams::default();
    assert_eq!(p.estimate.samples_per_lead, 1024);
    assert_eq!(p.table_max_order(), 8);
    p.analysis.scan_max_order = 3;
    assert_eq!(p.table_max_order(), 8);
    let s = analyze_strokes(
        vec![ripple_stroke(1, Direction::Forward, 1.0, 5.0)],
        &lead_10mm_axis(),
        &p,
        &|_, _| {},
    )
    .unwrap();
    assert_eq!(s.analyses[0].order_scan.rows.len(), 3);
    assert_eq!(s.order_scan_table.rows.len(), 8);
    assert!(s
        .order_scan_table
        .rows
        .iter()
        .all(|r| r.backward_std_n.is_none()));
    p.analysis.scan_max_order = 10;
    assert_eq!(p.table_max_order(), 10);
}

#[test]
fn analyze_strokes_names_the_stroke_that_fails() {
    // A breakpoint outside the stroke's travel (20-220 mm).
    let mut p = AnalyzeStudyParams::default();
    p.analysis.profile.breaks_mm = Some(vec![500.0]);
    p.analysis.profile.orders = Some(vec![2, 2]);
    let e = analyze_strokes(
        vec![ripple_stroke(4, Direction::Backward, 1.0, 5.0)],
        &lead_10mm_axis(),
        &p,
        &|_, _| {},
    )
    .unwrap_err();
    match &e {
        StudyError::Stroke {
            stroke,
            direction,
            start_mm,
            end_mm,
            source,
        } => {
            assert_eq!((*stroke, *direction), (4, "backward"));
            assert!((start_mm - 220.0).abs() < 1e-12 && (end_mm - 20.0).abs() < 1e-12);
            assert!(
                matches!(
                    source,
                    crate::profile::ProfileError::BreakpointOutsideStroke { .. }
                ),
                "{source}"
            );
        }
        e => panic!("{e}"),
    }
    assert_eq!(e.kind(), ErrorKind::BadInput);
}

#[test]
fn analyze_trace_estimates_then_analyses_both_directions() {
    let (trace, axis) = stroke_trace();
    let s = analyze_trace(&trace, &axis, &AnalyzeStudyParams::default(), &|_, _| {}).unwrap();
    assert_eq!(s.strokes.len(), 2);
    assert_eq!(s.analyses.len(), 2);
    assert_eq!(s.single_polynomials.len(), 2);
    let dirs: Vec<Direction> = s.strokes.iter().map(|x| x.summary.direction).collect();
    assert_eq!(dirs, vec![Direction::Forward, Direction::Backward]);
    for (x, a) in s.strokes.iter().zip(&s.analyses) {
        assert_eq!(a.iafv_n.len(), x.position_m.len());
        assert_eq!(a.direction, x.summary.direction);
    }
    assert_eq!(
        (
            s.order_scan_table.forward_strokes,
            s.order_scan_table.backward_strokes
        ),
        (1, 1)
    );
    // Estimation errors keep their kind.
    let bad = AnalyzeStudyParams {
        estimate: crate::estimate::EstimateParams {
            samples_per_lead: 0,
            ..Default::default()
        },
        ..Default::default()
    };
    let e = analyze_trace(&trace, &axis, &bad, &|_, _| {}).unwrap_err();
    assert!(matches!(e, StudyError::Estimate(_)), "{e}");
    assert_eq!(e.kind(), ErrorKind::BadInput);
}

#[test]
fn trends_without_a_baseline_say_what_is_missing() {
    // Two tests of one indicator against a five-test baseline: nothing can be assessed, and
    // the diagnosis must not read that silence as "no change".
    let p = |t: f64, v: f64| Point {
        time_s: t,
        value: v,
        std_error: Some(1.0),
    };
    let mut s: BTreeMap<String, IndicatorSeries> = BTreeMap::new();
    s.insert(
        "fs_n".into(),
        vec![(1, p(0.0, 100.0)), (2, p(86400.0, 101.0))],
    );
    let t = axis_trends(&s, None, &TrendStudyParams::default()).unwrap();
    assert!(t.trends.is_empty());
    assert_eq!(t.skipped, ["fs_n"]);
    assert_eq!(t.diagnosis.len(), 1, "{:?}", t.diagnosis);
    let d = &t.diagnosis[0];
    assert!(d.contains("No indicator has a baseline yet"), "{d}");
    assert!(
        d.contains("needs 5 tests") && d.contains("at most 2") && d.contains("3 more"),
        "{d}"
    );
    assert!(!d.contains("no evidence"), "{d}");
}
