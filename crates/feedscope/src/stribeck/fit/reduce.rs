//! What the data determine: the checks that refuse a Stribeck curve the points cannot pin
//! down, and the reduced models fitted instead (Coulomb + viscous line, Coulomb level).
//!
//! # Ladder
//! A fit tries, in order, the Stribeck curve with δ free (when asked), the Stribeck curve with
//! δ fixed (the given δ, or [`FALLBACK_DELTA`] after a refused δ-free fit), the line
//! F = F_c + σ·v and the level F = F_c, and reports the first the data determine. Each model
//! refused on the way is recorded as a [`Reduction`] with its reason ([`Undetermined`]).
//!
//! A Stribeck curve is refused when the points have fewer distinct speeds than it has
//! parameters (speeds within [`DISTINCT_SPEED_TOLERANCE`] of each other count once), when its
//! Jacobian is singular or its condition number exceeds [`CONDITION_LIMIT`], when a parameter
//! is not finite, when F_c, F_s or σ·v_max exceeds [`MAGNITUDE_LIMIT`] × the largest friction
//! measured, when a standard error of F_c, F_s, F_s − F_c or σ·v_max exceeds the largest
//! friction measured (or SE(δ) exceeds δ), when v_s lies more than [`VS_OUTSIDE_FACTOR`] ×
//! outside the measured speeds, or when F_s < F_c by more than the standard error of F_s − F_c
//! (by any amount without one). The line needs two distinct speeds, the level one.
//!
//! # Linear models
//! y_i ≈ c_0 + c_1·u_i (scaled units as the Stribeck fit) by non-negative least squares
//! (F_c ≥ 0, σ ≥ 0) over the active sets, exactly; a variable held at its bound is not a
//! parameter for the degrees of freedom. Standard errors from s²·(AᵀA)⁻¹ on the free columns.

use crate::diag::Code;
use serde::{Deserialize, Serialize};

use super::M_S_PER_MM_MIN;

/// Speeds whose ratio is below 1 + this count as one speed: they add no information about the
/// shape of the curve (a map's feed groups already merge feeds within 2 %).
pub const DISTINCT_SPEED_TOLERANCE: f64 = 0.01;
/// Largest condition number of the column-scaled Jacobian of an accepted Stribeck curve (the
/// [`FitWarning::IllConditioned`](super::FitWarning::IllConditioned) threshold).
pub const CONDITION_LIMIT: f64 = 1e8;
/// F_c, F_s and σ·v_max above this many times the largest friction measured are absurd.
pub const MAGNITUDE_LIMIT: f64 = 10.0;
/// v_s below v_min/this or above this·v_max: the hump is not in the data.
pub const VS_OUTSIDE_FACTOR: f64 = 10.0;
/// δ of the Stribeck curve tried after a refused δ-free fit (paper 000 Eq. 9, paper 001 Eq. 3).
pub const FALLBACK_DELTA: f64 = 2.0;

/// The friction model a fit reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum FrictionModel {
    /// F = F_c + (F_s − F_c)·exp(−(v/v_s)^δ) + σ·v (paper 000 Eq. 9).
    Stribeck,
    /// F = F_c + σ·v: the data do not determine a Stribeck hump (F_s = F_c, v_s not defined).
    CoulombViscous,
    /// F = F_c: one level (σ = 0, F_s = F_c).
    Coulomb,
}

impl FrictionModel {
    /// Stable kebab-case name for files and scripts.
    pub fn code(&self) -> &'static str {
        match self {
            Self::Stribeck => "stribeck",
            Self::CoulombViscous => "coulomb-viscous",
            Self::Coulomb => "coulomb",
        }
    }
}

impl std::fmt::Display for FrictionModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Stribeck => "Stribeck curve (Fc, Fs, vs, sigma)",
            Self::CoulombViscous => "Coulomb + viscous (F = Fc + sigma*v)",
            Self::Coulomb => "Coulomb level (F = Fc)",
        })
    }
}

