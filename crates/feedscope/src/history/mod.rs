//! Condition history: trends of the drive's indicators over many tests, control limits,
//! early warnings and a diagnosis in words.
//!
//! Pure functions on time series of indicator values (time, value, optional standard error):
//! a baseline from the first N tests or a reference test ([`baseline`]), Shewhart limits
//! μ₀ ± L·σ ([`Limits`]), an EWMA chart ([`ewma`]) and a two-sided CUSUM ([`cusum`]) that see a
//! sustained drift before a single test leaves the ±3σ band, a projected crossing of a user
//! threshold from the recent slope ([`project_crossing`]), and [`diagnose()`], which says which
//! indicators moved and what the papers associate with them. [`profile_changes`] compares the
//! friction of stroke tests with their baseline position by position along the travel (local
//! wear). The store that keeps the series lives in the CLI; nothing here does I/O.
//!
//! ```
//! use feedscope::history::{assess, Indicator, Point, TrendParams, Threshold};
//! // static friction: 5 steady weeks, then +6 N a week
//! let week = 7.0 * 86_400.0;
//! let pts: Vec<Point> = (0..12)
//!     .map(|i| {
//!         let drift = if i >= 5 { 6.0 * (i - 4) as f64 } else { 0.0 };
//!         let wobble = [0.8, -1.1, 0.4, -0.3, 0.2][i % 5];
//!         Point { time_s: i as f64 * week, value: 400.0 + wobble + drift, std_error: None }
//!     })
//!     .collect();
//! let th = Threshold { upper: Some(520.0), lower: None };
//! let t = assess(&Indicator::StaticFriction, &pts, &TrendParams::default(), &th).unwrap();
//! assert!(t.ewma.first_alarm.unwrap() < 9); // early: the raw value is still far below 520 N
//! // at 6 N a week from about 441 N, 520 N is (520 − 441)/6 ≈ 13 weeks away
//! let weeks = t.projection.unwrap().days / 7.0;
//! assert!((weeks - 13.0).abs() < 1.0, "{weeks}");
//! ```
use serde::{Deserialize, Serialize};

mod control;
mod diagnose;
mod local;
#[cfg(test)]
mod tests;

pub use control::{
    baseline, cusum, ewma, ewma_around_estimate, family_limit_width, project_crossing,
    recent_slope, Baseline, BaselineSpec, Cusum, Ewma, Limits, Projection, RecentSlope, Threshold,
    MAX_ABS_THRESHOLD,
};
pub use diagnose::{diagnose, diagnose_with_profiles};
pub use local::{
    describe_baseline, profile_changes, ChangeRange, DirectionChanges, Extent, GridBuilder,
    GridProfile, LocalParams, ProfileChanges, ProfileTest, TestChange,
};

use crate::stroke::Direction;

/// Errors of the trend computations.
#[derive(Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum HistoryError {
    /// The series is shorter than the baseline needs.
    #[error("{got} tests in the series, the baseline needs {needed}")]
    TooFewPoints {
        /// Points needed.
        needed: usize,
        /// Points present.
        got: usize,
    },
    /// A value or time is NaN or infinite.
    #[error("value at time {time_s} s is not finite")]
    NotFinite {
        /// Time of the point (s since the Unix epoch).
        time_s: f64,
    },
    /// Times are not increasing.
    #[error("times not increasing at point {index}")]
    TimeNotIncreasing {
        /// Index of the offending point.
        index: usize,
    },
    /// A parameter is out of range.
    #[error("invalid trend parameter: {0}")]
    InvalidParams(String),
}

impl HistoryError {
    /// What the error means to a caller: always [`BadInput`](crate::ErrorKind::BadInput): the series or the trend parameters do not allow the assessment.
    pub fn kind(&self) -> crate::ErrorKind {
        use crate::ErrorKind;
        ErrorKind::BadInput
    }
}

/// One test's value of an indicator.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Point {
    /// Test time (s since the Unix epoch, UTC).
    pub time_s: f64,
    /// Value (unit of the indicator).
    pub value: f64,
    /// Standard error of the value when the analysis gives one (unit of the indicator).
    pub std_error: Option<f64>,
}

