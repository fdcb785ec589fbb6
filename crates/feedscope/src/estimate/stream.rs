//! Friction estimated while the trace is read: each stroke as soon as the reversal after it
//! has come in, with memory that holds the move being read and the strokes waiting for their
//! batch, not the file.
//!
//! [`estimate_pieces_streaming`](super::estimate_pieces_streaming) needs the whole trace for
//! three things; a stream fixes them early and checks them at the end:
//! - **Segmentation** takes the position quantum and the turning-point hysteresis ε from the
//!   first [`StreamEstimator::PREFIX_SAMPLES`] position samples (module `segment`, step 1). At
//!   the end the whole trace's quantum and ε are known: the turning-point finder kept the
//!   largest retreat it let pass and the smallest it took for a reversal, and the whole
//!   trace's ε lying between them makes every decision the same; each move's chord width is
//!   recomputed with the whole trace's quantum.
//! - **Glitch screening** ([`crate::trace::glitch`]) tests each sample against the last kept
//!   one with a slack of twice the typical sampling interval. The stream keeps the largest
//!   excess of a step over the speed limit; when it stays below the slack that the mean
//!   interval alone gives (the typical one is never smaller), the screen drops nothing.
//! - **Rapids** are told by the axis' rapid rate; without one, by comparing every move's top
//!   speed, so a move at or above 3,000 mm/min cannot be classified before the end.
//!
//! When any check fails, or when the trace is one the whole-trace path would refuse, the
//! stream ends with [`Streamed::Redo`] and the reason: the caller discards what it wrote and
//! estimates from the whole trace, which gives the exact result or error. Otherwise every
//! stroke, move, zone and verdict is bit for bit what the whole-trace path gives (tested on the
//! twin's traces).

use super::moves::{self, INFERRED_RAPID_MIN_MM_MIN};
use super::pipeline::{estimate_chunk, next_chunk, recording_reasons, Failed, Seen};
use super::segment::{self, MoveScratch, StrokeSpan, TurnFinder};
use super::{friction_sign, EstimateParams, Move, MoveKind, Outline, StrokeFriction, StrokePiece};
use crate::axis::AxisParams;
use crate::trace::glitch::{EffortMagnitudes, GlitchParams, JUMP_FLOOR_M};
use crate::trace::{Channel, EffortKind, RecordingFacts, Trace, MIN_SAMPLES};
use crate::verdict::DataVerdict;

/// How a stream ended.
#[derive(Debug)]
pub enum Streamed {
    /// Every check held: the outline of the trace, as the whole-trace path gives it.
    Done(Outline),
    /// The streamed result cannot be vouched for (the reason says why): estimate from the
    /// whole trace instead.
    Redo(String),
    /// The prefix's segmentation statistics differ from the whole trace's in a way that
    /// changes strokes: stream again with these ([`StreamEstimator::with_segmentation`]).
    Again(Segmentation),
}

/// The statistics segmentation takes from the whole trace (module `segment`, step 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segmentation {
    /// The smallest non-zero position step (m).
    pub quantum_m: f64,
    /// The lowest and highest position (m).
    pub low_m: f64,
    /// See `low_m`.
    pub high_m: f64,
}

/// The segmentation of a stream once its prefix has fixed the quantum and ε.
struct Segmenter {
    /// Position quantum of the prefix (m).
    quantum: f64,
    finder: TurnFinder,
    /// The next position sample (global index) the finder has not seen.
    next: usize,
    /// The last turning point (global index): where the move being read began.
    turn: Option<usize>,
    scratch: MoveScratch,
    /// Each move's travel (m) and sample intervals, to recheck its chord width with the
    /// whole trace's quantum.
    widths: Vec<(f64, usize)>,
    /// The largest travel between turning points too small for a move, and the smallest
    /// kept (m).
    dropped_max: f64,
    kept_min: f64,
}

