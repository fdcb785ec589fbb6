use super::*;
use crate::axis::AxisParams;
use crate::estimate::{MoveKind, StrokeFriction, StrokeSummary};
use crate::map::{build_map, MapParams, RunFriction, TestRun};
use crate::stribeck::{fit_stribeck, StribeckFit, StribeckFitParams, StribeckParams, Termination};
use crate::stroke::Direction;
use crate::units::{feed_m_s_to_mm_min, feed_mm_min_to_m_s};

/// The twin's velocity term on a 260 N level: F_s − F_c = 85 N, v_s = 45 mm/min,
/// σ = 7000 N·s/m (the truth of `tests/roundtrip/map.rs` at z = 0).
fn params(fc: f64, excess: f64, vs_mm_min: f64, sigma: f64) -> StribeckParams {
    StribeckParams {
        fc_n: fc,
        fs_n: fc + excess,
        vs_m_s: feed_mm_min_to_m_s(vs_mm_min),
        sigma_n_s_per_m: sigma,
        delta: 2.0,
    }
}

/// The fit of exact data at `n` log-spaced feeds over [lo, hi] mm/min.
fn fit_of(p: &StribeckParams, lo: f64, hi: f64, n: usize) -> StribeckFit {
    let v: Vec<f64> = (0..n)
        .map(|k| feed_mm_min_to_m_s(lo * (hi / lo).powf(k as f64 / (n - 1) as f64)))
        .collect();
    let f: Vec<f64> = v.iter().map(|&v| p.magnitude_n(v)).collect();
    fit_stribeck(&v, &f, &StribeckFitParams::default()).unwrap()
}

fn curve(dir: Direction, p: &StribeckParams) -> FrictionCurve {
    FrictionCurve::from_stribeck(dir, &fit_of(p, 9.0, 900.0, 12)).unwrap()
}

/// The slow obvious reference: the table interpolated linearly (binary search) at `n` points
/// uniform in ln v over its span; max |e| and the trapezoidal RMS over ln v.
fn dense_error(c: &FrictionCurve, v: &[f64], y: &[f64], n: usize) -> (f64, f64) {
    let (a, b) = (v[0], v[v.len() - 1]);
    let mut max = 0.0f64;
    let (mut sq, mut prev) = (0.0, None::<f64>);
    let h = (b / a).ln() / (n - 1) as f64;
    for i in 0..n {
        let x = if i == n - 1 {
            b
        } else {
            a * (h * i as f64).exp()
        };
        let j = v.partition_point(|&t| t <= x).clamp(1, v.len() - 1);
        let lin = y[j - 1] + (y[j] - y[j - 1]) * (x - v[j - 1]) / (v[j] - v[j - 1]);
        let e = lin - c.magnitude_n(x);
        max = max.max(e.abs());
        if let Some(p) = prev {
            sq += 0.5 * h * (p * p + e * e);
        }
        prev = Some(e);
    }
    (max, (sq / (b / a).ln()).sqrt())
}

#[test]
fn stated_error_is_the_dense_measured_error() {
    let c = curve(Direction::Forward, &params(260.0, 85.0, 45.0, 7000.0));
    for n in [2, 5, 20, 60] {
        let t = place_points(&c, n, &PlacementParams::default()).unwrap();
        assert_eq!(t.velocity_m_s.len(), n);
        let (lo, hi) = c.range_m_s();
        assert!(
            (t.velocity_m_s[0] - lo).abs() < 1e-18 && (t.velocity_m_s[n - 1] - hi).abs() < 1e-18
        );
        assert!(t.velocity_m_s.windows(2).all(|w| w[1] > w[0]));
        let (max, rms) = dense_error(&c, &t.velocity_m_s, &t.friction_n, 400_001);
        // The stated max is sampled at 256 points per interval, the reference at 4e5 over the
        // range: the error is flat at its peaks, so they agree to the square of the sampling
        // step (≈ 1e-5 relative); the RMS (trapezoid on both) likewise.
        assert!(
            (t.error.max_n - max).abs() <= 1e-4 * max,
            "N={n}: {} vs {max}",
            t.error.max_n
        );
        assert!(
            (t.error.rms_n - rms).abs() <= 1e-3 * rms,
            "N={n}: {} vs {rms}",
            t.error.rms_n
        );
        // The stated max is refined between samples: never below the dense reference.
        assert!(t.error.max_n >= max * (1.0 - 1e-12), "N={n}");
        // The grid's minimax level is the same maximum seen at the candidates only.
        assert!((t.grid_level_n - t.error.max_n).abs() <= 0.01 * t.error.max_n + 1e-9);
    }
}

