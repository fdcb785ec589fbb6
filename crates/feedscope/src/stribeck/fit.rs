//! Bounded nonlinear least-squares identification of the Stribeck curve (paper 000 Eq. 9).
//!
//! # Problem
//! Given N points (|v_i|, |F_i|) of one direction, minimise Σ (F(|v_i|) − |F_i|)² over
//! θ = (F_c, F_s, σ, v_s[, δ]) with
//!
//! F(v) = F_c·(1 − e(v)) + F_s·e(v) + σ·v,  e(v) = exp(−(v/v_s)^δ)
//!
//! subject to the bounds F_c ≥ 0, F_s ≥ 0, σ ≥ 0 (friction and viscous damping cannot be
//! negative), v_s ∈ [v_min/100, 100·v_max] (v_s > 0; the range keeps it finite when the data
//! cannot see it; v_min is the smallest non-zero speed, v_max the largest) and
//! δ ∈ [0.3, 6] when δ is free. F_s < F_c is allowed (a rising low-speed branch).
//!
//! # Method
//! 1. Scale: speeds by v_max and forces by max|F_i|, so that every parameter is O(1).
//! 2. Start (the problem is separable): for each (v_s, δ) of a grid (v_s log-spaced over
//!    [v_min/4, 2·v_max], δ fixed or from {0.5, 0.75, 1, 1.5, 2, 2.5, 3, 4}), F is linear in
//!    (F_c, F_s, σ); solve that non-negative linear least-squares problem exactly by
//!    enumerating the 8 active sets of 3 variables, and keep the grid point of least residual.
//! 3. Refine all parameters with a projected Levenberg–Marquardt iteration (Marquardt's
//!    diagonal scaling; variables on a bound whose gradient points outwards are held), with
//!    v_s carried as ln v_s so that it stays positive.
//! 4. Uncertainty from the Jacobian J at the optimum: cov = s²·(JᵀJ)⁻¹ with
//!    s² = SSR/(N − p); 95 % intervals ± t_{0.975, N−p}·SE (v_s: v_s·exp(±t·SE(ln v_s)),
//!    always positive, the exponent capped at 600 to stay finite). The condition number is
//!    that of J with unit-norm columns.
//! 5. Determinacy ([`reduce`]): a curve the points do not determine (fewer distinct speeds
//!    than parameters, a singular or ill-conditioned Jacobian, non-physical or absurd values)
//!    is not returned; the fit steps down to δ fixed, then to F = F_c + σ·v, then to F = F_c,
//!    and says so in [`StribeckFit::model`] and [`StribeckFit::reductions`].
//!
//! # Reference
//! Paper 000 Eq. 9 and Section 4.2.1 (fitted with MATLAB `fminsearch` there); paper 001
//! Eq. 3; Marquardt, J. SIAM 11 (1963) 431-441.

use crate::diag::Code;
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use super::{StribeckError, StribeckParams, M_S_PER_MM_MIN};

pub mod reduce;

use reduce::{distinct_speeds, fit_linear, FALLBACK_DELTA};
pub use reduce::{FrictionModel, Reduction, Undetermined};

/// Smallest δ allowed when δ is free.
pub const DELTA_MIN: f64 = 0.3;
/// Largest δ allowed when δ is free.
pub const DELTA_MAX: f64 = 6.0;
/// v_s is bounded to [v_min/VS_RANGE, VS_RANGE·v_max].
pub const VS_RANGE: f64 = 100.0;
const DELTA_GRID: [f64; 8] = [0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0];
const NAMES: [&str; 5] = ["fc_n", "fs_n", "sigma_n_s_per_m", "vs_m_s", "delta"];

/// How the shape exponent δ is treated.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DeltaMode {
    /// δ held at this value (> 0); 2 is paper 000 Eq. 9 and paper 001 Eq. 3.
    Fixed(f64),
    /// δ fitted within [[`DELTA_MIN`], [`DELTA_MAX`]].
    Free,
}

impl Default for DeltaMode {
    fn default() -> Self {
        Self::Fixed(2.0)
    }
}

/// Settings of the Stribeck fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StribeckFitParams {
    /// Shape exponent δ: fixed (default 2) or free.
    pub delta: DeltaMode,
    /// Number of v_s values in the start grid (log-spaced). Default 40, at least 2.
    pub vs_grid_points: usize,
    /// Levenberg–Marquardt iterations (Jacobian evaluations) at most. Default 200.
    pub max_iterations: usize,
}

impl Default for StribeckFitParams {
    fn default() -> Self {
        Self {
            delta: DeltaMode::default(),
            vs_grid_points: 40,
            max_iterations: 200,
        }
    }
}

/// Why the Levenberg–Marquardt refinement stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum Termination {
    /// The residual is zero to rounding (noise-free data).
    PerfectFit,
    /// An accepted step reduced the sum of squares by less than 1e-12 of itself.
    SmallReduction,
    /// An accepted step changed no parameter by more than 1e-10 of its size.
    SmallStep,
    /// The projected gradient vanished (to 1e-14 of the sum of squares).
    SmallGradient,
    /// No step along the damped directions decreases the residual any more (damping above
    /// 1e16): a minimum to working precision.
    NoFurtherDecrease,
    /// [`StribeckFitParams::max_iterations`] reached.
    MaxIterations,
    /// A reduced model, linear in its parameters, solved directly (no iteration).
    Direct,
}

/// A parameter with its standard error and 95 % confidence interval (same unit as the value).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ParamEstimate {
    /// Estimate.
    pub value: f64,
    /// Standard error from s²·(JᵀJ)⁻¹.
    pub std_error: f64,
    /// Lower end of the 95 % interval.
    pub ci95_low: f64,
    /// Upper end of the 95 % interval.
    pub ci95_high: f64,
}

