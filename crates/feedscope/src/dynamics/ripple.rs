//! Torque-ripple harmonics of the servo motor and where they meet a natural frequency.

use serde::{Deserialize, Serialize};

use super::config::RippleParams;
use super::modal::PositionPlan;
use crate::units::feed_mm_min_to_m_s;

/// Torque-ripple harmonic frequency f_T = N_P·P_n·v/(60·p) (Hz), paper Eq. 16, with the feed
/// rate v in mm/min and the lead p in mm (v/(60·p) is the screw speed in rev/s).
///
/// # Reference
/// Paper 001 Eq. 16.
///
/// ```
/// use feedscope::dynamics::ripple_frequency_hz;
/// // 10.8 m/min on a 12 mm lead is 15 rev/s; N_P·P_n = 2·4 = 8 gives 120 Hz.
/// assert!((ripple_frequency_hz(2.0, 4.0, 10_800.0, 12.0) - 120.0).abs() < 1e-12);
/// ```
pub fn ripple_frequency_hz(harmonic: f64, pole_pairs: f64, feed_mm_min: f64, lead_mm: f64) -> f64 {
    harmonic * pole_pairs * feed_mm_min.abs() / (60.0 * lead_mm)
}

/// One resonance risk: a ripple harmonic crosses a natural frequency.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Resonance {
    /// Harmonic coefficient N_P.
    pub harmonic: f64,
    /// Ripple order in cycles per screw revolution, N_P·P_n.
    pub order: f64,
    /// Mode number, 1 = lowest.
    pub mode: usize,
    /// Feed rate where f_T equals the natural frequency (mm/min).
    pub feed_mm_min: f64,
    /// The natural frequency there (Hz).
    pub frequency_hz: f64,
    /// Margin used for the band (Hz).
    pub margin_hz: f64,
    /// Lowest feed rate of the band around the crossing where |f_T − f_n| ≤ margin (mm/min).
    pub feed_low_mm_min: f64,
    /// Highest feed rate of that band (mm/min).
    pub feed_high_mm_min: f64,
}

/// Feed rates where a ripple harmonic meets one of the lowest natural frequencies.
///
/// `feeds_mm_min` (ascending, ≥ 0) and `freqs_hz` (per feed, ascending modes) are a feed sweep
/// computed on `plan`. A crossing is a sign change of d(v) = f_T(v) − f_n(v) between two sweep
/// points; it is refined by bisection on the model itself (60 steps, to round-off) and the band
/// where |d| ≤ margin is walked out along the sweep and its edges bisected likewise. A ripple
/// line that touches a mode without crossing it within the sweep step is not reported: make the
/// sweep fine enough for the margin.
pub fn find_resonances(
    plan: &PositionPlan,
    feeds_mm_min: &[f64],
    freqs_hz: &[Vec<f64>],
    ripple: &RippleParams,
    lead_mm: f64,
) -> Vec<Resonance> {
    let n_modes = freqs_hz.first().map_or(0, Vec::len);
    let mut out = Vec::new();
    for &h in &ripple.harmonics {
        for mode in 0..n_modes {
            let fn_at = |v: f64| plan.frequencies_hz(feed_mm_min_to_m_s(v), mode + 1)[mode];
            let d = |v: f64| ripple_frequency_hz(h, ripple.pole_pairs, v, lead_mm) - fn_at(v);
            let grid: Vec<f64> = feeds_mm_min
                .iter()
                .zip(freqs_hz)
                .map(|(&v, f)| ripple_frequency_hz(h, ripple.pole_pairs, v, lead_mm) - f[mode])
                .collect();
            for i in 0..grid.len().saturating_sub(1) {
                if (grid[i] < 0.0) == (grid[i + 1] < 0.0) {
                    continue;
                }
                let v = bisect(&d, feeds_mm_min[i], feeds_mm_min[i + 1], 0.0);
                let band = |g: f64| g.abs() <= ripple.margin_hz;
                // walk left
                let mut j = i;
                while j > 0 && band(grid[j]) {
                    j -= 1;
                }
                let low = if band(grid[j]) {
                    feeds_mm_min[j]
                } else {
                    let inner = if j == i { v } else { feeds_mm_min[j + 1] };
                    edge(&d, feeds_mm_min[j], inner, ripple.margin_hz)
                };
                let mut j = i + 1;
                while j + 1 < grid.len() && band(grid[j]) {
                    j += 1;
                }
                let high = if band(grid[j]) {
                    feeds_mm_min[j]
                } else {
                    let inner = if j == i + 1 { v } else { feeds_mm_min[j - 1] };
                    edge(&d, feeds_mm_min[j], inner, ripple.margin_hz)
                };
                out.push(Resonance {
                    harmonic: h,
                    order: h * ripple.pole_pairs,
                    mode: mode + 1,
                    feed_mm_min: v,
                    frequency_hz: fn_at(v),
                    margin_hz: ripple.margin_hz,
                    feed_low_mm_min: low.min(high),
                    feed_high_mm_min: low.max(high),
                });
            }
        }
    }
    out.sort_by(|a, b| a.feed_mm_min.total_cmp(&b.feed_mm_min));
    out
}

/// Root of d(v) = target between a and b, where d − target changes sign (bisection).
fn bisect(d: &impl Fn(f64) -> f64, mut a: f64, mut b: f64, target: f64) -> f64 {
    let neg_at_a = d(a) - target < 0.0;
    for _ in 0..60 {
        let m = 0.5 * (a + b);
        if (d(m) - target < 0.0) == neg_at_a {
            a = m;
        } else {
            b = m;
        }
    }
    0.5 * (a + b)
}

/// Band edge between `outside` (|d| > margin) and `inside` (|d| ≤ margin).
fn edge(d: &impl Fn(f64) -> f64, outside: f64, inside: f64, margin: f64) -> f64 {
    let g = |v: f64| d(v).abs() - margin;
    let (mut a, mut b) = (inside, outside);
    for _ in 0..60 {
        let m = 0.5 * (a + b);
        if g(m) <= 0.0 {
            a = m;
        } else {
            b = m;
        }
    }
    0.5 * (a + b)
}
