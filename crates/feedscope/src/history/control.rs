//! Baseline, Shewhart limits, EWMA and CUSUM of one indicator series, and the projected
//! crossing of a user threshold from the recent slope.
use serde::{Deserialize, Serialize};

use super::{HistoryError, Point};

/// Where the baseline of an indicator comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum BaselineSpec {
    /// Mean and sample standard deviation of the first `count` points (count ≥ 2).
    FirstN {
        /// Number of tests in the baseline.
        count: usize,
    },
    /// The mean is the value of point `index` (a test marked as reference); the standard
    /// deviation is the sample standard deviation of the first `spread_count` points when
    /// that is ≥ 2, else the reference's own standard error.
    Reference {
        /// Index of the reference point in the series.
        index: usize,
        /// Number of leading points whose scatter sets σ.
        spread_count: usize,
    },
}

impl Default for BaselineSpec {
    fn default() -> Self {
        BaselineSpec::FirstN { count: 5 }
    }
}

/// In-control level μ₀ and scatter σ of an indicator.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Baseline {
    /// In-control mean μ₀ (indicator unit).
    pub mean: f64,
    /// In-control standard deviation σ (indicator unit), after the floor.
    pub std: f64,
    /// Points that set it.
    pub count: usize,
    /// `true` when σ was raised to the floor `min_relative_std·|μ₀|`.
    pub std_floored: bool,
}

/// Baseline of `points` (time order) by `spec`, with σ floored at `min_relative_std·|μ₀|`
/// (and at `f64::MIN_POSITIVE`) so that a series that happens to repeat the same value does not
/// make every later wobble an alarm.
///
/// # Errors
/// [`HistoryError::TooFewPoints`] when the series is shorter than the baseline needs;
/// [`HistoryError::NotFinite`] for a NaN or infinite value.
pub fn baseline(
    points: &[Point],
    spec: BaselineSpec,
    min_relative_std: f64,
) -> Result<Baseline, HistoryError> {
    let (mean, raw_std, count) = match spec {
        BaselineSpec::FirstN { count } => {
            let need = count.max(2);
            if points.len() < need {
                return Err(HistoryError::TooFewPoints {
                    needed: need,
                    got: points.len(),
                });
            }
            let (m, s) = mean_std(&points[..need])?;
            (m, s, need)
        }
        BaselineSpec::Reference {
            index,
            spread_count,
        } => {
            let p = points.get(index).ok_or(HistoryError::TooFewPoints {
                needed: index + 1,
                got: points.len(),
            })?;
            check_finite(p)?;
            let s = if spread_count >= 2 && points.len() >= spread_count {
                mean_std(&points[..spread_count])?.1
            } else {
                p.std_error.unwrap_or(0.0)
            };
            (p.value, s, 1)
        }
    };
    let floor = (min_relative_std * mean.abs()).max(f64::MIN_POSITIVE);
    Ok(Baseline {
        mean,
        std: raw_std.max(floor),
        count,
        std_floored: raw_std < floor,
    })
}

fn check_finite(p: &Point) -> Result<(), HistoryError> {
    if p.value.is_finite() && p.time_s.is_finite() {
        Ok(())
    } else {
        Err(HistoryError::NotFinite { time_s: p.time_s })
    }
}

/// Mean and sample standard deviation (n − 1) of the values.
fn mean_std(points: &[Point]) -> Result<(f64, f64), HistoryError> {
    for p in points {
        check_finite(p)?;
    }
    let n = points.len() as f64;
    let m = points.iter().map(|p| p.value).sum::<f64>() / n;
    let ss: f64 = points.iter().map(|p| (p.value - m).powi(2)).sum();
    Ok((
        m,
        if points.len() > 1 {
            (ss / (n - 1.0)).sqrt()
        } else {
            0.0
        },
    ))
}

/// Shewhart limits μ₀ ± L·σ.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Limits {
    /// Lower control limit (indicator unit).
    pub lower: f64,
    /// Upper control limit (indicator unit).
    pub upper: f64,
}