/// Standard errors and 95 % intervals of a Stribeck fit, SI units as in [`StribeckParams`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StribeckUncertainty {
    /// Coulomb friction F_c (N).
    pub fc_n: ParamEstimate,
    /// Static friction F_s (N); `None` for a reduced model.
    pub fs_n: Option<ParamEstimate>,
    /// Static excess F_s − F_c (N), with the covariance of F_s and F_c; `None` for a reduced
    /// model.
    pub static_excess_n: Option<ParamEstimate>,
    /// Stribeck velocity v_s (m/s); interval exp(±t·SE) around it from SE(ln v_s); `None` for
    /// a reduced model.
    pub vs_m_s: Option<ParamEstimate>,
    /// Viscous coefficient σ (N·s/m); `None` for a Coulomb level or when σ is held at 0 in a
    /// Coulomb + viscous line.
    pub sigma_n_s_per_m: Option<ParamEstimate>,
    /// Shape exponent δ when it was free.
    pub delta: Option<ParamEstimate>,
    /// The Student t quantile t_{0.975, N−p} used for the intervals.
    pub t_quantile: f64,
}

/// Something that limits what a fit can tell; the fit is still returned.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
#[non_exhaustive]
pub enum FitWarning {
    /// No more points than parameters: no residual degrees of freedom, so no standard errors.
    FewPoints {
        /// Points.
        points: usize,
        /// Fitted parameters.
        parameters: usize,
    },
    /// The slowest point is at or above 2·v_s: v_s and F_s − F_c are poorly identified.
    NoDataBelowTwiceVs {
        /// Slowest speed (m/s).
        min_speed_m_s: f64,
        /// Fitted v_s (m/s).
        vs_m_s: f64,
    },
    /// Every point is above 5·v_s, where the Stribeck term is below e^{−25} (δ = 2) of
    /// F_s − F_c: the data cannot see v_s or F_s at all.
    AllSpeedsFarAboveVs {
        /// Slowest speed (m/s).
        min_speed_m_s: f64,
        /// Fitted v_s (m/s).
        vs_m_s: f64,
    },
    /// The fastest point is below 3·v_s: F_c and σ are confounded with the Stribeck term.
    NoDataAboveThreeVs {
        /// Fastest speed (m/s).
        max_speed_m_s: f64,
        /// Fitted v_s (m/s).
        vs_m_s: f64,
    },
    /// A standard error exceeds the value: the parameter is not distinguishable from zero.
    StdErrorExceedsValue {
        /// Parameter name (`fc_n`, `fs_n`, `static_excess_n`, `sigma_n_s_per_m`, `vs_m_s`,
        /// `delta`).
        parameter: String,
        /// Its value (SI).
        value: f64,
        /// Its standard error (SI).
        std_error: f64,
    },
    /// A parameter ended on a bound of the search (e.g. σ = 0).
    AtBound {
        /// Parameter name.
        parameter: String,
        /// The bound (SI).
        bound: f64,
    },
    /// The column-scaled Jacobian is ill conditioned (> 1e8) or singular (no number):
    /// parameters trade off against each other.
    IllConditioned {
        /// Condition number, `None` when singular.
        condition_number: Option<f64>,
    },
    /// The refinement stopped at its iteration limit.
    NotConverged {
        /// Iterations used.
        iterations: usize,
    },
}

impl FitWarning {
    /// Its code in the diagnostics catalogue.
    pub fn code(&self) -> Code {
        match self {
            Self::FewPoints { .. } => Code::FewPoints,
            Self::NoDataBelowTwiceVs { .. } => Code::NoDataBelowTwiceVs,
            Self::AllSpeedsFarAboveVs { .. } => Code::AllSpeedsFarAboveVs,
            Self::NoDataAboveThreeVs { .. } => Code::NoDataAboveThreeVs,
            Self::StdErrorExceedsValue { .. } => Code::StdErrorExceedsValue,
            Self::AtBound { .. } => Code::AtBound,
            Self::IllConditioned { .. } => Code::IllConditioned,
            Self::NotConverged { .. } => Code::NotConverged,
        }
    }
}

impl std::fmt::Display for FitWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mm = |v: f64| v / M_S_PER_MM_MIN;
        match self {
            Self::FewPoints { points, parameters } => write!(
                f,
                "{points} points for {parameters} parameters: no standard errors"
            ),
            Self::NoDataBelowTwiceVs {
                min_speed_m_s,
                vs_m_s,
            } => write!(
                f,
                "no data below 2·vs (slowest {:.3} mm/min, vs {:.3} mm/min): vs and Fs − Fc \
                 are poorly identified",
                mm(*min_speed_m_s),
                mm(*vs_m_s)
            ),
            Self::AllSpeedsFarAboveVs {
                min_speed_m_s,
                vs_m_s,
            } => write!(
                f,
                "all speeds are above 5·vs (slowest {:.3} mm/min, vs {:.3} mm/min): vs and Fs \
                 are not identifiable from these data",
                mm(*min_speed_m_s),
                mm(*vs_m_s)
            ),
            Self::NoDataAboveThreeVs {
                max_speed_m_s,
                vs_m_s,
            } => write!(
                f,
                "no data above 3·vs (fastest {:.3} mm/min, vs {:.3} mm/min): Fc and sigma are \
                 confounded with the Stribeck term",
                mm(*max_speed_m_s),
                mm(*vs_m_s)
            ),
            Self::StdErrorExceedsValue {
                parameter,
                value,
                std_error,
            } => write!(
                f,
                "standard error of {parameter} ({std_error:.4e}) exceeds its value ({value:.4e})"
            ),
            Self::AtBound { parameter, bound } => {
                write!(f, "{parameter} is on its bound {bound:.4e}")
            }
            Self::IllConditioned { condition_number } => match condition_number {
                Some(c) => write!(f, "ill-conditioned fit (condition number {c:.3e})"),
                None => write!(f, "singular Jacobian: parameters are not separable"),
            },
            Self::NotConverged { iterations } => {
                write!(f, "not converged after {iterations} iterations")
            }
        }
    }
}

