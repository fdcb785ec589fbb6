use std::path::Path;

use super::*;
use crate::diag::Code;
use crate::estimate::{Direction, StrokeFriction, StrokeSummary};
use crate::units::feed_mm_min_to_m_s;

const LEAD_M: f64 = 0.01;

/// A synthetic stroke over [10, 50] mm on the grid p/1024, friction from `f(z_mm, feed)`
/// (magnitude; signed by the direction).
fn stroke(dir: Direction, feed: f64, f: impl Fn(f64, f64) -> f64) -> StrokeFriction {
    let step = LEAD_M / 1024.0;
    let mut z: Vec<f64> = (0..4097).map(|k| 0.01 + k as f64 * step).collect();
    if dir == Direction::Backward {
        z.reverse();
    }
    let n = z.len();
    let fr: Vec<f64> = z.iter().map(|&x| dir.sign() * f(x * 1e3, feed)).collect();
    StrokeFriction {
        summary: StrokeSummary {
            stroke: 0,
            direction: dir,
            feed_mm_min: feed,
            feed_min_mm_min: None,
            feed_max_mm_min: None,
            start_mm: z[0] * 1e3,
            end_mm: z[n - 1] * 1e3,
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
            kind: crate::estimate::MoveKind::Measuring,
            position_cutoff_order: None,
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
        velocity_m_s: vec![feed_mm_min_to_m_s(dir.sign() * feed); n],
        accel_m_s2: vec![0.0; n],
        effort: vec![0.0; n],
        position_m: z,
        friction_n: fr,
    }
}

fn run(feed: f64, repeat: u32, strokes: Vec<StrokeFriction>) -> RunFriction {
    RunFriction {
        run: TestRun {
            name: format!("f{feed}_r{repeat}.csv"),
            file: format!("f{feed}_r{repeat}.csv").into(),
            feed_mm_min: feed,
            repeat,
        },
        strokes,
        warnings: vec![],
    }
}

/// A smooth truth: level with a trend and a bump, Stribeck fall and viscous rise.
fn smooth(z: f64, feed: f64) -> f64 {
    let v = feed_mm_min_to_m_s(feed);
    200.0
        + 0.5 * z
        + 20.0 * (-0.5 * ((z - 30.0) / 6.0f64).powi(2)).exp()
        + 60.0 * (-(feed / 40.0f64).powi(2)).exp()
        + 5000.0 * v
}

#[test]
fn ppocm_of_identical_repeats_equals_each_repeat() {
    let runs: Vec<RunFriction> = (1..=3)
        .map(|r| {
            run(
                100.0,
                r,
                vec![
                    stroke(Direction::Forward, 100.0, |z, _| {
                        250.0 + (z * 0.2).sin() * 10.0
                    }),
                    stroke(Direction::Backward, 100.0, |z, _| 300.0 - 0.3 * z),
                ],
            )
        })
        .collect();
    let map = build_map(&runs, LEAD_M, &MapParams::default()).unwrap();
    assert_eq!(map.directions.len(), 2);
    for d in &map.directions {
        // 40 mm span minus 1 mm margins: 38 mm → ⌊38/40⌋ → 1 interval... clamp gives 1.
        assert_eq!(d.orders, vec![4]);
        assert_eq!(d.feeds.len(), 1);
        let g = &d.feeds[0];
        assert_eq!(g.repeats.len(), 3);
        for r in &g.repeats {
            for (a, b) in r
                .poly
                .coeffs_n
                .iter()
                .flatten()
                .zip(g.ppocm.coeffs_n.iter().flatten())
            {
                // Identical data: the mean of equal numbers is exact up to one rounding.
                assert!((a - b).abs() <= 1e-12 * b.abs().max(1.0), "{a} vs {b}");
            }
        }
        for rep in &g.repeatability {
            assert!(rep.std_n.unwrap() < 1e-9 && rep.max_spread_n < 1e-9);
        }
        // One feed: the map is constant in feed and equals the PPOCM.
        assert_eq!(d.feed_model.order, 0);
        let f = d.friction_n(30.0, 100.0, false).unwrap();
        assert!((f - g.ppocm.value_n(0.03)).abs() < 1e-9);
    }
}

#[test]
fn repeatability_of_offset_repeats() {
    // Repeats 250 ± 4 N: sample std = 4·√2 N, spread 8 N, mean 250 N.
    let runs = vec![
        run(
            50.0,
            1,
            vec![stroke(Direction::Forward, 50.0, |_, _| 254.0)],
        ),
        run(
            50.0,
            2,
            vec![stroke(Direction::Forward, 50.0, |_, _| 246.0)],
        ),
    ];
    let params = MapParams {
        breaks_mm: Some(vec![25.0]),
        orders: Some(vec![3, 3]),
        ..MapParams::default()
    };
    let map = build_map(&runs, LEAD_M, &params).unwrap();
    let d = map.direction(Direction::Forward).unwrap();
    assert!(map.direction(Direction::Backward).is_none());
    // The span ends are the grid points (step p/1024) just inside the 1 mm margins.
    let step_mm = 10.0 / 1024.0;
    assert!(d.breaks_mm[0] >= 11.0 && d.breaks_mm[0] < 11.0 + step_mm);
    assert!(d.breaks_mm[2] <= 49.0 && d.breaks_mm[2] > 49.0 - step_mm);
    assert!((d.breaks_mm[1] - 25.0).abs() < 1e-12);
    let g = &d.feeds[0];
    for rep in &g.repeatability {
        // Tolerances: constant data are fitted to rounding (1e-9 N).
        assert!((rep.mean_n - 250.0).abs() < 1e-9);
        assert!((rep.std_n.unwrap() - 4.0 * 2f64.sqrt()).abs() < 1e-9);
        assert!((rep.max_spread_n - 8.0).abs() < 1e-9);
    }
}

#[test]
fn feed_polynomial_order_rule_and_exactness() {
    // Friction quadratic in ln(feed): a feed polynomial of order ≥ 2 in log scale is exact.
    let law = |z: f64, f: f64| 180.0 + 0.2 * z + 12.0 * f.ln() - 1.5 * f.ln().powi(2);
    for (n_feeds, order) in [(1, 0), (2, 0), (3, 1), (4, 2), (7, 5), (10, 5)] {
        let feeds: Vec<f64> = (0..n_feeds)
            .map(|k| 10.0 * 60f64.powf(k as f64 / (n_feeds.max(2) - 1) as f64))
            .collect();
        let runs: Vec<RunFriction> = feeds
            .iter()
            .map(|&f| run(f, 1, vec![stroke(Direction::Forward, f, law)]))
            .collect();
        let map = build_map(&runs, LEAD_M, &MapParams::default()).unwrap();
        let d = &map.directions[0];
        assert_eq!(d.feed_model.order, order, "{n_feeds} feeds");
        if order >= 2 {
            // Exact model: misfit at rounding level of ~300 N values.
            assert!(
                d.feed_model.rms_misfit_n < 1e-8,
                "{}",
                d.feed_model.rms_misfit_n
            );
            let mid = (feeds[0] * feeds[n_feeds - 1]).sqrt();
            let f = d.friction_n(20.0, mid, false).unwrap();
            assert!((f - law(20.0, mid)).abs() < 1e-8);
            assert!(d.feed_model.condition_number < 10.0);
        }
    }
}

#[test]
fn map_refuses_positions_and_feeds_outside_unless_asked() {
    let runs: Vec<RunFriction> = [20.0, 80.0, 320.0]
        .iter()
        .map(|&f| run(f, 1, vec![stroke(Direction::Backward, f, smooth)]))
        .collect();
    let map = build_map(&runs, LEAD_M, &MapParams::default()).unwrap();
    let d = map.direction(Direction::Backward).unwrap();
    assert!(
        d.friction_n(30.0, 80.0, false).unwrap() < 0.0,
        "backward is negative"
    );
    assert!(matches!(
        d.friction_n(5.0, 80.0, false),
        Err(MapError::PositionOutside { .. })
    ));
    assert!(matches!(
        d.friction_n(30.0, 400.0, false),
        Err(MapError::FeedOutside { .. })
    ));
    assert!(d.friction_n(30.0, 400.0, true).unwrap().is_finite());
    assert!(matches!(
        stribeck_profile(d, &[30.0, 60.0], &MapParams::default()),
        Err(MapError::PositionOutside { position_mm, .. }) if (position_mm - 60.0).abs() < 1e-12
    ));
}

#[test]
fn stribeck_profile_recovers_synthetic_parameters() {
    let feeds: Vec<f64> = (0..12)
        .map(|k| 8.0 * 100f64.powf(k as f64 / 11.0))
        .collect();
    let runs: Vec<RunFriction> = feeds
        .iter()
        .flat_map(|&f| (1..=2).map(move |r| run(f, r, vec![stroke(Direction::Forward, f, smooth)])))
        .collect();
    let params = MapParams::default();
    let map = build_map(&runs, LEAD_M, &params).unwrap();
    let d = &map.directions[0];
    let prof = stribeck_profile(d, &[20.0, 30.0, 40.0], &params).unwrap();
    for p in &prof.positions {
        let fit = p.fit.as_ref().unwrap();
        let z = p.position_mm;
        let fc = 200.0 + 0.5 * z + 20.0 * (-0.5 * ((z - 30.0) / 6.0f64).powi(2)).exp();
        // The quartic in position does not hold the Gaussian bump exactly; 1 % covers it.
        assert!(
            (fit.params.fc_n - fc).abs() < 0.01 * fc,
            "{} vs {fc}",
            fit.params.fc_n
        );
        assert!((fit.params.static_excess_n() - 60.0).abs() < 0.5);
        assert!((fit.vs_mm_min() - 40.0).abs() < 0.5);
        assert!((fit.params.sigma_n_s_per_m - 5000.0).abs() < 50.0);
        assert!(p.nonconventional.as_ref().unwrap().ranges.is_empty());
    }
    assert!(nonconventional_spans(&prof).is_empty());
}

#[test]
fn nonconventional_falls_are_gathered_into_position_spans() {
    // Beyond 150 mm/min friction falls by up to 60 N (more than the viscous rise), but only for z in (20, 40) mm, weighted
    // by a C¹ bump cos²(π(z − 30)/20).
    let law = |z: f64, feed: f64| {
        let w = if (z - 30.0).abs() < 10.0 {
            (std::f64::consts::PI * (z - 30.0) / 20.0).cos().powi(2)
        } else {
            0.0
        };
        smooth(z, feed) - w * 60.0 * (1.0 - (-((feed - 150.0) / 100.0).max(0.0)).exp())
    };
    let feeds: Vec<f64> = (0..14)
        .map(|k| 8.0 * 150f64.powf(k as f64 / 13.0))
        .collect();
    let runs: Vec<RunFriction> = feeds
        .iter()
        .map(|&f| run(f, 1, vec![stroke(Direction::Forward, f, law)]))
        .collect();
    let params = MapParams {
        breaks_mm: Some(vec![20.0, 30.0, 40.0]),
        orders: Some(vec![4, 4, 4, 4]),
        // Noise-free data: state the noise rather than estimate it from model misfit.
        nonconventional: crate::stribeck::NonConventionalParams {
            noise_n: Some(0.5),
            ..Default::default()
        },
        ..MapParams::default()
    };
    let map = build_map(&runs, LEAD_M, &params).unwrap();
    let d = &map.directions[0];
    let positions: Vec<f64> = (0..=18).map(|k| 12.0 + 2.0 * k as f64).collect();
    let prof = stribeck_profile(d, &positions, &params).unwrap();
    let spans = nonconventional_spans(&prof);
    assert_eq!(spans.len(), 1, "{spans:#?}");
    let s = &spans[0];
    assert!(
        s.from_position_mm >= 18.0 && s.to_position_mm <= 42.0,
        "{s:?}"
    );
    assert!(
        s.from_position_mm <= 30.0 && s.to_position_mm >= 30.0,
        "{s:?}"
    );
    assert!(s.positions >= 3, "{s:?}");
    // The fall starts at the last feed below 150 mm/min and bottoms out a few feeds later.
    assert!((100.0..=160.0).contains(&s.from_feed_mm_min), "{s:?}");
    assert!(s.to_feed_mm_min > 300.0, "{s:?}");
}

#[test]
fn index_parses_relative_paths_and_extra_columns() {
    let text = "# test set of the Z axis\nrepeat,file,feed_mm_min,note\n1,a/r1.csv,100,cold\n\n2,r2.csv,100.5,warm\n";
    let set = TestSet::parse_index(text, Path::new("/data/z"), "index.csv").unwrap();
    assert_eq!(set.runs.len(), 2);
    assert_eq!(set.runs[0].file, Path::new("/data/z/a/r1.csv"));
    assert_eq!(set.runs[0].name, "a/r1.csv");
    assert_eq!(set.runs[1].repeat, 2);
    assert!((set.runs[1].feed_mm_min - 100.5).abs() < 1e-12);
    for (bad, line, what) in [
        ("file,feed_mm_min\na,1\n", 1, "repeat"),
        ("file,feed_mm_min,repeat\na,-3,1\n", 2, "feed_mm_min"),
        ("file,feed_mm_min,repeat\na,3,x\n", 2, "repeat"),
        ("file,feed_mm_min,repeat\na,3\n", 2, "fields"),
        ("file,feed_mm_min,repeat\n", 0, "no runs"),
    ] {
        let e = TestSet::parse_index(bad, Path::new(""), "i.csv").unwrap_err();
        match &e {
            MapError::Index {
                line: l, message, ..
            } => {
                assert_eq!(*l, line, "{e}");
                assert!(message.contains(what), "{e}");
            }
            other => panic!("{other}"),
        }
    }
}

#[test]
fn failed_runs_are_reported_by_name_and_the_rest_estimated() {
    use crate::trace::{Channel, EffortKind, Trace};
    let axis = crate::axis::AxisParams::parse(
        "lead_mm = 10\ntable_mass_kg = 300\ninertia_kgm2 = 0.002\n\
         damping_nms_per_rad = 0\ntorque_constant_nm_per_a = 1.5\n",
        crate::axis::ConfigFormat::Toml,
        "axis",
    )
    .unwrap();
    // 1 s dwell, then 20 mm forward at 120 mm/min against 150 N.
    let t: Vec<f64> = (0..1200).map(|k| k as f64 * 0.01).collect();
    let z: Vec<f64> = t
        .iter()
        .map(|&t| 0.002 * (t - 1.0).clamp(0.0, 10.0))
        .collect();
    let amps = 150.0 / axis.force_per_torque_n_per_nm() / 1.5;
    let trace = Trace {
        position_m: Channel {
            time_s: t.clone(),
            value: z,
        },
        effort: Channel {
            time_s: t,
            value: vec![amps; 1200],
        },
        effort_kind: EffortKind::CurrentA,
        facts: Default::default(),
    };
    let runs: Vec<TestRun> = ["good1.csv", "broken.csv", "good2.csv", "wrongfeed.csv"]
        .iter()
        .map(|n| TestRun {
            name: n.to_string(),
            file: n.into(),
            feed_mm_min: if *n == "wrongfeed.csv" { 600.0 } else { 120.0 },
            repeat: 1,
        })
        .collect();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let est = estimate_set_with(
        &runs,
        |r| {
            if r.name == "broken.csv" {
                Err("line 7: `x` is not a number".into())
            } else {
                Ok(trace.clone())
            }
        },
        &axis,
        &crate::estimate::EstimateParams::default(),
        0.25,
        &|_| {
            done.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        },
    );
    assert_eq!(done.into_inner(), 4);
    let ok: Vec<&str> = est.ok.iter().map(|r| r.run.name.as_str()).collect();
    assert_eq!(ok, ["good1.csv", "good2.csv"]);
    let failed: Vec<&str> = est.failed.iter().map(|r| r.run.name.as_str()).collect();
    assert_eq!(failed, ["broken.csv", "wrongfeed.csv"]);
    assert!(est.failed[0].error.contains("not a number"));
    assert!(
        est.failed[1].error.contains("600"),
        "{}",
        est.failed[1].error
    );
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(16))]
    /// The PPOCM is the pointwise mean of the repeats' IAFV (the basis is linear in the
    /// coefficients), for random smooth repeats and layouts.
    #[test]
    fn ppocm_is_the_pointwise_mean_of_the_repeats(
        offsets in proptest::collection::vec(-30.0f64..30.0, 2..5),
        slope in -2.0f64..2.0,
        wave in 0.0f64..15.0,
        two_intervals in proptest::bool::ANY,
    ) {
        let runs: Vec<RunFriction> = offsets
            .iter()
            .enumerate()
            .map(|(k, &o)| {
                let law = move |z: f64, _f: f64| 250.0 + o + slope * z + wave * (z * 0.15 + k as f64).sin();
                run(60.0, k as u32 + 1, vec![stroke(Direction::Forward, 60.0, law)])
            })
            .collect();
        let params = MapParams {
            breaks_mm: two_intervals.then(|| vec![30.0]),
            orders: two_intervals.then(|| vec![5, 5]),
            ..MapParams::default()
        };
        let map = build_map(&runs, LEAD_M, &params).unwrap();
        let g = &map.directions[0].feeds[0];
        for i in 0..=40 {
            let z = (12.0 + 36.0 * i as f64 / 40.0) * 1e-3;
            let mean = g.repeats.iter().map(|r| r.poly.value_n(z)).sum::<f64>() / g.repeats.len() as f64;
            // ~300 N values summed over ≤ 6 Legendre terms: 1e-9 N is far above rounding.
            proptest::prop_assert!((g.ppocm.value_n(z) - mean).abs() < 1e-9);
        }
    }
}

