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
pub mod moves;
pub mod segment;
pub mod stream;
mod transient;
mod view;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::axis::AxisParams;
use crate::diag::{Code, Diagnostic};
use crate::spline::{CubicSpline, EndCondition, Piece, PieceTable, SplineError};
use crate::trace::{EffortKind, Trace};
use crate::verdict::{judge_stroke, DataVerdict, FrictionSign, StrokeEvidence, StrokeVerdict};
pub use floor::NoiseFloor;
pub use moves::{Move, MoveKind, ProgrammedMove};
pub use segment::{MoveSpan, SegmentParams, StrokeSpan, Zone, ZoneKind};

pub use crate::stroke::Direction;

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

/// How the position is prepared for differentiation (see [`floor`]).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PositionSmoothing {
    /// Chosen per stroke from its samples (default): the interpolating spline of paper 000
    /// when it is quiet enough, else a Reinsch smoother whose cut-off (Hz) balances the
    /// position noise against the effort noise and the settling time ([`floor`]).
    #[default]
    Auto,
    /// A Reinsch smoother with this cut-off (Hz) on every stroke that samples above it.
    CutoffHz(f64),
    /// Always the interpolating spline (paper 000).
    Off,
}

/// Whether the effort carries its sign (see [`crate::verdict::FrictionSign`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum EffortSign {
    /// As the trace's facts say ([`crate::trace::RecordingFacts::effort_signed`]); signed when
    /// they say nothing (with a warning when a never-negative effort suggests a magnitude).
    #[default]
    Auto,
    /// Signed current or torque: friction as Eq. 5.
    Signed,
    /// A magnitude (a drive load reading): friction takes the sign of the direction of motion.
    Magnitude,
    /// A signed current or torque counted against the position (negative for motion towards
    /// +z, as some drives record it): its sign is turned, then friction as Eq. 5.
    Negated,
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
    /// Position smoothing before differentiation. Default: chosen per stroke.
    pub position_smoothing: PositionSmoothing,
    /// Whether the effort carries its sign. Default: [`EffortSign::Auto`].
    pub effort_sign: EffortSign,
    /// Also estimate the steady parts of rapids and jogs (marked with their kind). Default
    /// false: only measuring strokes are estimated.
    pub include_rapids: bool,
    /// The NC program's motion blocks, when known: they label the moves (see [`moves`]).
    #[serde(skip)]
    pub program: Vec<ProgrammedMove>,
    /// Stroke segmentation.
    pub segment: SegmentParams,
    /// Knots a spline is solved over at once: a longer stroke is solved in overlapping windows
    /// ([`crate::spline::smoothing_moments_windowed`]), equal to the whole solve to rounding,
    /// so that its work arrays stay bounded. Default [`crate::spline::DEFAULT_WINDOW_KNOTS`].
    /// A stroke with more position samples than this is also handed out in pieces of
    /// [`piece_points`](Self::piece_points) rows by [`estimate_pieces_streaming`].
    #[serde(skip, default = "default_window_knots")]
    pub spline_window_knots: usize,
    /// Resampled rows per piece of a long stroke ([`estimate_pieces_streaming`]). Default
    /// 2¹⁴ (about 1.3 MB of CSV text per piece).
    #[serde(skip, default = "default_piece_points")]
    pub piece_points: usize,
}

fn default_window_knots() -> usize {
    crate::spline::DEFAULT_WINDOW_KNOTS
}

fn default_piece_points() -> usize {
    1 << 14
}

impl Default for EstimateParams {
    fn default() -> Self {
        Self {
            samples_per_lead: 1024,
            end_condition: EndCondition::NotAKnot,
            time_of_position: TimeOfPosition::Invert,
            position_smoothing: PositionSmoothing::Auto,
            effort_sign: EffortSign::Auto,
            include_rapids: false,
            program: Vec::new(),
            segment: SegmentParams::default(),
            spline_window_knots: default_window_knots(),
            piece_points: default_piece_points(),
        }
    }
}

/// Grid points a stroke may always have: 2^22 (200 MB of results), 4096 leads at 1024 points
/// per lead, e.g. 4 m of a 1 mm lead, however sparsely it was sampled.
pub const MAX_GRID_POINTS_FLOOR: usize = 1 << 22;
/// Beyond the floor, grid points allowed per position sample (a stroke of 10 M samples may
/// have 41 G points' worth of travel only if that many samples justify it).
pub const MAX_GRID_POINTS_PER_SAMPLE: usize = 4096;

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

/// Strokes found in a trace, before estimation; lets a caller estimate them in batches (to
/// bound memory) with [`estimate_stroke`].
#[derive(Debug, Clone)]
pub struct Plan {
    /// The knot ranges of the strokes to estimate; a stroke's number is its index here.
    pub spans: Vec<StrokeSpan>,
    /// Every move with its kind; `strokes` holds the numbers of its spans.
    pub moves: Vec<Move>,
    /// Notes of the classification.
    pub notes: Vec<Diagnostic>,
}

/// The fastest plateau feed a move of `axis` can have (mm/min) and where the bound comes
/// from: [`RAPID_RATE_MARGIN`](crate::trace::glitch::RAPID_RATE_MARGIN) × the axis's rapid
/// rate when the axis file gives it, else
/// [`DEFAULT_MAX_AXIS_SPEED_MM_MIN`](crate::trace::glitch::DEFAULT_MAX_AXIS_SPEED_MM_MIN),
/// above the rapid rate of any ball-screw axis. The same bounds as the glitch screen's, which
/// lets a sustained speed up to about three times them through (its timing slack).
pub fn max_plausible_feed_mm_min(axis: &AxisParams) -> (f64, &'static str) {
    use crate::trace::glitch::{DEFAULT_MAX_AXIS_SPEED_MM_MIN, RAPID_RATE_MARGIN};
    match axis.rapid_rate_mm_min {
        Some(r) => (
            RAPID_RATE_MARGIN * r,
            "1.25 × rapid_rate_mm_min of the axis file",
        ),
        None => (
            DEFAULT_MAX_AXIS_SPEED_MM_MIN,
            "the fastest ball-screw axes reach 100-120 m/min; the axis file gives no \
             rapid_rate_mm_min",
        ),
    }
}

/// [`EstimateError::FeedImplausible`] for the first move faster than
/// [`max_plausible_feed_mm_min`].
pub(crate) fn check_feed_plausible(m: &Move, axis: &AxisParams) -> Result<(), EstimateError> {
    let (limit_mm_min, why) = max_plausible_feed_mm_min(axis);
    if let Some(feed_mm_min) = m.feed_mm_min.filter(|&f| f > limit_mm_min) {
        return Err(EstimateError::FeedImplausible {
            feed_mm_min,
            limit_mm_min,
            why,
            start_time_s: m.start_time_s,
            start_mm: m.start_mm,
            end_mm: m.end_mm,
        });
    }
    Ok(())
}

/// Segment a trace into moves, classify them and pick the strokes to estimate.
///
/// # Errors
/// [`EstimateError::NoStroke`], [`EstimateError::NoMeasuringStroke`],
/// [`EstimateError::BadSamplesPerLead`], [`EstimateError::FeedImplausible`].
pub fn plan(
    trace: &Trace,
    axis: &AxisParams,
    params: &EstimateParams,
) -> Result<Plan, EstimateError> {
    if params.samples_per_lead == 0 {
        return Err(EstimateError::BadSamplesPerLead);
    }
    let move_spans = segment::find_moves(&trace.position_m, &params.segment);
    let (mut moves, note) = moves::classify(&trace.position_m, &move_spans, axis.rapid_rate_mm_min);
    for m in &moves {
        check_feed_plausible(m, axis)?;
    }
    let mut notes: Vec<Diagnostic> = note.into_iter().collect();
    if !params.program.is_empty() {
        notes.extend(moves::label_with_program(&mut moves, &params.program));
    }
    let mut spans = Vec::new();
    let mut steady = 0;
    for (m, ms) in moves.iter_mut().zip(&move_spans) {
        steady += ms.strokes.len();
        let wanted = match m.kind {
            MoveKind::Measuring => true,
            MoveKind::Rapid | MoveKind::Jog => params.include_rapids,
            MoveKind::Positioning => false,
        };
        if wanted {
            for sp in &ms.strokes {
                m.strokes.push(spans.len());
                spans.push(sp.clone());
            }
        }
    }
    if spans.is_empty() {
        if steady == 0 {
            return Err(EstimateError::NoStroke {
                min_stroke_mm: params.segment.min_stroke_mm,
                min_knots: params.segment.min_knots,
            });
        }
        let count = |k| moves.iter().filter(|m| m.kind == k).count();
        return Err(EstimateError::NoMeasuringStroke {
            rapid: count(MoveKind::Rapid),
            jog: count(MoveKind::Jog),
            positioning: count(MoveKind::Positioning),
        });
    }
    Ok(Plan {
        spans,
        moves,
        notes,
    })
}

/// Why a stroke found by segmentation was not estimated.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Skip {
    /// Fewer than four effort samples inside it.
    TooFewEffortSamples,
    /// The settling margins after the ramps leave too little steady travel (mm).
    TooShortToSettle {
        /// Travel left after the margins (mm).
        left_mm: f64,
        /// Settling margin at each end (s).
        margin_s: f64,
    },
}

impl std::fmt::Display for Skip {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::TooFewEffortSamples => write!(f, "too few effort samples inside it"),
            Self::TooShortToSettle { left_mm, margin_s } => write!(
                f,
                "too short to settle: the smoothed position needs {margin_s:.3} s after the \
                 acceleration ramp and before the deceleration, which leaves {left_mm:.2} mm"
            ),
        }
    }
}

