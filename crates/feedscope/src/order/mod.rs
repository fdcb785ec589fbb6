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
//!
//! # Operations (one file each)
//! - `spectrum.rs`: windows and the amplitude spectrum, FFT planned once ([`SpectrumAnalyzer`]).
//! - `peaks.rs`: the significance rule ([`PeakParams`]) and the off-bin refinement.
//! - `kinematic.rs`: the drive's kinematic orders ([`kinematic_orders`], Eq. 7) and
//!   [`classify`].
//! - `fluctuation.rs`: segments, spectra and classified components of one stroke
//!   ([`analyze_fluctuation`]).

mod fluctuation;
mod kinematic;
mod peaks;
mod spectrum;

pub use crate::label::{Cause, LabelError, Segment};
pub use fluctuation::{
    analyze_fluctuation, segment_bounds, FluctuationAnalysis, SegmentSpec, SignificantComponent,
    Spectrum, SpectrumGrid, SpectrumParams, MAX_SEGMENTS, SEGMENT_CAUSE_MIN_LEADS,
};
pub use kinematic::{classify, kinematic_orders, KinematicOrder};
pub(crate) use peaks::find_peaks;
pub use peaks::PeakParams;
pub use spectrum::{SpectrumAnalyzer, Window};

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

#[cfg(test)]
mod tests;

impl OrderError {
    /// [`crate::ErrorKind::Internal`] for a failure of the FFT library, else
    /// [`crate::ErrorKind::BadInput`] (too few or non-finite samples, an invalid parameter).
    pub fn kind(&self) -> crate::ErrorKind {
        match self {
            OrderError::Fft(_) => crate::ErrorKind::Internal,
            _ => crate::ErrorKind::BadInput,
        }
    }
}
