//! Will a planned triangular-wave test identify J at the acquisition's sampling interval?
//!
//! The answer comes from running the test: the twin ([`crate::sim`], servo mode, default
//! drive) follows the planned path and is sampled at the interval the acquisition will use,
//! and [`crate::ident::identify`] is run on that trace. Its row selection (acceleration rows
//! clear of reversals and of the acceleration's steps, paper 002 Eq. 9-10) depends on the
//! ramps and the interval, hardly on the drive, so a refusal there predicts a refusal on the
//! machine. The twin is sampled synchronously and without noise, the kindest case: a test
//! that fails here fails on any acquisition at that interval.

use crate::ident::{identify, IdentError, IdentParams};
use crate::sim::{simulate_profile, DynamicsMode, SamplingMode, SimConfig};

use super::{TestKind, TestProgram};

/// Above this many predicted samples the check is skipped (its run would take seconds): at
/// such rates every ramp spans hundreds of samples.
const MAX_CHECK_SAMPLES: f64 = 2e6;

/// A relative standard error of J above this is reported as weak.
const WEAK_J_RELATIVE_SE: f64 = 0.1;

/// What the identification of the planned test would give at `interval_s`.
#[derive(Debug, Clone, PartialEq)]
pub enum Identifiability {
    /// The twin's trace identifies J with a relative standard error of `j_relative_se`.
    Identified {
        /// σ(J)/J from the twin's run.
        j_relative_se: f64,
        /// Rows the fit used.
        rows_used: usize,
    },
    /// [`identify`] refuses the twin's trace; `reason` is its text.
    Refused {
        /// Why, as `identify` says it.
        reason: String,
    },
    /// Not checked: not a triangular-wave test, or too many samples to check quickly.
    NotChecked,
}

impl Identifiability {
    /// A warning for the user, `None` when the test identifies J well.
    pub fn warning(&self, interval_s: f64) -> Option<String> {
        let at = format!(
            "at {:.3} ms per sample ({:.1} Hz)",
            interval_s * 1e3,
            1.0 / interval_s
        );
        match self {
            Self::Identified {
                j_relative_se,
                rows_used,
            } if *j_relative_se > WEAK_J_RELATIVE_SE => Some(format!(
                "{at} this test identifies the inertia J only roughly: on the twin, its \
                 standard error is {:.0} % of J ({rows_used} rows used)",
                100.0 * j_relative_se
            )),
            Self::Refused { reason } => Some(format!(
                "{at} this test cannot be identified: on the twin, `feedscope identify` \
                 refuses it: {reason}"
            )),
            _ => None,
        }
    }
}