/// Why the data do not determine a model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
#[non_exhaustive]
pub enum Undetermined {
    /// Fewer distinct speeds than the model has parameters.
    TooFewSpeeds {
        /// Distinct speeds in the data.
        distinct: usize,
        /// Distinct speeds the model needs (its number of parameters).
        needed: usize,
        /// The distinct speeds (m/s), increasing.
        speeds_m_s: Vec<f64>,
    },
    /// The Jacobian at the optimum is singular: some parameter does not change the fit.
    SingularJacobian,
    /// The column-scaled Jacobian's condition number exceeds [`CONDITION_LIMIT`].
    IllConditioned {
        /// Its condition number.
        condition_number: f64,
    },
    /// A fitted parameter is NaN or infinite.
    NonFinite {
        /// Parameter name.
        parameter: String,
    },
    /// A force (F_c, F_s or σ·v_max) exceeds [`MAGNITUDE_LIMIT`] × the largest friction
    /// measured.
    AbsurdMagnitude {
        /// Parameter name.
        parameter: String,
        /// The limit (N).
        limit_n: f64,
    },
    /// A standard error exceeds the largest friction measured (forces), or δ itself.
    AbsurdUncertainty {
        /// Parameter name.
        parameter: String,
        /// The limit (N for forces, 1 for δ).
        limit: f64,
    },
    /// v_s lies more than [`VS_OUTSIDE_FACTOR`] × below the slowest or above the fastest
    /// non-zero speed.
    VsOutsideData {
        /// Fitted v_s (m/s).
        vs_m_s: f64,
        /// Slowest non-zero speed (m/s).
        min_speed_m_s: f64,
        /// Fastest speed (m/s).
        max_speed_m_s: f64,
    },
    /// F_s < F_c by more than the standard error of F_s − F_c: a falling curve is not a
    /// Stribeck hump.
    StaticBelowCoulomb {
        /// F_s − F_c (N), negative.
        static_excess_n: f64,
        /// Its standard error (N), `None` without residual degrees of freedom.
        std_error_n: Option<f64>,
    },
}

impl Undetermined {
    /// Its code in the diagnostics catalogue.
    pub fn code(&self) -> Code {
        match self {
            Self::TooFewSpeeds { .. } => Code::TooFewFeeds,
            Self::SingularJacobian => Code::SingularJacobian,
            Self::IllConditioned { .. } => Code::IllConditioned,
            Self::NonFinite { .. } => Code::NonFinite,
            Self::AbsurdMagnitude { .. } => Code::AbsurdMagnitude,
            Self::AbsurdUncertainty { .. } => Code::AbsurdUncertainty,
            Self::VsOutsideData { .. } => Code::VsOutsideData,
            Self::StaticBelowCoulomb { .. } => Code::StaticBelowCoulomb,
        }
    }
}

/// "600 and 3000", "15, 45 and 135" (mm/min, up to 3 decimals, trailing zeros dropped).
pub(crate) fn feed_list(speeds_m_s: &[f64]) -> String {
    let f: Vec<String> = speeds_m_s
        .iter()
        .map(|v| {
            let s = format!("{:.3}", v / M_S_PER_MM_MIN);
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        })
        .collect();
    match f.as_slice() {
        [] => String::new(),
        [one] => one.clone(),
        [init @ .., last] => format!("{} and {last}", init.join(", ")),
    }
}

impl std::fmt::Display for Undetermined {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mm = |v: f64| v / M_S_PER_MM_MIN;
        match self {
            Self::TooFewSpeeds {
                distinct,
                needed,
                speeds_m_s,
            } => write!(
                f,
                "it needs at least {needed} distinct feeds; the data have {distinct} ({} mm/min)",
                feed_list(speeds_m_s)
            ),
            Self::SingularJacobian => f.write_str(
                "its Jacobian is singular: the data cannot separate its parameters (no visible \
                 hump, or the hump outside the measured feeds)",
            ),
            Self::IllConditioned { condition_number } => write!(
                f,
                "its Jacobian is ill-conditioned (condition number {condition_number:.2e} > \
                 {CONDITION_LIMIT:.0e}): its parameters trade off against each other"
            ),
            Self::NonFinite { parameter } => write!(f, "{parameter} is not finite"),
            Self::AbsurdMagnitude { parameter, limit_n } => write!(
                f,
                "{parameter} would exceed {MAGNITUDE_LIMIT} x the largest friction measured \
                 ({limit_n:.1} N)"
            ),
            Self::AbsurdUncertainty { parameter, limit } => {
                if parameter == "delta" {
                    write!(f, "the standard error of delta exceeds delta ({limit:.3})")
                } else {
                    write!(
                        f,
                        "the standard error of {parameter} exceeds the largest friction \
                         measured ({limit:.1} N)"
                    )
                }
            }
            Self::VsOutsideData {
                min_speed_m_s,
                max_speed_m_s,
                ..
            } => write!(
                f,
                "vs lands more than {VS_OUTSIDE_FACTOR} x outside the measured feeds \
                 ({:.3}-{:.3} mm/min): the hump is not in the data",
                mm(*min_speed_m_s),
                mm(*max_speed_m_s)
            ),
            Self::StaticBelowCoulomb {
                static_excess_n,
                std_error_n,
            } => match std_error_n {
                Some(se) => write!(
                    f,
                    "Fs is below Fc by {:.2} N, more than its standard error {se:.2} N: \
                     friction rises from the slowest feed, no Stribeck hump",
                    -static_excess_n
                ),
                None => write!(
                    f,
                    "Fs is below Fc by {:.2} N (no standard error to judge it): friction \
                     rises from the slowest feed, no Stribeck hump",
                    -static_excess_n
                ),
            },
        }
    }
}