/// A fitted friction curve with its diagnostics: the Stribeck curve when the data determine
/// it, else the reduced model they do determine ([`model`](Self::model), the refused models
/// and why in [`reductions`](Self::reductions)).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StribeckFit {
    /// The model reported.
    pub model: FrictionModel,
    /// The richer models refused on the way, in the order tried; empty when the curve asked
    /// for is reported.
    pub reductions: Vec<Reduction>,
    /// Fitted parameters (SI). For a reduced model F_s = F_c and v_s = 0 (no hump, so
    /// [`StribeckParams::magnitude_n`] is the reduced model), σ = 0 for a Coulomb level, and
    /// δ is the one of the curve asked for (not part of the model).
    pub params: StribeckParams,
    /// Standard errors and intervals; `None` without residual degrees of freedom or with a
    /// singular Jacobian.
    pub uncertainty: Option<StribeckUncertainty>,
    /// Whether δ was fitted (false after falling back to δ fixed and for reduced models).
    pub delta_free: bool,
    /// Number of points.
    pub points: usize,
    /// Residual degrees of freedom N − p (0 when N ≤ p).
    pub dof: usize,
    /// Slowest speed (m/s).
    pub min_speed_m_s: f64,
    /// Fastest speed (m/s).
    pub max_speed_m_s: f64,
    /// √(Σ r²/N) of the residuals r = F(v) − |F_i| (N).
    pub residual_rms_n: f64,
    /// Levenberg–Marquardt iterations (Jacobian evaluations).
    pub iterations: usize,
    /// Why the refinement stopped.
    pub termination: Termination,
    /// 2-norm condition number of the Jacobian with unit-norm columns; `None` if singular.
    pub condition_number: Option<f64>,
    /// What limits the fit; empty when it is well determined.
    pub warnings: Vec<FitWarning>,
}

impl StribeckFit {
    /// Fitted Stribeck velocity in mm/min (0 for a reduced model: see [`Self::vs_m_s`]).
    pub fn vs_mm_min(&self) -> f64 {
        self.params.vs_mm_min()
    }

    /// Stribeck velocity (m/s) when the model has one.
    pub fn vs_m_s(&self) -> Option<f64> {
        (self.model == FrictionModel::Stribeck).then_some(self.params.vs_m_s)
    }

    /// Static friction F_s (N) when the model has a hump.
    pub fn fs_n(&self) -> Option<f64> {
        (self.model == FrictionModel::Stribeck).then_some(self.params.fs_n)
    }

    /// Viscous coefficient σ (N·s/m) when the model has one.
    pub fn sigma_n_s_per_m(&self) -> Option<f64> {
        (self.model != FrictionModel::Coulomb).then_some(self.params.sigma_n_s_per_m)
    }

    /// δ when the model is a Stribeck curve.
    pub fn delta(&self) -> Option<f64> {
        (self.model == FrictionModel::Stribeck).then_some(self.params.delta)
    }

    /// Whether a simpler model than the one asked for is reported.
    pub fn is_reduced(&self) -> bool {
        !self.reductions.is_empty()
    }

    /// Fitted friction magnitude at a speed (N).
    pub fn magnitude_n(&self, speed_m_s: f64) -> f64 {
        self.params.magnitude_n(speed_m_s)
    }
}

/// A Stribeck fit planned for one set of speeds: holds the scaled speeds and the start grid's
/// exponential columns, so that many friction sets measured at the same feeds (e.g. every
/// position of a friction map) are fitted without recomputing them.
#[derive(Debug, Clone)]
pub struct StribeckFitter {
    params: StribeckFitParams,
    /// |v_i| / v_ref.
    u: Vec<f64>,
    v_ref: f64,
    min_speed_m_s: f64,
    /// (ln(v_s/v_ref), δ, e_i) of every grid point.
    grid: Vec<(f64, f64, Vec<f64>)>,
    /// The distinct speeds (m/s), increasing ([`reduce`]).
    distinct_m_s: Vec<f64>,
    lo: [f64; 5],
    hi: [f64; 5],
}

/// Fit the Stribeck curve to the points (|v_i|, |F_i|) of one direction (see the module docs).
///
/// Signs are dropped: pass one direction's speeds (m/s) and friction (N).
///
/// # Errors
/// [`StribeckError::LengthMismatch`], [`StribeckError::TooFewPoints`] (none given),
/// [`StribeckError::NonFinite`], [`StribeckError::NoMotion`],
/// [`StribeckError::BadParameter`] for a non-positive fixed δ or a grid of fewer than 2 points.
///
/// # Example
/// ```
/// # use feedscope::stribeck::{fit_stribeck, StribeckFitParams};
/// let v = [1e-4, 3e-4, 1e-3, 3e-3, 1e-2];
/// let f = [240.0, 200.0, 185.0, 195.0, 222.0];
/// let fit = fit_stribeck(&v, &f, &StribeckFitParams::default()).unwrap();
/// assert!(fit.residual_rms_n.is_finite() && fit.params.fc_n >= 0.0);
/// ```
pub fn fit_stribeck(
    speed_m_s: &[f64],
    friction_n: &[f64],
    params: &StribeckFitParams,
) -> Result<StribeckFit, StribeckError> {
    if speed_m_s.len() != friction_n.len() {
        return Err(StribeckError::LengthMismatch {
            speeds: speed_m_s.len(),
            frictions: friction_n.len(),
        });
    }
    StribeckFitter::new(speed_m_s, params)?.fit(friction_n)
}

fn check_finite(quantity: &'static str, values: &[f64]) -> Result<(), StribeckError> {
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(StribeckError::NonFinite {
            quantity,
            index,
            value: values[index],
        }),
        None => Ok(()),
    }
}

