//! Sensorless friction estimation along the travel (paper 000, Section 3, Eq. 1-5).
//!
//! For every steady stroke found by [`segment::find_strokes`]:
//! 1. cubic splines z(t) through the stroke's position knots and i(t) through the effort knots
//!    in the same time window (step 1; not-a-knot ends by default, natural as an option);
//! 2. velocity z'(t) and acceleration z''(t) from the position spline (step 2);
//! 3. t(z): by default the exact inverse of the position spline, found by safeguarded Newton
//!    iteration in each knot interval, so that z(t(Z)) = Z to rounding. The paper instead
//!    interpolates the knots (z_k, t_k) with a second spline ([`TimeOfPosition::KnotSpline`]);
//!    that t(z) is not the inverse of z(t) and breaks when quantisation repeats a position, so
//!    it is kept only as an option (step 3);
//! 4. resampling positions Z on the absolute grid k·p/m (m = 1024 by default), ascending for
//!    forward strokes and descending for backward ones, limited to the span where both
//!    channels have knots, so nothing is extrapolated (steps 4-5);
//! 5. velocity, acceleration and effort at T = t(Z) (step 6) and friction from Eq. 5 (step 7):
//!
//!    F_f = (2π/p)·k_e·i − (m_t + 4π²J/p²)·z'' − (4π²B/p²)·z'
//!
//!    (with torque input T the first term is (2π/p)·T). F_f is signed as in Eq. 5: positive
//!    while moving forward, negative backward.
//!
//! Strokes are independent and run in parallel.
//!
//! # Example
//! ```
//! use feedscope::axis::{AxisParams, ConfigFormat};
//! use feedscope::estimate::{estimate, EstimateParams};
//! use feedscope::trace::{Channel, EffortKind, Trace};
//!
//! let axis = AxisParams::parse(
//!     "lead_mm = 10\ntable_mass_kg = 300\ninertia_kgm2 = 0.002\n\
//!      damping_nms_per_rad = 0\ntorque_constant_nm_per_a = 1.5\n",
//!     ConfigFormat::Toml, "axis").unwrap();
//! // 1 s dwell, then 20 mm forward at 2 mm/s against a constant 150 N of friction.
//! let t: Vec<f64> = (0..1200).map(|k| k as f64 * 0.01).collect();
//! let z: Vec<f64> = t.iter().map(|&t| 0.002 * (t - 1.0).clamp(0.0, 10.0)).collect();
//! let amps = 150.0 / axis.force_per_torque_n_per_nm() / 1.5;
//! let trace = Trace {
//!     position_m: Channel { time_s: t.clone(), value: z },
//!     effort: Channel { time_s: t, value: vec![amps; 1200] },
//!     effort_kind: EffortKind::CurrentA,
//! };
//! let est = estimate(&trace, &axis, &EstimateParams::default()).unwrap();
//! assert_eq!(est.strokes.len(), 1);
//! let s = &est.strokes[0];
//! assert!((s.summary.mean_friction_n - 150.0).abs() < 1e-6);
//! ```

pub mod segment;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::axis::AxisParams;
use crate::spline::{CubicSpline, EndCondition, SplineError};
use crate::trace::{EffortKind, Trace};
pub use segment::{Direction, SegmentParams, StrokeSpan, Zone, ZoneKind};

/// How the run time t(z) of step 3 is obtained.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TimeOfPosition {
    /// Invert the position spline z(t) exactly (default).
    #[default]
    Invert,
    /// Interpolate the knots (z_k, t_k) with a spline, as the paper does.
    KnotSpline,
}

/// Estimation settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EstimateParams {
    /// Resampling points per lead, m (the position step is p/m). Default 1024.
    pub samples_per_lead: u32,
    /// Spline end condition. Default not-a-knot.
    pub end_condition: EndCondition,
    /// How t(z) is obtained. Default: exact inversion.
    pub time_of_position: TimeOfPosition,
    /// Position smoothing before differentiation, as a cut-off order (cycles per lead).
    /// Twice differentiating a quantised or noisy position amplifies its noise as 1/h²,
    /// which swamps the inertia term at kHz sampling. When a stroke's raw position samples
    /// resolve orders well above this cut-off (Nyquist order > 1.25 × cut-off), z(t) is a
    /// Reinsch smoothing spline whose half-power point is at this order at the stroke's
    /// feed; otherwise it interpolates exactly (paper 000). Default 64, twice the highest
    /// order paper 000 found significant (28.5). `None` always interpolates.
    pub position_cutoff_order: Option<f64>,
    /// Stroke segmentation.
    pub segment: SegmentParams,
}