/// Estimates friction from a trace handed in piece by piece, in time order (module docs).
pub struct StreamEstimator<'a, T, E> {
    axis: &'a AxisParams,
    params: &'a EstimateParams,
    glitch: GlitchParams,
    batch: usize,
    map: &'a (dyn Fn(StrokeFriction) -> T + Sync),
    sink: &'a mut dyn FnMut(StrokePiece<T>) -> Result<(), E>,
    prefix_samples: usize,
    /// Statistics given for the whole trace instead of a prefix's.
    given: Option<Segmentation>,
    /// The whole trace's statistics differ from those in use.
    again: bool,
    /// The samples still needed: positions from global index `base`, efforts from the time of
    /// that sample.
    buf: Trace,
    base: usize,
    /// Position and effort samples seen.
    n_pos: usize,
    n_effort: usize,
    // Whole-trace statistics, kept as samples pass.
    step_min: f64,
    low: f64,
    high: f64,
    first: (f64, f64),
    last: (f64, f64),
    /// Largest |Δz| − v_lim·Δt between consecutive position samples (m).
    worst_excess: f64,
    effort_first: Option<f64>,
    effort_constant: bool,
    effort_never_negative: bool,
    /// |effort| of every sample so far, for the effort glitch screen's bound.
    effort_magnitudes: EffortMagnitudes,
    seg: Option<Segmenter>,
    /// Why the stream gave up, once it has.
    redo: Option<String>,
    moves: Vec<Move>,
    /// Strokes to estimate (global knot indices); a stroke's number is its index.
    spans: Vec<StrokeSpan>,
    /// Steady strokes in all moves, estimated or not.
    steady: usize,
    /// The next stroke to estimate.
    next_stroke: usize,
    /// Time and position of the strokes' end knots (global index), for the zones.
    ends: std::collections::BTreeMap<usize, (f64, f64)>,
    seen: Seen,
}

impl<'a, T: Send, E> StreamEstimator<'a, T, E> {
    /// Position samples that fix the quantum and ε (about 1 s at 1 MHz, 4 h at 70 ms).
    pub const PREFIX_SAMPLES: usize = 1 << 20;

