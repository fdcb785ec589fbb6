//! One-test identification of the Stribeck friction and the total inertia from a single
//! variable-amplitude, variable-velocity triangular-wave test (paper 002).
//!
//! # Model (paper 002 Eq. 7 with Eq. 1, motor side, table velocity v)
//!
//! T = J·θ'' + sgn(v)·[T_c + (T_s − T_c)·exp(−(|v|/v_s)^δ)] + σ·v + T_0
//!
//! with T the motor torque (N·m), θ'' = (2π/p)·z'' the motor's angular acceleration (rad/s²),
//! J the total inertia on the motor shaft (kg·m², motor + screw + table reflected:
//! J_m + m_t·(p/2π)²), v = z' the table velocity (m/s), T_c and T_s the Coulomb and static
//! friction torques (N·m), v_s the Stribeck velocity, σ the viscous coefficient (N·m per m/s,
//! all viscous losses including bearing damping, as in paper 002), δ the shape exponent
//! (fixed, default 2) and T_0 an optional constant torque (gravity on an inclined axis, or the
//! mean of an asymmetric Coulomb level; paper 002 has none). Force-side values follow from
//! F = (2π/p)·T (paper 002 Eq. 3).
//!
//! # Method (the joint fit)
//! 1. **Kernel rows.** For each position sample t_k and a half-width of m samples, the
//!    second divided difference ā_k = 2·z[t_{k−m}, t_k, t_{k+m}] is *exactly* the average of
//!    the table acceleration weighted by the hat kernel M_k with knots t_{k−m}, t_k, t_{k+m}
//!    (see `kernel.rs`). The torque samples are averaged with the same kernel
//!    (T̄_k = Σ w_ki·T_i, exact for T linear between samples), and so are the friction
//!    columns, evaluated at the central-difference velocity v̂_i. The model averaged with M_k,
//!    T̄_k = J·(2π/p)·ā_k + (K·T_f(v̂))_k, has J on an exactly known regressor: no smoothing
//!    of the trajectory, no blurred acceleration steps. m = round([`IdentParams::kernel_half_width_s`]/Δt),
//!    at least 1 (one sample at paper 002's 83.33 Hz; paper 002 Eq. 5-6 are the m = 1
//!    differences).
//! 2. **Exclusions.** Standstill (|v̂| below [`IdentParams::min_speed_mm_min`] or less than
//!    1.5 position quanta over the difference window) and sign changes of v̂ are events at
//!    which the friction is not a function of v̂ (pre-sliding, the sign step); a row is
//!    excluded when an event lies within [`IdentParams::reversal_guard_s`] (default 3·m·Δt)
//!    or within its support. Everything else is used, including the whole acceleration and
//!    deceleration phases of the reversals, which is where J is seen.
//! 3. **Separable least squares** (variable projection): for a fixed v_s the rows are linear
//!    in (J, T_c, T_s − T_c, σ, T_0), solved by SVD of the column-scaled regressor matrix
//!    (paper 002 Eq. 9-10 is this linear step); the residual as a function of log v_s is
//!    scanned on a grid and refined by golden-section search.
//! 4. **Standard errors** from the full Jacobian X at the optimum (linear columns plus
//!    ∂/∂v_s) in the sandwich form that the kernel requires: neighbouring rows share torque
//!    samples, so with white sample noise of variance s² the rows' noise covariance is
//!    s²·KKᵀ and Cov = s²·C·XᵀKKᵀX·C, C = (XᵀX)⁻¹, with s² = RSS/(tr KKᵀ − tr(C·XᵀKKᵀX))
//!    (the unbiased estimate under that noise model). Model error (a friction ripple along
//!    the travel, a wrong δ) is not in them.
//!
//! # Example
//! ```
//! use feedscope::ident::{fit_torque, IdentParams, Regressors};
//! // Exact data of T = 0.01·θ'' + sgn v·[0.5 + 0.2·exp(−(|v|/2e-3)²)] + 30·v.
//! let mut r = Regressors::default();
//! for k in 0..400 {
//!     let v = (k as f64 - 200.0) * 1e-4 + 5e-5; // −20 … 20 mm/s
//!     let th_dd = 50.0 * ((k as f64) * 0.37).sin();
//!     let f = v.signum() * (0.5 + 0.2 * (-(v.abs() / 2e-3).powi(2)).exp()) + 30.0 * v;
//!     r.push(v, th_dd, 0.01 * th_dd + f);
//! }
//! let fit = fit_torque(&r, &IdentParams::default()).unwrap();
//! assert!((fit.j_total_kgm2 - 0.01).abs() < 1e-9);
//! assert!((fit.tc_nm - 0.5).abs() < 1e-8 && (fit.ts_nm - 0.7).abs() < 1e-8);
//! assert!((fit.vs_mm_min - 120.0).abs() < 1e-4);
//! ```
//!
//! # Reference
//! Paper 002 (rapid evaluation of feed-axis lubrication): Eq. 1 (Stribeck curve), Eq. 3 and 7
//! (drive torque), Eq. 5-6 (velocity and acceleration from position), Eq. 8 (triangular-wave
//! test, see [`crate::plan`]), Eq. 9-10 (least squares), Section 3.2 (comparison with
//! constant-speed groups).
//!
//! # Operations (one file each)
//! - `model.rs`: the regressors ([`Regressors`]) and the fitted model ([`TorqueFit`],
//!   [`ForceSide`]).
//! - `triangle.rs`: identification from a triangular-wave trace ([`identify`]).
//! - `kernel.rs`: the hat-kernel rows (divided differences and matching torque averages).
//! - `fit.rs`: the separable least-squares fit ([`fit_torque`] pointwise, and the kernel
//!   rows' joint fit with its sandwich standard errors).
//! - `groups.rs`: the constant-speed comparison ([`fit_groups`]).

