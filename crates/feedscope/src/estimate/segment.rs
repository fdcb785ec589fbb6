//! Stroke segmentation: where the table moves at a steady feed, and the dwells and reversals
//! between.
//!
//! 1. Turning points by hysteresis: the position must retreat more than `ε` from its running
//!    extreme before a reversal is declared, so dwell jitter and quantisation never make one.
//!    ε = max(8 × the position quantum seen in the data, 10⁻⁴ × the travel, 0.1 µm).
//! 2. Each move between turning points has a plateau speed P: the median chord speed
//!    (Δz/Δt between consecutive position samples) over chords faster than a quarter of the
//!    move's 95th-percentile speed.
//! 3. Steady chords are those at ≥ `steady_fraction` × P; each maximal run of them is a stroke
//!    after `trim_knots` knots are dropped at either end, so the knot at the start of the run
//!    (still in the dwell or the acceleration ramp) never enters the stroke's spline.
//!
//! Everything not inside a stroke is reported as a [`Zone`].

use serde::{Deserialize, Serialize};

use crate::trace::Channel;

pub use crate::stroke::Direction;

/// Knot range of one steady stroke in the position channel.
#[derive(Debug, Clone, PartialEq)]
pub struct StrokeSpan {
    /// Direction of travel.
    pub direction: Direction,
    /// First position knot (inclusive).
    pub first: usize,
    /// Last position knot (inclusive).
    pub last: usize,
    /// Mean speed over the stroke (m/s, positive).
    pub plateau_speed_m_s: f64,
    /// Index of the enclosing move in [`find_moves`]' list.
    pub move_index: usize,
    /// First knot of the enclosing move (its turning point, inclusive): a smoother may reach
    /// back this far, never across a reversal.
    pub move_first: usize,
    /// Last knot of the enclosing move (inclusive).
    pub move_last: usize,
}

/// One move between two turning points, with the steady strokes found inside it.
#[derive(Debug, Clone, PartialEq)]
pub struct MoveSpan {
    /// Direction of travel.
    pub direction: Direction,
    /// First knot (the turning point it starts from).
    pub first: usize,
    /// Last knot (the turning point it ends at).
    pub last: usize,
    /// Plateau speed P of the move (m/s, positive; 0 when it has too few samples to tell).
    pub plateau_speed_m_s: f64,
    /// Its top speed: the 95th percentile of its chord speeds (m/s).
    pub top_speed_m_s: f64,
    /// Its steady strokes, in time order (empty for a move too short to be steady).
    pub strokes: Vec<StrokeSpan>,
}

/// What happens in a stretch of the trace that is not a steady stroke.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ZoneKind {
    /// Before the first stroke.
    Start,
    /// Between strokes of opposite direction (deceleration, dwell, reversal, acceleration).
    Reversal,
    /// Between strokes of the same direction (a stop or a feed change).
    Pause,
    /// After the last stroke.
    End,
}

/// A stretch of the trace excluded from the strokes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Zone {
    /// What it is.
    pub kind: ZoneKind,
    /// Start time (s).
    pub start_time_s: f64,
    /// End time (s).
    pub end_time_s: f64,
    /// Position at the start (mm).
    pub start_position_mm: f64,
    /// Position at the end (mm).
    pub end_position_mm: f64,
}

/// Segmentation settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SegmentParams {
    /// A chord at or above this fraction of the plateau speed counts as steady. Default 0.5,
    /// which keeps feed modulations of up to ±50 % inside the stroke.
    pub steady_fraction: f64,
    /// Knots dropped at each end of a steady run. Default 2.
    pub trim_knots: usize,
    /// Shortest stroke kept (mm). Default 1.
    pub min_stroke_mm: f64,
    /// Fewest position knots in a kept stroke. Default 8.
    pub min_knots: usize,
}

impl Default for SegmentParams {
    fn default() -> Self {
        Self {
            steady_fraction: 0.5,
            trim_knots: 2,
            min_stroke_mm: 1.0,
            min_knots: 8,
        }
    }
}

/// The smallest non-zero position step in the data (m): the quantum, or 0 if none.
pub(crate) fn position_quantum_m(z: &[f64]) -> f64 {
    let q = z
        .windows(2)
        .fold(f64::INFINITY, |q, w| step_min(q, w[0], w[1]));
    if q.is_finite() {
        q
    } else {
        0.0
    }
}

/// `q` lowered to the step from `a` to `b` when that step is a non-zero one smaller than it
/// (one fold step of [`position_quantum_m`], shared with the streamed segmentation).
#[inline]
pub(crate) fn step_min(q: f64, a: f64, b: f64) -> f64 {
    let d = (b - a).abs();
    if d > 1e-12 {
        q.min(d)
    } else {
        q
    }
}

/// The position quantum ([`position_quantum_m`]) and the hysteresis for turning points (m,
/// see the module docs) of a channel of at least 2 samples, in one pass over it.
///
/// Same values as the separate folds: the quantum is a minimum of non-zero steps, so the
/// order it is taken in does not matter (no NaN or zero enters it); the lowest and highest
/// position skip NaN as `f64::min`/`max` do, and where they might differ from those, in the
/// sign of a zero, `hi − lo` (all that the hysteresis uses of them) does not.
fn quantum_and_hysteresis_m(z: &[f64]) -> (f64, f64) {
    // Four lanes each, so the folds are independent chains the compiler can vectorise.
    let mut q = [f64::INFINITY; 4];
    let mut lo = [f64::INFINITY; 4];
    let mut hi = [f64::NEG_INFINITY; 4];
    let mut prev = z[0];
    let chunks = z[1..].chunks_exact(4);
    let rest = chunks.remainder();
    for c in chunks {
        let a = [prev, c[0], c[1], c[2]];
        // Selects without branches (minimum and maximum instructions, which pass over a NaN
        // in `c` just as `f64::min`/`max` do).
        for l in 0..4 {
            let d = (c[l] - a[l]).abs();
            // `step_min`: only a step above 1e-12 counts, and then it is no NaN.
            let d = if d > 1e-12 { d } else { f64::INFINITY };
            q[l] = if d < q[l] { d } else { q[l] };
            lo[l] = if c[l] < lo[l] { c[l] } else { lo[l] };
            hi[l] = if c[l] > hi[l] { c[l] } else { hi[l] };
        }
        prev = c[3];
    }
    let (mut q, mut lo, mut hi) = (
        q[0].min(q[1]).min(q[2].min(q[3])),
        lo[0].min(lo[1]).min(lo[2].min(lo[3])).min(z[0]),
        hi[0].max(hi[1]).max(hi[2].max(hi[3])).max(z[0]),
    );
    for &v in rest {
        q = step_min(q, prev, v);
        lo = lo.min(v);
        hi = hi.max(v);
        prev = v;
    }
    let quantum = if q.is_finite() { q } else { 0.0 };
    (quantum, hysteresis_of(quantum, lo, hi))
}

/// Hysteresis for turning points (m) from the position quantum and the lowest and highest
/// position (m).
pub(crate) fn hysteresis_of(quantum: f64, lo: f64, hi: f64) -> f64 {
    (8.0 * quantum).max(1e-4 * (hi - lo)).max(1e-7)
}

/// Indices of alternating extremes (first and last sample included).
fn turning_points(z: &[f64], eps: f64) -> Vec<usize> {
    let mut finder = TurnFinder::new(eps);
    let mut tp = Vec::new();
    let mut k = 0;
    while k < z.len() {
        if let Some(i) = finder.push(k, z[k]) {
            tp.push(i);
        }
        // Most samples only renew the running extreme: skip them in a tight loop.
        k = finder.renew_run(z, k + 1);
    }
    finder.finish(z.len(), &mut tp);
    tp
}

