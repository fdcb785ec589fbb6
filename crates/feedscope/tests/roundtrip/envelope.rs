//! Issue 30 proof: `estimate` and the mean profile over the motion real controls make —
//! trapezoid, jerk-limited and bell ramps, a feed override turned during a stroke, servo lag —
//! sampled from 8 kHz synchronous to 70 ms polling, current or torque, feeds 5-15,000 mm/min,
//! on a drive unlike any paper's (lead 20 mm, 350 kg, Fc 260 N).
//!
//! Criteria on every stroke: one stroke per direction; the stroke mean within 1 % of the
//! truth (plus 3 standard errors); and, where the estimator says it resolves every true
//! component (its `max_order` above the highest true order), RMS error along the travel below
//! max(10 % of the true fluctuation's RMS, 1.5 × its own predicted noise floor). Where it does
//! not, it must say so: its `max_order` is below the truth's highest order. Under an override
//! every change of it is listed (`feed-change-unresolved`) and the bound holds away from them;
//! on a quiet drive (floor a few % of the fluctuation) it is 10 % with no allowance for noise.
use feedscope::diag::Code;
use feedscope::estimate::{estimate, Direction, EstimateParams};
use feedscope::sim::{FeedOverride, RampShape, SamplingMode, SimConfig, StrokeConfig};
use feedscope::trace::EffortKind;
use rayon::prelude::*;

use crate::util::*;

#[derive(Debug, Clone, Copy)]
enum Sampling {
    Synchronous { rate_hz: f64, quantum_mm: f64 },
    Polled { interval_ms: f64 },
}

fn drive(ramp: RampShape, sampling: Sampling, effort: EffortKind, feed_mm_min: f64) -> SimConfig {
    let mut c = SimConfig {
        seed: 77,
        ..SimConfig::default()
    };
    c.axis.lead_mm = 20.0;
    c.axis.table_mass_kg = 350.0;
    c.axis.inertia_kgm2 = 0.004;
    c.axis.torque_constant_nm_per_a = 1.6;
    c.axis.travel_min_mm = Some(0.0);
    c.axis.travel_max_mm = Some(600.0);
    let mut f = feedscope::sim::FrictionParams::default_for(&c.axis);
    f.forward.offset_n = 260.0;
    f.backward.offset_n = 250.0;
    c.friction = Some(f);
    c.motion.ramp = ramp;
    c.motion.acceleration_mm_s2 = 2000.0;
    // 20 m/s³: the S-curve's ramps reach a_max only above 12,000 mm/min
    c.motion.jerk_mm_s3 = Some(20_000.0);
    // travel for about 5 s of stroke, at least 8 mm and at most 500 mm
    let travel = (feed_mm_min / 60.0 * 5.0).clamp(8.0, 500.0);
    c.motion.start_mm = 40.0;
    c.motion.strokes = vec![
        StrokeConfig {
            to_mm: 40.0 + travel,
            feed_mm_min,
            dwell_s: 0.5,
        },
        StrokeConfig {
            to_mm: 40.0,
            feed_mm_min,
            dwell_s: 0.0,
        },
    ];
    c.sampling.effort_kind = effort;
    match sampling {
        Sampling::Synchronous {
            rate_hz,
            quantum_mm,
        } => {
            c.sampling.mode = SamplingMode::Synchronous;
            c.sampling.synchronous_rate_hz = rate_hz;
            c.sampling.position.quantum_mm = quantum_mm;
        }
        Sampling::Polled { interval_ms } => {
            c.sampling.mode = SamplingMode::Asynchronous;
            c.sampling.position.interval_ms = interval_ms;
            c.sampling.effort.interval_ms = interval_ms;
            c.sampling.position.quantum_mm = 1e-3;
        }
    }
    c
}

/// Highest order of the true fluctuation (cycles per lead).
fn top_order(c: &SimConfig) -> f64 {
    c.friction
        .as_ref()
        .unwrap()
        .components
        .iter()
        .map(|k| k.order)
        .fold(0.0, f64::max)
}

