//! How smooth the position must be before it is differentiated twice, and how much friction
//! noise that leaves: the per-stroke choice of the position cut-off and the predicted noise
//! floor of Eq. 5.
//!
//! Eq. 5 subtracts m_eq·z'' from the motor force. z'' comes from a spline through sampled,
//! quantised positions, so the position's measurement noise (variance σ_z², at least q²/12 for
//! a quantum q) reaches the friction amplified by (2πf)² and by the equivalent mass. For white
//! noise sampled every h (one-sided density S = 2h·σ_z²) behind the Reinsch smoother's response
//! H(f) = 1/(1 + (f/f_c)⁴) (see [`crate::spline::smoothing_moments`]):
//!
//! ```text
//! σ_F,quant = m_eq·(2π)²·sqrt(S·∫ f⁴H(f)² df) = m_eq·(2π)²·sqrt(2h·σ_z²·c₅·f_c⁵),
//! c₅ = ∫₀^∞ x⁴/(1 + x⁴)² dx = π√2/16
//! ```
//!
//! The effort term is not smoothed (friction ripple lives in it), so its noise σ_e passes
//! one to one: σ_F,effort = G·σ_e with G the force per unit of effort.
//!
//! A cut-off fixed in screw orders cannot work (order 64 is 4 Hz at 60 mm/min and 200 Hz at
//! 3000 mm/min), so the cut-off is chosen **in time** per stroke, from what the stroke's own
//! samples say: the sampling interval, the position quantum and noise, the effort noise and
//! the time the stroke leaves for its ramps to settle:
//!
//! 1. the target: the quantisation part may be half the effort noise, or 2 % of the force
//!    variation along the stroke when the effort is nearly noise-free;
//! 2. f_noise solves σ_F,quant(f_c) = target: f_c = (target²/(m_eq²·(2π)⁴·2h·σ_z²·c₅))^(1/5);
//! 3. the smoother's kernel decays as exp(−t/τ) with τ = √2/(2π·f_c); the stroke loses
//!    [`SETTLE_TIME_CONSTANTS`]·τ after its acceleration ramp and before its deceleration, and
//!    those margins may take at most a third of its steady time T: f_settle = 6·N/(√2·π·T);
//! 4. f_c = max(f_noise, f_settle), at most 0.4/h (0.8 × Nyquist); when the interpolating
//!    spline of paper 000 already meets the target, nothing is smoothed.
//!
//! Above f_c the table acceleration is not resolved: a friction ripple there is estimated
//! without its inertia correction, so the trusted orders end at f_c·p/v.

use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// ∫₀^∞ x⁴/(1 + x⁴)² dx = π√2/16: the noise bandwidth of z'' behind the Reinsch smoother.
#[cfg(test)]
const C5: f64 = PI * std::f64::consts::SQRT_2 / 16.0;

/// Mean variance of an interpolating cubic spline's second derivative, in units of σ²/h⁴, for
/// white data on evenly spaced knots (measured by Monte Carlo in the tests below).
const INTERP_ACCEL_VAR: f64 = 14.0;

/// Time constants of the smoother's kernel left between a ramp and the first output point.
/// The kernel's error after a jerk step decays as e^(−t/τ); 6 leaves e⁻⁶ = 0.25 %.
pub const SETTLE_TIME_CONSTANTS: f64 = 6.0;

/// The predicted noise floor of the friction of one stroke (N RMS) and its parts.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct NoiseFloor {
    /// sqrt of the sum of the squared parts (N RMS).
    pub total_n: f64,
    /// Position quantum and noise, twice differentiated and times m_eq (N RMS).
    pub quantisation_n: f64,
    /// Noise and quantum of the current or torque, as force (N RMS).
    pub effort_n: f64,
    /// The inertia term the smoothing cannot follow: the ramp transient left after the
    /// settling margin, m_eq·j·τ·e^(−N), spread over the stroke (N RMS).
    pub inertia_n: f64,
}

