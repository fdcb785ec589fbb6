//! Recognising the tests `feedscope plan` writes in a live stream of [`Event`]s.
//!
//! The stream is split into motion episodes separated by standstill: an episode starts when
//! the position leaves its resting value by more than the quantum and ends when it has not
//! moved by more than the quantum for [`RecognizerParams::standstill_s`] of control time
//! (the dwells of a planned test are shorter). An episode is a test when its motion is one:
//!
//! - strokes ([`TestKind::Strokes`]): back-and-forth moves over one range (every forward move
//!   from the same start to the same end, every backward move back), at least
//!   [`RecognizerParams::min_strokes_each_way`] each way, each with a steady stroke at constant
//!   feed, found by the estimator's segmentation ([`feedscope::estimate::segment::find_moves`]);
//! - triangle ([`TestKind::Triangle`]): alternating moves around one centre whose feed rises
//!   level by level (at least 3 levels), as [`feedscope::plan::triangle_program`] plans them.
//!
//! An episode is discarded at the first [`Event::Gap`] in it, never returned as a test. Memory is
//! bounded: an episode longer than [`RecognizerParams::max_samples`] samples per channel is
//! discarded.
//!
//! # Resolvable orders
//! A stream sampled every `Δt` at feed `v` sees the position advance `v·Δt` per sample; a
//! friction component of screw order `k` (k cycles per lead `L`) has the period `L/(k·v)` in
//! time, so Nyquist gives the highest order `k_max = L / (2·v·Δt)` ([`resolvable_order`]), and
//! a wanted order needs the feed `v ≤ L / (2·k·Δt)` ([`feed_for_order_m_s`]).
use feedscope::estimate::segment::{find_moves, MoveSpan, SegmentParams};
use feedscope::plan::TestKind;
use feedscope::trace::{Channel, EffortKind, RecordingFacts, Trace, MIN_SAMPLES};

use crate::source::{Event, GapReason, Quantity};

/// Settings of the [`Recognizer`].
#[derive(Debug, Clone, PartialEq)]
pub struct RecognizerParams {
    /// Which test to look for.
    pub kind: TestKind,
    /// Standstill that ends an episode (s of control time). Default 2.
    pub standstill_s: f64,
    /// Position changes up to this are no motion (m). Default 1 µm (MTConnect positions are
    /// usually given to 0.001 mm).
    pub position_quantum_m: f64,
    /// Only episodes that run while the control's program name contains this (ignoring case).
    pub program: Option<String>,
    /// Fewest strokes each way of a stroke test. Default 2.
    pub min_strokes_each_way: usize,
    /// Most samples kept per channel and episode. Default 500 000.
    pub max_samples: usize,
    /// Effort quantum of the source (SI), stored in the trace's facts (e.g. 1 % of load).
    pub effort_quantum: Option<f64>,
    /// `Some(false)` when the effort is a magnitude (drive load).
    pub effort_signed: Option<bool>,
}

impl Default for RecognizerParams {
    fn default() -> Self {
        Self {
            kind: TestKind::Strokes,
            standstill_s: 2.0,
            position_quantum_m: 1e-6,
            program: None,
            min_strokes_each_way: 2,
            max_samples: 500_000,
            effort_quantum: None,
            effort_signed: None,
        }
    }
}

/// A test found in the stream.
#[derive(Debug, Clone)]
pub struct FinishedTest {
    /// The episode as a trace: position (m), effort (SI), time (s) from the episode start.
    pub trace: Trace,
    /// Control time of the episode start (s since the Unix epoch, UTC).
    pub start_time_s: f64,
    /// Control time of its last sample (s since the Unix epoch).
    pub end_time_s: f64,
    /// Moves with a steady stroke (both directions).
    pub strokes: usize,
    /// The distinct feeds of its strokes (m/s), ascending.
    pub feeds_m_s: Vec<f64>,
    /// Median interval between its position samples (s).
    pub sample_interval_s: f64,
    /// The program running, if the control said.
    pub program: Option<String>,
}

impl FinishedTest {
    /// Highest screw order the stream resolves at the test's highest feed ([`resolvable_order`]).
    pub fn resolvable_order(&self, lead_m: f64) -> f64 {
        let v = self.feeds_m_s.last().copied().unwrap_or(f64::NAN);
        resolvable_order(lead_m, v, self.sample_interval_s)
    }
}

