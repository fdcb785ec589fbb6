//! Position glitches: samples whose value implies a speed the axis cannot reach.
//!
//! A logger glitch writes a wild position for one sample or a few (`1e308`, a flipped bit, a
//! value of another axis). Left in, it reshapes the trace: the spline through it swings over the
//! whole travel and stroke detection cuts a stroke at it. A ball-screw axis cannot move faster
//! than its rapid rate, so a change of position that implies a higher speed is not motion.
//!
//! # The test
//! Two samples a and b of the position channel (times t, positions z) are *consistent* when
//!
//! ```text
//! |z_b − z_a| ≤ v_lim · (t_b − t_a + 2τ) + z₀
//! ```
//!
//! with v_lim = [`GlitchParams::max_axis_speed_m_s`], τ the typical sampling interval of the
//! channel (the larger of the median and the mean interval) and z₀ = [`JUMP_FLOOR_M`]. The 2τ
//! lets either time stamp be off by a whole typical sampling interval (asynchronous polling with
//! jitter, a value stamped when the logger polled rather than when the drive sampled it, buffered
//! samples stamped in bursts on receipt: the mean interval keeps those from looking like fast
//! motion); z₀ covers position quantisation at very short intervals. A trajectory that never
//! moves faster than v_lim, with time stamps off by at most τ and positions off by at most z₀/2,
//! therefore never loses a sample. In practice a sample must jump by more than about v_lim × 3
//! sampling intervals to count: at 500 Hz, 20 mm for the default limit, 1.9 mm for a 15 m/min
//! rapid rate.
//!
//! The samples are walked in time order, each compared with the last kept one (the anchor a). A
//! sample i that is not consistent with a starts
//! - a **glitch** when one of the next [`MAX_GLITCH_RUN`] samples, j, is consistent with a again
//!   and the step into j is itself inconsistent and goes back towards a: samples i..j jumped away
//!   and came back, and are dropped;
//! - a glitch too when it is one of at most [`MAX_GLITCH_RUN`] samples at either end of the
//!   trace, cut off from the rest by an inconsistent step while the rest is consistent (nothing
//!   follows or precedes to prove a return; dropping them loses nothing of a stroke);
//! - otherwise a **discontinuity** (re-homing, two recordings stitched together, a logger that
//!   skipped a stretch while the axis moved fast): [`screen_position`] returns the [`Jump`], and
//!   the readers of `feedscope-io` refuse the trace with its `TraceError::PositionJump`.
//!
//! # Effort glitches
//! Motor current and torque legitimately jump (an acceleration step, a reversal, a saturated
//! current loop), and no bound on them follows from the axis description, so the effort is held
//! to its own recording instead ([`screen_effort`]): a run of at most [`MAX_GLITCH_RUN`]
//! samples whose magnitude exceeds [`EFFORT_GLITCH_FACTOR`] times the recording's 99.9th
//! percentile magnitude (in a short recording, the fifth largest) is a logger glitch and is dropped (one torque sample of −496,000 N·m
//! made friction of −3.4e8 N). A drive's peak current is a few times its rated current, and a
//! test's accelerations and reversals are among the 0.1 % the percentile covers whenever they
//! make up that much of the recording; the factor of 10 leaves room for the rest. The
//! percentile is read from a histogram of 1/8 octave bins ([`EffortMagnitudes`], its upper bin
//! edge: up to 9 % above the exact value, never below), so that a streamed read finds the same
//! bound as the whole read without holding the samples.

use super::Channel;
use crate::units::{feed_m_s_to_mm_min, feed_mm_min_to_m_s};

/// The speed limit used when the axis description gives no rapid rate (mm/min): 200 m/min,
/// above the rapid rate of any ball-screw axis (the fastest reach about 100-120 m/min).
pub const DEFAULT_MAX_AXIS_SPEED_MM_MIN: f64 = 200_000.0;

/// The speed limit is this factor times the axis' rapid rate, when it is known: the controller's
/// overshoot at the end of a rapid and its rounding stay well within 25 %.
pub const RAPID_RATE_MARGIN: f64 = 1.25;

/// Longest run of consecutive samples that can be dropped as one glitch. Four or more samples
/// off the trajectory are a real jump (or a broken logger) and are refused instead.
pub const MAX_GLITCH_RUN: usize = 3;

/// Position change that never counts as a jump, whatever the time between samples (m): 10 µm,
/// ten quanta of a 1 µm encoder.
pub const JUMP_FLOOR_M: f64 = 10e-6;