impl Default for EstimateParams {
    fn default() -> Self {
        Self {
            samples_per_lead: 1024,
            end_condition: EndCondition::NotAKnot,
            time_of_position: TimeOfPosition::Invert,
            position_cutoff_order: Some(64.0),
            segment: SegmentParams::default(),
        }
    }
}

/// Why estimation failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum EstimateError {
    /// No steady stroke was found.
    #[error(
        "no steady stroke found: the position never moves at a steady feed over at least \
         {min_stroke_mm} mm with {min_knots} samples"
    )]
    NoStroke {
        /// Shortest stroke accepted (mm).
        min_stroke_mm: f64,
        /// Fewest knots accepted.
        min_knots: usize,
    },
    /// Steady strokes were found, but none held enough effort samples to estimate.
    #[error(
        "{strokes} steady stroke(s) found, but none holds {min_samples} or more effort samples \
         (the current or torque channel is sampled too slowly or has a gap there)"
    )]
    NoEffortInStrokes {
        /// Strokes found.
        strokes: usize,
        /// Fewest effort samples a stroke needs.
        min_samples: usize,
    },
    /// `samples_per_lead` is zero.
    #[error("samples_per_lead must be at least 1")]
    BadSamplesPerLead,
    /// A spline could not be built.
    #[error("stroke {stroke}: {channel} spline: {error}")]
    Spline {
        /// Stroke number (0-based).
        stroke: usize,
        /// Channel name.
        channel: &'static str,
        /// The spline's complaint.
        error: SplineError,
    },
    /// A result came out NaN or infinite.
    #[error("stroke {stroke}: {quantity} is not finite at position {position_mm} mm")]
    NonFinite {
        /// Stroke number (0-based).
        stroke: usize,
        /// Which output.
        quantity: &'static str,
        /// Where.
        position_mm: f64,
    },
}

/// Per-stroke facts for people and reports.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StrokeSummary {
    /// Stroke number (0-based, time order).
    pub stroke: usize,
    /// Direction of travel.
    pub direction: Direction,
    /// Measured plateau feed of the stroke (mm/min), the commanded feed up to override.
    pub feed_mm_min: f64,
    /// First resampled position (mm).
    pub start_mm: f64,
    /// Last resampled position (mm).
    pub end_mm: f64,
    /// |end − start| (mm).
    pub length_mm: f64,
    /// Time at the first resampled point (s).
    pub start_time_s: f64,
    /// Time at the last resampled point (s).
    pub end_time_s: f64,
    /// Mean friction over the stroke (N, signed as Eq. 5).
    pub mean_friction_n: f64,
    /// RMS of friction minus its mean (N).
    pub friction_std_n: f64,
    /// Raw position samples in the stroke.
    pub position_samples: usize,
    /// Raw effort samples in the stroke.
    pub effort_samples: usize,
    /// Resampled points.
    pub points: usize,
    /// Raw samples per lead: the smaller of the position and the effort channel.
    pub raw_samples_per_lead: f64,
    /// Highest order (cycles per lead) that can be trusted: raw samples per lead / 2.5.
    /// Nyquist is samples per lead / 2, but the interpolating spline's response falls off and
    /// images fold back in the top fifth of that band, so 0.8 × Nyquist is kept as the limit.
    pub max_order: f64,
    /// Cut-off order of the position smoothing, when it was applied.
    pub position_cutoff_order: Option<f64>,
    /// Things a user should know about this stroke.
    pub warnings: Vec<String>,
}

/// Friction of one stroke on the resampling grid (SI, arrays of equal length, time order).
#[derive(Debug, Clone, PartialEq)]
pub struct StrokeFriction {
    /// Summary.
    pub summary: StrokeSummary,
    /// Resampled positions Z (m), on the grid k·p/m.
    pub position_m: Vec<f64>,
    /// Times T = t(Z) (s).
    pub time_s: Vec<f64>,
    /// Table velocity z'(T) (m/s).
    pub velocity_m_s: Vec<f64>,
    /// Table acceleration z''(T) (m/s²).
    pub accel_m_s2: Vec<f64>,
    /// Motor current (A) or torque (N·m) i(T), per [`Estimate::effort_kind`].
    pub effort: Vec<f64>,
    /// Friction force F_f (N), Eq. 5, signed.
    pub friction_n: Vec<f64>,
}

