//! From a trace to the strokes to estimate: segmentation, move classification and the
//! checks that refuse a trace before any stroke is estimated.

#[cfg(doc)]
use super::estimate_stroke;
use super::{
    moves, segment, Direction, EstimateError, EstimateParams, Move, MoveKind, StrokeFriction,
    StrokeSpan,
};
use crate::axis::AxisParams;
use crate::diag::Diagnostic;
use crate::trace::Trace;

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
pub(super) fn check_effort_informative(trace: &Trace, planned: &Plan) -> Result<(), EstimateError> {
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