/// What [`estimate_stroke`] made of a stroke.
#[derive(Debug, Clone, PartialEq)]
pub enum StrokeOutcome {
    /// Its friction.
    Estimated(Box<StrokeFriction>),
    /// Why it was left out.
    Skipped(Skip),
}

/// An effort that is zero everywhere, or one constant value across strokes of both directions,
/// holds no friction (a channel not wired, a drive that does not report it).
fn check_effort_informative(trace: &Trace, planned: &Plan) -> Result<(), EstimateError> {
    let v = &trace.effort.value;
    let Some(&first) = v.first() else {
        return Ok(());
    };
    // Exactly one value: a channel that never changed, not one that changed a little.
    #[allow(clippy::float_cmp)]
    let constant = v.iter().all(|&e| e == first);
    let both = planned
        .spans
        .iter()
        .any(|s| s.direction == Direction::Forward)
        && planned
            .spans
            .iter()
            .any(|s| s.direction == Direction::Backward);
    if constant && (first == 0.0 || both) {
        return Err(EstimateError::EffortWithoutInformation {
            channel: trace.effort_kind.column(),
            value: first,
            samples: v.len(),
        });
    }
    Ok(())
}

/// How the friction of `trace` gets its sign under `params`.
pub fn friction_sign(trace: &Trace, params: &EstimateParams) -> FrictionSign {
    let magnitude = match params.effort_sign {
        EffortSign::Signed | EffortSign::Negated => false,
        EffortSign::Magnitude => true,
        EffortSign::Auto => trace.facts.effort_signed == Some(false),
    };
    if magnitude {
        FrictionSign::FromDirection
    } else {
        FrictionSign::Signed
    }
}

/// The measuring strokes' mean friction per direction, weighted by stroke length.
#[derive(Debug, Default)]
struct DirectionMeans {
    /// (Σ mean·length, Σ length) of forward and of backward strokes.
    forward: (f64, f64),
    backward: (f64, f64),
    /// Σ damping force·length of forward and of backward strokes (N·mm): the axis file's
    /// 4π²B/p² times the signed feed, the term Eq. 5 subtracts from the drive's force.
    forward_damping: f64,
    backward_damping: f64,
}

impl DirectionMeans {
    fn add(&mut self, dir: Direction, mean_n: f64, length_mm: f64, damping_n: f64) {
        let (slot, d) = match dir {
            Direction::Forward => (&mut self.forward, &mut self.forward_damping),
            Direction::Backward => (&mut self.backward, &mut self.backward_damping),
        };
        slot.0 += mean_n * length_mm;
        slot.1 += length_mm;
        *d += damping_n * length_mm;
    }

    /// The mean damping force of each direction's strokes (N, signed with the motion).
    fn damping_means_n(&self) -> (f64, f64) {
        (
            self.forward_damping / self.forward.1,
            self.backward_damping / self.backward.1,
        )
    }

    /// Friction along the motion in both directions, and the drive's own force (friction plus
    /// damping, the inertia averaging out over a steady stroke) with the motion in both: the
    /// effort's sign is right and the axis file's damping is what turns the friction round.
    fn damping_turns_friction_round(&self) -> bool {
        let (df, db) = self.damping_means_n();
        self.assist_both_ways()
            && self.forward_mean_n() + df > 0.0
            && self.backward_mean_n() + db < 0.0
    }

    fn forward_mean_n(&self) -> f64 {
        self.forward.0 / self.forward.1
    }

    fn backward_mean_n(&self) -> f64 {
        self.backward.0 / self.backward.1
    }

    /// Both directions measured, and friction along the motion in each.
    fn assist_both_ways(&self) -> bool {
        self.forward.1 > 0.0
            && self.backward.1 > 0.0
            && self.forward_mean_n() < 0.0
            && self.backward_mean_n() > 0.0
    }
}

/// What limits a whole recording, from its facts and its samples (the per-stroke reasons are
/// in each stroke's verdict).
fn recording_reasons(
    trace: &Trace,
    params: &EstimateParams,
    backward_positive: bool,
    means: &DirectionMeans,
    effort_never_negative: bool,
) -> Vec<Diagnostic> {
    let mut out = Vec::new();
    let f = &trace.facts;
    if friction_sign(trace, params) == FrictionSign::Signed && means.damping_turns_friction_round()
    {
        let (df, db) = means.damping_means_n();
        out.push(Diagnostic::new(
            Code::DampingExceedsDriveForce,
            format!(
                "friction pushes the table along in both directions (mean {:.1} N on forward \
                 strokes, {:+.1} N on backward ones) only because the axis file's damping \
                 (damping_nms_per_rad) takes {:.1} N and {:+.1} N off them, more than the \
                 drive's whole force: the damping is far too large (a servo motor's viscous \
                 damping is about 1e-4 to 1e-1 N·m·s/rad); correct damping_nms_per_rad, or \
                 set it to 0 to take the viscous part into the friction; until then every \
                 friction value here is wrong",
                means.forward_mean_n(),
                means.backward_mean_n(),
                df,
                db
            ),
        ));
    } else if friction_sign(trace, params) == FrictionSign::Signed && means.assist_both_ways() {
        // A constant force (gravity, a counterweight) adds the same sign to both directions,
        // so it can make one direction's friction look negative, never both: friction that
        // pushes the table along in both directions is an effort counted against the position.
        let hint = if params.effort_sign == EffortSign::Negated {
            "the effort was negated (`--effort-sign negated`) but already counted with the \
             position: estimate with `--effort-sign signed`"
        } else {
            "the drive counts its current or torque against the position (negative for motion \
             towards +z): estimate with `--effort-sign negated`"
        };
        out.push(Diagnostic::new(
            Code::EffortSignReversed,
            format!(
                "friction pushes the table along in both directions (mean {:.1} N on forward \
                 strokes, {:+.1} N on backward ones, where friction opposes the motion): {hint}; \
                 until then every friction value here has the wrong sign and the inertia term \
                 the wrong weight against it",
                means.forward_mean_n(),
                means.backward_mean_n()
            ),
        ));
    }
    if friction_sign(trace, params) == FrictionSign::FromDirection {
        out.push(Diagnostic::new(
            Code::EffortUnsigned,
            "the effort is a magnitude: friction takes the sign of the direction of motion; \
             a force that assists the motion (gravity on a vertical axis) cannot be told apart",
        ));
    } else if backward_positive && effort_never_negative {
        out.push(Diagnostic::new(
            Code::EffortMaybeUnsigned,
            "the effort is never negative and backward strokes have positive friction: if the \
             effort is a magnitude (a drive load), say so with `--effort-sign magnitude` (or \
             import it with `feedscope import`, which records it)",
        ));
    }
    if let Some(q) = f.effort_quantum {
        out.push(Diagnostic::new(
            Code::EffortQuantised,
            format!(
                "the effort is recorded in steps of {q:.4} {}: its rounding enters every \
                 standard error",
                match trace.effort_kind {
                    EffortKind::CurrentA => "A",
                    EffortKind::TorqueNm => "N·m",
                }
            ),
        ));
    }
    if f.process_load == Some(true) {
        out.push(Diagnostic::new(
            Code::ProcessLoad,
            "the recording is of production work: the effort may hold cutting load, so only \
             each stroke's mean motor force is reported, as an upper bound of friction",
        ));
    }
    if let Some(n) = f.recordings.filter(|&n| n > 1) {
        out.push(Diagnostic::new(
            Code::PiecedRecording,
            format!("the trace is pieced together from {n} recordings"),
        ));
    }
    out
}

/// Force per unit of effort (N per A or N per N·m), Eq. 5's first term.
fn effort_gain(axis: &AxisParams, kind: EffortKind) -> f64 {
    match kind {
        EffortKind::CurrentA => axis.force_per_torque_n_per_nm() * axis.torque_constant_nm_per_a,
        EffortKind::TorqueNm => axis.force_per_torque_n_per_nm(),
    }
}