/// Where [`TurnFinder`] is.
#[derive(Debug, Clone, Copy)]
enum Heading {
    /// No direction yet: the running lowest and highest samples (index, value), the largest
    /// rise above the running low and fall below the running high, each split into before
    /// and since that extreme was last renewed.
    Unknown {
        low: (usize, f64),
        high: (usize, f64),
        rise: Excursion,
        fall: Excursion,
    },
    /// Rising (`up`) or falling from the last turning point: the running extreme (index,
    /// value), the largest counter-move before it, and since it the deepest retreat and the
    /// largest move back from that retreat.
    Moving {
        up: bool,
        ext: (usize, f64),
        counter: f64,
        retreat_to: f64,
        back: f64,
    },
}

/// The largest excursion seen before a running extreme was last renewed, and since (m).
#[derive(Debug, Clone, Copy, Default)]
struct Excursion {
    before: f64,
    since: f64,
}

/// Turning points by hysteresis, one sample at a time (step 1 of the module docs): what
/// [`find_moves`] runs over a whole trace and the streamed estimation over a trace as it is
/// read.
///
/// Besides the turning points, the finder keeps what tells which other hysteresis ε' finds
/// the same ones: `counter_max`, the largest move against the direction within a move (and
/// any move at all before the first turning point and after the last extreme), and
/// `travel_min`, the smallest travel between turning points. Every ε' with
/// `counter_max ≤ ε' < travel_min` finds exactly these turning points: within a move nothing
/// turns, each reversal is taken, and it is taken at the same extreme, because a retreat that
/// first exceeds a hysteresis is lower (higher) than every sample since the extreme. That lets
/// a stream segment with an ε fixed from a prefix and check it against the whole trace's.
#[derive(Debug, Clone)]
pub(crate) struct TurnFinder {
    eps: f64,
    heading: Heading,
    /// The last turning point (index, value).
    last_tp: Option<(usize, f64)>,
    /// See the type's docs (m).
    pub(crate) counter_max: f64,
    pub(crate) travel_min: f64,
}

impl TurnFinder {
    pub(crate) fn new(eps: f64) -> Self {
        Self {
            eps,
            heading: Heading::Unknown {
                low: (0, f64::NAN),
                high: (0, f64::NAN),
                rise: Excursion::default(),
                fall: Excursion::default(),
            },
            last_tp: None,
            counter_max: 0.0,
            travel_min: f64::INFINITY,
        }
    }

    /// The hysteresis in use (m).
    pub(crate) fn eps(&self) -> f64 {
        self.eps
    }

    /// A turning point at `tp`, found at sample `k` of value `v`, turning `up` (rising from
    /// now) or not; `counter` is the largest counter-move the new move already holds.
    fn turn(&mut self, tp: (usize, f64), k: usize, v: f64, up: bool, counter: f64) -> usize {
        if let Some((_, z)) = self.last_tp {
            self.travel_min = self.travel_min.min((tp.1 - z).abs());
        }
        self.last_tp = Some(tp);
        self.heading = Heading::Moving {
            up,
            ext: (k, v),
            counter,
            retreat_to: v,
            back: 0.0,
        };
        tp.0
    }

    /// Sample `k` (consecutive from 0) of value `v`; returns a turning point when this sample
    /// confirms one.
    #[inline]
    pub(crate) fn push(&mut self, k: usize, v: f64) -> Option<usize> {
        match self.heading {
            Heading::Unknown {
                mut low,
                mut high,
                mut rise,
                mut fall,
            } => {
                if k == 0 {
                    low = (0, v);
                    high = (0, v);
                }
                if v < low.1 {
                    low = (k, v);
                    rise.before = rise.before.max(rise.since);
                    rise.since = 0.0;
                }
                if v > high.1 {
                    high = (k, v);
                    fall.before = fall.before.max(fall.since);
                    fall.since = 0.0;
                }
                let (up, down) = (v - low.1, high.1 - v);
                if up > self.eps {
                    // Rises before the low and every fall would have turned a smaller ε.
                    let c = rise.before.max(fall.before).max(fall.since).max(down);
                    self.counter_max = self.counter_max.max(c);
                    return Some(self.turn(low, k, v, true, 0.0));
                }
                if down > self.eps {
                    let c = fall.before.max(rise.before).max(rise.since).max(up);
                    self.counter_max = self.counter_max.max(c);
                    return Some(self.turn(high, k, v, false, 0.0));
                }
                rise.since = rise.since.max(up);
                fall.since = fall.since.max(down);
                self.heading = Heading::Unknown {
                    low,
                    high,
                    rise,
                    fall,
                };
                None
            }
            Heading::Moving {
                up,
                ext,
                counter,
                retreat_to,
                back,
            } => {
                // Distances counted along the move's direction.
                let (ahead, deeper) = if up {
                    (v >= ext.1, v < retreat_to)
                } else {
                    (v <= ext.1, v > retreat_to)
                };
                if ahead {
                    // The retreat since the extreme came back: a counter-move inside the move.
                    let c = counter.max((ext.1 - retreat_to).abs());
                    self.heading = Heading::Moving {
                        up,
                        ext: (k, v),
                        counter: c,
                        retreat_to: v,
                        back: 0.0,
                    };
                    return None;
                }
                let retreat_to = if deeper { v } else { retreat_to };
                let back = back.max((v - retreat_to).abs());
                if (ext.1 - v).abs() > self.eps {
                    // The retreat's own samples begin the next move: their moves back count
                    // against it.
                    self.counter_max = self.counter_max.max(counter);
                    return Some(self.turn(ext, k, v, !up, back));
                }
                self.heading = Heading::Moving {
                    up,
                    ext,
                    counter,
                    retreat_to,
                    back,
                };
                None
            }
        }
    }

    /// Takes in samples `k`, `k + 1`, … of `z` (`k` the next sample [`push`](Self::push)
    /// expects) while each only renews the running extreme of a move that has not retreated
    /// since its extreme was last renewed; returns the first sample not taken.
    ///
    /// Exactly what `push` does with those samples: a renewal with no retreat since the
    /// last one moves the extreme, leaves the counter-move as it is (it is raised by the
    /// retreat's size, a zero; the counter-move is never NaN or −0) and no turn comes of it.
    #[inline]
    fn renew_run(&mut self, z: &[f64], mut k: usize) -> usize {
        let Heading::Moving {
            up,
            ext,
            counter,
            retreat_to,
            ..
        } = self.heading
        else {
            return k;
        };
        // Only after a renewal (or a turn) is the retreat at the extreme: a deeper sample
        // moves it strictly past.
        #[allow(clippy::float_cmp)]
        let fresh = retreat_to == ext.1;
        if !fresh || k >= z.len() {
            return k;
        }
        let (k0, mut top) = (k, ext.1);
        if up {
            while k < z.len() && z[k] >= top {
                top = z[k];
                k += 1;
            }
        } else {
            while k < z.len() && z[k] <= top {
                top = z[k];
                k += 1;
            }
        }
        if k > k0 {
            self.heading = Heading::Moving {
                up,
                ext: (k - 1, top),
                counter,
                retreat_to: top,
                back: 0.0,
            };
        }
        k
    }