/// Result of [`estimate`].
#[derive(Debug, Clone, PartialEq)]
pub struct Estimate {
    /// What the effort column is.
    pub effort_kind: EffortKind,
    /// The strokes in time order.
    pub strokes: Vec<StrokeFriction>,
    /// What lies between the strokes.
    pub zones: Vec<Zone>,
    /// Strokes found but not estimated, with the reason.
    pub skipped: Vec<String>,
}

/// Estimate friction along the travel for every steady stroke of a trace.
///
/// # Errors
/// [`EstimateError::NoStroke`] when no steady stroke exists; spline or non-finite errors when
/// the data are degenerate.
pub fn estimate(
    trace: &Trace,
    axis: &AxisParams,
    params: &EstimateParams,
) -> Result<Estimate, EstimateError> {
    let mut strokes = Vec::new();
    // One batch holding every stroke: all run in parallel.
    let (zones, skipped) = estimate_streaming(
        trace,
        axis,
        params,
        usize::MAX,
        |s| -> Result<(), EstimateError> {
            strokes.push(s);
            Ok(())
        },
    )?;
    Ok(Estimate {
        effort_kind: trace.effort_kind,
        strokes,
        zones,
        skipped,
    })
}

/// Strokes found in a trace, before estimation; lets a caller estimate them in batches (to
/// bound memory) with [`estimate_stroke`].
#[derive(Debug, Clone)]
pub struct Plan {
    /// The strokes' knot ranges.
    pub spans: Vec<StrokeSpan>,
}

/// Segment a trace into strokes.
///
/// # Errors
/// [`EstimateError::NoStroke`], [`EstimateError::BadSamplesPerLead`].
pub fn plan(trace: &Trace, params: &EstimateParams) -> Result<Plan, EstimateError> {
    if params.samples_per_lead == 0 {
        return Err(EstimateError::BadSamplesPerLead);
    }
    let spans = segment::find_strokes(&trace.position_m, &params.segment);
    if spans.is_empty() {
        return Err(EstimateError::NoStroke {
            min_stroke_mm: params.segment.min_stroke_mm,
            min_knots: params.segment.min_knots,
        });
    }
    Ok(Plan { spans })
}

