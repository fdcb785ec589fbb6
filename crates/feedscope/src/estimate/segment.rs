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
fn position_quantum_m(z: &[f64]) -> f64 {
    let q = z
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|d| *d > 1e-12)
        .fold(f64::INFINITY, f64::min);
    if q.is_finite() {
        q
    } else {
        0.0
    }
}

/// Hysteresis for turning points (m), see the module docs.
fn hysteresis_m(z: &[f64], quantum: f64) -> f64 {
    let (lo, hi) = z
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    (8.0 * quantum).max(1e-4 * (hi - lo)).max(1e-7)
}

/// Indices of alternating extremes (first and last sample included).
fn turning_points(z: &[f64], eps: f64) -> Vec<usize> {
    let mut tp = Vec::new();
    let n = z.len();
    // Until a direction is known, track both extremes.
    let (mut imin, mut imax) = (0usize, 0usize);
    let mut k = 0;
    let mut up;
    loop {
        if k >= n {
            return vec![0, n - 1];
        }
        if z[k] < z[imin] {
            imin = k;
        }
        if z[k] > z[imax] {
            imax = k;
        }
        if z[k] - z[imin] > eps {
            up = true;
            tp.push(imin);
            break;
        }
        if z[imax] - z[k] > eps {
            up = false;
            tp.push(imax);
            break;
        }
        k += 1;
    }
    let mut ext = k;
    for k in k..n {
        if up {
            if z[k] >= z[ext] {
                ext = k;
            } else if z[ext] - z[k] > eps {
                tp.push(ext);
                up = false;
                ext = k;
            }
        } else if z[k] <= z[ext] {
            ext = k;
        } else if z[k] - z[ext] > eps {
            tp.push(ext);
            up = true;
            ext = k;
        }
    }
    if *tp.last().unwrap_or(&usize::MAX) != ext {
        tp.push(ext);
    }
    tp
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
    // The chord speeds' order keys (see `order_key`; a speed is `from_order_key` of its key),
    // and a copy of them for selections on a short move.
    let (mut keys, mut sel) = (Vec::new(), Vec::new());
    for w in tp.windows(2) {
        let (i0, i1) = (w[0], w[1]);
        if i1 <= i0 || (z[i1] - z[i0]).abs() <= eps {
            continue;
        }
        let dir = if z[i1] > z[i0] {
            Direction::Forward
        } else {
            Direction::Backward
        };
        moves.push(MoveSpan {
            direction: dir,
            first: i0,
            last: i1,
            plateau_speed_m_s: 0.0,
            top_speed_m_s: 0.0,
            strokes: Vec::new(),
        });
        let move_index = moves.len() - 1;
        let this = &mut moves[move_index];
        if i1 <= i0 + 1 {
            continue;
        }
        let s = dir.sign();
        // Chords span w samples so that each covers at least 8 position quanta: at a slow feed
        // with coarse quantisation, consecutive samples often repeat a position and single-step
        // chord speeds jump between 0 and one quantum per interval.
        let mean_step = (z[i1] - z[i0]).abs() / (i1 - i0) as f64;
        let w = if mean_step > 0.0 {
            ((8.0 * quantum / mean_step).ceil() as usize).clamp(1, ((i1 - i0) / 4).max(1))
        } else {
            1
        };
        if i1 < i0 + w {
            continue;
        }
        let chord = |k: usize| s * (z[k + w] - z[k]) / (t[k + w] - t[k]);
        keys.clear();
        keys.extend((i0..=i1 - w).map(|k| order_key(chord(k))));
        let speed = |c: usize| from_order_key(keys[c]);
        let rank = ((keys.len() - 1) as f64 * 0.95).round() as usize;
        // A long move is ranked in place by radix passes (the same element as the copy's
        // selection): a copy of a 10 M-sample stroke's keys would cost 80 MB.
        let long = keys.len() > RADIX_SELECT_MIN;
        let p95 = if long {
            radix_select(&keys, |_| true, rank)
        } else {
            sel.clear();
            sel.extend_from_slice(&keys);
            select_key(&mut sel, rank)
        };
        if p95.is_nan() || p95 <= 0.0 {
            continue;
        }
        let fast = |k: &i64| from_order_key(*k) >= 0.25 * p95;
        let plateau = if long {
            let count = keys.iter().filter(|k| fast(k)).count();
            if count == 0 {
                f64::NAN
            } else {
                radix_select(&keys, fast, count / 2)
            }
        } else {
            sel.clear();
            sel.extend(keys.iter().filter(|k| fast(k)));
            median_key(&mut sel)
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
            if !holds_a_plateau(&keys[c0..=c1], &mut sel) {
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
    }
    moves
}

/// The stretches of the trace not covered by `strokes` (in time order).
pub fn zones_between(position: &Channel, strokes: &[StrokeSpan]) -> Vec<Zone> {
    let (t, z) = (&position.time_s, &position.value);
    let n = t.len();
    let mut zones = Vec::new();
    let zone = |kind, a: usize, b: usize| Zone {
        kind,
        start_time_s: t[a],
        end_time_s: t[b],
        start_position_mm: z[a] * 1e3,
        end_position_mm: z[b] * 1e3,
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
}