    /// The turning points that end a channel of `n` samples (pushed onto `tp`): the last
    /// extreme, or the first and last sample when no direction was ever found.
    pub(crate) fn finish(&mut self, n: usize, tp: &mut Vec<usize>) {
        match self.heading {
            Heading::Unknown { rise, fall, .. } => {
                let c = rise.before.max(rise.since).max(fall.before).max(fall.since);
                self.counter_max = self.counter_max.max(c);
                tp.clear();
                tp.extend([0, n - 1]);
            }
            Heading::Moving {
                ext,
                counter,
                retreat_to,
                ..
            } => {
                // A smaller ε would turn at the retreat after the last extreme; a larger one
                // than the last move's travel would not have taken the last turn.
                let c = counter.max((ext.1 - retreat_to).abs());
                self.counter_max = self.counter_max.max(c);
                if let Some((_, z)) = self.last_tp {
                    self.travel_min = self.travel_min.min((ext.1 - z).abs());
                }
                if self.last_tp.map(|t| t.0) != Some(ext.0) {
                    tp.push(ext.0);
                }
            }
        }
    }
}

/// `v` as an integer that orders like [`f64::total_cmp`]: selections then compare integers
/// (one instruction) instead of calling `total_cmp` on every comparison. The same order picks
/// the same element, so every median and percentile is bit for bit what `total_cmp` gives.
fn order_key(v: f64) -> i64 {
    // As `f64::total_cmp`: negative values have their magnitude bits flipped.
    let b = v.to_bits() as i64;
    b ^ ((((b >> 63) as u64) >> 1) as i64)
}

/// The value of an [`order_key`] (the flip leaves the sign bit alone, so it undoes itself).
fn from_order_key(k: i64) -> f64 {
    f64::from_bits(order_key(f64::from_bits(k as u64)) as u64)
}

/// The element of rank `rank` in the `total_cmp` order of the values keyed in `keys`
/// (reordered).
fn select_key(keys: &mut [i64], rank: usize) -> f64 {
    from_order_key(*keys.select_nth_unstable(rank).1)
}

/// Keys beyond which [`find_moves`] ranks in place ([`radix_select`]) rather than on a copy.
const RADIX_SELECT_MIN: usize = 1 << 18;

/// The key of rank `rank` in the `total_cmp` order among the `keys` that `keep` accepts,
/// found without copying or reordering them: four passes over the keys, each counting the
/// next 16 bits of those that share the bits found so far (keys in unsigned order: the sign
/// bit flipped). Exactly the element [`select_key`] finds on a copy of the kept keys.
///
/// # Panics
/// When `rank` is not below the number of kept keys (a caller's mistake).
fn radix_select(keys: &[i64], keep: impl Fn(&i64) -> bool, mut rank: usize) -> i64 {
    let unsigned = |k: i64| (k as u64) ^ (1 << 63);
    let mut counts = vec![0usize; 1 << 16];
    let mut prefix = 0u64;
    for pass in 0..4u32 {
        let shift = 48 - 16 * pass;
        counts.fill(0);
        for k in keys.iter().filter(|k| keep(k)) {
            let u = unsigned(*k);
            // The bits above this pass's digit must be those found so far.
            if pass == 0 || u >> (shift + 16) == prefix {
                counts[((u >> shift) & 0xffff) as usize] += 1;
            }
        }
        let mut digit = 0;
        loop {
            assert!(digit < counts.len(), "rank beyond the kept keys");
            if rank < counts[digit] {
                break;
            }
            rank -= counts[digit];
            digit += 1;
        }
        prefix = (prefix << 16) | digit as u64;
    }
    (prefix ^ (1 << 63)) as i64
}

/// Keys up to which [`select_in`] selects on a plain copy of the kept keys.
const DIRECT_SELECT_MAX: usize = 2048;

/// Keys [`select_in`] samples to bracket the rank it looks for.
const SELECT_SAMPLE: usize = 512;

/// The [`order_key`]s of the values `v` with `v >= min` (in `f64` comparison): a range,
/// inclusive; None when no value passes (`min` is NaN).
fn keys_at_least(min: f64) -> Option<(i64, i64)> {
    if min.is_nan() {
        return None;
    }
    // −0 and +0 compare equal, so a bound of either zero lets both pass; every other bound
    // passes exactly the values at or above it in the `total_cmp` order, up to +∞ (a NaN
    // passes no bound).
    let lo = if min == 0.0 {
        order_key(-0.0)
    } else {
        order_key(min)
    };
    Some((lo, order_key(f64::INFINITY)))
}

/// The key of rank `rank_of(count)` in increasing order among the `count` keys kept (those
/// in `range`, inclusive, when `FILTERED`; every key otherwise), or None when none is kept.
/// `rank_of(count)` must be below `count`, for any count.
///
/// The same key as `select_nth_unstable` on a copy of the kept keys: the element of a rank
/// in a total order is one value. A sample of the kept keys brackets where the rank
/// probably lies; one pass counts the keys below the bracket and copies those inside it into
/// `bracket` (which only grows, so it is never filled twice), and the rank is selected
/// there: a small fraction of the keys instead of a copy of all of them. When the bracket
/// misses the rank (an unlucky sample), the selection is made on a copy in `copy`, or in
/// place by radix passes for many keys, as before.
fn select_in<const FILTERED: bool>(
    keys: &[i64],
    range: (i64, i64),
    rank_of: impl Fn(usize) -> usize,
    bracket: &mut Vec<i64>,
    copy: &mut Vec<i64>,
) -> Option<i64> {
    // Unfiltered, the range (the bracket's open ends) reaches every key.
    let (lo, hi) = if FILTERED {
        range
    } else {
        (i64::MIN, i64::MAX)
    };
    let kept = |k: i64| !FILTERED || (lo <= k && k <= hi);
    let n = keys.len();
    if n > DIRECT_SELECT_MAX {
        let stride = n / SELECT_SAMPLE;
        copy.clear();
        copy.extend(
            keys.iter()
                .skip(stride / 2)
                .step_by(stride)
                .copied()
                .filter(|&k| kept(k)),
        );
        if let Some(k) = select_bracketed::<FILTERED>(keys, (lo, hi), &rank_of, bracket, copy) {
            return Some(k);
        }
    }
    let count = if FILTERED {
        keys.iter().filter(|&&k| kept(k)).count()
    } else {
        n
    };
    if count == 0 {
        return None;
    }
    let rank = rank_of(count);
    if n > RADIX_SELECT_MIN {
        // A copy of a 10 M-sample stroke's keys would cost 80 MB.
        return Some(radix_select(keys, |&k| kept(k), rank));
    }
    copy.clear();
    copy.extend(keys.iter().copied().filter(|&k| kept(k)));
    Some(*copy.select_nth_unstable(rank).1)
}

