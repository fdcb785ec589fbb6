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
//!     facts: Default::default(),
//! };
//! let est = estimate(&trace, &axis, &EstimateParams::default()).unwrap();
//! assert_eq!(est.strokes.len(), 1);
//! let s = &est.strokes[0];
//! assert!((s.summary.mean_friction_n - 150.0).abs() < 1e-6);
//! ```

pub mod floor;
mod inversion;
pub mod moves;
mod params;
mod pipeline;
mod plan;
pub mod segment;
pub mod stream;
mod stroke;
mod transient;
mod view;

use serde::{Deserialize, Serialize};

use crate::axis::AxisParams;
use crate::diag::Diagnostic;
use crate::spline::SplineError;
use crate::trace::{EffortKind, Trace};
use crate::verdict::{DataVerdict, StrokeVerdict};
pub use floor::NoiseFloor;
pub use moves::{Move, MoveKind, ProgrammedMove};
pub use params::{friction_sign, EffortSign, EstimateParams, PositionSmoothing, TimeOfPosition};
pub use pipeline::{
    estimate_map_streaming, estimate_pieces_streaming, estimate_streaming, StrokePiece,
};
pub use plan::{max_plausible_feed_mm_min, plan, Plan, Skip, StrokeOutcome};
pub use segment::{MoveSpan, SegmentParams, StrokeSpan, Zone, ZoneKind};
pub use stroke::{
    estimate_stroke, estimate_stroke_pieces, MAX_GRID_POINTS_FLOOR, MAX_GRID_POINTS_PER_SAMPLE,
    MEAN_RESOLVED_SE,
};

pub use crate::stroke::Direction;