/// Minimax placement beats the obvious placements it replaces (uniform in v, uniform in ln v)
/// and comes out dense at low speed, where the Stribeck hump bends.
#[test]
fn placement_beats_uniform_and_is_dense_where_the_curve_bends() {
    let c = curve(Direction::Forward, &params(260.0, 85.0, 45.0, 7000.0));
    let p = PlacementParams::default();
    let t = place_points(&c, 20, &p).unwrap();
    let (lo, hi) = c.range_m_s();
    for spacing in [0, 1] {
        let v: Vec<f64> = (0..20)
            .map(|k| {
                let s = k as f64 / 19.0;
                match (k, spacing) {
                    (19, _) => hi,
                    (_, 0) => lo + (hi - lo) * s,
                    _ => lo * (hi / lo).powf(s),
                }
            })
            .collect();
        let y: Vec<f64> = v.iter().map(|&v| c.magnitude_n(v)).collect();
        let e = interpolation_error(&c, &v, &y, &p).unwrap();
        assert!(
            t.error.max_n < 0.5 * e.max_n,
            "{spacing}: {} vs {}",
            t.error.max_n,
            e.max_n
        );
    }
    // Half the points lie below 3·v_s (135 mm/min), a fifth of the range in ln v.
    let below = t
        .velocity_m_s
        .iter()
        .filter(|&&v| feed_m_s_to_mm_min(v) < 135.0)
        .count();
    assert!(below >= 10, "{below} of 20 below 3 vs");
    // On the test twin: 20 points cost well under 1 N (0.1 % of ~300 N).
    assert!(
        t.error.max_n < 0.3 && t.error.max_pct < 0.1,
        "{:?}",
        t.error
    );
}

/// A straight curve (the Coulomb + viscous line) is tabulated exactly with any N.
#[test]
fn a_straight_line_needs_two_points_and_gets_n() {
    let line = params(250.0, 0.0, 45.0, 5000.0);
    let fit = fit_of(&line, 10.0, 600.0, 2);
    assert_eq!(fit.model, crate::stribeck::FrictionModel::CoulombViscous);
    let c = FrictionCurve::from_stribeck(Direction::Backward, &fit).unwrap();
    assert!(c.stribeck().is_none());
    let t = place_points(&c, 7, &PlacementParams::default()).unwrap();
    assert_eq!(t.velocity_m_s.len(), 7);
    assert!(t.velocity_m_s.windows(2).all(|w| w[1] > w[0]));
    // Rounding only: 1e-12 of the force.
    assert!(t.error.max_n < 1e-9, "{:?}", t.error);
}

#[test]
fn bad_point_counts_and_extrapolation_are_refused() {
    let c = curve(Direction::Forward, &params(260.0, 85.0, 45.0, 7000.0));
    let p = PlacementParams::default();
    assert!(matches!(
        place_points(&c, 1, &p),
        Err(CompensationError::TooFewPoints { points: 1 })
    ));
    assert!(matches!(
        place_points(&c, 513, &p),
        Err(CompensationError::TooManyPoints { max: 512, .. })
    ));
    let (lo, hi) = c.range_m_s();
    let e = interpolation_error(&c, &[lo * 0.9, hi], &[300.0, 400.0], &p).unwrap_err();
    assert!(matches!(e, CompensationError::OutsideRange { .. }), "{e}");
    assert!(e.to_string().contains("no extrapolation"), "{e}");
    let e = interpolation_error(&c, &[hi, lo], &[1.0, 2.0], &p).unwrap_err();
    assert!(matches!(e, CompensationError::BadTable { .. }), "{e}");
}

