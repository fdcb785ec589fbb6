//! Analytic round trips: a known trajectory and friction, the current from the exact inverse
//! dynamics of Eq. 5, sampled asynchronously; the estimator must give the friction back.
use super::inversion::newton_in_piece;
use super::stroke::{short_of, KnotRead};
use super::*;
use crate::axis::{AxisParams, ConfigFormat};
use crate::spline::CubicSpline;
use crate::trace::Channel;
use rand::{Rng, SeedableRng};

fn axis(lead_mm: f64) -> AxisParams {
    AxisParams::parse(
        &format!(
            "lead_mm = {lead_mm}\ntable_mass_kg = 350\ninertia_kgm2 = 0.003\n\
             damping_nms_per_rad = 0.004\ntorque_constant_nm_per_a = 1.4\n"
        ),
        ConfigFormat::Toml,
        "test",
    )
    .unwrap()
}

/// Forward at v0·(1 + a·sin ωt) from z = 1 mm.
struct Motion {
    v0: f64,
    a: f64,
    w: f64,
}

impl Motion {
    fn state(&self, t: f64) -> (f64, f64, f64) {
        let z = 1e-3 + self.v0 * t + self.v0 * self.a / self.w * (1.0 - (self.w * t).cos());
        let v = self.v0 * (1.0 + self.a * (self.w * t).sin());
        let acc = self.v0 * self.a * self.w * (self.w * t).cos();
        (z, v, acc)
    }
}

/// Friction magnitude at z: mean trend + orders 0.6, 1, 3 and 8.6 of the lead.
fn friction(z: f64, lead: f64) -> f64 {
    let th = 2.0 * std::f64::consts::PI * z / lead;
    180.0
        + 4000.0 * z
        + 6.0 * (0.6 * th + 0.3).sin()
        + 8.0 * th.sin()
        + 4.0 * (3.0 * th + 1.0).sin()
        + 3.0 * (8.6 * th + 2.0).sin()
}

fn fluctuation_rms() -> f64 {
    ((36.0 + 64.0 + 16.0 + 9.0) / 2.0f64).sqrt()
}

/// Jittered sample times from `start` with mean `dt`, some dropped.
fn times(rng: &mut impl Rng, start: f64, end: f64, dt: f64, drop: f64) -> Vec<f64> {
    let mut t = start;
    let mut v = Vec::new();
    while t < end {
        if rng.random::<f64>() >= drop {
            v.push(t);
        }
        t += dt * (1.0 + 0.03 * (rng.random::<f64>() - 0.5));
    }
    v
}

fn trace(lead_mm: f64, m: &Motion, dt: f64, duration: f64, seed: u64) -> (Trace, AxisParams) {
    let ax = axis(lead_mm);
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let tz = times(&mut rng, 0.0, duration, dt, 0.05);
    // The current channel starts later and runs on its own clock.
    let ti = times(&mut rng, 0.031, duration, dt * 1.01, 0.05);
    let gain = ax.force_per_torque_n_per_nm() * ax.torque_constant_nm_per_a;
    let pos = Channel {
        value: tz.iter().map(|&t| m.state(t).0).collect(),
        time_s: tz,
    };
    let cur = Channel {
        value: ti
            .iter()
            .map(|&t| {
                let (z, v, a) = m.state(t);
                (ax.equivalent_mass_kg() * a
                    + ax.equivalent_damping_n_s_per_m() * v
                    + friction(z, ax.lead_m()))
                    / gain
            })
            .collect(),
        time_s: ti,
    };
    (
        Trace {
            position_m: pos,
            effort: cur,
            effort_kind: EffortKind::CurrentA,
            facts: Default::default(),
        },
        ax,
    )
}

/// RMS of (estimate − truth) over points at least 2 mm from the stroke ends.
fn rms_error(s: &StrokeFriction, lead: f64) -> f64 {
    let (z0, z1) = (s.position_m[0], s.position_m[s.position_m.len() - 1]);
    let (lo, hi) = (z0.min(z1) + 2e-3, z0.max(z1) - 2e-3);
    let (mut se, mut n) = (0.0, 0);
    for (z, f) in s.position_m.iter().zip(&s.friction_n) {
        if *z >= lo && *z <= hi {
            se += (f - friction(*z, lead)).powi(2);
            n += 1;
        }
    }
    (se / n as f64).sqrt()
}