/// What became of an episode.
#[derive(Debug, Clone)]
pub enum Outcome {
    /// A test.
    Test(Box<FinishedTest>),
    /// Motion that is no test of the kind looked for, or ran under another program (words).
    NotATest {
        /// Control time of the episode start (s since the epoch).
        start_time_s: f64,
        /// Why.
        reason: String,
    },
    /// An episode that had to be thrown away (a gap in it, too long, shut down mid-test).
    Discarded {
        /// Control time of the episode start (s since the epoch).
        start_time_s: f64,
        /// Why.
        reason: String,
    },
}

/// The highest screw order (cycles per lead) a stream sampled every `interval_s` resolves at
/// feed `feed_m_s`: Nyquist, `k_max = lead / (2 · feed · interval)`.
///
/// ```
/// // 10 mm lead, 100 mm/min, a sample every 0.35 s: orders up to 8.6.
/// let k = feedscope_live::watch::resolvable_order(0.010, 0.1 / 60.0, 0.35);
/// assert!((k - 8.571).abs() < 1e-3);
/// ```
pub fn resolvable_order(lead_m: f64, feed_m_s: f64, interval_s: f64) -> f64 {
    lead_m / (2.0 * feed_m_s * interval_s)
}

/// The highest feed (m/s) at which a stream sampled every `interval_s` resolves screw order
/// `order`: `lead / (2 · order · interval)`.
pub fn feed_for_order_m_s(lead_m: f64, order: f64, interval_s: f64) -> f64 {
    lead_m / (2.0 * order * interval_s)
}

/// Splits a stream of events into motion episodes and recognises the tests among them.
#[derive(Debug, Clone)]
pub struct Recognizer {
    params: RecognizerParams,
    effort_kind: EffortKind,
    /// Resting position and its time.
    rest: Option<(f64, f64)>,
    /// Latest effort sample (time, value).
    last_effort: Option<(f64, f64)>,
    program: Option<String>,
    episode: Option<Episode>,
    /// Latest control time seen.
    now_s: Option<f64>,
}

#[derive(Debug, Clone)]
struct Episode {
    start_s: f64,
    position: Vec<(f64, f64)>,
    effort: Vec<(f64, f64)>,
    last_motion_s: f64,
    last_motion_z: f64,
    spoiled: Option<String>,
    program: Option<String>,
}

fn push(v: &mut Vec<(f64, f64)>, t: f64, x: f64) {
    match v.last_mut() {
        // Several observations with one timestamp (the same parsed text, so the same f64
        // bits): the last one holds.
        Some(l) if l.0.to_bits() == t.to_bits() => l.1 = x,
        Some(l) if t < l.0 => {}
        _ => v.push((t, x)),
    }
}

impl Recognizer {
    /// A recognizer with these settings.
    pub fn new(params: RecognizerParams) -> Self {
        Self {
            params,
            effort_kind: EffortKind::TorqueNm,
            rest: None,
            last_effort: None,
            program: None,
            episode: None,
            now_s: None,
        }
    }

    /// True while a motion episode is being collected.
    pub fn in_episode(&self) -> bool {
        self.episode.is_some()
    }

    /// Latest control time seen (s since the epoch).
    pub fn now_s(&self) -> Option<f64> {
        self.now_s
    }

    /// Take one event; returns what became of an episode that ended.
    pub fn push(&mut self, e: &Event) -> Option<Outcome> {
        match e {
            Event::Sample {
                quantity,
                time_s,
                value,
            } => {
                let t = *time_s;
                let done = self.tick(t);
                self.now_s = Some(self.now_s.map_or(t, |n| n.max(t)));
                match quantity {
                    Quantity::Position => self.position(t, *value),
                    Quantity::Effort(k) => {
                        self.effort_kind = *k;
                        self.last_effort = Some((t, *value));
                        if let Some(ep) = &mut self.episode {
                            if ep.spoiled.is_none() {
                                push(&mut ep.effort, t, *value);
                            }
                        }
                    }
                }
                self.check_size();
                done
            }
            Event::Program { time_s, name } => {
                let done = self.tick(*time_s);
                self.program = Some(name.clone());
                done
            }
            Event::Gap { reason, .. } => {
                // The resting position is unknown after a gap: motion must start again from
                // a position seen after it.
                self.rest = None;
                self.last_effort = None;
                // An episode with a gap is thrown away at once: its data cannot be trusted.
                self.episode.take().map(|ep| Outcome::Discarded {
                    start_time_s: ep.start_s,
                    reason: ep.spoiled.unwrap_or_else(|| match reason {
                        GapReason::ConnectionLost { .. } | GapReason::BadValue { .. } => {
                            format!("{reason}; the test is not stored")
                        }
                        _ => {
                            format!("data gap during the motion ({reason}); the test is not stored")
                        }
                    }),
                })
            }
            _ => None,
        }
    }

