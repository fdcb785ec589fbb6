//! Spectra of the friction fluctuating signal (FFS) in screw orders, the drive's kinematic
//! orders, and the classification of significant components by cause (paper 000,
//! section 4.1.2, Eq. 7, Figs 9-10).
//!
//! # Conventions
//! - **Order** = cycles per screw revolution = cycles per lead of table travel. A signal
//!   sampled every Δu leads over N samples has bins at k/(N·Δu) orders; the *order
//!   resolution* is 1 / (segment length in leads).
//! - **Amplitude spectrum** (single-sided, newtons): with window w_n and
//!   X_k = Σ_n w_n x_n e^{−2πi kn/N}, `amplitude_n[k] = 2|X_k| / Σ_n w_n` for 0 < k < N/2 and
//!   `|X_k| / Σ_n w_n` at k = 0 and k = N/2. A sinusoid A·cos on a bin reads exactly A
//!   (coherent-gain correction). The Hann window is the periodic (DFT-even) one,
//!   w_n = ½ − ½cos(2πn/N), coherent gain ½, equivalent noise bandwidth 1.5 bins.
//! - The mean of each segment is removed before windowing (it belongs to the IAFV).

use std::sync::Arc;

use realfft::{RealFftPlanner, RealToComplex};
use rustfft::num_complex::Complex;
use serde::{Deserialize, Serialize};

use crate::axis::AxisParams;
use crate::stroke::StrokeView;

/// Errors of the spectral analysis.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum OrderError {
    /// A spectrum needs at least `needed` samples.
    #[error("too few samples for a spectrum: {got}, need at least {needed}")]
    TooFewSamples {
        /// Minimum number of samples.
        needed: usize,
        /// Number given.
        got: usize,
    },
    /// A sample is NaN or infinite.
    #[error("non-finite sample at index {index}")]
    NonFinite {
        /// Index of the first offending sample.
        index: usize,
    },
    /// Two inputs that must have the same length do not.
    #[error("length mismatch: {what} has {got} values, expected {expected}")]
    LengthMismatch {
        /// Which input.
        what: &'static str,
        /// Its length.
        got: usize,
        /// The length required.
        expected: usize,
    },
    /// A parameter is out of range.
    #[error("parameter `{name}` = {value}: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Value given.
        value: f64,
        /// Why it is rejected.
        reason: &'static str,
    },
    /// The FFT backend refused the buffers (a bug; reported instead of panicking).
    #[error("FFT failed: {0}")]
    Fft(String),
}

/// Window applied before the FFT.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Window {
    /// Periodic Hann window ½ − ½cos(2πn/N) (default): sidelobes −31 dB, falling 18 dB/octave.
    #[default]
    Hann,
    /// No window (w_n = 1): exact Parseval, high leakage.
    Rectangular,
}

impl Window {
    /// The N window coefficients.
    pub fn coefficients(self, n: usize) -> Vec<f64> {
        match self {
            Self::Hann => (0..n)
                .map(|i| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos())
                .collect(),
            Self::Rectangular => vec![1.0; n],
        }
    }

    /// Coherent gain Σw/N (½ for Hann, 1 for rectangular).
    pub fn coherent_gain(self) -> f64 {
        match self {
            Self::Hann => 0.5,
            Self::Rectangular => 1.0,
        }
    }

    /// Equivalent noise bandwidth in bins (1.5 for Hann, 1 for rectangular).
    pub fn enbw_bins(self) -> f64 {
        match self {
            Self::Hann => 1.5,
            Self::Rectangular => 1.0,
        }
    }

    /// Offset δ ∈ [0, ½] of a single tone from the peak bin towards the larger neighbour, from
    /// the ratio ρ = |X_{k±1}| / |X_k|: Hann δ = (2ρ − 1)/(ρ + 1) (Grandke), rectangular
    /// δ = ρ/(1 + ρ). Both are exact for one noise-free tone.
    fn bin_offset(self, ratio: f64) -> f64 {
        let d = match self {
            Self::Hann => (2.0 * ratio - 1.0) / (ratio + 1.0),
            Self::Rectangular => ratio / (1.0 + ratio),
        };
        d.clamp(0.0, 0.5)
    }

    /// Smallest on-peak gain of a tone between bins relative to on-bin (Hann 0.849 at ½ bin,
    /// rectangular 0.637), slightly rounded down.
    fn worst_scalloping(self) -> f64 {
        match self {
            Self::Hann => 0.84,
            Self::Rectangular => 0.63,
        }
    }