/// Estimate one stroke (step 1-7). `Ok(None)` when the effort channel has fewer than four
/// samples inside it.
///
/// # Errors
/// Spline failures and non-finite results.
pub fn estimate_stroke(
    trace: &Trace,
    axis: &AxisParams,
    params: &EstimateParams,
    index: usize,
    span: &StrokeSpan,
) -> Result<Option<StrokeFriction>, EstimateError> {
    let pos = &trace.position_m;
    let tz = &pos.time_s[span.first..=span.last];
    let zz = &pos.value[span.first..=span.last];
    let (t_lo, t_hi) = (tz[0], tz[tz.len() - 1]);
    // Effort knots inside the position window: no extrapolation of either channel.
    let te_all = &trace.effort.time_s;
    let e0 = te_all.partition_point(|&t| t < t_lo);
    let e1 = te_all.partition_point(|&t| t <= t_hi);
    if e1 < e0 + crate::trace::MIN_SAMPLES {
        return Ok(None);
    }
    let te = &te_all[e0..e1];
    let ee = &trace.effort.value[e0..e1];
    let lead = axis.lead_m();
    let spline_err = |error| EstimateError::Spline {
        stroke: index,
        channel: "position",
        error,
    };
    // Position samples per lead decide whether smoothing can help (see `position_cutoff_order`).
    let spl_z = (tz.len() - 1) as f64 * lead / (zz[zz.len() - 1] - zz[0]).abs().max(1e-12);
    let cutoff = params
        .position_cutoff_order
        .filter(|&c| c > 0.0 && 0.5 * spl_z > 1.25 * c);
    let mut z_smooth = Vec::new();
    let zs = match cutoff {
        Some(order) => {
            let h = (t_hi - t_lo) / (tz.len() - 1) as f64;
            let f_c = order * span.plateau_speed_m_s / lead;
            let alpha = crate::spline::alpha_for_cutoff(h, f_c);
            let m = crate::spline::smoothing_moments(tz, zz, alpha, &mut z_smooth)
                .map_err(spline_err)?;
            CubicSpline::from_moments(tz, &z_smooth, m).map_err(spline_err)?
        }
        None => CubicSpline::new(tz, zz, params.end_condition).map_err(spline_err)?,
    };
    let zz: &[f64] = if cutoff.is_some() { &z_smooth } else { zz };
    let es =
        CubicSpline::new(te, ee, params.end_condition).map_err(|error| EstimateError::Spline {
            stroke: index,
            channel: trace.effort_kind.column(),
            error,
        })?;
    let (w_lo, w_hi) = (te[0].max(t_lo), te[te.len() - 1].min(t_hi));
    let dir = span.direction;
    let s = dir.sign();
    let step = lead / f64::from(params.samples_per_lead);
    // Position range covered by the window, on the spline (exact at knots, else evaluated).
    let (z_a, z_b) = (zs.eval(w_lo), zs.eval(w_hi));
    // Grid indices strictly inside [z_a, z_b] in the direction of travel.
    let (k_first, k_last): (i64, i64) = match dir {
        Direction::Forward => ((z_a / step).ceil() as i64, (z_b / step).floor() as i64),
        Direction::Backward => ((z_a / step).floor() as i64, (z_b / step).ceil() as i64),
    };
    let count = ((k_last - k_first) as f64 * s) as i64 + 1;
    let mut warnings = Vec::new();
    if count < 2 {
        return Ok(None);
    }
    let count = count as usize;
    let mut out = StrokeFriction {
        summary: StrokeSummary {
            stroke: index,
            direction: dir,
            feed_mm_min: span.plateau_speed_m_s * 60e3,
            start_mm: 0.0,
            end_mm: 0.0,
            length_mm: 0.0,
            start_time_s: 0.0,
            end_time_s: 0.0,
            mean_friction_n: 0.0,
            friction_std_n: 0.0,
            position_samples: tz.len(),
            effort_samples: te.len(),
            points: count,
            raw_samples_per_lead: 0.0,
            max_order: 0.0,
            position_cutoff_order: cutoff,
            warnings: Vec::new(),
        },
        position_m: Vec::with_capacity(count),
        time_s: Vec::with_capacity(count),
        velocity_m_s: Vec::with_capacity(count),
        accel_m_s2: Vec::with_capacity(count),
        effort: Vec::with_capacity(count),
        friction_n: Vec::with_capacity(count),
    };
    let m_eq = axis.equivalent_mass_kg();
    let b_eq = axis.equivalent_damping_n_s_per_m();
    let gain = match trace.effort_kind {
        EffortKind::CurrentA => axis.force_per_torque_n_per_nm() * axis.torque_constant_nm_per_a,
        EffortKind::TorqueNm => axis.force_per_torque_n_per_nm(),
    };
    // t(z) by the paper's knot spline, when asked for: a spline through (s·z_k, t_k), since its
    // abscissae must increase for either direction.
    let knot_x: Vec<f64> = match params.time_of_position {
        TimeOfPosition::Invert => Vec::new(),
        TimeOfPosition::KnotSpline => zz.iter().map(|z| s * z).collect(),
    };
    let knot_spline = match params.time_of_position {
        TimeOfPosition::Invert => None,
        TimeOfPosition::KnotSpline => Some(
            CubicSpline::new(&knot_x, tz, params.end_condition).map_err(|error| {
                EstimateError::Spline {
                    stroke: index,
                    channel: "t(z)",
                    error,
                }
            })?,
        ),
    };
    let mut knot_cursor = knot_spline.as_ref().map(|k| k.cursor());
    let mut ecur = es.cursor();
    let mut k_int = zs.interval(w_lo);
    let mut piece = zs.piece(k_int);
    let mut non_monotone = false;
    let mut t_prev = w_lo;
    let mut sum = 0.0;
    for j in 0..count {
        let zg = (k_first as f64 + s * j as f64) * step;
        let (t, v, a) = match &mut knot_cursor {
            Some(ks) => {
                let t = ks.eval(s * zg).clamp(w_lo, w_hi);
                let (_, v, a) = zs.eval_all(t);
                (t, v, a)
            }
            None => {
                // Advance to the knot interval whose end lies beyond the target.
                let k_old = k_int;
                while k_int + 2 < zz.len() && s * (zz[k_int + 1] - zg) < 0.0 {
                    k_int += 1;
                }
                if k_int != k_old {
                    piece = zs.piece(k_int);
                }
                match newton_in_piece(&piece, zz[k_int + 1], zg) {
                    Some((u, v, a)) => (piece.x0 + u, v, a),
                    None => {
                        // Not monotone here: the safeguarded search over neighbours.
                        let (t, k, ok) =
                            invert_in(&zs, k_int, zg, t_prev.max(tz[k_int]), w_lo, w_hi);
                        non_monotone |= !ok;
                        let (_, v, a) = zs.eval_in(k, t);
                        (t, v, a)
                    }
                }
            }
        };
        t_prev = t;
        let e = ecur.eval(t);
        let f = gain * e - m_eq * a - b_eq * v;
        if !f.is_finite() {
            return Err(EstimateError::NonFinite {
                stroke: index,
                quantity: "friction_n",
                position_mm: zg * 1e3,
            });
        }
        sum += f;
        out.position_m.push(zg);
        out.time_s.push(t);
        out.velocity_m_s.push(v);
        out.accel_m_s2.push(a);
        out.effort.push(e);
        out.friction_n.push(f);
    }
    if non_monotone {
        warnings.push(
            "the position spline is not monotone somewhere in this stroke (noisy or coarsely \
             quantised position at a low feed); t(z) took the nearest solution"
                .to_string(),
        );
    }
    let mean = sum / count as f64;
    let var = out
        .friction_n
        .iter()
        .map(|f| (f - mean) * (f - mean))
        .sum::<f64>()
        / count as f64;
    let travel = (out.position_m[count - 1] - out.position_m[0]).abs();
    // Raw samples per lead of each channel over its own span inside the stroke.
    let z_span = |a: f64, b: f64| (zs.eval(b) - zs.eval(a)).abs().max(1e-12);
    let spl_e = (te.len() - 1) as f64 * lead / z_span(te[0], te[te.len() - 1]);
    let spl = spl_z.min(spl_e);
    let sm = &mut out.summary;
    sm.start_mm = out.position_m[0] * 1e3;
    sm.end_mm = out.position_m[count - 1] * 1e3;
    sm.length_mm = travel * 1e3;
    sm.start_time_s = out.time_s[0];
    sm.end_time_s = out.time_s[count - 1];
    sm.mean_friction_n = mean;
    sm.friction_std_n = var.sqrt();
    sm.raw_samples_per_lead = spl;
    sm.max_order = spl / 2.5;
    if spl < 8.0 {
        warnings.push(format!(
            "only {spl:.1} raw samples per lead: fluctuation above order {:.1} cannot be \
             trusted; sample faster or feed slower (below {:.0} mm/min for 8 samples per lead)",
            spl / 2.5,
            span.plateau_speed_m_s * 60e3 * spl / 8.0
        ));
    }
    sm.warnings = warnings;
    Ok(Some(out))
}

