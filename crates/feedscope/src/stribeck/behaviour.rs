//! Non-conventional Stribeck behaviour: friction that falls with feed where a conventional
//! Stribeck curve rises (paper 000 Section 4.2.1: "the friction characteristic curve decrease
//! as the feed velocity increases, exhibiting nonconventional Stribeck-curve behavior").
//!
//! # Method
//! A conventional curve (F_s ≥ F_c, σ ≥ 0) falls only from the slowest feeds through its
//! Stribeck region and does not fall again once it has risen.
//! 1. The noise s of one point is given, or estimated robustly as 1.4826·MAD/√6 of the
//!    second differences of neighbouring fit residuals (a fit that bent towards an anomaly
//!    leaves a smooth misfit, whose linear part the differences cancel). The threshold is k·√2·s, a drop
//!    being the difference of two noisy points.
//! 2. v* = the speed of the minimum of the fitted curve (on a fine log grid) when it lies
//!    inside the data.
//! 3. On the points at speeds ≥ v* (all points when the fit has no interior minimum), sorted
//!    by speed with equal speeds averaged, a fall starts at the running maximum once the data
//!    are more than the threshold below it, extends to the lowest point that follows, and
//!    ends when the data recover by more than the threshold (or at the last point).
//! 4. Without an interior minimum, a first fall that starts at one of the three slowest feeds,
//!    or below the fitted v_s, is the conventional Stribeck fall and its end becomes v*.
//!    Every other fall is non-conventional.
//!
//! Limitation: a non-conventional fall that continues the Stribeck fall without a recovery
//! larger than the threshold in between merges with it and is not reported separately; the
//! fitted curve then shows it (σ on its bound 0, v_s far up the feed range).
//!
//! Each range reports its feeds, the drop of the data, the change the fit predicts over the
//! same feeds and the drop in excess of that prediction.
//!
//! # Reference
//! Paper 000 Section 4.2.1, Figures 14-15.

use serde::{Deserialize, Serialize};

use super::{StribeckError, StribeckFit, M_S_PER_MM_MIN};

/// Settings of [`detect_nonconventional`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct NonConventionalParams {
    /// Threshold in noise standard deviations, k (a drop must exceed k·√2·s). Default 3.
    pub k_sigma: f64,
    /// Noise standard deviation of one friction value (N); `None` (default) estimates it from
    /// the fit residuals.
    pub noise_n: Option<f64>,
}

impl Default for NonConventionalParams {
    fn default() -> Self {
        Self {
            k_sigma: 3.0,
            noise_n: None,
        }
    }
}

/// A feed range over which friction falls where a conventional curve would not.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FallingRange {
    /// Speed where the fall starts (the local maximum) (m/s).
    pub from_m_s: f64,
    /// Speed of the lowest point of the fall (m/s).
    pub to_m_s: f64,
    /// Points from start to end, inclusive.
    pub points: usize,
    /// How much the data fall, F(from) − F(to) (N, > 0).
    pub drop_n: f64,
    /// Change the fitted curve predicts over the same range, F̂(to) − F̂(from) (N).
    pub fit_change_n: f64,
    /// Drop beyond the prediction: drop + fit change (N).
    pub excess_drop_n: f64,
}

impl FallingRange {
    /// Start feed (mm/min).
    pub fn from_mm_min(&self) -> f64 {
        self.from_m_s / M_S_PER_MM_MIN
    }

    /// End feed (mm/min).
    pub fn to_mm_min(&self) -> f64 {
        self.to_m_s / M_S_PER_MM_MIN
    }
}

/// Result of [`detect_nonconventional`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NonConventional {
    /// Falling ranges, by increasing feed; empty for conventional behaviour.
    pub ranges: Vec<FallingRange>,
    /// Speed v* where the conventional Stribeck fall ends, above which friction should not
    /// fall (m/s): the fitted curve's minimum, else the end of a fall from the slowest feeds,
    /// else the slowest speed.
    pub rising_above_m_s: f64,
    /// Noise standard deviation used (N).
    pub noise_n: f64,
    /// Detection threshold k·√2·s (N).
    pub threshold_n: f64,
}

