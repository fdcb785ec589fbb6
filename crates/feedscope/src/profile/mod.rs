//! Position-dependent friction along the travel: the instantaneous average friction value
//! (IAFV, a C¹ piecewise polynomial of the position, paper 000 Eq. 6 and section 4.1.1) and the
//! friction fluctuating signal (FFS = friction − IAFV) whose spectra in screw orders are
//! analysed by [`crate::order`].
//!
//! # Input and conventions
//! One stroke of estimated friction resampled on a uniform position grid (the estimator uses
//! step lead/1024), as a [`StrokeView`]: positions in metres, increasing (forward) or
//! decreasing (backward), friction in newtons signed as in Eq. 5 (positive forward, negative
//! backward). Results give positions in mm (machine coordinates) and forces in N.
//!
//! # How the IAFV is kept from absorbing the fluctuation
//! The FFS contains orders as low as ~0.5 cycles per lead, which leak into any flexible
//! polynomial. Two measures keep the IAFV to the slow mean profile:
//! 1. *Bandwidth limit tied to the lead*: intervals are at least `min_interval_leads` (4) leads
//!    long and an interval of L leads may use at most order ⌊L / `leads_per_order`⌋ (2 leads per
//!    order). A degree-m polynomial over L leads resolves roughly m/(πL) cycles per lead, so the
//!    IAFV cannot follow much above 1/(2π) ≈ 0.16 orders.
//! 2. *Joint fit of the dominant fluctuation*: the significant spectral peaks at orders ≥
//!    `fluctuation_min_order` (0.3) of the linearly detrended friction are fitted jointly with
//!    the piecewise polynomial as global sinusoids (nuisance terms); the IAFV is the polynomial
//!    part only, the sinusoids stay in the FFS.
//!
//! The fit runs on block means of the samples (at most ~2048 blocks, weights = block sizes; the
//! polynomial and sinusoid columns are the exact block means of the basis functions), which
//! leaves the estimate of the smooth part essentially unchanged and makes it cheap.
//!
//! # Example
//! ```
//! use feedscope::profile::{fit_iafv, Direction, ProfileParams, StrokeView};
//! use feedscope::order::SpectrumAnalyzer;
//! let lead_m = 0.01;
//! let x: Vec<f64> = (0..=20 * 256).map(|i| i as f64 * lead_m / 256.0).collect(); // 200 mm
//! let f: Vec<f64> = x
//!     .iter()
//!     .map(|&p| 80.0 + 50.0 * p + 6.0 * (2.0 * std::f64::consts::PI * 3.0 * p / lead_m).sin())
//!     .collect();
//! let stroke = StrokeView {
//!     direction: Direction::Forward,
//!     position_m: &x,
//!     friction_n: &f,
//!     lead_m,
//!     max_trusted_order: 40.0,
//!     feed_mm_min: None,
//! };
//! let fit = fit_iafv(&stroke, &ProfileParams::default(), &mut SpectrumAnalyzer::new()).unwrap();
//! assert!((fit.poly.value_n(0.1) - 85.0).abs() < 0.05);
//! ```
//!
//! # Operations (one file each)
//! - `prepare.rs`: validation of a [`StrokeView`] (uniform, monotonic, finite).
//! - `scan.rs`: the order scan ([`order_scan`], [`order_scan_table`], Table 2).
//! - `iafv.rs`: the IAFV fit ([`fit_iafv`]) and the FFS ([`iafv_and_ffs`]).
//! - `analyze.rs`: all of it for one stroke ([`analyze_stroke`]).
//! - `piecewise.rs`, `select.rs`, `lsq.rs`: the piecewise polynomial, the choice of its
//!   layout, and the least-squares kernels underneath.

mod analyze;
mod iafv;
mod lsq;
mod piecewise;
mod prepare;
mod scan;
mod select;