    /// (bins, ratio): a candidate within `bins` of a stronger peak and weaker than `ratio` times
    /// it is taken for a sidelobe (Hann sidelobes ≤ 2.7 %, rectangular ≤ 22 %).
    fn sidelobe_mask(self) -> (f64, f64) {
        match self {
            Self::Hann => (4.0, 0.05),
            Self::Rectangular => (10.0, 0.25),
        }
    }
}

/// Computes amplitude spectra; holds the FFT plans and buffers (plan once, reuse).
pub struct SpectrumAnalyzer {
    planner: RealFftPlanner<f64>,
    plan: Option<Arc<dyn RealToComplex<f64>>>,
    input: Vec<f64>,
    output: Vec<Complex<f64>>,
    scratch: Vec<Complex<f64>>,
    window: Option<(Window, Vec<f64>, f64)>,
}

impl Default for SpectrumAnalyzer {
    fn default() -> Self {
        Self::new()
    }
}

impl std::fmt::Debug for SpectrumAnalyzer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SpectrumAnalyzer").finish_non_exhaustive()
    }
}

impl SpectrumAnalyzer {
    /// A new analyzer with no plan yet.
    pub fn new() -> Self {
        Self {
            planner: RealFftPlanner::new(),
            plan: None,
            input: Vec::new(),
            output: Vec::new(),
            scratch: Vec::new(),
            window: None,
        }
    }

    fn prepare(&mut self, n: usize, window: Window) {
        if self.plan.as_ref().map(|p| p.len()) != Some(n) {
            let plan = self.planner.plan_fft_forward(n);
            self.input = plan.make_input_vec();
            self.output = plan.make_output_vec();
            self.scratch = plan.make_scratch_vec();
            self.plan = Some(plan);
        }
        let stale = match &self.window {
            Some((w, c, _)) => *w != window || c.len() != n,
            None => true,
        };
        if stale {
            let c = window.coefficients(n);
            let s = c.iter().sum();
            self.window = Some((window, c, s));
        }
    }

    /// Single-sided amplitude spectrum (N) of `samples` with `window` into `amplitude_n`
    /// (N/2 + 1 bins, see the module conventions). Returns the amplitude correction 2/Σw.
    /// The samples are used as given (no mean removal).
    ///
    /// # Errors
    /// [`OrderError::TooFewSamples`] below 4 samples, [`OrderError::NonFinite`].
    pub fn amplitude_spectrum(
        &mut self,
        samples: &[f64],
        window: Window,
        amplitude_n: &mut Vec<f64>,
    ) -> Result<f64, OrderError> {
        let n = samples.len();
        if n < 4 {
            return Err(OrderError::TooFewSamples { needed: 4, got: n });
        }
        if let Some(index) = samples.iter().position(|v| !v.is_finite()) {
            return Err(OrderError::NonFinite { index });
        }
        self.prepare(n, window);
        let (Some(plan), Some((_, w, sum))) = (&self.plan, &self.window) else {
            return Err(OrderError::Fft("no plan".into()));
        };
        for ((dst, s), wi) in self.input.iter_mut().zip(samples).zip(w) {
            *dst = s * wi;
        }
        plan.process_with_scratch(&mut self.input, &mut self.output, &mut self.scratch)
            .map_err(|e| OrderError::Fft(e.to_string()))?;
        let corr = 2.0 / sum;
        amplitude_n.clear();
        amplitude_n.extend(self.output.iter().map(|c| c.norm() * corr));
        amplitude_n[0] *= 0.5;
        if n.is_multiple_of(2) {
            if let Some(last) = amplitude_n.last_mut() {
                *last *= 0.5;
            }
        }
        Ok(corr)
    }

    fn window_coefficients(&self) -> &[f64] {
        self.window.as_ref().map_or(&[], |(_, c, _)| c.as_slice())
    }
}

/// Windowed DTFT Σ w_n x_n e^{−2πi f n} at `f` cycles per sample, by a rotating phasor
/// re-synchronised every 256 samples to bound rounding drift.
fn dtft(samples: &[f64], w: &[f64], f: f64) -> Complex<f64> {
    let step = -2.0 * std::f64::consts::PI * f;
    let rot = Complex::from_polar(1.0, step);
    let mut acc = Complex::new(0.0, 0.0);
    let mut z = Complex::new(1.0, 0.0);
    for (i, (x, wi)) in samples.iter().zip(w).enumerate() {
        if i % 256 == 0 {
            z = Complex::from_polar(1.0, step * i as f64);
        }
        acc += z * (x * wi);
        z *= rot;
    }
    acc
}

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
    fn validate(&self) -> Result<(), OrderError> {
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

/// A kinematic order of the drive and its cause.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct KinematicOrder {
    /// Cycles per lead.
    pub order: f64,
    /// Cause, e.g. `shaft 1x`, `nut ball refeed 2x`, `declared: rolling-tool mark`.
    pub cause: String,
}