    /// Control time has reached `now_s` (also when no event came, from the caller's clock): an
    /// episode at standstill for [`RecognizerParams::standstill_s`] ends here.
    pub fn tick(&mut self, now_s: f64) -> Option<Outcome> {
        let ep = self.episode.as_ref()?;
        if now_s - ep.last_motion_s < self.params.standstill_s {
            return None;
        }
        let ep = self.episode.take().expect("checked");
        self.rest = Some((ep.last_motion_s, ep.last_motion_z));
        Some(self.finish(ep))
    }

    /// The stream ends (shutdown): an episode in progress is discarded, never a test.
    pub fn shutdown(&mut self) -> Option<Outcome> {
        let ep = self.episode.take()?;
        Some(Outcome::Discarded {
            start_time_s: ep.start_s,
            reason: "stopped during a motion episode; the partial test is not stored".into(),
        })
    }

    fn position(&mut self, t: f64, z: f64) {
        let q = self.params.position_quantum_m;
        if let Some(ep) = &mut self.episode {
            if (z - ep.last_motion_z).abs() > q {
                ep.last_motion_s = t;
                ep.last_motion_z = z;
            }
            if ep.spoiled.is_none() {
                push(&mut ep.position, t, z);
            }
            return;
        }
        let Some((rt, rz)) = self.rest else {
            self.rest = Some((t, z));
            return;
        };
        if (z - rz).abs() <= q {
            self.rest = Some((rt, rz));
            return;
        }
        // Motion starts: the resting sample, at most one standstill before, opens the episode
        // (a change-only stream wrote nothing while the axis stood).
        let t0 = rt.max(t - self.params.standstill_s).min(t);
        let mut ep = Episode {
            start_s: t0,
            position: Vec::new(),
            effort: Vec::new(),
            last_motion_s: t,
            last_motion_z: z,
            spoiled: None,
            program: self.program.clone(),
        };
        if t0 < t {
            ep.position.push((t0, rz));
        }
        if let Some((_, v)) = self.last_effort {
            if t0 < t {
                ep.effort.push((t0, v));
            }
        }
        ep.position.push((t, z));
        self.episode = Some(ep);
    }

    fn check_size(&mut self) {
        let max = self.params.max_samples;
        if let Some(ep) = &mut self.episode {
            if ep.spoiled.is_none() && (ep.position.len() > max || ep.effort.len() > max) {
                ep.spoiled = Some(format!(
                    "the motion ran longer than {max} samples per channel without a standstill"
                ));
                ep.position = Vec::new();
                ep.effort = Vec::new();
            }
        }
    }

    fn finish(&self, ep: Episode) -> Outcome {
        let start_time_s = ep.start_s;
        if let Some(reason) = ep.spoiled {
            return Outcome::Discarded {
                start_time_s,
                reason,
            };
        }
        if let Some(want) = &self.params.program {
            let ok = ep
                .program
                .as_deref()
                .is_some_and(|p| p.to_lowercase().contains(&want.to_lowercase()));
            if !ok {
                return Outcome::NotATest {
                    start_time_s,
                    reason: format!(
                        "program {} is not {want}",
                        ep.program.as_deref().unwrap_or("(unknown)")
                    ),
                };
            }
        }
        // Up to the end of the motion plus one sample: the final standstill adds nothing.
        let end = ep.last_motion_s;
        let keep = |v: &[(f64, f64)]| -> Channel {
            let mut ch = Channel::default();
            for &(t, x) in v.iter().filter(|(t, _)| *t <= end + 1e-9) {
                ch.time_s.push(t - start_time_s);
                ch.value.push(x);
            }
            ch
        };
        let position = keep(&ep.position);
        let effort = keep(&ep.effort);
        if position.len() < MIN_SAMPLES || effort.len() < MIN_SAMPLES {
            return Outcome::NotATest {
                start_time_s,
                reason: format!(
                    "too few samples ({} position, {} effort)",
                    position.len(),
                    effort.len()
                ),
            };
        }
        let moves = find_moves(&position, &SegmentParams::default());
        let verdict = match self.params.kind {
            TestKind::Strokes => check_strokes(&moves, &position, &self.params),
            TestKind::Triangle => check_triangle(&moves, &position),
        };
        let (strokes, feeds_m_s) = match verdict {
            Ok(x) => x,
            Err(reason) => {
                return Outcome::NotATest {
                    start_time_s,
                    reason,
                }
            }
        };
        let mut dts: Vec<f64> = position.time_s.windows(2).map(|w| w[1] - w[0]).collect();
        dts.sort_by(f64::total_cmp);
        let sample_interval_s = dts[dts.len() / 2];
        Outcome::Test(Box::new(FinishedTest {
            trace: Trace {
                position_m: position,
                effort,
                effort_kind: self.effort_kind,
                facts: RecordingFacts {
                    effort_quantum: self.params.effort_quantum,
                    effort_signed: self.params.effort_signed,
                    ..RecordingFacts::default()
                },
            },
            start_time_s,
            end_time_s: end,
            strokes,
            feeds_m_s,
            sample_interval_s,
            program: ep.program,
        }))
    }
}