impl NoiseFloor {
    /// Combine the parts.
    pub fn new(quantisation_n: f64, effort_n: f64, inertia_n: f64) -> Self {
        Self {
            total_n: (quantisation_n * quantisation_n
                + effort_n * effort_n
                + inertia_n * inertia_n)
                .sqrt(),
            quantisation_n,
            effort_n,
            inertia_n,
        }
    }
}

/// What the samples of one stroke say about their own noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SampleNoise {
    /// Mean position sampling interval h (s).
    pub interval_s: f64,
    /// Position measurement variance σ_z² (m²): at least q²/12.
    pub position_var_m2: f64,
    /// Effort noise as force, G·σ_e (N).
    pub effort_n: f64,
}

/// Robust standard deviation of white noise on a smooth signal sampled at `times`: the
/// fourth divided differences over five consecutive samples vanish for cubics (so for ramps,
/// steady feeds and slow ripple) whatever the spacing; each is scaled by its noise gain
/// sqrt(Σ c_i²) so that white noise of standard deviation σ gives σ, and the mean square of
/// the smallest 90 %, corrected for the trimming, gives σ² (see below). At most `MAX_DIFFS` differences are looked at, evenly spread,
/// so long strokes cost little. (On evenly spaced samples this is the 1, −4, 6, −4, 1 stencil
/// over √70.)
pub(crate) fn robust_noise_std(times: &[f64], values: &[f64]) -> f64 {
    // 4096 differences hold σ² to ±2.5 % (the cut-off, ∝ σ^(−2/5), to ±1 %).
    const MAX_DIFFS: usize = 4096;
    let n = values.len().min(times.len());
    if n < 5 {
        return 0.0;
    }
    let count = n - 4;
    let stride = count.div_ceil(MAX_DIFFS).max(1);
    // Each square is kept as its bit pattern: for finite non-negative doubles (all of them,
    // see below) the bits order as the values do, so the selection below compares integers
    // (f64::total_cmp on the same values gives the same answers, only dearer).
    let mut d: Vec<u64> = Vec::with_capacity(count.div_ceil(stride));
    d.extend((0..count).step_by(stride).filter_map(|k| {
        let t = &times[k..k + 5];
        let v = &values[k..k + 5];
        // Divided-difference weights c_i = 1/Π_{j≠i}(t_i − t_j), in units of the local
        // spacing so that nothing underflows; the ten gaps are formed once.
        let scale = (t[4] - t[0]) / 4.0;
        if scale.is_nan() || scale <= 0.0 {
            return None;
        }
        let r = 1.0 / scale;
        let g = |i: usize, j: usize| (t[i] - t[j]) * r;
        let (g01, g02, g03, g04) = (g(0, 1), g(0, 2), g(0, 3), g(0, 4));
        let (g12, g13, g14) = (g(1, 2), g(1, 3), g(1, 4));
        let (g23, g24, g34) = (g(2, 3), g(2, 4), g(3, 4));
        // Π_{j≠i}(t_i − t_j) with t_i − t_j = −(t_j − t_i) for j < i.
        let p = [
            g01 * g02 * g03 * g04,
            -g01 * g12 * g13 * g14,
            g02 * g12 * g23 * g24,
            -g03 * g13 * g23 * g34,
            g04 * g14 * g24 * g34,
        ];
        // The normalised difference (Σ c_i·v_i)²/Σ c_i² is unchanged when every c_i is
        // multiplied by Π_k p_k, which turns c_i = 1/p_i into Π_{k≠i} p_k: no division.
        // (Divisions dominated this kernel, which runs on every stroke.)
        let p01 = p[0] * p[1];
        let p34 = p[3] * p[4];
        let pre = [1.0, p[0], p01, p01 * p[2], p01 * p[2] * p[3]];
        let suf = [p[1] * p[2] * p34, p[2] * p34, p34, p[4], 1.0];
        let (mut dd, mut gain) = (0.0, 0.0);
        for i in 0..5 {
            let c = pre[i] * suf[i];
            dd += c * v[i];
            gain += c * c;
        }
        // The square: the trimmed mean below ranks and averages squares anyway. It is
        // +0 or positive (gain > 0 wherever it is finite).
        let r2 = dd * dd / gain;
        r2.is_finite().then_some(r2.to_bits())
    }));
    if d.is_empty() {
        return 0.0;
    }
    // Mean square of the smallest 90 %: robust to spikes and ramps' kinks, and continuous on
    // quantised data (whose median jumps in whole quanta). For Gaussian noise it holds
    // 1 − 2·z·φ(z)/0.9 = 0.6232 of σ² (z = 1.6449, the 90 % point of |x|).
    let keep = (d.len() * 9).div_ceil(10).max(1);
    if keep < d.len() {
        d.select_nth_unstable(keep - 1);
    }
    let ms = d[..keep].iter().map(|&b| f64::from_bits(b)).sum::<f64>() / keep as f64;
    (ms / 0.6232).sqrt()
}