pub use analyze::{analyze_stroke, AnalysisParams, StrokeAnalysis, DEFAULT_SCAN_MAX_ORDER};
pub use iafv::{
    fit_iafv, iafv_and_ffs, IafvFit, LayoutSelection, LinearTrend, NuisanceSinusoid, ProfileParams,
};
pub use piecewise::{
    fit_piecewise, ContinuityDefect, PiecewiseFit, PiecewisePoly, MAX_INTERVAL_ORDER,
};
pub use prepare::MIN_POINTS;
pub use scan::{
    order_scan, order_scan_table, OrderScan, OrderScanRow, OrderScanTable, OrderScanTableRow,
};

pub use crate::stroke::{Direction, StrokeView};

use crate::order::OrderError;

/// Errors of the profile analysis.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ProfileError {
    /// Not enough samples.
    #[error("too few points: {got}, need at least {needed}")]
    TooFewPoints {
        /// Minimum required.
        needed: usize,
        /// Number given.
        got: usize,
    },
    /// Position and friction differ in length.
    #[error("position has {position} samples but friction has {friction}")]
    LengthMismatch {
        /// Length of the positions.
        position: usize,
        /// Length of the friction.
        friction: usize,
    },
    /// A NaN or infinite value.
    #[error("non-finite value in {channel} at index {index}")]
    NonFinite {
        /// `position_m` or `friction_n`.
        channel: &'static str,
        /// Index of the first offending sample.
        index: usize,
    },
    /// Positions are not strictly monotonic.
    #[error("positions are not strictly monotonic at index {index}")]
    NotMonotonic {
        /// Index of the first offending sample.
        index: usize,
    },
    /// Positions are not on a uniform grid (relative tolerance 1e-6 of the mean step).
    #[error(
        "position grid is not uniform at index {index}: step {step_m} m, mean step {expected_m} m"
    )]
    NonUniformGrid {
        /// Index of the first offending sample.
        index: usize,
        /// Step found (m).
        step_m: f64,
        /// Mean step (m).
        expected_m: f64,
    },
    /// A user breakpoint is not strictly inside the stroke.
    #[error("breakpoint {break_mm} mm lies outside the stroke ({start_mm} .. {end_mm} mm)")]
    BreakpointOutsideStroke {
        /// The breakpoint (mm).
        break_mm: f64,
        /// Stroke start (mm).
        start_mm: f64,
        /// Stroke end (mm).
        end_mm: f64,
    },
    /// User breakpoints are not strictly increasing.
    #[error("breakpoints must be strictly increasing: {previous_mm} mm then {break_mm} mm")]
    BreakpointsUnsorted {
        /// The previous breakpoint (mm).
        previous_mm: f64,
        /// The offending breakpoint (mm).
        break_mm: f64,
    },
    /// Number of orders does not match the number of intervals.
    #[error("{orders} orders given for {intervals} intervals")]
    OrdersMismatch {
        /// Orders given.
        orders: usize,
        /// Intervals defined by the breakpoints.
        intervals: usize,
    },
    /// An interval has too few points for its order (or the order exceeds the maximum, 20).
    #[error(
        "interval {interval} ({start_mm:.3}..{end_mm:.3} mm) has {points} points, too few for order {order} (max order 20)"
    )]
    OrderTooHigh {
        /// Interval index (0-based along increasing position).
        interval: usize,
        /// Order requested.
        order: usize,
        /// Points in the interval.
        points: usize,
        /// Interval start (mm).
        start_mm: f64,
        /// Interval end (mm).
        end_mm: f64,
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
    /// The least-squares problem is rank deficient (the data cannot determine the coefficients).
    #[error("least-squares problem is rank deficient at column {column}")]
    RankDeficient {
        /// First dependent column of the reduced problem.
        column: usize,
    },
    /// Spectral analysis failed.
    #[error(transparent)]
    Spectrum(#[from] OrderError),
}

#[cfg(test)]
mod tests;

impl ProfileError {
    /// As the spectrum's error for [`ProfileError::Spectrum`], else [`crate::ErrorKind::BadInput`]
    /// (the stroke or the parameters do not allow the fit).
    pub fn kind(&self) -> crate::ErrorKind {
        match self {
            ProfileError::Spectrum(e) => e.kind(),
            _ => crate::ErrorKind::BadInput,
        }
    }
}