/// Distinct plateau speeds (m/s), ascending: speeds within 5 % are one feed.
fn distinct_feeds(moves: &[&MoveSpan]) -> Vec<f64> {
    let mut v: Vec<f64> = moves.iter().map(|m| m.plateau_speed_m_s).collect();
    v.sort_by(f64::total_cmp);
    let mut out: Vec<f64> = Vec::new();
    for s in v {
        match out.last() {
            Some(&l) if s <= l * 1.05 => {}
            _ => out.push(s),
        }
    }
    out
}

fn check_strokes(
    moves: &[MoveSpan],
    position: &Channel,
    p: &RecognizerParams,
) -> Result<(usize, Vec<f64>), String> {
    let z = &position.value;
    let steady: Vec<&MoveSpan> = moves.iter().filter(|m| !m.strokes.is_empty()).collect();
    let (lo, hi) = steady
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |a, m| {
            (
                a.0.min(z[m.first].min(z[m.last])),
                a.1.max(z[m.first].max(z[m.last])),
            )
        });
    let span = hi - lo;
    if steady.is_empty() || span <= 0.0 {
        return Err("no steady stroke".into());
    }
    // The ends of every stroke are the two ends of the range, within 2 % of it (the reversal
    // hysteresis and change-only sampling blur a turning point).
    let tol = 0.02 * span + 2.0 * p.position_quantum_m;
    let off_range = steady
        .iter()
        .filter(|m| {
            let (a, b) = (z[m.first].min(z[m.last]), z[m.first].max(z[m.last]));
            (a - lo).abs() > tol || (b - hi).abs() > tol
        })
        .count();
    if off_range > 0 {
        return Err(format!(
            "{off_range} of {} moves do not run over one range ({:.3}-{:.3} mm): not the \
             back-and-forth strokes of a stroke test",
            steady.len(),
            lo * 1e3,
            hi * 1e3
        ));
    }
    // Any other move between them (not a steady stroke) longer than the tolerance breaks the
    // pattern: machining moves in between.
    let first = moves
        .iter()
        .position(|m| !m.strokes.is_empty())
        .unwrap_or(0);
    let last = moves
        .iter()
        .rposition(|m| !m.strokes.is_empty())
        .unwrap_or(0);
    if let Some(m) = moves[first..=last]
        .iter()
        .find(|m| m.strokes.is_empty() && (z[m.last] - z[m.first]).abs() > tol)
    {
        return Err(format!(
            "a move of {:.3} mm without steady feed between the strokes",
            (z[m.last] - z[m.first]).abs() * 1e3
        ));
    }
    let fwd = steady
        .iter()
        .filter(|m| m.direction == feedscope::stroke::Direction::Forward)
        .count();
    let bwd = steady.len() - fwd;
    if fwd.min(bwd) < p.min_strokes_each_way {
        return Err(format!(
            "{fwd} forward and {bwd} backward strokes; a stroke test has at least {} each way",
            p.min_strokes_each_way
        ));
    }
    Ok((steady.len(), distinct_feeds(&steady)))
}

fn check_triangle(moves: &[MoveSpan], position: &Channel) -> Result<(usize, Vec<f64>), String> {
    let z = &position.value;
    let steady: Vec<&MoveSpan> = moves.iter().filter(|m| !m.strokes.is_empty()).collect();
    if steady.len() < 4 {
        return Err(format!(
            "{} moves at steady feed; a triangle test has more",
            steady.len()
        ));
    }
    if steady.windows(2).any(|w| w[0].direction == w[1].direction) {
        return Err("moves do not alternate in direction".into());
    }
    // Feeds rise level by level (never fall by more than 10 %).
    if steady
        .windows(2)
        .any(|w| w[1].plateau_speed_m_s < 0.9 * w[0].plateau_speed_m_s)
    {
        return Err("the feed falls between moves: not a triangle wave of rising feed".into());
    }
    let feeds = distinct_feeds(&steady);
    if feeds.len() < 3 {
        return Err(format!(
            "{} feed level(s); a triangle test has at least 3",
            feeds.len()
        ));
    }
    // Turning points lie symmetric around one centre.
    let tps: Vec<f64> = steady
        .iter()
        .flat_map(|m| [z[m.first], z[m.last]])
        .collect();
    let (lo, hi) = tps
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |a, &v| {
            (a.0.min(v), a.1.max(v))
        });
    let c = 0.5 * (lo + hi);
    let half = 0.5 * (hi - lo);
    let asym = steady
        .iter()
        .filter(|m| {
            let mid = 0.5 * (z[m.first] + z[m.last]);
            (mid - c).abs() > 0.25 * half.max(1e-9)
        })
        .count();
    if asym * 2 > steady.len() {
        return Err("the moves are not centred on one position".into());
    }
    Ok((steady.len(), feeds))
}