/// What an indicator measures; its [`Indicator::name`] is the key in the store.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Indicator {
    /// Static (breakaway) friction F_s (N), one-test identification.
    StaticFriction,
    /// Coulomb friction F_c (N).
    CoulombFriction,
    /// Viscous coefficient σ (N·s/m).
    Viscous,
    /// Stribeck velocity v_s (mm/min).
    StribeckVelocity,
    /// Total inertia J at the motor (kg·m²).
    Inertia,
    /// Mean friction of a stroke direction over a fixed position interval (N), from the IAFV.
    MeanFriction {
        /// Stroke direction.
        direction: Direction,
        /// Interval start (mm).
        start_mm: f64,
        /// Interval end (mm).
        end_mm: f64,
    },
    /// Amplitude of a classified fluctuation component over the whole stroke (N).
    Component {
        /// Stroke direction.
        direction: Direction,
        /// Kinematic cause as classified (written `shaft 1x`, `nut ball refeed 1x`, ...).
        cause: crate::label::Cause,
    },
}

impl Indicator {
    /// Stable key: `fs_n`, `fc_n`, `sigma_n_s_per_m`, `vs_mm_min`, `j_total_kgm2`,
    /// `mean_n/<direction>/<start>-<end>mm`, `amplitude_n/<direction>/<cause>`.
    pub fn name(&self) -> String {
        match self {
            Indicator::StaticFriction => "fs_n".into(),
            Indicator::CoulombFriction => "fc_n".into(),
            Indicator::Viscous => "sigma_n_s_per_m".into(),
            Indicator::StribeckVelocity => "vs_mm_min".into(),
            Indicator::Inertia => "j_total_kgm2".into(),
            Indicator::MeanFriction {
                direction,
                start_mm,
                end_mm,
            } => format!("mean_n/{}/{start_mm}-{end_mm}mm", direction.as_str()),
            Indicator::Component { direction, cause } => {
                format!("amplitude_n/{}/{cause}", direction.as_str())
            }
        }
    }

    /// Inverse of [`Indicator::name`]; `None` for an unknown key.
    pub fn parse(name: &str) -> Option<Self> {
        let dir = |s: &str| match s {
            "forward" => Some(Direction::Forward),
            "backward" => Some(Direction::Backward),
            _ => None,
        };
        Some(match name {
            "fs_n" => Indicator::StaticFriction,
            "fc_n" => Indicator::CoulombFriction,
            "sigma_n_s_per_m" => Indicator::Viscous,
            "vs_mm_min" => Indicator::StribeckVelocity,
            "j_total_kgm2" => Indicator::Inertia,
            _ => {
                let mut it = name.splitn(3, '/');
                let (kind, d, rest) = (it.next()?, dir(it.next()?)?, it.next()?);
                match kind {
                    "mean_n" => {
                        let (a, b) = rest.strip_suffix("mm")?.split_once('-')?;
                        Indicator::MeanFriction {
                            direction: d,
                            start_mm: a.parse().ok()?,
                            end_mm: b.parse().ok()?,
                        }
                    }
                    "amplitude_n" => Indicator::Component {
                        direction: d,
                        cause: rest.parse().ok()?,
                    },
                    _ => return None,
                }
            }
        })
    }

    /// Unit of the values.
    pub fn unit(&self) -> &'static str {
        match self {
            Indicator::Viscous => "N·s/m",
            Indicator::StribeckVelocity => "mm/min",
            Indicator::Inertia => "kg·m²",
            _ => "N",
        }
    }

    /// Words for a reader.
    pub fn label(&self) -> String {
        match self {
            Indicator::StaticFriction => "static friction Fs".into(),
            Indicator::CoulombFriction => "Coulomb friction Fc".into(),
            Indicator::Viscous => "viscous coefficient σ".into(),
            Indicator::StribeckVelocity => "Stribeck velocity vs".into(),
            Indicator::Inertia => "inertia J".into(),
            Indicator::MeanFriction {
                direction,
                start_mm,
                end_mm,
            } => format!(
                "mean friction {} {start_mm}-{end_mm} mm",
                direction.as_str()
            ),
            Indicator::Component { direction, cause } => {
                format!("amplitude of {cause} ({})", direction.as_str())
            }
        }
    }
}

