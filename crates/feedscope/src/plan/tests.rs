//! Planner rules, run-time arithmetic, limits and G-code formatting.

use super::gcode::{fixed, write_gcode, Dialect, FanucMachine, GcodeOptions};
use super::*;

fn strokes() -> StrokeTestParams {
    StrokeTestParams {
        from_mm: 0.0,
        to_mm: 410.0,
        feeds_mm_min: vec![5.0, 20.0, 80.0],
        repeats: 3,
        dwell_s: 1.0,
        accel_mm_s2: 1000.0,
    }
}

/// Paper 000's test by hand: 410 mm at 5, 20 and 80 mm/min, 3 forward/backward pairs each,
/// 1 s dwell after every stroke. With trapezoid ramps a stroke takes L/v + v/a:
/// 410/(5/60) = 4920 s plus (5/60)/1000 s; likewise 1230 s and 307.5 s. Total =
/// 6·(4920 + 1230 + 307.5) + 6·(5 + 20 + 80)/60/1000 + 18·1 = 38 763.0105 s.
#[test]
fn run_time_matches_hand_calculation() {
    let p = strokes_program(&strokes(), &Limits::default())
        .unwrap()
        .with_ramp(RampShape::Trapezoid, None)
        .unwrap();
    assert_eq!(p.moves.len(), 18);
    let hand = 6.0 * (4920.0 + 1230.0 + 307.5) + 6.0 * 105.0 / 60.0 / 1000.0 + 18.0;
    assert!((p.run_time_s() - hand).abs() < 1e-9, "{}", p.run_time_s());
    // at 72 ms: ⌊38763.0105/0.072⌋ + 1
    assert_eq!(p.expected_samples(0.072), 538_376);
    // the simulator's path of the program lasts exactly as long
    assert!((p.duration_s() - hand).abs() < 1e-6);
}

/// The default ramp is the simulator's: jerk-limited at 20 m/s³. At these feeds
/// (v ≤ 1.33 mm/s, v·j ≤ 2.7e4 mm²/s⁴ < a² = 1e6) the acceleration limit is not reached and
/// each ramp lasts t_a = 2·√(v/j), a stroke L/v + t_a: total = 6·(4920 + 1230 + 307.5)
/// \+ 12·(√(5/60/j) + √(20/60/j) + √(80/60/j)) + 18 = 38 763.1715 s, and
/// ⌊38 763.1715/0.072⌋ + 1 = 538 378 samples at 72 ms. The bell ramp takes T = 2v/a per ramp.
#[test]
fn run_time_follows_the_ramp_shape() {
    let p = strokes_program(&strokes(), &Limits::default()).unwrap();
    assert_eq!(
        (p.ramp, p.jerk_mm_s3),
        (RampShape::JerkLimited, Some(20_000.0))
    );
    let j = 20_000.0f64;
    let ramps: f64 = [5.0f64, 20.0, 80.0]
        .iter()
        .map(|f| (f / 60.0 / j).sqrt())
        .sum();
    let hand = 6.0 * (4920.0 + 1230.0 + 307.5) + 12.0 * ramps + 18.0;
    assert!(
        (p.run_time_s() - hand).abs() < 1e-9,
        "{} {hand}",
        p.run_time_s()
    );
    assert!((hand - 38_763.171_5).abs() < 1e-4, "{hand}");
    assert_eq!(p.expected_samples(0.072), 538_378);
    // with j = 5 m/s³ every feed stays below a²/j = 200 mm/s: still 2·√(v/j) per ramp
    let q = p
        .clone()
        .with_ramp(RampShape::JerkLimited, Some(5_000.0))
        .unwrap();
    let ramps5: f64 = [5.0f64, 20.0, 80.0]
        .iter()
        .map(|f| (f / 60.0 / 5_000.0).sqrt())
        .sum();
    assert!((q.run_time_s() - (hand - 12.0 * ramps + 12.0 * ramps5)).abs() < 1e-9);
    let b = p.with_ramp(RampShape::Bell, Some(5_000.0)).unwrap();
    assert_eq!(b.jerk_mm_s3, None);
    let bell = 6.0 * 2.0 * (5.0 + 20.0 + 80.0) / 60.0 / 1000.0;
    let hand_b = 6.0 * (4920.0 + 1230.0 + 307.5) + bell + 18.0;
    assert!((b.run_time_s() - hand_b).abs() < 1e-9, "{}", b.run_time_s());
    assert!(matches!(
        strokes_program(&strokes(), &Limits::default())
            .unwrap()
            .with_ramp(RampShape::JerkLimited, Some(0.0)),
        Err(PlanError::InvalidValue {
            name: "jerk_mm_s3",
            ..
        })
    ));
}