mod fit;
mod groups;
mod kernel;
mod model;
mod triangle;

pub use fit::fit_torque;
pub use groups::{fit_groups, Group, GroupFit};
pub use model::{ForceSide, Regressors, TorqueFit, TorqueStdError};
pub use triangle::{identify, Identification};

use serde::{Deserialize, Serialize};

use crate::estimate::EstimateError;

/// Settings of the identification. The defaults suit a synchronous trace (83 Hz to kHz) of
/// the test planned by [`crate::plan::triangle_program`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct IdentParams {
    /// Half-width of the hat kernel (s), rounded to m ≥ 1 sampling intervals. `None`
    /// (default) takes 10 ms: m = 1 at 83 Hz, m = 10 at 1 kHz.
    pub kernel_half_width_s: Option<f64>,
    /// Samples slower than this are pre-sliding or standstill and are excluded (mm/min).
    /// Default 1.
    pub min_speed_mm_min: f64,
    /// Rows within this time of a slow sample or a velocity sign change are excluded too (s).
    /// `None` (default) takes three kernel half-widths, 3·m·Δt.
    pub reversal_guard_s: Option<f64>,
    /// Stribeck shape exponent δ, held fixed. Default 2.
    pub delta: f64,
    /// Lower bound of the v_s search (mm/min). Default 0.5.
    pub vs_min_mm_min: f64,
    /// Upper bound of the v_s search (mm/min). Default 5000.
    pub vs_max_mm_min: f64,
    /// Points of the logarithmic v_s grid before the golden-section refinement. Default 60.
    pub vs_grid_points: usize,
    /// Fit a constant torque T_0 (gravity, asymmetric Coulomb level). Default true.
    pub fit_offset: bool,
    /// Fewest octaves of speed (bins |v| ∈ [2^k, 2^(k+1)) holding at least 0.5 % of the used
    /// samples) for the curve to be identifiable. Default 3.
    pub min_speed_octaves: usize,
}

impl Default for IdentParams {
    fn default() -> Self {
        Self {
            kernel_half_width_s: None,
            min_speed_mm_min: 1.0,
            reversal_guard_s: None,
            delta: 2.0,
            vs_min_mm_min: 0.5,
            vs_max_mm_min: 5000.0,
            vs_grid_points: 60,
            fit_offset: true,
            min_speed_octaves: 3,
        }
    }
}

/// Why identification failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum IdentError {
    /// The trace does not excite what the model needs.
    #[error("not identifiable: {reason}")]
    NotIdentifiable {
        /// What is missing, for the user (e.g. "no motion reversal").
        reason: String,
    },
    /// A parameter is outside its range.
    #[error("identification parameter `{name}` = {value}: {reason}")]
    InvalidParam {
        /// Parameter name.
        name: &'static str,
        /// Value given.
        value: f64,
        /// Why it is rejected.
        reason: &'static str,
    },
    /// The constant-speed comparison could not estimate the groups.
    #[error("constant-speed groups: {0}")]
    Groups(#[from] EstimateError),
}

/// Check the settings of the identification, before any data are read.
///
/// # Errors
/// [`IdentError::InvalidParam`] naming the first setting out of its range.
pub fn check_params(p: &IdentParams) -> Result<(), IdentError> {
    let bad = |name, value, reason| {
        Err(IdentError::InvalidParam {
            name,
            value,
            reason,
        })
    };
    if let Some(c) = p.kernel_half_width_s {
        if !(c.is_finite() && c > 0.0) {
            return bad("kernel_half_width_s", c, "must be finite and > 0");
        }
    }
    if !(p.min_speed_mm_min.is_finite() && p.min_speed_mm_min >= 0.0) {
        return bad(
            "min_speed_mm_min",
            p.min_speed_mm_min,
            "must be finite and ≥ 0",
        );
    }
    if let Some(g) = p.reversal_guard_s {
        if !(g.is_finite() && g >= 0.0) {
            return bad("reversal_guard_s", g, "must be finite and ≥ 0");
        }
    }
    if !(p.delta.is_finite() && p.delta > 0.0) {
        return bad("delta", p.delta, "must be finite and > 0");
    }
    if !(p.vs_min_mm_min.is_finite() && p.vs_min_mm_min > 0.0) {
        return bad("vs_min_mm_min", p.vs_min_mm_min, "must be finite and > 0");
    }
    if !(p.vs_max_mm_min.is_finite() && p.vs_max_mm_min > p.vs_min_mm_min) {
        return bad(
            "vs_max_mm_min",
            p.vs_max_mm_min,
            "must be finite and > vs_min_mm_min",
        );
    }
    if p.vs_grid_points < 3 {
        return bad(
            "vs_grid_points",
            p.vs_grid_points as f64,
            "must be at least 3",
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests;

impl IdentError {
    /// Always [`crate::ErrorKind::BadInput`]: the trace does not identify the parameters, or a
    /// parameter is invalid.
    pub fn kind(&self) -> crate::ErrorKind {
        crate::ErrorKind::BadInput
    }
}