/// Subsample of steps the median sampling interval τ is taken from (a fixed stride over long
/// channels: the median of a million steps is as good as that of a hundred million).
const MEDIAN_STEPS: usize = 1 << 16;

/// How a position channel is screened for glitches.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GlitchParams {
    /// Highest speed the axis can move at (m/s). Default: [`DEFAULT_MAX_AXIS_SPEED_MM_MIN`]
    /// (200 m/min = 3.33 m/s). [`GlitchParams::for_axis`] takes 1.25 × the axis' rapid rate
    /// when the axis file gives it, which catches much smaller glitches. `f64::INFINITY` turns
    /// screening off.
    pub max_axis_speed_m_s: f64,
    /// The axis's usable travel [min, max] (m) when the axis file declares it
    /// (`travel_min_mm`, `travel_max_mm`): a kept position sample farther outside it than
    /// [`GlitchParams::travel_margin_m`] is not this axis in machine coordinates (another
    /// coordinate system, a wrong scale, another axis), and readers refuse it. `None`: not
    /// checked.
    pub travel_m: Option<(f64, f64)>,
}

impl Default for GlitchParams {
    fn default() -> Self {
        Self {
            max_axis_speed_m_s: feed_mm_min_to_m_s(DEFAULT_MAX_AXIS_SPEED_MM_MIN),
            travel_m: None,
        }
    }
}

impl GlitchParams {
    /// [`RAPID_RATE_MARGIN`] × the rapid rate (mm/min) when it is given (finite and positive),
    /// else the default limit.
    ///
    /// ```
    /// use feedscope::trace::GlitchParams;
    /// let p = GlitchParams::from_rapid_rate(Some(15_000.0));
    /// assert!((p.max_axis_speed_m_s - 0.3125).abs() < 1e-12); // 18.75 m/min
    /// assert_eq!(GlitchParams::from_rapid_rate(None), GlitchParams::default());
    /// ```
    pub fn from_rapid_rate(rapid_rate_mm_min: Option<f64>) -> Self {
        match rapid_rate_mm_min {
            Some(r) if r.is_finite() && r > 0.0 => Self {
                max_axis_speed_m_s: feed_mm_min_to_m_s(RAPID_RATE_MARGIN * r),
                travel_m: None,
            },
            _ => Self::default(),
        }
    }

    /// [`GlitchParams::from_rapid_rate`] with the axis' `rapid_rate_mm_min`, and its travel
    /// when both ends are declared (finite, max > min).
    pub fn for_axis(axis: &crate::axis::AxisParams) -> Self {
        let travel_m = match (axis.travel_min_mm, axis.travel_max_mm) {
            (Some(lo), Some(hi)) if lo.is_finite() && hi.is_finite() && hi > lo => {
                Some((lo * 1e-3, hi * 1e-3))
            }
            _ => None,
        };
        Self {
            travel_m,
            ..Self::from_rapid_rate(axis.rapid_rate_mm_min)
        }
    }

    /// How far outside the declared travel a position may lie (m): 1 mm + 1 % of the travel,
    /// room for reference-point and overtravel margins and the slack of a hand-written travel.
    pub fn travel_margin_m(&self) -> f64 {
        self.travel_m
            .map_or(0.0, |(lo, hi)| 1e-3 + 0.01 * (hi - lo))
    }

    /// The limit in mm/min, for messages.
    pub fn max_axis_speed_mm_min(&self) -> f64 {
        feed_m_s_to_mm_min(self.max_axis_speed_m_s)
    }
}

/// What [`screen_position`] found in a channel without discontinuities.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Screening {
    /// Indices of the samples that are glitches, ascending.
    pub glitches: Vec<usize>,
    /// τ, the typical sampling interval of the channel (s): the larger of the median and the
    /// mean interval; 0 when it has fewer than 3 samples and was not screened.
    pub timing_slack_s: f64,
}

/// An inconsistent step that does not come back: the trace is discontinuous.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Jump {
    /// Index of the first sample after the jump.
    pub index: usize,
    /// Index of the last kept sample before the jump.
    pub from_index: usize,
    /// Position change across the jump (m), signed.
    pub jump_m: f64,
    /// Time between the two samples (s).
    pub interval_s: f64,
    /// Speed the jump implies, |jump_m| / interval_s (m/s); may be infinite for absurd values.
    pub speed_m_s: f64,
}