impl StribeckFitter {
    /// Plan the fit for these speeds (m/s; signs dropped).
    ///
    /// # Errors
    /// As [`fit_stribeck`], except the friction checks.
    pub fn new(speed_m_s: &[f64], params: &StribeckFitParams) -> Result<Self, StribeckError> {
        if speed_m_s.is_empty() {
            return Err(StribeckError::TooFewPoints {
                points: 0,
                needed: 1,
            });
        }
        check_finite("speed", speed_m_s)?;
        if params.vs_grid_points < 2 {
            return Err(StribeckError::BadParameter {
                name: "vs_grid_points",
                value: params.vs_grid_points as f64,
                expected: "at least 2",
            });
        }
        let deltas: Vec<f64> = match params.delta {
            DeltaMode::Fixed(d) => {
                if !(d.is_finite() && d > 0.0) {
                    return Err(StribeckError::BadParameter {
                        name: "delta",
                        value: d,
                        expected: "a positive, finite exponent",
                    });
                }
                vec![d]
            }
            // The grid holds δ = FALLBACK_DELTA, so the fixed-δ fallback reuses it.
            DeltaMode::Free => DELTA_GRID.to_vec(),
        };
        let v_ref = speed_m_s.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if v_ref <= 0.0 {
            return Err(StribeckError::NoMotion);
        }
        let min_speed_m_s = speed_m_s.iter().fold(f64::INFINITY, |m, v| m.min(v.abs()));
        let min_pos = speed_m_s
            .iter()
            .map(|v| v.abs())
            .filter(|&v| v > 0.0)
            .fold(f64::INFINITY, f64::min);
        let u: Vec<f64> = speed_m_s.iter().map(|v| v.abs() / v_ref).collect();
        let u_min = min_pos / v_ref;
        let (g_lo, g_hi) = ((0.25 * u_min).ln(), 2f64.ln());
        let m = params.vs_grid_points;
        let mut grid = Vec::with_capacity(m * deltas.len());
        for &d in &deltas {
            for k in 0..m {
                let l = g_lo + (g_hi - g_lo) * k as f64 / (m - 1) as f64;
                let vs = l.exp();
                let e = u.iter().map(|&ui| (-(ui / vs).powf(d)).exp()).collect();
                grid.push((l, d, e));
            }
        }
        let (d_lo, d_hi) = match params.delta {
            DeltaMode::Fixed(d) => (d, d),
            DeltaMode::Free => (DELTA_MIN, DELTA_MAX),
        };
        Ok(Self {
            params: params.clone(),
            u,
            v_ref,
            min_speed_m_s,
            grid,
            distinct_m_s: distinct_speeds(speed_m_s),
            lo: [0.0, 0.0, 0.0, (u_min / VS_RANGE).ln(), d_lo],
            hi: [
                f64::INFINITY,
                f64::INFINITY,
                f64::INFINITY,
                VS_RANGE.ln(),
                d_hi,
            ],
        })
    }

    /// Number of points this fitter expects.
    pub fn points(&self) -> usize {
        self.u.len()
    }

    /// The distinct speeds of the plan (m/s, increasing; speeds within
    /// [`reduce::DISTINCT_SPEED_TOLERANCE`] count once).
    pub fn distinct_speeds_m_s(&self) -> &[f64] {
        &self.distinct_m_s
    }

    /// Fit one set of friction values (N, signs dropped), measured at the planned speeds.
    ///
    /// Returns the Stribeck curve asked for when the points determine it, else the richest
    /// reduced model they determine (δ fixed at [`reduce::FALLBACK_DELTA`] after δ free, then
    /// F = F_c + σ·v, then F = F_c), with [`StribeckFit::model`] and
    /// [`StribeckFit::reductions`] saying which and why (module [`reduce`]).
    ///
    /// # Errors
    /// [`StribeckError::LengthMismatch`], [`StribeckError::NonFinite`].
    pub fn fit(&self, friction_n: &[f64]) -> Result<StribeckFit, StribeckError> {
        let n = self.u.len();
        if friction_n.len() != n {
            return Err(StribeckError::LengthMismatch {
                speeds: n,
                frictions: friction_n.len(),
            });
        }
        check_finite("friction", friction_n)?;
        let f_ref = friction_n.iter().fold(0.0f64, |m, f| m.max(f.abs()));
        let f_ref = if f_ref > 0.0 { f_ref } else { 1.0 };
        let y: Vec<f64> = friction_n.iter().map(|f| f.abs() / f_ref).collect();
        let k = self.distinct_m_s.len();
        let mut reductions = Vec::new();
        let tries: &[bool] = match self.params.delta {
            DeltaMode::Free => &[true, false],
            DeltaMode::Fixed(_) => &[false],
        };
        for &delta_free in tries {
            let p = if delta_free { 5 } else { 4 };
            let reason = if k < p {
                Undetermined::TooFewSpeeds {
                    distinct: k,
                    needed: p,
                    speeds_m_s: self.distinct_m_s.clone(),
                }
            } else {
                let fit = self.fit_curve(&y, f_ref, delta_free);
                match self.undetermined(&fit, f_ref) {
                    None => return Ok(StribeckFit { reductions, ..fit }),
                    Some(r) => r,
                }
            };
            reductions.push(Reduction {
                refused: FrictionModel::Stribeck,
                delta_free,
                parameters: p,
                reason,
            });
        }
        let viscous = k >= 2;
        if !viscous {
            reductions.push(Reduction {
                refused: FrictionModel::CoulombViscous,
                delta_free: false,
                parameters: 2,
                reason: Undetermined::TooFewSpeeds {
                    distinct: k,
                    needed: 2,
                    speeds_m_s: self.distinct_m_s.clone(),
                },
            });
        }
        Ok(StribeckFit {
            reductions,
            ..self.fit_reduced(&y, f_ref, viscous)
        })
    }