/// The kinematic orders of an axis: shaft orders 1-4 (pitch errors), ball refeeding in the nut
/// and in the guides by Eq. 7 with their 2× and 3× harmonics (when the geometry is given), and
/// the user-declared orders.
///
/// # Reference
/// Paper 000, Eq. 7 and section 4.1.2 (groups 1-4 of significant components).
///
/// # Example
/// ```
/// use feedscope::axis::{AxisParams, ConfigFormat};
/// use feedscope::order::kinematic_orders;
/// let axis = AxisParams::parse(
///     "lead_mm = 10\ntable_mass_kg = 425\ninertia_kgm2 = 0.004\n\
///      damping_nms_per_rad = 0.002\ntorque_constant_nm_per_a = 1.82\n\
///      guide_balls_per_raceway = 19\n",
///     ConfigFormat::Toml,
///     "axis.toml",
/// )
/// .unwrap();
/// let k = kinematic_orders(&axis);
/// let g2 = k.iter().find(|k| k.cause == "guide ball refeed 2x").unwrap();
/// assert!((g2.order - 19.0).abs() < 1e-12); // z/2 · 2 with z = 19 (Eq. 7, d → ∞)
/// ```
pub fn kinematic_orders(axis: &AxisParams) -> Vec<KinematicOrder> {
    let mut out: Vec<KinematicOrder> = (1..=4)
        .map(|h| KinematicOrder {
            order: h as f64,
            cause: format!("shaft {h}x"),
        })
        .collect();
    for (base, name) in [
        (axis.nut_refeed_order(), "nut ball refeed"),
        (axis.guide_refeed_order(), "guide ball refeed"),
    ] {
        if let Some(f) = base.filter(|f| f.is_finite() && *f > 0.0) {
            for h in 1..=3 {
                out.push(KinematicOrder {
                    order: f * h as f64,
                    cause: format!("{name} {h}x"),
                });
            }
        }
    }
    for d in &axis.declared_orders {
        out.push(KinematicOrder {
            order: d.order,
            cause: format!("declared: {}", d.cause),
        });
    }
    out
}

/// The kinematic order explaining a component at `order`: the nearest one within
/// tolerance max(`resolution`, `tolerance_fraction` × its order), nearness measured in units of
/// that tolerance. `None` means unexplained.
pub fn classify(
    order: f64,
    resolution: f64,
    tolerance_fraction: f64,
    kinematic: &[KinematicOrder],
) -> Option<&KinematicOrder> {
    kinematic
        .iter()
        .filter_map(|k| {
            let tol = resolution.max(tolerance_fraction * k.order);
            let d = (order - k.order).abs() / tol;
            (d <= 1.0).then_some((d, k))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, k)| k)
}

/// How the travel is split into segments for the spectra.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum SegmentSpec {
    /// Like the paper: each IAFV interval is split into equal segments, n =
    /// max(round(len / target), 2 if len ≥ 2·min else 1), capped so no segment is shorter than
    /// `min_leads` (an interval shorter than that stays whole).
    Auto {
        /// Target segment length in leads (default 5).
        target_leads: f64,
        /// Minimum segment length in leads (default 3).
        min_leads: f64,
    },
    /// `count` equal segments of the whole stroke.
    Count {
        /// Number of segments (≥ 1).
        count: usize,
    },
    /// Equal segments of about `length_mm` over the whole stroke.
    LengthMm {
        /// Segment length (mm).
        length_mm: f64,
    },
}

impl Default for SegmentSpec {
    fn default() -> Self {
        Self::Auto {
            target_leads: 5.0,
            min_leads: 3.0,
        }
    }
}

/// Most segments [`segment_bounds`] returns per interval (and for `count`).
pub const MAX_SEGMENTS: usize = 1000;