/// Screen a position channel (m, strictly increasing times) for glitches, as described in the
/// [module doc](self).
///
/// ```
/// use feedscope::trace::{screen_position, Channel, GlitchParams};
/// use feedscope::units::feed_mm_min_to_m_s;
/// // 100 mm/min at 100 Hz with one logger glitch at index 50
/// let time_s: Vec<f64> = (0..200).map(|k| k as f64 * 0.01).collect();
/// let mut value: Vec<f64> = time_s.iter().map(|t| 0.01 + feed_mm_min_to_m_s(t * 100.0)).collect();
/// value[50] = 1e308;
/// let ch = Channel { time_s, value };
/// let s = screen_position(&ch, &GlitchParams::default()).unwrap();
/// assert_eq!(s.glitches, [50]);
/// ```
///
/// # Errors
/// The first [`Jump`] that is not a glitch.
///
/// # Panics
/// When `params.max_axis_speed_m_s` is NaN, zero or negative (a programmer's mistake: the
/// limit comes from a validated axis file or the default).
pub fn screen_position(position_m: &Channel, params: &GlitchParams) -> Result<Screening, Jump> {
    let v = params.max_axis_speed_m_s;
    assert!(v > 0.0, "max_axis_speed_m_s must be positive, got {v}");
    let (t, z) = (&position_m.time_s[..], &position_m.value[..]);
    let n = t.len().min(z.len());
    if n < 3 {
        return Ok(Screening::default());
    }
    let mean_step = (t[n - 1] - t[0]) / (n - 1) as f64;
    let tau = median_step(&t[..n]).max(mean_step);
    // The allowance is the consistency bound of the module doc; times strictly increase, so
    // t_b − t_a > 0 and the bound is never NaN (infinite only when v is).
    let slack = v * 2.0 * tau + JUMP_FLOOR_M;
    let ok = |a: usize, b: usize| (z[b] - z[a]).abs() <= v * (t[b] - t[a]) + slack;
    let mut glitches: Vec<usize> = Vec::new();
    let mut a = 0;
    let mut i = 1;
    while i < n {
        if ok(a, i) {
            a = i;
            i += 1;
            continue;
        }
        // Samples i.. are off the trajectory seen up to a. Does it come back within the run?
        let last = (i + MAX_GLITCH_RUN).min(n - 1);
        let back = (i + 1..=last).find(|&j| ok(a, j));
        if let Some(j) = back {
            let toward = |x: f64, y: f64| (x > 0.0) == (y > 0.0);
            if !ok(j - 1, j) && toward(z[j] - z[j - 1], z[a] - z[j - 1]) {
                glitches.extend(i..j);
                a = j;
                i = j + 1;
                continue;
            }
        } else {
            // Runs at either end: prefer the explanation that drops fewer samples.
            let trailing = n - i;
            let leading = a + 1;
            let kept_before = glitches.is_empty() && i == a + 1;
            let rest_consistent = i + 1 < n && ok(i, i + 1) && (i + 2 >= n || ok(i + 1, i + 2));
            let lead_ok = kept_before && leading <= MAX_GLITCH_RUN && rest_consistent;
            let trail_ok = trailing <= MAX_GLITCH_RUN;
            if lead_ok && (!trail_ok || leading <= trailing) {
                glitches.extend(0..=a);
                a = i;
                i += 1;
                continue;
            }
            if trail_ok {
                glitches.extend(i..n);
                break;
            }
        }
        let dt = t[i] - t[a];
        let dz = z[i] - z[a];
        return Err(Jump {
            index: i,
            from_index: a,
            jump_m: dz,
            interval_s: dt,
            speed_m_s: dz.abs() / dt,
        });
    }
    Ok(Screening {
        glitches,
        timing_slack_s: tau,
    })
}

/// Median of the steps between consecutive times `t` (s) (of at most 2¹⁶ of
/// them, at a fixed stride): the sampling interval a recording with gaps and bursts really
/// has, where the mean over its span counts the gaps. NaN for fewer than two times.
pub fn median_step(t: &[f64]) -> f64 {
    if t.len() < 2 {
        return f64::NAN;
    }
    let steps = t.len() - 1;
    let stride = steps.div_ceil(MEDIAN_STEPS).max(1);
    let mut d: Vec<f64> = (0..steps)
        .step_by(stride)
        .map(|k| t[k + 1] - t[k])
        .collect();
    let mid = d.len() / 2;
    let (_, m, _) = d.select_nth_unstable_by(mid, f64::total_cmp);
    *m
}

/// An effort sample counts as a glitch when its magnitude exceeds this factor times the
/// recording's 99.9th percentile magnitude ([module doc](self#effort-glitches)).
pub const EFFORT_GLITCH_FACTOR: f64 = 10.0;

/// The quantile of |effort| the glitch bound is a multiple of.
pub const EFFORT_SCALE_QUANTILE: f64 = 0.999;