/// RMS of the values about their mean.
fn rms_about_mean(v: &[f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    (v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / v.len() as f64).sqrt()
}

/// A stroke's mean friction is resolved when it lies more than this many standard errors from
/// zero (about 95 % two-sided); otherwise the stroke gets the `mean-not-resolved` warning.
pub const MEAN_RESOLVED_SE: f64 = 2.0;

/// Standard error of the mean of `n` effort samples of robust noise `std` and quantum `q`, in
/// the effort's unit (see [`StrokeSummary::mean_friction_se_n`]): the noise over √n, and the
/// rounding's bias that the dither σ_d² = std² − q²/12 leaves. Under Gaussian dither the mean
/// rounding error's k-th harmonic falls as exp(−2π²k²σ_d²/q²); its first, scaled to the
/// undithered q/√12, bounds the bias: at σ_d = q/2 it is 0.7 % of q/√12.
///
/// A quantum the recording declares (`declared_q`, e.g. a drive load in whole percent) keeps
/// its full q/√12: how the drive rounds (to nearest, or down) is not known, so its bias is
/// not assumed to average out.
fn mean_se(std: f64, q: f64, declared_q: f64, n: usize) -> f64 {
    let noise = std * std / n.max(1) as f64;
    let declared = declared_q * declared_q / 12.0;
    if q <= 0.0 {
        return (noise + declared).sqrt();
    }
    let dither = (std * std - q * q / 12.0).max(0.0);
    let bias = q * q / 12.0 * (-4.0 * std::f64::consts::PI.powi(2) * dither / (q * q)).exp();
    (noise + bias.max(declared)).sqrt()
}

/// Estimate one stroke (step 1-7), with the position treatment chosen from its samples
/// ([`floor`]).
///
/// # Errors
/// Spline failures and non-finite results.
pub fn estimate_stroke(
    trace: &Trace,
    axis: &AxisParams,
    params: &EstimateParams,
    index: usize,
    span: &StrokeSpan,
) -> Result<StrokeOutcome, EstimateError> {
    estimate_stroke_pieces(trace, axis, params, index, span, usize::MAX, &mut |_| {
        unreachable!("no piece is handed out when a stroke is kept whole")
    })
}

/// As [`estimate_stroke`], but handing the resampled rows to `emit` in pieces of
/// `piece_points` rows while the stroke is estimated, so that a long stroke's results need
/// not be held whole. The pieces' summaries are provisional (stroke number, direction, feed,
/// noise floor); the returned stroke holds the rows after the last piece (at least one) and
/// the complete summary, with its mean and scatter over every row.
///
/// # Errors
/// As [`estimate_stroke`], or what `emit` returns.
pub fn estimate_stroke_pieces<E: From<EstimateError>>(
    trace: &Trace,
    axis: &AxisParams,
    params: &EstimateParams,
    index: usize,
    span: &StrokeSpan,
    piece_points: usize,
    emit: &mut dyn FnMut(StrokeFriction) -> Result<(), E>,
) -> Result<StrokeOutcome, E> {
    let pos = &trace.position_m;
    let ts = &pos.time_s[span.first..=span.last];
    let zs_raw = &pos.value[span.first..=span.last];
    let (t_lo, t_hi) = (ts[0], ts[ts.len() - 1]);
    let te_all = &trace.effort.time_s;
    let e0 = te_all.partition_point(|&t| t < t_lo);
    let e1 = te_all.partition_point(|&t| t <= t_hi);
    if e1 < e0 + crate::trace::MIN_SAMPLES {
        return Ok(StrokeOutcome::Skipped(Skip::TooFewEffortSamples));
    }
    let lead = axis.lead_m();
    let m_eq = axis.equivalent_mass_kg();
    let b_eq = axis.equivalent_damping_n_s_per_m();
    let gain = effort_gain(axis, trace.effort_kind);
    let dir = span.direction;
    let s = dir.sign();
    // A magnitude takes the sign of the motion; the noise terms use |gain|.
    let force_gain = match friction_sign(trace, params) {
        FrictionSign::Signed if params.effort_sign == EffortSign::Negated => -gain,
        FrictionSign::Signed => gain,
        FrictionSign::FromDirection => gain * s,
    };

    // What the stroke's own samples say about their noise (floor module, step 1).
    let h = (t_hi - t_lo) / (ts.len() - 1) as f64;
    let ee_span = &trace.effort.value[e0..e1];
    // The effort's resolution: what its samples show, or what the recording declares (a whole
    // percent of load rounds however the signal moves), whichever is coarser.
    let effort_std = floor::robust_noise_std(&te_all[e0..e1], ee_span);
    let effort_step = floor::smallest_step(ee_span);
    let effort_q_seen = floor::quantum_from_step(ee_span, effort_step);
    // A coarse quantum can hold a whole steady stroke on one value, which shows no step: the
    // steps are then seen in the ramps of the enclosing move (turning point to turning point).
    let (m0, m1) = (pos.time_s[span.move_first], pos.time_s[span.move_last]);
    let ev = &trace.effort.value;
    let (f0, f1) = (
        te_all.partition_point(|&t| t < m0),
        te_all.partition_point(|&t| t <= m1),
    );
    // The move's smallest step: the stroke's, and those of the move's parts before and after
    // it (not a second pass over the stroke).
    let move_step = if f0 <= e0 && e1 <= f1 {
        effort_step
            .min(floor::smallest_step(&ev[f0..=e0]))
            .min(floor::smallest_step(&ev[e1 - 1..f1]))
    } else {
        floor::smallest_step(&ev[f0..f1])
    };
    let effort_q_move = floor::quantum_from_step(&ev[f0..f1], move_step);
    let effort_q = effort_q_seen
        .max(effort_q_move)
        .max(trace.facts.effort_quantum.unwrap_or(0.0));
    let effort_var = (effort_std * effort_std).max(effort_q * effort_q / 12.0);
    let noise = floor::SampleNoise {
        interval_s: h,
        position_var_m2: floor::channel_variance(ts, zs_raw),
        effort_n: gain * effort_var.sqrt(),
    };
    let interp_quant = floor::interpolated_quantisation_n(m_eq, noise.position_var_m2, h);
    let choice = match params.position_smoothing {
        PositionSmoothing::Auto => {
            floor::choose(&noise, m_eq, gain * rms_about_mean(ee_span), t_hi - t_lo)
        }
        PositionSmoothing::CutoffHz(f) if f > 0.0 && f < 0.5 / h => {
            floor::Differentiation::Smooth {
                cutoff_hz: f,
                quantisation_n: floor::smoothed_quantisation_n(m_eq, noise.position_var_m2, h, f),
            }
        }
        _ => floor::Differentiation::Interpolate {
            quantisation_n: interp_quant,
        },
    };
    let (cutoff_hz, quantisation_n) = match choice {
        floor::Differentiation::Interpolate { quantisation_n } => (None, quantisation_n),
        floor::Differentiation::Smooth {
            cutoff_hz,
            quantisation_n,
        } => (Some(cutoff_hz), quantisation_n),
    };

    // The smoother reaches a settling margin beyond the stroke on both sides (never across a
    // reversal), so that its natural ends lie outside the output.
    let (tau, margin_s) = match cutoff_hz {
        Some(f) => {
            let tau = floor::settle_time_constant_s(f);
            (tau, floor::SETTLE_TIME_CONSTANTS * tau)
        }
        None => (0.0, 0.0),
    };
    let extra = if cutoff_hz.is_some() {
        (margin_s / h).ceil() as usize + 2
    } else {
        0
    };
    let k0 = span.first.saturating_sub(extra).max(span.move_first);
    let k1 = (span.last + extra).min(span.move_last).max(span.last);
    let tz = &pos.time_s[k0..=k1];
    let zz = &pos.value[k0..=k1];
    let spline_err = |error| EstimateError::Spline {
        stroke: index,
        channel: "position",
        error,
    };
    let mut z_smooth = Vec::new();
    // A long stroke's smoothed position is solved one window at a time as it is read (the
    // t(z) inversion walks forward), so its values and moments are never held whole; the
    // paper's knot spline for t(z) needs them all at once.
    let windowed = tz.len() > params.spline_window_knots
        && params.time_of_position == TimeOfPosition::Invert
        && tz.len() >= 3;
    let mut zs = match cutoff_hz {
        Some(f_c) if windowed => {
            let h_w = (tz[tz.len() - 1] - tz[0]) / (tz.len() - 1) as f64;
            let alpha = crate::spline::alpha_for_cutoff(h_w, f_c);
            PositionSpline::Windowed(
                crate::spline::WindowedSmoothing::new(tz, zz, alpha, params.spline_window_knots)
                    .map_err(spline_err)?,
            )
        }
        Some(f_c) => {
            let h_w = (tz[tz.len() - 1] - tz[0]) / (tz.len() - 1) as f64;
            let alpha = crate::spline::alpha_for_cutoff(h_w, f_c);
            let m = crate::spline::smoothing_moments_windowed(
                tz,
                zz,
                alpha,
                params.spline_window_knots,
                &mut z_smooth,
            )
            .map_err(spline_err)?;
            PositionSpline::Whole(CubicSpline::from_moments(tz, &z_smooth, m).map_err(spline_err)?)
        }
        None => PositionSpline::Whole(
            CubicSpline::new_windowed(tz, zz, params.end_condition, params.spline_window_knots)
                .map_err(spline_err)?,
        ),
    };

    // Output window: the stroke, and with smoothing only where the ramps have settled.
    let (mut w_lo, mut w_hi) = (t_lo, t_hi);
    let mut inertia_n = 0.0;
    if cutoff_hz.is_some() {
        let n = ts.len() - 1;
        let (q1, q3) = (n / 4, 3 * n / 4);
        let v_mid = s * (zs_raw[q3] - zs_raw[q1]) / (ts[q3] - ts[q1]).max(1e-300);
        // The ramps end where the speed reaches 98 % of the feed held after them: the middle
        // half's mean at a steady feed; where the feed varies along the stroke (a feed
        // override, a modulated feed: its range beyond ±25 %), the fastest quarter of the
        // stroke's first (last) eighth, so that a later change of the feed moves neither end.
        let varies = span.feed_min_m_s < 0.75 * v_mid || span.feed_max_m_s > 1.25 * v_mid;
        let (reach_a, reach_b) = if varies && n >= 32 {
            let mean =
                |a: usize, b: usize| s * (zs_raw[b] - zs_raw[a]) / (ts[b] - ts[a]).max(1e-300);
            let e = n / 8;
            let fastest = |start: usize| {
                (0..4)
                    .map(|k| mean(start + k * e / 4, start + (k + 1) * e / 4))
                    .fold(f64::NEG_INFINITY, f64::max)
            };
            (0.98 * fastest(0), 0.98 * fastest(n - e))
        } else {
            (0.98 * v_mid, 0.98 * v_mid)
        };
        let (i_first, i_last) = (span.first - k0, span.last - k0);
        let mut speed = |i: usize| s * zs.eval_in(i.min(tz.len() - 2), tz[i]).1;
        let ramp_end = (i_first..=i_last).find(|&i| speed(i) >= reach_a);
        let decel_start = (i_first..=i_last).rev().find(|&i| speed(i) >= reach_b);
        let (Some(i_a), Some(i_b)) = (ramp_end, decel_start) else {
            return Ok(StrokeOutcome::Skipped(Skip::TooShortToSettle {
                left_mm: 0.0,
                margin_s,
            }));
        };
        w_lo = tz[i_a] + margin_s;
        w_hi = tz[i_b] - margin_s;
        let left_mm = (w_hi - w_lo) * v_mid * 1e3;
        if w_hi <= w_lo || left_mm < params.segment.min_stroke_mm {
            return Ok(StrokeOutcome::Skipped(Skip::TooShortToSettle {
                left_mm: left_mm.max(0.0),
                margin_s,
            }));
        }
        // The largest jerk of the smoothed ramps, whose transient the margin lets decay to
        // e^(−N): m_eq·j·τ·e^(−N) at the window's edges, spread over it as an RMS.
        let n_m = tz.len();
        let mut jerk = |range: std::ops::Range<usize>| {
            range
                .map(|i| ((zs.moment(i + 1) - zs.moment(i)) / (tz[i + 1] - tz[i])).abs())
                .fold(0.0, f64::max)
        };
        let j = jerk(0..i_a.min(n_m - 1)).max(jerk(i_b.min(n_m - 1)..n_m - 1));
        let edge = m_eq * j * tau * (-floor::SETTLE_TIME_CONSTANTS).exp();
        inertia_n = edge * (tau / (w_hi - w_lo)).min(1.0).sqrt();
    }
    // Effort knots over the whole spline window: no extrapolation of either channel, and the
    // effort spline's ends outside the output too.
    let e0 = te_all.partition_point(|&t| t < tz[0]);
    let e1 = te_all.partition_point(|&t| t <= tz[tz.len() - 1]);
    let te = &te_all[e0..e1];
    let ee = &trace.effort.value[e0..e1];
    // A long stroke's effort spline is solved one window at a time as the grid walks forward
    // (its moments would otherwise be held whole); a short one at once.
    let effort_err = |error| EstimateError::Spline {
        stroke: index,
        channel: trace.effort_kind.column(),
        error,
    };
    let es_whole;
    let mut effort_at = if te.len() > params.spline_window_knots {
        EffortEval::Windowed(
            crate::spline::WindowedSpline::new(
                te,
                ee,
                params.end_condition,
                params.spline_window_knots,
            )
            .map_err(effort_err)?,
        )
    } else {
        es_whole = CubicSpline::new(te, ee, params.end_condition).map_err(effort_err)?;
        EffortEval::Whole(es_whole.cursor())
    };
    w_lo = w_lo.max(te[0]);
    w_hi = w_hi.min(te[te.len() - 1]);
    let step = lead / f64::from(params.samples_per_lead);
    // Position range covered by the window, on the spline (exact at knots, else evaluated).
    let (z_a, z_b) = (zs.eval(w_lo), zs.eval(w_hi));
    // Grid indices strictly inside [z_a, z_b] in the direction of travel.
    let (k_first, k_last): (i64, i64) = match dir {
        Direction::Forward => ((z_a / step).ceil() as i64, (z_b / step).floor() as i64),
        Direction::Backward => ((z_a / step).floor() as i64, (z_b / step).ceil() as i64),
    };
    // Bound the grid before allocating six arrays of it: positions in µm read as mm, or a
    // lead of 1e-5 mm, would ask for gigabytes from a few kilobytes of trace.
    let points = ((z_b - z_a).abs() / step).floor() + 1.0;
    let limit = MAX_GRID_POINTS_FLOOR.max(MAX_GRID_POINTS_PER_SAMPLE * ts.len());
    if points.is_nan() || points > limit as f64 {
        return Err(EstimateError::GridTooLarge {
            stroke: index,
            length_mm: (z_b - z_a).abs() * 1e3,
            lead_mm: axis.lead_mm,
            samples_per_lead: params.samples_per_lead,
            points,
            samples: ts.len(),
            limit,
        }
        .into());
    }
    let count = ((k_last - k_first) as f64 * s) as i64 + 1;
    let mut warnings = Vec::new();
    if count < 2 {
        return Ok(StrokeOutcome::Skipped(Skip::TooFewEffortSamples));
    }
    let count = count as usize;
    let feed_m_s = span.plateau_speed_m_s;
    let mut out = StrokeFriction {
        summary: StrokeSummary {
            stroke: index,
            kind: MoveKind::Measuring,
            direction: dir,
            feed_mm_min: feed_m_s * 60e3,
            feed_min_mm_min: Some(span.feed_min_m_s * 60e3),
            feed_max_mm_min: Some(span.feed_max_m_s * 60e3),
            start_mm: 0.0,
            end_mm: 0.0,
            length_mm: 0.0,
            start_time_s: 0.0,
            end_time_s: 0.0,
            mean_friction_n: 0.0,
            friction_std_n: 0.0,
            position_samples: ts.len(),
            effort_samples: ee_span.len(),
            points: count,
            raw_samples_per_lead: 0.0,
            max_order: 0.0,
            position_cutoff_hz: cutoff_hz,
            position_cutoff_order: cutoff_hz.map(|f| f * lead / feed_m_s),
            settle_margin_s: margin_s,
            noise_floor: NoiseFloor::new(quantisation_n, noise.effort_n, inertia_n),
            mean_friction_se_n: Some(
                gain * mean_se(
                    effort_std,
                    effort_q,
                    trace.facts.effort_quantum.unwrap_or(0.0),
                    ee_span.len(),
                ),
            ),
            effort_quantum_n: gain * effort_q,
            verdict: None,
            program_line: None,
            programmed_feed_mm_min: None,
            warnings: Vec::new(),
        },
        position_m: Vec::new(),
        time_s: Vec::new(),
        velocity_m_s: Vec::new(),
        accel_m_s2: Vec::new(),
        effort: Vec::new(),
        friction_n: Vec::new(),
    };
    // Rows held at once: the whole stroke, or a piece and the block being filled.
    let held = if count > piece_points {
        piece_points + 256
    } else {
        count
    };
    for col in out.columns_mut() {
        col.reserve_exact(held);
    }
    // Rows already handed out, the first row's position and time, and the scatter of their
    // friction about the first value (shifted sums: the mean is not known until the end).
    let mut emitted = 0usize;
    let mut first_row = None;
    let (mut shift, mut s1, mut s2) = (0.0, 0.0, 0.0);
    // t(z) by the paper's knot spline, when asked for: a spline through (s·z_k, t_k), since its
    // abscissae must increase for either direction.
    let knot_x: Vec<f64> = match params.time_of_position {
        TimeOfPosition::Invert => Vec::new(),
        TimeOfPosition::KnotSpline => (0..tz.len()).map(|k| s * zs.value(k)).collect(),
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
    let knot_cursor = knot_spline.as_ref().map(|k| k.cursor());
    let k_int = zs.interval(w_lo);
    let mut walk = GridWalk {
        k_first: k_first as f64,
        s,
        step,
        w_lo,
        w_hi,
        force_gain,
        m_eq,
        b_eq,
        knot_cursor,
        k_int,
        non_monotone: false,
        t_prev: w_lo,
        sum: 0.0,
    };
    // The six columns are filled a block at a time in arrays on the stack, each block then
    // appended with one copy per column: six pushes per point re-read and re-stored six
    // lengths and checked six capacities, a sizeable share of the loop's instructions.
    let mut cols = [[0.0f64; BLOCK]; 6];
    // Feed changes inside the stroke faster than the smoothing resolves (`transient`).
    let mut transients = cutoff_hz.map(|fc| {
        transient::TransientScan::new(m_eq, out.summary.noise_floor.total_n, fc, feed_m_s)
    });
    // The cubics of the knot intervals a block spans (see `GridWalk::invert`).
    let mut table = PieceTable::new();
    let mut j0 = 0;
    while j0 < count {
        let len = BLOCK.min(count - j0);
        let (block, sc) = (&mut cols, &mut *table);
        // One loop per kind of spline, chosen once a block (see `KnotRead`).
        let filled = match (&mut zs, &mut effort_at) {
            (PositionSpline::Whole(z), EffortEval::Whole(e)) => walk.fill(z, e, j0, len, block, sc),
            (PositionSpline::Whole(z), EffortEval::Windowed(e)) => {
                walk.fill(z, e, j0, len, block, sc)
            }
            (PositionSpline::Windowed(z), EffortEval::Whole(e)) => {
                walk.fill(z, e, j0, len, block, sc)
            }
            (PositionSpline::Windowed(z), EffortEval::Windowed(e)) => {
                walk.fill(z, e, j0, len, block, sc)
            }
        };
        if let Err(zg) = filled {
            return Err(EstimateError::NonFinite {
                stroke: index,
                quantity: "friction_n",
                position_mm: zg * 1e3,
            }
            .into());
        }
        if let Some(scan) = &mut transients {
            scan.push(&cols[0][..len], &cols[2][..len], &cols[3][..len]);
        }
        for (col, dst) in cols.iter().zip(out.columns_mut()) {
            dst.extend_from_slice(&col[..len]);
        }
        j0 += len;
        if out.friction_n.len() >= piece_points && j0 < count {
            if first_row.is_none() {
                first_row = Some((out.position_m[0], out.time_s[0]));
                shift = out.friction_n[0];
            }
            for f in &out.friction_n {
                let d = f - shift;
                s1 += d;
                s2 += d * d;
            }
            let mut piece = StrokeFriction {
                summary: out.summary.clone(),
                position_m: Vec::new(),
                time_s: Vec::new(),
                velocity_m_s: Vec::new(),
                accel_m_s2: Vec::new(),
                effort: Vec::new(),
                friction_n: Vec::new(),
            };
            for (src, dst) in out.columns_mut().into_iter().zip(piece.columns_mut()) {
                *dst = std::mem::replace(src, Vec::with_capacity(held));
            }
            emitted += piece.friction_n.len();
            emit(piece)?;
        }
    }
    if let (Some(scan), Some(fc)) = (transients, cutoff_hz) {
        let found = scan.finish();
        if !found.is_empty() {
            warnings.push(feed_changes_unresolved(&found, fc, feed_m_s, s));
        }
    }
    if walk.non_monotone {
        warnings.push(Diagnostic::new(
            Code::PositionNotMonotone,
            "the position spline is not monotone somewhere in this stroke (noisy or coarsely \
             quantised position at a low feed); t(z) took the nearest solution",
        ));
    }
    let mean = walk.sum / count as f64;
    let var = if emitted == 0 {
        out.friction_n
            .iter()
            .map(|f| (f - mean) * (f - mean))
            .sum::<f64>()
            / count as f64
    } else {
        for f in &out.friction_n {
            let d = f - shift;
            s1 += d;
            s2 += d * d;
        }
        let m1 = s1 / count as f64;
        (s2 / count as f64 - m1 * m1).max(0.0)
    };
    let (z_first, t_first) = first_row.unwrap_or((out.position_m[0], out.time_s[0]));
    let tail = out.friction_n.len();
    let (z_last, t_last) = (out.position_m[tail - 1], out.time_s[tail - 1]);
    let travel = (z_last - z_first).abs();
    // Raw samples per lead of each channel over the stroke.
    let mut z_span = |a: f64, b: f64| (zs.eval(b) - zs.eval(a)).abs().max(1e-12);
    let spl_z =
        (ts.len() - 1) as f64 * lead / (zs_raw[zs_raw.len() - 1] - zs_raw[0]).abs().max(1e-12);
    let spl_e = (te.len() - 1) as f64 * lead / z_span(te[0], te[te.len() - 1]);
    let spl = spl_z.min(spl_e);
    let sm = &mut out.summary;
    sm.start_mm = z_first * 1e3;
    sm.end_mm = z_last * 1e3;
    sm.length_mm = travel * 1e3;
    sm.start_time_s = t_first;
    sm.end_time_s = t_last;
    sm.mean_friction_n = mean;
    sm.friction_std_n = var.sqrt();
    sm.raw_samples_per_lead = spl;
    sm.max_order = spl / 2.5;
    if let Some(se) = sm.mean_friction_se_n {
        // Within two standard errors of zero the stroke says nothing about its friction, not
        // even its sign: the table would print it like any other mean.
        if mean.is_nan() || mean.abs() <= MEAN_RESOLVED_SE * se {
            warnings.push(Diagnostic::new(
                Code::MeanNotResolved,
                format!(
                    "the mean friction {mean:.2} N lies within {MEAN_RESOLVED_SE} standard \
                     errors ({se:.2} N) of zero: this stroke does not resolve its friction \
                     (the effort varies along it far more than friction does: process load, \
                     or too few samples for its noise)"
                ),
            ));
        }
    }
    let feed_mm_min = feed_m_s * 60e3;
    if spl < 8.0 {
        warnings.push(Diagnostic::new(
            Code::FewSamplesPerLead,
            format!(
                "only {spl:.1} raw samples per lead: fluctuation above order {:.1} cannot be \
             trusted; sample faster or feed slower (below {:.0} mm/min for 8 samples per lead)",
                spl / 2.5,
                feed_mm_min * spl / 8.0
            ),
        ));
    }
    if let Some(order) = sm.position_cutoff_order {
        if order < sm.max_order {
            sm.max_order = order;
            let (highest, cause) = highest_expected_order(axis);
            if order < highest {
                warnings.push(Diagnostic::new(
                    Code::PositionSmoothedBelowOrder,
                    format!(
                        "the position is smoothed above {:.1} Hz, order {order:.1} at this feed: \
                     the table acceleration of higher orders is not resolved, so their \
                     amplitudes lack the inertia term ({cause} at order {highest:.1} is among \
                     them); finer position quanta, faster sampling or a slower feed resolve more",
                        sm.position_cutoff_hz.unwrap_or(0.0)
                    ),
                ));
            }
        }
    }
    // The floor against the variation it has to be seen against: friction_std² holds both.
    let fl = sm.noise_floor;
    let variation = (sm.friction_std_n.powi(2) - fl.total_n.powi(2))
        .max(0.0)
        .sqrt();
    if fl.total_n > 0.1 * variation {
        // With no variation left above the floor a percentage means nothing.
        let share = if variation > 1e-3 * fl.total_n {
            format!(
                "is {:.0} % of the friction variation along this stroke ({variation:.2} N RMS)",
                100.0 * fl.total_n / variation
            )
        } else {
            "holds all of the friction variation along this stroke".to_string()
        };
        warnings.push(Diagnostic::new(
            Code::NoiseFloorHigh,
            format!(
                "predicted noise floor {:.2} N RMS (position quantisation {:.2}, effort noise \
             {:.2}, inertia {:.2}) {share}: the profile is only good to about ±{:.1} N",
                fl.total_n,
                fl.quantisation_n,
                fl.effort_n,
                fl.inertia_n,
                2.0 * fl.total_n
            ),
        ));
    }
    sm.verdict = Some(judge_stroke(&StrokeEvidence {
        length_leads: travel / lead,
        max_order: sm.max_order,
        floor_n: fl.total_n,
        mean_n: mean,
        process_load: trace.facts.process_load == Some(true),
    }));
    sm.warnings = warnings;
    Ok(StrokeOutcome::Estimated(Box::new(out)))
}

/// The position spline of a stroke as the estimator reads it: held whole, or (a long stroke's
/// smoothed position) solved one window at a time as it is read.
enum PositionSpline<'a> {
    Whole(CubicSpline<'a>),
    Windowed(crate::spline::WindowedSmoothing<'a>),
}

impl<'a> PositionSpline<'a> {
    #[inline(always)]
    fn value(&mut self, k: usize) -> f64 {
        match self {
            Self::Whole(s) => s.y()[k],
            Self::Windowed(w) => w.value(k),
        }
    }

    fn moment(&mut self, k: usize) -> f64 {
        match self {
            Self::Whole(s) => s.moments()[k],
            Self::Windowed(w) => w.moment(k),
        }
    }

    #[inline]
    fn eval_in(&mut self, k: usize, t: f64) -> (f64, f64, f64) {
        match self {
            Self::Whole(s) => s.eval_in(k, t),
            Self::Windowed(w) => w.eval_in(k, t),
        }
    }

    fn interval(&self, t: f64) -> usize {
        match self {
            Self::Whole(s) => s.interval(t),
            Self::Windowed(w) => w.interval(t),
        }
    }

    fn eval_all(&mut self, t: f64) -> (f64, f64, f64) {
        let k = self.interval(t);
        self.eval_in(k, t)
    }

    fn eval(&mut self, t: f64) -> f64 {
        self.eval_all(t).0
    }
}

/// The effort spline of a stroke as the grid loop reads it.
enum EffortEval<'s, 'a> {
    Whole(crate::spline::Cursor<'s, 'a>),
    Windowed(crate::spline::WindowedSpline<'a>),
}

/// A position spline read by knot index, as the t(z) inversion walks it. The grid loop is
/// generic over it (and over [`EffortRead`]) so that each kind of spline gets a loop of its
/// own: dispatching on [`PositionSpline`] at every read kept the current piece in memory,
/// stored in halves and reloaded whole, which stalled store forwarding once a point.
trait KnotRead<'a> {
    /// The knots' abscissae (s).
    fn x(&self) -> &'a [f64];
    /// The spline's value at knot k (m).
    fn value(&mut self, k: usize) -> f64;
    /// The cubic of interval k.
    fn piece(&mut self, k: usize) -> crate::spline::Piece;
    /// Value, first and second derivative at t (s) on interval k.
    fn eval_in(&mut self, k: usize, t: f64) -> (f64, f64, f64);
    /// The interval holding t (s), clamped to the end intervals.
    fn interval(&self, t: f64) -> usize;
    /// Whether [`fill_table`](Self::fill_table) holds intervals in a [`PieceTable`]: else
    /// the inversion reads pieces one at a time, in the order it needs them (a windowed
    /// spline solves a window whenever a read leaves the one held).
    const TABLE: bool = false;
    /// Hold intervals `first..first + intervals` (at most [`PieceTable::INTERVALS`]) in
    /// `table` ([`TABLE`](Self::TABLE) splines only).
    fn fill_table(&mut self, _first: usize, _intervals: usize, _table: &mut PieceTable) {
        unreachable!("a spline without a piece table")
    }
    /// The first interval from k on, up to `limit`, whose right knot's value does not lie
    /// short of `zg` in the direction of travel (`FORWARD`), else `limit` (k ≤ `limit` ≤ the
    /// last interval).
    #[inline(always)]
    fn advance<const FORWARD: bool>(&mut self, mut k: usize, limit: usize, zg: f64) -> usize {
        while k < limit && short_of::<FORWARD>(self.value(k + 1), zg) {
            k += 1;
        }
        k
    }
}

/// Whether a spline value z lies short of the grid position zg in the direction of travel
/// (`FORWARD`): for s = ±1, s·(z − z_g) < 0 is exactly z < z_g forward and z > z_g backward.
#[inline(always)]
fn short_of<const FORWARD: bool>(z: f64, zg: f64) -> bool {
    if FORWARD {
        z < zg
    } else {
        z > zg
    }
}

impl<'a> KnotRead<'a> for CubicSpline<'a> {
    #[inline(always)]
    fn x(&self) -> &'a [f64] {
        CubicSpline::x(self)
    }
    #[inline(always)]
    fn value(&mut self, k: usize) -> f64 {
        self.y()[k]
    }
    #[inline(always)]
    fn piece(&mut self, k: usize) -> crate::spline::Piece {
        CubicSpline::piece(self, k)
    }
    #[inline(always)]
    fn eval_in(&mut self, k: usize, t: f64) -> (f64, f64, f64) {
        CubicSpline::eval_in(self, k, t)
    }
    #[inline(always)]
    fn interval(&self, t: f64) -> usize {
        CubicSpline::interval(self, t)
    }
    const TABLE: bool = true;
    #[inline(always)]
    fn fill_table(&mut self, first: usize, intervals: usize, table: &mut PieceTable) {
        CubicSpline::fill_table(self, first, intervals, table);
    }
    #[inline(always)]
    fn advance<const FORWARD: bool>(&mut self, k: usize, limit: usize, zg: f64) -> usize {
        // The values at knots k + 1..=limit, one bounds check for the lot.
        let ahead = &self.y()[k + 1..=limit];
        k + ahead
            .iter()
            .position(|&z| !short_of::<FORWARD>(z, zg))
            .unwrap_or(ahead.len())
    }
}

impl<'a> KnotRead<'a> for crate::spline::WindowedSmoothing<'a> {
    #[inline(always)]
    fn x(&self) -> &'a [f64] {
        crate::spline::WindowedSmoothing::x(self)
    }
    #[inline(always)]
    fn value(&mut self, k: usize) -> f64 {
        crate::spline::WindowedSmoothing::value(self, k)
    }
    #[inline(always)]
    fn piece(&mut self, k: usize) -> crate::spline::Piece {
        crate::spline::WindowedSmoothing::piece(self, k)
    }
    #[inline(always)]
    fn eval_in(&mut self, k: usize, t: f64) -> (f64, f64, f64) {
        crate::spline::WindowedSmoothing::eval_in(self, k, t)
    }
    #[inline(always)]
    fn interval(&self, t: f64) -> usize {
        crate::spline::WindowedSmoothing::interval(self, t)
    }
}

