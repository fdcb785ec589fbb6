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

pub use super::piecewise::{
    fit_piecewise, ContinuityDefect, PiecewiseFit, PiecewisePoly, MAX_INTERVAL_ORDER,
};

use serde::{Deserialize, Serialize};

use crate::axis::AxisParams;
use crate::order::{
    analyze_fluctuation, find_peaks, kinematic_orders, FluctuationAnalysis, OrderError, PeakParams,
    SpectrumAnalyzer, SpectrumParams, Window,
};
use super::piecewise::{solve, validate_layout, Layout};
use super::select::{order_cap, select, SelectParams};

pub use crate::stroke::{Direction, StrokeView};

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

/// Minimum number of samples of a stroke.
pub const MIN_POINTS: usize = 16;

pub(crate) fn check_finite(channel: &'static str, v: &[f64]) -> Result<(), ProfileError> {
    match v.iter().position(|x| !x.is_finite()) {
        Some(index) => Err(ProfileError::NonFinite { channel, index }),
        None => Ok(()),
    }
}

/// A validated stroke in increasing position, u = leads from the start.
struct Prepared {
    x0_mm: f64,
    x1_mm: f64,
    lead_mm: f64,
    /// Leads per sample.
    du: f64,
    u: Vec<f64>,
    y: Vec<f64>,
}

impl Prepared {
    fn to_mm(&self, u: f64) -> f64 {
        self.x0_mm + u * self.lead_mm
    }
    fn to_u(&self, mm: f64) -> f64 {
        (mm - self.x0_mm) / self.lead_mm
    }
}

fn prepare(s: &StrokeView<'_>) -> Result<Prepared, ProfileError> {
    let n = s.position_m.len();
    if n != s.friction_n.len() {
        return Err(ProfileError::LengthMismatch {
            position: n,
            friction: s.friction_n.len(),
        });
    }
    if n < MIN_POINTS {
        return Err(ProfileError::TooFewPoints {
            needed: MIN_POINTS,
            got: n,
        });
    }
    if !(s.lead_m.is_finite() && s.lead_m > 0.0) {
        return Err(ProfileError::InvalidParameter {
            name: "lead_m",
            value: s.lead_m,
            reason: "must be a finite number > 0",
        });
    }
    if s.max_trusted_order.is_nan() || s.max_trusted_order <= 0.0 {
        return Err(ProfileError::InvalidParameter {
            name: "max_trusted_order",
            value: s.max_trusted_order,
            reason: "must be > 0 (infinity means no limit)",
        });
    }
    check_finite("position_m", s.position_m)?;
    check_finite("friction_n", s.friction_n)?;
    let step = (s.position_m[n - 1] - s.position_m[0]) / (n - 1) as f64;
    if step.is_nan() || step == 0.0 {
        return Err(ProfileError::NotMonotonic { index: 1 });
    }
    if let Some(i) = (1..n).find(|&i| (s.position_m[i] - s.position_m[i - 1]) * step <= 0.0) {
        return Err(ProfileError::NotMonotonic { index: i });
    }
    for i in 1..n {
        let d = s.position_m[i] - s.position_m[i - 1];
        if (d - step).abs() > 1e-6 * step.abs() {
            return Err(ProfileError::NonUniformGrid {
                index: i,
                step_m: d,
                expected_m: step,
            });
        }
    }
    let reversed = step < 0.0;
    let mut y = s.friction_n.to_vec();
    let (x0, x1) = if reversed {
        y.reverse();
        (s.position_m[n - 1], s.position_m[0])
    } else {
        (s.position_m[0], s.position_m[n - 1])
    };
    let lead_mm = s.lead_m * 1e3;
    let du = step.abs() / s.lead_m;
    Ok(Prepared {
        x0_mm: x0 * 1e3,
        x1_mm: x1 * 1e3,
        lead_mm,
        du,
        u: (0..n).map(|i| i as f64 * du).collect(),
        y,
    })
}