/// Fewest effort samples screened.
pub const MIN_EFFORT_SCREENED: u64 = 50;

/// Mantissa bits kept in an [`EffortMagnitudes`] bin: 3, eight bins per octave.
const BIN_MANTISSA_BITS: u32 = 3;
const BIN_SHIFT: u32 = 52 - BIN_MANTISSA_BITS;

/// A histogram of |effort| in 1/8 octave bins (2¹⁴ of them, every finite f64), filled sample by
/// sample: the 99.9th percentile and the largest magnitude of a recording without holding it.
#[derive(Debug, Clone)]
pub struct EffortMagnitudes {
    bins: Vec<u64>,
    n: u64,
    max_abs: f64,
}

impl Default for EffortMagnitudes {
    fn default() -> Self {
        Self {
            bins: vec![0; 1 << (63 - BIN_SHIFT)],
            n: 0,
            max_abs: 0.0,
        }
    }
}

impl EffortMagnitudes {
    /// Count the magnitudes of `values` (non-finite values are not counted: readers refuse
    /// them).
    pub fn add(&mut self, values: &[f64]) {
        for &v in values {
            let a = v.abs();
            if a.is_finite() {
                self.bins[(a.to_bits() >> BIN_SHIFT) as usize] += 1;
                self.n += 1;
                self.max_abs = self.max_abs.max(a);
            }
        }
    }

    /// Largest magnitude counted.
    pub fn max_abs(&self) -> f64 {
        self.max_abs
    }

    /// The bound a glitch exceeds: [`EFFORT_GLITCH_FACTOR`] × the upper edge of the bin that
    /// holds the [`EFFORT_SCALE_QUANTILE`] of the magnitudes (in a recording of under 4000
    /// samples, the magnitude below the largest [`MAX_GLITCH_RUN`] + 1, so that a glitch
    /// never sets its own bound). `None` when fewer than
    /// [`MIN_EFFORT_SCREENED`] samples were counted or the percentile is 0 (an effort that is
    /// mostly zero holds no scale to compare with).
    pub fn glitch_limit(&self) -> Option<f64> {
        if self.n < MIN_EFFORT_SCREENED {
            return None;
        }
        // The rank of the quantile, 1-based: ⌈q·n⌉, but below the largest MAX_GLITCH_RUN + 1
        // (under 4000 samples the quantile is among them, and a glitch would set its own
        // bound).
        let rank = ((EFFORT_SCALE_QUANTILE * self.n as f64).ceil() as u64)
            .min(self.n - MAX_GLITCH_RUN as u64 - 1)
            .max(1);
        let mut seen = 0;
        let bin = self.bins.iter().position(|&c| {
            seen += c;
            seen >= rank
        })?;
        if bin == 0 {
            return None;
        }
        let upper = f64::from_bits(((bin as u64) + 1) << BIN_SHIFT);
        Some(EFFORT_GLITCH_FACTOR * upper)
    }
}

/// What [`screen_effort`] found.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EffortScreening {
    /// Indices of the samples that are glitches, ascending.
    pub glitches: Vec<usize>,
    /// The magnitude they exceed (effort unit); `None` when the channel was not screened
    /// ([`EffortMagnitudes::glitch_limit`]).
    pub limit: Option<f64>,
    /// Runs of more than [`MAX_GLITCH_RUN`] samples beyond the limit, kept (first index,
    /// length): a stretch, not a glitch.
    pub long_runs: Vec<(usize, usize)>,
}

/// Screen an effort channel (A or N·m) for glitches, as described in the
/// [module doc](self#effort-glitches).
///
/// ```
/// use feedscope::trace::glitch::screen_effort;
/// use feedscope::trace::Channel;
/// // 2 kHz of a current near ±2 A with one glitch of -496,000 A
/// let time_s: Vec<f64> = (0..4000).map(|k| k as f64 * 5e-4).collect();
/// let mut value: Vec<f64> = time_s.iter().map(|t| 2.0 * (3.0 * t).sin() + 0.1).collect();
/// value[1234] = -496_000.0;
/// let s = screen_effort(&Channel { time_s, value });
/// assert_eq!(s.glitches, [1234]);
/// ```
pub fn screen_effort(effort: &Channel) -> EffortScreening {
    let mut mags = EffortMagnitudes::default();
    mags.add(&effort.value);
    let Some(limit) = mags.glitch_limit() else {
        return EffortScreening::default();
    };
    let mut out = EffortScreening {
        limit: Some(limit),
        ..EffortScreening::default()
    };
    if mags.max_abs() <= limit {
        return out;
    }
    let v = &effort.value;
    let mut k = 0;
    while k < v.len() {
        if v[k].abs() > limit {
            let start = k;
            while k < v.len() && v[k].abs() > limit {
                k += 1;
            }
            let len = k - start;
            if len <= MAX_GLITCH_RUN {
                out.glitches.extend(start..k);
            } else {
                out.long_runs.push((start, len));
            }
        } else {
            k += 1;
        }
    }
    out
}