/// Options of [`assess`]. Defaults: baseline from the first 5 tests, σ floor 1 % of μ₀,
/// Shewhart L = 3, EWMA λ = 0.2 with L = 3, CUSUM k = 0.5, h = 5, slope from the last 6 tests.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrendParams {
    /// Where the baseline comes from.
    pub baseline: BaselineSpec,
    /// Floor of σ relative to |μ₀| (so that repeated identical values do not make every
    /// wobble an alarm). Default 0.01.
    pub min_relative_std: f64,
    /// Shewhart width L (σ units). Default 3.
    pub shewhart_l: f64,
    /// EWMA weight λ ∈ (0, 1]. Default 0.2.
    pub ewma_lambda: f64,
    /// EWMA limit width L (σ units). Default 3.
    pub ewma_l: f64,
    /// CUSUM reference value k (σ units). Default 0.5.
    pub cusum_k: f64,
    /// CUSUM decision interval h (σ units). Default 5.
    pub cusum_h: f64,
    /// Tests in the recent-slope fit. Default 6.
    pub slope_window: usize,
    /// Raise σ to √(SE² + (`min_relative_std`·μ₀)²), SE the RMS standard error of the points
    /// that set the baseline, when that is larger (a scatter below the measurement's own
    /// uncertainty plus the quantity's known relative scatter is luck). Default `false`.
    #[serde(default)]
    pub std_error_floor: bool,
    /// Limits that hold the error of μ₀ itself (an estimate from the baseline's n tests, or a
    /// single reference test): Shewhart μ₀ ± L·σ·√(1 + 1/n), EWMA as
    /// [`ewma_around_estimate`] with Var(μ₀)/σ² = 1/n, and the CUSUM, which integrates that
    /// error into a drift, does not raise [`Status::Drifting`] (it is still computed and
    /// shown). For indicators judged many at a time, whose baselines come from few tests
    /// (the component amplitudes). Default `false`.
    #[serde(default)]
    pub baseline_mean_error: bool,
}

impl Default for TrendParams {
    fn default() -> Self {
        Self {
            baseline: BaselineSpec::default(),
            min_relative_std: 0.01,
            shewhart_l: 3.0,
            ewma_lambda: 0.2,
            ewma_l: 3.0,
            cusum_k: 0.5,
            cusum_h: 5.0,
            slope_window: 6,
            std_error_floor: false,
            baseline_mean_error: false,
        }
    }
}

impl TrendParams {
    fn validate(&self) -> Result<(), HistoryError> {
        let bad = |m: &str| Err(HistoryError::InvalidParams(m.into()));
        if !(self.ewma_lambda > 0.0 && self.ewma_lambda <= 1.0) {
            return bad("EWMA λ must be in (0, 1]");
        }
        if !(self.ewma_l > 0.0 && self.shewhart_l > 0.0 && self.cusum_h > 0.0) {
            return bad("limit widths L and CUSUM h must be positive");
        }
        if !(self.cusum_k >= 0.0 && self.min_relative_std >= 0.0) {
            return bad("CUSUM k and the σ floor must be ≥ 0");
        }
        Ok(())
    }
}

/// Where an indicator stands, worst first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// The latest value is beyond a user threshold.
    ThresholdCrossed,
    /// The latest value is outside the Shewhart limits.
    OutOfLimits,
    /// EWMA or CUSUM signals a sustained change (early warning).
    Drifting,
    /// In control.
    Ok,
}

impl Status {
    /// Short word for tables.
    pub fn as_str(self) -> &'static str {
        match self {
            Status::ThresholdCrossed => "threshold crossed",
            Status::OutOfLimits => "out of limits",
            Status::Drifting => "drifting",
            Status::Ok => "ok",
        }
    }
}

/// The trend of one indicator.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IndicatorTrend {
    /// What it measures.
    pub indicator: Indicator,
    /// The series assessed.
    pub points: Vec<Point>,
    /// Baseline.
    pub baseline: Baseline,
    /// Shewhart limits μ₀ ± L·σ.
    pub limits: Limits,
    /// EWMA chart.
    pub ewma: Ewma,
    /// CUSUM chart.
    pub cusum: Cusum,
    /// Slope of the recent tests.
    pub slope: Option<RecentSlope>,
    /// User threshold.
    pub threshold: Threshold,
    /// Projected crossing of the threshold.
    pub projection: Option<Projection>,
    /// Latest value relative to μ₀ (percent).
    pub change_percent: f64,
    /// Latest value relative to μ₀ (σ units).
    pub change_sigma: f64,
    /// Index of the first point flagged by EWMA, CUSUM or the Shewhart limits.
    pub first_alarm: Option<usize>,
    /// Status of the latest test.
    pub status: Status,
}

