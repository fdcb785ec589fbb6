//! Tests of the IAFV fit and the full stroke analysis on synthetic friction.

use std::f64::consts::PI;

use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};

use super::lsq::{legendre, lstsq, Mat};
use super::piecewise::Layout;
use super::*;
use crate::axis::{AxisParams, DeclaredOrder};
use crate::order::SpectrumAnalyzer;

/// A true fluctuation component.
#[derive(Clone, Copy)]
pub(crate) struct Tone {
    pub order: f64,
    pub amplitude_n: f64,
    pub cause: &'static str,
}

/// The components of the synthetic drive: rolling mark, shaft 1-4, nut refeed 8.6 + 2x, guide
/// refeed 9.5 + 2x, amplitudes 2-12 N.
pub(crate) const TONES: [Tone; 9] = [
    Tone {
        order: 0.6,
        amplitude_n: 4.0,
        cause: "declared: rolling-tool mark",
    },
    Tone {
        order: 1.0,
        amplitude_n: 8.0,
        cause: "shaft 1x",
    },
    Tone {
        order: 2.0,
        amplitude_n: 6.0,
        cause: "shaft 2x",
    },
    Tone {
        order: 3.0,
        amplitude_n: 3.0,
        cause: "shaft 3x",
    },
    Tone {
        order: 4.0,
        amplitude_n: 2.0,
        cause: "shaft 4x",
    },
    Tone {
        order: 8.6,
        amplitude_n: 10.0,
        cause: "nut ball refeed 1x",
    },
    Tone {
        order: 17.2,
        amplitude_n: 4.0,
        cause: "nut ball refeed 2x",
    },
    Tone {
        order: 9.5,
        amplitude_n: 12.0,
        cause: "guide ball refeed 1x",
    },
    Tone {
        order: 19.0,
        amplitude_n: 5.0,
        cause: "guide ball refeed 2x",
    },
];

pub(crate) fn axis(lead_mm: f64) -> AxisParams {
    let text = format!(
        "lead_mm = {lead_mm}\ntable_mass_kg = 425\ninertia_kgm2 = 0.004\n\
         damping_nms_per_rad = 0.002\ntorque_constant_nm_per_a = 1.82\n"
    );
    let mut a = AxisParams::parse(&text, crate::axis::ConfigFormat::Toml, "t").unwrap();
    // ½·20·(40 − 5.6)/40 = 8.6; guides z = 19 → 9.5.
    a.screw_diameter_mm = Some(40.0);
    a.screw_ball_diameter_mm = Some(5.6);
    a.contact_angle_deg = Some(0.0);
    a.screw_balls_per_turn = Some(20.0);
    a.guide_balls_per_raceway = Some(19.0);
    a.declared_orders = vec![DeclaredOrder {
        order: 0.6,
        cause: "rolling-tool mark".into(),
    }];
    a
}

/// True mean profile (N) at x (mm): offset + trend + Gaussian bump, different per direction.
pub(crate) fn true_mean(dir: Direction, x_mm: f64) -> f64 {
    match dir {
        Direction::Forward => {
            60.0 + 0.05 * x_mm + 15.0 * (-0.5 * ((x_mm - 120.0) / 25.0).powi(2)).exp()
        }
        Direction::Backward => {
            -(90.0 + 0.08 * x_mm + 20.0 * (-0.5 * ((x_mm - 250.0) / 30.0).powi(2)).exp())
        }
    }
}

/// Synthetic stroke over 0-400 mm on the grid lead/1024: positions (m), friction (N), true mean,
/// true fluctuation without noise.
pub(crate) struct Synth {
    pub position_m: Vec<f64>,
    pub friction_n: Vec<f64>,
    pub mean_n: Vec<f64>,
    pub tones_n: Vec<f64>,
}

pub(crate) fn synth(lead_mm: f64, dir: Direction, noise_n: f64, seed: u64) -> Synth {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let phases: Vec<f64> = TONES
        .iter()
        .map(|_| rng.random_range(0.0..2.0 * PI))
        .collect();
    let normal = Normal::new(0.0, noise_n.max(1e-300)).unwrap();
    let n = (400.0 / lead_mm * 1024.0).round() as usize + 1;
    let dx = lead_mm / 1024.0;
    let mut s = Synth {
        position_m: Vec::with_capacity(n),
        friction_n: Vec::with_capacity(n),
        mean_n: Vec::with_capacity(n),
        tones_n: Vec::with_capacity(n),
    };
    for i in 0..n {
        let x = match dir {
            Direction::Forward => i as f64 * dx,
            Direction::Backward => 400.0 - i as f64 * dx,
        };
        let mean = true_mean(dir, x);
        let tones: f64 = TONES
            .iter()
            .zip(&phases)
            .map(|(t, ph)| t.amplitude_n * (2.0 * PI * t.order * x / lead_mm + ph).cos())
            .collect::<Vec<_>>()
            .iter()
            .sum();
        let noise = if noise_n > 0.0 {
            normal.sample(&mut rng)
        } else {
            0.0
        };
        s.position_m.push(x * 1e-3);
        s.mean_n.push(mean);
        s.tones_n.push(tones);
        s.friction_n.push(mean + tones + noise);
    }
    s
}