#[test]
fn a_fit_that_did_not_converge_is_refused() {
    let mut fit = fit_of(&params(260.0, 85.0, 45.0, 7000.0), 9.0, 900.0, 12);
    fit.termination = Termination::MaxIterations;
    let e = FrictionCurve::from_stribeck(Direction::Forward, &fit).unwrap_err();
    assert!(matches!(e, CompensationError::NotConverged { .. }), "{e}");
    assert_eq!(e.kind(), crate::ErrorKind::BadInput);
}

/// Hand-computed: 300 N on a 10 mm lead, η = 0.9, k_e = 1.5 N·m/A:
/// T = 300·0.010/(2π·0.9) = 0.5305165 N·m, i = T/1.5 = 0.3536777 A; and the axis file's keys.
#[test]
fn force_to_torque_and_current_by_hand() {
    let d = DriveConversion::new(0.010, 1.5, 0.9).unwrap();
    assert!((d.torque_nm(300.0) - 0.530_516_477).abs() < 1e-8);
    assert!((d.current_a(300.0) - 0.353_677_651).abs() < 1e-8);
    assert!((d.current_a(-300.0) + 0.353_677_651).abs() < 1e-8);
    assert!((d.friction_from_current_n(0.353_677_651) - 300.0).abs() < 1e-6);
    let e = DriveConversion::new(0.010, 0.0, 1.0).unwrap_err();
    assert!(e.to_string().contains("torque_constant_nm_per_a"), "{e}");
    assert!(DriveConversion::new(0.010, 1.5, 1.2).is_err());
    let axis = twin_axis();
    let d = DriveConversion::from_axis(&axis, 1.0).unwrap();
    // 2π/p·k_e·i = F (paper 000 Eq. 5 at steady speed)
    assert!(
        (axis.force_per_torque_n_per_nm() * axis.torque_constant_nm_per_a * d.current_a(250.0)
            - 250.0)
            .abs()
            < 1e-9
    );
}

fn twin_axis() -> AxisParams {
    crate::sim::SimConfig::default().axis
}

// ---------- map section ----------

const LEAD_M: f64 = 0.01;

fn smooth(z: f64, feed: f64) -> f64 {
    let v = feed_mm_min_to_m_s(feed);
    200.0 + 0.5 * z + 60.0 * (-(feed / 40.0f64).powi(2)).exp() + 5000.0 * v
}