/// Options of the IAFV fit. Defaults are documented per field; `breaks_mm` / `orders` override
/// the automatic choice.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ProfileParams {
    /// Interior breakpoints (mm, machine coordinates, strictly increasing, strictly inside the
    /// stroke). `None` (default): chosen automatically by BIC.
    pub breaks_mm: Option<Vec<f64>>,
    /// Order per interval (`breaks_mm.len() + 1` values; a single value without `breaks_mm`
    /// fits one polynomial, like the paper's Table 2 choice). `None` (default): by BIC, capped
    /// by `leads_per_order`.
    pub orders: Option<Vec<usize>>,
    /// Highest order of the automatic choice (default 8).
    pub max_order: usize,
    /// Shortest automatic interval in leads (default 4).
    pub min_interval_leads: f64,
    /// Leads of interval length per order of the automatic choice (default 2).
    pub leads_per_order: f64,
    /// Number of equal candidate cells whose edges may become breakpoints (default 32).
    pub candidate_cells: usize,
    /// Fit the dominant fluctuation jointly as sinusoids (default true).
    pub joint_sinusoids: bool,
    /// Lowest order treated as fluctuation in the joint fit (default 0.3 cycles per lead).
    pub fluctuation_min_order: f64,
    /// Most sinusoids in the joint fit (default 16, strongest first).
    pub max_sinusoids: usize,
}

impl Default for ProfileParams {
    fn default() -> Self {
        Self {
            breaks_mm: None,
            orders: None,
            max_order: 8,
            min_interval_leads: 4.0,
            leads_per_order: 2.0,
            candidate_cells: 32,
            joint_sinusoids: true,
            fluctuation_min_order: 0.3,
            max_sinusoids: 16,
        }
    }
}

impl ProfileParams {
    fn validate(&self) -> Result<(), ProfileError> {
        let bad = |name, value: f64, reason| {
            Err(ProfileError::InvalidParameter {
                name,
                value,
                reason,
            })
        };
        if self.max_order > MAX_INTERVAL_ORDER {
            return bad("max_order", self.max_order as f64, "must be <= 20");
        }
        if !(self.min_interval_leads.is_finite() && self.min_interval_leads > 0.0) {
            return bad("min_interval_leads", self.min_interval_leads, "must be > 0");
        }
        if !(self.leads_per_order.is_finite() && self.leads_per_order > 0.0) {
            return bad("leads_per_order", self.leads_per_order, "must be > 0");
        }
        if self.candidate_cells == 0 || self.candidate_cells > 10_000 {
            return bad(
                "candidate_cells",
                self.candidate_cells as f64,
                "must be in 1..=10000",
            );
        }
        if !(self.fluctuation_min_order.is_finite() && self.fluctuation_min_order > 0.0) {
            return bad(
                "fluctuation_min_order",
                self.fluctuation_min_order,
                "must be > 0",
            );
        }
        Ok(())
    }
}

/// Residual standard deviation of one global polynomial order (a row of the paper's Table 2).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OrderScanRow {
    /// Polynomial order m of Eq. 6.
    pub order: usize,
    /// sqrt(RSS / (n − m − 1)) (N).
    pub residual_std_n: f64,
}

/// Residual standard deviation of single-polynomial fits of increasing order (Table 2).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OrderScan {
    /// Direction of the stroke.
    pub direction: Direction,
    /// One row per order 1..=max.
    pub rows: Vec<OrderScanRow>,
    /// Order with the lowest residual standard deviation (the paper's criterion).
    pub best_order: usize,
}