/// Newton's method for z(x0 + u) = target inside one monotone piece, started from linear
/// interpolation between the piece's ends (`z1` is the value at its right knot). Returns (u, z', z'') or `None` when the piece does
/// not bracket the target monotonically (then [`invert_in`] takes over).
#[inline]
fn newton_in_piece(p: &crate::spline::Piece, z1: f64, target: f64) -> Option<(f64, f64, f64)> {
    let dz = z1 - p.c0;
    if dz == 0.0 {
        return None;
    }
    let frac = (target - p.c0) / dz;
    if !(0.0..=1.0).contains(&frac) {
        return None;
    }
    let mut u = frac * p.h;
    // Chord-Newton: the slope from the start point is kept, which trades one division per
    // step for a slightly slower (still fast: the start is within O(h²) of the root)
    // convergence. Steps below 1e-13 of the interval are rounding noise.
    let tol = 1e-13 * p.h;
    let (_, d1_0, _) = p.eval(u);
    if d1_0 == 0.0 || (d1_0 > 0.0) != (dz > 0.0) {
        return None;
    }
    let inv_d1 = 1.0 / d1_0;
    for _ in 0..16 {
        let (z, d1, _) = p.eval(u);
        if (d1 > 0.0) != (dz > 0.0) {
            return None;
        }
        let du = (z - target) * inv_d1;
        u -= du;
        if du.abs() <= tol {
            if !(-tol..=p.h + tol).contains(&u) {
                return None;
            }
            let (_, d1, d2) = p.eval(u);
            return Some((u, d1, d2));
        }
    }
    None
}

