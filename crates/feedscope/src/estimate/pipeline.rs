//! The estimation of a whole trace, stroke after stroke in batches, handed out as the results
//! are made; what the strokes tell about the recording as a whole.

use rayon::prelude::*;

#[cfg(doc)]
use super::estimate;
use super::plan::check_effort_informative;
use super::{
    estimate_stroke, estimate_stroke_pieces, friction_sign, plan, segment, Direction, EffortSign,
    EstimateError, EstimateParams, Move, MoveKind, Outline, Skip, StrokeFriction, StrokeOutcome,
    StrokeSpan, StrokeSummary,
};
use crate::axis::AxisParams;
use crate::diag::{Code, Diagnostic};
use crate::trace::{EffortKind, Trace};
use crate::verdict::{DataVerdict, FrictionSign, StrokeVerdict};

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
pub(super) struct Seen {
    pub(super) any: bool,
    pub(super) verdicts: Vec<StrokeVerdict>,
    pub(super) any_backward_positive: bool,
    pub(super) means: DirectionMeans,
    pub(super) skipped: Vec<String>,
    pub(super) first_skip: Option<Skip>,
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
pub(super) fn next_chunk(spans: &[StrokeSpan], k: usize, batch: usize, window: usize) -> usize {
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
pub(super) enum Failed<E> {
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
pub(super) fn estimate_chunk<T: Send, E>(
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

/// The measuring strokes' mean friction per direction, weighted by stroke length.
#[derive(Debug, Default)]
pub(super) struct DirectionMeans {
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
pub(super) fn recording_reasons(
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