/// Check one case; `Err` names what failed.
fn check(label: &str, c: &SimConfig) -> Result<String, String> {
    let out = run(c);
    let est = estimate(&out.trace, &out.truth.axis, &EstimateParams::default())
        .map_err(|e| format!("{label}: {e}"))?;
    if est.strokes.len() != 2 {
        return Err(format!("{label}: {} strokes", est.strokes.len()));
    }
    let mut line = String::new();
    for (s, dir) in est
        .strokes
        .iter()
        .zip([Direction::Forward, Direction::Backward])
    {
        if s.summary.direction != dir {
            return Err(format!("{label}: stroke directions"));
        }
        let e = errors(&out, s);
        let mean_tol = 0.01 * e.mean_abs_n() + 3.0 * s.summary.mean_friction_se_n.unwrap_or(0.0);
        let floor = s.summary.noise_floor.total_n;
        let resolved = s.summary.max_order > top_order(c);
        line.push_str(&format!(
            " {dir:?}: mean {:+.2} %, rms {:.2} N (fluct {:.2} N, floor {:.2} N, max order \
             {:.1}{})",
            100.0 * e.mean_rel,
            e.rms_n,
            e.fluctuation_rms_n,
            floor,
            s.summary.max_order,
            if resolved { "" } else { ", not all resolved" }
        ));
        if (e.mean_rel * e.mean_abs_n()).abs() > mean_tol {
            return Err(format!("{label}: mean {e:?}"));
        }
        if resolved && e.rms_n > (0.10 * e.fluctuation_rms_n).max(1.5 * floor) {
            return Err(format!("{label}: rms {e:?}, floor {floor}"));
        }
    }
    Ok(format!("{label}:{line}"))
}

