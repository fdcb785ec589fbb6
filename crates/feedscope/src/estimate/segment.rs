//! Stroke segmentation: where the table moves at a steady feed, and the dwells and reversals
//! between.
//!
//! 1. Turning points by hysteresis: the position must retreat more than `ε` from its running
//!    extreme before a reversal is declared, so dwell jitter and quantisation never make one.
//!    ε = max(8 × the position quantum seen in the data, 10⁻⁴ × the travel, 0.1 µm).
//! 2. Each move between turning points has a plateau speed P: the median chord speed
//!    (Δz/Δt over `w` consecutive sample intervals, `w` chosen so a chord covers at least 8
//!    position quanta, `chord_samples`) over chords faster than a quarter of the move's
//!    95th-percentile speed.
//! 3. The move's steady part runs from its first chord at ≥ `steady_fraction` × P to its last:
//!    the acceleration and deceleration ramps and the dwells at the ends are left out.
//! 4. Inside the steady part a stroke is cut only where the table (nearly) stops: a
//!    **standstill** is a run of at least [`MIN_STANDSTILL_CHORDS`] consecutive chords slower
//!    than the standstill speed `stop_fraction` × P. One slow chord alone never cuts (a
//!    noisy or late sample shifts one chord's end, and its error comes back in the next one; a
//!    dropped sample only lengthens a chord's interval, not its speed). Each stretch between
//!    standstills is again reduced to its first to last chord at ≥ `steady_fraction` × P, so
//!    the deceleration into a stop and the acceleration out of it stay out. A feed that varies
//!    but never falls below the standstill speed (a modulated feed, an override changed in
//!    the middle of a block) is therefore one stroke.
//! 5. A stretch is a stroke when it holds a feed (`holds_a_plateau`: not only a rise to one
//!    peak and a fall from it), and after `trim_knots` knots are dropped at either end (the
//!    knot at the start of the run, still in the dwell or the acceleration ramp, never enters
//!    the stroke's spline) it keeps at least `min_knots` knots and `min_stroke_mm` of travel.
//!
//! Each stroke carries its feed (the mean speed from its first to its last knot) and the
//! range of its feed: the 5th and 95th percentile of its chord speeds (taken over at most
//! [`FEED_RANGE_SAMPLE`] chords evenly spread over it).
//!
//! Everything not inside a stroke is reported as a [`Zone`]. Two strokes of one move are
//! always separated by a standstill (step 4), so the zone between them is a
//! [`ZoneKind::Pause`].
//!
//! What the chords cannot see: a stop shorter than about two chords. At 1000 mm/min polled
//! every 70 ms an exact stop without dwell (a few tens of ms below the standstill speed) falls
//! inside one or two chords whose mean speed stays far above it, and the two blocks are one
//! stroke.

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
    /// Low end of the stroke's feed range: the 5th percentile of its chord speeds (m/s; see
    /// the module docs).
    pub feed_min_m_s: f64,
    /// High end of the stroke's feed range: the 95th percentile of its chord speeds (m/s).
    pub feed_max_m_s: f64,
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
    /// Between strokes of the same direction: the table stood still in it (a standstill of
    /// one move, module docs step 4, or the two reversals around a move left out).
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
    /// A chord at or above this fraction of the plateau speed counts as steady: the steady
    /// part of a move (and of each stretch between standstills) runs from its first such
    /// chord to its last. Default 0.5.
    pub steady_fraction: f64,
    /// The standstill speed as a fraction of the plateau speed: a stroke is cut where at least
    /// [`MIN_STANDSTILL_CHORDS`] consecutive chords are slower (module docs, step 4).
    /// Default 0.2, which keeps a feed modulated by ±60 % (or an override lowered to 45 %)
    /// one stroke with room for the chords' quantisation error.
    #[serde(default = "default_stop_fraction")]
    pub stop_fraction: f64,
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
            stop_fraction: default_stop_fraction(),
            trim_knots: 2,
            min_stroke_mm: 1.0,
            min_knots: 8,
        }
    }
}

/// [`SegmentParams::stop_fraction`]'s default, also for settings written before it existed.
fn default_stop_fraction() -> f64 {
    0.2
}