pub(crate) fn stroke<'a>(
    s: &'a Synth,
    dir: Direction,
    lead_mm: f64,
    trusted: f64,
) -> StrokeView<'a> {
    StrokeView {
        direction: dir,
        position_m: &s.position_m,
        friction_n: &s.friction_n,
        lead_m: lead_mm * 1e-3,
        max_trusted_order: trusted,
        feed_mm_min: Some(200.0),
    }
}

fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for x in v {
        s += x * x;
        n += 1;
    }
    (s / n.max(1) as f64).sqrt()
}

const CASES: [(f64, Direction, u64); 4] = [
    (10.0, Direction::Forward, 1),
    (10.0, Direction::Backward, 2),
    (16.0, Direction::Forward, 3),
    (5.0, Direction::Backward, 4),
];

/// IAFV error relative to the fluctuation RMS, ≥ 10 mm from the ends.
fn iafv_error_ratio(
    lead: f64,
    dir: Direction,
    seed: u64,
    params: &ProfileParams,
) -> (f64, IafvFit) {
    let s = synth(lead, dir, 3.0, seed);
    let st = stroke(&s, dir, lead, 60.0);
    let fit = fit_iafv(&st, params, &mut SpectrumAnalyzer::new()).unwrap();
    let iafv = fit.evaluate(&s.position_m);
    let err = rms(s
        .position_m
        .iter()
        .zip(iafv.iter().zip(&s.mean_n))
        .filter(|(x, _)| **x >= 0.010 && **x <= 0.390)
        .map(|(_, (a, b))| a - b));
    let fluct = rms(s.tones_n.iter().copied());
    (err / fluct, fit)
}

#[test]
fn iafv_recovers_true_mean_within_15_percent_of_fluctuation() {
    for (lead, dir, seed) in CASES {
        let (ratio, fit) = iafv_error_ratio(lead, dir, seed, &ProfileParams::default());
        eprintln!(
            "lead {lead} {dir:?}: IAFV RMS error / fluctuation RMS = {ratio:.4}; breaks {:?} orders {:?}; {} sinusoids",
            fit.poly.breaks_mm, fit.poly.orders, fit.nuisance_sinusoids.len()
        );
        assert!(ratio < 0.15, "lead {lead} {dir:?}: ratio {ratio}");
    }
}

#[test]
fn joint_sinusoids_are_what_keeps_the_low_orders_out_of_the_iafv() {
    // Without the joint sinusoids the 0.6-8.6 order tones inflate the BIC's noise estimate and
    // leak into the fit: the joint fit must be several times better. (Measured: 0.018 vs 0.29.)
    let no_joint = ProfileParams {
        joint_sinusoids: false,
        ..ProfileParams::default()
    };
    let (without, _) = iafv_error_ratio(10.0, Direction::Forward, 1, &no_joint);
    let (with, _) = iafv_error_ratio(10.0, Direction::Forward, 1, &ProfileParams::default());
    eprintln!("IAFV error ratio: joint {with:.4}, polynomial only {without:.4}");
    assert!(with < 0.15 && with * 3.0 < without, "{with} vs {without}");
}

#[test]
fn continuity_holds_at_every_breakpoint() {
    for (lead, dir, seed) in CASES {
        let (_, fit) = iafv_error_ratio(lead, dir, seed, &ProfileParams::default());
        assert!(fit.poly.orders.len() >= 2, "expected several intervals");
        for d in fit.poly.continuity_defects() {
            assert!(d.value_relative < 1e-9 && d.slope_relative < 1e-9, "{d:?}");
        }
    }
    // The paper's layout as a user override.
    let s = synth(10.0, Direction::Forward, 3.0, 7);
    let st = stroke(&s, Direction::Forward, 10.0, 60.0);
    let params = ProfileParams {
        breaks_mm: Some(vec![85.0, 150.0]),
        orders: Some(vec![4, 5, 4]),
        ..ProfileParams::default()
    };
    let fit = fit_iafv(&st, &params, &mut SpectrumAnalyzer::new()).unwrap();
    assert_eq!(fit.poly.orders, vec![4, 5, 4]);
    for d in &fit.continuity {
        assert!(d.value_relative < 1e-9 && d.slope_relative < 1e-9, "{d:?}");
    }
}

