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

/// Hysteresis for turning points (m), see the module docs.
fn hysteresis_m(z: &[f64], quantum: f64) -> f64 {
    let (lo, hi) = z
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    hysteresis_of(quantum, lo, hi)
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
    for (k, &v) in z.iter().enumerate() {
        if let Some(i) = finder.push(k, v) {
            tp.push(i);
        }
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

/// The element of rank `rank` in the `total_cmp` order among the `keys` that `keep` accepts,
/// found without copying or reordering them: four passes over the keys, each counting the
/// next 16 bits of those that share the bits found so far (keys in unsigned order: the sign
/// bit flipped). Exactly the element [`select_key`] finds on a copy of the kept keys.
///
/// # Panics
/// When `rank` is not below the number of kept keys (a caller's mistake).
fn radix_select(keys: &[i64], keep: impl Fn(&i64) -> bool, mut rank: usize) -> f64 {
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
    from_order_key((prefix ^ (1 << 63)) as i64)
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
/// `keys` are the speeds' [`order_key`]s; `scratch` is reused for the blocks.
fn holds_a_plateau(keys: &[i64], scratch: &mut Vec<i64>) -> bool {
    // Fewer chords than blocks (a short move at a slow sampling rate): one chord a block.
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
    let quantum = position_quantum_m(z);
    let eps = hysteresis_m(z, quantum);
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
    /// A copy of them for selections on a short move.
    sel: Vec<i64>,
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
    let MoveScratch { keys, sel } = scratch;
    let chord = |k: usize| s * (z[k + w] - z[k]) / (t[k + w] - t[k]);
    keys.clear();
    keys.extend((i0..=i1 - w).map(|k| order_key(chord(k))));
    let speed = |c: usize| from_order_key(keys[c]);
    let rank = ((keys.len() - 1) as f64 * 0.95).round() as usize;
    // A long move is ranked in place by radix passes (the same element as the copy's
    // selection): a copy of a 10 M-sample stroke's keys would cost 80 MB.
    let long = keys.len() > RADIX_SELECT_MIN;
    let p95 = if long {
        radix_select(keys, |_| true, rank)
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
            radix_select(keys, fast, count / 2)
        }
    } else {
        sel.clear();
        sel.extend(keys.iter().filter(|k| fast(k)));
        median_key(sel)
    };
    this.plateau_speed_m_s = plateau;
    this.top_speed_m_s = p95;
    let threshold = params.steady_fraction * plateau;
    // Maximal runs of steady chords.
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
        let c1 = c - 1; // last steady chord
        if !holds_a_plateau(&keys[c0..=c1], sel) {
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
                let got = radix_select(&keys, &keep, rank);
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
}