/// Segment bounds (mm) for `spec` over [start_mm, end_mm] with IAFV interval ends `breaks_mm`
/// (including both stroke ends).
///
/// # Errors
/// [`OrderError::InvalidParameter`] for a non-positive count, length or target.
pub fn segment_bounds(
    breaks_mm: &[f64],
    lead_mm: f64,
    spec: &SegmentSpec,
) -> Result<Vec<(f64, f64)>, OrderError> {
    let (Some(&start), Some(&end)) = (breaks_mm.first(), breaks_mm.last()) else {
        return Ok(Vec::new());
    };
    let split = |a: f64, b: f64, n: usize| -> Vec<(f64, f64)> {
        (0..n)
            .map(|i| {
                let h = (b - a) / n as f64;
                (a + i as f64 * h, a + (i + 1) as f64 * h)
            })
            .collect()
    };
    match spec {
        SegmentSpec::Count { count } => {
            if *count == 0 || *count > MAX_SEGMENTS {
                return Err(OrderError::InvalidParameter {
                    name: "segments.count",
                    value: *count as f64,
                    reason: "must be in 1..=1000",
                });
            }
            Ok(split(start, end, *count))
        }
        SegmentSpec::LengthMm { length_mm } => {
            if !(length_mm.is_finite() && *length_mm > 0.0) {
                return Err(OrderError::InvalidParameter {
                    name: "segments.length_mm",
                    value: *length_mm,
                    reason: "must be > 0",
                });
            }
            let n = (((end - start) / length_mm).round().max(1.0) as usize).min(MAX_SEGMENTS);
            Ok(split(start, end, n))
        }
        SegmentSpec::Auto {
            target_leads,
            min_leads,
        } => {
            if !(target_leads.is_finite()
                && *target_leads > 0.0
                && min_leads.is_finite()
                && *min_leads > 0.0)
            {
                return Err(OrderError::InvalidParameter {
                    name: "segments.target_leads",
                    value: *target_leads,
                    reason: "target_leads and min_leads must be > 0",
                });
            }
            let mut out = Vec::new();
            for w in breaks_mm.windows(2) {
                let len = (w[1] - w[0]) / lead_mm;
                let mut n = (len / target_leads).round().max(1.0) as usize;
                if len >= 2.0 * min_leads {
                    n = n.max(2);
                }
                n = n
                    .min((len / min_leads).floor().max(1.0) as usize)
                    .min(MAX_SEGMENTS);
                out.extend(split(w[0], w[1], n));
            }
            Ok(out)
        }
    }
}

/// Options of the fluctuation spectra.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SpectrumParams {
    /// Window (default Hann).
    pub window: Window,
    /// Segmentation (default [`SegmentSpec::Auto`]).
    pub segments: SegmentSpec,
    /// Significance rule.
    pub peaks: PeakParams,
    /// Relative tolerance for matching a kinematic order (default 0.03); the tolerance used is
    /// max(order resolution, this × order).
    pub tolerance_fraction: f64,
    /// Spectra are reported up to this order (detection uses the full spectrum; default 64).
    pub report_max_order: f64,
}

impl Default for SpectrumParams {
    fn default() -> Self {
        Self {
            window: Window::Hann,
            segments: SegmentSpec::default(),
            peaks: PeakParams::default(),
            tolerance_fraction: 0.03,
            report_max_order: 64.0,
        }
    }
}

/// Amplitude spectrum of one segment of the FFS.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Spectrum {
    /// Segment label: `all` for the whole stroke, else `1`, `2`, ... along increasing position.
    pub segment: String,
    /// Segment start (mm).
    pub start_mm: f64,
    /// Segment end (mm).
    pub end_mm: f64,
    /// Number of samples.
    pub samples: usize,
    /// Segment length N·Δu in leads.
    pub length_leads: f64,
    /// Bin spacing = order resolution = 1 / `length_leads` (orders).
    pub order_resolution: f64,
    /// Window used.
    pub window: Window,
    /// Amplitude correction applied to |X_k|: 2/Σw (halved at DC and Nyquist).
    pub amplitude_correction: f64,
    /// Segment mean (N) removed before windowing.
    pub mean_removed_n: f64,
    /// Amplitude (N) at orders k · `order_resolution`, k = 0, 1, ...
    pub amplitude_n: Vec<f64>,
}

impl Spectrum {
    /// The order of bin k (cycles per lead).
    pub fn order(&self, k: usize) -> f64 {
        k as f64 * self.order_resolution
    }
}

/// A significant component of a segment's FFS spectrum.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SignificantComponent {
    /// Segment label (`all` or `1`, `2`, ...).
    pub segment: String,
    /// Centre of the segment (mm).
    pub position_mm: f64,
    /// Refined order (cycles per lead).
    pub order: f64,
    /// Refined amplitude (N).
    pub amplitude_n: f64,
    /// Local median noise floor (N).
    pub floor_n: f64,
    /// Cause: a kinematic cause (`shaft 1x`, `nut ball refeed 1x`, ...) or `unexplained`.
    pub cause: String,
    /// The kinematic order matched, if any.
    pub kinematic_order: Option<f64>,
    /// `false` when the order is above the stroke's highest trusted order (possible alias).
    pub trusted: bool,
}