    /// Why the data do not determine this Stribeck curve, if they do not (module [`reduce`]).
    fn undetermined(&self, fit: &StribeckFit, f_ref: f64) -> Option<Undetermined> {
        let p = &fit.params;
        let named = [
            ("fc_n", p.fc_n),
            ("fs_n", p.fs_n),
            ("sigma_n_s_per_m", p.sigma_n_s_per_m),
            ("vs_m_s", p.vs_m_s),
            ("delta", p.delta),
        ];
        if let Some((name, _)) = named.iter().find(|(_, x)| !x.is_finite()) {
            return Some(Undetermined::NonFinite {
                parameter: name.to_string(),
            });
        }
        match fit.condition_number {
            None => return Some(Undetermined::SingularJacobian),
            Some(c) if c > reduce::CONDITION_LIMIT => {
                return Some(Undetermined::IllConditioned {
                    condition_number: c,
                })
            }
            Some(_) => {}
        }
        let v_max = self.v_ref;
        let limit_n = reduce::MAGNITUDE_LIMIT * f_ref;
        for (name, force) in [
            ("fc_n", p.fc_n),
            ("fs_n", p.fs_n),
            ("sigma_n_s_per_m * v_max", p.sigma_n_s_per_m * v_max),
        ] {
            if force.abs() > limit_n {
                return Some(Undetermined::AbsurdMagnitude {
                    parameter: name.to_string(),
                    limit_n,
                });
            }
        }
        let u = fit.uncertainty.as_ref();
        if let Some(u) = u {
            let se = |e: Option<ParamEstimate>| e.map_or(0.0, |e| e.std_error);
            for (name, se_n) in [
                ("fc_n", u.fc_n.std_error),
                ("fs_n", se(u.fs_n)),
                ("static_excess_n", se(u.static_excess_n)),
                ("sigma_n_s_per_m * v_max", se(u.sigma_n_s_per_m) * v_max),
            ] {
                if se_n > f_ref {
                    return Some(Undetermined::AbsurdUncertainty {
                        parameter: name.to_string(),
                        limit: f_ref,
                    });
                }
            }
            if let Some(d) = u.delta.filter(|d| d.std_error > d.value) {
                return Some(Undetermined::AbsurdUncertainty {
                    parameter: "delta".to_string(),
                    limit: d.value,
                });
            }
        }
        let v_min = self
            .u
            .iter()
            .copied()
            .filter(|&x| x > 0.0)
            .fold(1.0, f64::min)
            * v_max;
        if p.vs_m_s < v_min / reduce::VS_OUTSIDE_FACTOR
            || p.vs_m_s > reduce::VS_OUTSIDE_FACTOR * v_max
        {
            return Some(Undetermined::VsOutsideData {
                vs_m_s: p.vs_m_s,
                min_speed_m_s: v_min,
                max_speed_m_s: v_max,
            });
        }
        let excess = p.static_excess_n();
        let excess_se = u.and_then(|u| u.static_excess_n).map(|e| e.std_error);
        if excess < 0.0 && excess_se.is_none_or(|se| excess < -se) {
            return Some(Undetermined::StaticBelowCoulomb {
                static_excess_n: excess,
                std_error_n: excess_se,
            });
        }
        None
    }

    /// The reduced model F = F_c + σ·v (`viscous`) or F = F_c, by non-negative linear least
    /// squares ([`reduce`]).
    fn fit_reduced(&self, y: &[f64], f_ref: f64, viscous: bool) -> StribeckFit {
        let n = y.len();
        let v_ref = self.v_ref;
        let lin = fit_linear(&self.u, y, viscous);
        let model = if viscous {
            FrictionModel::CoulombViscous
        } else {
            FrictionModel::Coulomb
        };
        let fc_n = lin.c[0] * f_ref;
        let params = StribeckParams {
            fc_n,
            fs_n: fc_n,
            vs_m_s: 0.0,
            sigma_n_s_per_m: lin.c[1] * f_ref / v_ref,
            delta: match self.params.delta {
                DeltaMode::Fixed(d) => d,
                DeltaMode::Free => FALLBACK_DELTA,
            },
        };
        let q = lin.free.iter().filter(|&&f| f).count();
        let p = if viscous { 2 } else { 1 };
        let dof = n.saturating_sub(q);
        let uncertainty = (dof > 0 && q > 0).then(|| {
            let s2 = lin.ssr / dof as f64;
            let t = t_quantile_975(dof);
            let est = |value: f64, var: f64, scale: f64| {
                let se = var.max(0.0).sqrt() * s2.sqrt() * scale;
                ParamEstimate {
                    value,
                    std_error: se,
                    ci95_low: value - t * se,
                    ci95_high: value + t * se,
                }
            };
            // (AᵀA)⁻¹ is indexed over the free columns in order.
            let mut k = 0;
            let mut next = |free: bool| {
                free.then(|| {
                    k += 1;
                    lin.inv[k - 1][k - 1]
                })
            };
            let var_fc = next(lin.free[0]);
            let var_sigma = next(lin.free[1]);
            StribeckUncertainty {
                fc_n: est(fc_n, var_fc.unwrap_or(0.0), f_ref),
                fs_n: None,
                static_excess_n: None,
                vs_m_s: None,
                sigma_n_s_per_m: var_sigma.map(|v| est(params.sigma_n_s_per_m, v, f_ref / v_ref)),
                delta: None,
                t_quantile: t,
            }
        });
        let mut warnings = Vec::new();
        if n <= p {
            warnings.push(FitWarning::FewPoints {
                points: n,
                parameters: p,
            });
        }
        if let Some(u) = &uncertainty {
            for (name, e) in [
                ("fc_n", Some(u.fc_n)),
                ("sigma_n_s_per_m", u.sigma_n_s_per_m),
            ] {
                if let Some(e) = e.filter(|e| e.std_error > e.value.abs()) {
                    warnings.push(FitWarning::StdErrorExceedsValue {
                        parameter: name.to_string(),
                        value: e.value,
                        std_error: e.std_error,
                    });
                }
            }
        }
        for (i, name) in ["fc_n", "sigma_n_s_per_m"].iter().enumerate().take(p) {
            if !lin.free[i] {
                warnings.push(FitWarning::AtBound {
                    parameter: name.to_string(),
                    bound: 0.0,
                });
            }
        }
        if lin.condition_number > reduce::CONDITION_LIMIT {
            warnings.push(FitWarning::IllConditioned {
                condition_number: Some(lin.condition_number),
            });
        }
        StribeckFit {
            model,
            reductions: Vec::new(),
            params,
            uncertainty,
            delta_free: false,
            points: n,
            dof,
            min_speed_m_s: self.min_speed_m_s,
            max_speed_m_s: v_ref,
            residual_rms_n: (lin.ssr / n as f64).sqrt() * f_ref,
            iterations: 0,
            termination: Termination::Direct,
            condition_number: Some(lin.condition_number),
            warnings,
        }
    }

