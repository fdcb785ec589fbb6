//! Significant peaks of an amplitude spectrum: a local noise floor, the significance rule of
//! [`PeakParams`], and the off-bin refinement of order and amplitude.

use serde::{Deserialize, Serialize};

use super::spectrum::{dtft, SpectrumAnalyzer, Window};
use super::OrderError;

/// Rule for significant components of an amplitude spectrum.
///
/// A bin is a candidate when it is a local maximum at order ≥ `min_order` (and bin ≥ 2). Its
/// noise floor is 1.55 × the lower quartile of the amplitudes over ±max(`floor_min_bins`,
/// `floor_half_width_orders` / resolution) bins (the median for pure noise, whose amplitudes are
/// Rayleigh distributed, but robust while up to 3/4 of the window holds peaks). It is significant when its refined amplitude is ≥ `noise_floor_factor` ×
/// floor and ≥ `min_amplitude_n`, and it is not a window sidelobe of a stronger peak (Hann:
/// within 4 bins and below 5 % of it). Order and amplitude are refined off-bin by the window's
/// closed-form bin interpolation followed by an exact windowed DTFT at the refined order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PeakParams {
    /// Significance factor k over the local median floor (default 4).
    pub noise_floor_factor: f64,
    /// Half-width of the median window in orders (default 1.0).
    pub floor_half_width_orders: f64,
    /// Minimum half-width of the median window in bins (default 8).
    pub floor_min_bins: usize,
    /// Absolute minimum amplitude (N) of a significant component (default 0.5).
    pub min_amplitude_n: f64,
    /// Lowest order considered (default 0.3; slower variation belongs to the IAFV).
    pub min_order: f64,
}

impl Default for PeakParams {
    fn default() -> Self {
        Self {
            noise_floor_factor: 4.0,
            floor_half_width_orders: 1.0,
            floor_min_bins: 8,
            min_amplitude_n: 0.5,
            min_order: 0.3,
        }
    }
}

impl PeakParams {
    pub(super) fn validate(&self) -> Result<(), OrderError> {
        let bad = |name, value: f64, reason| {
            Err(OrderError::InvalidParameter {
                name,
                value,
                reason,
            })
        };
        if !(self.noise_floor_factor.is_finite() && self.noise_floor_factor > 0.0) {
            return bad("noise_floor_factor", self.noise_floor_factor, "must be > 0");
        }
        if !(self.floor_half_width_orders.is_finite() && self.floor_half_width_orders >= 0.0) {
            return bad(
                "floor_half_width_orders",
                self.floor_half_width_orders,
                "must be >= 0",
            );
        }
        if !(self.min_amplitude_n.is_finite() && self.min_amplitude_n >= 0.0) {
            return bad("min_amplitude_n", self.min_amplitude_n, "must be >= 0");
        }
        if !(self.min_order.is_finite() && self.min_order >= 0.0) {
            return bad("min_order", self.min_order, "must be >= 0");
        }
        Ok(())
    }
}

/// Median / lower quartile of a Rayleigh distribution: sqrt(ln 2 / ln(4/3)).
const RAYLEIGH_MEDIAN_OVER_QUARTILE: f64 = 1.552_281_9;

/// A refined spectral peak (internal form, with phase).
#[derive(Debug, Clone, Copy)]
pub(crate) struct RawPeak {
    pub order: f64,
    pub amplitude_n: f64,
    pub floor_n: f64,
    /// a, b of a·cos(2π order u) + b·sin(2π order u), u in leads from the first sample.
    pub cos_n: f64,
    pub sin_n: f64,
}

/// Find significant peaks (see [`PeakParams`]) in `amplitude` computed by `analyzer` from
/// `samples` (spacing `du` leads) with the analyzer's current window.
pub(crate) fn find_peaks(
    analyzer: &SpectrumAnalyzer,
    window: Window,
    samples: &[f64],
    amplitude: &[f64],
    du: f64,
    params: &PeakParams,
) -> Vec<RawPeak> {
    let n = samples.len();
    let nb = amplitude.len();
    if nb < 5 || du.is_nan() || du <= 0.0 {
        return Vec::new();
    }
    let w = analyzer.window_coefficients();
    if w.len() != n {
        return Vec::new();
    }
    let wsum: f64 = w.iter().sum();
    let res = 1.0 / (n as f64 * du);
    let kmin = ((params.min_order / res).ceil() as usize).max(2);
    let half = ((params.floor_half_width_orders / res).ceil() as usize).max(params.floor_min_bins);
    let mut cands: Vec<(usize, RawPeak)> = Vec::new();
    let mut buf = Vec::new();
    for k in kmin..nb - 1 {
        let a = amplitude[k];
        if !(a >= amplitude[k - 1] && a > amplitude[k + 1]) || a < 0.7 * params.min_amplitude_n {
            continue;
        }
        let (lo, hi) = (k.saturating_sub(half), (k + half + 1).min(nb));
        buf.clear();
        buf.extend_from_slice(&amplitude[lo..hi]);
        // Robust local floor: 1.55 × lower quartile. For noise alone (Rayleigh amplitudes) this
        // equals the median, but it stays at the noise level while up to 3/4 of the window is
        // occupied by peaks (the crowded shaft orders 0.5-4 in a short segment).
        let q = buf.len() / 4;
        let floor =
            RAYLEIGH_MEDIAN_OVER_QUARTILE * *buf.select_nth_unstable_by(q, |x, y| x.total_cmp(y)).1;
        // Cheap pre-test on the bin amplitude (worst-case scalloping loss of the window) so the
        // O(N) DTFT runs only for plausible peaks, even in very noisy spectra.
        if a < window.worst_scalloping() * params.noise_floor_factor * floor {
            continue;
        }
        let (left, right) = (amplitude[k - 1], amplitude[k + 1]);
        let delta = if right >= left {
            window.bin_offset(right / a)
        } else {
            -window.bin_offset(left / a)
        };
        let order = (k as f64 + delta) * res;
        let x = dtft(samples, w, order * du);
        let amp = 2.0 * x.norm() / wsum;
        if amp < params.noise_floor_factor * floor || amp < params.min_amplitude_n {
            continue;
        }
        // X ≈ (A/2)Σw·e^{iφ} for A·cos(2π f u + φ): a = A cos φ, b = −A sin φ.
        let z = x * (2.0 / wsum);
        cands.push((
            k,
            RawPeak {
                order,
                amplitude_n: amp,
                floor_n: floor,
                cos_n: z.re,
                sin_n: -z.im,
            },
        ));
    }
    cands.sort_by(|a, b| b.1.amplitude_n.total_cmp(&a.1.amplitude_n));
    let (mask_bins, mask_ratio) = window.sidelobe_mask();
    let mut kept: Vec<(usize, RawPeak)> = Vec::new();
    for (k, p) in cands {
        let masked = kept.iter().any(|(kk, q)| {
            (*kk as f64 - k as f64).abs() <= mask_bins && p.amplitude_n < mask_ratio * q.amplitude_n
        });
        if !masked {
            kept.push((k, p));
        }
    }
    let mut out: Vec<RawPeak> = kept.into_iter().map(|(_, p)| p).collect();
    out.sort_by(|a, b| a.order.total_cmp(&b.order));
    out
}