#[test]
fn backward_stroke_equals_forward_sorted() {
    let s = synth(10.0, Direction::Backward, 3.0, 5);
    let st = stroke(&s, Direction::Backward, 10.0, 60.0);
    let mut a = SpectrumAnalyzer::new();
    let fb = fit_iafv(&st, &ProfileParams::default(), &mut a).unwrap();
    let mut x = s.position_m.clone();
    let mut y = s.friction_n.clone();
    x.reverse();
    y.reverse();
    let st2 = StrokeView {
        position_m: &x,
        friction_n: &y,
        ..st
    };
    let ff = fit_iafv(&st2, &ProfileParams::default(), &mut a).unwrap();
    assert_eq!(fb.poly.breaks_mm.len(), ff.poly.breaks_mm.len());
    for p in [0.05, 0.2, 0.33] {
        // Same data, same algorithm: agreement to rounding.
        assert!((fb.poly.value_n(p) - ff.poly.value_n(p)).abs() < 1e-8);
    }
}

/// A C¹ piecewise polynomial of the given layout with random coefficients: the projection of
/// random data onto the feasible set.
fn random_c1_truth(x: &[f64], breaks: &[f64], orders: &[usize], seed: u64) -> PiecewisePoly {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let y: Vec<f64> = x.iter().map(|_| rng.random_range(-50.0..50.0)).collect();
    fit_piecewise(x, &y, breaks, orders).unwrap().poly
}

#[test]
fn piecewise_polynomial_of_fitted_orders_is_reproduced_exactly() {
    let lead = 10.0;
    let n = 40 * 1024 + 1;
    let x: Vec<f64> = (0..n).map(|i| i as f64 * lead / 1024.0 * 1e-3).collect();
    let truth = random_c1_truth(&x, &[85.0, 150.0], &[4, 5, 4], 11);
    let y: Vec<f64> = x.iter().map(|&p| 100.0 + truth.value_n(p)).collect();
    let scale = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    // Plain fit on the points.
    let fit = fit_piecewise(&x, &y, &[85.0, 150.0], &[4, 5, 4]).unwrap();
    // Through the IAFV path: block means, joint sinusoids (if any are found) must get ~0.
    let st = StrokeView {
        direction: Direction::Forward,
        position_m: &x,
        friction_n: &y,
        lead_m: lead * 1e-3,
        max_trusted_order: 512.0,
        feed_mm_min: None,
    };
    let params = ProfileParams {
        breaks_mm: Some(vec![85.0, 150.0]),
        orders: Some(vec![4, 5, 4]),
        ..ProfileParams::default()
    };
    let iafv = fit_iafv(&st, &params, &mut SpectrumAnalyzer::new()).unwrap();
    // Also a single global quartic, reproduced by any layout with orders ≥ 4.
    let q: Vec<f64> = x
        .iter()
        .map(|&p| {
            let t = p * 1e3 / 400.0;
            30.0 - 20.0 * t + 50.0 * t * t - 70.0 * t.powi(3) + 40.0 * t.powi(4)
        })
        .collect();
    let fq = fit_piecewise(&x, &q, &[120.0, 260.0], &[4, 4, 6]).unwrap();
    for (i, &p) in x.iter().enumerate().step_by(97) {
        // Rounding: ~1e-13 relative per operation, amplified modestly by the QR.
        assert!(
            (fit.poly.value_n(p) - y[i]).abs() < 1e-9 * scale,
            "plain at {p}"
        );
        assert!(
            (iafv.poly.value_n(p) - y[i]).abs() < 1e-9 * scale,
            "iafv at {p}"
        );
        assert!(
            (fq.poly.value_n(p) - q[i]).abs() < 1e-9 * 50.0,
            "quartic at {p}"
        );
    }
}