/// The simulated path of a planned program follows its ramp: for every shape the moves end
/// at their targets at rest, and the run time is the path's duration.
#[test]
fn path_follows_the_ramp_and_ends_at_the_targets() {
    let t = TriangleParams {
        window_min_mm: 20.0,
        window_max_mm: 140.0,
        feed_max_mm_min: 8000.0,
        levels: 4,
        ..TriangleParams::default()
    };
    for shape in [
        RampShape::Trapezoid,
        RampShape::JerkLimited,
        RampShape::Bell,
    ] {
        let p = triangle_program(&t, &Limits::default())
            .unwrap()
            .with_ramp(shape, None)
            .unwrap();
        assert!((p.run_time_s() - p.duration_s()).abs() < 1e-12);
        for s in p.path().strokes() {
            let k = p.kinematics(s.end_time_s);
            assert_eq!(
                k.position_m.to_bits(),
                (s.end_mm * 1e-3).to_bits(),
                "{shape:?}"
            );
            assert!(k.velocity_m_s.abs() < 1e-15);
        }
    }
}

/// A move too short to reach its feed is a triangle: 2·√(L/a).
#[test]
fn short_move_is_a_triangle() {
    let m = Move {
        from_mm: 0.0,
        to_mm: 1.0,
        feed_mm_min: 6000.0,
        dwell_s: 0.0,
    };
    // v²/a = 100²/100 = 100 mm > 1 mm
    assert!((m.motion_time_s(100.0) - 2.0 * 0.1).abs() < 1e-12);
    assert!(m.cruise_time_s(100.0).abs() < 1e-15);
}

#[test]
fn travel_limits_are_enforced_and_named() {
    let lim = Limits {
        travel_min_mm: Some(0.0),
        travel_max_mm: Some(400.0),
        feed_max_mm_min: None,
    };
    match strokes_program(&strokes(), &lim) {
        Err(PlanError::OutsideTravel {
            limit, limit_mm, ..
        }) => {
            assert_eq!(limit, "travel_max_mm");
            assert!((limit_mm - 400.0).abs() < 1e-12);
        }
        other => panic!("{other:?}"),
    }
    let mut s = strokes();
    s.to_mm = 100.0;
    s.from_mm = -1.0;
    let e = strokes_program(&s, &lim).unwrap_err();
    assert!(e.to_string().contains("travel_min_mm"), "{e}");
}

#[test]
fn feed_limit_is_enforced() {
    let lim = Limits {
        feed_max_mm_min: Some(50.0),
        ..Limits::default()
    };
    assert!(matches!(
        strokes_program(&strokes(), &lim),
        Err(PlanError::FeedTooHigh { .. })
    ));
    let t = TriangleParams {
        feed_max_mm_min: 8000.0,
        ..TriangleParams::default()
    };
    assert!(matches!(
        triangle_program(&t, &lim),
        Err(PlanError::FeedTooHigh { .. })
    ));
}