/// The effort spline read at non-decreasing times, as the grid loop reads it.
trait EffortRead {
    /// The effort at times `ts` (s), in its unit, into `es`.
    fn eval_block(&mut self, ts: &[f64], es: &mut [f64], table: &mut PieceTable);
}

impl EffortRead for crate::spline::Cursor<'_, '_> {
    #[inline(always)]
    fn eval_block(&mut self, ts: &[f64], es: &mut [f64], table: &mut PieceTable) {
        crate::spline::Cursor::eval_block(self, ts, es, table);
    }
}

impl EffortRead for crate::spline::WindowedSpline<'_> {
    #[inline(always)]
    fn eval_block(&mut self, ts: &[f64], es: &mut [f64], _: &mut PieceTable) {
        for (&t, e) in ts.iter().zip(es) {
            *e = crate::spline::WindowedSpline::eval(self, t);
        }
    }
}

/// Grid points filled at a time by [`GridWalk::fill`].
const BLOCK: usize = 256;

/// The resampling of one stroke on the position grid (steps 3-6) between blocks of points:
/// the grid, the output window, Eq. 5's constants, where the t(z) inversion stands and the
/// running sum of the friction.
struct GridWalk<'s, 'a> {
    /// Index of the first grid point: point j lies at (k_first + s·j)·step.
    k_first: f64,
    /// The direction's sign.
    s: f64,
    /// Grid step lead/m (m).
    step: f64,
    /// Output window (s).
    w_lo: f64,
    w_hi: f64,
    /// Force per unit of effort, signed as the friction is (N per A or N per N·m).
    force_gain: f64,
    /// Equivalent mass (kg) and damping (N·s/m) of Eq. 5.
    m_eq: f64,
    b_eq: f64,
    /// t(z) from the paper's knot spline, when asked for; else the inversion below.
    knot_cursor: Option<crate::spline::Cursor<'s, 'a>>,
    /// Knot interval of the last point.
    k_int: usize,
    /// Whether the inversion found no bracketing interval somewhere.
    non_monotone: bool,
    /// Time of the last point (s).
    t_prev: f64,
    /// Sum of the friction so far (N).
    sum: f64,
}

