//! Every move of the axis gets a kind: a measuring stroke at a steady programmed feed, a rapid
//! (G0) or positioning move, or motion that no block of the NC program explains (a jog).
//!
//! Only measuring strokes carry friction into profiles, spectra, maps and the history: a rapid
//! runs at the axis's traverse rate with its own ramps, and a positioning move never holds a
//! steady feed, so neither is a friction measurement at a programmed feed.
//!
//! Without an NC program the kind comes from the motion:
//! - **rapid**: the move's top speed is at least 90 % of the axis file's
//!   `rapid_rate_mm_min`; without that key, the fastest moves are taken for rapids when they
//!   run at ≥ 3000 mm/min and at least twice as fast as every other move (a warning says this
//!   was inferred);
//! - **positioning**: no steady stroke was found in the move (too short, or never at a steady
//!   feed);
//! - **measuring**: everything else.
//!
//! With a program (its motion blocks as [`ProgrammedMove`]s) the blocks decide: each is matched,
//! in order, to the next move that ends at its target (see `label_with_program`).

use serde::{Deserialize, Serialize};

use super::segment::MoveSpan;
use crate::diag::{Code, Diagnostic};
use crate::stroke::Direction;
use crate::trace::Channel;
use crate::units::feed_m_s_to_mm_min;

/// One motion block of an NC program, resolved to absolute axis positions (from
/// [`crate::nc`] or any other source).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProgrammedMove {
    /// 1-based line in the program file.
    pub line: usize,
    /// G0 (rapid) rather than G1.
    pub rapid: bool,
    /// Axis position before the block (mm).
    pub from_mm: f64,
    /// Axis position after the block (mm).
    pub to_mm: f64,
    /// Programmed feed along this axis (mm/min); none for rapids or when unknown.
    pub feed_mm_min: Option<f64>,
}

/// What a move is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MoveKind {
    /// A steady stroke at a programmed feed: a friction measurement.
    Measuring,
    /// A rapid traverse (G0) at or near the axis's rapid rate.
    Rapid,
    /// A move that never holds a steady feed (too short, or a triangle of speed).
    Positioning,
    /// Motion that no block of the given NC program explains (manual jog, another program).
    Jog,
}

impl MoveKind {
    /// `"measuring"`, `"rapid"`, `"positioning"` or `"jog"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Measuring => "measuring",
            Self::Rapid => "rapid",
            Self::Positioning => "positioning",
            Self::Jog => "jog",
        }
    }
}

/// One move of the axis between two reversals or stops, with its kind.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Move {
    /// What it is.
    pub kind: MoveKind,
    /// Direction of travel.
    pub direction: Direction,
    /// Start (s).
    pub start_time_s: f64,
    /// End (s).
    pub end_time_s: f64,
    /// Position at the start (mm).
    pub start_mm: f64,
    /// Position at the end (mm).
    pub end_mm: f64,
    /// Feed of the move (mm/min): the mean speed over its steady strokes, else its travel over
    /// its duration. `None` for a move without a steady stroke that spans a gap in the
    /// recording ([`Self::gap_s`]): a speed over a time the axis was not recorded is no feed.
    pub feed_mm_min: Option<f64>,
    /// The longest time between two position samples inside the move (s), when it is a gap in
    /// the recording ([`GAP_FACTOR`] times the move's median sample interval and at least
    /// [`MIN_GAP_S`]): recordings joined, or a logger that stopped.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gap_s: Option<f64>,
    /// Numbers of the strokes estimated in it (see the strokes' `stroke` field).
    pub strokes: Vec<usize>,
    /// The NC program line that commanded it, when a program was given and matched.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub program_line: Option<usize>,
    /// The programmed axis feed of that block (mm/min; none for rapids).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub programmed_feed_mm_min: Option<f64>,
}