impl Limits {
    /// μ₀ ± `l`·σ of a baseline.
    pub fn shewhart(b: &Baseline, l: f64) -> Self {
        Self {
            lower: b.mean - l * b.std,
            upper: b.mean + l * b.std,
        }
    }

    /// `true` when `x` lies outside [lower, upper].
    pub fn outside(&self, x: f64) -> bool {
        x < self.lower || x > self.upper
    }
}

/// Exponentially weighted moving average chart (Roberts 1959; Montgomery, *Introduction to
/// Statistical Quality Control*, Eq. 9.22-9.25):
///
/// z_t = λ·x_t + (1 − λ)·z_{t−1}, z_0 = μ₀, limits μ₀ ± L·σ·√(λ/(2 − λ)·(1 − (1 − λ)^{2t})),
/// t = 1, 2, ...
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Ewma {
    /// z_t for each point (indicator unit).
    pub z: Vec<f64>,
    /// Time-varying limits of z_t.
    pub limits: Vec<Limits>,
    /// Index of the first point whose z_t is outside its limits.
    pub first_alarm: Option<usize>,
}

/// EWMA chart of `values` around `b` with weight `lambda` ∈ (0, 1] and width `l` (σ units).
pub fn ewma(values: &[f64], b: &Baseline, lambda: f64, l: f64) -> Ewma {
    ewma_around_estimate(values, b, lambda, l, 0.0)
}

/// [`ewma`] whose limits also hold the error of μ₀ itself when μ₀ is an estimate:
/// μ₀ ± L·σ·√(λ/(2 − λ)·(1 − (1 − λ)^{2t}) + `mean_var`), `mean_var` = Var(μ₀)/σ² (1/n for the
/// mean of n baseline tests, 1 for a single reference test). The EWMA averages the tests'
/// scatter away but not the baseline's own error, which every later z_t carries in full: with
/// 5 baseline tests and λ = 0.2 that error is larger than the scatter left in z_t, and
/// without it an unchanged series drifts out of its EWMA limits far more often than L
/// promises.
pub fn ewma_around_estimate(
    values: &[f64],
    b: &Baseline,
    lambda: f64,
    l: f64,
    mean_var: f64,
) -> Ewma {
    let mut z = Vec::with_capacity(values.len());
    let mut limits = Vec::with_capacity(values.len());
    let mut first_alarm = None;
    let mut prev = b.mean;
    let r = 1.0 - lambda;
    for (i, &x) in values.iter().enumerate() {
        let zt = lambda * x + r * prev;
        let t = (i + 1) as f64;
        let w = l * b.std * (lambda / (2.0 - lambda) * (1.0 - r.powf(2.0 * t)) + mean_var).sqrt();
        let lim = Limits {
            lower: b.mean - w,
            upper: b.mean + w,
        };
        if first_alarm.is_none() && lim.outside(zt) {
            first_alarm = Some(i);
        }
        z.push(zt);
        limits.push(lim);
        prev = zt;
    }
    Ewma {
        z,
        limits,
        first_alarm,
    }
}

/// Two-sided tabular CUSUM on standardized values (Page 1954; Montgomery Eq. 9.2-9.3):
///
/// u_t = (x_t − μ₀)/σ, C⁺_t = max(0, C⁺_{t−1} + u_t − k), C⁻_t = max(0, C⁻_{t−1} − u_t − k),
/// alarm when C⁺ or C⁻ exceeds h. k and h are in σ units (defaults 0.5 and 5: a shift of
/// 1 σ is detected after about 10 points on average, a false alarm every ~465 points).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Cusum {
    /// C⁺_t (σ units).
    pub upper: Vec<f64>,
    /// C⁻_t (σ units).
    pub lower: Vec<f64>,
    /// Decision interval h (σ units).
    pub h: f64,
    /// Index of the first point where C⁺ or C⁻ exceeds h.
    pub first_alarm: Option<usize>,
}