/// Find feed ranges where friction falls where the conventional curve `fit` rises (see the
/// module docs). Pass the same points (one direction, signs dropped) the fit was made from.
///
/// # Errors
/// [`StribeckError::LengthMismatch`], [`StribeckError::NonFinite`] for bad points;
/// [`StribeckError::BadParameter`] for k ≤ 0 or a negative noise.
///
/// # Example
/// ```
/// use feedscope::stribeck::{detect_nonconventional, fit_stribeck, NonConventionalParams,
///                           StribeckFitParams, StribeckParams};
/// let truth = StribeckParams { fc_n: 200.0, fs_n: 260.0, vs_m_s: 4e-4,
///                              sigma_n_s_per_m: 5000.0, delta: 2.0 };
/// let v: Vec<f64> = (0..18).map(|k| 8.3e-5 * 120f64.powf(k as f64 / 17.0)).collect();
/// let f: Vec<f64> = v.iter().map(|&s| truth.magnitude_n(s)).collect();
/// let fit = fit_stribeck(&v, &f, &StribeckFitParams::default()).unwrap();
/// let params = NonConventionalParams { noise_n: Some(1.0), ..Default::default() };
/// let nc = detect_nonconventional(&v, &f, &fit, &params).unwrap();
/// assert!(nc.ranges.is_empty());
/// ```
pub fn detect_nonconventional(
    speed_m_s: &[f64],
    friction_n: &[f64],
    fit: &StribeckFit,
    params: &NonConventionalParams,
) -> Result<NonConventional, StribeckError> {
    if speed_m_s.len() != friction_n.len() {
        return Err(StribeckError::LengthMismatch {
            speeds: speed_m_s.len(),
            frictions: friction_n.len(),
        });
    }
    for (quantity, vals) in [("speed", speed_m_s), ("friction", friction_n)] {
        if let Some(index) = vals.iter().position(|v| !v.is_finite()) {
            return Err(StribeckError::NonFinite {
                quantity,
                index,
                value: vals[index],
            });
        }
    }
    if !(params.k_sigma.is_finite() && params.k_sigma > 0.0) {
        return Err(StribeckError::BadParameter {
            name: "k_sigma",
            value: params.k_sigma,
            expected: "a positive number of standard deviations",
        });
    }
    if let Some(s) = params.noise_n {
        if !(s.is_finite() && s >= 0.0) {
            return Err(StribeckError::BadParameter {
                name: "noise_n",
                value: s,
                expected: "a non-negative noise level in N",
            });
        }
    }
    let p = &fit.params;
    // Points sorted by speed, equal speeds averaged.
    let mut pts: Vec<(f64, f64)> = speed_m_s
        .iter()
        .zip(friction_n)
        .map(|(v, f)| (v.abs(), f.abs()))
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut merged: Vec<(f64, f64, usize)> = Vec::with_capacity(pts.len());
    for (v, f) in pts {
        match merged.last_mut() {
            Some(last) if (v - last.0).abs() <= 1e-12 * v.max(1e-300) => {
                last.1 += f;
                last.2 += 1;
            }
            _ => merged.push((v, f, 1)),
        }
    }
    let pts: Vec<(f64, f64)> = merged
        .into_iter()
        .map(|(v, f, c)| (v, f / c as f64))
        .collect();
    let max_f = pts.iter().fold(0.0f64, |m, p| m.max(p.1));
    if pts.is_empty() {
        return Err(StribeckError::TooFewPoints {
            points: 0,
            needed: 1,
        });
    }

    // Step 1: noise and threshold. The fit may bend towards an anomaly, so its residuals carry
    // a smooth misfit; second differences of neighbouring residuals cancel its linear part.
    let noise_n = match params.noise_n {
        Some(s) => s,
        None => {
            let r: Vec<f64> = pts.iter().map(|q| q.1 - p.magnitude_n(q.0)).collect();
            // r_{i−1} − 2r_i + r_{i+1} of white noise has variance 6s²
            let mut d: Vec<f64> = r.windows(3).map(|w| w[0] - 2.0 * w[1] + w[2]).collect();
            let med = median(&mut d.clone());
            let mut dev: Vec<f64> = d.iter_mut().map(|x| (*x - med).abs()).collect();
            1.4826 * median(&mut dev) / 6f64.sqrt()
        }
    }
    // a floor so that noise-free data do not flag rounding-level wiggles
    .max(1e-9 * max_f);
    let threshold_n = params.k_sigma * std::f64::consts::SQRT_2 * noise_n;

    // Step 2: v*, the minimum of the fitted curve when it lies inside the data.
    let (v_lo, v_hi) = (pts[0].0, pts[pts.len() - 1].0);
    let mut fit_min = None;
    if v_hi > 0.0 {
        let lo = v_lo.max(v_hi * 1e-6);
        let m = 400;
        let (mut best_v, mut best_f) = (lo, f64::INFINITY);
        for k in 0..=m {
            let v = lo * (v_hi / lo).powf(k as f64 / m as f64);
            let f = p.magnitude_n(v);
            if f < best_f {
                (best_v, best_f) = (v, f);
            }
        }
        if best_v < v_hi * (1.0 - 1e-9) {
            fit_min = Some(best_v);
        }
    }
    // Step 3: drawdown episodes by increasing speed, above v* when there is one.
    let r: Vec<(f64, f64)> = match fit_min {
        Some(vm) => pts.iter().copied().filter(|q| q.0 >= vm).collect(),
        None => pts.clone(),
    };
    let close = |i: usize, j: usize| {
        let drop_n = r[i].1 - r[j].1;
        let fit_change_n = p.magnitude_n(r[j].0) - p.magnitude_n(r[i].0);
        FallingRange {
            from_m_s: r[i].0,
            to_m_s: r[j].0,
            points: j - i + 1,
            drop_n,
            fit_change_n,
            excess_drop_n: drop_n + fit_change_n,
        }
    };
    let mut episodes: Vec<(usize, usize)> = Vec::new();
    let mut peak = 0;
    let mut trough: Option<usize> = None;
    for j in 1..r.len() {
        match trough {
            None => {
                if r[j].1 >= r[peak].1 {
                    peak = j;
                } else if r[peak].1 - r[j].1 > threshold_n {
                    trough = Some(j);
                }
            }
            Some(t) => {
                if r[j].1 < r[t].1 {
                    trough = Some(j);
                } else if r[j].1 - r[t].1 > threshold_n {
                    episodes.push((peak, t));
                    peak = j;
                    trough = None;
                }
            }
        }
    }
    if let Some(t) = trough {
        episodes.push((peak, t));
    }
    // Without an interior minimum of the fit, a first fall from the slowest feeds is the
    // conventional Stribeck fall.
    let mut rising_above_m_s = fit_min.unwrap_or(v_lo);
    if fit_min.is_none() {
        if let Some(&(i, j)) = episodes.first() {
            if i <= 2 || r[i].0 <= p.vs_m_s {
                rising_above_m_s = r[j].0;
                episodes.remove(0);
            }
        }
    }
    let ranges = episodes.into_iter().map(|(i, j)| close(i, j)).collect();
    Ok(NonConventional {
        ranges,
        rising_above_m_s,
        noise_n,
        threshold_n,
    })
}