#[cfg(test)]
mod tests {
    use super::*;
    use feedscope::trace::EffortKind;

    fn sample(q: Quantity, t: f64, v: f64) -> Event {
        Event::Sample {
            quantity: q,
            time_s: t,
            value: v,
        }
    }

    /// Strokes 0 → 100 mm at 600 mm/min (10 s each), 1 s dwells, sampled every 0.25 s
    /// change-only; `strokes` strokes; then `rest` s still.
    fn strokes(strokes: usize, t0: f64) -> Vec<Event> {
        let mut ev = Vec::new();
        let dt = 0.25;
        let mut t = t0;
        let pos = Quantity::Position;
        let eff = Quantity::Effort(EffortKind::TorqueNm);
        ev.push(sample(pos, t, 0.0));
        ev.push(sample(eff, t, 0.0));
        t += 3.0;
        for s in 0..strokes {
            let (a, b) = if s % 2 == 0 { (0.0, 0.1) } else { (0.1, 0.0) };
            let n = 40;
            for i in 1..=n {
                let z = a + (b - a) * i as f64 / n as f64;
                ev.push(sample(pos, t + i as f64 * dt, z));
                ev.push(sample(
                    eff,
                    t + i as f64 * dt,
                    if b > a { 1.0 } else { -1.0 },
                ));
            }
            t += n as f64 * dt + 1.0;
        }
        ev.push(sample(eff, t + 5.0, 0.0));
        ev
    }

    #[test]
    fn four_strokes_are_a_test_and_gaps_spoil_it() {
        let mut r = Recognizer::new(RecognizerParams::default());
        let out: Vec<Outcome> = strokes(4, 1000.0)
            .iter()
            .filter_map(|e| r.push(e))
            .collect();
        assert_eq!(out.len(), 1, "{out:?}");
        let Outcome::Test(t) = &out[0] else {
            panic!("{out:?}")
        };
        assert_eq!(t.strokes, 4);
        assert_eq!(t.feeds_m_s.len(), 1);
        assert!((t.feeds_m_s[0] - 0.01).abs() < 1e-3);
        assert!((t.sample_interval_s - 0.25).abs() < 1e-9);
        assert!((t.start_time_s - 1001.25).abs() < 1e-9);
        // 10 mm lead at 600 mm/min every 0.25 s: order 2.
        assert!((t.resolvable_order(0.010) - 2.0).abs() < 1e-9);
        // Two strokes only: not a test.
        let mut r = Recognizer::new(RecognizerParams::default());
        let out: Vec<Outcome> = strokes(2, 0.0).iter().filter_map(|e| r.push(e)).collect();
        assert!(matches!(&out[..], [Outcome::NotATest { .. }]), "{out:?}");
        // A gap in the middle.
        let mut r = Recognizer::new(RecognizerParams::default());
        let mut ev = strokes(4, 0.0);
        ev.insert(
            100,
            Event::Gap {
                time_s: None,
                reason: crate::source::GapReason::Skipped { lost: Some(3) },
            },
        );
        let out: Vec<Outcome> = ev.iter().filter_map(|e| r.push(e)).collect();
        assert!(
            matches!(&out[0], Outcome::Discarded { reason, .. } if reason.contains("3 observations")),
            "{out:?}"
        );
        assert!(
            !out.iter().any(|o| matches!(o, Outcome::Test(_))),
            "{out:?}"
        );
        // Shut down mid-test.
        let mut r = Recognizer::new(RecognizerParams::default());
        for e in &strokes(4, 0.0)[..120] {
            assert!(r.push(e).is_none());
        }
        assert!(matches!(r.shutdown(), Some(Outcome::Discarded { .. })));
    }

    #[test]
    fn order_and_feed_are_inverse() {
        let f = feed_for_order_m_s(0.01, 4.0, 0.1);
        assert!((resolvable_order(0.01, f, 0.1) - 4.0).abs() < 1e-12);
    }
}