/// The quantum of a quantised channel: the largest q that (nearly) every step between
/// consecutive values is a whole multiple of, tried as the smallest non-zero step divided by
/// 1 to 10 (steps of 4, 5 and 6 µm have the quantum 1 µm); 0 for an unquantised channel,
/// whose smallest step is only its slowest motion.
pub(crate) fn quantum(values: &[f64]) -> f64 {
    quantum_from_step(values, smallest_step(values))
}

/// The smallest non-zero step |v_{k+1} − v_k| between consecutive values; +∞ when there is
/// none. A minimum is exact whatever the grouping, so that of a channel is the smaller of its
/// parts' (the parts overlapping by one value, so that every step lies in one of them).
pub(crate) fn smallest_step(values: &[f64]) -> f64 {
    // Four independent lanes over equal-length slices (no bounds check in the loop), so
    // that it vectorises; zero steps (most of a slow feed) and NaN count as infinitely large.
    // A step is then never NaN, so a plain comparison is `f64::min`.
    let pairs = values.len().saturating_sub(1);
    let (from, to) = (&values[..pairs], &values[values.len().min(1)..]);
    let step = |a: f64, b: f64| {
        let d = (b - a).abs();
        if d > 0.0 {
            d
        } else {
            f64::INFINITY
        }
    };
    let mut lanes = [f64::INFINITY; 4];
    let (from4, to4) = (from.chunks_exact(4), to.chunks_exact(4));
    let (from_rest, to_rest) = (from4.remainder(), to4.remainder());
    for (a, b) in from4.zip(to4) {
        for l in 0..4 {
            let d = step(a[l], b[l]);
            lanes[l] = if d < lanes[l] { d } else { lanes[l] };
        }
    }
    for (&a, &b) in from_rest.iter().zip(to_rest) {
        let d = step(a, b);
        lanes[0] = if d < lanes[0] { d } else { lanes[0] };
    }
    lanes.iter().copied().fold(f64::INFINITY, f64::min)
}

/// [`quantum`] of `values` whose [`smallest_step`] is `q0`.
pub(crate) fn quantum_from_step(values: &[f64], q0: f64) -> f64 {
    // The smallest step over the whole channel (q0): at a slow feed most steps are zero and
    // the few quantum steps could all fall between the evenly spread sample below.
    if !q0.is_finite() {
        return 0.0;
    }
    // An evenly spread sample of the steps: enough to tell a quantum, cheap on long strokes.
    const MAX_STEPS: usize = 4096;
    let stride = values.len().div_ceil(MAX_STEPS).max(1);
    let steps: Vec<f64> = (1..values.len())
        .step_by(stride)
        .map(|k| (values[k] - values[k - 1]).abs())
        .filter(|d| *d > 0.0)
        .collect();
    if steps.is_empty() {
        return q0;
    }
    // At a fast feed every step spans many quanta; the steps then differ by whole quanta.
    let q1 = steps
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|d| *d > 1e-9 * q0)
        .fold(f64::INFINITY, f64::min);
    // 0.2 % of a quantum: above the rounding of decimal text (a 1 µm quantum printed to 1 nm
    // is exact), below the spread of an unquantised channel.
    // At most 5 % may miss; stop at the first miss beyond that (most candidates fail fast).
    let whole = |q: f64, s: &[f64]| {
        let allowed = s.len() - (0.95 * s.len() as f64).ceil() as usize;
        let inv_q = 1.0 / q;
        let mut misses = 0;
        for &d in s {
            let r = d * inv_q;
            if (r - nearest_integer(r)).abs() >= 2e-3 {
                misses += 1;
                if misses > allowed {
                    return false;
                }
            }
        }
        true
    };
    (1..=10)
        .map(|d| q0 / d as f64)
        .chain((1..=10).map(|d| q1 / d as f64).filter(|q| q.is_finite()))
        .find(|&q| whole(q, &steps))
        .unwrap_or(0.0)
}