/// [`select_in`] within a bracket taken from the kept keys in `sample` (reordered): None when
/// the sample is too small, the rank falls outside the bracket, or the bracket holds more
/// keys than `bracket` may (then the caller selects another way; no kept key means None too).
fn select_bracketed<const FILTERED: bool>(
    keys: &[i64],
    (lo, hi): (i64, i64),
    rank_of: impl Fn(usize) -> usize,
    bracket: &mut Vec<i64>,
    sample: &mut [i64],
) -> Option<i64> {
    let ms = sample.len();
    if ms < 64 {
        return None;
    }
    // The rank's place in the sample, and a margin of 4 standard deviations of a sample
    // quantile around it (plus a few for ties and rounding).
    let at = rank_of(ms).min(ms - 1);
    let p = (at as f64 + 0.5) / ms as f64;
    let margin = (4.0 * (ms as f64 * p * (1.0 - p)).sqrt()) as usize + 4;
    let (l, h) = match (at.checked_sub(margin), at + margin < ms) {
        (Some(i), true) => {
            let (_, &mut l, above) = sample.select_nth_unstable(i);
            (l, *above.select_nth_unstable(at + margin - i - 1).1)
        }
        (Some(i), false) => (*sample.select_nth_unstable(i).1, hi),
        (None, true) => (lo, *sample.select_nth_unstable(at + margin).1),
        (None, false) => (lo, hi),
    };
    let n = keys.len();
    let cap = n.min(RADIX_SELECT_MIN);
    if bracket.len() <= cap {
        bracket.resize(cap + 1, 0);
    }
    let buf = &mut bracket[..=cap];
    // Chord speeds repeat exactly (quantised steps over near-equal intervals), often by the
    // thousand: the keys equal to either end of the bracket are counted, not copied, and
    // only those strictly inside are. Branch-free: every key is written at the next free
    // place, which only advances past the keys strictly inside; once `cap` of them are in,
    // the rest overwrite the spare place at `cap` (and with more than `cap` the bracket is
    // given up below).
    let inner_lo = l.wrapping_add(1);
    let inner_width = (h.wrapping_sub(l) as u64).saturating_sub(1);
    let (mut below_lo, mut above_hi) = (0usize, 0usize);
    let (mut below_l, mut to_l, mut to_h, mut m) = (0usize, 0usize, 0usize, 0usize);
    for &k in keys {
        if FILTERED {
            below_lo += usize::from(k < lo);
            above_hi += usize::from(k > hi);
        }
        below_l += usize::from(k < l);
        to_l += usize::from(k <= l);
        to_h += usize::from(k <= h);
        buf[m.min(cap)] = k;
        m += usize::from((k.wrapping_sub(inner_lo) as u64) < inner_width);
    }
    let count = n - below_lo - above_hi;
    if count == 0 || m > cap {
        return None;
    }
    let rank = rank_of(count);
    // The bracket lies within the kept range: every key below it (or at or below one of its
    // ends) that is not below the range is kept. In increasing order the kept keys are
    // those below `l`, those equal to it, those strictly inside, those equal to `h` (none
    // more when `h` is `l`), and those above.
    let r = rank + below_lo;
    if r < below_l {
        None
    } else if r < to_l {
        Some(l)
    } else if r < to_l + m {
        Some(*buf[..m].select_nth_unstable(r - to_l).1)
    } else if r < to_h {
        Some(h)
    } else {
        None
    }
}

/// The upper median of the keyed values (NaN when there are none); reorders `keys`.
fn median_key(keys: &mut [i64]) -> f64 {
    if keys.is_empty() {
        return f64::NAN;
    }
    let mid = keys.len() / 2;
    select_key(keys, mid)
}

/// Whether a run of chord speeds holds its feed, rather than only passing through its top
/// speed: a move too short to reach its programmed feed (a triangle of speed, typically a
/// short rapid) rises to one peak and falls again. The run is cut into 20 blocks (fewer for a
/// short run, at least 5) whose median
/// speeds are compared: it is a triangle when the blocks rise to a single peak and fall after
/// it (each step within 1 % of monotone), the first and last block lie below 80 % of the peak,
/// and at most 2 blocks are within 2 % of it. A feed held for a tenth of the run already
/// makes 2 blocks flat; a modulated feed rises and falls more than once.
///
/// `keys` are the speeds' [`order_key`]s, none NaN, and `top` is the largest of them;
/// `scratch` is reused for the blocks.
fn holds_a_plateau(keys: &[i64], top: i64, scratch: &mut Vec<i64>) -> bool {
    // Fewer chords than blocks (a short move at a slow sampling rate): one chord a block.
    let blocks_n = keys.len().min(20);
    if blocks_n < 5 {
        return true;
    }
    let bounds = |b: usize| (b * keys.len() / blocks_n, (b + 1) * keys.len() / blocks_n);
    // A run whose first (or last) block's median is at least 80 % of the top speed cannot end
    // low, whatever the other blocks' medians (the peak among them is at most the top, and
    // 0.8 × x rounds monotonically): a held feed is told by one count over that block. The
    // median (the element at the middle place) reaches a bound when no more keys than
    // that place lie below it.
    let floor = 0.8 * from_order_key(top);
    for b in [0, blocks_n - 1] {
        let (i, j) = bounds(b);
        let low = keys[i..j]
            .iter()
            .filter(|&&k| from_order_key(k) < floor)
            .count();
        if low <= (j - i) / 2 {
            return true;
        }
    }
    let mut blocks = [0.0; 20];
    for (b, v) in blocks[..blocks_n].iter_mut().enumerate() {
        let (i, j) = bounds(b);
        scratch.clear();
        scratch.extend_from_slice(&keys[i..j]);
        *v = median_key(scratch);
    }
    let blocks = &blocks[..blocks_n];
    let (peak_at, peak) =
        blocks
            .iter()
            .copied()
            .enumerate()
            .fold(
                (0, f64::NEG_INFINITY),
                |a, (k, v)| if v > a.1 { (k, v) } else { a },
            );
    let rising = blocks[..=peak_at].windows(2).all(|w| w[1] >= 0.99 * w[0]);
    let falling = blocks[peak_at..].windows(2).all(|w| w[1] <= 1.01 * w[0]);
    let ends_low = blocks[0] < 0.8 * peak && blocks[blocks_n - 1] < 0.8 * peak;
    let near_peak = blocks.iter().filter(|&&v| v >= 0.98 * peak).count();
    !(rising && falling && ends_low && near_peak <= 2)
}

/// Find the steady strokes in a position channel (time strictly increasing).
pub fn find_strokes(position: &Channel, params: &SegmentParams) -> Vec<StrokeSpan> {
    find_moves(position, params)
        .into_iter()
        .flat_map(|m| m.strokes)
        .collect()
}

/// Every move between turning points, each with its steady strokes (module docs, steps 1-3).
pub fn find_moves(position: &Channel, params: &SegmentParams) -> Vec<MoveSpan> {
    let (t, z) = (&position.time_s, &position.value);
    let n = z.len();
    if n < 2 {
        return Vec::new();
    }
    let (quantum, eps) = quantum_and_hysteresis_m(z);
    let tp = turning_points(z, eps);
    let mut moves: Vec<MoveSpan> = Vec::new();
    let mut scratch = MoveScratch::default();
    for w in tp.windows(2) {
        let (i0, i1) = (w[0], w[1]);
        if i1 <= i0 || (z[i1] - z[i0]).abs() <= eps {
            continue;
        }
        let m = move_between(t, z, i0, i1, quantum, params, moves.len(), &mut scratch);
        moves.push(m);
    }
    moves
}

/// Buffers [`move_between`] reuses from move to move.
#[derive(Debug, Default)]
pub(crate) struct MoveScratch {
    /// The chord speeds' order keys (see `order_key`; a speed is `from_order_key` of its key).
    keys: Vec<i64>,
    /// The keys inside a selection's bracket (see `select_in`; it only grows).
    bracket: Vec<i64>,
    /// A selection's sample, or a copy of the keys it selects from, or a block of them.
    copy: Vec<i64>,
}

/// Samples a chord spans in the move from knot `i0` to `i1`, so that each covers at least 8
/// position quanta: at a slow feed with coarse quantisation, consecutive samples often repeat
/// a position and single-step chord speeds jump between 0 and one quantum per interval.
pub(crate) fn chord_samples(z: &[f64], i0: usize, i1: usize, quantum: f64) -> usize {
    chord_samples_of((z[i1] - z[i0]).abs(), i1 - i0, quantum)
}

/// [`chord_samples`] of a move that travels `travel_m` over `steps` sample intervals.
pub(crate) fn chord_samples_of(travel_m: f64, steps: usize, quantum: f64) -> usize {
    let mean_step = travel_m / steps as f64;
    if mean_step > 0.0 {
        ((8.0 * quantum / mean_step).ceil() as usize).clamp(1, (steps / 4).max(1))
    } else {
        1
    }
}