#[test]
fn modulated_feed_async_channels_lead_5mm() {
    // 60 mm/min ± 30 % at 0.5 Hz: inertia force m_eq·a ≈ 5.1e3 kg · 9.4e-4 m/s² ≈ 4.8 N peak.
    let m = Motion {
        v0: 1e-3,
        a: 0.3,
        w: 2.0 * std::f64::consts::PI * 0.5,
    };
    let (tr, ax) = trace(5.0, &m, 0.05, 60.0, 7);
    let est = estimate(&tr, &ax, &EstimateParams::default()).unwrap();
    assert_eq!(est.strokes.len(), 1);
    let s = &est.strokes[0];
    let err = rms_error(s, ax.lead_m());
    // Noise-free: within 2 % of the fluctuation RMS.
    eprintln!(
        "modulated feed, lead 5 mm: rms error {err:.4} N of {:.2} N",
        fluctuation_rms()
    );
    assert!(err < 0.02 * fluctuation_rms(), "rms error {err} N");
    // Position grid: absolute multiples of p/1024.
    let step = ax.lead_m() / 1024.0;
    for z in s.position_m.iter().take(50) {
        assert!(((z / step) - (z / step).round()).abs() < 1e-6);
    }
    // Without the inertia term the error would be large: the test does see inertia.
    let naive: f64 = s
        .friction_n
        .iter()
        .zip(&s.accel_m_s2)
        .map(|(f, a)| (f + ax.equivalent_mass_kg() * a) - f)
        .map(|d| d * d)
        .sum::<f64>()
        / s.friction_n.len() as f64;
    assert!(naive.sqrt() > 3.0, "inertia RMS {}", naive.sqrt());
}

#[test]
fn knot_spline_time_of_position_is_close_too() {
    let m = Motion {
        v0: 2e-3,
        a: 0.0,
        w: 1.0,
    };
    let (tr, ax) = trace(10.0, &m, 0.072, 40.0, 3);
    let p = EstimateParams {
        time_of_position: TimeOfPosition::KnotSpline,
        ..EstimateParams::default()
    };
    let est = estimate(&tr, &ax, &p).unwrap();
    let err = rms_error(&est.strokes[0], ax.lead_m());
    eprintln!("knot-spline t(z): rms error {err:.4} N");
    assert!(err < 0.05 * fluctuation_rms(), "rms error {err} N");
}

#[test]
fn inversion_is_exact() {
    let m = Motion {
        v0: 2e-3,
        a: 0.2,
        w: 1.3,
    };
    let (tr, ax) = trace(10.0, &m, 0.072, 20.0, 5);
    let est = estimate(&tr, &ax, &EstimateParams::default()).unwrap();
    let s = &est.strokes[0];
    // z(t(Z)) = Z on the spline; against the true motion the spline error is a few nm.
    for (z, t) in s.position_m.iter().zip(&s.time_s) {
        assert!((m.state(*t).0 - z).abs() < 5e-9, "{z} at {t}");
    }
}

#[test]
fn strokes_without_effort_samples_are_named_as_such() {
    // A steady forward stroke, but the current was logged only before it started.
    let m = Motion {
        v0: 0.01,
        a: 0.0,
        w: 1.0,
    };
    let tz: Vec<f64> = (0..2000).map(|k| k as f64 * 1e-3).collect();
    let zz: Vec<f64> = tz.iter().map(|&t| m.state(t).0).collect();
    let te: Vec<f64> = (0..6).map(|k| -1.0 + k as f64 * 0.1).collect();
    let trace = Trace {
        position_m: Channel {
            time_s: tz,
            value: zz,
        },
        effort: Channel {
            value: vec![1.0; te.len()],
            time_s: te,
        },
        effort_kind: EffortKind::CurrentA,
        facts: Default::default(),
    };
    let err = estimate(&trace, &axis(10.0), &EstimateParams::default()).unwrap_err();
    assert!(
        matches!(
            err,
            EstimateError::NoEffortInStrokes {
                strokes: 1,
                min_samples: 4
            }
        ),
        "{err}"
    );
    assert!(
        err.to_string().contains("1 steady stroke(s) found"),
        "{err}"
    );
}