/// A model the fit tried and refused, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Reduction {
    /// The refused model.
    pub refused: FrictionModel,
    /// Whether δ was free in the refused Stribeck curve.
    pub delta_free: bool,
    /// Its number of parameters.
    pub parameters: usize,
    /// Why the data do not determine it.
    pub reason: Undetermined,
}

impl Reduction {
    /// Its code in the diagnostics catalogue: the reason's.
    pub fn code(&self) -> Code {
        self.reason.code()
    }
}

impl std::fmt::Display for Reduction {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let name = match (self.refused, self.delta_free) {
            (FrictionModel::Stribeck, true) => "a Stribeck curve with delta free",
            (FrictionModel::Stribeck, false) => "a Stribeck curve",
            (FrictionModel::CoulombViscous, _) => "a Coulomb + viscous line",
            (FrictionModel::Coulomb, _) => "a Coulomb level",
        };
        write!(
            f,
            "{name} ({} parameters) is not determined: {}",
            self.parameters, self.reason
        )
    }
}

/// Representatives of the distinct speeds (m/s, magnitudes, increasing): a speed starts a new
/// group when it exceeds the group's first by more than [`DISTINCT_SPEED_TOLERANCE`]
/// (relative), or the group is at rest and it moves.
pub(crate) fn distinct_speeds(speed_m_s: &[f64]) -> Vec<f64> {
    let mut v: Vec<f64> = speed_m_s.iter().map(|s| s.abs()).collect();
    v.sort_by(f64::total_cmp);
    let mut out: Vec<f64> = Vec::new();
    for s in v {
        match out.last() {
            Some(&first) if s <= first * (1.0 + DISTINCT_SPEED_TOLERANCE) => {}
            _ => out.push(s),
        }
    }
    out
}

/// Non-negative least squares of y ≈ c_0 + c_1·u (c_1 held at 0 when `viscous` is false):
/// returns (c, which of c are free (not on their bound 0), SSR, (AᵀA)⁻¹ of the free columns
/// in their order, condition number of A's free columns scaled to unit norm).
pub(crate) struct LinearFit {
    pub c: [f64; 2],
    pub free: [bool; 2],
    pub ssr: f64,
    pub inv: Vec<Vec<f64>>,
    pub condition_number: f64,
}

pub(crate) fn fit_linear(u: &[f64], y: &[f64], viscous: bool) -> LinearFit {
    let n = u.len() as f64;
    let (su, suu) = (u.iter().sum::<f64>(), u.iter().map(|x| x * x).sum::<f64>());
    let sy = y.iter().sum::<f64>();
    let suy = u.iter().zip(y).map(|(a, b)| a * b).sum::<f64>();
    let ssr = |c: [f64; 2]| -> f64 {
        u.iter()
            .zip(y)
            .map(|(&a, &b)| (c[0] + c[1] * a - b).powi(2))
            .sum()
    };
    let mut cands: Vec<[f64; 2]> = vec![[sy / n, 0.0]];
    if viscous {
        let det = n * suu - su * su;
        if det > 0.0 {
            cands.push([(suu * sy - su * suy) / det, (n * suy - su * sy) / det]);
        }
        if suu > 0.0 {
            cands.push([0.0, suy / suu]);
        }
    }
    // The optimum is the unconstrained solution on its support; every feasible candidate is
    // admissible, so the feasible one of least SSR is it.
    let best = cands
        .into_iter()
        .filter(|c| c[0] >= 0.0 && c[1] >= 0.0)
        .map(|c| (ssr(c), c))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        // y ≥ 0 (magnitudes), so the mean is always feasible; keep a total answer anyway
        .unwrap_or((ssr([0.0, 0.0]), [0.0, 0.0]));
    let c = best.1;
    let sigma_free = viscous && c[1] > 0.0;
    let free = [c[0] > 0.0 || !sigma_free, sigma_free];
    let (inv, condition_number) = match free {
        [true, true] => {
            let det = n * suu - su * su;
            let r = su / (n * suu).sqrt();
            (
                vec![vec![suu / det, -su / det], vec![-su / det, n / det]],
                ((1.0 + r.abs()) / (1.0 - r.abs()).max(f64::MIN_POSITIVE)).sqrt(),
            )
        }
        [true, false] => (vec![vec![1.0 / n]], 1.0),
        [false, true] => (vec![vec![1.0 / suu]], 1.0),
        [false, false] => (vec![], 1.0),
    };
    LinearFit {
        c,
        free,
        ssr: best.0,
        inv,
        condition_number,
    }
}