/// A test set at two feeds: at every position the fit is the Coulomb + viscous line through
/// the two PPOCM values, exactly, and says that four parameters need four feeds.
#[test]
fn two_feed_profile_gives_the_line_through_the_ppocm() {
    let feeds = [600.0, 3000.0];
    let runs: Vec<RunFriction> = feeds
        .iter()
        .flat_map(|&f| {
            (1..=2).map(move |r| {
                run(
                    f,
                    r,
                    vec![
                        stroke(Direction::Forward, f, smooth),
                        stroke(Direction::Backward, f, |z, f| 1.1 * smooth(z, f)),
                    ],
                )
            })
        })
        .collect();
    let params = MapParams::default();
    let map = build_map(&runs, LEAD_M, &params).unwrap();
    for d in &map.directions {
        let prof = stribeck_profile(d, &[20.0, 30.0, 40.0], &params).unwrap();
        for p in &prof.positions {
            let fit = p.fit.as_ref().unwrap();
            assert_eq!(fit.model, crate::stribeck::FrictionModel::CoulombViscous);
            let v: Vec<f64> = feeds.iter().map(|&f| feed_mm_min_to_m_s(f)).collect();
            let (f0, f1) = (p.friction_n[0], p.friction_n[1]);
            let sigma = (f1 - f0) / (v[1] - v[0]);
            let fc = f0 - sigma * v[0];
            // two exact equations on ~250 N values: rounding far below 1e-9
            assert!((fit.params.fc_n - fc).abs() < 1e-9, "{fit:?}");
            assert!((fit.params.sigma_n_s_per_m - sigma).abs() < 1e-9 * sigma);
            let r = &fit.reductions[0];
            assert_eq!(r.code(), Code::TooFewFeeds);
            assert!(r.to_string().contains("2 (600 and 3000 mm/min)"), "{r}");
            assert!(p.error.is_none());
        }
    }
}