/// Residual standard deviation of least-squares polynomials of orders 1..=`max_order` over the
/// whole stroke (Eq. 6, Table 2), by orthogonal polynomials on the samples (Forsythe).
///
/// # Errors
/// The input errors of [`fit_iafv`]; [`ProfileError::InvalidParameter`] for `max_order` 0 or
/// above 20.
pub fn order_scan(stroke: &StrokeView<'_>, max_order: usize) -> Result<OrderScan, ProfileError> {
    if max_order == 0 || max_order > MAX_INTERVAL_ORDER {
        return Err(ProfileError::InvalidParameter {
            name: "max_order",
            value: max_order as f64,
            reason: "must be in 1..=20",
        });
    }
    let p = prepare(stroke)?;
    let n = p.y.len();
    let top = max_order.min(n - 2);
    let rss = super::lsq::forsythe_rss(&p.u, &p.y, None, top);
    let rows: Vec<OrderScanRow> = (1..=top)
        .map(|m| OrderScanRow {
            order: m,
            residual_std_n: (rss[m] / (n - m - 1) as f64).sqrt(),
        })
        .collect();
    let best_order = rows
        .iter()
        .min_by(|a, b| a.residual_std_n.total_cmp(&b.residual_std_n))
        .map_or(1, |r| r.order);
    Ok(OrderScan {
        direction: stroke.direction,
        rows,
        best_order,
    })
}

/// One row of [`OrderScanTable`]: mean residual standard deviation per direction.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OrderScanTableRow {
    /// Polynomial order m of Eq. 6.
    pub order: usize,
    /// Mean over the forward strokes (N), `None` without forward strokes.
    pub forward_std_n: Option<f64>,
    /// Mean over the backward strokes (N), `None` without backward strokes.
    pub backward_std_n: Option<f64>,
}

/// The paper's Table 2: average residual standard deviation of single polynomials of orders
/// 1..=max per feed direction.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OrderScanTable {
    /// One row per order.
    pub rows: Vec<OrderScanTableRow>,
    /// Forward strokes averaged.
    pub forward_strokes: usize,
    /// Backward strokes averaged.
    pub backward_strokes: usize,
    /// Order of the lowest forward mean, if any.
    pub best_order_forward: Option<usize>,
    /// Order of the lowest backward mean, if any.
    pub best_order_backward: Option<usize>,
}

/// Table 2 over several strokes: [`order_scan`] of each, averaged per direction.
///
/// # Errors
/// The first error of [`order_scan`] on any stroke.
pub fn order_scan_table(
    strokes: &[StrokeView<'_>],
    max_order: usize,
) -> Result<OrderScanTable, ProfileError> {
    let scans = strokes
        .iter()
        .map(|s| order_scan(s, max_order))
        .collect::<Result<Vec<_>, _>>()?;
    let mean = |dir: Direction, order: usize| -> Option<f64> {
        let v: Vec<f64> = scans
            .iter()
            .filter(|s| s.direction == dir)
            .filter_map(|s| s.rows.iter().find(|r| r.order == order))
            .map(|r| r.residual_std_n)
            .collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    let rows: Vec<OrderScanTableRow> = (1..=max_order)
        .map(|m| OrderScanTableRow {
            order: m,
            forward_std_n: mean(Direction::Forward, m),
            backward_std_n: mean(Direction::Backward, m),
        })
        .filter(|r| r.forward_std_n.is_some() || r.backward_std_n.is_some())
        .collect();
    let best = |f: fn(&OrderScanTableRow) -> Option<f64>| {
        rows.iter()
            .filter_map(|r| f(r).map(|v| (v, r.order)))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .map(|(_, o)| o)
    };
    Ok(OrderScanTable {
        best_order_forward: best(|r| r.forward_std_n),
        best_order_backward: best(|r| r.backward_std_n),
        forward_strokes: scans
            .iter()
            .filter(|s| s.direction == Direction::Forward)
            .count(),
        backward_strokes: scans
            .iter()
            .filter(|s| s.direction == Direction::Backward)
            .count(),
        rows,
    })
}

/// Straight-line least-squares fit over the stroke: the paper's linear IAFV trend (Fig. 7,
/// dashed), attributed to the torsional stiffness of the screw segment between motor and nut.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LinearTrend {
    /// Slope (N per mm of position).
    pub slope_n_per_mm: f64,
    /// Stroke start (mm).
    pub start_mm: f64,
    /// Stroke end (mm).
    pub end_mm: f64,
    /// Trend value at the start (N).
    pub value_at_start_n: f64,
    /// Trend value at the end (N).
    pub value_at_end_n: f64,
    /// Residual standard deviation about the line (N).
    pub residual_std_n: f64,
}

fn linear_trend(p: &Prepared) -> (LinearTrend, f64, f64) {
    let n = p.y.len() as f64;
    let um = p.u.iter().sum::<f64>() / n;
    let ym = p.y.iter().sum::<f64>() / n;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (u, y) in p.u.iter().zip(&p.y) {
        sxy += (u - um) * (y - ym);
        sxx += (u - um) * (u - um);
    }
    let b = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    let a = ym - b * um;
    let rss: f64 =
        p.u.iter()
            .zip(&p.y)
            .map(|(u, y)| (y - a - b * u).powi(2))
            .sum();
    let uend = p.u[p.u.len() - 1];
    (
        LinearTrend {
            slope_n_per_mm: b / p.lead_mm,
            start_mm: p.x0_mm,
            end_mm: p.x1_mm,
            value_at_start_n: a,
            value_at_end_n: a + b * uend,
            residual_std_n: (rss / (n - 2.0).max(1.0)).sqrt(),
        },
        a,
        b,
    )
}

/// How the IAFV layout was chosen.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LayoutSelection {
    /// `true` when breakpoints (and orders) were chosen automatically.
    pub automatic: bool,
    /// The rule in words.
    pub rule: String,
    /// BIC of the chosen partition (automatic breakpoints only).
    pub bic: Option<f64>,
    /// Per-sample noise σ (N) used by the BIC (automatic choices only).
    pub noise_sigma_n: Option<f64>,
    /// Candidate intervals evaluated.
    pub intervals_evaluated: usize,
}