/// Spectra and significant components of one stroke's FFS.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FluctuationAnalysis {
    /// Whole stroke (`all`) first, then the segments.
    pub spectra: Vec<Spectrum>,
    /// Significant components of every spectrum.
    pub components: Vec<SignificantComponent>,
    /// Kinematic orders used for the classification.
    pub kinematic_orders: Vec<KinematicOrder>,
    /// Highest order resolvable without aliasing (raw samples per lead / 2).
    pub max_trusted_order: f64,
    /// The significance rule in words.
    pub noise_floor_rule: String,
    /// Aliasing and other warnings.
    pub warnings: Vec<String>,
}

/// Segment spectra on one order grid, for a heat map of amplitude over order and position.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpectrumGrid {
    /// Orders of the columns (cycles per lead), from 0 in equal steps.
    pub orders: Vec<f64>,
    /// Segment centre of each row (mm), increasing.
    pub position_mm: Vec<f64>,
    /// Amplitude (N), one row per segment; NaN where a segment's spectrum ends.
    pub amplitude_n: Vec<Vec<f64>>,
}

impl FluctuationAnalysis {
    /// The segment spectra (not `all`) on a common order grid from 0 to `max_order`: the
    /// finest segment resolution, but at most `max_columns` columns; each cell takes its
    /// segment's nearest bin. `None` without segments.
    pub fn segment_grid(&self, max_order: f64, max_columns: usize) -> Option<SpectrumGrid> {
        let segs: Vec<&Spectrum> = self
            .spectra
            .iter()
            .filter(|sp| sp.segment != "all")
            .collect();
        if segs.is_empty() || max_order.is_nan() || max_order <= 0.0 {
            return None;
        }
        let step = segs
            .iter()
            .map(|sp| sp.order_resolution)
            .fold(f64::INFINITY, f64::min)
            .max(max_order / max_columns.max(1) as f64);
        let nx = (max_order / step).floor() as usize + 1;
        let orders: Vec<f64> = (0..nx).map(|i| i as f64 * step).collect();
        let mut rows: Vec<(f64, Vec<f64>)> = segs
            .iter()
            .map(|sp| {
                let row = orders
                    .iter()
                    .map(|&o| {
                        let b = (o / sp.order_resolution).round() as usize;
                        sp.amplitude_n.get(b).copied().unwrap_or(f64::NAN)
                    })
                    .collect();
                (0.5 * (sp.start_mm + sp.end_mm), row)
            })
            .collect();
        rows.sort_by(|a, b| a.0.total_cmp(&b.0));
        Some(SpectrumGrid {
            orders,
            position_mm: rows.iter().map(|r| r.0).collect(),
            amplitude_n: rows.into_iter().map(|r| r.1).collect(),
        })
    }
}