    /// A stream of a trace whose effort is `effort_kind` and whose source says `facts`,
    /// screened with `glitch` as the trace readers screen it; strokes are estimated `batch`
    /// at a time and handed to `sink` as [`estimate_pieces_streaming`](super::estimate_pieces_streaming)
    /// hands them out.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        axis: &'a AxisParams,
        params: &'a EstimateParams,
        effort_kind: EffortKind,
        facts: RecordingFacts,
        glitch: GlitchParams,
        batch: usize,
        map: &'a (dyn Fn(StrokeFriction) -> T + Sync),
        sink: &'a mut dyn FnMut(StrokePiece<T>) -> Result<(), E>,
    ) -> Self {
        let redo = if !params.program.is_empty() {
            Some("strokes are labelled with an NC program, which needs every move".to_string())
        } else if params.samples_per_lead == 0 {
            Some("no samples per lead".to_string())
        } else {
            None
        };
        Self {
            axis,
            params,
            glitch,
            batch: batch.max(1),
            map,
            sink,
            prefix_samples: Self::PREFIX_SAMPLES,
            given: None,
            again: false,
            buf: Trace {
                position_m: Channel::default(),
                effort: Channel::default(),
                effort_kind,
                facts,
            },
            base: 0,
            n_pos: 0,
            n_effort: 0,
            step_min: f64::INFINITY,
            low: f64::INFINITY,
            high: f64::NEG_INFINITY,
            first: (f64::NAN, f64::NAN),
            last: (f64::NAN, f64::NAN),
            worst_excess: f64::NEG_INFINITY,
            effort_first: None,
            effort_constant: true,
            effort_never_negative: true,
            effort_magnitudes: EffortMagnitudes::default(),
            seg: None,
            redo,
            moves: Vec::new(),
            spans: Vec::new(),
            steady: 0,
            next_stroke: 0,
            ends: std::collections::BTreeMap::new(),
            seen: Seen::default(),
        }
    }

    /// Fix the quantum and ε from the first `n` position samples instead of
    /// [`Self::PREFIX_SAMPLES`] (tests use it to make a short trace long).
    pub fn with_prefix_samples(mut self, n: usize) -> Self {
        self.prefix_samples = n.max(2);
        self
    }

    /// Segment with the whole trace's statistics, known from an earlier pass
    /// ([`Streamed::Again`]), instead of a prefix's.
    pub fn with_segmentation(mut self, s: Segmentation) -> Self {
        self.given = Some(s);
        self
    }

    /// Reserve room for `position` and `effort` samples in all (e.g. the whole file's, from
    /// its size): growing then never copies what is held, and room never used is never
    /// touched, so it costs no memory.
    pub fn reserve(&mut self, position: usize, effort: usize) {
        let (p, e) = (&mut self.buf.position_m, &mut self.buf.effort);
        let more_p = position.saturating_sub(p.len());
        let more_e = effort.saturating_sub(e.len());
        p.time_s.reserve(more_p);
        p.value.reserve(more_p);
        e.time_s.reserve(more_e);
        e.value.reserve(more_e);
    }

    /// Why the stream gave up, if it has: nothing more is estimated, [`Self::finish`] says
    /// [`Streamed::Redo`].
    pub fn gave_up(&self) -> Option<&str> {
        self.redo.as_deref()
    }

    /// The lowest and highest position seen (m).
    pub fn position_range_m(&self) -> (f64, f64) {
        (self.low, self.high)
    }

    /// Hand in the next samples of each channel (times strictly increasing within a channel
    /// and after those handed in before; either may be empty), and estimate every stroke they
    /// complete.
    ///
    /// # Errors
    /// What `sink` returns.
    pub fn push(&mut self, position_m: &Channel, effort: &Channel) -> Result<(), E> {
        if self.redo.is_some() {
            return Ok(());
        }
        self.take_effort(effort);
        self.take_position(position_m);
        if self.seg.is_none() && (self.n_pos >= self.prefix_samples || self.given.is_some()) {
            self.fix_segmentation();
        }
        self.segment(false)?;
        self.drop_used();
        Ok(())
    }

    /// The trace has ended: estimate what is left and check what was fixed early against the
    /// whole trace.
    ///
    /// # Errors
    /// What `sink` returns.
    pub fn finish(mut self) -> Result<Streamed, E> {
        if self.redo.is_none() {
            if self.n_pos < MIN_SAMPLES
                || self.n_effort < MIN_SAMPLES
                || self.high - self.low <= 1e-9
            {
                self.give_up("too few samples or no motion");
            } else {
                if self.seg.is_none() {
                    self.fix_segmentation();
                }
                self.segment(true)?;
            }
        }
        if self.redo.is_none() {
            if let Some(why) = self.whole_trace_disagrees() {
                self.give_up(&why);
            }
        }
        if self.redo.is_none() {
            self.estimate_pending(true)?;
        }
        if let Some(why) = self.redo.take() {
            if self.again && self.given.is_none() {
                return Ok(Streamed::Again(self.whole_segmentation()));
            }
            return Ok(Streamed::Redo(why));
        }
        if !self.seen.any {
            return Ok(Streamed::Redo("no stroke was estimated".into()));
        }
        let (first, last, n) = (self.first, self.last, self.n_pos);
        let ends = &self.ends;
        let zones = segment::zones_of(n, &self.spans, |k| {
            if k == 0 {
                first
            } else if k + 1 == n {
                last
            } else {
                ends[&k]
            }
        });
        let seen = std::mem::take(&mut self.seen);
        let verdict = DataVerdict::from_strokes(
            &seen.verdicts,
            friction_sign(&self.buf, self.params),
            recording_reasons(
                &self.buf,
                self.params,
                seen.any_backward_positive,
                &seen.means,
                self.effort_never_negative,
            ),
        );
        Ok(Streamed::Done(Outline {
            zones,
            moves: std::mem::take(&mut self.moves),
            skipped: seen.skipped,
            notes: Vec::new(),
            verdict,
        }))
    }

    fn give_up(&mut self, why: &str) {
        if self.redo.is_none() {
            self.redo = Some(why.to_string());
        }
    }

    fn take_effort(&mut self, effort: &Channel) {
        for &e in &effort.value {
            let first = *self.effort_first.get_or_insert(e);
            // Exactly one value, as the whole-trace check asks.
            #[allow(clippy::float_cmp)]
            let same = e == first;
            self.effort_constant &= same;
            self.effort_never_negative &= e >= 0.0;
        }
        self.effort_magnitudes.add(&effort.value);
        self.n_effort += effort.len();
        self.buf.effort.time_s.extend_from_slice(&effort.time_s);
        self.buf.effort.value.extend_from_slice(&effort.value);
    }

    fn take_position(&mut self, p: &Channel) {
        let Some((&t0, &z0)) = p.time_s.first().zip(p.value.first()) else {
            return;
        };
        let v = self.glitch.max_axis_speed_m_s;
        let (mut tp, mut zp) = if self.n_pos == 0 {
            self.first = (t0, z0);
            (t0, z0)
        } else {
            self.last
        };
        let (mut q, mut lo, mut hi, mut worst) =
            (self.step_min, self.low, self.high, self.worst_excess);
        for (&t, &z) in p.time_s.iter().zip(&p.value) {
            q = segment::step_min(q, zp, z);
            lo = lo.min(z);
            hi = hi.max(z);
            worst = worst.max((z - zp).abs() - v * (t - tp));
            (tp, zp) = (t, z);
        }
        (self.step_min, self.low, self.high, self.worst_excess) = (q, lo, hi, worst);
        self.last = (tp, zp);
        self.n_pos += p.len();
        self.buf.position_m.time_s.extend_from_slice(&p.time_s);
        self.buf.position_m.value.extend_from_slice(&p.value);
    }

    /// Quantum and ε from the samples read so far (all of them are still held).
    fn fix_segmentation(&mut self) {
        debug_assert_eq!(self.base, 0);
        let z = &self.buf.position_m.value;
        let (quantum, lo, hi) = match self.given {
            Some(g) => (g.quantum_m, g.low_m, g.high_m),
            None => {
                let (lo, hi) = z
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                        (a.min(v), b.max(v))
                    });
                (segment::position_quantum_m(z), lo, hi)
            }
        };
        self.seg = Some(Segmenter {
            quantum,
            finder: TurnFinder::new(segment::hysteresis_of(quantum, lo, hi)),
            next: 0,
            turn: None,
            scratch: MoveScratch::default(),
            widths: Vec::new(),
            dropped_max: 0.0,
            kept_min: f64::INFINITY,
        });
    }

    /// Find the turning points in the samples not yet seen and take in every move they end;
    /// at the `end`, the last move too. Estimates the strokes once a batch is ready.
    fn segment(&mut self, end: bool) -> Result<(), E> {
        let Some(mut seg) = self.seg.take() else {
            return Ok(());
        };
        while seg.next < self.n_pos && self.redo.is_none() {
            let k = seg.next;
            seg.next += 1;
            let v = self.buf.position_m.value[k - self.base];
            if let Some(tp) = seg.finder.push(k, v) {
                if let Some(prev) = seg.turn {
                    self.take_move(&mut seg, prev, tp);
                }
                seg.turn = Some(tp);
            }
        }
        if end && self.redo.is_none() {
            let mut tps: Vec<usize> = seg.turn.into_iter().collect();
            seg.finder.finish(self.n_pos, &mut tps);
            for w in tps.windows(2) {
                self.take_move(&mut seg, w[0], w[1]);
            }
        }
        self.seg = Some(seg);
        if self.redo.is_some() {
            return Ok(());
        }
        let waiting = self.spans.len() - self.next_stroke;
        let long_waiting = self.spans[self.next_stroke..]
            .iter()
            .any(|s| s.last - s.first + 1 > self.params.spline_window_knots);
        if waiting >= self.batch || long_waiting {
            self.estimate_pending(false)?;
        }
        Ok(())
    }

    /// The move between turning points `i0` and `i1` (global indices): classified, and its
    /// strokes queued.
    fn take_move(&mut self, seg: &mut Segmenter, i0: usize, i1: usize) {
        let (t, z) = (&self.buf.position_m.time_s, &self.buf.position_m.value);
        let (r0, r1) = (i0 - self.base, i1 - self.base);
        if i1 <= i0 {
            return;
        }
        // The test `find_moves` makes, with the record of which side of ε each travel fell.
        let travel = (z[r1] - z[r0]).abs();
        if travel <= seg.finder.eps() {
            seg.dropped_max = seg.dropped_max.max(travel);
            return;
        }
        seg.kept_min = seg.kept_min.min(travel);
        let params = &self.params.segment;
        let mut m = segment::move_between(
            t,
            z,
            r0,
            r1,
            seg.quantum,
            params,
            self.moves.len(),
            &mut seg.scratch,
        );
        seg.widths.push((travel, r1 - r0));
        let rapid_above = self.axis.rapid_rate_mm_min.map(moves::rapid_above_rate);
        let top = moves::top_mm_min(&m);
        if rapid_above.is_none() && top >= INFERRED_RAPID_MIN_MM_MIN {
            self.give_up(&format!(
                "a move reaches {top:.0} mm/min and the axis gives no rapid rate: whether it is \
                 a rapid depends on every other move"
            ));
            return;
        }
        let mut mv = moves::classify_one(&self.buf.position_m, &m, rapid_above);
        if super::plan::check_feed_plausible(&mv, self.axis).is_err() {
            // The whole read refuses it, naming the move.
            self.give_up("a move runs faster than a feed axis can");
            return;
        }
        self.steady += m.strokes.len();
        let wanted = match mv.kind {
            MoveKind::Measuring => true,
            MoveKind::Rapid | MoveKind::Jog => self.params.include_rapids,
            MoveKind::Positioning => false,
        };
        if wanted {
            for sp in &mut m.strokes {
                for k in [sp.first, sp.last] {
                    self.ends.insert(k + self.base, (t[k], z[k]));
                }
                sp.first += self.base;
                sp.last += self.base;
                sp.move_first += self.base;
                sp.move_last += self.base;
                mv.strokes.push(self.spans.len());
                self.spans.push(sp.clone());
            }
        }
        self.moves.push(mv);
    }

    /// Estimate the queued strokes, `batch` at a time in parallel (a long stroke alone, in
    /// pieces), and hand them to the sink in order; unless `all`, short strokes at the end
    /// too few for a batch wait for more. An estimation error ends the stream (the whole
    /// read gives it, or the error that comes before it there).
    fn estimate_pending(&mut self, all: bool) -> Result<(), E> {
        while self.next_stroke < self.spans.len() && self.redo.is_none() {
            let k = self.next_stroke;
            let end = next_chunk(&self.spans, k, self.batch, self.params.spline_window_knots);
            // A partial batch of short strokes waits for more, unless everything is due.
            let long =
                self.spans[k].last - self.spans[k].first + 1 > self.params.spline_window_knots;
            if !long && end - k < self.batch && end == self.spans.len() && !all {
                return Ok(());
            }
            let base = self.base;
            let local: Vec<StrokeSpan> = self.spans[k..end]
                .iter()
                .map(|s| StrokeSpan {
                    first: s.first - base,
                    last: s.last - base,
                    move_first: s.move_first - base,
                    move_last: s.move_last - base,
                    ..s.clone()
                })
                .collect();
            let done = estimate_chunk(
                &self.buf,
                self.axis,
                self.params,
                &local,
                k,
                &self.moves,
                self.map,
                self.sink,
                &mut self.seen,
            );
            match done {
                Ok(()) => self.next_stroke = end,
                Err(Failed::Sink(e)) => return Err(e),
                Err(Failed::Estimate(e)) => self.give_up(&format!("stroke {k}: {e}")),
            }
        }
        Ok(())
    }

    /// Forget the samples no stroke still to come can reach: those before the move being read
    /// and before the first stroke waiting for its batch. Done when they are at least half of
    /// what is held, so each sample is moved at most about once.
    fn drop_used(&mut self) {
        let Some(mut keep) = self.seg.as_ref().and_then(|s| s.turn) else {
            return;
        };
        if let Some(s) = self.spans.get(self.next_stroke) {
            keep = keep.min(s.move_first);
        }
        let drop = keep - self.base;
        let held = self.buf.position_m.len();
        if drop < (1 << 16) || 2 * drop < held {
            return;
        }
        let t_keep = self.buf.position_m.time_s[drop];
        let p = &mut self.buf.position_m;
        p.time_s.drain(..drop);
        p.value.drain(..drop);
        let e = &mut self.buf.effort;
        let e_drop = e.time_s.partition_point(|&t| t < t_keep);
        e.time_s.drain(..e_drop);
        e.value.drain(..e_drop);
        self.base = keep;
    }

    /// The segmentation statistics of everything pushed.
    fn whole_segmentation(&self) -> Segmentation {
        Segmentation {
            quantum_m: if self.step_min.is_finite() {
                self.step_min
            } else {
                0.0
            },
            low_m: self.low,
            high_m: self.high,
        }
    }

    /// Why the whole trace would not give what was streamed, if it would not (setting
    /// `again` when only the segmentation statistics are to blame).
    fn whole_trace_disagrees(&mut self) -> Option<String> {
        let seg = self.seg.as_ref()?;
        let (quantum_in_use, eps_in_use) = (seg.quantum, seg.finder.eps());
        // Glitch screening: the slack with the mean interval bounds the screen's from below.
        let n = self.n_pos;
        if n >= 3 {
            let mean_step = (self.last.0 - self.first.0) / (n - 1) as f64;
            let slack = self.glitch.max_axis_speed_m_s * 2.0 * mean_step + JUMP_FLOOR_M;
            // NaN (a non-finite time) fails too.
            let below = self.worst_excess.partial_cmp(&(slack * (1.0 - 1e-9)));
            if !matches!(
                below,
                Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
            ) {
                return Some(
                    "a position step comes near the speed limit: the glitch screen needs the \
                     whole trace"
                        .into(),
                );
            }
        }
        // Effort glitches: the whole read drops samples beyond this bound (the same
        // histogram), and what it drops changes the strokes.
        let m = &self.effort_magnitudes;
        if m.glitch_limit().is_some_and(|l| m.max_abs() > l) {
            return Some(
                "an effort sample lies far beyond the rest: the effort glitch screen needs the \
                 whole trace"
                    .into(),
            );
        }
        // Segmentation: the whole trace's ε must make every decision the prefix's ε made.
        let q = if self.step_min.is_finite() {
            self.step_min
        } else {
            0.0
        };
        let eps = segment::hysteresis_of(q, self.low, self.high);
        let f = &seg.finder;
        let same_turns = f.counter_max <= eps && eps < f.travel_min;
        let same_moves = seg.dropped_max <= eps && eps < seg.kept_min;
        #[allow(clippy::float_cmp)]
        let same_quantum = q == quantum_in_use;
        let same_widths = same_quantum
            || seg.widths.iter().all(|&(dz, len)| {
                segment::chord_samples_of(dz, len, q)
                    == segment::chord_samples_of(dz, len, quantum_in_use)
            });
        if !(same_turns && same_moves) {
            self.again = true;
            return Some(format!(
                "the turning-point hysteresis of the whole trace ({:.3} µm) decides differently \
                 from the prefix's ({:.3} µm)",
                eps * 1e6,
                eps_in_use * 1e6
            ));
        }
        if !same_widths {
            self.again = true;
            return Some(
                "the whole trace's position quantum gives other chord widths than the prefix's"
                    .into(),
            );
        }
        // The whole-trace path refuses these before estimating anything.
        if self.spans.is_empty() {
            return Some(format!(
                "no stroke to estimate ({} steady in all moves)",
                self.steady
            ));
        }
        let both = self
            .spans
            .iter()
            .any(|s| s.direction == super::Direction::Forward)
            && self
                .spans
                .iter()
                .any(|s| s.direction == super::Direction::Backward);
        if self.effort_constant && (self.effort_first == Some(0.0) || both) {
            return Some("the effort never changes".into());
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate::estimate;
    use crate::sim::{simulate, SamplingMode, SimConfig, StrokeConfig};

    /// A twin trace: strokes between `lo` and `hi` mm at the given feeds, with a dwell after
    /// each, sampled as `sampling` says.
    fn twin(
        feeds: &[f64],
        lo: f64,
        hi: f64,
        seed: u64,
        tune: impl Fn(&mut SimConfig),
    ) -> (Trace, AxisParams) {
        let mut c = SimConfig {
            seed,
            ..SimConfig::default()
        };
        c.motion.start_mm = lo;
        c.motion.strokes = feeds
            .iter()
            .enumerate()
            .map(|(k, &f)| StrokeConfig {
                to_mm: if k % 2 == 0 { hi } else { lo },
                feed_mm_min: f,
                dwell_s: 0.3,
            })
            .collect();
        c.truth.interval_ms = 1000.0;
        tune(&mut c);
        let out = simulate(&c, &mut |_| {}).expect("simulation");
        (out.trace, out.truth.axis)
    }

    /// The trace handed to a stream in time slices of `slice_s`, with ε fixed from the first
    /// `prefix` position samples.
    fn streamed(
        trace: &Trace,
        axis: &AxisParams,
        params: &EstimateParams,
        slice_s: f64,
        prefix: usize,
        given: Option<Segmentation>,
    ) -> (Vec<StrokeFriction>, Streamed) {
        let mut out: Vec<StrokeFriction> = Vec::new();
        let mut current: Option<StrokeFriction> = None;
        let map = |s: StrokeFriction| s;
        let mut sink = |p: StrokePiece<StrokeFriction>| -> Result<(), ()> {
            match p {
                StrokePiece::Rows(s) => match &mut current {
                    Some(c) => c.append_rows(s),
                    None => current = Some(s),
                },
                StrokePiece::End(summary) => {
                    let mut s = current.take().expect("rows before the end");
                    s.summary = *summary;
                    out.push(s);
                }
            }
            Ok(())
        };
        let mut st = StreamEstimator::new(
            axis,
            params,
            trace.effort_kind,
            trace.facts,
            GlitchParams::for_axis(axis),
            3,
            &map,
            &mut sink,
        )
        .with_prefix_samples(prefix);
        if let Some(g) = given {
            st = st.with_segmentation(g);
        }
        let slice = |ch: &Channel, a: f64, b: f64| {
            let i = ch.time_s.partition_point(|&t| t < a);
            let j = ch.time_s.partition_point(|&t| t < b);
            Channel {
                time_s: ch.time_s[i..j].to_vec(),
                value: ch.value[i..j].to_vec(),
            }
        };
        let end = trace
            .position_m
            .time_s
            .last()
            .unwrap()
            .max(*trace.effort.time_s.last().unwrap());
        let mut a = f64::NEG_INFINITY;
        let mut b = trace.position_m.time_s[0] + slice_s;
        while a <= end {
            st.push(&slice(&trace.position_m, a, b), &slice(&trace.effort, a, b))
                .unwrap();
            (a, b) = (b, b + slice_s);
        }
        let done = st.finish().unwrap();
        (out, done)
    }

    /// Streamed and whole-trace results are the same, bit for bit, or the stream says why not;
    /// a second pass when the first asks for one. Returns the reason to redo, and whether a
    /// second pass was needed.
    fn same_or_redo(
        trace: &Trace,
        axis: &AxisParams,
        slice_s: f64,
        prefix: usize,
    ) -> (Option<String>, bool) {
        same_or_redo_with(trace, axis, &EstimateParams::default(), slice_s, prefix)
    }

    fn same_or_redo_with(
        trace: &Trace,
        axis: &AxisParams,
        params: &EstimateParams,
        slice_s: f64,
        prefix: usize,
    ) -> (Option<String>, bool) {
        let params = params.clone();
        let whole = estimate(trace, axis, &params);
        let (mut strokes, mut done) = streamed(trace, axis, &params, slice_s, prefix, None);
        let mut again = false;
        if let Streamed::Again(g) = done {
            again = true;
            (strokes, done) = streamed(trace, axis, &params, slice_s, prefix, Some(g));
        }
        let redo = match done {
            Streamed::Done(outline) => {
                let whole = whole.expect("the stream vouched for a trace the whole path refuses");
                assert_eq!(strokes.len(), whole.strokes.len());
                for (s, w) in strokes.iter().zip(&whole.strokes) {
                    assert_eq!(s, w, "stroke {}", w.summary.stroke);
                }
                assert_eq!(outline.moves, whole.moves);
                assert_eq!(outline.zones, whole.zones);
                assert_eq!(outline.skipped, whole.skipped);
                assert_eq!(outline.notes, whole.notes);
                assert_eq!(outline.verdict, whole.verdict);
                None
            }
            Streamed::Redo(why) => Some(why),
            Streamed::Again(_) => Some("a second pass asked for a third".into()),
        };
        (redo, again)
    }

    /// A change to the twin's settings.
    type Tune = Box<dyn Fn(&mut SimConfig)>;

    #[test]
    fn streamed_strokes_are_the_whole_traces_over_a_matrix_of_recordings() {
        // (what, sampling, slice s, prefix as a fraction of the position samples)
        let feeds_slow = [40.0, 40.0, 400.0, 400.0, 2000.0, 2000.0];
        let cases: Vec<(&str, Tune, f64, f64)> = vec![
            (
                "async 5 ms, 0.1 µm, current",
                Box::new(|c: &mut SimConfig| {
                    c.sampling.position.interval_ms = 5.0;
                    c.sampling.position.jitter_ms = 0.2;
                    c.sampling.position.quantum_mm = 1e-4;
                    c.sampling.effort.interval_ms = 5.0;
                    c.sampling.effort.jitter_ms = 0.2;
                    c.sampling.effort.start_offset_ms = 2.5;
                }),
                0.7,
                0.2,
            ),
            (
                "synchronous 8 kHz, 1 µm, torque",
                Box::new(|c: &mut SimConfig| {
                    c.sampling.mode = SamplingMode::Synchronous;
                    c.sampling.synchronous_rate_hz = 8000.0;
                    c.sampling.effort_kind = EffortKind::TorqueNm;
                }),
                0.05,
                0.3,
            ),
            (
                "asynchronous 70 ms polling, 1 µm",
                Box::new(|_c: &mut SimConfig| {}),
                3.0,
                0.25,
            ),
        ];
        for (k, (name, tune, slice_s, prefix)) in cases.iter().enumerate() {
            let (trace, axis) = twin(&feeds_slow, 20.0, 120.0, 7 + k as u64, tune);
            // The prefix covers less than the travel, so ε is fixed from part of it.
            let prefix = (trace.position_m.len() as f64 * prefix) as usize;
            let (redo, again) = same_or_redo(&trace, &axis, *slice_s, prefix);
            assert_eq!(redo, None, "{name}: the stream gave up");
            eprintln!("{name}: second pass {again}");
            // A whole-trace prefix and one slice: the same too, in one pass.
            let (redo, again) = same_or_redo(&trace, &axis, 1e9, usize::MAX / 2);
            assert_eq!((redo, again), (None, false), "{name}");
        }
    }

    #[test]
    fn rapids_stream_with_a_rapid_rate_and_not_without() {
        let fast = |c: &mut SimConfig| {
            c.sampling.position.interval_ms = 2.0;
            c.sampling.effort.interval_ms = 2.0;
            c.sampling.position.jitter_ms = 0.1;
            c.sampling.effort.jitter_ms = 0.1;
        };
        let (trace, mut axis) = twin(&[300.0, 300.0, 12000.0, 12000.0], 0.0, 150.0, 3, fast);
        let n = trace.position_m.len();
        // Without a rapid rate, whether the 12 m/min moves are rapids depends on all moves.
        axis.rapid_rate_mm_min = None;
        let (redo, _) = same_or_redo(&trace, &axis, 0.5, n / 3);
        assert!(redo.is_some_and(|w| w.contains("no rapid rate")));
        // With one, each move is classified as it ends: left out, or kept with --include-rapids.
        for rate in [13000.0, 30000.0] {
            axis.rapid_rate_mm_min = Some(rate);
            for include_rapids in [false, true] {
                let params = EstimateParams {
                    include_rapids,
                    ..EstimateParams::default()
                };
                let (redo, _) = same_or_redo_with(&trace, &axis, &params, 0.5, n / 3);
                assert_eq!(redo, None, "rapid rate {rate}, include {include_rapids}");
            }
        }
    }

    #[test]
    fn long_strokes_stream_in_windows_and_pieces() {
        let (trace, axis) = twin(&[200.0, 200.0, 50.0], 0.0, 60.0, 9, |c| {
            c.sampling.position.interval_ms = 4.0;
            c.sampling.effort.interval_ms = 4.0;
            c.sampling.position.jitter_ms = 0.1;
            c.sampling.effort.jitter_ms = 0.1;
            c.sampling.position.quantum_mm = 1e-4;
        });
        // Strokes of thousands of knots solved in windows of 512 and handed out in pieces.
        let params = EstimateParams {
            spline_window_knots: 512,
            piece_points: 700,
            ..EstimateParams::default()
        };
        let n = trace.position_m.len();
        let (redo, _) = same_or_redo_with(&trace, &axis, &params, 0.9, n / 4);
        assert_eq!(redo, None);
    }

    #[test]
    fn what_the_whole_path_refuses_is_left_to_it() {
        let (mut trace, axis) = twin(&[400.0, 400.0], 0.0, 40.0, 4, |_| {});
        // One effort value throughout: the whole path names it; the stream hands it over.
        trace.effort.value.fill(1.25);
        assert!(estimate(&trace, &axis, &EstimateParams::default()).is_err());
        let (redo, _) = same_or_redo(&trace, &axis, 1.0, 100);
        assert_eq!(redo.as_deref(), Some("the effort never changes"));
        // Too few samples.
        let (short, _) = twin(&[400.0], 0.0, 1.0, 4, |_| {});
        let cut = Trace {
            position_m: Channel {
                time_s: short.position_m.time_s[..3].to_vec(),
                value: short.position_m.value[..3].to_vec(),
            },
            ..short
        };
        let (redo, _) = same_or_redo(&cut, &axis, 1.0, 100);
        assert!(redo.is_some());
    }
}