/// The move between the turning points `i0` < `i1` (whose travel exceeds the hysteresis), with
/// its plateau and top speed and its steady strokes (steps 2-3); it is move number
/// `move_index`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn move_between(
    t: &[f64],
    z: &[f64],
    i0: usize,
    i1: usize,
    quantum: f64,
    params: &SegmentParams,
    move_index: usize,
    scratch: &mut MoveScratch,
) -> MoveSpan {
    let dir = if z[i1] > z[i0] {
        Direction::Forward
    } else {
        Direction::Backward
    };
    let mut this = MoveSpan {
        direction: dir,
        first: i0,
        last: i1,
        plateau_speed_m_s: 0.0,
        top_speed_m_s: 0.0,
        strokes: Vec::new(),
    };
    if i1 <= i0 + 1 {
        return this;
    }
    let s = dir.sign();
    let w = chord_samples(z, i0, i1, quantum);
    if i1 < i0 + w {
        return this;
    }
    let MoveScratch {
        keys,
        bracket,
        copy,
    } = scratch;
    // Chord k joins knots k and k + w: as zipped slices, free of bounds checks.
    let (z0, z1) = (&z[i0..=i1 - w], &z[i0 + w..=i1]);
    let (t0, t1) = (&t[i0..=i1 - w], &t[i0 + w..=i1]);
    keys.clear();
    keys.extend(
        z0.iter()
            .zip(z1)
            .zip(t0.iter().zip(t1))
            .map(|((&za, &zb), (&ta, &tb))| order_key(s * (zb - za) / (tb - ta))),
    );
    let n = keys.len();
    let rank95 = |len: usize| ((len - 1) as f64 * 0.95).round() as usize;
    let Some(p95) =
        select_in::<false>(keys, (i64::MIN, i64::MAX), rank95, bracket, copy).map(from_order_key)
    else {
        return this;
    };
    if p95.is_nan() || p95 <= 0.0 {
        return this;
    }
    // The median of the chords at least a quarter of the top speed (never none: p95 is one).
    let plateau = keys_at_least(0.25 * p95)
        .and_then(|fast| select_in::<true>(keys, fast, |len| len / 2, bracket, copy))
        .map_or(f64::NAN, from_order_key);
    this.plateau_speed_m_s = plateau;
    this.top_speed_m_s = p95;
    // Steady chords, by their keys (no steady chord under a NaN threshold).
    let Some((steady_lo, steady_hi)) = keys_at_least(params.steady_fraction * plateau) else {
        return this;
    };
    let steady = |k: i64| steady_lo <= k && k <= steady_hi;
    // Maximal runs of steady chords.
    let mut c = 0;
    while c < n {
        if !steady(keys[c]) {
            c += 1;
            continue;
        }
        let c0 = c;
        let mut top = keys[c];
        while c < n && steady(keys[c]) {
            top = top.max(keys[c]);
            c += 1;
        }
        let c1 = c - 1; // last steady chord
        if !holds_a_plateau(&keys[c0..=c1], top, copy) {
            continue;
        }
        // Chord c joins knots i0+c and i0+c+w. A steady chord may straddle the start (or
        // end) of the motion, so the stroke keeps only knots inside every steady chord's
        // reach: from the end of the first to the start of the last (for w = 1 this is
        // the whole run), then trims.
        let first = i0 + c0 + (w - 1) + params.trim_knots;
        let last = (i0 + c1 + 1).saturating_sub(params.trim_knots);
        if last < first || last + 1 - first < params.min_knots.max(4) {
            continue;
        }
        if (z[last] - z[first]).abs() < params.min_stroke_mm * 1e-3 {
            continue;
        }
        // The feed of the stroke: its mean speed, exact also when single chords are coarse.
        let speed = (z[last] - z[first]).abs() / (t[last] - t[first]);
        this.strokes.push(StrokeSpan {
            direction: dir,
            first,
            last,
            plateau_speed_m_s: speed,
            move_index,
            move_first: i0,
            move_last: i1,
        });
    }
    this
}

/// The stretches of the trace not covered by `strokes` (in time order).
pub fn zones_between(position: &Channel, strokes: &[StrokeSpan]) -> Vec<Zone> {
    let (t, z) = (&position.time_s, &position.value);
    zones_of(t.len(), strokes, |k| (t[k], z[k]))
}