/// CUSUM of `values` around `b` with reference value `k` and decision interval `h`.
pub fn cusum(values: &[f64], b: &Baseline, k: f64, h: f64) -> Cusum {
    let (mut cp, mut cn) = (0.0f64, 0.0f64);
    let mut upper = Vec::with_capacity(values.len());
    let mut lower = Vec::with_capacity(values.len());
    let mut first_alarm = None;
    for (i, &x) in values.iter().enumerate() {
        let u = (x - b.mean) / b.std;
        cp = (cp + u - k).max(0.0);
        cn = (cn - u - k).max(0.0);
        if first_alarm.is_none() && (cp > h || cn > h) {
            first_alarm = Some(i);
        }
        upper.push(cp);
        lower.push(cn);
    }
    Cusum {
        upper,
        lower,
        h,
        first_alarm,
    }
}

/// Least-squares line through the last points, value = a + slope·(t − t_last).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RecentSlope {
    /// Slope (indicator unit per day).
    pub per_day: f64,
    /// Its standard error (indicator unit per day).
    pub std_error_per_day: f64,
    /// Fitted value at the last point (indicator unit).
    pub value_at_last: f64,
    /// Points used.
    pub count: usize,
}

/// Ordinary least-squares slope of the last `window` points (≥ 3 needed, time in days).
/// `None` when there are fewer than 3 points or all at one time.
pub fn recent_slope(points: &[Point], window: usize) -> Option<RecentSlope> {
    let w = window.max(3).min(points.len());
    if w < 3 {
        return None;
    }
    let pts = &points[points.len() - w..];
    let t_last = pts[w - 1].time_s;
    let t: Vec<f64> = pts.iter().map(|p| (p.time_s - t_last) / 86_400.0).collect();
    let n = w as f64;
    let tm = t.iter().sum::<f64>() / n;
    let ym = pts.iter().map(|p| p.value).sum::<f64>() / n;
    let stt: f64 = t.iter().map(|x| (x - tm).powi(2)).sum();
    if stt <= 0.0 {
        return None;
    }
    let sty: f64 = t
        .iter()
        .zip(pts)
        .map(|(x, p)| (x - tm) * (p.value - ym))
        .sum();
    let slope = sty / stt;
    let a = ym - slope * tm;
    let rss: f64 = t
        .iter()
        .zip(pts)
        .map(|(x, p)| (p.value - a - slope * x).powi(2))
        .sum();
    let s2 = rss / (n - 2.0);
    Some(RecentSlope {
        per_day: slope,
        std_error_per_day: (s2 / stt).sqrt(),
        value_at_last: a,
        count: w,
    })
}

/// Largest |alarm level| a threshold may set (indicator unit): no indicator of a feed drive
/// (forces in N, σ in N·s/m, J in kg·m², speeds, percentages) comes near 1e9, and a level far
/// beyond makes projections and plots meaningless (`upper = 4e102` broke the report's charts).
pub const MAX_ABS_THRESHOLD: f64 = 1e9;

/// A user threshold on an indicator: an alarm level above and/or below.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Threshold {
    /// Alarm when the indicator rises above this (indicator unit).
    pub upper: Option<f64>,
    /// Alarm when the indicator falls below this (indicator unit).
    pub lower: Option<f64>,
}

/// When the recent trend reaches a threshold.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Projection {
    /// The threshold it heads for (indicator unit).
    pub threshold: f64,
    /// `true` for the upper threshold.
    pub upper: bool,
    /// Days from the last test until the fitted line reaches the threshold.
    pub days: f64,
}