    /// Steps 2-4 of the module docs for the Stribeck curve, δ free or fixed (at the planned δ,
    /// or [`FALLBACK_DELTA`] when the plan has δ free).
    fn fit_curve(&self, y: &[f64], f_ref: f64, delta_free: bool) -> StribeckFit {
        let n = y.len();
        let p = if delta_free { 5 } else { 4 };
        let fixed = match self.params.delta {
            DeltaMode::Fixed(d) => d,
            DeltaMode::Free => FALLBACK_DELTA,
        };

        // Step 2: separable grid start.
        let mut best = (f64::INFINITY, [0.0; 5]);
        for (l, d, e) in &self.grid {
            // The δ = 2 column of a δ-free grid is the fixed-δ fallback's grid.
            if !delta_free && (d - fixed).abs() > 1e-12 {
                continue;
            }
            let (c, ssr) = nnls3(&self.u, e, y);
            if ssr < best.0 {
                best = (ssr, [c[0], c[1], c[2], *l, *d]);
            }
        }
        // Step 3: Levenberg–Marquardt on all free parameters.
        let free = [true, true, true, true, delta_free];
        let lm = self.levenberg_marquardt(y, best.1, free);
        let th = lm.theta;

        let v_ref = self.v_ref;
        let params = StribeckParams {
            fc_n: th[0] * f_ref,
            fs_n: th[1] * f_ref,
            sigma_n_s_per_m: th[2] * f_ref / v_ref,
            vs_m_s: th[3].exp() * v_ref,
            delta: th[4],
        };
        let residual_rms_n = (lm.ssr / n as f64).sqrt() * f_ref;
        let dof = n.saturating_sub(p);

        // Step 4: uncertainty from the Jacobian at the optimum.
        let (jac, _) = self.jacobian(&th, y);
        let cols: Vec<usize> = (0..5).filter(|&i| free[i]).collect();
        let mut js = DMatrix::zeros(n, p);
        let mut norms = vec![0.0; p];
        for (c, &i) in cols.iter().enumerate() {
            let nrm = (0..n).map(|r| jac[r][i] * jac[r][i]).sum::<f64>().sqrt();
            norms[c] = nrm;
            for r in 0..n {
                js[(r, c)] = if nrm > 0.0 { jac[r][i] / nrm } else { 0.0 };
            }
        }
        let mut warnings = Vec::new();
        let (condition_number, inv) = scaled_inverse(&js, &norms);
        let uncertainty = match (dof > 0, inv) {
            (true, Some(inv)) => {
                let s2 = lm.ssr / dof as f64;
                let t = t_quantile_975(dof);
                let var = |a: usize, b: usize| s2 * inv[(a, b)];
                let lin = |value: f64, se: f64| ParamEstimate {
                    value,
                    std_error: se,
                    ci95_low: value - t * se,
                    ci95_high: value + t * se,
                };
                let se_l = var(3, 3).max(0.0).sqrt();
                let excess_se = (var(0, 0) + var(1, 1) - 2.0 * var(0, 1)).max(0.0).sqrt() * f_ref;
                Some(StribeckUncertainty {
                    fc_n: lin(params.fc_n, var(0, 0).max(0.0).sqrt() * f_ref),
                    fs_n: Some(lin(params.fs_n, var(1, 1).max(0.0).sqrt() * f_ref)),
                    static_excess_n: Some(lin(params.fs_n - params.fc_n, excess_se)),
                    sigma_n_s_per_m: Some(lin(
                        params.sigma_n_s_per_m,
                        var(2, 2).max(0.0).sqrt() * f_ref / v_ref,
                    )),
                    // the exponent is capped at 600 so that an unidentifiable v_s still
                    // gets a finite (absurdly wide) interval
                    vs_m_s: Some(ParamEstimate {
                        value: params.vs_m_s,
                        std_error: params.vs_m_s * se_l,
                        ci95_low: params.vs_m_s * (-(t * se_l).min(600.0)).exp(),
                        ci95_high: params.vs_m_s * (t * se_l).min(600.0).exp(),
                    }),
                    delta: delta_free.then(|| lin(params.delta, var(4, 4).max(0.0).sqrt())),
                    t_quantile: t,
                })
            }
            _ => None,
        };
        // Uncertainties can overflow to infinity on hopeless data; never hand out non-finite
        // numbers.
        let uncertainty = uncertainty.filter(|u| {
            let all = [
                Some(u.fc_n),
                u.fs_n,
                u.static_excess_n,
                u.sigma_n_s_per_m,
                u.vs_m_s,
                u.delta,
            ];
            all.iter().flatten().all(|e| {
                e.std_error.is_finite() && e.ci95_low.is_finite() && e.ci95_high.is_finite()
            })
        });

        // Identifiability warnings.
        let max_speed_m_s = self.v_ref;
        if n <= p {
            warnings.push(FitWarning::FewPoints {
                points: n,
                parameters: p,
            });
        }
        let vs = params.vs_m_s;
        if self.min_speed_m_s > 5.0 * vs {
            warnings.push(FitWarning::AllSpeedsFarAboveVs {
                min_speed_m_s: self.min_speed_m_s,
                vs_m_s: vs,
            });
        } else if self.min_speed_m_s >= 2.0 * vs {
            warnings.push(FitWarning::NoDataBelowTwiceVs {
                min_speed_m_s: self.min_speed_m_s,
                vs_m_s: vs,
            });
        }
        if max_speed_m_s < 3.0 * vs {
            warnings.push(FitWarning::NoDataAboveThreeVs {
                max_speed_m_s,
                vs_m_s: vs,
            });
        }
        if let Some(u) = &uncertainty {
            let mut check = |name: &str, e: &ParamEstimate| {
                if e.std_error > e.value.abs() {
                    warnings.push(FitWarning::StdErrorExceedsValue {
                        parameter: name.to_string(),
                        value: e.value,
                        std_error: e.std_error,
                    });
                }
            };
            check("fc_n", &u.fc_n);
            for (name, e) in [
                ("fs_n", &u.fs_n),
                ("static_excess_n", &u.static_excess_n),
                ("sigma_n_s_per_m", &u.sigma_n_s_per_m),
                ("vs_m_s", &u.vs_m_s),
                ("delta", &u.delta),
            ] {
                if let Some(e) = e {
                    check(name, e);
                }
            }
        }
        let si = [
            f_ref,
            f_ref,
            f_ref / v_ref,
            f64::NAN, // v_s bounds are on ln v_s
            1.0,
        ];
        for i in cols.iter().copied() {
            for (bound, is_lo) in [(self.lo[i], true), (self.hi[i], false)] {
                let hit = if is_lo {
                    th[i] <= bound
                } else {
                    th[i] >= bound
                };
                if bound.is_finite() && hit {
                    let b = if i == 3 {
                        bound.exp() * v_ref
                    } else {
                        bound * si[i]
                    };
                    warnings.push(FitWarning::AtBound {
                        parameter: NAMES[i].to_string(),
                        bound: b,
                    });
                }
            }
        }
        match condition_number {
            Some(c) if c <= 1e8 => {}
            c => warnings.push(FitWarning::IllConditioned {
                condition_number: c,
            }),
        }
        if lm.termination == Termination::MaxIterations {
            warnings.push(FitWarning::NotConverged {
                iterations: lm.iterations,
            });
        }
        StribeckFit {
            model: FrictionModel::Stribeck,
            reductions: Vec::new(),
            params,
            uncertainty,
            delta_free,
            points: n,
            dof,
            min_speed_m_s: self.min_speed_m_s,
            max_speed_m_s,
            residual_rms_n,
            iterations: lm.iterations,
            termination: lm.termination,
            condition_number,
            warnings,
        }
    }