/// Spectra of the FFS of a stroke: whole stroke and segments, significant components and
/// their causes, aliasing guard.
///
/// `ffs_n` is aligned with `stroke.position_m` (any direction); `breaks_mm` are the IAFV
/// interval ends (both stroke ends included) used by [`SegmentSpec::Auto`]. The grid must be
/// uniform (as validated by [`crate::profile::fit_iafv`]).
///
/// # Reference
/// Paper 000, section 4.1.2, Figs 9-10, Eq. 7.
///
/// # Errors
/// [`OrderError::LengthMismatch`], [`OrderError::NonFinite`], [`OrderError::TooFewSamples`],
/// [`OrderError::InvalidParameter`].
pub fn analyze_fluctuation(
    analyzer: &mut SpectrumAnalyzer,
    stroke: &StrokeView<'_>,
    ffs_n: &[f64],
    breaks_mm: &[f64],
    kinematic: &[KinematicOrder],
    params: &SpectrumParams,
) -> Result<FluctuationAnalysis, OrderError> {
    let n = stroke.position_m.len();
    if ffs_n.len() != n {
        return Err(OrderError::LengthMismatch {
            what: "ffs_n",
            got: ffs_n.len(),
            expected: n,
        });
    }
    if n < 16 {
        return Err(OrderError::TooFewSamples { needed: 16, got: n });
    }
    if let Some(index) = ffs_n.iter().position(|v| !v.is_finite()) {
        return Err(OrderError::NonFinite { index });
    }
    params.peaks.validate()?;
    if !(params.tolerance_fraction.is_finite() && params.tolerance_fraction >= 0.0) {
        return Err(OrderError::InvalidParameter {
            name: "tolerance_fraction",
            value: params.tolerance_fraction,
            reason: "must be >= 0",
        });
    }
    let lead_mm = stroke.lead_m * 1e3;
    if !(lead_mm.is_finite() && lead_mm > 0.0) {
        return Err(OrderError::InvalidParameter {
            name: "lead_m",
            value: stroke.lead_m,
            reason: "must be > 0",
        });
    }
    let reversed = stroke.position_m[n - 1] < stroke.position_m[0];
    let (x0_mm, x1_mm) = if reversed {
        (stroke.position_m[n - 1] * 1e3, stroke.position_m[0] * 1e3)
    } else {
        (stroke.position_m[0] * 1e3, stroke.position_m[n - 1] * 1e3)
    };
    let mut y = ffs_n.to_vec();
    if reversed {
        y.reverse();
    }
    let dx_mm = (x1_mm - x0_mm) / (n - 1) as f64;
    let du = dx_mm / lead_mm;
    let bounds = if breaks_mm.len() >= 2 {
        segment_bounds(breaks_mm, lead_mm, &params.segments)?
    } else {
        segment_bounds(&[x0_mm, x1_mm], lead_mm, &params.segments)?
    };
    let mut segs: Vec<(String, usize, usize)> = vec![("all".to_string(), 0, n)];
    let mut warnings = Vec::new();
    let mut skipped = Vec::new();
    for (i, (a, b)) in bounds.iter().enumerate() {
        let lo = (((a - x0_mm) / dx_mm).round().max(0.0) as usize).min(n);
        let hi = (((b - x0_mm) / dx_mm).round().max(0.0) as usize + 1).min(n);
        if hi.saturating_sub(lo) < 16 {
            skipped.push((i + 1).to_string());
            continue;
        }
        // Adjacent segments share their boundary sample at most.
        segs.push(((i + 1).to_string(), lo, hi));
    }
    if !skipped.is_empty() {
        warnings.push(format!(
            "{} segment(s) with fewer than 16 samples skipped (first: {})",
            skipped.len(),
            skipped[0]
        ));
    }
    let mut spectra = Vec::new();
    let mut components = Vec::new();
    let mut amp = Vec::new();
    let mut buf = Vec::new();
    for (label, lo, hi) in segs {
        let seg = &y[lo..hi];
        let m = seg.len();
        let mean = seg.iter().sum::<f64>() / m as f64;
        buf.clear();
        buf.extend(seg.iter().map(|v| v - mean));
        let corr = analyzer.amplitude_spectrum(&buf, params.window, &mut amp)?;
        let res = 1.0 / (m as f64 * du);
        let centre = x0_mm + 0.5 * (lo + hi - 1) as f64 * dx_mm;
        for p in find_peaks(analyzer, params.window, &buf, &amp, du, &params.peaks) {
            let k = classify(p.order, res, params.tolerance_fraction, kinematic);
            components.push(SignificantComponent {
                segment: label.clone(),
                position_mm: centre,
                order: p.order,
                amplitude_n: p.amplitude_n,
                floor_n: p.floor_n,
                cause: k.map_or_else(|| "unexplained".to_string(), |k| k.cause.clone()),
                kinematic_order: k.map(|k| k.order),
                trusted: p.order <= stroke.max_trusted_order || stroke.max_trusted_order.is_nan(),
            });
        }
        let keep = ((params.report_max_order / res).floor() as usize + 1).min(amp.len());
        spectra.push(Spectrum {
            segment: label,
            start_mm: x0_mm + lo as f64 * dx_mm,
            end_mm: x0_mm + (hi - 1) as f64 * dx_mm,
            samples: m,
            length_leads: m as f64 * du,
            order_resolution: res,
            window: params.window,
            amplitude_correction: corr,
            mean_removed_n: mean,
            amplitude_n: amp[..keep].to_vec(),
        });
    }
    warnings.extend(aliasing_warnings(stroke, kinematic, &components));
    Ok(FluctuationAnalysis {
        spectra,
        components,
        kinematic_orders: kinematic.to_vec(),
        max_trusted_order: stroke.max_trusted_order,
        noise_floor_rule: format!(
            "local maximum at order >= {} with refined amplitude >= {} x floor (1.55 x lower \
             quartile of the amplitudes over +-max({} bins, {} orders), the median for pure \
             noise) and >= {} N; window sidelobes of stronger peaks rejected",
            params.peaks.min_order,
            params.peaks.noise_floor_factor,
            params.peaks.floor_min_bins,
            params.peaks.floor_half_width_orders,
            params.peaks.min_amplitude_n
        ),
        warnings,
    })
}