impl GridWalk<'_, '_> {
    /// Resample grid points `j0..j0 + len` into `cols` (position m, time s, velocity m/s,
    /// acceleration m/s², effort, friction N by Eq. 5).
    ///
    /// # Errors
    /// The grid position (m) of the first point whose friction is not finite.
    #[inline(never)]
    fn fill<'a, Z: KnotRead<'a>, E: EffortRead>(
        &mut self,
        zs: &mut Z,
        effort: &mut E,
        j0: usize,
        len: usize,
        cols: &mut [[f64; BLOCK]; 6],
        table: &mut PieceTable,
    ) -> Result<(), f64> {
        let (force_gain, m_eq, b_eq) = (self.force_gain, self.m_eq, self.b_eq);
        match self.knot_cursor.take() {
            Some(mut ks) => {
                self.fill_knot_spline(zs, &mut ks, j0, len, cols);
                self.knot_cursor = Some(ks);
            }
            // The direction as a constant: the interval search compares instead of forming
            // s·(z − z_g), and each loop keeps only its own comparison.
            None if self.s > 0.0 => self.invert::<true, Z>(zs, j0, len, cols, table),
            None => self.invert::<false, Z>(zs, j0, len, cols, table),
        }
        // The effort, then Eq. 5, in passes of their own over the block: each loop is short
        // enough that the processor overlaps several points' dependency chains (t(z)'s
        // divisions and Newton steps, then the effort's seek and cubic), which one long loop
        // body did not let it do. Eq. 5 keeps the running sum: in a loop of its own (Eq. 5
        // then vectorises) the chain of additions was all the loop did, and it took longer.
        let [zgs, ts, vs, accs, es, fs] = cols;
        let (es, fs) = (&mut es[..len], &mut fs[..len]);
        effort.eval_block(&ts[..len], es, table);
        let mut sum = self.sum;
        for i in 0..len {
            let f = force_gain * es[i] - m_eq * accs[i] - b_eq * vs[i];
            if !f.is_finite() {
                return Err(zgs[i]);
            }
            sum += f;
            fs[i] = f;
        }
        self.sum = sum;
        Ok(())
    }