    /// Residuals r_i = F(u_i) − y_i and their Jacobian rows ∂r_i/∂θ (scaled units,
    /// θ = (F_c, F_s, σ, ln v_s, δ)). Returns (Jacobian rows, residuals).
    fn jacobian(&self, th: &[f64; 5], y: &[f64]) -> (Vec<[f64; 5]>, Vec<f64>) {
        let mut jac = Vec::with_capacity(y.len());
        let mut r = Vec::with_capacity(y.len());
        for (&u, &yi) in self.u.iter().zip(y) {
            let (f, g) = model(th, u);
            jac.push(g);
            r.push(f - yi);
        }
        (jac, r)
    }

    fn ssr(&self, th: &[f64; 5], y: &[f64]) -> f64 {
        self.u
            .iter()
            .zip(y)
            .map(|(&u, &yi)| {
                let r = value(th, u) - yi;
                r * r
            })
            .sum()
    }

    /// Projected Levenberg–Marquardt from `th` (step 3 of the module docs).
    // Index loops over the 5×5 normal equations read like the formulas.
    #[allow(clippy::needless_range_loop)]
    fn levenberg_marquardt(&self, y: &[f64], mut th: [f64; 5], free: [bool; 5]) -> LmResult {
        let n = y.len();
        let mut ssr = self.ssr(&th, y);
        let mut lambda = 1e-3;
        let mut iterations = 0;
        let termination = loop {
            if ssr <= 1e-28 * n as f64 {
                break Termination::PerfectFit;
            }
            if iterations >= self.params.max_iterations {
                break Termination::MaxIterations;
            }
            iterations += 1;
            let (jac, r) = self.jacobian(&th, y);
            let mut h = [[0.0; 5]; 5];
            let mut g = [0.0; 5];
            for (row, ri) in jac.iter().zip(&r) {
                for a in 0..5 {
                    g[a] += row[a] * ri;
                    for b in a..5 {
                        h[a][b] += row[a] * row[b];
                    }
                }
            }
            for a in 0..5 {
                for b in 0..a {
                    h[a][b] = h[b][a];
                }
            }
            // Hold variables on a bound whose descent direction −g leaves the box.
            let mut act = free;
            for i in 0..5 {
                if free[i]
                    && ((th[i] <= self.lo[i] && g[i] > 0.0) || (th[i] >= self.hi[i] && g[i] < 0.0))
                {
                    act[i] = false;
                }
            }
            let idx: Vec<usize> = (0..5).filter(|&i| act[i]).collect();
            let gmax = idx.iter().map(|&i| g[i].abs()).fold(0.0, f64::max);
            if idx.is_empty() || gmax <= 1e-14 * ssr.max(1e-300) {
                break Termination::SmallGradient;
            }
            let hmax = idx.iter().map(|&i| h[i][i]).fold(0.0, f64::max);
            let mut accepted = None;
            while lambda <= 1e16 {
                let k = idx.len();
                let mut a = DMatrix::zeros(k, k);
                let mut b = nalgebra::DVector::zeros(k);
                for (p, &i) in idx.iter().enumerate() {
                    for (q, &j) in idx.iter().enumerate() {
                        a[(p, q)] = h[i][j];
                    }
                    a[(p, p)] += lambda * h[i][i].max(1e-12 * hmax).max(1e-300);
                    b[p] = -g[i];
                }
                let step = a.cholesky().map(|c| c.solve(&b));
                if let Some(step) = step {
                    let mut trial = th;
                    for (p, &i) in idx.iter().enumerate() {
                        trial[i] = (th[i] + step[p]).clamp(self.lo[i], self.hi[i]);
                    }
                    let s_new = self.ssr(&trial, y);
                    if s_new.is_finite() && s_new < ssr {
                        accepted = Some((trial, s_new));
                        lambda = (lambda / 3.0).max(1e-12);
                        break;
                    }
                }
                lambda *= 4.0;
            }
            let Some((trial, s_new)) = accepted else {
                break Termination::NoFurtherDecrease;
            };
            let small_step =
                (0..5).all(|i| (trial[i] - th[i]).abs() <= 1e-10 * (th[i].abs() + 1e-10));
            let small_red = ssr - s_new <= 1e-12 * ssr;
            th = trial;
            ssr = s_new;
            if small_step {
                break Termination::SmallStep;
            }
            if small_red {
                break Termination::SmallReduction;
            }
        };
        LmResult {
            theta: th,
            ssr,
            iterations,
            termination,
        }
    }
}

struct LmResult {
    theta: [f64; 5],
    ssr: f64,
    iterations: usize,
    termination: Termination,
}

/// F(u) in scaled units for θ = (F_c, F_s, σ, ln v_s, δ).
#[inline]
fn value(th: &[f64; 5], u: f64) -> f64 {
    let e = if u > 0.0 {
        (-(u / th[3].exp()).powf(th[4])).exp()
    } else {
        1.0
    };
    th[0] * (1.0 - e) + th[1] * e + th[2] * u
}

/// F(u) and ∂F/∂θ: with w = (u/v_s)^δ and e = exp(−w),
/// ∂F/∂F_c = 1 − e, ∂F/∂F_s = e, ∂F/∂σ = u, ∂F/∂ln v_s = (F_s − F_c)·e·δ·w,
/// ∂F/∂δ = −(F_s − F_c)·e·w·ln(u/v_s).
#[inline]
fn model(th: &[f64; 5], u: f64) -> (f64, [f64; 5]) {
    let (e, w, lnr) = if u > 0.0 {
        let lnr = u.ln() - th[3];
        let w = (th[4] * lnr).exp();
        ((-w).exp(), w, lnr)
    } else {
        (1.0, 0.0, 0.0)
    };
    let ex = th[1] - th[0];
    let f = th[0] * (1.0 - e) + th[1] * e + th[2] * u;
    (f, [1.0 - e, e, u, ex * e * th[4] * w, -ex * e * w * lnr])
}