#[test]
fn order_scan_matches_dense_qr_and_table2_shape() {
    let s = synth(10.0, Direction::Forward, 3.0, 1);
    let st = stroke(&s, Direction::Forward, 10.0, 60.0);
    let scan = order_scan(&st, 8).unwrap();
    assert_eq!(scan.rows.len(), 8);
    // Oracle: Householder QR on a Legendre basis for every order.
    let n = s.position_m.len();
    for row in &scan.rows {
        let m = row.order;
        let mut a = Mat::zeros(n, m + 1);
        let mut p = vec![0.0; m + 1];
        for (i, &x) in s.position_m.iter().enumerate() {
            legendre(x / 0.2 - 1.0, &mut p);
            for (j, v) in p.iter().enumerate() {
                a.add(i, j, *v);
            }
        }
        let r = lstsq(a, s.friction_n.clone()).unwrap();
        let sd = (r.rss / (n - m - 1) as f64).sqrt();
        assert!(
            (sd - row.residual_std_n).abs() < 1e-9 * sd,
            "order {m}: {sd} vs {}",
            row.residual_std_n
        );
    }
    // The residual std never exceeds the line's and the minimum is reported.
    let best = scan
        .rows
        .iter()
        .map(|r| r.residual_std_n)
        .fold(f64::INFINITY, f64::min);
    let at_best = scan
        .rows
        .iter()
        .find(|r| r.order == scan.best_order)
        .unwrap();
    assert!((at_best.residual_std_n - best).abs() < 1e-15 * best.max(1.0));
    let json = serde_json::to_string(&scan).unwrap();
    assert!(json.contains("\"residual_std_n\""));
}

#[test]
fn linear_trend_recovers_slope() {
    let n = 4001;
    let x: Vec<f64> = (0..n).map(|i| 0.1 + i as f64 * 1e-4).collect();
    let y: Vec<f64> = x.iter().map(|&p| 50.0 + 30.0 * p).collect(); // 0.03 N/mm
    let st = StrokeView {
        direction: Direction::Forward,
        position_m: &x,
        friction_n: &y,
        lead_m: 0.01,
        max_trusted_order: 10.0,
        feed_mm_min: None,
    };
    let fit = fit_iafv(&st, &ProfileParams::default(), &mut SpectrumAnalyzer::new()).unwrap();
    assert!((fit.linear.slope_n_per_mm - 0.03).abs() < 1e-12);
    assert!((fit.linear.value_at_start_n - 53.0).abs() < 1e-9);
    assert!((fit.linear.value_at_end_n - 65.0).abs() < 1e-9);
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let x: Vec<f64> = (0..100).map(|i| i as f64 * 1e-3).collect();
    let y = vec![1.0; 100];
    let mut a = SpectrumAnalyzer::new();
    let base = StrokeView {
        direction: Direction::Forward,
        position_m: &x,
        friction_n: &y,
        lead_m: 0.01,
        max_trusted_order: 5.0,
        feed_mm_min: None,
    };
    let p = ProfileParams::default();
    let err = |st: StrokeView<'_>, p: &ProfileParams, a: &mut SpectrumAnalyzer| {
        fit_iafv(&st, p, a).unwrap_err()
    };
    assert!(matches!(
        err(
            StrokeView {
                position_m: &x[..10],
                friction_n: &y[..10],
                ..base
            },
            &p,
            &mut a
        ),
        ProfileError::TooFewPoints { got: 10, .. }
    ));
    assert!(matches!(
        err(
            StrokeView {
                friction_n: &y[..99],
                ..base
            },
            &p,
            &mut a
        ),
        ProfileError::LengthMismatch { .. }
    ));
    let mut yn = y.clone();
    yn[42] = f64::NAN;
    assert!(matches!(
        err(
            StrokeView {
                friction_n: &yn,
                ..base
            },
            &p,
            &mut a
        ),
        ProfileError::NonFinite {
            channel: "friction_n",
            index: 42
        }
    ));
    let mut xb = x.clone();
    xb[50] += 3e-4;
    assert!(matches!(
        err(
            StrokeView {
                position_m: &xb,
                ..base
            },
            &p,
            &mut a
        ),
        ProfileError::NonUniformGrid { index: 50, .. }
    ));
    let mut xs = x.clone();
    xs.swap(10, 11);
    assert!(matches!(
        err(
            StrokeView {
                position_m: &xs,
                ..base
            },
            &p,
            &mut a
        ),
        ProfileError::NotMonotonic { .. }
    ));
    let with = |b: Vec<f64>, o: Vec<usize>| ProfileParams {
        breaks_mm: Some(b),
        orders: Some(o),
        ..ProfileParams::default()
    };
    assert!(matches!(
        err(base, &with(vec![120.0], vec![1, 1]), &mut a),
        ProfileError::BreakpointOutsideStroke { .. }
    ));
    assert!(matches!(
        err(base, &with(vec![60.0, 30.0], vec![1, 1, 1]), &mut a),
        ProfileError::BreakpointsUnsorted { .. }
    ));
    assert!(matches!(
        err(base, &with(vec![30.0], vec![1]), &mut a),
        ProfileError::OrdersMismatch { .. }
    ));
    assert!(matches!(
        err(base, &with(vec![3.0], vec![5, 1]), &mut a),
        ProfileError::OrderTooHigh {
            interval: 0,
            order: 5,
            points: 3,
            ..
        }
    ));
    assert!(matches!(
        err(
            StrokeView {
                lead_m: -1.0,
                ..base
            },
            &p,
            &mut a
        ),
        ProfileError::InvalidParameter { name: "lead_m", .. }
    ));
    assert!(matches!(
        order_scan(&base, 0),
        Err(ProfileError::InvalidParameter { .. })
    ));
}