/// Why estimation failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum EstimateError {
    /// The effort is zero everywhere, or one value across strokes of both directions.
    #[error(
        "the effort channel `{channel}` holds no information: all {samples} samples are \
         {value}; friction cannot be estimated from it (check the channel mapping or the \
         axis chosen at import)"
    )]
    EffortWithoutInformation {
        /// Channel name.
        channel: &'static str,
        /// Its one value.
        value: f64,
        /// Its samples.
        samples: usize,
    },
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
    /// The axis moved, but only in rapids, jogs or positioning moves.
    #[error(
        "no measuring stroke: the trace holds {rapid} rapid, {jog} jog and {positioning} \
         positioning move(s) but no steady move at a programmed feed (rapids are found by \
         rapid_rate_mm_min in the axis file or inferred; include them with --include-rapids)"
    )]
    NoMeasuringStroke {
        /// Rapid moves found.
        rapid: usize,
        /// Moves that no program block explains.
        jog: usize,
        /// Moves without a steady feed.
        positioning: usize,
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
    /// Steady strokes were found, but none could be estimated.
    #[error("{strokes} steady stroke(s) found, but none could be estimated: {reason}")]
    NoneEstimated {
        /// Strokes found.
        strokes: usize,
        /// Why the first was left out.
        reason: String,
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
    /// The resampling grid of a stroke would be far larger than the stroke's samples justify
    /// (positions in the wrong unit, or a lead far too small): refused before allocating.
    #[error(
        "stroke {stroke}: {length_mm:.4e} mm of travel at {samples_per_lead} points per lead of \
         {lead_mm} mm would be {points} grid points for {samples} position samples (at most \
         {limit}); check lead_mm in the axis file and the unit of the trace's position column"
    )]
    GridTooLarge {
        /// Stroke number (0-based).
        stroke: usize,
        /// Travel of the stroke (mm).
        length_mm: f64,
        /// The axis lead (mm).
        lead_mm: f64,
        /// Resampled points per lead.
        samples_per_lead: u32,
        /// Grid points the stroke would need.
        points: f64,
        /// Position samples of the stroke.
        samples: usize,
        /// The bound: the larger of [`MAX_GRID_POINTS_FLOOR`] and
        /// [`MAX_GRID_POINTS_PER_SAMPLE`] per position sample.
        limit: usize,
    },
    /// A move runs faster than any feed axis (or this axis, by its rapid rate) can: the
    /// positions are in another unit than mm (µm written as mm) or the times are not seconds.
    #[error(
        "a move from {start_mm:.1} mm to {end_mm:.1} mm at t = {start_time_s:.3} s runs at \
         {feed_mm_min:.1} mm/min, beyond {limit_mm_min:.0} mm/min ({why}): no feed axis moves \
         so fast; the trace's positions are scaled (µm written as mm?) or its times are not in \
         seconds; check the units of its position and time columns"
    )]
    FeedImplausible {
        /// Plateau speed of the move (mm/min).
        feed_mm_min: f64,
        /// The bound (mm/min), [`max_plausible_feed_mm_min`].
        limit_mm_min: f64,
        /// Where the bound comes from.
        why: &'static str,
        /// Start of the move (s).
        start_time_s: f64,
        /// Position at its start (mm).
        start_mm: f64,
        /// Position at its end (mm).
        end_mm: f64,
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

impl EstimateError {
    /// Always [`crate::ErrorKind::BadInput`]: every variant says why these data (or parameters) give
    /// no estimate.
    pub fn kind(&self) -> crate::ErrorKind {
        crate::ErrorKind::BadInput
    }
}

/// Per-stroke facts for people and reports.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StrokeSummary {
    /// Stroke number (0-based, time order).
    pub stroke: usize,
    /// What the move is (measuring unless rapids were included).
    pub kind: MoveKind,
    /// Direction of travel.
    pub direction: Direction,
    /// Measured plateau feed of the stroke (mm/min), the commanded feed up to override.
    pub feed_mm_min: f64,
    /// Low end of the stroke's feed range (mm/min): the 5th percentile of its chord speeds
    /// ([`segment`], module docs); a feed that varies along the stroke (a modulation, an
    /// override changed mid-block) shows here. `None` when not known (a friction CSV read
    /// without its summary).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub feed_min_mm_min: Option<f64>,
    /// High end of the stroke's feed range (mm/min): the 95th percentile of its chord speeds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub feed_max_mm_min: Option<f64>,
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
    /// Mean friction over the stroke (N, signed as Eq. 5, or from the direction of motion when
    /// the effort is a magnitude; see [`Estimate::verdict`]).
    pub mean_friction_n: f64,
    /// Standard error of [`mean_friction_n`](Self::mean_friction_n) (N): the effort noise over
    /// the raw effort samples, and the effort quantum's rounding, which need not average out:
    /// sqrt(σ_F²/N_e + b²) with b = (q_F/√12)·exp(−2π²σ_d²/q_F²), the rounding's bias left
    /// after the dither σ_d² = max(0, σ_F² − q_F²/12) that the noise and the signal's own
    /// variation give it (q_F/√12 on a reading that sits still; nothing once σ_d ≳ q_F/2, when
    /// the rounding is already in σ_F); a quantum the recording's facts declare keeps its full
    /// q_F/√12 (the drive's rounding rule is unknown). `None` when not known (a friction CSV
    /// without its summary).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mean_friction_se_n: Option<f64>,
    /// Resolution of the effort as force (N): the larger of the quantum found in the samples
    /// and the one the recording's facts declare; 0 for an unquantised effort.
    #[serde(default)]
    pub effort_quantum_n: f64,
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
    /// Highest order (cycles per lead) that can be trusted: raw samples per lead / 2.5, and
    /// no higher than the position cut-off's order when the position was smoothed. Nyquist is
    /// samples per lead / 2, but the interpolating spline's response falls off and images fold
    /// back in the top fifth of that band, so 0.8 × Nyquist is kept as the limit; above the
    /// cut-off the table acceleration, and so the inertia term of Eq. 5, is not resolved.
    pub max_order: f64,
    /// Cut-off of the position smoothing (Hz), when it was applied.
    pub position_cutoff_hz: Option<f64>,
    /// The same cut-off as an order at the stroke's feed (cycles per lead).
    pub position_cutoff_order: Option<f64>,
    /// Time left out after the acceleration ramp and before the deceleration so that the
    /// smoother's transient has settled (s; 0 without smoothing).
    pub settle_margin_s: f64,
    /// Predicted noise floor of the friction (N RMS) and its parts.
    pub noise_floor: NoiseFloor,
    /// NC program line of the block that commanded the stroke, when a program was given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub program_line: Option<usize>,
    /// Programmed axis feed of that block (mm/min).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub programmed_feed_mm_min: Option<f64>,
    /// What this stroke's data support ([`crate::verdict`]); `None` when not judged (a
    /// friction CSV read without its summary).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub verdict: Option<StrokeVerdict>,
    /// Things a user should know about this stroke, each with a stable code
    /// (`position-not-monotone`, `few-samples-per-lead`, `position-smoothed-below-order`,
    /// `noise-floor-high`, `mean-not-resolved` when the mean lies within
    /// [`MEAN_RESOLVED_SE`] standard errors of zero).
    pub warnings: Vec<Diagnostic>,
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

impl StrokeFriction {
    /// The six row columns, in the order of the struct.
    fn columns_mut(&mut self) -> [&mut Vec<f64>; 6] {
        [
            &mut self.position_m,
            &mut self.time_s,
            &mut self.velocity_m_s,
            &mut self.accel_m_s2,
            &mut self.effort,
            &mut self.friction_n,
        ]
    }

    /// Append the rows of `later`, the next piece of the same stroke (the summary is kept).
    pub fn append_rows(&mut self, mut later: StrokeFriction) {
        for (dst, src) in self.columns_mut().into_iter().zip(later.columns_mut()) {
            if dst.is_empty() {
                *dst = std::mem::take(src);
            } else {
                dst.extend_from_slice(src);
            }
        }
    }
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
    /// Every move of the axis with its kind.
    pub moves: Vec<Move>,
    /// Strokes found but not estimated, with the reason.
    pub skipped: Vec<String>,
    /// What the move classification wants a user to know (inferred rapids, program match).
    pub notes: Vec<Diagnostic>,
    /// What the recording supports, over all its strokes.
    pub verdict: DataVerdict,
}

/// What [`estimate_streaming`] returns besides the strokes.
#[derive(Debug, Clone, PartialEq)]
pub struct Outline {
    /// What lies between the strokes.
    pub zones: Vec<Zone>,
    /// Every move of the axis with its kind.
    pub moves: Vec<Move>,
    /// Strokes found but not estimated, with the reason.
    pub skipped: Vec<String>,
    /// Notes of the move classification.
    pub notes: Vec<Diagnostic>,
    /// What the recording supports, over all its strokes.
    pub verdict: DataVerdict,
}

/// Estimate friction along the travel for every measuring stroke of a trace.
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
    let outline = estimate_streaming(
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
        zones: outline.zones,
        moves: outline.moves,
        skipped: outline.skipped,
        notes: outline.notes,
        verdict: outline.verdict,
    })
}

#[cfg(test)]
mod tests;
