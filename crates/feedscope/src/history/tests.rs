//! Hand computations, a detection-delay test on a simulated drift, and the diagnosis rules.
use rand::{rngs::StdRng, Rng, SeedableRng};
use rand_distr::{Distribution, Normal};

use super::*;
use crate::stroke::Direction;

const DAY: f64 = 86_400.0;

fn series(values: &[f64]) -> Vec<Point> {
    values
        .iter()
        .enumerate()
        .map(|(i, &v)| Point {
            time_s: i as f64 * 7.0 * DAY,
            value: v,
            std_error: None,
        })
        .collect()
}

/// Relative tolerance for hand-computed values: a few ulps of the sums involved.
const TOL: f64 = 1e-12;

#[test]
fn baseline_first_n_by_hand() {
    // mean of 10, 12, 14 = 12; sample variance ((−2)² + 0 + 2²)/2 = 4 → σ = 2
    let p = series(&[10.0, 12.0, 14.0, 30.0]);
    let b = baseline(&p, BaselineSpec::FirstN { count: 3 }, 0.0).unwrap();
    assert!((b.mean - 12.0).abs() < TOL && (b.std - 2.0).abs() < TOL);
    assert_eq!(b.count, 3);
    let l = Limits::shewhart(&b, 3.0);
    assert!((l.lower - 6.0).abs() < TOL && (l.upper - 18.0).abs() < TOL);
    // floor: 1 % of 12 = 0.12 > 0 scatter
    let b = baseline(
        &series(&[12.0, 12.0, 12.0]),
        BaselineSpec::FirstN { count: 3 },
        0.01,
    )
    .unwrap();
    assert!((b.std - 0.12).abs() < TOL && b.std_floored);
    assert_eq!(
        baseline(&p[..1], BaselineSpec::FirstN { count: 3 }, 0.0),
        Err(HistoryError::TooFewPoints { needed: 3, got: 1 })
    );
}

#[test]
fn baseline_reference_by_hand() {
    let mut p = series(&[10.0, 12.0, 14.0, 30.0]);
    p[3].std_error = Some(0.5);
    // reference = point 3 (30), σ from the first 3 = 2
    let b = baseline(
        &p,
        BaselineSpec::Reference {
            index: 3,
            spread_count: 3,
        },
        0.0,
    )
    .unwrap();
    assert!((b.mean - 30.0).abs() < TOL && (b.std - 2.0).abs() < TOL);
    // no spread points: the reference's own standard error
    let b = baseline(
        &p,
        BaselineSpec::Reference {
            index: 3,
            spread_count: 0,
        },
        0.0,
    )
    .unwrap();
    assert!((b.std - 0.5).abs() < TOL);
}

#[test]
fn ewma_by_hand() {
    // μ0 = 0, σ = 1, λ = 0.5, L = 2
    let b = Baseline {
        mean: 0.0,
        std: 1.0,
        count: 2,
        std_floored: false,
    };
    let e = ewma(&[2.0, 2.0, -4.0], &b, 0.5, 2.0);
    // z1 = 1, z2 = 1.5, z3 = −1.25
    for (z, want) in e.z.iter().zip([1.0, 1.5, -1.25]) {
        assert!((z - want).abs() < TOL, "{z} vs {want}");
    }
    // width_t = 2·sqrt(0.5/1.5·(1 − 0.25^t)): t=1 → 2·sqrt(0.25) = 1, t=2 → 2·sqrt(0.3125)
    assert!((e.limits[0].upper - 1.0).abs() < TOL);
    assert!((e.limits[1].upper - 2.0 * 0.3125f64.sqrt()).abs() < TOL);
    // z2 = 1.5 > 1.118: the second point alarms, not the first (z1 = 1 is on the limit)
    assert_eq!(e.first_alarm, Some(1));
}

#[test]
fn cusum_by_hand() {
    let b = Baseline {
        mean: 10.0,
        std: 2.0,
        count: 2,
        std_floored: false,
    };
    // u = 1, 1, 3, −2; k = 0.5, h = 3
    // C+ = 0.5, 1.0, 3.5, 1.0 ; C− = 0, 0, 0, 1.5
    let c = cusum(&[12.0, 12.0, 16.0, 6.0], &b, 0.5, 3.0);
    for (x, want) in c.upper.iter().zip([0.5, 1.0, 3.5, 1.0]) {
        assert!((x - want).abs() < TOL);
    }
    for (x, want) in c.lower.iter().zip([0.0, 0.0, 0.0, 1.5]) {
        assert!((x - want).abs() < TOL);
    }
    assert_eq!(c.first_alarm, Some(2));
}