    /// The first pass of [`fill`](Self::fill) by t(z) inversion: position, time, velocity and
    /// acceleration of points `j0..j0 + len` (`FORWARD`: the direction of travel).
    ///
    /// The intervals the block spans are known before its points: the walk passes them on its
    /// way to the last point's. When they fit a [`PieceTable`], their cubics are formed there
    /// together (grid points come about once an interval, so forming each point's cubic as it
    /// arrived cost a division and a dozen loads and checks a point), and the walk steps
    /// through the table by offsets.
    #[inline(always)]
    fn invert<'a, const FORWARD: bool, Z: KnotRead<'a>>(
        &mut self,
        zs: &mut Z,
        j0: usize,
        len: usize,
        cols: &mut [[f64; BLOCK]; 6],
        table: &mut PieceTable,
    ) {
        let tz = zs.x();
        let last = tz.len().saturating_sub(2);
        let (w_lo, w_hi) = (self.w_lo, self.w_hi);
        let (k_first, s, step) = (self.k_first, self.s, self.step);
        let [zgs, ts, vs, accs, _, _] = cols;
        // The walk's state rides in locals through the block.
        let mut k_int = self.k_int;
        let mut solve = Solve {
            tz,
            w_lo,
            w_hi,
            t_prev: self.t_prev,
            non_monotone: false,
        };
        // j as a float: exact below 2⁵³, and cheaper to step than to convert.
        let mut jf = j0 as f64;
        for zg in &mut zgs[..len] {
            *zg = (k_first + s * jf) * step;
            jf += 1.0;
        }
        let zgs = &zgs[..len];
        // The walk advances while the next knot lies short of the target, and the targets
        // advance too (step > 0), so the block spans the intervals up to the last point's.
        // Where that interval's end is not short of the last target, no point's walk passes
        // it, and the walk through the table needs no bound.
        let spanned = match zgs.last() {
            Some(&zg_last) if Z::TABLE && step > 0.0 => {
                let limit = (k_int + PieceTable::INTERVALS - 1).min(last);
                let k_end = zs.advance::<FORWARD>(k_int, limit, zg_last);
                (!short_of::<FORWARD>(zs.value(k_end + 1), zg_last)).then_some(k_end)
            }
            _ => None,
        };
        if let Some(k_end) = spanned {
            // The walk by offsets into the table.
            let first = k_int;
            zs.fill_table(first, k_end - first + 1, table);
            let mut o = 0;
            for (i, &zg) in zgs.iter().enumerate() {
                while short_of::<FORWARD>(table.value(o + 1), zg) {
                    o += 1;
                }
                let (t, v, a) = solve.at(zs, first + o, &table.piece(o), table.value(o + 1), zg);
                ts[i] = t;
                vs[i] = v;
                accs[i] = a;
            }
            k_int = first + o;
        } else {
            // Points sparser than knots (or a spline without a table): a piece when the
            // interval changes.
            let mut held: Option<(usize, Piece)> = None;
            for (i, &zg) in zgs.iter().enumerate() {
                k_int = zs.advance::<FORWARD>(k_int, last, zg);
                let p = match held {
                    Some((k, p)) if k == k_int => p,
                    _ => {
                        let p = zs.piece(k_int);
                        held = Some((k_int, p));
                        p
                    }
                };
                let z1 = zs.value(k_int + 1);
                let (t, v, a) = solve.at(zs, k_int, &p, z1, zg);
                ts[i] = t;
                vs[i] = v;
                accs[i] = a;
            }
        }
        (self.k_int, self.t_prev) = (k_int, solve.t_prev);
        self.non_monotone |= solve.non_monotone;
    }