/// A fluctuation component fitted jointly with the IAFV (kept in the FFS).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct NuisanceSinusoid {
    /// Order (cycles per lead).
    pub order: f64,
    /// Amplitude (N) from the joint fit.
    pub amplitude_n: f64,
}

/// The fitted IAFV of one stroke.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IafvFit {
    /// Direction of the stroke.
    pub direction: Direction,
    /// The IAFV: C¹ piecewise polynomial (Eq. 6 per interval).
    pub poly: PiecewisePoly,
    /// Straight-line trend over the stroke.
    pub linear: LinearTrend,
    /// How breakpoints and orders were chosen.
    pub selection: LayoutSelection,
    /// Sinusoids fitted jointly (empty if disabled or none significant).
    pub nuisance_sinusoids: Vec<NuisanceSinusoid>,
    /// Residual standard deviation (N) of friction − IAFV − sinusoids, estimated on the block
    /// means scaled to one sample.
    pub residual_std_n: f64,
    /// Samples per block of the final fit.
    pub block_size: usize,
    /// Conditioning indicator of the final least-squares problem.
    pub condition_estimate: f64,
    /// Relative continuity defects at the breakpoints (should be at rounding level).
    pub continuity: Vec<ContinuityDefect>,
}

impl IafvFit {
    /// IAFV (N) at each of `position_m`.
    pub fn evaluate(&self, position_m: &[f64]) -> Vec<f64> {
        position_m.iter().map(|&x| self.poly.value_n(x)).collect()
    }
}