/// Solve z(t) = target on knot interval k (then its neighbours) by Newton steps safeguarded
/// with bisection. Returns the time, the interval holding it, and whether a bracketing
/// interval was found.
fn invert_in(
    zs: &CubicSpline<'_>,
    k: usize,
    target: f64,
    guess: f64,
    w_lo: f64,
    w_hi: f64,
) -> (f64, usize, bool) {
    let x = zs.x();
    let n_int = x.len() - 1;
    // Search this interval and a few after it for a sign change (the spline can overshoot
    // between knots when the position is noisy).
    for kk in k..(k + 4).min(n_int) {
        let (a, b) = (x[kk].max(w_lo), x[kk + 1].min(w_hi));
        if b < a {
            continue;
        }
        let fa = zs.eval_in(kk, a).0 - target;
        if fa == 0.0 {
            return (a, kk, true);
        }
        let fb = zs.eval_in(kk, b).0 - target;
        if fa * fb > 0.0 {
            continue;
        }
        // Converged when a step is below a few ulps of t.
        let tol = 4.0 * f64::EPSILON * b.abs().max(1.0);
        let (mut lo, mut hi) = (a, b);
        let mut t = if guess > a && guess < b {
            guess
        } else {
            a + (b - a) * fa / (fa - fb)
        };
        for _ in 0..100 {
            let (v, d1, _) = zs.eval_in(kk, t);
            let f = v - target;
            if f == 0.0 {
                return (t, kk, true);
            }
            if (f < 0.0) == (fa < 0.0) {
                lo = t;
            } else {
                hi = t;
            }
            let newton = t - f / d1;
            if d1 != 0.0 && newton >= lo && newton <= hi {
                // Newton from one side lands on the bracket's edge when it has converged,
                // so test convergence before anything else.
                if (newton - t).abs() <= tol {
                    return (newton, kk, true);
                }
                t = newton;
            } else {
                t = 0.5 * (lo + hi);
                if hi - lo <= tol {
                    return (t, kk, true);
                }
            }
        }
        return (t, kk, true);
    }
    let t = guess.clamp(w_lo, w_hi);
    (t, zs.interval(t), false)
}

/// Estimate the strokes in batches of `batch` at a time (in parallel within a batch) and hand
/// each finished stroke, in time order, to `sink`; memory holds one batch of results.
///
/// # Errors
/// As [`estimate`], or what `sink` returns.
pub fn estimate_streaming<E: From<EstimateError>>(
    trace: &Trace,
    axis: &AxisParams,
    params: &EstimateParams,
    batch: usize,
    sink: impl FnMut(StrokeFriction) -> Result<(), E>,
) -> Result<(Vec<Zone>, Vec<String>), E> {
    estimate_map_streaming(trace, axis, params, batch, |s| s, sink)
}

/// As [`estimate_streaming`], but `map` runs on each stroke inside the parallel section (e.g.
/// to format it for output), and `sink` receives what `map` returns, in time order.
///
/// # Errors
/// As [`estimate`], or what `sink` returns.
pub fn estimate_map_streaming<T: Send, E: From<EstimateError>>(
    trace: &Trace,
    axis: &AxisParams,
    params: &EstimateParams,
    batch: usize,
    map: impl Fn(StrokeFriction) -> T + Sync,
    mut sink: impl FnMut(T) -> Result<(), E>,
) -> Result<(Vec<Zone>, Vec<String>), E> {
    let planned = plan(trace, params)?;
    let mut skipped = Vec::new();
    let mut any = false;
    let batch = batch.max(1);
    for (b, chunk) in planned.spans.chunks(batch).enumerate() {
        let base = b * batch;
        let results: Vec<_> = chunk
            .par_iter()
            .enumerate()
            .map(|(k, span)| {
                estimate_stroke(trace, axis, params, base + k, span).map(|o| o.map(&map))
            })
            .collect();
        for (k, r) in results.into_iter().enumerate() {
            match r? {
                Some(t) => {
                    any = true;
                    sink(t)?;
                }
                None => {
                    let span = &chunk[k];
                    skipped.push(format!(
                        "stroke {} ({}, {:.1} to {:.1} mm): too few effort samples inside it",
                        base + k,
                        span.direction.as_str(),
                        trace.position_m.value[span.first] * 1e3,
                        trace.position_m.value[span.last] * 1e3
                    ));
                }
            }
        }
    }
    if !any {
        return Err(EstimateError::NoEffortInStrokes {
            strokes: planned.spans.len(),
            min_samples: crate::trace::MIN_SAMPLES,
        }
        .into());
    }
    Ok((
        segment::zones_between(&trace.position_m, &planned.spans),
        skipped,
    ))
}

#[cfg(test)]
mod tests;