#[test]
fn estimate_over_ramp_shapes_sampling_effort_and_feeds() {
    let ramps = [
        ("trapezoid", RampShape::Trapezoid),
        ("jerk-limited", RampShape::JerkLimited),
        ("bell", RampShape::Bell),
    ];
    let samplings = [
        (
            "8 kHz",
            Sampling::Synchronous {
                rate_hz: 8000.0,
                quantum_mm: 1e-4,
            },
        ),
        (
            "1 kHz",
            Sampling::Synchronous {
                rate_hz: 1000.0,
                quantum_mm: 1e-4,
            },
        ),
        (
            "83 Hz",
            Sampling::Synchronous {
                rate_hz: 83.33,
                quantum_mm: 1e-3,
            },
        ),
        ("70 ms", Sampling::Polled { interval_ms: 70.0 }),
    ];
    let feeds = [5.0, 60.0, 1000.0, 15_000.0];
    let mut cases = Vec::new();
    for (i, (rn, r)) in ramps.iter().enumerate() {
        for (j, (sn, s)) in samplings.iter().enumerate() {
            for (k, f) in feeds.iter().enumerate() {
                let effort = if (i + j + k) % 2 == 0 {
                    EffortKind::CurrentA
                } else {
                    EffortKind::TorqueNm
                };
                // 70 ms polling of a 15 m/min stroke: 2 samples per lead, nothing to resolve
                // and no steady stroke to find; paper 000's logger is for slow idle strokes
                if matches!(s, Sampling::Polled { .. }) && *f > 1000.0 {
                    continue;
                }
                cases.push((
                    format!("{rn} {sn} {f} mm/min {effort:?}"),
                    drive(*r, *s, effort, *f),
                ));
            }
        }
    }
    let results: Vec<_> = cases.par_iter().map(|(l, c)| check(l, c)).collect();
    let mut failures = Vec::new();
    for r in results {
        match r {
            Ok(line) => eprintln!("{line}"),
            Err(e) => failures.push(e),
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// The feed override turned during the strokes (100 → 45 → 120 %), bell ramps, servo lag
/// without velocity feed-forward (the table trails the command by v/K_v): still one stroke
/// per direction covering at least 95 % of the travel, friction within 10 % of the
/// fluctuation's RMS or 1.5 × the estimator's predicted noise floor, whichever is larger.
#[test]
fn override_turned_during_the_strokes_keeps_one_stroke() {
    override_case(false);
}

/// Effort noise and quanta a quarter of the default's (a torque read at 16 bits), so that the
/// floor is a few percent of the fluctuation: what is left is the estimator's own error.
fn quieten(c: &mut SimConfig) {
    let e = &mut c.sampling.effort;
    e.current_noise_std_a /= 4.0;
    e.current_quantum_a /= 4.0;
    e.torque_noise_std_nm /= 4.0;
    e.torque_quantum_nm /= 4.0;
}

/// The override and the modulated feed on a quiet drive: where the noise floor is small, the
/// friction is within 10 % of the fluctuation's RMS without any allowance for the floor (the
/// issue's criterion); the matrix's allowance is for noise, not for the varying feed.
#[test]
fn quiet_drive_override_and_modulation_within_10_percent() {
    override_case(true);
    modulated_case(true);
}

/// The bound of the RMS error (N): 10 % of the fluctuation, and on a noisy drive at least
/// 1.5 × the estimator's own floor.
fn bound_n(quiet: bool, fluctuation_rms_n: f64, floor_n: f64) -> f64 {
    if quiet {
        0.10 * fluctuation_rms_n
    } else {
        (0.10 * fluctuation_rms_n).max(1.5 * floor_n)
    }
}

/// The positions (mm) a stroke's `feed-change-unresolved` warning lists.
fn unresolved_feed_changes_mm(s: &feedscope::estimate::StrokeFriction) -> Vec<f64> {
    let Some(w) = s
        .summary
        .warnings
        .iter()
        .find(|w| w.code == Code::FeedChangeUnresolved)
    else {
        return Vec::new();
    };
    w.message
        .split(" mm (")
        .filter_map(|head| head.rsplit([' ', ',']).next()?.parse::<f64>().ok())
        .collect()
}

/// Where the twin's table was when an override change of the schedule was made, inside the
/// stroke's output range (mm, in the order of travel).
fn override_positions_mm(
    c: &SimConfig,
    out: &feedscope::sim::SimOutput,
    s: &feedscope::estimate::StrokeFriction,
) -> Vec<f64> {
    let pos = &out.trace.position_m;
    let (t0, t1) = (s.summary.start_time_s, s.summary.end_time_s);
    c.motion
        .overrides
        .iter()
        .filter(|o| o.at_s > t0 && o.at_s < t1)
        .map(|o| {
            let k = pos.time_s.partition_point(|&t| t < o.at_s);
            pos.value[k] * 1e3
        })
        .collect()
}

/// [`errors`] over the points farther than `reach_mm` from every one of `changes_mm`.
fn errors_away_from(
    out: &feedscope::sim::SimOutput,
    s: &feedscope::estimate::StrokeFriction,
    changes_mm: &[f64],
    reach_mm: f64,
) -> Errors {
    let model = &out.truth.friction;
    let (mut se, mut sf, mut n) = (0.0, 0.0, 0.0);
    for j in inner(s, 2.0) {
        let (z, v) = (s.position_m[j], s.velocity_m_s[j]);
        if changes_mm.iter().any(|c| (z * 1e3 - c).abs() < reach_mm) {
            continue;
        }
        se += (s.friction_n[j] - model.friction_n(z, v)).powi(2);
        sf += model.fluctuation_n(s.summary.direction, z).powi(2);
        n += 1.0;
    }
    Errors {
        rms_n: (se / n).sqrt(),
        fluctuation_rms_n: (sf / n).sqrt(),
        mean_rel: 0.0,
        mean_truth_n: 0.0,
    }
}

fn override_case(quiet: bool) {
    let mut c = drive(
        RampShape::Bell,
        Sampling::Synchronous {
            rate_hz: 1000.0,
            quantum_mm: 1e-4,
        },
        EffortKind::CurrentA,
        600.0,
    );
    c.motion.strokes[0].to_mm = 140.0;
    c.dynamics.velocity_feedforward = 0.0;
    c.motion.overrides = vec![
        FeedOverride {
            at_s: 3.0,
            percent: 45.0,
        },
        FeedOverride {
            at_s: 8.0,
            percent: 120.0,
        },
        FeedOverride {
            at_s: 14.0,
            percent: 100.0,
        },
        FeedOverride {
            at_s: 18.0,
            percent: 60.0,
        },
    ];
    if quiet {
        quieten(&mut c);
    }
    let out = run(&c);
    let est = est(&out);
    assert_eq!(est.strokes.len(), 2, "{:#?}", est.zones);
    for s in &est.strokes {
        let e = errors(&out, s);
        eprintln!(
            "override{} {:?}: {:.1} mm of 100, rms {:.2} N of {:.2} N (floor {:.2} N), mean {:+.2} %",
            if quiet { " (quiet)" } else { "" },
            s.summary.direction,
            s.summary.length_mm,
            e.rms_n,
            e.fluctuation_rms_n,
            s.summary.noise_floor.total_n,
            100.0 * e.mean_rel
        );
        assert!(s.summary.length_mm >= 95.0, "{:?}", s.summary);
        // the feed range says the feed was not one: from the turned-down to the turned-up part
        let (lo, hi) = (
            s.summary.feed_min_mm_min.unwrap(),
            s.summary.feed_max_mm_min.unwrap(),
        );
        assert!(
            lo < 0.8 * s.summary.feed_mm_min && hi > 1.1 * s.summary.feed_mm_min,
            "{lo} {hi}"
        );
        // Each override change is a step of the feed within a few ms, faster than the
        // position cut-off: the stroke says where, and away from there the friction holds
        // the bound (10 % of the fluctuation, on the noisy drive at least 1.5 × the floor).
        let changes = unresolved_feed_changes_mm(s);
        let expected = override_positions_mm(&c, &out, s);
        assert_eq!(changes.len(), expected.len(), "{changes:?} vs {expected:?}");
        for (got, want) in changes.iter().zip(&expected) {
            assert!((got - want).abs() < 1.0, "{changes:?} vs {expected:?}");
        }
        let reach_mm = 2.0 * s.summary.feed_mm_min / 60.0 / s.summary.position_cutoff_hz.unwrap();
        let e = errors_away_from(&out, s, &changes, reach_mm);
        let floor = s.summary.noise_floor.total_n;
        eprintln!(
            "  away from the {} changes (±{reach_mm:.2} mm): rms {:.2} N of {:.2} N",
            changes.len(),
            e.rms_n,
            e.fluctuation_rms_n
        );
        assert!(
            e.rms_n < bound_n(quiet, e.fluctuation_rms_n, floor),
            "quiet {quiet}: {e:?}, floor {floor}"
        );
    }
}

/// The case of issue 30: a feed modulated by ±60 % around 60 mm/min with a 1.5 s period (the
/// table never stops), jerk-limited ramps, 83 Hz current with 1 µm quanta and 1 kHz torque with
/// 0.1 µm: one stroke per direction covering ≥ 95 % of the travel, friction within 10 % of the
/// fluctuation's RMS or 1.5 × the noise floor, and the feed range reported.
#[test]
fn modulated_feed_is_one_stroke_per_direction() {
    modulated_case(false);
}

fn modulated_case(quiet: bool) {
    for (rate_hz, quantum_mm, effort) in [
        (83.33, 1e-3, EffortKind::CurrentA),
        (1000.0, 1e-4, EffortKind::TorqueNm),
    ] {
        let mut c = drive(
            RampShape::JerkLimited,
            Sampling::Synchronous {
                rate_hz,
                quantum_mm,
            },
            effort,
            60.0,
        );
        c.motion.strokes[0].to_mm = 70.0;
        c.motion.modulation = Some(feedscope::sim::FeedModulation {
            relative_amplitude: 0.6,
            period_s: 1.5,
        });
        if quiet {
            quieten(&mut c);
        }
        let out = run(&c);
        let est = est(&out);
        assert_eq!(est.strokes.len(), 2, "{rate_hz} Hz: {:#?}", est.zones);
        for s in &est.strokes {
            let e = errors(&out, s);
            let floor = s.summary.noise_floor.total_n;
            let (lo, hi) = (
                s.summary.feed_min_mm_min.unwrap(),
                s.summary.feed_max_mm_min.unwrap(),
            );
            eprintln!(
                "modulated{} {rate_hz} Hz {:?}: {:.1} mm of 30, feed {:.0} ({lo:.0}-{hi:.0}) \
                 mm/min, rms {:.2} N of {:.2} N (floor {floor:.2} N)",
                if quiet { " (quiet)" } else { "" },
                s.summary.direction,
                s.summary.length_mm,
                s.summary.feed_mm_min,
                e.rms_n,
                e.fluctuation_rms_n,
            );
            assert!(s.summary.length_mm >= 0.95 * 30.0, "{:?}", s.summary);
            assert!(lo < 40.0 && hi > 80.0, "feed range {lo}-{hi}");
            assert!(
                e.rms_n < bound_n(quiet, e.fluctuation_rms_n, floor),
                "quiet {quiet}: {e:?}, floor {floor}"
            );
        }
    }
}