/// Dense KKT oracle for min ‖A c − y‖ s.t. C c = 0 (nalgebra SVD solve of the square system).
fn kkt_fit(x_mm: &[f64], y: &[f64], breaks: &[f64], orders: &[usize]) -> Vec<f64> {
    let layout = Layout::new(breaks.to_vec(), orders.to_vec());
    let nc = layout.n_coef();
    let c = layout.constraints();
    let r = c.len();
    let mut a = nalgebra::DMatrix::<f64>::zeros(x_mm.len(), nc);
    let mut k = 0;
    for (i, &x) in x_mm.iter().enumerate() {
        while k + 1 < orders.len() && x >= breaks[k + 1] {
            k += 1;
        }
        let t = 2.0 * (x - breaks[k]) / (breaks[k + 1] - breaks[k]) - 1.0;
        let mut p = vec![0.0; orders[k] + 1];
        legendre(t, &mut p);
        for (j, v) in p.iter().enumerate() {
            a[(i, layout.offsets[k] + j)] = *v;
        }
    }
    let mut kkt = nalgebra::DMatrix::<f64>::zeros(nc + r, nc + r);
    let ata = a.transpose() * &a;
    kkt.view_mut((0, 0), (nc, nc)).copy_from(&ata);
    for (i, row) in c.iter().enumerate() {
        for (j, v) in row.iter().enumerate() {
            kkt[(nc + i, j)] = *v;
            kkt[(j, nc + i)] = *v;
        }
    }
    let yv = nalgebra::DVector::from_column_slice(y);
    let mut rhs = nalgebra::DVector::<f64>::zeros(nc + r);
    rhs.rows_mut(0, nc).copy_from(&(a.transpose() * yv));
    let sol = kkt.svd(true, true).solve(&rhs, 1e-13).unwrap();
    let coef = sol.rows(0, nc).iter().copied().collect::<Vec<_>>();
    (&a * nalgebra::DVector::from_vec(coef))
        .iter()
        .copied()
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// The null-space solution satisfies the constraints exactly, matches the KKT oracle and has
    /// a residual orthogonal to every feasible direction.
    #[test]
    fn constrained_ls_matches_kkt_oracle(
        seed in 0u64..1_000_000,
        nint in 1usize..4,
        orders in proptest::collection::vec(1usize..6, 3),
        npts in 60usize..200,
    ) {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let x: Vec<f64> = (0..npts).map(|i| i as f64 * 2.0 + rng.random_range(0.0..1.0)).collect();
        let y: Vec<f64> = x.iter().map(|v| (v * 0.05).sin() * 20.0 + rng.random_range(-3.0..3.0)).collect();
        let span = x[npts - 1] - x[0];
        let interior: Vec<f64> = (1..nint).map(|k| x[0] + span * k as f64 / nint as f64 + 0.3).collect();
        let ord = &orders[..nint];
        let xm: Vec<f64> = x.iter().map(|v| v * 1e-3).collect();
        let fit = fit_piecewise(&xm, &y, &interior, ord).unwrap();
        for d in fit.poly.continuity_defects() {
            prop_assert!(d.value_relative < 1e-9 && d.slope_relative < 1e-9, "{:?}", d);
        }
        let mut breaks = vec![x[0]];
        breaks.extend_from_slice(&interior);
        breaks.push(x[npts - 1]);
        let oracle = kkt_fit(&x, &y, &breaks, ord);
        let scale = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (i, &xv) in xm.iter().enumerate() {
            // KKT squares the condition number; 1e-7 of the data scale is still far below any
            // mistake in a constraint row or basis.
            prop_assert!((fit.poly.value_n(xv) - oracle[i]).abs() < 1e-7 * scale, "point {}", i);
        }
    }

    /// Arbitrary (finite or not) data never panics the whole analysis.
    #[test]
    fn analysis_never_panics(
        vals in proptest::collection::vec(prop_oneof![Just(f64::NAN), -1e6f64..1e6, Just(0.0)], 0..300),
        lead in prop_oneof![Just(0.0), Just(-1.0), 1e-4f64..0.05],
        trusted in prop_oneof![Just(f64::NAN), Just(0.0), 0.5f64..100.0],
        brk in proptest::option::of(proptest::collection::vec(-10.0f64..400.0, 0..4)),
    ) {
        let x: Vec<f64> = (0..vals.len()).map(|i| i as f64 * 1e-4).collect();
        let st = StrokeView {
            direction: Direction::Forward,
            position_m: &x,
            friction_n: &vals,
            lead_m: lead,
            max_trusted_order: trusted,
            feed_mm_min: None,
        };
        let params = AnalysisParams {
            profile: ProfileParams { orders: brk.as_ref().map(|b| vec![2; b.len() + 1]), breaks_mm: brk, ..ProfileParams::default() },
            ..AnalysisParams::default()
        };
        let _ = analyze_stroke(&st, &axis(10.0), &params, &mut SpectrumAnalyzer::new());
    }
}