impl ProgrammedMove {
    /// The motion blocks of a resolved NC program (dwells and blocks that do not move the
    /// axis dropped).
    pub fn from_steps(steps: &[crate::nc::ResolvedStep]) -> Vec<Self> {
        steps
            .iter()
            // 1 nm: below any programmable increment.
            .filter(|s| s.kind != crate::nc::StepKind::Dwell && (s.to_mm - s.from_mm).abs() > 1e-6)
            .map(|s| Self {
                line: s.line,
                rapid: s.kind == crate::nc::StepKind::Rapid,
                from_mm: s.from_mm,
                to_mm: s.to_mm,
                feed_mm_min: s.feed_mm_min,
            })
            .collect()
    }
}

/// Fraction of the rapid rate above which a move is a rapid (feed override of rapids and
/// the servo's following make the plateau a few per cent slow).
const RAPID_FRACTION: f64 = 0.9;
/// Without a rapid rate: the slowest speed taken for a rapid (mm/min) ...
pub(crate) const INFERRED_RAPID_MIN_MM_MIN: f64 = 3000.0;
/// ... and how much faster than every other move it must be.
const INFERRED_RAPID_RATIO: f64 = 2.0;

/// Classify the moves by their motion (module docs). Returns the moves (without stroke
/// numbers) and a note when rapids were inferred without a rapid rate.
pub(crate) fn classify(
    position: &Channel,
    moves: &[MoveSpan],
    rapid_rate_mm_min: Option<f64>,
) -> (Vec<Move>, Option<Diagnostic>) {
    // Rapids are told by their top speed: a long rapid spends much of its time on its ramps,
    // which pull the plateau (a median) below the rapid rate.
    let mut note = None;
    let rapid_above = match rapid_rate_mm_min {
        Some(r) => Some(rapid_above_rate(r)),
        None => {
            let fastest = moves.iter().map(top_mm_min).fold(0.0, f64::max);
            let fast_cut = RAPID_FRACTION * fastest;
            let others = moves
                .iter()
                .map(top_mm_min)
                .filter(|&f| f < fast_cut)
                .fold(0.0, f64::max);
            let any_other = moves.iter().any(|m| top_mm_min(m) < fast_cut);
            if fastest >= INFERRED_RAPID_MIN_MM_MIN
                && any_other
                && fastest >= INFERRED_RAPID_RATIO * others
            {
                note = Some(Diagnostic::new(
                    Code::RapidsInferred,
                    format!(
                    "moves at about {fastest:.0} mm/min, more than {INFERRED_RAPID_RATIO}× faster \
                     than any other (at most {others:.0} mm/min), were taken for rapids and left \
                     out; set rapid_rate_mm_min in the axis file (or give --program) to be sure"
                ),
                ));
                Some(fast_cut)
            } else {
                None
            }
        }
    };
    let out = moves
        .iter()
        .map(|m| classify_one(position, m, rapid_above))
        .collect();
    (out, note)
}

/// The top speed of a move (mm/min), what tells a rapid.
pub(crate) fn top_mm_min(m: &MoveSpan) -> f64 {
    feed_m_s_to_mm_min(m.top_speed_m_s)
}

/// One move classified, with moves at or above `rapid_above` (mm/min) taken for rapids.
pub(crate) fn classify_one(position: &Channel, m: &MoveSpan, rapid_above: Option<f64>) -> Move {
    let (t, z) = (&position.time_s, &position.value);
    let gap = gap_in(&t[m.first..=m.last]);
    let kind = if rapid_above.is_some_and(|r| top_mm_min(m) >= r) {
        MoveKind::Rapid
    } else if m.strokes.is_empty() {
        MoveKind::Positioning
    } else {
        MoveKind::Measuring
    };
    Move {
        kind,
        direction: m.direction,
        start_time_s: t[m.first],
        end_time_s: t[m.last],
        start_mm: z[m.first] * 1e3,
        end_mm: z[m.last] * 1e3,
        feed_mm_min: steady_feed_mm_min(position, m, gap.is_some()),
        gap_s: gap,
        strokes: Vec::new(),
        program_line: None,
        programmed_feed_mm_min: None,
    }
}

/// The speed at or above which a move is a rapid when the axis gives its rapid rate (mm/min).
pub(crate) fn rapid_above_rate(rapid_rate_mm_min: f64) -> f64 {
    RAPID_FRACTION * rapid_rate_mm_min
}