/// Days until the line of `s` reaches the threshold it heads for; `None` when it heads away
/// from both, is already beyond, or the slope is not distinguishable from zero (|slope| < 2·SE).
pub fn project_crossing(s: &RecentSlope, th: &Threshold) -> Option<Projection> {
    // false for NaN too
    let significant = s.per_day.abs() > 2.0 * s.std_error_per_day;
    if !significant {
        return None;
    }
    let (thr, upper) = if s.per_day > 0.0 {
        (th.upper?, true)
    } else {
        (th.lower?, false)
    };
    let days = (thr - s.value_at_last) / s.per_day;
    (days > 0.0).then_some(Projection {
        threshold: thr,
        upper,
        days,
    })
}

/// Limit width L (σ units) for each of `members` charts judged together at every test, such
/// that the chance that any of them raises a false alarm at a test (Gaussian, independent
/// scatter) is `false_alarm_per_test` (Šidák's correction for a family of tests):
///
/// α = 1 − (1 − α_family)^{1/m}, L = Φ⁻¹(1 − α / 2).
///
/// An axis has a dozen or more component amplitudes; judged each at ±3σ, one of them leaves
/// its band by chance every few dozen tests although the screw is unchanged. One ±3σ chart has
/// α_family = 0.0027 (L = 3.0 for m = 1); α_family = 0.001 gives L = 3.84 for 8 members and
/// 4.06 for 20. `false_alarm_per_test` is clamped to [1e-12, 0.5] and `members` to ≥ 1.
pub fn family_limit_width(false_alarm_per_test: f64, members: usize) -> f64 {
    let family = if false_alarm_per_test.is_nan() {
        0.0027
    } else {
        false_alarm_per_test.clamp(1e-12, 0.5)
    };
    // 1 − (1 − α)^{1/m} without cancellation for small α
    let alpha = -((-family).ln_1p() / members.max(1) as f64).exp_m1();
    normal_upper_quantile(alpha / 2.0)
}

/// 1 − Φ(x) of the standard normal distribution, via the complementary error function
/// (Chebyshev fit of Numerical Recipes §6.2, fractional error < 1.2e-7 everywhere).
fn normal_upper_tail(x: f64) -> f64 {
    0.5 * erfc(x / std::f64::consts::SQRT_2)
}

fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let r = t * poly.exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

/// x with 1 − Φ(x) = p, for p ∈ (0, 0.5]: bisection on [`normal_upper_tail`] (monotone), to
/// 1e-10 in x; a limit width needs no more.
fn normal_upper_quantile(p: f64) -> f64 {
    let (mut lo, mut hi) = (0.0_f64, 40.0_f64);
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if normal_upper_tail(mid) > p {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo < 1e-10 {
            break;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod family_tests {
    use super::*;

    #[test]
    fn normal_tail_matches_tabulated_values() {
        // Abramowitz & Stegun Table 26.1 values, to the fit's 1.2e-7 relative accuracy
        for (x, q) in [
            (0.0, 0.5),
            (1.0, 0.158_655_253_9),
            (1.959_963_985, 0.025),
            (3.0, 0.001_349_898_0),
            (4.0, 3.167_124_2e-5),
        ] {
            let got = normal_upper_tail(x);
            assert!((got - q).abs() <= 2e-7 * q, "x {x}: {got} vs {q}");
            assert!((normal_upper_quantile(q) - x).abs() < 1e-5, "q {q}");
        }
    }

    #[test]
    fn family_width_keeps_the_family_rate() {
        // one chart at α = 0.0027 is the ±3σ chart
        assert!((family_limit_width(0.002_699_796, 1) - 3.0).abs() < 1e-5);
        assert!((family_limit_width(0.001, 8) - 3.8360).abs() < 1e-3);
        for m in [2usize, 8, 20, 100] {
            let l = family_limit_width(0.001, m);
            let fam = 1.0 - (1.0 - 2.0 * normal_upper_tail(l)).powi(m as i32);
            assert!((fam - 0.001).abs() < 1e-6, "m {m}: {fam}");
            assert!(l > family_limit_width(0.001, m - 1));
        }
        assert!(family_limit_width(f64::NAN, 1).is_finite());
    }
}