/// Found by fuzzing: positions ×1e5 (or a lead of 1e-5 mm) made an 81 KB trace allocate
/// ~16 GB. The grid is bounded before allocation and the error names the stroke and the cause.
#[test]
fn a_grid_far_beyond_the_samples_is_an_error() {
    let m = Motion {
        v0: 1e-3,
        a: 0.0,
        w: 1.0,
    };
    let (tr, ax) = trace(5.0, &m, 0.05, 30.0, 3);
    // The same trace is fine at its true lead...
    assert!(estimate(&tr, &ax, &EstimateParams::default()).is_ok());
    // ...and at a lead of 1e-5 mm its 30 mm stroke would be 3e9 points. (An axis file refuses
    // such a lead; the grid bound still guards callers of the library.)
    let mut tiny = axis(1.0);
    tiny.lead_mm = 1e-5;
    match estimate(&tr, &tiny, &EstimateParams::default()) {
        Err(EstimateError::GridTooLarge {
            points,
            limit,
            samples,
            ..
        }) => {
            assert!(points > 1e9, "{points}");
            assert_eq!(limit, MAX_GRID_POINTS_FLOOR.max(4096 * samples));
        }
        other => panic!("{other:?}"),
    }
    let msg = estimate(&tr, &tiny, &EstimateParams::default())
        .unwrap_err()
        .to_string();
    assert!(msg.contains("lead_mm") && msg.contains("stroke 0"), "{msg}");
}

/// t(z) inside one piece is solved to the stated tolerance, not just stepped once: a curved
/// piece (slope 1 to 1.225, as a ramp's), where the linear start is 1e-2 off and one chord
/// step still 1e-3. (A piece whose slope varies several-fold is left to `invert_in`.)
#[test]
fn newton_in_piece_converges_to_tolerance() {
    let p = crate::spline::Piece {
        x0: 2.0,
        h: 0.5,
        c0: 1.0,
        c1: 1.0,
        c2: 0.3,
        c3: -0.1,
    };
    let z1 = p.eval(p.h).0;
    for k in 1..20 {
        let target = p.c0 + (z1 - p.c0) * k as f64 / 20.0;
        let (u, d1, d2) = newton_in_piece(&p, z1, target).expect("monotone piece");
        let (z, d1_at, d2_at) = p.eval(u);
        // Steps stop below 1e-13 of the interval (slope ≈ 1), plus rounding.
        assert!((z - target).abs() < 1e-12, "k {k}: z {z} target {target}");
        assert_eq!((d1, d2), (d1_at, d2_at));
    }
}

/// The position spline's search ahead over a slice stops where stepping a knot at a time
/// stops, on values that go back and forth (a noisy spline), in either direction and at
/// either limit.
#[test]
fn advance_stops_where_the_walk_a_knot_at_a_time_stops() {
    let mut rng = rand::rngs::StdRng::seed_from_u64(0xadu64);
    let x: Vec<f64> = (0..400).map(|k| k as f64 * 1e-3).collect();
    let y: Vec<f64> = x
        .iter()
        .map(|&t| t + 3e-3 * (rng.random::<f64>() - 0.5))
        .collect();
    let m = vec![0.0; x.len()];
    let mut s = CubicSpline::from_moments(&x, &y, m).unwrap();
    let last = x.len() - 2;
    fn stepwise<const FORWARD: bool>(y: &[f64], mut k: usize, limit: usize, zg: f64) -> usize {
        while k < limit && short_of::<FORWARD>(y[k + 1], zg) {
            k += 1;
        }
        k
    }
    for _ in 0..2000 {
        let k = rng.random_range(0..=last);
        let limit = rng.random_range(k..=last);
        let zg = rng.random_range(-0.01..0.41);
        assert_eq!(
            s.advance::<true>(k, limit, zg),
            stepwise::<true>(&y, k, limit, zg)
        );
        assert_eq!(
            s.advance::<false>(k, limit, zg),
            stepwise::<false>(&y, k, limit, zg)
        );
    }
}