/// Fit the IAFV of one stroke (see the module docs for the method).
///
/// # Reference
/// Paper 000, Eq. 6, Table 2, Figs 6-7 (section 4.1.1).
///
/// # Errors
/// [`ProfileError::LengthMismatch`], [`ProfileError::TooFewPoints`] (< 16),
/// [`ProfileError::NonFinite`], [`ProfileError::NotMonotonic`],
/// [`ProfileError::NonUniformGrid`], [`ProfileError::InvalidParameter`] on bad input;
/// breakpoint/order errors for bad overrides; [`ProfileError::RankDeficient`] if the data
/// cannot determine the layout's coefficients.
pub fn fit_iafv(
    stroke: &StrokeView<'_>,
    params: &ProfileParams,
    analyzer: &mut SpectrumAnalyzer,
) -> Result<IafvFit, ProfileError> {
    params.validate()?;
    let p = prepare(stroke)?;
    let n = p.y.len();
    let (linear, a, b) = linear_trend(&p);
    let u_end = p.u[n - 1];

    // Fine blocks for the final fit (≈ 2048 block means).
    let fine_block = n.div_ceil(2048).max(1);
    // Dominant fluctuation: peaks of the detrended friction's spectrum.
    let mut nuisance: Vec<(f64, f64, f64)> = Vec::new();
    if params.joint_sinusoids && params.max_sinusoids > 0 {
        let r0: Vec<f64> = p.u.iter().zip(&p.y).map(|(u, y)| y - a - b * u).collect();
        let mut amp = Vec::new();
        analyzer.amplitude_spectrum(&r0, Window::Hann, &mut amp)?;
        let pk = PeakParams {
            min_order: params.fluctuation_min_order,
            ..PeakParams::default()
        };
        // Orders whose block means are attenuated by more than ~10 % carry no leakage risk.
        let max_order = 0.25 / (fine_block as f64 * p.du);
        let mut peaks: Vec<_> = find_peaks(analyzer, Window::Hann, &r0, &amp, p.du, &pk)
            .into_iter()
            .filter(|q| q.order <= stroke.max_trusted_order && q.order <= max_order)
            .collect();
        peaks.sort_by(|x, y| y.amplitude_n.total_cmp(&x.amplitude_n));
        peaks.truncate(params.max_sinusoids);
        nuisance = peaks.iter().map(|q| (q.order, q.cos_n, q.sin_n)).collect();
    }
    let sp = SelectParams {
        cells: params.candidate_cells,
        min_interval_leads: params.min_interval_leads,
        leads_per_order: params.leads_per_order,
        max_order: params.max_order,
    };
    // Selection data: ≈ 256 block means with the estimated sinusoids removed.
    let selection_data = || {
        let block = n.div_ceil(256).max(1);
        let nb = n.div_ceil(block);
        let mut uc = Vec::with_capacity(nb);
        let mut r = Vec::with_capacity(nb);
        let mut w = Vec::with_capacity(nb);
        for bi in 0..nb {
            let (lo, hi) = (bi * block, ((bi + 1) * block).min(n));
            let cnt = (hi - lo) as f64;
            let centre = 0.5 * (p.u[lo] + p.u[hi - 1]);
            let mut mean = p.y[lo..hi].iter().sum::<f64>() / cnt;
            for &(f, c, s) in &nuisance {
                let half = std::f64::consts::PI * f * p.du;
                let dir = if cnt > 1.0 && half.sin().abs() > 1e-12 {
                    (cnt * half).sin() / (cnt * half.sin())
                } else {
                    1.0
                };
                let (sn, cs) = (2.0 * std::f64::consts::PI * f * centre).sin_cos();
                mean -= dir * (c * cs + s * sn);
            }
            uc.push(centre);
            r.push(mean);
            w.push(cnt);
        }
        (uc, r, w)
    };
    let (breaks, orders, selection) = match (&params.breaks_mm, &params.orders) {
        (None, None) => {
            let (uc, r, w) = selection_data();
            let s = select(&uc, &r, &w, 0.0, u_end, n, &sp);
            let mut breaks = vec![0.0];
            breaks.extend_from_slice(&s.interior_breaks);
            breaks.push(u_end);
            let sel = LayoutSelection {
                automatic: true,
                rule: format!(
                    "exact DP minimising BIC = sum(RSS_k/sigma^2 + (m_k+1) ln n) + (K-1) ln n over \
                     breakpoints on {} equal cells, intervals >= {} leads, order <= min({}, \
                     floor(len_leads / {}))",
                    sp.cells, sp.min_interval_leads, sp.max_order, sp.leads_per_order
                ),
                bic: Some(s.bic),
                noise_sigma_n: Some(s.sigma),
                intervals_evaluated: s.intervals_evaluated,
            };
            (breaks, s.orders, sel)
        }
        (bk, ord) => {
            let interior: Vec<f64> = bk
                .as_deref()
                .unwrap_or(&[])
                .iter()
                .map(|&m| p.to_u(m))
                .collect();
            let user_orders = ord.clone();
            let provisional: Vec<usize> = user_orders
                .clone()
                .unwrap_or_else(|| vec![0; interior.len() + 1]);
            let breaks = validate_layout(&p.u, &interior, &provisional, |u| p.to_mm(u))?;
            match user_orders {
                Some(o) => (
                    breaks,
                    o,
                    LayoutSelection {
                        automatic: false,
                        rule: "user breakpoints and orders".into(),
                        bic: None,
                        noise_sigma_n: None,
                        intervals_evaluated: 0,
                    },
                ),
                None => {
                    // Orders by the same BIC, interval by interval.
                    let (uc, r, w) = selection_data();
                    let mut orders = Vec::new();
                    let mut sigma = 0.0;
                    for win in breaks.windows(2) {
                        let lo = uc.partition_point(|&v| v < win[0]);
                        let hi = uc.partition_point(|&v| v < win[1]).max(lo);
                        let s = select(
                            &uc[lo..hi],
                            &r[lo..hi],
                            &w[lo..hi],
                            win[0],
                            win[1],
                            n,
                            &SelectParams {
                                cells: 1,
                                ..sp.clone()
                            },
                        );
                        sigma = s.sigma;
                        orders.push(
                            s.orders
                                .first()
                                .copied()
                                .unwrap_or(0)
                                .min(order_cap(win[1] - win[0], &sp)),
                        );
                    }
                    (
                        breaks,
                        orders,
                        LayoutSelection {
                            automatic: true,
                            rule: "user breakpoints; order per interval by BIC (RSS/sigma^2 + (m+1) ln n)".into(),
                            bic: None,
                            noise_sigma_n: Some(sigma),
                            intervals_evaluated: 0,
                        },
                    )
                }
            }
        }
    };
    // Every interval needs enough block means for its order.
    let mut block = fine_block;
    for (k, m) in orders.iter().enumerate() {
        let pts = (((breaks[k + 1] - breaks[k]) / p.du).floor() as usize).max(1);
        block = block.min((pts / (2 * (m + 1) + 2)).max(1));
    }
    let layout = Layout::new(breaks, orders);
    let sin_orders: Vec<f64> = nuisance.iter().map(|q| q.0).collect();
    let sol = match solve(&layout, &p.u, &p.y, block, &sin_orders) {
        Ok(s) => s,
        Err(ProfileError::RankDeficient { .. }) if !sin_orders.is_empty() => {
            solve(&layout, &p.u, &p.y, block, &[])?
        }
        Err(e) => return Err(e),
    };
    let poly = layout.to_poly(&sol.coef, |u| p.to_mm(u));
    let nb = n.div_ceil(block);
    let dof = nb.saturating_sub(sol.free_parameters).max(1);
    let nuisance_sinusoids = sin_orders
        .iter()
        .zip(&sol.sinusoids)
        .map(|(&order, (c, s))| NuisanceSinusoid {
            order,
            amplitude_n: c.hypot(*s),
        })
        .collect();
    Ok(IafvFit {
        direction: stroke.direction,
        continuity: poly.continuity_defects(),
        poly,
        linear,
        selection,
        nuisance_sinusoids,
        residual_std_n: (sol.rss / dof as f64).sqrt(),
        block_size: block,
        condition_estimate: sol.condition_estimate,
    })
}