/// Non-negative least squares of y ≈ c0·(1 − e) + c1·e + c2·u, exactly, by trying every
/// active set of the 3 variables (the optimum is the unconstrained solution on its support,
/// and every feasible candidate is admissible, so the feasible candidate of least residual is
/// the optimum). Returns (c, SSR).
#[allow(clippy::needless_range_loop)] // 3×3 Gram matrix, indexed as in the formulas
fn nnls3(u: &[f64], e: &[f64], y: &[f64]) -> ([f64; 3], f64) {
    let mut g = [[0.0; 3]; 3];
    let mut b = [0.0; 3];
    let mut yy = 0.0;
    for ((&ui, &ei), &yi) in u.iter().zip(e).zip(y) {
        let a = [1.0 - ei, ei, ui];
        for p in 0..3 {
            b[p] += a[p] * yi;
            for q in p..3 {
                g[p][q] += a[p] * a[q];
            }
        }
        yy += yi * yi;
    }
    for p in 0..3 {
        for q in 0..p {
            g[p][q] = g[q][p];
        }
    }
    let mut best = ([0.0; 3], yy);
    for mask in 1u8..8 {
        let idx: Vec<usize> = (0..3).filter(|i| mask & (1 << i) != 0).collect();
        let Some(sol) = small_spd_solve(&g, &b, &idx) else {
            continue;
        };
        if sol.iter().any(|&c| c < 0.0) {
            continue;
        }
        let mut c = [0.0; 3];
        for (k, &i) in idx.iter().enumerate() {
            c[i] = sol[k];
        }
        let mut ssr = yy;
        for p in 0..3 {
            ssr -= 2.0 * c[p] * b[p];
            for q in 0..3 {
                ssr += c[p] * g[p][q] * c[q];
            }
        }
        let ssr = ssr.max(0.0);
        if ssr < best.1 {
            best = (c, ssr);
        }
    }
    best
}

/// Solve `G[idx, idx]·x = b[idx]` by Cholesky; `None` when a pivot falls below 1e-12 of its
/// diagonal (a column that the data cannot see, e.g. e ≡ 0).
#[allow(clippy::needless_range_loop)] // Cholesky indexed as in the formulas
fn small_spd_solve(g: &[[f64; 3]; 3], b: &[f64; 3], idx: &[usize]) -> Option<Vec<f64>> {
    let k = idx.len();
    let mut l = [[0.0; 3]; 3];
    for i in 0..k {
        for j in 0..=i {
            let mut s = g[idx[i]][idx[j]];
            for m in 0..j {
                s -= l[i][m] * l[j][m];
            }
            if i == j {
                if s <= 1e-12 * g[idx[i]][idx[i]] || s <= 0.0 {
                    return None;
                }
                l[i][i] = s.sqrt();
            } else {
                l[i][j] = s / l[j][j];
            }
        }
    }
    let mut z = vec![0.0; k];
    for i in 0..k {
        let mut s = b[idx[i]];
        for m in 0..i {
            s -= l[i][m] * z[m];
        }
        z[i] = s / l[i][i];
    }
    for i in (0..k).rev() {
        let mut s = z[i];
        for m in i + 1..k {
            s -= l[m][i] * z[m];
        }
        z[i] = s / l[i][i];
    }
    Some(z)
}

/// Condition number of the unit-column matrix `js` and (JᵀJ)⁻¹ of the unscaled J whose column
/// norms are `norms` (scaled-parameter units), both from the SVD; `None`s when singular.
fn scaled_inverse(js: &DMatrix<f64>, norms: &[f64]) -> (Option<f64>, Option<DMatrix<f64>>) {
    let p = js.ncols();
    if js.nrows() < p || norms.iter().any(|&n| n <= 0.0) {
        return (None, None);
    }
    let svd = js.clone().svd(false, true);
    let s = &svd.singular_values;
    let smax = s.max();
    let smin = s.min();
    if smin.is_nan() || smin <= 1e-15 * smax {
        return (None, None);
    }
    let vt = svd.v_t.expect("requested V");
    let mut inv = DMatrix::zeros(p, p);
    for a in 0..p {
        for b in 0..p {
            let mut acc = 0.0;
            for k in 0..p {
                acc += vt[(k, a)] * vt[(k, b)] / (s[k] * s[k]);
            }
            inv[(a, b)] = acc / (norms[a] * norms[b]);
        }
    }
    (Some(smax / smin), Some(inv))
}

/// Student t quantile t_{0.975, ν}: table for ν ≤ 30, Cornish–Fisher expansion in 1/ν above
/// (error < 1e-4 at ν = 31).
pub fn t_quantile_975(dof: usize) -> f64 {
    const T: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
        2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
        2.052, 2.048, 2.045, 2.042,
    ];
    if dof == 0 {
        return f64::INFINITY;
    }
    if dof <= 30 {
        return T[dof - 1];
    }
    let z: f64 = 1.959_963_984_540_054;
    let nu = dof as f64;
    let (z3, z5, z7) = (z.powi(3), z.powi(5), z.powi(7));
    z + (z3 + z) / (4.0 * nu)
        + (5.0 * z5 + 16.0 * z3 + 3.0 * z) / (96.0 * nu * nu)
        + (3.0 * z7 + 19.0 * z5 + 17.0 * z3 - 15.0 * z) / (384.0 * nu * nu * nu)
}

// Here, not in `diag`, so that the catalogue depends on no module that uses it.
impl From<&FitWarning> for crate::diag::Diagnostic {
    fn from(w: &FitWarning) -> Self {
        Self::new(w.code(), w.to_string())
    }
}

impl From<&Reduction> for crate::diag::Diagnostic {
    fn from(r: &Reduction) -> Self {
        Self::new(r.code(), r.to_string())
    }
}

#[cfg(test)]
pub(crate) mod tests;