fn analysis(lead: f64, dir: Direction, seed: u64, trusted: f64) -> (StrokeAnalysis, Synth) {
    let s = synth(lead, dir, 3.0, seed);
    let st = stroke(&s, dir, lead, trusted);
    let a = analyze_stroke(
        &st,
        &axis(lead),
        &AnalysisParams::default(),
        &mut SpectrumAnalyzer::new(),
    )
    .unwrap();
    (a, s)
}

#[test]
fn whole_stroke_spectrum_finds_and_classifies_every_component() {
    for (lead, dir, seed) in CASES {
        let (a, _) = analysis(lead, dir, seed, 60.0);
        let all: Vec<_> = a
            .fluctuation
            .components
            .iter()
            .filter(|c| c.segment.is_whole())
            .collect();
        for t in TONES {
            let found = all
                .iter()
                .filter(|c| (c.order - t.order).abs() <= 0.02)
                .max_by(|x, y| x.amplitude_n.total_cmp(&y.amplitude_n));
            let Some(c) = found else {
                panic!(
                    "lead {lead} {dir:?}: component {} not found in {all:#?}",
                    t.order
                )
            };
            let rel = (c.amplitude_n - t.amplitude_n).abs() / t.amplitude_n;
            eprintln!(
                "lead {lead} {dir:?}: order {:.2}: found {:.5} (err {:+.5}), amplitude {:.3} N (err {:+.2} %), {}",
                t.order,
                c.order,
                c.order - t.order,
                c.amplitude_n,
                100.0 * (c.amplitude_n - t.amplitude_n) / t.amplitude_n,
                c.cause
            );
            assert!(
                rel < 0.10,
                "order {}: amplitude {} vs {}",
                t.order,
                c.amplitude_n,
                t.amplitude_n
            );
            assert_eq!(c.cause.to_string(), t.cause);
            assert!(c.trusted);
        }
        // Spurious: significant components ≥ 1 N not within 0.02 orders of a true one.
        let spurious: Vec<_> = all
            .iter()
            .filter(|c| {
                c.amplitude_n >= 1.0 && TONES.iter().all(|t| (c.order - t.order).abs() > 0.02)
            })
            .collect();
        assert!(
            spurious.is_empty(),
            "lead {lead} {dir:?}: spurious {spurious:#?}"
        );
        eprintln!(
            "lead {lead} {dir:?}: whole stroke {} components, extras below 1 N {:?}",
            all.len(),
            all.iter()
                .filter(|c| TONES.iter().all(|t| (c.order - t.order).abs() > 0.02))
                .map(|c| (c.order, c.amplitude_n))
                .collect::<Vec<_>>()
        );
        // Per segment at most one spurious significant component (any amplitude): a component
        // is explained by a true tone within max(resolution, 3 %) of its order.
        for sp in a
            .fluctuation
            .spectra
            .iter()
            .filter(|s| !s.segment.is_whole())
        {
            let bad: Vec<_> = a
                .fluctuation
                .components
                .iter()
                .filter(|c| c.segment == sp.segment)
                .filter(|c| {
                    TONES.iter().all(|t| {
                        (c.order - t.order).abs() > sp.order_resolution.max(0.03 * t.order)
                    })
                })
                .collect();
            let total = a
                .fluctuation
                .components
                .iter()
                .filter(|c| c.segment == sp.segment)
                .count();
            eprintln!(
                "lead {lead} {dir:?} segment {} ({:.0}-{:.0} mm, resolution {:.3}): {total} components, {} spurious {:?}",
                sp.segment,
                sp.start_mm,
                sp.end_mm,
                sp.order_resolution,
                bad.len(),
                bad.iter().map(|c| (c.order, c.amplitude_n)).collect::<Vec<_>>()
            );
            let seg: Vec<_> = a
                .fluctuation
                .components
                .iter()
                .filter(|c| c.segment == sp.segment)
                .collect();
            let missed: Vec<f64> = TONES
                .iter()
                .filter(|t| {
                    seg.iter().all(|c| {
                        (c.order - t.order).abs() > sp.order_resolution.max(0.03 * t.order)
                    })
                })
                .map(|t| t.order)
                .collect();
            eprintln!("    missed {missed:?}");
            // Recall in segments of ≥ 4 leads: every tone but 0.6, which sits 2 bins (Hann's
            // resolution limit) from the twice stronger shaft 1x at these resolutions.
            if sp.length_leads >= 4.0 {
                assert!(
                    missed.iter().all(|&o| o < 0.7),
                    "segment {}: missed {missed:?}",
                    sp.segment
                );
            }
            assert!(
                bad.len() <= 1,
                "lead {lead} {dir:?} segment {}: {bad:#?}",
                sp.segment
            );
        }
        assert!(
            a.fluctuation.warnings.is_empty(),
            "{:?}",
            a.fluctuation.warnings
        );
        assert!(a.fluctuation.spectra.len() >= 4);
    }
}