/// IAFV and FFS (friction − IAFV) at every sample of the stroke, aligned with its positions.
pub fn iafv_and_ffs(stroke: &StrokeView<'_>, fit: &IafvFit) -> (Vec<f64>, Vec<f64>) {
    let iafv = fit.evaluate(stroke.position_m);
    let ffs = stroke
        .friction_n
        .iter()
        .zip(&iafv)
        .map(|(f, m)| f - m)
        .collect();
    (iafv, ffs)
}

/// Options of [`analyze_stroke`].
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AnalysisParams {
    /// IAFV fit.
    pub profile: ProfileParams,
    /// Spectra and significant components.
    pub spectrum: SpectrumParams,
    /// Highest order of the Table 2 scan (default 8 when 0).
    pub scan_max_order: usize,
}

/// Everything issue 3 reports for one stroke.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StrokeAnalysis {
    /// Direction of the stroke.
    pub direction: Direction,
    /// Table 2 scan.
    pub order_scan: OrderScan,
    /// The IAFV fit (with the linear trend).
    pub iafv: IafvFit,
    /// IAFV (N) at each sample, aligned with the input positions.
    pub iafv_n: Vec<f64>,
    /// FFS (N) at each sample, aligned with the input positions.
    pub ffs_n: Vec<f64>,
    /// Spectra of the FFS, significant components and their causes.
    pub fluctuation: FluctuationAnalysis,
}