fn median(x: &mut [f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    x.sort_by(f64::total_cmp);
    let n = x.len();
    if n % 2 == 1 {
        x[n / 2]
    } else {
        0.5 * (x[n / 2 - 1] + x[n / 2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stribeck::fit::tests::{feeds_m_s, set_a, synth};
    use crate::stribeck::{fit_stribeck, StribeckFitParams};

    fn detect(v: &[f64], f: &[f64]) -> NonConventional {
        let fit = fit_stribeck(v, f, &StribeckFitParams::default()).unwrap();
        detect_nonconventional(v, f, &fit, &NonConventionalParams::default()).unwrap()
    }

    /// Clean Stribeck curves with 1 % noise: nothing reported over 30 seeds.
    #[test]
    fn clean_curve_reports_nothing() {
        let v = feeds_m_s();
        for seed in 0..30 {
            let f = synth(&set_a(), &v, 0.01, seed);
            let nc = detect(&v, &f);
            assert!(nc.ranges.is_empty(), "seed {seed}: {nc:?}");
        }
        // noise-free too
        let f = synth(&set_a(), &v, 0.0, 0);
        assert!(detect(&v, &f).ranges.is_empty());
    }

    /// A planted fall of 80 N between 150 and 300 mm/min (σ alone raises friction by 40 N
    /// there) is found at the right feeds and with about the right size, in every seed.
    #[test]
    fn planted_falling_range_is_found() {
        let v = feeds_m_s();
        for seed in 0..20 {
            let mut f = synth(&set_a(), &v, 0.01, seed);
            for (fi, &vi) in f.iter_mut().zip(&v) {
                let mm = vi / M_S_PER_MM_MIN;
                *fi -= 80.0 * ((mm - 150.0) / 150.0).clamp(0.0, 1.0);
            }
            let nc = detect(&v, &f);
            assert_eq!(nc.ranges.len(), 1, "seed {seed}: {nc:?}");
            let r = nc.ranges[0];
            // feeds 146 → 340 mm/min bracket the planted 150-300 (one grid step either side
            // allowed for noise)
            assert!(
                r.from_mm_min() > 100.0 && r.from_mm_min() < 200.0,
                "seed {seed}: {r:?}"
            );
            assert!(
                r.to_mm_min() > 250.0 && r.to_mm_min() < 460.0,
                "seed {seed}: {r:?}"
            );
            // data drop ≈ 80 − σ·Δv ≈ 80 − 16000·(340 − 146)/60000 = 28 N up to noise
            assert!(r.drop_n > 15.0 && r.drop_n < 45.0, "seed {seed}: {r:?}");
        }
    }

    #[test]
    fn bad_settings_are_errors() {
        let v = feeds_m_s();
        let f = synth(&set_a(), &v, 0.0, 0);
        let fit = fit_stribeck(&v, &f, &StribeckFitParams::default()).unwrap();
        let bad = NonConventionalParams {
            k_sigma: 0.0,
            ..Default::default()
        };
        assert!(detect_nonconventional(&v, &f, &fit, &bad).is_err());
        let mut g = f.clone();
        g[2] = f64::NAN;
        assert!(detect_nonconventional(&v, &g, &fit, &Default::default()).is_err());
    }
}