/// Remove the samples at `indices` (ascending, in range) from a channel, keeping the order of
/// the others.
///
/// # Panics
/// When an index is out of range or the indices do not strictly ascend.
pub fn remove_samples(ch: &mut Channel, indices: &[usize]) {
    assert!(
        indices.windows(2).all(|w| w[0] < w[1]),
        "indices must strictly ascend"
    );
    if let Some(&last) = indices.last() {
        assert!(last < ch.len(), "index {last} out of range");
    }
    let mut next = indices.iter().peekable();
    let mut k = 0;
    let mut keep = |_: &f64| {
        let drop = next.peek() == Some(&&k);
        if drop {
            next.next();
        }
        k += 1;
        !drop
    };
    ch.time_s.retain(&mut keep);
    let mut next = indices.iter().peekable();
    let mut k = 0;
    ch.value.retain(|_| {
        let drop = next.peek() == Some(&&k);
        if drop {
            next.next();
        }
        k += 1;
        !drop
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Times and positions (m) into a channel.
    fn ch(t: Vec<f64>, z: Vec<f64>) -> Channel {
        Channel {
            time_s: t,
            value: z,
        }
    }

    /// A 20 mm stroke at `feed_mm_min` sampled every `dt` s, position rounded to `quantum_m`,
    /// with 1 s of dwell before and after.
    fn stroke(dt: f64, feed_mm_min: f64, quantum_m: f64) -> Channel {
        stroke_of(0.02, dt, feed_mm_min, quantum_m)
    }

    /// [`stroke`] of `travel` (m).
    fn stroke_of(travel: f64, dt: f64, feed_mm_min: f64, quantum_m: f64) -> Channel {
        let v = feed_mm_min_to_m_s(feed_mm_min);
        let dur = travel / v;
        let n = ((dur + 2.0) / dt) as usize;
        let t: Vec<f64> = (0..n).map(|k| k as f64 * dt).collect();
        let z = t
            .iter()
            .map(|&t| {
                let z = 0.1 + (v * (t - 1.0)).clamp(0.0, travel);
                (z / quantum_m).round() * quantum_m
            })
            .collect();
        ch(t, z)
    }

    fn rapid_limit(rapid_mm_min: f64) -> GlitchParams {
        GlitchParams::from_rapid_rate(Some(rapid_mm_min))
    }

    #[test]
    fn defaults_and_axis_limit() {
        assert!((GlitchParams::default().max_axis_speed_mm_min() - 200_000.0).abs() < 1e-9);
        assert!((rapid_limit(15_000.0).max_axis_speed_mm_min() - 18_750.0).abs() < 1e-9);
        for bad in [
            Some(0.0),
            Some(-1.0),
            Some(f64::NAN),
            Some(f64::INFINITY),
            None,
        ] {
            assert_eq!(GlitchParams::from_rapid_rate(bad), GlitchParams::default());
        }
    }

    #[test]
    fn absurd_value_mid_stroke_is_dropped() {
        let mut c = stroke(0.072, 100.0, 1e-6);
        let k = c.len() / 2;
        c.value[k] = 1e308;
        let s = screen_position(&c, &GlitchParams::default()).unwrap();
        assert_eq!(s.glitches, [k]);
        assert!((s.timing_slack_s - 0.072).abs() < 1e-12);
        remove_samples(&mut c, &s.glitches);
        assert!(c.value.iter().all(|&z| z < 1.0));
    }

    #[test]
    fn runs_of_one_to_three_are_dropped_four_refused() {
        for run in 1..=4 {
            let mut c = stroke(0.002, 1000.0, 1e-7);
            let k = c.len() / 3;
            for j in 0..run {
                // a 5 mm offset, alternating sign: still away from the trajectory each time
                c.value[k + j] += if j % 2 == 0 { 5e-3 } else { -5e-3 };
            }
            let r = screen_position(&c, &rapid_limit(15_000.0));
            if run <= MAX_GLITCH_RUN {
                assert_eq!(
                    r.unwrap().glitches,
                    (k..k + run).collect::<Vec<_>>(),
                    "{run}"
                );
            } else {
                let j = r.unwrap_err();
                assert_eq!((j.index, j.from_index), (k, k - 1));
                // 5 mm plus one step of the 1000 mm/min feed (33 µm)
                assert!((j.jump_m - 5e-3).abs() < 1e-4, "{}", j.jump_m);
            }
        }
    }

    #[test]
    fn five_mm_spike_needs_the_axis_limit_at_500_hz() {
        // 2.5 m/s between samples: above 1.25 × 15 m/min (with the 2τ slack: 1.9 mm allowed),
        // below the default 200 m/min (20 mm allowed).
        let mut c = stroke(0.002, 1000.0, 1e-6);
        let k = c.len() / 2;
        c.value[k] += 5e-3;
        assert_eq!(
            screen_position(&c, &rapid_limit(15_000.0))
                .unwrap()
                .glitches,
            [k]
        );
        assert!(screen_position(&c, &GlitchParams::default())
            .unwrap()
            .glitches
            .is_empty());
    }

    #[test]
    fn non_returning_jump_is_refused() {
        let mut c = stroke(0.002, 1000.0, 1e-6);
        let k = c.len() / 2;
        for z in &mut c.value[k..] {
            *z += 0.05;
        }
        let j = screen_position(&c, &rapid_limit(15_000.0)).unwrap_err();
        assert_eq!(j.index, k);
        assert!((j.jump_m - 0.05).abs() < 1e-4, "{}", j.jump_m);
        assert!((j.interval_s - 0.002).abs() < 1e-12);
        // ~25 m/s = 1.5e6 mm/min
        assert!((j.speed_m_s - 25.0).abs() < 0.1, "{}", j.speed_m_s);
        // and at the default limit too: 50 mm in 2 ms is 1500 m/min
        assert_eq!(
            screen_position(&c, &GlitchParams::default())
                .unwrap_err()
                .index,
            k
        );
    }

    #[test]
    fn glitches_at_the_ends_are_dropped() {
        let c0 = stroke(0.01, 500.0, 1e-6);
        let n = c0.len();
        for (idx, want) in [
            (vec![0], vec![0]),
            (vec![0, 1, 2], vec![0, 1, 2]),
            (vec![n - 1], vec![n - 1]),
            (vec![n - 3, n - 2, n - 1], vec![n - 3, n - 2, n - 1]),
            (vec![1], vec![1]),
            (vec![n - 2], vec![n - 2]),
        ] {
            let mut c = c0.clone();
            for &k in &idx {
                c.value[k] = -1e300;
            }
            let s = screen_position(&c, &GlitchParams::default()).unwrap();
            assert_eq!(s.glitches, want, "{idx:?}");
        }
        // four at the start: a jump after the fourth sample, refused
        let mut c = c0.clone();
        for k in 0..4 {
            c.value[k] = 1.0;
        }
        assert_eq!(
            screen_position(&c, &GlitchParams::default())
                .unwrap_err()
                .index,
            4
        );
    }

    #[test]
    fn two_glitches_of_opposite_sign_are_one_run() {
        let mut c = stroke(0.001, 2000.0, 1e-6);
        let k = 1500;
        c.value[k] = 1e308;
        c.value[k + 1] = -1e308;
        assert_eq!(
            screen_position(&c, &GlitchParams::default())
                .unwrap()
                .glitches,
            [k, k + 1]
        );
    }

    #[test]
    fn legitimate_traces_lose_nothing() {
        let none = |c: &Channel, p: GlitchParams, what: &str| {
            let s = screen_position(c, &p).unwrap_or_else(|j| panic!("{what}: {j:?}"));
            assert!(s.glitches.is_empty(), "{what}: {:?}", s.glitches);
        };
        // 1 µm steps at 5 mm/min, 1 kHz and 500 Hz
        none(&stroke(0.001, 5.0, 1e-6), rapid_limit(1000.0), "slow 1 kHz");
        none(
            &stroke(0.002, 5.0, 1e-6),
            rapid_limit(1000.0),
            "slow 500 Hz",
        );
        // 8 kHz at 60 m/min with the axis' own rapid rate
        none(
            &stroke(1.0 / 8000.0, 60_000.0, 1e-6),
            rapid_limit(60_000.0),
            "8 kHz rapid",
        );
        none(
            &stroke(1.0 / 8000.0, 60_000.0, 1e-6),
            GlitchParams::default(),
            "8 kHz",
        );
        // 70 ms polling with ±30 ms jitter on the stamps during a 60 m/min rapid: some steps
        // imply 2.5 × the real speed.
        let mut c = stroke_of(0.5, 0.07, 60_000.0, 1e-6);
        for (k, t) in c.time_s.iter_mut().enumerate() {
            *t += 0.03 * ((k * 7919 % 13) as f64 / 6.0 - 1.0);
        }
        assert!(c.time_s.windows(2).all(|w| w[1] > w[0]));
        none(&c, rapid_limit(60_000.0), "jittered polling");
        // a 10 µm quantum at 8 kHz and 5 mm/min
        none(
            &stroke(1.0 / 8000.0, 5.0, 10e-6),
            rapid_limit(1000.0),
            "coarse quantum",
        );
    }

    #[test]
    fn burst_stamped_samples_are_not_fast_motion() {
        // Samples taken every 8 ms during a 60 m/min rapid, stamped by a logger in bursts of
        // ten, 1 µs apart, on receipt: the median interval is 1 µs, the mean 8 ms.
        let c0 = stroke_of(0.5, 0.008, 60_000.0, 1e-6);
        let t: Vec<f64> = (0..c0.len())
            .map(|k| (k / 10) as f64 * 0.08 + (k % 10) as f64 * 1e-6)
            .collect();
        let c = ch(t, c0.value.clone());
        let s = screen_position(&c, &rapid_limit(60_000.0)).unwrap();
        assert!(s.glitches.is_empty());
        assert!(
            (s.timing_slack_s - 0.008).abs() < 1e-3,
            "{}",
            s.timing_slack_s
        );
    }

    #[test]
    fn short_channels_are_not_screened() {
        let c = ch(vec![0.0, 1.0], vec![0.0, 1e300]);
        assert_eq!(
            screen_position(&c, &GlitchParams::default()).unwrap(),
            Screening::default()
        );
    }

    #[test]
    fn infinite_limit_screens_nothing() {
        let mut c = stroke(0.01, 500.0, 1e-6);
        c.value[100] = 1e308;
        let off = GlitchParams {
            max_axis_speed_m_s: f64::INFINITY,
            ..GlitchParams::default()
        };
        assert!(screen_position(&c, &off).unwrap().glitches.is_empty());
    }

    #[test]
    fn remove_keeps_order() {
        let mut c = ch(
            (0..6).map(f64::from).collect(),
            (10..16).map(f64::from).collect(),
        );
        remove_samples(&mut c, &[0, 3, 5]);
        assert_eq!(c.time_s, [1.0, 2.0, 4.0]);
        assert_eq!(c.value, [11.0, 12.0, 14.0]);
    }

    proptest! {
        /// A smooth trajectory (any speeds up to the limit, accelerations, reversals), sampled at
        /// jittered intervals (stamps off by at most a quarter interval) and quantised, never
        /// loses a sample.
        #[test]
        fn smooth_quantised_trajectories_lose_nothing(
            dt in 1.0e-4f64..0.1,
            jitter in 0.0f64..0.25,
            quantum in prop_oneof![Just(1e-7), Just(1e-6), Just(5e-6)],
            rapid_mm_min in 1000.0f64..120_000.0,
            f1 in 0.01f64..3.0,
            f2 in 0.01f64..3.0,
            w in 0.0f64..1.0,
            n in 50usize..3000,
            seed in 0u64..1000,
        ) {
            let p = GlitchParams::from_rapid_rate(Some(rapid_mm_min));
            let vmax = feed_mm_min_to_m_s(rapid_mm_min);
            // z(t) = A1 sin(2π f1 t) + A2 sin(2π f2 t) with peak speed ≤ vmax
            let (a1, a2) = (
                w * vmax / (2.0 * std::f64::consts::PI * f1),
                (1.0 - w) * vmax / (2.0 * std::f64::consts::PI * f2),
            );
            let z = |t: f64| {
                0.2 + a1 * (2.0 * std::f64::consts::PI * f1 * t).sin()
                    + a2 * (2.0 * std::f64::consts::PI * f2 * t).sin()
            };
            // deterministic jitter from the seed (a small LCG)
            let mut s = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
            let mut next = || {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
            };
            let mut time_s = Vec::with_capacity(n);
            let mut value = Vec::with_capacity(n);
            for k in 0..n {
                let t_true = k as f64 * dt;
                let stamp = t_true + jitter * dt * next();
                time_s.push(stamp);
                value.push((z(t_true) / quantum).round() * quantum);
            }
            prop_assume!(time_s.windows(2).all(|w| w[1] > w[0]));
            let c = ch(time_s, value);
            let r = screen_position(&c, &p);
            prop_assert!(r.is_ok(), "{:?}", r);
            prop_assert!(r.unwrap().glitches.is_empty());
        }

        /// One absurd sample anywhere in such a trajectory is found and is the only one dropped.
        #[test]
        fn one_absurd_sample_is_found(
            n in 10usize..2000,
            at in 0.0f64..1.0,
            big in prop_oneof![Just(1e308), Just(-1e308), Just(1e3)],
        ) {
            let mut c = stroke(0.004, 3000.0, 1e-6);
            let n = n.min(c.len());
            c.time_s.truncate(n);
            c.value.truncate(n);
            let k = ((n - 1) as f64 * at) as usize;
            c.value[k] = big;
            let s = screen_position(&c, &GlitchParams::default()).unwrap();
            prop_assert_eq!(s.glitches, vec![k]);
        }
    }
}

#[cfg(test)]
mod effort_tests {
    use super::*;
    use crate::sim::{simulate, SimConfig};

    /// The twin's trace of moves at `feed` with rapid returns at 12 m/min, sampled as `sampling`
    /// (a TOML `[sampling]` table body).
    fn twin_effort(sampling: &str) -> Channel {
        let mut toml = String::from(
            "[motion]\nlead_in_s = 0.3\nlead_out_s = 0.3\nacceleration_mm_s2 = 3000\n",
        );
        for _ in 0..3 {
            toml.push_str(
                "[[motion.stroke]]\nto_mm = 60\nfeed_mm_min = 900\n\
                 [[motion.stroke]]\nto_mm = 0\nfeed_mm_min = 12000\n",
            );
        }
        toml.push_str(sampling);
        let cfg = SimConfig::from_toml_str(&toml).unwrap();
        simulate(&cfg, &mut |_| {}).unwrap().trace.effort
    }

    #[test]
    fn real_motion_loses_no_effort_sample_and_a_glitch_is_found() {
        for (what, sampling) in [
            ("72 ms polling", ""),
            (
                "8 kHz synchronous",
                "[sampling]\nmode = \"synchronous\"\nsynchronous_rate_hz = 8000\n",
            ),
        ] {
            let mut e = twin_effort(sampling);
            let s = screen_effort(&e);
            assert!(s.glitches.is_empty(), "{what}: {:?}", s.glitches);
            assert!(s.long_runs.is_empty(), "{what}: {:?}", s.long_runs);
            // Every real sample (reversals, rapids' ramps included) stays well within.
            let max = e.value.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let limit = s.limit.expect("screened");
            assert!(max < 0.5 * limit, "{what}: max {max} limit {limit}");
            let k = e.len() / 3;
            e.value[k] = -496_000.0;
            e.value[k + 7] = 1e9;
            e.value[k + 8] = -1e9;
            assert_eq!(screen_effort(&e).glitches, [k, k + 7, k + 8], "{what}");
        }
    }

    #[test]
    fn percentile_bin_is_at_or_above_the_exact_value_within_an_eighth_of_an_octave() {
        let mut v: Vec<f64> = (0..20_000)
            .map(|k| ((k as f64 * 0.37).sin() * 3.0 + (k % 17) as f64 * 0.01) * 1e-3)
            .collect();
        v.push(0.0);
        let mut m = EffortMagnitudes::default();
        m.add(&v);
        let mut a: Vec<f64> = v.iter().map(|x| x.abs()).collect();
        a.sort_by(f64::total_cmp);
        let exact = a[(EFFORT_SCALE_QUANTILE * a.len() as f64).ceil() as usize - 1];
        let got = m.glitch_limit().unwrap() / EFFORT_GLITCH_FACTOR;
        assert!(
            got >= exact && got <= exact * 2f64.powf(0.125) * (1.0 + 1e-12),
            "{got} vs {exact}"
        );
        // Too few samples, or a channel that is mostly zero: not screened.
        let mut few = EffortMagnitudes::default();
        few.add(&v[..40]);
        assert_eq!(few.glitch_limit(), None);
        let mut zeros = EffortMagnitudes::default();
        zeros.add(&vec![0.0; 5000]);
        zeros.add(&[3.0]);
        assert_eq!(zeros.glitch_limit(), None);
    }

    #[test]
    fn a_stretch_beyond_the_limit_is_kept_and_reported() {
        let time_s: Vec<f64> = (0..5000).map(|k| k as f64 * 1e-3).collect();
        let mut value: Vec<f64> = time_s.iter().map(|t| 1.0 + 0.1 * (7.0 * t).sin()).collect();
        for v in &mut value[100..104] {
            *v = 500.0;
        }
        let s = screen_effort(&Channel { time_s, value });
        assert!(s.glitches.is_empty());
        assert_eq!(s.long_runs, [(100, 4)]);
    }
}