    /// The first pass of [`fill`](Self::fill) with t(z) from the paper's knot spline.
    fn fill_knot_spline<'a, Z: KnotRead<'a>>(
        &mut self,
        zs: &mut Z,
        ks: &mut crate::spline::Cursor<'_, '_>,
        j0: usize,
        len: usize,
        cols: &mut [[f64; BLOCK]; 6],
    ) {
        let [zgs, ts, vs, accs, _, _] = cols;
        let (k_first, s, step) = (self.k_first, self.s, self.step);
        let mut jf = j0 as f64;
        for i in 0..len {
            let zg = (k_first + s * jf) * step;
            jf += 1.0;
            let t = ks.eval(s * zg).clamp(self.w_lo, self.w_hi);
            let (_, v, a) = zs.eval_in(zs.interval(t), t);
            self.t_prev = t;
            zgs[i] = zg;
            ts[i] = t;
            vs[i] = v;
            accs[i] = a;
        }
    }
}

/// t(z) at one grid point after another, as [`GridWalk::invert`] solves it.
struct Solve<'a> {
    /// The position spline's knots (s).
    tz: &'a [f64],
    /// Output window (s).
    w_lo: f64,
    w_hi: f64,
    /// Time of the last point (s).
    t_prev: f64,
    /// Whether the inversion found no bracketing interval somewhere.
    non_monotone: bool,
}

impl<'a> Solve<'a> {
    /// Time, velocity and acceleration where the position spline reaches zg (m), on interval
    /// k, whose cubic is p and right knot's value z1.
    #[inline(always)]
    fn at<Z: KnotRead<'a>>(
        &mut self,
        zs: &mut Z,
        k: usize,
        p: &Piece,
        z1: f64,
        zg: f64,
    ) -> (f64, f64, f64) {
        let (t, v, a) = match newton_in_piece(p, z1, zg) {
            Some((u, v, a)) => (p.x0 + u, v, a),
            None => {
                // Not monotone here: the safeguarded search over neighbours.
                let guess = self.t_prev.max(self.tz[k]);
                let (t, k, ok) = invert_in(zs, k, zg, guess, self.w_lo, self.w_hi);
                self.non_monotone |= !ok;
                let (_, v, a) = zs.eval_in(k, t);
                (t, v, a)
            }
        };
        self.t_prev = t;
        (t, v, a)
    }
}

/// Newton's method for z(x0 + u) = target inside one monotone piece, started from linear
/// interpolation between the piece's ends (`z1` is the value at its right knot). Returns
/// (u, z', z'') or `None` when the piece does not bracket the target monotonically (then
/// [`invert_in`] takes over).
#[inline(always)]
fn newton_in_piece(p: &crate::spline::Piece, z1: f64, target: f64) -> Option<(f64, f64, f64)> {
    let dz = z1 - p.c0;
    if dz == 0.0 {
        return None;
    }
    let frac = (target - p.c0) / dz;
    if !(0.0..=1.0).contains(&frac) {
        return None;
    }
    // The sign of the rise as a constant: each slope test is then one comparison.
    if dz > 0.0 {
        chord_newton::<true>(p, frac, target)
    } else {
        chord_newton::<false>(p, frac, target)
    }
}

/// The iteration of [`newton_in_piece`] from `frac` of the way along piece p, on a piece
/// that rises (`RISING`) or falls from its left knot to its right.
#[inline(always)]
fn chord_newton<const RISING: bool>(
    p: &crate::spline::Piece,
    frac: f64,
    target: f64,
) -> Option<(f64, f64, f64)> {
    let mut u = frac * p.h;
    // Chord-Newton: the slope from the start point is kept, which trades one division per
    // step for a slightly slower (still fast: the start is within O(h²) of the root)
    // convergence. Steps below 1e-13 of the interval are rounding noise.
    let tol = 1e-13 * p.h;
    // One evaluation per step: the start's slope fixes the chord, each new point's values are
    // both the next residual and, once the step is below tolerance, the answer.
    let (mut z, d1_0, _) = p.eval(u);
    if d1_0 == 0.0 || (d1_0 > 0.0) != RISING {
        return None;
    }
    let inv_d1 = 1.0 / d1_0;
    // No contraction estimate before the second step (NaN fails every comparison).
    let mut du_prev = f64::NAN;
    for _ in 0..16 {
        let du = (z - target) * inv_d1;
        u -= du;
        let (z_new, d1, d2) = p.eval(u);
        z = z_new;
        if (d1 > 0.0) != RISING {
            return None;
        }
        // The chord iteration contracts by ρ per step, so the error left after this step is
        // about |du|·ρ/(1 − ρ): stop as soon as that, or the step itself, is below tolerance.
        // The ratio is formed only when the step alone does not decide: the first step nearly
        // always does, and the division cost every point.
        if du.abs() <= tol || {
            let rho = (du / du_prev).abs();
            rho < 0.5 && du.abs() * rho <= 0.5 * tol
        } {
            if !(-tol..=p.h + tol).contains(&u) {
                return None;
            }
            return Some((u, d1, d2));
        }
        du_prev = du;
    }
    None
}

/// Solve z(t) = target on knot interval k (then its neighbours) by Newton steps safeguarded
/// with bisection. Returns the time, the interval holding it, and whether a bracketing
/// interval was found.
fn invert_in<'a>(
    zs: &mut impl KnotRead<'a>,
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
) -> Result<Outline, E> {
    estimate_map_streaming(trace, axis, params, batch, |s| s, sink)
}

/// As [`estimate_streaming`], but `map` runs on each stroke inside the parallel section (e.g.
/// to format it for output), and `sink` receives what `map` returns, in time order. A long
/// stroke (see [`estimate_pieces_streaming`]) is joined from its pieces before `map` sees it.
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
) -> Result<Outline, E> {
    let mut current: Option<StrokeFriction> = None;
    estimate_pieces_streaming(
        trace,
        axis,
        params,
        batch,
        |s| s,
        |piece| match piece {
            StrokePiece::Rows(s) => {
                match &mut current {
                    Some(c) => c.append_rows(s),
                    None => current = Some(s),
                }
                Ok(())
            }
            StrokePiece::End(summary) => match current.take() {
                Some(mut s) => {
                    s.summary = *summary;
                    sink(map(s))
                }
                None => unreachable!("every stroke hands out rows before its end"),
            },
        },
    )
}

/// What [`estimate_pieces_streaming`] hands out, in time order: each estimated stroke's rows
/// (one piece, or several for a long stroke), then its summary.
#[derive(Debug)]
pub enum StrokePiece<T> {
    /// Consecutive resampled rows of the stroke, as `map` made them of a [`StrokeFriction`]
    /// whose summary is final for a stroke in one piece and provisional (number, direction,
    /// feed, noise floor) for the pieces of a long one.
    Rows(T),
    /// The stroke's rows are all out: its complete summary.
    End(Box<StrokeSummary>),
}

/// Estimate every stroke and hand the results out as they are made, in time order, in
/// [`StrokePiece`]s: strokes of up to [`EstimateParams::spline_window_knots`] position samples
/// run `batch` at a time in parallel, each handed out whole; a longer stroke is estimated on
/// the calling thread with windowed spline solves and handed out in pieces of
/// [`EstimateParams::piece_points`] rows while it is estimated, so that memory holds a piece
/// of its results, not the whole stroke (`map` runs on each piece, e.g. to format it).
///
/// # Errors
/// As [`estimate`], or what `sink` returns.
pub fn estimate_pieces_streaming<T: Send, E: From<EstimateError>>(
    trace: &Trace,
    axis: &AxisParams,
    params: &EstimateParams,
    batch: usize,
    map: impl Fn(StrokeFriction) -> T + Sync,
    mut sink: impl FnMut(StrokePiece<T>) -> Result<(), E>,
) -> Result<Outline, E> {
    let planned = plan(trace, axis, params)?;
    check_effort_informative(trace, &planned)?;
    let mut seen = Seen::default();
    let batch = batch.max(1);
    let mut k = 0;
    while k < planned.spans.len() {
        let end = next_chunk(&planned.spans, k, batch, params.spline_window_knots);
        estimate_chunk(
            trace,
            axis,
            params,
            &planned.spans[k..end],
            k,
            &planned.moves,
            &map,
            &mut sink,
            &mut seen,
        )
        .map_err(|e| match e {
            Failed::Estimate(e) => E::from(e),
            Failed::Sink(e) => e,
        })?;
        k = end;
    }
    if !seen.any {
        let strokes = planned.spans.len();
        return Err(match seen.first_skip {
            Some(why) if why != Skip::TooFewEffortSamples => EstimateError::NoneEstimated {
                strokes,
                reason: why.to_string(),
            },
            _ => EstimateError::NoEffortInStrokes {
                strokes,
                min_samples: crate::trace::MIN_SAMPLES,
            },
        }
        .into());
    }
    Ok(Outline {
        zones: segment::zones_between(&trace.position_m, &planned.spans),
        moves: planned.moves,
        skipped: seen.skipped,
        notes: planned.notes,
        verdict: DataVerdict::from_strokes(
            &seen.verdicts,
            friction_sign(trace, params),
            recording_reasons(
                trace,
                params,
                seen.any_backward_positive,
                &seen.means,
                trace.effort.value.iter().all(|&e| e >= 0.0),
            ),
        ),
    })
}