/// A stroke solved in windows of 2,000 knots and handed out in pieces of 3,000 rows equals
/// the whole solve held at once: every column to 1e-9 of its scale, the summary likewise,
/// with the interpolating spline (exact positions) and with the smoother (1 µm quanta).
#[test]
fn a_long_stroke_in_windows_and_pieces_equals_the_whole_solve() {
    let m = Motion {
        v0: 1e-3,
        a: 0.3,
        w: 2.0 * std::f64::consts::PI * 0.5,
    };
    for quantum_m in [0.0, 1e-6] {
        let (mut tr, ax) = trace(5.0, &m, 0.002, 60.0, 11);
        if quantum_m > 0.0 {
            for z in &mut tr.position_m.value {
                *z = (*z / quantum_m).round() * quantum_m;
            }
        }
        let whole = estimate(&tr, &ax, &EstimateParams::default()).unwrap();
        let small = EstimateParams {
            spline_window_knots: 2_000,
            piece_points: 3_000,
            ..EstimateParams::default()
        };
        let mut pieces = 0;
        let mut ends = Vec::new();
        let mut joined: Option<StrokeFriction> = None;
        estimate_pieces_streaming(
            &tr,
            &ax,
            &small,
            4,
            |s| s,
            |p| -> Result<(), EstimateError> {
                match p {
                    StrokePiece::Rows(s) => {
                        pieces += 1;
                        match &mut joined {
                            Some(j) => j.append_rows(s),
                            None => joined = Some(s),
                        }
                    }
                    StrokePiece::End(summary) => ends.push(*summary),
                }
                Ok(())
            },
        )
        .unwrap();
        assert_eq!(whole.strokes.len(), 1);
        assert_eq!(ends.len(), 1);
        let (w, j) = (&whole.strokes[0], joined.unwrap());
        assert!(pieces > 3, "{pieces} pieces: the stroke was not cut");
        assert_eq!(
            w.summary.position_cutoff_hz.is_some(),
            quantum_m > 0.0,
            "the smoother runs on quantised positions only"
        );
        let close = |a: &[f64], b: &[f64], what: &str| {
            assert_eq!(a.len(), b.len(), "{what}");
            let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let worst = a
                .iter()
                .zip(b)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max);
            assert!(
                worst <= 1e-9 * scale,
                "quantum {quantum_m}: {what} differs by {worst:e} of {scale:e}"
            );
        };
        close(&w.position_m, &j.position_m, "position");
        close(&w.time_s, &j.time_s, "time");
        close(&w.velocity_m_s, &j.velocity_m_s, "velocity");
        close(&w.accel_m_s2, &j.accel_m_s2, "acceleration");
        close(&w.effort, &j.effort, "effort");
        close(&w.friction_n, &j.friction_n, "friction");
        let (a, b) = (&w.summary, &ends[0]);
        assert_eq!(a.points, b.points);
        for (x, y, what) in [
            (a.mean_friction_n, b.mean_friction_n, "mean"),
            (a.friction_std_n, b.friction_std_n, "std"),
            (a.start_mm, b.start_mm, "start"),
            (a.end_mm, b.end_mm, "end"),
            (a.end_time_s, b.end_time_s, "end time"),
        ] {
            assert!(
                (x - y).abs() <= 1e-9 * x.abs().max(1.0),
                "{what}: {x} vs {y}"
            );
        }
        // The joined stroke through `estimate_map_streaming` is the same stroke.
        let mut via_map = Vec::new();
        estimate_map_streaming(
            &tr,
            &ax,
            &small,
            4,
            |s| s,
            |s| -> Result<(), EstimateError> {
                via_map.push(s);
                Ok(())
            },
        )
        .unwrap();
        assert_eq!(via_map[0].summary, *b);
        close(&via_map[0].friction_n, &w.friction_n, "friction via map");
    }
}