/// Consecutive chords below the standstill speed that make a standstill (module docs, step 4):
/// two, so that one chord alone (one noisy sample's error) never cuts a stroke.
pub const MIN_STANDSTILL_CHORDS: usize = 2;

/// Most chords a stroke's feed range is taken over (evenly spread): enough for the 5th and
/// 95th percentile to within a fraction of a percent of rank, and a bounded cost per stroke.
pub const FEED_RANGE_SAMPLE: usize = 1024;

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
/// and at most 2 blocks are within the flatness band of it: 0.5 %, or 3 standard deviations
/// of a block's median where the chords are noisier ([`block_median_noise`]). A feed held for
/// a sixth of the run makes 3 blocks flat; a modulated feed rises and falls more than once.
///
/// The band is narrow because jerk-limited and bell-shaped ramps round the top of a move that
/// never holds its feed: the speed falls off the peak as the square (S-curve) or the cube
/// (bell) of the time from it, so within 2 % of the peak lie 10-16 % of such a move (3-4
/// blocks), within 0.5 % at most 9 % (2 blocks).
///
/// `keys` are the speeds' [`order_key`]s, none NaN, of chords `w` sample intervals long
/// starting at consecutive knots, and `top` is the largest of them; `scratch` is reused for
/// the blocks.
fn holds_a_plateau(keys: &[i64], top: i64, w: usize, scratch: &mut Vec<i64>) -> bool {
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
    if !(rising && falling && ends_low) {
        return true;
    }
    let band = PLATEAU_BAND.max(3.0 * block_median_noise(keys, w, blocks_n, scratch) / peak);
    let near_peak = blocks.iter().filter(|&&v| v >= (1.0 - band) * peak).count();
    near_peak > 2
}

/// How close to its peak (relative) a block's median must be to count as holding it, where
/// the chords are clean ([`holds_a_plateau`]).
const PLATEAU_BAND: f64 = 0.005;

/// Second differences that [`block_median_noise`] takes at most, evenly spread over the run.
const NOISE_SAMPLE: usize = 4096;

/// The standard deviation (m/s) of one block's median speed in [`holds_a_plateau`]'s `blocks_n`
/// blocks, from the chords' noise: the second differences of chords `w` knots apart (which
/// share no sample interval) cancel every linear trend of the speed, so their median
/// magnitude over the run gives the chord noise σ_c = 1.4826 · median|e| / √6 even on a
/// ramp; a block's median of n independent chords scatters by 1.2533 · σ_c / √n. Kinks (a
/// trapezoid's corners) touch a few differences only, which the median ignores.
fn block_median_noise(keys: &[i64], w: usize, blocks_n: usize, scratch: &mut Vec<i64>) -> f64 {
    let lag = w.max(1);
    let Some(m) = keys.len().checked_sub(2 * lag).filter(|&m| m > 0) else {
        return 0.0;
    };
    let step = m.div_ceil(NOISE_SAMPLE);
    let v = |i: usize| from_order_key(keys[i]);
    scratch.clear();
    scratch.extend(
        (0..m)
            .step_by(step)
            .map(|i| order_key((v(i + 2 * lag) - 2.0 * v(i + lag) + v(i)).abs())),
    );
    let sigma_chord = 1.4826 * median_key(scratch) / 6f64.sqrt();
    let independent = (keys.len() / blocks_n / lag).max(1) as f64;
    1.2533 * sigma_chord / independent.sqrt()
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
/// its plateau and top speed and its steady strokes (steps 2-5); it is move number
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
    // Steady chords, by their keys (no steady chord under a NaN threshold), and the chords
    // at or above the standstill speed (the others, NaN included, are slow).
    let Some(steady_keys) = keys_at_least(params.steady_fraction * plateau) else {
        return this;
    };
    let steady = |k: i64| steady_keys.0 <= k && k <= steady_keys.1;
    // No bound (a NaN standstill speed) leaves every chord slow.
    let (moving_lo, moving_hi) =
        keys_at_least(params.stop_fraction * plateau).unwrap_or((i64::MAX, i64::MIN));
    let slow = |k: i64| (k < moving_lo) | (k > moving_hi);
    // Step 3: the moving part (its ends are trimmed per stretch, step 4), if the move
    // reaches a steady speed at all.
    if !keys.iter().any(|&k| steady(k)) {
        return this;
    }
    let (Some(c_first), Some(c_last)) = (
        keys.iter().position(|&k| !slow(k)),
        keys.iter().rposition(|&k| !slow(k)),
    ) else {
        return this;
    };
    // Step 4: stretches between standstills (a slow run ends at the last steady chord at the
    // latest, unless the standstill speed is set above the steady one).
    let mut from = c_first;
    let mut c = c_first;
    while c <= c_last {
        // Most chords are not slow: skip blocks of them with a test that vectorises.
        const BLOCK: usize = 16;
        if c + BLOCK <= c_last + 1 {
            let block = &keys[c..c + BLOCK];
            if !block.iter().fold(false, |any, &k| any | slow(k)) {
                c += BLOCK;
                continue;
            }
        }
        if !slow(keys[c]) {
            c += 1;
            continue;
        }
        let r0 = c;
        while c <= c_last && slow(keys[c]) {
            c += 1;
        }
        if c - r0 >= MIN_STANDSTILL_CHORDS {
            if r0 > from {
                let chords = (from, r0 - 1);
                push_stroke(
                    &mut this,
                    t,
                    z,
                    w,
                    chords,
                    steady_keys,
                    params,
                    move_index,
                    keys,
                    copy,
                );
            }
            from = c;
        }
    }
    if from <= c_last {
        let chords = (from, c_last);
        push_stroke(
            &mut this,
            t,
            z,
            w,
            chords,
            steady_keys,
            params,
            move_index,
            keys,
            copy,
        );
    }
    this
}