#[test]
fn slope_and_projection_by_hand() {
    // exactly 2 N/day from 100 N; the last point is at t = 5 d, 110 N; threshold 120 N →
    // (120 − 110)/2 = 5 days after it
    let p: Vec<Point> = (0..6)
        .map(|i| Point {
            time_s: i as f64 * DAY,
            value: 100.0 + 2.0 * i as f64,
            std_error: None,
        })
        .collect();
    let s = recent_slope(&p, 6).unwrap();
    assert!((s.per_day - 2.0).abs() < 1e-9 && (s.value_at_last - 110.0).abs() < 1e-9);
    let th = Threshold {
        upper: Some(120.0),
        lower: Some(50.0),
    };
    let pr = project_crossing(&s, &th).unwrap();
    assert!(pr.upper && (pr.days - 5.0).abs() < 1e-9, "{pr:?}");
    // heading away from the only threshold, or too noisy: no projection
    assert!(project_crossing(
        &s,
        &Threshold {
            upper: None,
            lower: Some(50.0)
        }
    )
    .is_none());
    let noisy = series(&[100.0, 130.0, 90.0, 125.0, 95.0, 120.0]);
    let s = recent_slope(&noisy, 6).unwrap();
    assert!(project_crossing(&s, &th).is_none(), "{s:?}");
}

#[test]
fn indicator_names_round_trip() {
    for i in [
        Indicator::StaticFriction,
        Indicator::CoulombFriction,
        Indicator::Viscous,
        Indicator::StribeckVelocity,
        Indicator::Inertia,
        Indicator::MeanFriction {
            direction: Direction::Backward,
            start_mm: 0.0,
            end_mm: 82.5,
        },
        Indicator::Component {
            direction: Direction::Forward,
            cause: crate::label::Cause::NutRefeed(1),
        },
    ] {
        assert_eq!(Indicator::parse(&i.name()), Some(i.clone()), "{}", i.name());
    }
    assert_eq!(Indicator::parse("mean_n/sideways/0-1mm"), None);
}

/// Detection delay on a simulated drift: 10 in-control weeks (σ = 4 N), then +0.6 N a week
/// (0.15 σ/week, the slow lubrication drift the charts are for). Over 200 seeds, EWMA and
/// CUSUM must signal on average well before the Shewhart chart and before the drift itself
/// reaches the 3σ = 12 N line of a single test (20 weeks), and false alarms in the
/// in-control part must be rare.
#[test]
fn drift_detected_before_the_shewhart_chart() {
    let mut rng = StdRng::seed_from_u64(42);
    let noise = Normal::new(0.0, 4.0).unwrap();
    let (mut d_ewma, mut d_cusum, mut d_shew, mut false_alarms) = (0.0, 0.0, 0.0, 0);
    let runs = 200;
    let params = TrendParams {
        baseline: BaselineSpec::FirstN { count: 10 },
        min_relative_std: 0.0,
        ..TrendParams::default()
    };
    for _ in 0..runs {
        let vals: Vec<f64> = (0..60)
            .map(|i| {
                let drift = if i >= 10 { 0.6 * (i - 9) as f64 } else { 0.0 };
                400.0 + noise.sample(&mut rng) + drift
            })
            .collect();
        let p = series(&vals);
        let t = assess(
            &Indicator::StaticFriction,
            &p,
            &params,
            &Threshold::default(),
        )
        .unwrap();
        let delay = |a: Option<usize>| a.map_or(50.0, |i| i as f64 - 9.0);
        if t.ewma.first_alarm.is_some_and(|i| i < 10) || t.cusum.first_alarm.is_some_and(|i| i < 10)
        {
            false_alarms += 1;
        }
        d_ewma += delay(t.ewma.first_alarm);
        d_cusum += delay(t.cusum.first_alarm);
        d_shew += delay(p.iter().position(|q| t.limits.outside(q.value)));
        let _: f64 = rng.random(); // decorrelate runs a little more
    }
    let n = runs as f64;
    let (e, c, s) = (d_ewma / n, d_cusum / n, d_shew / n);
    eprintln!("mean detection delay (weeks): EWMA {e:.1}, CUSUM {c:.1}, Shewhart {s:.1}");
    assert!(
        e < s - 2.0 && c < s - 2.0,
        "EWMA {e}, CUSUM {c}, Shewhart {s}"
    );
    assert!(e < 16.0 && c < 16.0, "EWMA {e}, CUSUM {c}");
    // baseline points are judged against their own mean: rare but possible; < 10 % of runs
    assert!(false_alarms < runs / 10, "{false_alarms} false alarms");
}