/// The integer nearest to r ≥ 0 (NaN and ∞ as themselves): |r − nearest_integer(r)| is
/// exactly |r − r.round()|, ties included (both integers are ½ away). Adding and removing 2⁵²
/// rounds in one instruction each where `round` is a library call (x86-64 before SSE4.1).
#[inline]
fn nearest_integer(r: f64) -> f64 {
    const TWO52: f64 = 4_503_599_627_370_496.0;
    if r < TWO52 {
        (r + TWO52) - TWO52
    } else {
        // From 2⁵² on every double is an integer (and ∞, NaN stay what they are).
        r
    }
}

/// Measurement variance of a channel: the robust white-noise estimate (which holds the
/// quantisation error of a channel that moves many quanta per sample), at least q²/12 (a
/// slow quantised ramp's error is a sawtooth that the differences barely see).
pub(crate) fn channel_variance(times: &[f64], values: &[f64]) -> f64 {
    let (s, q) = channel_noise(times, values);
    (s * s).max(q * q / 12.0)
}

/// A channel's robust white-noise standard deviation ([`robust_noise_std`]) and its quantum
/// ([`quantum`], 0 when unquantised), in the channel's unit.
pub(crate) fn channel_noise(times: &[f64], values: &[f64]) -> (f64, f64) {
    (robust_noise_std(times, values), quantum(values))
}

/// ∫₀^u x⁴/(1 + x⁴)² dx: c₅ for u → ∞ (Simpson's rule below u = 8, the tail in closed form
/// beyond: the integrand is x⁻⁴ − 2x⁻⁸ + … there).
fn noise_bandwidth(u: f64) -> f64 {
    let simpson = |top: f64| {
        let g = |x: f64| {
            let x4 = x * x * x * x;
            x4 / ((1.0 + x4) * (1.0 + x4))
        };
        let n = 256;
        let h = top / n as f64;
        let mut sum = g(0.0) + g(top);
        for k in 1..n {
            sum += if k % 2 == 1 { 4.0 } else { 2.0 } * g(k as f64 * h);
        }
        sum * h / 3.0
    };
    let tail = |a: f64| 1.0 / (3.0 * a * a * a) - 2.0 / (7.0 * a.powi(7));
    if u > 8.0 {
        // The head up to 8 once per process: the cut-off's bisection asks for it 48 times a
        // stroke, at 256 points each.
        static HEAD_TO_8: std::sync::OnceLock<f64> = std::sync::OnceLock::new();
        *HEAD_TO_8.get_or_init(|| simpson(8.0)) + tail(8.0) - tail(u)
    } else {
        simpson(u)
    }
}

/// σ_F,quant of the Reinsch smoother at cut-off `cutoff_hz` (N RMS), module docs step 2, with
/// the noise integrated up to the Nyquist frequency 1/(2h) only (the cut-off may lie above it).
pub fn smoothed_quantisation_n(
    mass_kg: f64,
    position_var_m2: f64,
    interval_s: f64,
    cutoff_hz: f64,
) -> f64 {
    let w2 = (2.0 * PI) * (2.0 * PI);
    let nyquist = 0.5 / interval_s;
    let band = noise_bandwidth(nyquist / cutoff_hz) * cutoff_hz.powi(5);
    mass_kg * w2 * (2.0 * interval_s * position_var_m2 * band).sqrt()
}