/// A sample interval inside a move is a gap in the recording when it is at least this many
/// times the move's median interval: a change-only logger's intervals scatter by a few times
/// their median, not by twenty.
pub const GAP_FACTOR: f64 = 20.0;
/// ... and at least this long (s): a dropped sample or two of a fast logger is no gap.
pub const MIN_GAP_S: f64 = 1.0;

/// The longest interval of the sample times `t` (increasing) when it is a gap ([`GAP_FACTOR`],
/// [`MIN_GAP_S`]) against the lower median of the others' intervals; `None` otherwise. With a
/// single interval there is nothing to compare it with: no gap.
fn gap_in(t: &[f64]) -> Option<f64> {
    let mut dt: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    if dt.len() < 2 {
        return None;
    }
    dt.sort_by(f64::total_cmp);
    let longest = dt[dt.len() - 1];
    // The lower median: with two intervals, the shorter one (the other is the candidate).
    let median = dt[(dt.len() - 1) / 2];
    (longest >= MIN_GAP_S && longest >= GAP_FACTOR * median).then_some(longest)
}

/// The feed of a move (mm/min): the mean speed over its steady strokes (exact also when single
/// chords are coarse; a standstill, and so a gap, always ends a stroke), else its travel over
/// its duration, else (no stroke and a gap inside, `gap`) none. The move's plateau speed is
/// not used: it is 0 for a move with fewer samples than one chord needs, which made a 15 mm
/// positioning move logged by a few change-only samples read "0.0 mm/min".
fn steady_feed_mm_min(position: &Channel, m: &MoveSpan, gap: bool) -> Option<f64> {
    let (t, z) = (&position.time_s, &position.value);
    let (dist, dur) = m.strokes.iter().fold((0.0, 0.0), |(d, s), sp| {
        (
            d + (z[sp.last] - z[sp.first]).abs(),
            s + t[sp.last] - t[sp.first],
        )
    });
    if dur > 0.0 {
        return Some(feed_m_s_to_mm_min(dist / dur));
    }
    let span = t[m.last] - t[m.first];
    // Time strictly increases, so a move of two or more knots has a positive duration.
    (!gap && span > 0.0).then(|| feed_m_s_to_mm_min((z[m.last] - z[m.first]).abs() / span))
}

/// How far a measured end position may lie from the programmed one and still match (mm):
/// the servo's following error at standstill is microns; 0.5 mm allows for a program that
/// was started from a slightly different position and for position offsets.
const MATCH_TOLERANCE_MM: f64 = 0.5;