/// The aliasing guard: warn when a kinematic order or a detected component lies above the
/// stroke's highest trusted order, and say which feed would resolve the highest kinematic order.
fn aliasing_warnings(
    stroke: &StrokeView<'_>,
    kinematic: &[KinematicOrder],
    components: &[SignificantComponent],
) -> Vec<String> {
    let mut out = Vec::new();
    let limit = stroke.max_trusted_order;
    let highest = kinematic.iter().max_by(|a, b| a.order.total_cmp(&b.order));
    if let Some(h) = highest.filter(|h| h.order > limit) {
        // Samples per lead = sample rate × lead / feed; resolving order f needs 2f per lead.
        let factor = h.order / limit;
        let feed = match stroke.feed_mm_min {
            Some(f) if f.is_finite() && f > 0.0 => {
                format!("feed at most {:.1} mm/min (now {f:.1} mm/min)", f / factor)
            }
            _ => format!("feed at most {:.3} x the present feed", 1.0 / factor),
        };
        out.push(format!(
            "highest kinematic order {:.2} ({}) exceeds the highest trusted order {limit:.2} \
             (raw samples per lead / 2): sample at least {factor:.2} x faster or {feed} so \
             that it is resolved without aliasing",
            h.order, h.cause
        ));
    }
    let untrusted = components.iter().filter(|c| !c.trusted).count();
    if untrusted > 0 {
        out.push(format!(
            "{untrusted} significant component(s) above the trusted order {limit:.2} are flagged \
             trusted = false: they may be aliases of higher orders"
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use std::f64::consts::PI;

    fn dft_amplitude(x: &[f64], w: &[f64]) -> Vec<f64> {
        let n = x.len();
        let sw: f64 = w.iter().sum();
        (0..=n / 2)
            .map(|k| {
                let (mut re, mut im) = (0.0, 0.0);
                for (i, (v, wi)) in x.iter().zip(w).enumerate() {
                    let ph = -2.0 * PI * (k * i % n) as f64 / n as f64;
                    re += v * wi * ph.cos();
                    im += v * wi * ph.sin();
                }
                let edge = k == 0 || (n.is_multiple_of(2) && k == n / 2);
                (re.hypot(im)) * if edge { 1.0 } else { 2.0 } / sw
            })
            .collect()
    }

    #[test]
    fn fft_amplitude_matches_direct_dft() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(42);
        let mut an = SpectrumAnalyzer::new();
        for n in [17usize, 64, 257, 1000] {
            let x: Vec<f64> = (0..n).map(|_| rng.random_range(-5.0..5.0)).collect();
            for win in [Window::Hann, Window::Rectangular] {
                let mut amp = Vec::new();
                an.amplitude_spectrum(&x, win, &mut amp).unwrap();
                let want = dft_amplitude(&x, &win.coefficients(n));
                assert_eq!(amp.len(), want.len());
                for (a, b) in amp.iter().zip(&want) {
                    // Direct DFT rounding grows ~ n·eps·Σ|x|.
                    assert!((a - b).abs() < 1e-10, "n {n} {win:?}: {a} vs {b}");
                }
            }
        }
    }

    #[test]
    fn parseval_holds_for_the_single_sided_amplitudes() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let mut an = SpectrumAnalyzer::new();
        for n in [100usize, 101] {
            let x: Vec<f64> = (0..n).map(|_| rng.random_range(-3.0..3.0)).collect();
            let mut amp = Vec::new();
            an.amplitude_spectrum(&x, Window::Rectangular, &mut amp)
                .unwrap();
            // mean(x²) = A_0² + Σ A_k²/2 + A_{N/2}² (N even).
            let last = amp.len() - 1;
            let mut s = amp[0] * amp[0];
            for (k, a) in amp.iter().enumerate().skip(1) {
                s += if n % 2 == 0 && k == last {
                    a * a
                } else {
                    0.5 * a * a
                };
            }
            let ms = x.iter().map(|v| v * v).sum::<f64>() / n as f64;
            assert!((s - ms).abs() < 1e-12 * ms, "n {n}: {s} vs {ms}");
            // Hann: the same identity for the windowed signal, scaled by (Σw/N)².
            an.amplitude_spectrum(&x, Window::Hann, &mut amp).unwrap();
            let w = Window::Hann.coefficients(n);
            let g = w.iter().sum::<f64>() / n as f64;
            let mut s = amp[0] * amp[0];
            for (k, a) in amp.iter().enumerate().skip(1) {
                s += if n % 2 == 0 && k == last {
                    a * a
                } else {
                    0.5 * a * a
                };
            }
            let ms = x
                .iter()
                .zip(&w)
                .map(|(v, wi)| (v * wi).powi(2))
                .sum::<f64>()
                / n as f64;
            assert!((s * g * g - ms).abs() < 1e-12 * ms, "hann n {n}");
        }
    }

    #[test]
    fn on_bin_sinusoid_reads_its_amplitude_exactly() {
        let n = 4096;
        let mut an = SpectrumAnalyzer::new();
        for (k, a, ph) in [(37usize, 7.5, 0.3), (400, 2.0, 2.0), (3, 11.0, -1.0)] {
            let x: Vec<f64> = (0..n)
                .map(|i| a * (2.0 * PI * (k * i) as f64 / n as f64 + ph).cos())
                .collect();
            let mut amp = Vec::new();
            let corr = an.amplitude_spectrum(&x, Window::Hann, &mut amp).unwrap();
            assert!((corr - 2.0 / (0.5 * n as f64)).abs() < 1e-15);
            // Periodic Hann, coherent gain ½: exact up to rounding.
            assert!((amp[k] - a).abs() < 1e-10 * a, "{} vs {a}", amp[k]);
            // Leakage only into the two neighbours (a/2 each), nothing beyond.
            assert!((amp[k + 1] - 0.5 * a).abs() < 1e-10 * a);
            assert!(amp[k + 3] < 1e-10 * a);
        }
    }

    #[test]
    fn off_bin_peak_refinement_is_accurate() {
        // 40 leads at 256 samples per lead; tones off-bin by up to ½ bin.
        let du = 1.0 / 256.0;
        let n = 40 * 256;
        let mut an = SpectrumAnalyzer::new();
        for (f, a) in [
            (0.6137, 4.0),
            (8.6, 10.0),
            (9.5123, 3.0),
            (19.0, 5.0),
            (2.0125, 6.0),
        ] {
            let x: Vec<f64> = (0..n)
                .map(|i| a * (2.0 * PI * f * i as f64 * du + 0.7).cos())
                .collect();
            let mut amp = Vec::new();
            an.amplitude_spectrum(&x, Window::Hann, &mut amp).unwrap();
            let p = find_peaks(&an, Window::Hann, &x, &amp, du, &PeakParams::default());
            assert_eq!(p.len(), 1, "{f}: {p:?}");
            // Grandke's interpolation is exact for one tone; the negative-frequency image
            // biases it slightly at low orders.
            assert!((p[0].order - f).abs() < 2e-4, "{f}: {}", p[0].order);
            assert!(
                (p[0].amplitude_n - a).abs() < 1e-3 * a,
                "{f}: {}",
                p[0].amplitude_n
            );
        }
    }

    #[test]
    fn segment_bounds_follow_the_paper_layout() {
        let b = segment_bounds(&[0.0, 85.0, 150.0, 410.0], 10.0, &SegmentSpec::default()).unwrap();
        let counts: Vec<usize> = [(0.0, 85.0), (85.0, 150.0), (150.0, 410.0)]
            .iter()
            .map(|(a, c)| b.iter().filter(|s| s.0 >= *a && s.1 <= *c).count())
            .collect();
        assert_eq!(counts, vec![2, 2, 5]);
        let b = segment_bounds(&[0.0, 400.0], 10.0, &SegmentSpec::Count { count: 4 }).unwrap();
        assert_eq!(b.len(), 4);
        assert!((b[3].0 - 300.0).abs() < 1e-12);
        assert!(segment_bounds(&[0.0, 400.0], 10.0, &SegmentSpec::Count { count: 0 }).is_err());
        assert!(segment_bounds(
            &[0.0, 400.0],
            10.0,
            &SegmentSpec::LengthMm {
                length_mm: f64::NAN
            }
        )
        .is_err());
    }

    #[test]
    fn classification_uses_resolution_or_relative_tolerance() {
        let k = vec![
            KinematicOrder {
                order: 1.0,
                cause: "shaft 1x".into(),
            },
            KinematicOrder {
                order: 8.6,
                cause: "nut ball refeed 1x".into(),
            },
            KinematicOrder {
                order: 9.5,
                cause: "guide ball refeed 1x".into(),
            },
        ];
        assert_eq!(classify(1.02, 0.025, 0.03, &k).unwrap().cause, "shaft 1x");
        assert!(classify(1.05, 0.025, 0.03, &k).is_none());
        assert!(classify(1.2, 0.25, 0.03, &k).is_some()); // coarse segment resolution
        assert_eq!(
            classify(8.8, 0.025, 0.03, &k).unwrap().cause,
            "nut ball refeed 1x"
        );
        assert_eq!(
            classify(9.3, 0.025, 0.03, &k).unwrap().cause,
            "guide ball refeed 1x"
        );
        assert!(classify(9.05, 0.025, 0.03, &k).is_none());
    }

    #[test]
    fn spectrum_rejects_bad_samples() {
        let mut an = SpectrumAnalyzer::new();
        let mut amp = Vec::new();
        assert!(matches!(
            an.amplitude_spectrum(&[1.0, 2.0], Window::Hann, &mut amp),
            Err(OrderError::TooFewSamples { .. })
        ));
        assert!(matches!(
            an.amplitude_spectrum(&[1.0, 2.0, f64::INFINITY, 0.0], Window::Hann, &mut amp),
            Err(OrderError::NonFinite { index: 2 })
        ));
    }
}