fn stroke(dir: Direction, feed: f64) -> StrokeFriction {
    let step = LEAD_M / 1024.0;
    let mut z: Vec<f64> = (0..4097).map(|k| 0.01 + k as f64 * step).collect();
    if dir == Direction::Backward {
        z.reverse();
    }
    let n = z.len();
    let fr: Vec<f64> = z
        .iter()
        .map(|&x| dir.sign() * smooth(x * 1e3, feed))
        .collect();
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
            kind: MoveKind::Measuring,
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

fn small_map() -> crate::map::FrictionMap {
    let runs: Vec<RunFriction> = [10.0, 20.0, 40.0, 80.0, 160.0, 320.0]
        .into_iter()
        .map(|f| RunFriction {
            run: TestRun {
                name: format!("f{f}"),
                file: "".into(),
                feed_mm_min: f,
                repeat: 1,
            },
            strokes: vec![
                stroke(Direction::Forward, f),
                stroke(Direction::Backward, f),
            ],
            warnings: vec![],
        })
        .collect();
    build_map(&runs, LEAD_M, &MapParams::default()).unwrap()
}

/// The collapsed series equals the map's own evaluation F(z, v) at every feed.
#[test]
fn map_section_equals_the_map() {
    let map = small_map();
    for d in &map.directions {
        let z = 27.3;
        let c = FrictionCurve::from_map_section(d, z).unwrap();
        let (lo, hi) = c.range_m_s();
        assert!(
            (feed_m_s_to_mm_min(lo) - 10.0).abs() < 1e-9
                && (feed_m_s_to_mm_min(hi) - 320.0).abs() < 1e-9
        );
        for f in [10.0, 13.7, 40.0, 99.0, 320.0] {
            let want = d.friction_n(z, f, false).unwrap().abs();
            let got = c.magnitude_n(feed_mm_min_to_m_s(f));
            assert!((got - want).abs() < 1e-9 * want, "{f}: {got} vs {want}");
        }
        assert!(
            c.label().contains("map section at 27.300 mm"),
            "{}",
            c.label()
        );
        let e = FrictionCurve::from_map_section(d, 80.0).unwrap_err();
        assert!(e.to_string().contains("position_mm"), "{e}");
    }
}

// ---------- TF5200 ----------

#[test]
fn tf5200_block_of_both_directions() {
    let fwd = curve(Direction::Forward, &params(260.0, 85.0, 45.0, 7000.0));
    let bwd = curve(Direction::Backward, &params(310.0, 85.0, 45.0, 7000.0));
    let drive = DriveConversion::from_axis(&twin_axis(), 1.0).unwrap();
    let p = PlacementParams::default();
    let params = Tf5200Params::new(20, Tf5200OutUnit::Ampere(0.001));
    let t = Tf5200Table::build(Some(&fwd), Some(&bwd), drive, &params, &p).unwrap();
    assert_eq!(t.entries.len(), 20);
    assert_eq!(t.scaling_factor, 1000);
    assert!(t.entries.windows(2).all(|w| w[1].in_um_s > w[0].in_um_s));
    // 9 mm/min = 150 µm/s, 900 mm/min = 15000 µm/s: inside, to the µm/s.
    assert_eq!(t.entries[0].in_um_s, 150);
    assert_eq!(t.entries[19].in_um_s, 15_000);
    // out: the mean friction's motor current in mA, rounded.
    for e in &t.entries {
        let v = e.in_um_s as f64 * 1e-6;
        let want = drive.current_a(0.5 * (fwd.magnitude_n(v) + bwd.magnitude_n(v))) * 1e3;
        assert!((e.out as f64 - want).abs() <= 0.5 + 1e-9, "{e:?} vs {want}");
    }
    // The stated error is the error of the written integers.
    let v: Vec<f64> = t.entries.iter().map(|e| e.in_um_s as f64 * 1e-6).collect();
    let y: Vec<f64> = t
        .entries
        .iter()
        .map(|e| e.out as f64 * t.n_per_unit())
        .collect();
    let (max, _) = dense_error(&t.curve, &v, &y, 200_001);
    assert!(
        (t.error.max_n - max).abs() <= 1e-3 * max,
        "{} vs {max}",
        t.error.max_n
    );
    // Against each direction: the asymmetry (25 N each way) dominates.
    assert_eq!(t.direction_errors.len(), 2);
    for (_, e) in &t.direction_errors {
        assert!((e.max_n - 25.0).abs() < 1.0, "{e:?}");
    }
    // Limits: P-COMP-00062, and a unit given inverted.
    let e = Tf5200Table::build(
        Some(&fwd),
        None,
        drive,
        &Tf5200Params::new(21, Tf5200OutUnit::Ampere(0.001)),
        &p,
    )
    .unwrap_err();
    assert!(e.to_string().contains("P-COMP-00062"), "{e}");
    let e = Tf5200Table::build(
        Some(&fwd),
        None,
        drive,
        &Tf5200Params::new(20, Tf5200OutUnit::Ampere(1000.0)),
        &p,
    )
    .unwrap_err();
    assert!(e.to_string().contains("too coarse"), "{e}");
    let mut more = Tf5200Params::new(40, Tf5200OutUnit::NewtonMetre(1e-4));
    more.max_points = 40;
    let t = Tf5200Table::build(None, Some(&bwd), drive, &more, &p).unwrap();
    assert_eq!(t.entries.len(), 40);
    assert!(t.direction_errors.is_empty());
    // 1e-4 N·m is 0.063 N: the rounding adds at most half of it to the interpolation.
    assert!(t.error.max_n < 0.1, "{:?}", t.error);
}

// ---------- SINUMERIK ----------

/// Hand-computed on the twin axis (m_t 425 kg, J 0.004 kg·m², p 10 mm: m_eq = 425 +
/// 4π²·0.004/1e-4 = 2004.137 kg), F_s 345 N and 395 N, v_s 45 mm/min, f_c 50 Hz, circle
/// r = 10 mm at 1000 mm/min:
/// ΔF = 740 N, Δv = 740/(2004.137·2π·50) = 1.17532e-3 m/s = 70.519 mm/min;
/// a = (1000/60000)²/0.01 = 0.0277778 m/s², T = 7.5e-4/0.0277778 = 0.027 s.
#[test]
fn sinumerik_start_values_by_hand() {
    let fwd = curve(Direction::Forward, &params(260.0, 85.0, 45.0, 7000.0));
    let bwd = curve(Direction::Backward, &params(310.0, 85.0, 45.0, 7000.0));
    let s = SinumerikStartValues::compute(
        Some(&fwd),
        Some(&bwd),
        &twin_axis(),
        &SinumerikParams::default(),
    )
    .unwrap();
    assert!((s.equivalent_mass_kg - 2004.1367).abs() < 1e-3);
    assert!(
        (s.breakaway_step_n - 740.0).abs() < 1e-6,
        "{}",
        s.breakaway_step_n
    );
    assert!(
        (s.const_max_mm_min - 70.519).abs() < 1e-3,
        "{}",
        s.const_max_mm_min
    );
    assert!((s.quadrant_accel_m_s2 - 0.027_777_78).abs() < 1e-8);
    assert!((s.time_s - 0.027).abs() < 1e-9, "{}", s.time_s);
    // K_p = J·ω_c = m_eq·(p/2π)²·2π·50 = 2004.137·2.533e-6·314.16 = 1.5950 N·m·s/rad
    assert!(
        (s.speed_gain_nms_per_rad - 1.5950).abs() < 1e-3,
        "{}",
        s.speed_gain_nms_per_rad
    );
    // One direction: the step is twice its breakaway friction.
    let one =
        SinumerikStartValues::compute(Some(&fwd), None, &twin_axis(), &SinumerikParams::default())
            .unwrap();
    assert!((one.breakaway_step_n - 690.0).abs() < 1e-6);
    // A Coulomb + viscous line has no breakaway friction to start from.
    let line = FrictionCurve::from_stribeck(
        Direction::Forward,
        &fit_of(&params(250.0, 0.0, 45.0, 5000.0), 10.0, 600.0, 2),
    )
    .unwrap();
    let e =
        SinumerikStartValues::compute(Some(&line), None, &twin_axis(), &SinumerikParams::default())
            .unwrap_err();
    assert!(matches!(e, CompensationError::NeedsStribeck { .. }), "{e}");
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(16))]
    /// More points never make the table worse, and twice the points make it better.
    #[test]
    fn error_decreases_with_points(
        fc in 50.0f64..600.0,
        excess in 0.0f64..200.0,
        vs in 5.0f64..200.0,
        sigma in 0.0f64..40_000.0,
        lo in 1.0f64..30.0,
        decades in 0.7f64..3.0,
    ) {
        let p = params(fc, excess, vs, sigma);
        let hi = lo * 10f64.powf(decades);
        let c = FrictionCurve::from_params(
            Direction::Forward, p, feed_mm_min_to_m_s(lo), feed_mm_min_to_m_s(hi)).unwrap();
        let pp = PlacementParams::default();
        let ns = [2usize, 3, 4, 6, 8, 12, 16, 20, 24];
        let e: Vec<f64> = ns.iter().map(|&n| place_points(&c, n, &pp).unwrap().error.max_n).collect();
        for k in 1..ns.len() {
            // The minimax level on the grid does not grow with N; the continuous max may
            // differ from it by the grid's resolution (1 %, see the test above).
            proptest::prop_assert!(e[k] <= e[k - 1] * 1.01 + 1e-9, "N={}: {} > {}", ns[k], e[k], e[k - 1]);
        }
        // Twice the points, strictly better (unless the table is already exact).
        let scale = c.magnitude_n(c.range_m_s().0);
        for (a, b) in [(2, 4), (4, 6), (6, 8)] {
            if e[a] > 1e-6 * scale {
                proptest::prop_assert!(e[b] < e[a], "N={} {} !< N={} {}", ns[b], e[b], ns[a], e[a]);
            }
        }
    }
}