#[test]
fn aliasing_guard_flags_untrusted_orders_and_gives_the_feed() {
    // Raw samples per lead = 24 → trusted up to 12: 17.2 and 19 must be flagged, and the
    // highest kinematic order (guide 3x = 28.5) needs 28.5/12 = 2.375 × slower feed:
    // 200 mm/min / 2.375 = 84.2 mm/min.
    let (a, _) = analysis(10.0, Direction::Forward, 1, 12.0);
    let comps = &a.fluctuation.components;
    assert!(comps
        .iter()
        .filter(|c| c.segment.is_whole() && c.order > 12.0)
        .all(|c| !c.trusted));
    assert!(comps
        .iter()
        .any(|c| c.segment.is_whole() && (c.order - 19.0).abs() < 0.02 && !c.trusted));
    assert!(comps.iter().filter(|c| c.order <= 12.0).all(|c| c.trusted));
    let codes: Vec<&str> = a
        .fluctuation
        .warnings
        .iter()
        .map(|d| d.code.as_str())
        .collect();
    assert!(
        codes.contains(&"kinematic-order-above-trusted"),
        "{codes:?}"
    );
    assert!(codes.contains(&"components-above-trusted"), "{codes:?}");
    let w: Vec<String> = a
        .fluctuation
        .warnings
        .iter()
        .map(|d| d.to_string())
        .collect();
    let w = w.join("\n");
    assert!(
        w.contains("28.50") && w.contains("84.2 mm/min") && w.contains("2.38 x faster"),
        "{w}"
    );
    assert!(w.contains("trusted = false"), "{w}");
}

#[test]
fn analysis_serialises_with_unit_named_fields() {
    let (a, _) = analysis(16.0, Direction::Forward, 3, 60.0);
    let json = serde_json::to_string(&a.fluctuation.components[0]).unwrap();
    for key in [
        "\"order\"",
        "\"amplitude_n\"",
        "\"position_mm\"",
        "\"cause\"",
        "\"trusted\"",
    ] {
        assert!(json.contains(key), "{json}");
    }
    let json = serde_json::to_string(&a.iafv).unwrap();
    for key in ["\"breaks_mm\"", "\"coeffs_n\"", "\"slope_n_per_mm\""] {
        assert!(json.contains(key), "{key}");
    }
    let back: IafvFit = serde_json::from_str(&json).unwrap();
    assert_eq!(back.poly, a.iafv.poly);
}

#[test]
fn power_coefficients_evaluate_like_the_legendre_form() {
    let x: Vec<f64> = (0..400).map(|i| i as f64 * 1e-3).collect();
    let truth = random_c1_truth(&x, &[120.0, 250.0], &[3, 5, 4], 3);
    for k in 0..3 {
        let a = truth.power_coefficients(k).unwrap();
        assert_eq!(a.len(), truth.orders[k] + 1);
        let b = truth.breaks_mm[k];
        for s in [0.0f64, 17.3, 60.0] {
            let v: f64 = a
                .iter()
                .enumerate()
                .map(|(j, aj)| aj * s.powi(j as i32))
                .sum();
            let want = truth.interval_value_slope(k, (b + s) * 1e-3).unwrap().0;
            // Power form over ≤ 150 mm at order ≤ 5: cancellation ~1e-10 of the scale.
            assert!(
                (v - want).abs() < 1e-8 * (1.0 + want.abs()),
                "k {k} s {s}: {v} vs {want}"
            );
        }
    }
    assert!(truth.power_coefficients(3).is_none());
}