/// The stroke of the stretch of chords `a..=b` of the move `this` (chords of `w` sample
/// intervals from the move's first knot, keyed in `keys`; the steady ones have keys in the
/// range `steady_keys`), if it makes one (module docs, steps 4-5); `copy` is scratch.
#[allow(clippy::too_many_arguments)]
fn push_stroke(
    this: &mut MoveSpan,
    t: &[f64],
    z: &[f64],
    w: usize,
    (a, b): (usize, usize),
    steady_keys: (i64, i64),
    params: &SegmentParams,
    move_index: usize,
    keys: &[i64],
    copy: &mut Vec<i64>,
) {
    let i0 = this.first;
    // The stretch from its first to its last steady chord (none when it never got up to
    // speed between two standstills); steady near each end against the feed held there.
    let stretch = &keys[a..=b];
    let head = edge_steady_keys(
        &stretch[..edge_window(stretch.len())],
        this,
        steady_keys,
        params,
        copy,
    );
    let tail = edge_steady_keys(
        &stretch[stretch.len() - edge_window(stretch.len())..],
        this,
        steady_keys,
        params,
        copy,
    );
    let (Some(f), Some(l)) = (
        stretch.iter().position(|&k| head.0 <= k && k <= head.1),
        stretch.iter().rposition(|&k| tail.0 <= k && k <= tail.1),
    ) else {
        return;
    };
    if l < f {
        return;
    }
    let (c0, c1) = (a + f, a + l);
    let run = &keys[c0..=c1];
    let top = run.iter().copied().fold(i64::MIN, i64::max);
    if !holds_a_plateau(run, top, w, copy) {
        return;
    }
    // Chord c joins knots i0+c and i0+c+w. A steady chord may straddle the start (or end) of
    // the motion, so the stroke keeps only knots inside every steady chord's reach: from the
    // end of the first to the start of the last (for w = 1 this is the whole run), then trims.
    let first = i0 + c0 + (w - 1) + params.trim_knots;
    let last = (i0 + c1 + 1).saturating_sub(params.trim_knots);
    if last < first || last + 1 - first < params.min_knots.max(4) {
        return;
    }
    if (z[last] - z[first]).abs() < params.min_stroke_mm * 1e-3 {
        return;
    }
    // The feed of the stroke: its mean speed, exact also when single chords are coarse.
    let speed = (z[last] - z[first]).abs() / (t[last] - t[first]);
    let (feed_min_m_s, feed_max_m_s) = feed_range(run, copy);
    this.strokes.push(StrokeSpan {
        direction: this.direction,
        first,
        last,
        plateau_speed_m_s: speed,
        feed_min_m_s,
        feed_max_m_s,
        move_index,
        move_first: this.first,
        move_last: this.last,
    });
}