/// [`zones_between`] over a channel of `n` samples known only through `at(k)`, the time (s)
/// and position (m) of sample `k`: it asks only for the first and last sample and the ends of
/// the strokes (what a streamed estimate keeps).
pub(crate) fn zones_of(
    n: usize,
    strokes: &[StrokeSpan],
    at: impl Fn(usize) -> (f64, f64),
) -> Vec<Zone> {
    let mut zones = Vec::new();
    let zone = |kind, a: usize, b: usize| {
        let ((ta, za), (tb, zb)) = (at(a), at(b));
        Zone {
            kind,
            start_time_s: ta,
            end_time_s: tb,
            start_position_mm: za * 1e3,
            end_position_mm: zb * 1e3,
        }
    };
    if let Some(f) = strokes.first() {
        if f.first > 0 {
            zones.push(zone(ZoneKind::Start, 0, f.first));
        }
    }
    for w in strokes.windows(2) {
        let kind = if w[0].direction == w[1].direction {
            ZoneKind::Pause
        } else {
            ZoneKind::Reversal
        };
        zones.push(zone(kind, w[0].last, w[1].first));
    }
    if let Some(l) = strokes.last() {
        if l.last + 1 < n {
            zones.push(zone(ZoneKind::End, l.last, n - 1));
        }
    }
    zones
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Forward 0→100 mm at 10 mm/s, dwell 1 s, back at 5 mm/s; 50 ms sampling, 1 µm steps.
    fn back_and_forth() -> Channel {
        let mut c = Channel::default();
        let mut t = 0.0;
        while t < 33.0 {
            let z_mm = if t < 1.0 {
                0.0
            } else if t < 11.0 {
                10.0 * (t - 1.0)
            } else if t < 12.0 {
                100.0
            } else if t < 32.0 {
                100.0 - 5.0 * (t - 12.0)
            } else {
                0.0
            };
            c.time_s.push(t);
            c.value.push((z_mm * 1e3).round() * 1e-6);
            t += 0.05;
        }
        c
    }

    #[test]
    fn finds_both_strokes_and_zones() {
        let c = back_and_forth();
        let s = find_strokes(&c, &SegmentParams::default());
        assert_eq!(s.len(), 2, "{s:?}");
        assert_eq!(s[0].direction, Direction::Forward);
        assert_eq!(s[1].direction, Direction::Backward);
        assert!((s[0].plateau_speed_m_s - 0.010).abs() < 1e-6);
        assert!((s[1].plateau_speed_m_s - 0.005).abs() < 1e-6);
        // Steady parts only: no knot of the dwell at 0 or 100 mm.
        for sp in &s {
            for k in sp.first..=sp.last {
                let zmm = c.value[k] * 1e3;
                assert!(zmm > 0.05 && zmm < 99.95, "knot {k} at {zmm} mm");
            }
        }
        let zones = zones_between(&c, &s);
        let kinds: Vec<_> = zones.iter().map(|z| z.kind).collect();
        assert_eq!(kinds, [ZoneKind::Start, ZoneKind::Reversal, ZoneKind::End]);
        assert!(zones[1].start_time_s < 11.0 && zones[1].end_time_s > 12.0);
    }

    #[test]
    fn dwell_noise_is_not_a_stroke() {
        let mut c = back_and_forth();
        // ±1 µm jitter everywhere.
        for (k, v) in c.value.iter_mut().enumerate() {
            *v += if k % 2 == 0 { 1e-6 } else { -1e-6 };
        }
        let s = find_strokes(&c, &SegmentParams::default());
        assert_eq!(s.len(), 2);
    }

    #[test]
    fn slow_feed_below_one_quantum_per_sample() {
        // 10 mm/min sampled every 5 ms moves 0.83 µm per sample; positions in 1 µm steps.
        let mut c = Channel::default();
        for k in 0..40_000 {
            let t = k as f64 * 0.005;
            let z_um = if t < 1.0 {
                0.0
            } else {
                (t - 1.0) * 10_000.0 / 60.0
            };
            c.time_s.push(t);
            c.value.push(z_um.round() * 1e-6);
        }
        let s = find_strokes(&c, &SegmentParams::default());
        assert_eq!(s.len(), 1, "{s:?}");
        assert!((s[0].plateau_speed_m_s * 60e3 - 10.0).abs() < 0.2);
        assert!(c.time_s[s[0].first] < 1.2 && c.time_s[s[0].last] > 199.0);
    }

    #[test]
    fn radix_selection_is_the_copys_selection() {
        // Quantised speeds (many exact repeats), both signs, and a filter, at every 37th rank.
        let v: Vec<f64> = (0..20_000)
            .map(|k| {
                let x = ((k as f64 * 12.9898).sin() * 43758.5453).fract() - 0.3;
                if k % 3 == 0 {
                    (x * 50.0).round() * 1e-5
                } else {
                    x * 1e-3
                }
            })
            .collect();
        let keys: Vec<i64> = v.iter().map(|&x| order_key(x)).collect();
        for (keep, name) in [
            (Box::new(|_: &i64| true) as Box<dyn Fn(&i64) -> bool>, "all"),
            (Box::new(|k: &i64| from_order_key(*k) >= 1e-4), "fast"),
        ] {
            let mut kept: Vec<i64> = keys.iter().copied().filter(|k| keep(k)).collect();
            for rank in (0..kept.len()).step_by(37).chain([kept.len() - 1]) {
                let want = select_key(&mut kept, rank);
                let got = from_order_key(radix_select(&keys, &keep, rank));
                assert_eq!(got.to_bits(), want.to_bits(), "{name}, rank {rank}");
            }
        }
    }

    #[test]
    fn order_keys_select_as_total_cmp() {
        // Signed zeros, infinities, NaNs of both signs, subnormals, repeats and ordinary values:
        // every rank selected through the keys is bit for bit the `total_cmp` selection.
        let special = [
            0.0,
            -0.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            -f64::NAN,
            f64::MIN_POSITIVE / 4.0,
            -f64::MIN_POSITIVE / 4.0,
            f64::MAX,
            f64::MIN,
            1.5,
            1.5,
            -2.25,
        ];
        let mut v: Vec<f64> = special.to_vec();
        v.extend((0..200).map(|k| ((k as f64 * 12.9898).sin() * 43758.5453).fract() - 0.5));
        for rank in 0..v.len() {
            let mut want = v.clone();
            let w = *want.select_nth_unstable_by(rank, f64::total_cmp).1;
            let mut keys: Vec<i64> = v.iter().map(|&x| order_key(x)).collect();
            assert_eq!(
                select_key(&mut keys, rank).to_bits(),
                w.to_bits(),
                "rank {rank}"
            );
        }
        for &x in &v {
            assert_eq!(from_order_key(order_key(x)).to_bits(), x.to_bits());
        }
    }

    #[test]
    fn no_motion_no_stroke() {
        let c = Channel {
            time_s: (0..100).map(|k| k as f64).collect(),
            value: vec![0.0; 100],
        };
        assert!(find_strokes(&c, &SegmentParams::default()).is_empty());
    }

    /// The claim that lets a stream check its prefix's ε: every ε' with
    /// counter_max ≤ ε' < travel_min finds the same turning points, and an ε' outside that
    /// range finds others on these walks (so the range is not merely loose).
    #[test]
    fn any_hysteresis_between_counter_moves_and_travels_finds_the_same_turns() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(5);
        let (mut checked, mut tight) = (0, 0);
        for walk in 0..400 {
            // Legs of random length and speed, with dwells, jitter and quantisation.
            let mut z = Vec::new();
            let mut x = 0.0f64;
            let q = [0.0, 1e-7, 1e-6][walk % 3];
            while z.len() < 3000 {
                let v = rng.random_range(-2e-4..2e-4) * f64::from(rng.random_range(0u8..2));
                for _ in 0..rng.random_range(1..200) {
                    x += v + rng.random_range(-3e-6..3e-6);
                    z.push(if q > 0.0 { (x / q).round() * q } else { x });
                }
            }
            let eps = rng.random_range(1e-6..5e-5);
            let mut finder = TurnFinder::new(eps);
            let mut tp = Vec::new();
            for (k, &v) in z.iter().enumerate() {
                if let Some(i) = finder.push(k, v) {
                    tp.push(i);
                }
            }
            finder.finish(z.len(), &mut tp);
            assert_eq!(tp, turning_points(&z, eps));
            let (lo, hi) = (finder.counter_max, finder.travel_min);
            assert!(lo <= eps && eps < hi, "walk {walk}: {lo} {eps} {hi}");
            for f in [0.0, 0.25, 0.5, 0.999] {
                let other = lo + f * (hi.min(1.0) - lo);
                if other >= lo && other < hi {
                    assert_eq!(turning_points(&z, other), tp, "walk {walk}, ε' = {other}");
                    checked += 1;
                }
            }
            // Just outside the range something changes.
            if lo > 1e-9 && turning_points(&z, lo * (1.0 - 1e-9)) != tp {
                tight += 1;
            }
        }
        assert!(checked > 1000, "{checked}");
        assert!(tight > 100, "{tight}");
    }

    /// Values for the selection oracles: quantised (heavy ties) and plain, both signs, and
    /// the special values of `order_keys_select_as_total_cmp` sprinkled in.
    fn oracle_values(n: usize, seed: u64, specials: bool) -> Vec<f64> {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let special = [
            0.0,
            -0.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            -f64::NAN,
            f64::MIN_POSITIVE / 4.0,
            -f64::MIN_POSITIVE / 4.0,
            f64::MAX,
            f64::MIN,
        ];
        let step = [1e-4, 1e-3, 0.05][(seed % 3) as usize];
        (0..n)
            .map(|_| {
                let x: f64 = rng.random_range(-0.3..1.0);
                match rng.random_range(0..20) {
                    0 if specials => special[rng.random_range(0..special.len())],
                    1..=12 => (x / step).round() * step,
                    _ => x * 1e-2,
                }
            })
            .collect()
    }

    /// `select_in` against `select_key` on a copy of the kept keys, bit for bit.
    fn check_select_in(keys: &[i64], range: Option<(i64, i64)>, ranks_every: usize, what: &str) {
        let kept: Vec<i64> = keys
            .iter()
            .copied()
            .filter(|&k| range.is_none_or(|(lo, hi)| lo <= k && k <= hi))
            .collect();
        let count = kept.len();
        let (mut bracket, mut copy) = (Vec::new(), Vec::new());
        let mut select = |rank_of: &dyn Fn(usize) -> usize| match range {
            None => select_in::<false>(keys, (0, 0), rank_of, &mut bracket, &mut copy),
            Some(r) => select_in::<true>(keys, r, rank_of, &mut bracket, &mut copy),
        };
        if count == 0 {
            assert_eq!(select(&|_| 0), None, "{what}: nothing kept");
            return;
        }
        let mut ranks: Vec<usize> = (0..count).step_by(ranks_every).collect();
        ranks.extend([
            count / 2,
            count - 1,
            ((count - 1) as f64 * 0.95).round() as usize,
        ]);
        for rank in ranks {
            // The same quantile of any other count (the sample's), this rank of `count`.
            let rank_of = |len: usize| (rank * len / count).min(len - 1);
            let want = select_key(&mut kept.clone(), rank);
            let got = select(&rank_of).map(from_order_key);
            assert_eq!(
                got.map(f64::to_bits),
                Some(want.to_bits()),
                "{what}: rank {rank} of {count}"
            );
        }
        // The two rank rules of `move_between`.
        let mut sorted = kept.clone();
        sorted.sort_unstable();
        let p95 = select(&|len| ((len - 1) as f64 * 0.95).round() as usize);
        assert_eq!(
            p95,
            Some(sorted[((count - 1) as f64 * 0.95).round() as usize])
        );
        assert_eq!(select(&|len| len / 2), Some(sorted[count / 2]), "{what}");
    }

    #[test]
    fn bracketed_selection_is_the_copys_selection() {
        let sizes = [
            1, 2, 3, 5, 10, 64, 100, 2047, 2048, 2049, 3000, 20_000, 300_000,
        ];
        for (i, &n) in sizes.iter().enumerate() {
            for specials in [false, true] {
                let v = oracle_values(n, i as u64 * 7 + u64::from(specials), specials);
                let keys: Vec<i64> = v.iter().map(|&x| order_key(x)).collect();
                let every = if n <= 3000 { 1 } else { n / 97 };
                let what = format!("n {n}, specials {specials}");
                check_select_in(&keys, None, every, &format!("{what}, all"));
                for min in [0.0, -0.0, 1e-3, 0.25, 0.9, 2.0, f64::INFINITY, f64::MIN] {
                    let r = keys_at_least(min);
                    check_select_in(&keys, r, every, &format!("{what}, v ≥ {min}"));
                }
                // Arbitrary key ranges, reaching into the negatives and NaNs.
                let (a, b) = (order_key(-0.1), order_key(0.3));
                check_select_in(&keys, Some((a, b)), every, &format!("{what}, range"));
                check_select_in(&keys, Some((i64::MIN, a)), every, &format!("{what}, low"));
                check_select_in(&keys, Some((b, i64::MAX)), every, &format!("{what}, high"));
                check_select_in(&keys, Some((b, a)), every, &format!("{what}, empty"));
            }
        }
        // A sample that misses: the values at the sampled places are far from the rest.
        for n in [5000, 300_000] {
            let stride = n / SELECT_SAMPLE;
            let keys: Vec<i64> = (0..n)
                .map(|k| {
                    let x = if k % stride == stride / 2 { 10.0 } else { 1e-3 };
                    order_key(x * (1.0 + (k % 13) as f64 * 1e-3))
                })
                .collect();
            check_select_in(&keys, None, n / 53, "biased sample");
            check_select_in(&keys, keys_at_least(5.0), 1, "biased sample, filtered");
            // All equal.
            check_select_in(&vec![order_key(0.5); n], None, n / 53, "equal");
        }
    }

    #[test]
    fn one_pass_quantum_and_hysteresis_are_the_folds() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        for n in (2..40).chain([1000, 4097]) {
            for _ in 0..20 {
                let z: Vec<f64> = (0..n)
                    .map(|_| match rng.random_range(0..30) {
                        0 => f64::NAN,
                        1 => 0.0,
                        2 => -0.0,
                        3 => 1e-13,
                        _ => (rng.random_range(-0.2..0.4f64) / 1e-6).round() * 1e-6,
                    })
                    .collect();
                let q = position_quantum_m(&z);
                let (lo, hi) = z
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                        (a.min(v), b.max(v))
                    });
                let (q1, eps1) = quantum_and_hysteresis_m(&z);
                assert_eq!(q1.to_bits(), q.to_bits(), "{z:?}");
                assert_eq!(eps1.to_bits(), hysteresis_of(q, lo, hi).to_bits(), "{z:?}");
            }
        }
    }

    /// The segmentation as it was before the bracketed selections, the one-pass quantum, the
    /// skipped renewals of the extreme and the counted first block: the reference the new
    /// one must equal.
    mod reference {
        use super::super::*;

        fn select_key(keys: &mut [i64], rank: usize) -> f64 {
            from_order_key(*keys.select_nth_unstable(rank).1)
        }

        fn median_key(keys: &mut [i64]) -> f64 {
            if keys.is_empty() {
                return f64::NAN;
            }
            let mid = keys.len() / 2;
            select_key(keys, mid)
        }

        fn holds_a_plateau(keys: &[i64], scratch: &mut Vec<i64>) -> bool {
            let blocks_n = keys.len().min(20);
            if blocks_n < 5 {
                return true;
            }
            let blocks: Vec<f64> = (0..blocks_n)
                .map(|b| {
                    let (i, j) = (b * keys.len() / blocks_n, (b + 1) * keys.len() / blocks_n);
                    scratch.clear();
                    scratch.extend_from_slice(&keys[i..j]);
                    median_key(scratch)
                })
                .collect();
            let (peak_at, peak) =
                blocks
                    .iter()
                    .copied()
                    .enumerate()
                    .fold(
                        (0, f64::NEG_INFINITY),
                        |a, (k, v)| if v > a.1 { (k, v) } else { a },
                    );
            let rising = blocks[..=peak_at].windows(2).all(|w| w[1] >= 0.99 * w[0]);
            let falling = blocks[peak_at..].windows(2).all(|w| w[1] <= 1.01 * w[0]);
            let ends_low = blocks[0] < 0.8 * peak && blocks[blocks_n - 1] < 0.8 * peak;
            let near_peak = blocks.iter().filter(|&&v| v >= 0.98 * peak).count();
            !(rising && falling && ends_low && near_peak <= 2)
        }

        #[allow(clippy::too_many_arguments)]
        fn move_between(
            t: &[f64],
            z: &[f64],
            i0: usize,
            i1: usize,
            quantum: f64,
            params: &SegmentParams,
            move_index: usize,
            keys: &mut Vec<i64>,
            sel: &mut Vec<i64>,
        ) -> MoveSpan {
            let dir = if z[i1] > z[i0] {
                Direction::Forward
            } else {
                Direction::Backward
            };
            let mut this = MoveSpan {
                direction: dir,
                first: i0,
                last: i1,
                plateau_speed_m_s: 0.0,
                top_speed_m_s: 0.0,
                strokes: Vec::new(),
            };
            if i1 <= i0 + 1 {
                return this;
            }
            let s = dir.sign();
            let w = chord_samples(z, i0, i1, quantum);
            if i1 < i0 + w {
                return this;
            }
            let chord = |k: usize| s * (z[k + w] - z[k]) / (t[k + w] - t[k]);
            keys.clear();
            keys.extend((i0..=i1 - w).map(|k| order_key(chord(k))));
            let speed = |c: usize| from_order_key(keys[c]);
            let rank = ((keys.len() - 1) as f64 * 0.95).round() as usize;
            let long = keys.len() > RADIX_SELECT_MIN;
            let p95 = if long {
                from_order_key(radix_select(keys, |_| true, rank))
            } else {
                sel.clear();
                sel.extend_from_slice(keys);
                select_key(sel, rank)
            };
            if p95.is_nan() || p95 <= 0.0 {
                return this;
            }
            let fast = |k: &i64| from_order_key(*k) >= 0.25 * p95;
            let plateau = if long {
                let count = keys.iter().filter(|k| fast(k)).count();
                if count == 0 {
                    f64::NAN
                } else {
                    from_order_key(radix_select(keys, fast, count / 2))
                }
            } else {
                sel.clear();
                sel.extend(keys.iter().filter(|k| fast(k)));
                median_key(sel)
            };
            this.plateau_speed_m_s = plateau;
            this.top_speed_m_s = p95;
            let threshold = params.steady_fraction * plateau;
            let mut c = 0;
            while c < keys.len() {
                if speed(c) < threshold {
                    c += 1;
                    continue;
                }
                let c0 = c;
                while c < keys.len() && speed(c) >= threshold {
                    c += 1;
                }
                let c1 = c - 1;
                if !holds_a_plateau(&keys[c0..=c1], sel) {
                    continue;
                }
                let first = i0 + c0 + (w - 1) + params.trim_knots;
                let last = (i0 + c1 + 1).saturating_sub(params.trim_knots);
                if last < first || last + 1 - first < params.min_knots.max(4) {
                    continue;
                }
                if (z[last] - z[first]).abs() < params.min_stroke_mm * 1e-3 {
                    continue;
                }
                let speed = (z[last] - z[first]).abs() / (t[last] - t[first]);
                this.strokes.push(StrokeSpan {
                    direction: dir,
                    first,
                    last,
                    plateau_speed_m_s: speed,
                    move_index,
                    move_first: i0,
                    move_last: i1,
                });
            }
            this
        }

        pub(super) fn find_moves(position: &Channel, params: &SegmentParams) -> Vec<MoveSpan> {
            let (t, z) = (&position.time_s, &position.value);
            let n = z.len();
            if n < 2 {
                return Vec::new();
            }
            let quantum = position_quantum_m(z);
            let (lo, hi) = z
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                    (a.min(v), b.max(v))
                });
            let eps = hysteresis_of(quantum, lo, hi);
            let mut finder = TurnFinder::new(eps);
            let mut tp = Vec::new();
            for (k, &v) in z.iter().enumerate() {
                if let Some(i) = finder.push(k, v) {
                    tp.push(i);
                }
            }
            finder.finish(z.len(), &mut tp);
            let mut moves: Vec<MoveSpan> = Vec::new();
            let (mut keys, mut sel) = (Vec::new(), Vec::new());
            for w in tp.windows(2) {
                let (i0, i1) = (w[0], w[1]);
                if i1 <= i0 || (z[i1] - z[i0]).abs() <= eps {
                    continue;
                }
                let m = move_between(
                    t,
                    z,
                    i0,
                    i1,
                    quantum,
                    params,
                    moves.len(),
                    &mut keys,
                    &mut sel,
                );
                moves.push(m);
            }
            moves
        }
    }

    /// A channel of legs (target position mm, feed mm/s, dwell s after it) with trapezoid or
    /// triangle speed profiles (acceleration `acc` mm/s²), sampled every `dt` s with a
    /// jitter of ±`jitter` × dt on the times, positions quantised to `q` m.
    fn legs_channel(
        legs: &[(f64, f64, f64)],
        acc: f64,
        dt: f64,
        jitter: f64,
        q: f64,
        seed: u64,
    ) -> Channel {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        // Piecewise motion: (start time, start mm, signed feed, accel time, cruise time).
        let mut segs = Vec::new();
        let (mut t0, mut z0) = (0.5, 0.0);
        for &(to, feed, dwell) in legs {
            let d: f64 = to - z0;
            let (ta, tc, v) = if d.abs() / feed > feed / acc {
                (feed / acc, d.abs() / feed - feed / acc, feed)
            } else {
                // A triangle: the feed is never reached.
                let v = (d.abs() * acc).sqrt();
                (v / acc, 0.0, v)
            };
            segs.push((t0, z0, v * d.signum(), ta, tc));
            t0 += 2.0 * ta + tc + dwell;
            z0 = to;
        }
        let end = t0 + 0.5;
        let at = |t: f64| {
            let mut z = 0.0;
            for &(s0, zs, v, ta, tc) in &segs {
                if t < s0 {
                    break;
                }
                let u = t - s0;
                let a = v / ta;
                z = zs
                    + if u < ta {
                        0.5 * a * u * u
                    } else if u < ta + tc {
                        0.5 * v * ta + v * (u - ta)
                    } else if u < 2.0 * ta + tc {
                        let r = u - ta - tc;
                        0.5 * v * ta + v * tc + v * r - 0.5 * a * r * r
                    } else {
                        v * (ta + tc)
                    };
            }
            z
        };
        let mut c = Channel::default();
        let mut k = 0.0;
        loop {
            let t = k * dt + rng.random_range(-jitter..=jitter) * dt;
            if t > end {
                break;
            }
            c.time_s.push(t);
            c.value.push((at(t) * 1e-3 / q).round() * q);
            k += 1.0;
        }
        c
    }

    #[test]
    fn find_moves_is_the_reference() {
        // Strokes with dwells, a feed change, short triangular rapids, a jog back and forth.
        let legs = [
            (100.0, 10.0, 0.5),
            (0.0, 5.0, 0.2),
            (3.0, 200.0, 0.3),
            (6.0, 200.0, 0.0),
            (50.0, 2.0, 1.0),
            (50.5, 0.5, 0.4),
            (20.0, 400.0, 0.1),
            (80.0, 25.0, 0.6),
            (80.0, 25.0, 0.6),
            (0.0, 100.0, 0.0),
        ];
        let params = SegmentParams::default();
        let mut checked = 0;
        for (i, (dt, q)) in [
            (0.070, 1e-6),
            (0.070, 1e-7),
            (0.001, 1e-7),
            (0.001, 1e-6),
            (0.004, 1e-6),
            (1.25e-4, 1e-7),
            (1.25e-4, 1e-6),
        ]
        .into_iter()
        .enumerate()
        {
            for (acc, jitter) in [(500.0, 0.0), (3000.0, 0.2), (50.0, 0.05)] {
                let c = legs_channel(&legs, acc, dt, jitter, q, i as u64);
                let want = reference::find_moves(&c, &params);
                let got = find_moves(&c, &params);
                assert_eq!(got, want, "dt {dt}, q {q}, acc {acc}");
                for (g, w) in got.iter().zip(&want) {
                    assert_eq!(g.plateau_speed_m_s.to_bits(), w.plateau_speed_m_s.to_bits());
                    assert_eq!(g.top_speed_m_s.to_bits(), w.top_speed_m_s.to_bits());
                    for (gs, ws) in g.strokes.iter().zip(&w.strokes) {
                        assert_eq!(
                            gs.plateau_speed_m_s.to_bits(),
                            ws.plateau_speed_m_s.to_bits()
                        );
                    }
                }
                assert!(want.iter().any(|m| !m.strokes.is_empty()));
                checked += want.len();
            }
        }
        assert!(checked > 100, "{checked}");
        // Random legs, and one long move beyond the in-place radix threshold.
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        for seed in 0..12 {
            let legs: Vec<(f64, f64, f64)> = (0..8)
                .map(|_| {
                    (
                        rng.random_range(0.0..300.0),
                        [1.0, 10.0, 50.0, 400.0][rng.random_range(0..4)],
                        rng.random_range(0.0..1.0),
                    )
                })
                .collect();
            let dt = [0.070, 0.01, 0.001, 1.25e-4][seed % 4];
            let q = [1e-7, 1e-6][seed % 2];
            let c = legs_channel(&legs, 1000.0, dt, 0.1, q, seed as u64);
            assert_eq!(find_moves(&c, &params), reference::find_moves(&c, &params));
        }
        let c = legs_channel(
            &[(100.0, 2.0, 0.5), (0.0, 5.0, 0.5)],
            200.0,
            1e-4,
            0.0,
            1e-7,
            9,
        );
        let want = reference::find_moves(&c, &params);
        assert!(want.iter().any(|m| m.last - m.first > RADIX_SELECT_MIN));
        assert_eq!(find_moves(&c, &params), want);
    }
}