#[test]
fn partial_overrides_use_the_given_part() {
    let s = synth(10.0, Direction::Forward, 3.0, 9);
    let st = stroke(&s, Direction::Forward, 10.0, 60.0);
    let mut an = SpectrumAnalyzer::new();
    // One global quartic (the paper's Table 2 choice).
    let p = ProfileParams {
        orders: Some(vec![4]),
        ..ProfileParams::default()
    };
    let f = fit_iafv(&st, &p, &mut an).unwrap();
    assert_eq!(f.poly.orders, vec![4]);
    assert_eq!(f.poly.breaks_mm.len(), 2);
    assert!(!f.selection.automatic);
    // Breakpoints given, orders by BIC within the cap ⌊len_leads / 2⌋.
    let p = ProfileParams {
        breaks_mm: Some(vec![85.0, 150.0]),
        ..ProfileParams::default()
    };
    let f = fit_iafv(&st, &p, &mut an).unwrap();
    assert_eq!(f.poly.breaks_mm, vec![0.0, 85.0, 150.0, 400.0]);
    assert_eq!(f.poly.orders.len(), 3);
    assert!(f.poly.orders[1] <= 3 && f.poly.orders[0] <= 4 && f.poly.orders[2] <= 8);
    assert!(f.selection.automatic && f.selection.noise_sigma_n.is_some());
    // The bump at 120 mm needs curvature in the first two intervals.
    assert!(
        f.poly.orders[0] >= 2 || f.poly.orders[1] >= 2,
        "{:?}",
        f.poly.orders
    );
    // Two orders for one interval is a mismatch.
    let p = ProfileParams {
        orders: Some(vec![4, 4]),
        ..ProfileParams::default()
    };
    assert!(matches!(
        fit_iafv(&st, &p, &mut an),
        Err(ProfileError::OrdersMismatch {
            orders: 2,
            intervals: 1
        })
    ));
}

#[test]
fn heavy_noise_stays_fast_and_finds_the_strong_tones() {
    // σ = 30 N per sample: thousands of noise maxima above 0.5 N; only the pre-tested ones get a
    // DTFT. The strong tones (≥ 8 N) must still be found in the whole-stroke spectrum.
    let s = synth(10.0, Direction::Forward, 30.0, 21);
    let st = stroke(&s, Direction::Forward, 10.0, 60.0);
    let t0 = std::time::Instant::now();
    let a = analyze_stroke(
        &st,
        &axis(10.0),
        &AnalysisParams::default(),
        &mut SpectrumAnalyzer::new(),
    )
    .unwrap();
    eprintln!("heavy noise analysis: {:?}", t0.elapsed());
    for t in TONES.iter().filter(|t| t.amplitude_n >= 8.0) {
        assert!(
            a.fluctuation
                .components
                .iter()
                .any(|c| c.segment.is_whole() && (c.order - t.order).abs() < 0.02),
            "{}",
            t.order
        );
    }
}

#[test]
fn order_scan_table_averages_per_direction() {
    let f1 = synth(10.0, Direction::Forward, 3.0, 1);
    let f2 = synth(10.0, Direction::Forward, 3.0, 2);
    let b1 = synth(10.0, Direction::Backward, 3.0, 3);
    let strokes = [
        stroke(&f1, Direction::Forward, 10.0, 60.0),
        stroke(&f2, Direction::Forward, 10.0, 60.0),
        stroke(&b1, Direction::Backward, 10.0, 60.0),
    ];
    let t = order_scan_table(&strokes, 8).unwrap();
    assert_eq!((t.forward_strokes, t.backward_strokes), (2, 1));
    assert_eq!(t.rows.len(), 8);
    let s1 = order_scan(&strokes[0], 8).unwrap();
    let s2 = order_scan(&strokes[1], 8).unwrap();
    let sb = order_scan(&strokes[2], 8).unwrap();
    for (i, r) in t.rows.iter().enumerate() {
        let want = 0.5 * (s1.rows[i].residual_std_n + s2.rows[i].residual_std_n);
        assert!((r.forward_std_n.unwrap() - want).abs() < 1e-12 * want);
        assert!((r.backward_std_n.unwrap() - sb.rows[i].residual_std_n).abs() < 1e-12 * want);
    }
    assert!(t.best_order_forward.is_some() && t.best_order_backward.is_some());
}

#[test]
fn malformed_poly_evaluates_to_nan_not_panic() {
    let p = PiecewisePoly {
        breaks_mm: vec![0.0],
        orders: vec![2, 3],
        coeffs_n: vec![vec![1.0]],
    };
    assert!(p.value_n(0.1).is_nan());
    assert!(p.power_coefficients(1).is_none());
    let _ = p.continuity_defects();
}