fn trend_of(ind: Indicator, vals: &[f64]) -> IndicatorTrend {
    assess(
        &ind,
        &series(vals),
        &TrendParams::default(),
        &Threshold::default(),
    )
    .unwrap()
}

#[test]
fn diagnosis_lubrication_and_steady() {
    let steady = [400.0, 401.0, 399.0, 400.5, 399.5, 400.0, 400.2, 399.8];
    let rising = [400.0, 401.0, 399.0, 400.5, 399.5, 420.0, 440.0, 460.0];
    let d = diagnose(&[
        trend_of(Indicator::StaticFriction, &rising),
        trend_of(Indicator::Viscous, &rising),
        trend_of(Indicator::CoulombFriction, &steady),
    ]);
    assert!(
        d[0].contains("lubrication") && d[0].contains("evidence"),
        "{d:?}"
    );
    let d = diagnose(&[
        trend_of(Indicator::StaticFriction, &steady),
        trend_of(Indicator::Viscous, &steady),
    ]);
    assert_eq!(d.len(), 1);
    assert!(d[0].contains("no evidence"), "{d:?}");
}

#[test]
fn diagnosis_preload_and_local_bump() {
    let steady = [300.0, 301.0, 299.0, 300.5, 299.5, 300.0, 300.2, 299.8];
    let falling = [300.0, 301.0, 299.0, 300.5, 299.5, 285.0, 275.0, 265.0];
    let rising = [300.0, 301.0, 299.0, 300.5, 299.5, 315.0, 325.0, 335.0];
    let m = |a: f64, b: f64| Indicator::MeanFriction {
        direction: Direction::Forward,
        start_mm: a,
        end_mm: b,
    };
    let refeed = Indicator::Component {
        direction: Direction::Forward,
        cause: crate::label::Cause::NutRefeed(1),
    };
    let d = diagnose(&[
        trend_of(m(0.0, 100.0), &falling),
        trend_of(m(100.0, 200.0), &falling),
        trend_of(m(200.0, 300.0), &steady),
        trend_of(refeed, &[5.0, 5.1, 4.9, 5.0, 5.05, 7.0, 8.0, 9.0]),
    ]);
    assert!(
        d.iter()
            .any(|s| s.contains("preload") && s.contains("refeed")),
        "{d:?}"
    );
    let d = diagnose(&[
        trend_of(m(0.0, 100.0), &steady),
        trend_of(m(100.0, 200.0), &rising),
        trend_of(m(200.0, 300.0), &steady),
    ]);
    assert!(
        d.iter()
            .any(|s| s.contains("locally") && s.contains("100-200 mm")),
        "{d:?}"
    );
}

#[test]
fn rejects_bad_input() {
    let mut p = series(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    p[2].value = f64::NAN;
    assert!(matches!(
        assess(
            &Indicator::Inertia,
            &p,
            &TrendParams::default(),
            &Threshold::default()
        ),
        Err(HistoryError::NotFinite { .. })
    ));
    let mut p = series(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    p[4].time_s = 0.0;
    assert!(matches!(
        assess(
            &Indicator::Inertia,
            &p,
            &TrendParams::default(),
            &Threshold::default()
        ),
        Err(HistoryError::TimeNotIncreasing { index: 4 })
    ));
    let bad = TrendParams {
        ewma_lambda: 0.0,
        ..TrendParams::default()
    };
    assert!(matches!(
        assess(
            &Indicator::Inertia,
            &series(&[1.0; 6]),
            &bad,
            &Threshold::default()
        ),
        Err(HistoryError::InvalidParams(_))
    ));
}
