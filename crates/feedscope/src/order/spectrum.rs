//! The amplitude spectrum of a uniformly sampled signal: windows and their corrections, and
//! the [`SpectrumAnalyzer`] that plans the FFT once and reuses it (conventions in the
//! [module docs](super)).

use std::sync::Arc;

use realfft::{RealFftPlanner, RealToComplex};
use rustfft::num_complex::Complex;
use serde::{Deserialize, Serialize};

use super::OrderError;

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
    pub(super) fn bin_offset(self, ratio: f64) -> f64 {
        let d = match self {
            Self::Hann => (2.0 * ratio - 1.0) / (ratio + 1.0),
            Self::Rectangular => ratio / (1.0 + ratio),
        };
        d.clamp(0.0, 0.5)
    }

    /// Smallest on-peak gain of a tone between bins relative to on-bin (Hann 0.849 at ½ bin,
    /// rectangular 0.637), slightly rounded down.
    pub(super) fn worst_scalloping(self) -> f64 {
        match self {
            Self::Hann => 0.84,
            Self::Rectangular => 0.63,
        }
    }

    /// (bins, ratio): a candidate within `bins` of a stronger peak and weaker than `ratio` times
    /// it is taken for a sidelobe (Hann sidelobes ≤ 2.7 %, rectangular ≤ 22 %).
    pub(super) fn sidelobe_mask(self) -> (f64, f64) {
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

    pub(super) fn window_coefficients(&self) -> &[f64] {
        self.window.as_ref().map_or(&[], |(_, c, _)| c.as_slice())
    }
}

/// Windowed DTFT Σ w_n x_n e^{−2πi f n} at `f` cycles per sample, by a rotating phasor
/// re-synchronised every 256 samples to bound rounding drift.
pub(super) fn dtft(samples: &[f64], w: &[f64], f: f64) -> Complex<f64> {
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