/// What the strokes handed out so far tell about the recording as a whole.
#[derive(Default)]
struct Seen {
    any: bool,
    verdicts: Vec<StrokeVerdict>,
    any_backward_positive: bool,
    means: DirectionMeans,
    skipped: Vec<String>,
    first_skip: Option<Skip>,
}

impl Seen {
    fn stroke(&mut self, s: &StrokeSummary, axis: &AxisParams) {
        self.any = true;
        self.verdicts.extend(s.verdict.clone());
        self.any_backward_positive |= s.direction == Direction::Backward && s.mean_friction_n > 0.0;
        if s.kind == MoveKind::Measuring {
            let v_m_s = crate::units::feed_mm_min_to_m_s(s.feed_mm_min) * s.direction.sign();
            let damping_n = axis.equivalent_damping_n_s_per_m() * v_m_s;
            self.means
                .add(s.direction, s.mean_friction_n, s.length_mm, damping_n);
        }
    }

    fn skip(&mut self, trace: &Trace, k: usize, span: &StrokeSpan, why: Skip) {
        if self.first_skip.is_none() {
            self.first_skip = Some(why.clone());
        }
        self.skipped.push(format!(
            "stroke {k} ({}, {:.1} to {:.1} mm): {why}",
            span.direction.as_str(),
            trace.position_m.value[span.first] * 1e3,
            trace.position_m.value[span.last] * 1e3
        ));
    }
}

/// The end of the chunk of strokes from `k` that [`estimate_chunk`] takes next: a long stroke
/// (more than `window` position samples) alone, else up to `batch` short ones, stopping before
/// a long one.
fn next_chunk(spans: &[StrokeSpan], k: usize, batch: usize, window: usize) -> usize {
    let long = |s: &StrokeSpan| s.last - s.first + 1 > window;
    if long(&spans[k]) {
        return k + 1;
    }
    (k..spans.len())
        .take(batch)
        .find(|&j| long(&spans[j]))
        .unwrap_or(k.saturating_add(batch).min(spans.len()))
}

/// What failed while strokes were estimated: the estimation, or the sink.
enum Failed<E> {
    Estimate(EstimateError),
    Sink(E),
}

impl<E> From<EstimateError> for Failed<E> {
    fn from(e: EstimateError) -> Self {
        Self::Estimate(e)
    }
}

/// Label a stroke's summary with the kind and program block of its move.
fn label(s: &mut StrokeSummary, m: &Move) {
    s.kind = m.kind;
    s.program_line = m.program_line;
    s.programmed_feed_mm_min = m.programmed_feed_mm_min;
}

/// Estimate a chunk of [`next_chunk`] (strokes numbered from `first`, spans indexing
/// `trace`) and hand the results to `sink` in order, as [`estimate_pieces_streaming`]
/// describes: one long stroke in pieces on this thread, or short ones in parallel, each whole.
/// Skipped strokes and what the strokes tell go to `seen`.
#[allow(clippy::too_many_arguments)]
fn estimate_chunk<T: Send, E>(
    trace: &Trace,
    axis: &AxisParams,
    params: &EstimateParams,
    spans: &[StrokeSpan],
    first: usize,
    moves: &[Move],
    map: &(impl Fn(StrokeFriction) -> T + Sync + ?Sized),
    sink: &mut (impl FnMut(StrokePiece<T>) -> Result<(), E> + ?Sized),
    seen: &mut Seen,
) -> Result<(), Failed<E>> {
    if let [span] = spans {
        if span.last - span.first + 1 > params.spline_window_knots {
            let m = &moves[span.move_index];
            let outcome = estimate_stroke_pieces(
                trace,
                axis,
                params,
                first,
                span,
                params.piece_points,
                &mut |mut piece: StrokeFriction| -> Result<(), Failed<E>> {
                    label(&mut piece.summary, m);
                    sink(StrokePiece::Rows(map(piece))).map_err(Failed::Sink)
                },
            )?;
            match outcome {
                StrokeOutcome::Estimated(mut s) => {
                    label(&mut s.summary, m);
                    let summary = Box::new(s.summary.clone());
                    seen.stroke(&summary, axis);
                    sink(StrokePiece::Rows(map(*s))).map_err(Failed::Sink)?;
                    sink(StrokePiece::End(summary)).map_err(Failed::Sink)?;
                }
                StrokeOutcome::Skipped(why) => seen.skip(trace, first, span, why),
            }
            return Ok(());
        }
    }
    let results: Vec<_> = spans
        .par_iter()
        .enumerate()
        .map(|(i, span)| {
            estimate_stroke(trace, axis, params, first + i, span).map(|o| match o {
                StrokeOutcome::Estimated(mut s) => {
                    label(&mut s.summary, &moves[span.move_index]);
                    let summary = Box::new(s.summary.clone());
                    Ok((summary, map(*s)))
                }
                StrokeOutcome::Skipped(why) => Err(why),
            })
        })
        .collect();
    for (i, r) in results.into_iter().enumerate() {
        match r? {
            Ok((summary, t)) => {
                seen.stroke(&summary, axis);
                sink(StrokePiece::Rows(t)).map_err(Failed::Sink)?;
                sink(StrokePiece::End(summary)).map_err(Failed::Sink)?;
            }
            Err(why) => seen.skip(trace, first + i, &spans[i], why),
        }
    }
    Ok(())
}

/// The warning for feed changes inside a stroke that the position cut-off `fc` (Hz) does not
/// resolve ([`transient`]); `feed_m_s` the stroke's feed, `s` its direction's sign.
fn feed_changes_unresolved(
    found: &[transient::FeedChange],
    fc: f64,
    feed_m_s: f64,
    s: f64,
) -> Diagnostic {
    const LISTED: usize = 6;
    let reach_mm = 2.0 * feed_m_s / fc * 1e3;
    let mut at: Vec<String> = found
        .iter()
        .take(LISTED)
        .map(|c| {
            format!(
                "{:.1} mm ({:+.0} mm/min)",
                c.position_m * 1e3,
                s * c.delta_v_m_s * 60e3
            )
        })
        .collect();
    if found.len() > LISTED {
        at.push(format!("and {} more", found.len() - LISTED));
    }
    let peak = found.iter().map(|c| c.peak_inertia_n).fold(0.0, f64::max);
    Diagnostic::new(
        Code::FeedChangeUnresolved,
        format!(
            "the feed changed inside the stroke faster than the position smoothing resolves \
             (cut-off {fc:.1} Hz) at {}: the effort shows the inertia of each change at once, \
             the smoothed acceleration spreads it over about {:.0} ms (up to {peak:.0} N), so \
             the friction within about ±{reach_mm:.2} mm of each is off; the rest of the stroke \
             is not affected. A gentler override change, finer position quanta or faster \
             sampling (a higher cut-off) narrow it",
            at.join(", "),
            1e3 / fc
        ),
    )
}

/// The order a friction fluctuation of this axis is expected to reach (cycles per lead) and
/// what causes it: the shaft orders 1-4, the ball-refeed orders of nut and guides (paper 000
/// Eq. 7) with their second harmonics, the groups of significant components of paper 000
/// section 4.1.2, and the declared orders. Without the geometry of nut or guides, order 10,
/// where the refeed orders of common drives lie (z/2 of 14-30 balls a turn, less the
/// contact-angle term).
fn highest_expected_order(axis: &AxisParams) -> (f64, String) {
    use crate::order::{kinematic_orders, Cause};
    // The kinematic orders less the refeeds' third harmonics, which section 4.1.2 does not
    // find significant.
    let kin = kinematic_orders(axis);
    let geometry = kin
        .iter()
        .any(|k| matches!(k.cause, Cause::NutRefeed(_) | Cause::GuideRefeed(_)));
    let mut best = if geometry {
        (0.0, String::new())
    } else {
        (
            10.0,
            "the ball refeed of a typical nut or guide (no geometry in the axis file)".to_string(),
        )
    };
    for k in kin {
        let significant = !matches!(k.cause, Cause::NutRefeed(h) | Cause::GuideRefeed(h) if h > 2);
        if significant && k.order.is_finite() && k.order > best.0 {
            best = (k.order, k.cause.to_string());
        }
    }
    best
}

#[cfg(test)]
mod tests;

impl EstimateError {
    /// Always [`crate::ErrorKind::BadInput`]: every variant says why these data (or parameters) give
    /// no estimate.
    pub fn kind(&self) -> crate::ErrorKind {
        crate::ErrorKind::BadInput
    }
}