/// Full analysis of one stroke: order scan (Table 2), IAFV fit (automatic or user layout),
/// FFS, segment spectra in screw orders, significant components classified against the axis'
/// kinematic orders (Eq. 7), aliasing guard.
///
/// # Reference
/// Paper 000, section 4.1 (Eq. 6-7, Table 2, Figs 6-10).
///
/// # Errors
/// As [`fit_iafv`] and [`analyze_fluctuation`].
///
/// # Example
/// ```
/// use feedscope::axis::{AxisParams, ConfigFormat};
/// use feedscope::order::SpectrumAnalyzer;
/// use feedscope::profile::{analyze_stroke, AnalysisParams, Direction, StrokeView};
/// let axis = AxisParams::parse(
///     "lead_mm = 10\ntable_mass_kg = 425\ninertia_kgm2 = 0.004\n\
///      damping_nms_per_rad = 0.002\ntorque_constant_nm_per_a = 1.82\n",
///     ConfigFormat::Toml,
///     "axis.toml",
/// )
/// .unwrap();
/// // 200 mm at 256 samples per lead: mean 70 N + a 5 N shaft-1x ripple.
/// let x: Vec<f64> = (0..=20 * 256).map(|i| i as f64 * 0.01 / 256.0).collect();
/// let f: Vec<f64> =
///     x.iter().map(|&p| 70.0 + 5.0 * (2.0 * std::f64::consts::PI * p / 0.01).cos()).collect();
/// let stroke = StrokeView {
///     direction: Direction::Forward,
///     position_m: &x,
///     friction_n: &f,
///     lead_m: 0.01,
///     max_trusted_order: 20.0,
///     feed_mm_min: Some(100.0),
/// };
/// let a = analyze_stroke(&stroke, &axis, &AnalysisParams::default(), &mut SpectrumAnalyzer::new())
///     .unwrap();
/// let c = a.fluctuation.components.iter().find(|c| c.segment == "all").unwrap();
/// assert_eq!(c.cause, "shaft 1x");
/// assert!((c.amplitude_n - 5.0).abs() < 0.05);
/// ```
pub fn analyze_stroke(
    stroke: &StrokeView<'_>,
    axis: &AxisParams,
    params: &AnalysisParams,
    analyzer: &mut SpectrumAnalyzer,
) -> Result<StrokeAnalysis, ProfileError> {
    let scan_max = if params.scan_max_order == 0 {
        8
    } else {
        params.scan_max_order
    };
    let order_scan = order_scan(stroke, scan_max)?;
    let iafv = fit_iafv(stroke, &params.profile, analyzer)?;
    let (iafv_n, ffs_n) = iafv_and_ffs(stroke, &iafv);
    let kin = kinematic_orders(axis);
    let fluctuation = analyze_fluctuation(
        analyzer,
        stroke,
        &ffs_n,
        &iafv.poly.breaks_mm,
        &kin,
        &params.spectrum,
    )?;
    Ok(StrokeAnalysis {
        direction: stroke.direction,
        order_scan,
        iafv,
        iafv_n,
        ffs_n,
        fluctuation,
    })
}