/// The warning for the planned test `prog` sampled every `interval_s`, `None` when the twin
/// identifies J well at that interval. When it does not, the warning names the lowest rate
/// (searched by doubling, then bisection, up to 8 kHz) at which the twin identifies J with a
/// standard error within a tenth of J.
pub fn identifiability_warning(prog: &TestProgram, interval_s: f64) -> Option<String> {
    let w = identifiability(prog, interval_s).warning(interval_s)?;
    let good = |rate_hz: f64| {
        matches!(identifiability(prog, 1.0 / rate_hz),
            Identifiability::Identified { j_relative_se, .. } if j_relative_se <= WEAK_J_RELATIVE_SE)
    };
    let (mut lo, mut hi) = (1.0 / interval_s, None);
    let mut rate = 2.0 * lo;
    while rate <= MAX_SEARCH_RATE_HZ {
        if good(rate) {
            hi = Some(rate);
            break;
        }
        lo = rate;
        rate *= 2.0;
    }
    let Some(mut hi) = hi else {
        return Some(format!(
            "{w}; on the twin, sampling up to {MAX_SEARCH_RATE_HZ:.0} Hz does not help: plan \
             gentler ramps (a lower --accel-mm-s2 set in the control) or more reversals"
        ));
    };
    for _ in 0..4 {
        let mid = 0.5 * (lo + hi);
        if good(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Some(format!(
        "{w}; on the twin, this test identifies J from about {:.0} Hz ({:.1} ms per sample)",
        hi.ceil(),
        1e3 / hi.ceil()
    ))
}

/// Highest rate the search of [`identifiability_warning`] tries (Hz): a fast servo trace.
const MAX_SEARCH_RATE_HZ: f64 = 8000.0;

/// Run the planned triangular-wave test `prog` on the twin sampled every `interval_s` and
/// identify it (paper 002 Eq. 9-10). Other tests, and runs of more than 2·10⁶ samples, are
/// [`Identifiability::NotChecked`].
pub fn identifiability(prog: &TestProgram, interval_s: f64) -> Identifiability {
    if prog.kind != TestKind::Triangle
        || !(interval_s.is_finite() && interval_s > 0.0)
        || prog.run_time_s() / interval_s > MAX_CHECK_SAMPLES
    {
        return Identifiability::NotChecked;
    }
    let mut cfg = SimConfig::default();
    cfg.dynamics.mode = DynamicsMode::Servo;
    cfg.sampling.mode = SamplingMode::Synchronous;
    cfg.sampling.synchronous_rate_hz = 1.0 / interval_s;
    cfg.sampling.position.noise_std_mm = 0.0;
    cfg.sampling.effort.current_noise_std_a = 0.0;
    cfg.sampling.effort.torque_noise_std_nm = 0.0;
    // The truth is not used: one record per sample keeps the run small.
    cfg.truth.interval_ms = (interval_s * 1e3).max(1.0);
    // The default drive's loop and travel must hold the planned path: open the travel.
    cfg.axis.travel_min_mm = None;
    cfg.axis.travel_max_mm = None;
    let out = match simulate_profile(&cfg, prog, &mut |_| {}) {
        Ok(o) => o,
        // The twin cannot run it (a path the default drive cannot follow): say nothing
        // rather than guess.
        Err(_) => return Identifiability::NotChecked,
    };
    match identify(&out.trace, &cfg.axis, &IdentParams::default()) {
        Ok(id) => Identifiability::Identified {
            j_relative_se: (id.fit.std_error.j_total_kgm2 / id.fit.j_total_kgm2).abs(),
            rows_used: id.fit.samples_used,
        },
        Err(IdentError::NotIdentifiable { reason }) => Identifiability::Refused { reason },
        Err(_) => Identifiability::NotChecked,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::{
        strokes_program, triangle_program, Limits, StrokeTestParams, TriangleParams,
    };
    use crate::sim::RampShape;

    fn triangle(shape: RampShape) -> TestProgram {
        let t = TriangleParams {
            window_min_mm: 20.0,
            window_max_mm: 140.0,
            feed_max_mm_min: 4000.0,
            ..TriangleParams::default()
        };
        triangle_program(&t, &Limits::default())
            .unwrap()
            .with_ramp(shape, None)
            .unwrap()
    }

    /// Every ramp shape: polled at 72 ms the ramps of 1000 mm/s² span one or two samples and
    /// `identify` refuses; at 1 kHz J comes out within a few per cent of its standard error.
    #[test]
    fn slow_polling_is_refused_and_a_servo_trace_identifies() {
        for shape in [
            RampShape::Trapezoid,
            RampShape::JerkLimited,
            RampShape::Bell,
        ] {
            let p = triangle(shape);
            let slow = identifiability(&p, 0.072);
            assert!(
                matches!(slow, Identifiability::Refused { ref reason } if reason.contains("acceleration")),
                "{shape:?}: {slow:?}"
            );
            assert!(slow.warning(0.072).unwrap().contains("at 72.000 ms"));
            match identifiability(&p, 1e-3) {
                Identifiability::Identified { j_relative_se, .. } => {
                    assert!(j_relative_se < 0.02, "{shape:?}: {j_relative_se}")
                }
                other => panic!("{shape:?} at 1 kHz: {other:?}"),
            }
            assert_eq!(identifiability_warning(&p, 1e-3), None);
        }
    }

    /// The search names a rate at which the twin does identify J, and no lower power-of-two
    /// step of the starting rate did.
    #[test]
    fn the_named_rate_identifies() {
        let p = triangle(RampShape::JerkLimited);
        let w = identifiability_warning(&p, 0.072).unwrap();
        let rate: f64 = w
            .split("identifies J from about ")
            .nth(1)
            .and_then(|r| r.split(' ').next())
            .and_then(|r| r.parse().ok())
            .unwrap_or_else(|| panic!("no rate in {w}"));
        assert!(rate > 1.0 / 0.072 && rate < 1000.0, "{rate}");
        assert!(
            matches!(identifiability(&p, 1.0 / rate), Identifiability::Identified { j_relative_se, .. } if j_relative_se <= WEAK_J_RELATIVE_SE),
            "{w}"
        );
    }

    #[test]
    fn a_stroke_test_is_not_checked() {
        let s = StrokeTestParams {
            from_mm: 0.0,
            to_mm: 100.0,
            feeds_mm_min: vec![600.0],
            repeats: 1,
            dwell_s: 1.0,
            accel_mm_s2: 1000.0,
        };
        let p = strokes_program(&s, &Limits::default()).unwrap();
        assert_eq!(identifiability(&p, 0.072), Identifiability::NotChecked);
    }
}