/// Chords at each end of a stretch of `len` chords over which the feed held there is judged:
/// an eighth of the stretch, at least 8 (all of a shorter one).
fn edge_window(len: usize) -> usize {
    (len / 8).max(8).min(len)
}

/// The keys counted steady at one end of a stretch whose chords there are keyed in `window`
/// (module docs, step 4): `steady_keys` (≥ `steady_fraction` × P), unless the feed held at
/// that end (the 75th percentile of the window, so that a ramp filling up to three quarters of
/// it does not count) is below 0.8 × P — a feed override turned down or a slower block's feed
/// — when the bound is `steady_fraction` × that feed, so that the stroke keeps that end.
fn edge_steady_keys(
    window: &[i64],
    this: &MoveSpan,
    steady_keys: (i64, i64),
    params: &SegmentParams,
    copy: &mut Vec<i64>,
) -> (i64, i64) {
    copy.clear();
    copy.extend_from_slice(window);
    let rank = ((copy.len() - 1) as f64 * 0.75).round() as usize;
    let held = select_key(copy, rank);
    if held < EDGE_SLOWER * this.plateau_speed_m_s {
        keys_at_least(params.steady_fraction * held).unwrap_or(steady_keys)
    } else {
        steady_keys
    }
}

/// An end of a stretch holds a slower feed when it is below this fraction of the plateau.
const EDGE_SLOWER: f64 = 0.8;