/// The planned wave stays inside its window and never exceeds the feed limit, its feeds
/// span from v_s/5 to the limit with amplitudes that do not shrink, and the simulated
/// profile stays inside the window too.
#[test]
fn triangle_respects_window_and_feed_limit() {
    let t = TriangleParams {
        window_min_mm: 20.0,
        window_max_mm: 140.0,
        feed_max_mm_min: 8000.0,
        ..TriangleParams::default()
    };
    let lim = Limits {
        travel_min_mm: Some(0.0),
        travel_max_mm: Some(410.0),
        feed_max_mm_min: Some(8000.0),
    };
    let p = triangle_program(&t, &lim).unwrap();
    let (lo, hi) = p.span_mm();
    assert!(lo >= 20.0 && hi <= 140.0, "{lo} {hi}");
    let feeds = p.feeds_mm_min();
    assert_eq!(feeds.len(), 10);
    assert!((feeds[0] - 12.0).abs() < 1e-9);
    assert!((feeds[9] - 8000.0).abs() < 1e-9);
    assert!(feeds.windows(2).all(|w| w[1] > w[0]));
    assert!(p.moves.iter().all(|m| m.feed_mm_min <= 8000.0));
    let amps: Vec<f64> = p
        .moves
        .iter()
        .filter(|m| m.to_mm > 80.0)
        .map(|m| m.to_mm - 80.0)
        .collect();
    assert!(amps.windows(2).all(|w| w[1] >= w[0]));
    // slow levels hold their 2 s cruise
    assert!(p.moves[1].cruise_time_s(t.accel_mm_s2) >= 2.0 - 1e-6);
    let mut k = 0.0;
    while k <= p.duration_s() {
        let z = p.kinematics(k);
        assert!(z.position_m * 1e3 >= 20.0 - 1e-9 && z.position_m * 1e3 <= 140.0 + 1e-9);
        assert!(z.velocity_m_s.abs() * 60_000.0 <= 8000.0 + 1e-6);
        k += 0.01;
    }
}

#[test]
fn triangle_window_too_short_for_the_feed() {
    let t = TriangleParams {
        window_min_mm: 0.0,
        window_max_mm: 10.0,
        feed_max_mm_min: 20_000.0,
        ..TriangleParams::default()
    };
    assert!(matches!(
        triangle_program(&t, &Limits::default()),
        Err(PlanError::FeedNotReachable { .. })
    ));
}

#[test]
fn fixed_decimals_never_exponent_or_negative_zero() {
    assert_eq!(fixed(1e-5, 3), "0.000");
    assert_eq!(fixed(-1e-7, 3), "0.000");
    assert_eq!(fixed(-2.5, 3), "-2.500");
    assert_eq!(fixed(12345678.9, 1), "12345678.9");
    let mut s = strokes();
    s.from_mm = 1e-5;
    s.feeds_mm_min = vec![0.123456, 1e4];
    let p = strokes_program(&s, &Limits::default()).unwrap();
    for d in [Dialect::Fanuc, Dialect::Siemens] {
        let g = write_gcode(
            &p,
            &GcodeOptions {
                dialect: d,
                ..GcodeOptions::default()
            },
        )
        .unwrap();
        for line in g.lines().filter(|l| l.starts_with('G')) {
            assert!(!line.contains('e') && !line.contains('E'), "{line}");
        }
        assert!(g.contains("G01 Z0.000 F0.1"), "{g}");
    }
}

#[test]
fn fanuc_lathe_omits_g90_mill_has_it() {
    let p = strokes_program(&strokes(), &Limits::default()).unwrap();
    let lathe = write_gcode(&p, &GcodeOptions::default()).unwrap();
    assert!(lathe.contains("\nG21 G98 G61\n") && !lathe.contains("G90"));
    assert!(lathe.contains("G04 P1000"));
    assert!(lathe.starts_with("%\nO1000 ") && lathe.ends_with("M30\n%\n"));
    let mill = write_gcode(
        &p,
        &GcodeOptions {
            fanuc_machine: FanucMachine::Mill,
            ..GcodeOptions::default()
        },
    )
    .unwrap();
    assert!(mill.contains("\nG21 G90 G94 G61\n") && !mill.contains("G98"));
    let sie = write_gcode(
        &p,
        &GcodeOptions {
            dialect: Dialect::Siemens,
            axis_letter: 'X',
            ..GcodeOptions::default()
        },
    )
    .unwrap();
    assert!(sie.contains("G4 F1.000") && sie.contains("G01 X410.000 F5.0"));
    assert!(!sie.contains('%') && sie.lines().all(|l| !l.starts_with('(')));
}

#[test]
fn bad_gcode_options_rejected() {
    let p = strokes_program(&strokes(), &Limits::default()).unwrap();
    for o in [
        GcodeOptions {
            axis_letter: 'z',
            ..GcodeOptions::default()
        },
        GcodeOptions {
            program_number: 10_000,
            ..GcodeOptions::default()
        },
        GcodeOptions {
            sample_interval_s: 0.0,
            ..GcodeOptions::default()
        },
    ] {
        assert!(matches!(
            write_gcode(&p, &o),
            Err(PlanError::InvalidValue { .. })
        ));
    }
}