/// σ_F,quant of the interpolating spline (N RMS): m_eq·sqrt(K·σ_z²)/h², K measured for
/// not-a-knot splines on evenly spaced knots.
pub fn interpolated_quantisation_n(mass_kg: f64, position_var_m2: f64, interval_s: f64) -> f64 {
    mass_kg * (INTERP_ACCEL_VAR * position_var_m2).sqrt() / (interval_s * interval_s)
}

/// The settling time constant τ = √2/(2π·f_c) of the smoother's kernel (s).
pub fn settle_time_constant_s(cutoff_hz: f64) -> f64 {
    std::f64::consts::SQRT_2 / (2.0 * PI * cutoff_hz)
}

/// The chosen position treatment of one stroke.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Differentiation {
    /// The interpolating spline of paper 000; its quantisation floor (N RMS).
    Interpolate { quantisation_n: f64 },
    /// A Reinsch smoother with this cut-off (Hz); its quantisation floor (N RMS).
    Smooth { cutoff_hz: f64, quantisation_n: f64 },
}

/// Choose the cut-off (module docs, steps 1-4). `variation_n` is the RMS of the motor force
/// about its mean along the stroke, `steady_s` the stroke's steady time.
pub(crate) fn choose(
    noise: &SampleNoise,
    mass_kg: f64,
    variation_n: f64,
    steady_s: f64,
) -> Differentiation {
    let h = noise.interval_s;
    let var = noise.position_var_m2;
    let interp = interpolated_quantisation_n(mass_kg, var, h);
    // Half the effort noise (the total then grows by 12 % only); a nearly noise-free effort
    // still leaves 0.5 % of the force variation.
    let target = (0.5 * noise.effort_n).max(0.005 * variation_n);
    if var <= 0.0 || mass_kg <= 0.0 || interp <= target || h.is_nan() || h <= 0.0 {
        return Differentiation::Interpolate {
            quantisation_n: interp,
        };
    }
    let floor_at = |f: f64| smoothed_quantisation_n(mass_kg, var, h, f);
    // Above 1.5 × Nyquist the smoother is as loud as the interpolating spline.
    let f_max = 0.75 / h;
    let f_settle = if steady_s > 0.0 {
        6.0 * SETTLE_TIME_CONSTANTS / (std::f64::consts::SQRT_2 * PI * steady_s)
    } else {
        f_max
    };
    let cutoff_hz = if f_settle >= f_max {
        f_max
    } else if floor_at(f_settle) >= target {
        f_settle
    } else {
        // The floor rises monotonically with the cut-off: bisect (in log) for the target.
        let (mut lo, mut hi) = (f_settle, f_max);
        for _ in 0..48 {
            let mid = (lo * hi).sqrt();
            if floor_at(mid) > target {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        lo
    };
    let smooth = floor_at(cutoff_hz);
    if smooth >= interp {
        Differentiation::Interpolate {
            quantisation_n: interp,
        }
    } else {
        Differentiation::Smooth {
            cutoff_hz,
            quantisation_n: smooth,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spline::{alpha_for_cutoff, smoothing_moments, CubicSpline, EndCondition};
    use rand::{Rng, SeedableRng};
    use rand_distr::{Distribution, Normal};

    /// The vectorised smallest step against the obvious fold, and the rounding trick against
    /// `round`, on quantised, unquantised, repeating and non-finite values of every length.
    #[test]
    fn smallest_step_and_nearest_integer_match_the_obvious_code() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        let obvious = |v: &[f64]| {
            v.windows(2)
                .map(|w| (w[1] - w[0]).abs())
                .filter(|d| *d > 0.0)
                .fold(f64::INFINITY, f64::min)
        };
        for len in (0..40).chain([1000, 4097]) {
            for kind in 0..4 {
                let v: Vec<f64> = (0..len)
                    .map(|k| match kind {
                        0 => (rng.random_range(-5.0..5.0f64) * 10.0).round() * 1e-7,
                        1 => rng.random_range(-1.0..1.0),
                        2 => (k / 7) as f64 * 1e-6,
                        _ => [0.0, f64::NAN, f64::INFINITY, 1.0, -0.0][k % 5],
                    })
                    .collect();
                let (got, want) = (smallest_step(&v), obvious(&v));
                assert_eq!(got.to_bits(), want.to_bits(), "len {len} kind {kind}");
            }
        }
        let mut r: Vec<f64> = (0..20_000).map(|_| rng.random_range(0.0..1e3)).collect();
        r.extend((0..2000).map(|k| k as f64 * 0.5));
        r.extend([
            0.0,
            0.5,
            2.5,
            4_503_599_627_370_495.5,
            4_503_599_627_370_496.0,
            1e300,
            f64::MIN_POSITIVE,
            f64::INFINITY,
            f64::NAN,
        ]);
        for x in r {
            let (got, want) = ((x - nearest_integer(x)).abs(), (x - x.round()).abs());
            assert_eq!(got.to_bits(), want.to_bits(), "{x}");
        }
    }

    fn white(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let d = Normal::new(0.0, 1.0).unwrap();
        (0..n).map(|_| d.sample(&mut rng)).collect()
    }

    /// Mean of z''² over dense points between the knots, away from the ends.
    fn mean_accel_sq(s: &CubicSpline<'_>, x: &[f64]) -> f64 {
        let (a, b) = (x[200], x[x.len() - 200]);
        let m = 20_000;
        (0..m)
            .map(|k| {
                let t = a + (b - a) * (k as f64 + 0.37) / m as f64;
                s.eval_all(t).2.powi(2)
            })
            .sum::<f64>()
            / m as f64
    }

    #[test]
    fn interpolating_spline_noise_gain_matches_constant() {
        // White data of unit variance on knots 1 apart: E[z''²] = K.
        let n = 6000;
        let x: Vec<f64> = (0..n).map(|k| k as f64).collect();
        let y = white(n, 7);
        let s = CubicSpline::new(&x, &y, EndCondition::NotAKnot).unwrap();
        let k = mean_accel_sq(&s, &x);
        // 5800 knots of chi-square-like averages: a few per cent of sampling scatter.
        eprintln!("K measured {k}");
        assert!((k / INTERP_ACCEL_VAR - 1.0).abs() < 0.1, "K measured {k}");
    }

    #[test]
    fn smoother_noise_gain_matches_formula() {
        // h = 2 ms, cut-off 20 Hz, σ = 1: predicted σ_a from the formula with mass 1.
        let (h, fc) = (0.002, 20.0);
        let n = 40_000;
        let x: Vec<f64> = (0..n).map(|k| k as f64 * h).collect();
        let y = white(n, 11);
        let mut g = Vec::new();
        let m = smoothing_moments(&x, &y, alpha_for_cutoff(h, fc), &mut g).unwrap();
        let s = CubicSpline::from_moments(&x, &g, m).unwrap();
        let measured = mean_accel_sq(&s, &x).sqrt();
        let predicted = smoothed_quantisation_n(1.0, 1.0, h, fc);
        assert!(
            (measured / predicted - 1.0).abs() < 0.1,
            "measured {measured}, predicted {predicted}"
        );
    }

    #[test]
    fn noise_bandwidth_tends_to_c5() {
        assert!((noise_bandwidth(1e6) / C5 - 1.0).abs() < 1e-6);
        // Below the cut-off the integrand is x⁴: ∫₀^0.1 x⁴ dx = 2e-6 (to 0.1 %).
        assert!((noise_bandwidth(0.1) / 2e-6 - 1.0).abs() < 1e-3);
        // Continuous at the switch to the closed-form tail.
        assert!((noise_bandwidth(8.0 + 1e-9) - noise_bandwidth(8.0)).abs() < 1e-9);
    }

    #[test]
    fn robust_noise_ignores_smooth_signal_and_spikes() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        let w = white(20_000, 5);
        // Jittered sampling (±20 % of 2 ms): the divided differences do not mind.
        let times: Vec<f64> = (0..20_000)
            .map(|k| k as f64 * 0.002 + 0.0004 * (rng.random::<f64>() - 0.5))
            .collect();
        let v: Vec<f64> = (0..20_000)
            .map(|k| {
                let t = times[k];
                // a ramp, a slow ripple and 0.3 of noise, with a few wild samples
                let spike = if rng.random::<f64>() < 0.001 {
                    1e3
                } else {
                    0.0
                };
                5.0 * t + 17.0 * (2.0 * PI * 3.0 * t).sin() + 0.3 * w[k] + spike
            })
            .collect();
        let s = robust_noise_std(&times, &v);
        assert!((s / 0.3 - 1.0).abs() < 0.05, "{s}");
    }

    /// [`robust_noise_std`] as it was before the squares were ranked by their bits: the
    /// selection on f64 with `total_cmp`.
    fn robust_noise_std_reference(times: &[f64], values: &[f64]) -> f64 {
        let n = values.len().min(times.len());
        if n < 5 {
            return 0.0;
        }
        let count = n - 4;
        let stride = count.div_ceil(4096).max(1);
        let mut d: Vec<f64> = (0..count)
            .step_by(stride)
            .filter_map(|k| {
                let (t, v) = (&times[k..k + 5], &values[k..k + 5]);
                let scale = (t[4] - t[0]) / 4.0;
                if scale.is_nan() || scale <= 0.0 {
                    return None;
                }
                let r = 1.0 / scale;
                let g = |i: usize, j: usize| (t[i] - t[j]) * r;
                let (g01, g02, g03, g04) = (g(0, 1), g(0, 2), g(0, 3), g(0, 4));
                let (g12, g13, g14) = (g(1, 2), g(1, 3), g(1, 4));
                let (g23, g24, g34) = (g(2, 3), g(2, 4), g(3, 4));
                let p = [
                    g01 * g02 * g03 * g04,
                    -g01 * g12 * g13 * g14,
                    g02 * g12 * g23 * g24,
                    -g03 * g13 * g23 * g34,
                    g04 * g14 * g24 * g34,
                ];
                let p01 = p[0] * p[1];
                let p34 = p[3] * p[4];
                let pre = [1.0, p[0], p01, p01 * p[2], p01 * p[2] * p[3]];
                let suf = [p[1] * p[2] * p34, p[2] * p34, p34, p[4], 1.0];
                let (mut dd, mut gain) = (0.0, 0.0);
                for i in 0..5 {
                    let c = pre[i] * suf[i];
                    dd += c * v[i];
                    gain += c * c;
                }
                let r2 = dd * dd / gain;
                r2.is_finite().then_some(r2)
            })
            .collect();
        if d.is_empty() {
            return 0.0;
        }
        let keep = (d.len() * 9).div_ceil(10).max(1);
        if keep < d.len() {
            d.select_nth_unstable_by(keep - 1, f64::total_cmp);
        }
        let ms = d[..keep].iter().sum::<f64>() / keep as f64;
        (ms / 0.6232).sqrt()
    }

    #[test]
    fn robust_noise_gives_the_bits_of_the_reference() {
        // Quantised values (many equal squares, so ties in the ranking), jittered and repeated
        // times, spikes, and lengths around the stride's steps: the sum over the kept squares
        // must add the same values in the same order.
        let mut rng = rand::rngs::StdRng::seed_from_u64(21);
        for case in 0..200 {
            let n = [5, 6, 17, 100, 1000, 4100, 9000, 20_000][case % 8] + case;
            let q = [0.0, 1e-6, 1e-3, 1.0][case % 4];
            let mut t = 0.0;
            let (mut times, mut values) = (Vec::new(), Vec::new());
            for k in 0..n {
                t += if rng.random::<f64>() < 0.01 {
                    0.0
                } else {
                    1e-3 * (0.5 + rng.random::<f64>())
                };
                let x =
                    1e-2 * t + 1e-4 * (k as f64 * 0.01).sin() + 3e-6 * (rng.random::<f64>() - 0.5);
                let x = if rng.random::<f64>() < 0.002 {
                    x + 1.0
                } else {
                    x
                };
                times.push(t);
                values.push(if q > 0.0 { (x / q).round() * q } else { x });
            }
            let (a, b) = (
                robust_noise_std(&times, &values),
                robust_noise_std_reference(&times, &values),
            );
            assert_eq!(a.to_bits(), b.to_bits(), "case {case}: {a} vs {b}");
        }
    }

    #[test]
    fn quantised_channel_takes_its_quantum() {
        // 1 µm steps of a slow ramp: the quantum's q²/12, not the sawtooth's differences.
        let v: Vec<f64> = (0..5000)
            .map(|k| (k as f64 * 0.3e-6 / 1e-6).round() * 1e-6)
            .collect();
        let t: Vec<f64> = (0..5000).map(|k| k as f64 * 1e-3).collect();
        let var = channel_variance(&t, &v);
        assert!((1e-12 / 12.0..2.0 * 1e-12 / 12.0).contains(&var), "{var}");
    }

    #[test]
    fn slow_feed_at_a_high_rate_keeps_its_quantum() {
        // 10 mm/min at 8 kHz with 1 µm steps: one step every 48 samples, so an evenly spread
        // sample of the steps (stride 118 here) sees none; the quantum must still be found
        // (missing it once cost 63 kN of error behind a 0.6 N predicted floor).
        let v: Vec<f64> = (0..480_000)
            .map(|k| (k as f64 / 48.0).floor() * 1e-6)
            .collect();
        assert!((quantum(&v) / 1e-6 - 1.0).abs() < 1e-9, "{}", quantum(&v));
    }

    #[test]
    fn unquantised_steady_feed_has_no_quantum() {
        // 130-137 µm per sample of a steady feed with timing jitter: not a 130 µm quantum.
        let v: Vec<f64> = (0..500)
            .map(|k| k as f64 * 133e-6 + 3e-6 * ((k as f64 * 12.9898).sin() * 43758.5453).fract())
            .collect();
        assert!(
            quantum(&v) == 0.0,
            "an unquantised channel has quantum 0 exactly"
        );
        // The same feed quantised to 1 µm: steps of 133-136 µm, quantum 1 µm.
        let q: Vec<f64> = v.iter().map(|x| (x / 1e-6).round() * 1e-6).collect();
        assert!((quantum(&q) / 1e-6 - 1.0).abs() < 1e-6, "{}", quantum(&q));
        // Steps of 5 and 6 µm: 1 µm, not the smallest step.
        let s: Vec<f64> = (0..300).map(|k| (k as f64 * 5.3).round() * 1e-6).collect();
        assert!((quantum(&s) / 1e-6 - 1.0).abs() < 1e-6, "{}", quantum(&s));
    }

    #[test]
    fn cutoff_choice_in_time_not_orders() {
        // A mill axis at 500 Hz, 1 µm, 1 N of effort noise, 940 kg: a cut-off of some 15-20 Hz
        // whatever the feed, because nothing in the choice depends on the feed.
        let noise = SampleNoise {
            interval_s: 0.002,
            position_var_m2: 1e-12 / 12.0,
            effort_n: 1.0,
        };
        match choose(&noise, 940.0, 17.0, 6.0) {
            Differentiation::Smooth {
                cutoff_hz,
                quantisation_n,
            } => {
                assert!((12.0..22.0).contains(&cutoff_hz), "{cutoff_hz}");
                assert!((quantisation_n - 0.5).abs() < 1e-6, "{quantisation_n}");
            }
            other => panic!("{other:?}"),
        }
        // FOCAS-style 72 ms polling: the interpolating spline is already quiet enough.
        let slow = SampleNoise {
            interval_s: 0.072,
            position_var_m2: 1e-12 / 12.0,
            effort_n: 2.3,
        };
        assert!(matches!(
            choose(&slow, 2000.0, 30.0, 200.0),
            Differentiation::Interpolate { .. }
        ));
        // A short stroke needs a faster settle: the cut-off rises above the noise choice.
        match choose(&noise, 940.0, 17.0, 0.2) {
            Differentiation::Smooth { cutoff_hz, .. } => {
                let f_settle = 6.0 * SETTLE_TIME_CONSTANTS / (std::f64::consts::SQRT_2 * PI * 0.2);
                assert!((cutoff_hz - f_settle).abs() < 1e-9);
            }
            other => panic!("{other:?}"),
        }
    }
}