/// The 5th and 95th percentile (m/s) of the chord speeds keyed in `run` (not empty), over at
/// most [`FEED_RANGE_SAMPLE`] of them evenly spread; `copy` is scratch.
fn feed_range(run: &[i64], copy: &mut Vec<i64>) -> (f64, f64) {
    let stride = run.len().div_ceil(FEED_RANGE_SAMPLE);
    copy.clear();
    copy.extend(run.iter().step_by(stride));
    let last = copy.len() - 1;
    let rank = |p: f64| (last as f64 * p).round() as usize;
    let (r5, r95) = (rank(0.05), rank(0.95));
    // The 95th percentile from the part above the 5th, which the first selection leaves there.
    let lo = select_key(copy, r5);
    let hi = select_key(&mut copy[r5..], r95 - r5);
    (lo, hi)
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

        fn holds_a_plateau(keys: &[i64], w: usize, scratch: &mut Vec<i64>) -> bool {
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
            if !(rising && falling && ends_low) {
                return true;
            }
            // The chord noise from every second difference of chords w apart (the real one
            // takes at most NOISE_SAMPLE of them, evenly spread).
            let v: Vec<f64> = keys.iter().map(|&k| from_order_key(k)).collect();
            let m = v.len().saturating_sub(2 * w);
            let step = m.div_ceil(NOISE_SAMPLE).max(1);
            let mut e: Vec<f64> = (0..m)
                .step_by(step)
                .map(|i| (v[i + 2 * w] - 2.0 * v[i + w] + v[i]).abs())
                .collect();
            let noise = if e.is_empty() {
                0.0
            } else {
                let mid = e.len() / 2;
                let med = *e.select_nth_unstable_by(mid, f64::total_cmp).1;
                let n = (keys.len() / blocks_n / w).max(1) as f64;
                1.2533 * 1.4826 * med / 6f64.sqrt() / n.sqrt()
            };
            let band = 0.005f64.max(3.0 * noise / peak);
            blocks.iter().filter(|&&v| v >= (1.0 - band) * peak).count() > 2
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
            // The rule of the module docs, steps 3-5, spelt out on the speeds.
            let threshold = params.steady_fraction * plateau;
            let standstill = params.stop_fraction * plateau;
            let v: Vec<f64> = (0..keys.len()).map(speed).collect();
            let is_steady = |c: usize| v[c] >= threshold;
            if !(0..v.len()).any(is_steady) {
                return this;
            }
            let moving = |c: usize| v[c] >= standstill;
            let Some(c_first) = (0..v.len()).find(|&c| moving(c)) else {
                return this;
            };
            let c_last = (0..v.len()).rev().find(|&c| moving(c)).unwrap();
            // Stretches between runs of at least MIN_STANDSTILL_CHORDS slow chords.
            let mut stretches = Vec::new();
            let mut from = c_first;
            let mut c = c_first;
            while c <= c_last {
                let mut run = 0;
                // Slow: below the standstill speed, or NaN.
                let slow = |c: usize| v[c].is_nan() || v[c] < standstill;
                while c + run <= c_last && slow(c + run) {
                    run += 1;
                }
                if run >= MIN_STANDSTILL_CHORDS {
                    if c > from {
                        stretches.push((from, c - 1));
                    }
                    from = c + run;
                }
                c += run.max(1);
            }
            if from <= c_last {
                stretches.push((from, c_last));
            }
            for (a, b) in stretches {
                // Each end steady against the feed held there when that is clearly slower.
                let len = b - a + 1;
                let win = (len / 8).max(8).min(len);
                let edge_threshold = |range: std::ops::Range<usize>| {
                    let mut e: Vec<f64> = v[range].to_vec();
                    e.sort_by(f64::total_cmp);
                    let held = e[((e.len() - 1) as f64 * 0.75).round() as usize];
                    if held < 0.8 * plateau {
                        params.steady_fraction * held
                    } else {
                        threshold
                    }
                };
                let (th, tt) = (
                    edge_threshold(a..a + win),
                    edge_threshold(b + 1 - win..b + 1),
                );
                let Some(c0) = (a..=b).find(|&c| v[c] >= th) else {
                    continue;
                };
                let c1 = (a..=b).rev().find(|&c| v[c] >= tt).unwrap();
                if c1 < c0 {
                    continue;
                }
                if !holds_a_plateau(&keys[c0..=c1], w, sel) {
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
                // Feed range: a sorted strided sample, ranks by the same rounding.
                let stride = (c1 - c0 + 1).div_ceil(FEED_RANGE_SAMPLE);
                let mut sample: Vec<f64> = v[c0..=c1].iter().copied().step_by(stride).collect();
                sample.sort_by(f64::total_cmp);
                let at = |p: f64| sample[((sample.len() - 1) as f64 * p).round() as usize];
                this.strokes.push(StrokeSpan {
                    direction: dir,
                    first,
                    last,
                    plateau_speed_m_s: speed,
                    feed_min_m_s: at(0.05),
                    feed_max_m_s: at(0.95),
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

    /// One forward move: 0.5 s at rest, a ramp at `acc` (mm/s²) up to `feed(0)`, then the feed
    /// `feed(u)` (mm/s, u the time since the ramp) for `duration` s, a ramp down at `acc` and
    /// 0.5 s at rest. Sampled every `dt` s (stamps jittered by up to ±`jitter` × dt), a fraction
    /// `drop` of the samples left out at random, positions quantised to `q` m. The positions
    /// are the speed integrated by Simpson's rule in steps of at most 0.5 ms.
    #[allow(clippy::too_many_arguments)]
    fn feed_channel(
        feed: &dyn Fn(f64) -> f64,
        duration: f64,
        acc: f64,
        dt: f64,
        jitter: f64,
        drop: f64,
        q: f64,
        seed: u64,
    ) -> Channel {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let (rest, up, down) = (0.5, feed(0.0) / acc, feed(duration) / acc);
        let t_end = rest + up + duration + down + rest;
        let speed = |t: f64| {
            let u = t - rest;
            if u <= 0.0 {
                0.0
            } else if u < up {
                acc * u
            } else if u < up + duration {
                feed(u - up)
            } else if u < up + duration + down {
                acc * (up + duration + down - u)
            } else {
                0.0
            }
        };
        let mut c = Channel::default();
        let (mut t_prev, mut z_mm) = (0.0, 0.0);
        let mut k = 0.0;
        loop {
            let t = (k * dt + rng.random_range(-jitter..=jitter) * dt).max(0.0);
            k += 1.0;
            if t > t_end {
                break;
            }
            let h = t - t_prev;
            let m = ((h / 5e-4).ceil() as usize).max(1);
            let step = h / m as f64;
            for j in 0..m {
                let a = t_prev + j as f64 * step;
                z_mm += step / 6.0 * (speed(a) + 4.0 * speed(a + 0.5 * step) + speed(a + step));
            }
            t_prev = t;
            if c.time_s.is_empty() || !rng.random_bool(drop) {
                c.time_s.push(t);
                c.value.push((z_mm * 1e-3 / q).round() * q);
            }
        }
        c
    }

    /// The strokes of a one-move channel, which must be one move.
    fn strokes_of(c: &Channel) -> (MoveSpan, Vec<StrokeSpan>) {
        let moves = find_moves(c, &SegmentParams::default());
        let with_travel: Vec<&MoveSpan> = moves
            .iter()
            .filter(|m| (c.value[m.last] - c.value[m.first]).abs() > 1e-4)
            .collect();
        assert_eq!(with_travel.len(), 1, "{moves:?}");
        let m = with_travel[0].clone();
        let s = m.strokes.clone();
        (m, s)
    }

    /// The samplings of the issue: 83 Hz, 1 kHz and 70 ms polling with ±20 % jitter, each also
    /// with 5 % of the samples dropped.
    const SAMPLINGS: [(f64, f64, f64); 6] = [
        (1.0 / 83.0, 0.0, 0.0),
        (1.0 / 83.0, 0.0, 0.05),
        (1e-3, 0.0, 0.0),
        (1e-3, 0.0, 0.05),
        (0.070, 0.2, 0.0),
        (0.070, 0.2, 0.05),
    ];

    #[test]
    fn a_modulated_feed_is_one_stroke() {
        let mut seed = 0;
        for feed_mm_min in [5.0, 60.0, 1000.0] {
            let f = feed_mm_min / 60.0;
            for period in [0.3, 1.5, 5.0] {
                // Whole periods, so the modulation ends where it began (at the mean feed).
                let duration = (40.0f64 / period).round() * period;
                let feed =
                    move |u: f64| f * (1.0 + 0.6 * (2.0 * std::f64::consts::PI * u / period).sin());
                for (dt, jitter, drop) in SAMPLINGS {
                    for q in [1e-7, 1e-6] {
                        seed += 1;
                        let c = feed_channel(&feed, duration, 500.0, dt, jitter, drop, q, seed);
                        let what = format!(
                            "{feed_mm_min} mm/min, period {period} s, dt {dt} s, drop {drop}, \
                             q {q} m"
                        );
                        let (m, s) = strokes_of(&c);
                        assert_eq!(s.len(), 1, "{what}: {s:?}");
                        let travel = (c.value[m.last] - c.value[m.first]).abs();
                        let covered = (c.value[s[0].last] - c.value[s[0].first]).abs();
                        assert!(covered >= 0.95 * travel, "{what}: {covered} of {travel}");
                        // The 5th and 95th percentile of 1 + 0.6·sin are 0.407 and 1.593;
                        // a chord's position quanta move it by up to q/(w·dt) (and 5 % for
                        // dropped samples and the percentiles of a sampled tail); a chord
                        // that is not short against the period averages the modulation.
                        let (lo, hi) = (s[0].feed_min_m_s * 6e4, s[0].feed_max_m_s * 6e4);
                        assert!(lo < feed_mm_min && hi > feed_mm_min, "{what}: {lo}-{hi}");
                        let w = chord_samples(&c.value, m.first, m.last, q);
                        if w as f64 * dt > period / 8.0 {
                            continue;
                        }
                        let tol = q / (w as f64 * dt) * 6e4 + 0.05 * feed_mm_min;
                        let (lo_want, hi_want) = (0.407 * feed_mm_min, 1.593 * feed_mm_min);
                        assert!((lo - lo_want).abs() < tol, "{what}: {lo} for {lo_want}");
                        assert!((hi - hi_want).abs() < tol, "{what}: {hi} for {hi_want}");
                    }
                }
            }
        }
    }

    #[test]
    fn an_override_change_is_one_stroke() {
        // 100 % → 45 % → 120 % of the feed, 8 s each, with ramps of 0.3 s between.
        let mut seed = 100;
        for feed_mm_min in [5.0, 60.0, 1000.0] {
            let f = feed_mm_min / 60.0;
            let feed = move |u: f64| {
                let r = 0.3;
                let level = if u < 8.0 {
                    1.0
                } else if u < 8.0 + r {
                    1.0 - 0.55 * (u - 8.0) / r
                } else if u < 16.0 {
                    0.45
                } else if u < 16.0 + r {
                    0.45 + 0.75 * (u - 16.0) / r
                } else {
                    1.2
                };
                f * level
            };
            for (dt, jitter, drop) in SAMPLINGS {
                for q in [1e-7, 1e-6] {
                    seed += 1;
                    let c = feed_channel(&feed, 24.0, 500.0, dt, jitter, drop, q, seed);
                    let (m, s) = strokes_of(&c);
                    let what = format!("{feed_mm_min} mm/min, dt {dt}, drop {drop}, q {q}");
                    assert_eq!(s.len(), 1, "{what}: {s:?}");
                    let travel = (c.value[m.last] - c.value[m.first]).abs();
                    let covered = (c.value[s[0].last] - c.value[s[0].first]).abs();
                    assert!(covered >= 0.95 * travel, "{what}: {covered} of {travel}");
                }
            }
        }
    }

    /// The slowest chord (m/s, over the chord width the move uses) between two knots.
    fn slowest_chord(c: &Channel, m: &MoveSpan, a: usize, b: usize) -> f64 {
        let w = chord_samples(&c.value, m.first, m.last, position_quantum_m(&c.value));
        (a..=b.saturating_sub(w))
            .map(|k| (c.value[k + w] - c.value[k]) / (c.time_s[k + w] - c.time_s[k]))
            .fold(f64::INFINITY, f64::min)
    }

    #[test]
    fn an_exact_stop_or_a_dwell_cuts_and_is_a_pause() {
        // Two blocks of 12 s at 60 mm/min in the same direction; between them the table
        // decelerates at 50 mm/s² to a stop and accelerates again (an exact stop), and then
        // also rests 0.3 s (a dwell in the move) — or, at 500 mm/s², rests 0.5 s.
        let f = 1.0;
        let mut seed = 200;
        for (acc, dwell) in [(50.0, 0.0), (50.0, 0.3), (500.0, 0.5)] {
            let feed = move |u: f64| {
                let (stop_at, ramp) = (12.0, f / acc);
                let d = u - stop_at;
                if d < -ramp || d > ramp + dwell {
                    f
                } else if d < 0.0 {
                    -d * acc
                } else if d < dwell {
                    0.0
                } else {
                    (d - dwell) * acc
                }
            };
            // A stop only shows in at least two chords shorter than it: fine sampling for the
            // exact stop (20 ms of ramps), 83 Hz too for a 0.3 s dwell, any for 0.5 s (at 70 ms
            // with 5 % dropped, 0.3 s may leave a single chord inside the dwell).
            let samplings: &[(f64, f64, f64)] = if dwell == 0.0 {
                &SAMPLINGS[2..4]
            } else if dwell < 0.5 {
                &SAMPLINGS[..4]
            } else {
                &SAMPLINGS
            };
            for &(dt, jitter, drop) in samplings {
                for q in [1e-7, 1e-6] {
                    seed += 1;
                    let c = feed_channel(&feed, 24.0 + dwell, acc, dt, jitter, drop, q, seed);
                    let what = format!("acc {acc}, dwell {dwell}, dt {dt}, drop {drop}, q {q}");
                    let (m, s) = strokes_of(&c);
                    assert_eq!(s.len(), 2, "{what}: {s:?}");
                    let zones = zones_between(&c, &s);
                    let kinds: Vec<_> = zones.iter().map(|z| z.kind).collect();
                    assert_eq!(
                        kinds,
                        [ZoneKind::Start, ZoneKind::Pause, ZoneKind::End],
                        "{what}"
                    );
                    let stop_speed = SegmentParams::default().stop_fraction * m.plateau_speed_m_s;
                    let slowest = slowest_chord(&c, &m, s[0].last, s[1].first);
                    assert!(slowest < stop_speed, "{what}: {slowest} ≥ {stop_speed}");
                    // The pause lies around the stop (at 12 mm).
                    let p = &zones[1];
                    assert!(
                        p.start_position_mm < 12.05 && p.end_position_mm > 11.95,
                        "{what}"
                    );
                }
            }
        }
    }

    #[test]
    fn one_slow_chord_does_not_cut() {
        // 60 mm/min at 1 kHz, 0.1 µm: one sample repeats its predecessor's position (a stale
        // read), so one chord reads 0 and the next twice the feed.
        let c0 = feed_channel(&|_| 1.0, 20.0, 500.0, 1e-3, 0.0, 0.0, 1e-7, 7);
        let mut c = c0.clone();
        let k = c.time_s.len() / 2;
        c.value[k] = c.value[k - 1];
        let (_, s) = strokes_of(&c);
        assert_eq!(s.len(), 1, "{s:?}");
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
        /// A feed that never falls below 40 % of its mean — held levels joined by ramps, with a
        /// few sinusoids on top — sampled at 50 Hz-2 kHz with 0.1-1 µm quanta, is one stroke.
        /// Each level is held for at least a sixth of the stroke and each sinusoid's period is
        /// at most a third of it: one rise to a single peak and a fall from it, with no feed
        /// held at the top, is what `holds_a_plateau` takes for a move that never reaches its
        /// feed (module docs, limits).
        #[test]
        fn a_feed_that_never_nearly_stops_is_one_stroke(
            feed_mm_min in 5.0f64..1000.0,
            duration in 10.0f64..30.0,
            levels in proptest::collection::vec((0.5f64..1.5, 0.05f64..1.0), 1..4),
            waves in proptest::collection::vec((0.0f64..0.3, 0.2f64..1.0, 0.0f64..6.3), 0..4),
            rate_hz in 50.0f64..2000.0,
            q in 1e-7f64..1e-6,
            seed in 0u64..1000,
        ) {
            // At least 2.5 mm of travel: a shorter stroke is below `min_stroke_mm` (1 mm) after
            // its ends are trimmed, whatever its feed profile.
            let duration = duration.max(150.0 / feed_mm_min);
            let n = levels.len();
            let hold = duration / n as f64;
            // Level j from j·hold, reached by a ramp of its own length (at most half a hold).
            let base = |u: f64| {
                let j = ((u / hold) as usize).min(n - 1);
                let (l, r) = levels[j];
                let r = r * 0.5 * hold;
                let x = u - j as f64 * hold;
                if j == 0 || x >= r {
                    l
                } else {
                    let p = levels[j - 1].0;
                    p + (l - p) * x / r
                }
            };
            let wave = |u: f64| {
                waves
                    .iter()
                    .map(|&(a, p, ph)| {
                        let period = 0.2 + p * (duration / 3.0 - 0.2);
                        a * (2.0 * std::f64::consts::PI * u / period + ph).sin()
                    })
                    .sum::<f64>()
            };
            let raw = |u: f64| base(u) + wave(u);
            // Scaled about its mean so that it never falls below 40 % of it.
            let grid: Vec<f64> = (0..=4000).map(|i| raw(duration * i as f64 / 4000.0)).collect();
            let mean = grid.iter().sum::<f64>() / grid.len() as f64;
            let low = grid.iter().copied().fold(f64::INFINITY, f64::min);
            let scale = if low < 0.45 * mean { 0.55 * mean / (mean - low) } else { 1.0 };
            let f = feed_mm_min / 60.0;
            let feed = |u: f64| f * (mean + scale * (raw(u) - mean)) / mean;
            let c = feed_channel(&feed, duration, 500.0, 1.0 / rate_hz, 0.1, 0.0, q, seed);
            let (_, s) = strokes_of(&c);
            proptest::prop_assert_eq!(s.len(), 1, "{:?}", s);
        }
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