/// Assess one indicator series (time order): baseline, limits, EWMA, CUSUM, slope and
/// projected threshold crossing, status of the latest test.
///
/// The status is [`Status::ThresholdCrossed`] if the latest value is beyond a user threshold,
/// else [`Status::OutOfLimits`] if it is outside μ₀ ± L·σ, else [`Status::Drifting`] if the
/// EWMA at the latest test is outside its limits or either CUSUM sum exceeds h, else
/// [`Status::Ok`].
///
/// # Errors
/// Too few points for the baseline, non-finite values, times not increasing, parameters out
/// of range.
pub fn assess(
    indicator: &Indicator,
    points: &[Point],
    params: &TrendParams,
    threshold: &Threshold,
) -> Result<IndicatorTrend, HistoryError> {
    params.validate()?;
    for (i, w) in points.windows(2).enumerate() {
        if w[1].time_s < w[0].time_s {
            return Err(HistoryError::TimeNotIncreasing { index: i + 1 });
        }
    }
    for p in points {
        if !(p.value.is_finite() && p.time_s.is_finite()) {
            return Err(HistoryError::NotFinite { time_s: p.time_s });
        }
    }
    let mut b = baseline(points, params.baseline, params.min_relative_std)?;
    if params.std_error_floor {
        let set: Vec<&Point> = match params.baseline {
            BaselineSpec::FirstN { .. } => points.iter().take(b.count).collect(),
            BaselineSpec::Reference { index, .. } => points.get(index).into_iter().collect(),
        };
        let ses: Vec<f64> = set.iter().filter_map(|p| p.std_error).collect();
        if !ses.is_empty() {
            // Test-to-test scatter = the relative scatter of the quantity ⊕ the measurement
            // error: the two floors add in quadrature.
            let rms = (ses.iter().map(|s| s * s).sum::<f64>() / ses.len() as f64).sqrt();
            let floor = rms.hypot(params.min_relative_std * b.mean.abs());
            if floor > b.std {
                b.std = floor;
                b.std_floored = true;
            }
        }
    }
    // Var(μ₀)/σ²: the baseline mean's own error, when the limits are to hold it
    let mean_var = if params.baseline_mean_error {
        1.0 / b.count.max(1) as f64
    } else {
        0.0
    };
    let limits = Limits::shewhart(&b, params.shewhart_l * (1.0 + mean_var).sqrt());
    let values: Vec<f64> = points.iter().map(|p| p.value).collect();
    let ew = ewma_around_estimate(&values, &b, params.ewma_lambda, params.ewma_l, mean_var);
    let cu = cusum(&values, &b, params.cusum_k, params.cusum_h);
    let slope = recent_slope(points, params.slope_window);
    let projection = slope.as_ref().and_then(|s| project_crossing(s, threshold));
    let last = *values.last().expect("baseline needs ≥ 1 point");
    let n = values.len() - 1;
    let shewhart_first = values.iter().position(|&x| limits.outside(x));
    let cusum_first = cu.first_alarm.filter(|_| !params.baseline_mean_error);
    let first_alarm = [ew.first_alarm, cusum_first, shewhart_first]
        .into_iter()
        .flatten()
        .min();
    let crossed =
        threshold.upper.is_some_and(|u| last > u) || threshold.lower.is_some_and(|l| last < l);
    let cusum_signal = !params.baseline_mean_error && (cu.upper[n] > cu.h || cu.lower[n] > cu.h);
    let drifting = ew.limits[n].outside(ew.z[n]) || cusum_signal;
    let status = if crossed {
        Status::ThresholdCrossed
    } else if limits.outside(last) {
        Status::OutOfLimits
    } else if drifting {
        Status::Drifting
    } else {
        Status::Ok
    };
    Ok(IndicatorTrend {
        indicator: indicator.clone(),
        points: points.to_vec(),
        change_percent: if b.mean.abs() > 0.0 {
            100.0 * (last - b.mean) / b.mean.abs()
        } else {
            0.0
        },
        change_sigma: (last - b.mean) / b.std,
        baseline: b,
        limits,
        ewma: ew,
        cusum: cu,
        slope,
        threshold: *threshold,
        projection,
        first_alarm,
        status,
    })
}