/// Label moves with the blocks of an NC program (already resolved to absolute positions):
/// each programmed motion block, in order, is matched to the next measured move that ends at
/// its target within [`MATCH_TOLERANCE_MM`] in its direction. A matched G0 makes the move a
/// rapid and a matched G1 a measuring stroke (or a positioning move when it held no steady
/// feed); a measured move that no block explains is a jog. Returns warnings: blocks never
/// found in the trace, and feeds that differ from the programmed one (override).
pub(crate) fn label_with_program(moves: &mut [Move], steps: &[ProgrammedMove]) -> Vec<Diagnostic> {
    let mut warnings = Vec::new();
    let mut next = 0usize;
    let mut unmatched_blocks = Vec::new();
    let mut matched = vec![false; moves.len()];
    for step in steps {
        if (step.to_mm - step.from_mm).abs() < 1e-9 {
            continue;
        }
        let dir = if step.to_mm > step.from_mm {
            Direction::Forward
        } else {
            Direction::Backward
        };
        let found = (next..moves.len()).find(|&k| {
            moves[k].direction == dir && (moves[k].end_mm - step.to_mm).abs() <= MATCH_TOLERANCE_MM
        });
        let Some(k) = found else {
            unmatched_blocks.push(step.line);
            continue;
        };
        // Moves skipped over before this match are unprogrammed motion.
        next = k + 1;
        matched[k] = true;
        let m = &mut moves[k];
        m.program_line = Some(step.line);
        m.programmed_feed_mm_min = step.feed_mm_min;
        m.kind = if step.rapid {
            MoveKind::Rapid
        } else if m.kind == MoveKind::Positioning {
            MoveKind::Positioning
        } else {
            MoveKind::Measuring
        };
        if let (false, Some(f), Some(feed)) = (step.rapid, step.feed_mm_min, m.feed_mm_min) {
            if m.kind == MoveKind::Measuring && (feed / f - 1.0).abs() > 0.05 {
                warnings.push(Diagnostic::new(
                    Code::FeedNotAsProgrammed,
                    format!(
                    "the move ending at {:.3} mm ran at {:.1} mm/min, not the {:.1} mm/min that \
                     line {} programs (feed override?)",
                    m.end_mm, feed, f, step.line
                ),
                ));
            }
        }
    }
    for (m, &ok) in moves.iter_mut().zip(&matched) {
        if !ok {
            m.kind = MoveKind::Jog;
        }
    }
    let jogs = matched.iter().filter(|&&ok| !ok).count();
    if jogs > 0 {
        warnings.push(Diagnostic::new(
            Code::MovesNotInProgram,
            format!("{jogs} move(s) match no block of the program and are called jog (left out)"),
        ));
    }
    if !unmatched_blocks.is_empty() {
        let shown: Vec<String> = unmatched_blocks
            .iter()
            .take(8)
            .map(|l| l.to_string())
            .collect();
        warnings.push(Diagnostic::new(
            Code::BlocksNotFound,
            format!(
                "{} programmed move(s) were not found in the trace (lines {}{})",
                unmatched_blocks.len(),
                shown.join(", "),
                if unmatched_blocks.len() > 8 {
                    ", …"
                } else {
                    ""
                }
            ),
        ));
    }
    warnings
}

#[cfg(test)]
mod tests {
    use super::*;

    fn span(first: usize, last: usize) -> MoveSpan {
        MoveSpan {
            direction: Direction::Forward,
            first,
            last,
            plateau_speed_m_s: 0.0,
            top_speed_m_s: 0.0,
            strokes: Vec::new(),
        }
    }

    /// A 15 mm move in four change-only samples has too few for a chord (plateau 0): its feed
    /// is its travel over its duration, not "0.0 mm/min".
    #[test]
    fn a_move_too_short_for_a_plateau_has_its_mean_speed() {
        let p = Channel {
            time_s: vec![0.0, 0.35, 0.7, 1.05],
            value: vec![0.0, 0.005, 0.010, 0.015],
        };
        let m = classify_one(&p, &span(0, 3), None);
        let feed = m.feed_mm_min.unwrap();
        // 15 mm in 1.05 s: 857.14 mm/min, to rounding.
        assert!((feed - 15.0 / 1.05 * 60.0).abs() < 1e-9, "{feed}");
        assert_eq!(m.gap_s, None);
    }

    /// A move across a 1589 s gap between two recordings has no feed, and says so; a
    /// hiccup of a fast logger, or a lone interval, is no gap.
    #[test]
    fn a_move_across_a_gap_has_no_feed() {
        let p = Channel {
            time_s: vec![0.0, 0.35, 0.7, 1589.7, 1590.05],
            value: vec![0.0, 0.001, 0.002, 0.014, 0.015],
        };
        let m = classify_one(&p, &span(0, 4), None);
        assert_eq!(m.feed_mm_min, None);
        assert!((m.gap_s.unwrap() - 1589.0).abs() < 1e-9, "{m:?}");
        // Two intervals, one of them 1589 s: still a gap.
        let m = classify_one(&p, &span(1, 3), None);
        assert!(m.gap_s.is_some(), "{m:?}");
        assert_eq!(gap_in(&[0.0, 5.0]), None);
        // 30 ms among 1 ms intervals: 30 × the median, but shorter than MIN_GAP_S.
        assert_eq!(gap_in(&[0.0, 0.001, 0.002, 0.032, 0.033]), None);
        // 0.7 s among 0.35 s change-only intervals: no gap.
        assert_eq!(gap_in(&[0.0, 0.35, 1.05, 1.4]), None);
    }
}
