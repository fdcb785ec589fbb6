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
//! # Method
//! 1. Velocity and acceleration from the position: a Reinsch smoothing spline
//!    ([`crate::spline::smoothing_moments`]) with its half-power point at
//!    [`IdentParams::cutoff_hz`] is differentiated twice (paper 002 Eq. 5-6 use differences;
//!    at kHz sampling those swamp θ'' with quantisation noise).
//! 2. The torque is smoothed by the same filter, so both sides of the model see the same
//!    low-pass (exact for the terms linear in the signals; for the friction curve the error is
//!    second order in the velocity change over the filter's window).
//! 3. Samples slower than [`IdentParams::min_speed_mm_min`], or within
//!    [`IdentParams::reversal_guard_s`] of such a sample (reversals, starts, stops: the
//!    pre-sliding regime and the smeared friction sign change), are excluded.
//! 4. Separable least squares (variable projection): for a fixed v_s the model is linear in
//!    (J, T_c, T_s − T_c, σ, T_0), solved by SVD of the column-scaled regressor matrix; the
//!    residual sum of squares as a function of log v_s is scanned on a grid and refined by
//!    golden-section search (paper 002 Eq. 9-10 is the linear step for known v_s).
//! 5. Standard errors from the full Jacobian at the optimum (linear columns plus ∂/∂v_s),
//!    Cov = s²·(JᵀJ)⁻¹, with s² inflated by n/n_eff because the smoothing correlates
//!    neighbouring residuals (n_eff = 2·f_c·duration of the used samples).
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

use std::f64::consts::PI;

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::axis::AxisParams;
use crate::estimate::{estimate, Direction, EstimateError, EstimateParams};
use crate::lugre::sign;
use crate::spline::{alpha_for_cutoff, smoothing_moments, CubicSpline, SplineError};
use crate::stribeck::StribeckParams;
use crate::trace::{EffortKind, Trace};
use crate::units::{feed_m_s_to_mm_min, feed_mm_min_to_m_s};

/// Settings of the identification. The defaults suit a kHz synchronous trace of the test
/// planned by [`crate::plan::triangle_program`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct IdentParams {
    /// Half-power frequency of the smoothing applied to position and torque (Hz). `None`
    /// (default) takes min(30 Hz, f_sample/8).
    pub cutoff_hz: Option<f64>,
    /// Samples slower than this are pre-sliding or standstill and are excluded (mm/min).
    /// Default 1.
    pub min_speed_mm_min: f64,
    /// Samples within this time of a slow sample are excluded too (s): the smoothing smears
    /// the friction sign change over about 1/f_c. `None` (default) takes 1.5/f_c.
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
            cutoff_hz: None,
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
    /// A smoothing spline could not be built.
    #[error("{channel} spline: {error}")]
    Spline {
        /// Channel name.
        channel: &'static str,
        /// The spline's complaint.
        error: SplineError,
    },
    /// The constant-speed comparison could not estimate the groups.
    #[error("constant-speed groups: {0}")]
    Groups(#[from] EstimateError),
}

/// Samples prepared for the fit, one per position sample of the trace (SI, motor side).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Regressors {
    /// Table velocity v = z' (m/s).
    pub velocity_m_s: Vec<f64>,
    /// Motor angular acceleration θ'' = (2π/p)·z'' (rad/s²).
    pub angular_accel_rad_s2: Vec<f64>,
    /// Motor torque T (N·m), smoothed like the position.
    pub torque_nm: Vec<f64>,
}

impl Regressors {
    /// Append one sample.
    pub fn push(&mut self, velocity_m_s: f64, angular_accel_rad_s2: f64, torque_nm: f64) {
        self.velocity_m_s.push(velocity_m_s);
        self.angular_accel_rad_s2.push(angular_accel_rad_s2);
        self.torque_nm.push(torque_nm);
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.velocity_m_s.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.velocity_m_s.is_empty()
    }
}

/// One parameter set of the torque model, motor side, with standard errors and diagnostics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TorqueFit {
    /// Total inertia on the motor shaft J (kg·m²).
    pub j_total_kgm2: f64,
    /// Coulomb friction torque T_c (N·m).
    pub tc_nm: f64,
    /// Static friction torque T_s (N·m).
    pub ts_nm: f64,
    /// Stribeck velocity v_s (mm/min of table feed).
    pub vs_mm_min: f64,
    /// Viscous coefficient σ (N·m per m/s of table velocity).
    pub sigma_nm_s_per_m: f64,
    /// Constant torque T_0 (N·m); 0 when not fitted.
    pub offset_nm: f64,
    /// Shape exponent δ (fixed).
    pub delta: f64,
    /// Standard errors of the same quantities.
    pub std_error: TorqueStdError,
    /// RMS of measured − model over the used samples (N·m).
    pub residual_rms_nm: f64,
    /// Condition number of the column-scaled Jacobian at the optimum.
    pub condition_number: f64,
    /// Evaluations of the separable residual (grid + golden section).
    pub iterations: usize,
    /// Samples in the fit.
    pub samples_used: usize,
    /// True when v_s ended at a bound of its search interval (then it is not resolved).
    pub vs_at_bound: bool,
}

/// Standard errors (1σ) of a [`TorqueFit`], same units.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TorqueStdError {
    /// Of J (kg·m²).
    pub j_total_kgm2: f64,
    /// Of T_c (N·m).
    pub tc_nm: f64,
    /// Of T_s (N·m).
    pub ts_nm: f64,
    /// Of v_s (mm/min).
    pub vs_mm_min: f64,
    /// Of σ (N·m·s/m).
    pub sigma_nm_s_per_m: f64,
    /// Of T_0 (N·m).
    pub offset_nm: f64,
}

impl TorqueFit {
    /// Friction torque of the fitted model at table velocity v (N·m), T_0 included.
    pub fn friction_torque_nm(&self, velocity_m_s: f64) -> f64 {
        let s = velocity_m_s.abs();
        let vs = feed_mm_min_to_m_s(self.vs_mm_min);
        let sgn = sign(velocity_m_s);
        sgn * (self.tc_nm + (self.ts_nm - self.tc_nm) * (-(s / vs).powf(self.delta)).exp())
            + self.sigma_nm_s_per_m * velocity_m_s
            + self.offset_nm
    }

    /// Model torque J·θ'' + T_f(v) (N·m).
    pub fn torque_nm(&self, velocity_m_s: f64, angular_accel_rad_s2: f64) -> f64 {
        self.j_total_kgm2 * angular_accel_rad_s2 + self.friction_torque_nm(velocity_m_s)
    }

    /// The friction curve on the table side, F = (2π/p)·T (paper 002 Eq. 3), for a lead `lead_m`.
    pub fn stribeck(&self, lead_m: f64) -> StribeckParams {
        let k = 2.0 * PI / lead_m;
        StribeckParams {
            fc_n: k * self.tc_nm,
            fs_n: k * self.ts_nm,
            vs_m_s: feed_mm_min_to_m_s(self.vs_mm_min),
            sigma_n_s_per_m: k * self.sigma_nm_s_per_m,
            delta: self.delta,
        }
    }
}

/// Force-side view of a fit (table side, F = (2π/p)·T).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ForceSide {
    /// Coulomb friction F_c (N).
    pub fc_n: f64,
    /// Static friction F_s (N).
    pub fs_n: f64,
    /// Viscous coefficient σ (N·s/m).
    pub sigma_n_s_per_m: f64,
    /// Stribeck velocity (mm/min).
    pub vs_mm_min: f64,
    /// Constant force F_0 (N).
    pub offset_n: f64,
    /// Equivalent translational mass J·(2π/p)² (kg).
    pub equivalent_mass_kg: f64,
    /// Standard error of F_c (N).
    pub fc_std_n: f64,
    /// Standard error of F_s (N).
    pub fs_std_n: f64,
    /// Standard error of σ (N·s/m).
    pub sigma_std_n_s_per_m: f64,
}

impl ForceSide {
    /// Convert a motor-side fit with the screw lead `lead_m`.
    pub fn from_fit(fit: &TorqueFit, lead_m: f64) -> Self {
        let k = 2.0 * PI / lead_m;
        Self {
            fc_n: k * fit.tc_nm,
            fs_n: k * fit.ts_nm,
            sigma_n_s_per_m: k * fit.sigma_nm_s_per_m,
            vs_mm_min: fit.vs_mm_min,
            offset_n: k * fit.offset_nm,
            equivalent_mass_kg: fit.j_total_kgm2 * k * k,
            fc_std_n: k * fit.std_error.tc_nm,
            fs_std_n: k * fit.std_error.ts_nm,
            sigma_std_n_s_per_m: k * fit.std_error.sigma_nm_s_per_m,
        }
    }
}

/// Result of [`identify`]: the fit, its force-side view, the series for plotting and
/// diagnostics.
#[derive(Debug, Clone, PartialEq)]
pub struct Identification {
    /// The motor-side fit.
    pub fit: TorqueFit,
    /// The same on the table side.
    pub force: ForceSide,
    /// J_total the axis file predicts, J + m_t·(p/2π)² (kg·m²), for comparison.
    pub axis_j_total_kgm2: f64,
    /// Smoothing cut-off used (Hz).
    pub cutoff_hz: f64,
    /// Reversal guard used (s).
    pub reversal_guard_s: f64,
    /// Mean position sampling interval (s).
    pub sample_interval_s: f64,
    /// Position samples in the trace.
    pub samples_total: usize,
    /// Times of the position samples (s).
    pub time_s: Vec<f64>,
    /// The smoothed regressors at those times.
    pub regressors: Regressors,
    /// Whether each sample was used in the fit.
    pub used: Vec<bool>,
    /// Model torque at each sample (N·m).
    pub computed_torque_nm: Vec<f64>,
    /// Things the user should know (unresolved v_s, large standard errors, …).
    pub warnings: Vec<String>,
}

fn check_params(p: &IdentParams) -> Result<(), IdentError> {
    let bad = |name, value, reason| {
        Err(IdentError::InvalidParam {
            name,
            value,
            reason,
        })
    };
    if let Some(c) = p.cutoff_hz {
        if !(c.is_finite() && c > 0.0) {
            return bad("cutoff_hz", c, "must be finite and > 0");
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

/// Smoothed values and their first and second derivatives at the knots of one channel.
struct Smoothed {
    value: Vec<f64>,
    d1: Vec<f64>,
    d2: Vec<f64>,
}

fn smooth(
    t: &[f64],
    y: &[f64],
    cutoff_hz: f64,
    channel: &'static str,
) -> Result<Smoothed, IdentError> {
    let h = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
    // At or above ~0.4·f_sample the smoother would not smooth: interpolate.
    let alpha = if cutoff_hz * h >= 0.4 {
        0.0
    } else {
        alpha_for_cutoff(h, cutoff_hz)
    };
    let mut g = Vec::new();
    let m = smoothing_moments(t, y, alpha, &mut g)
        .map_err(|error| IdentError::Spline { channel, error })?;
    let s = CubicSpline::from_moments(t, &g, m)
        .map_err(|error| IdentError::Spline { channel, error })?;
    let mut v = Vec::with_capacity(t.len());
    let mut a = Vec::with_capacity(t.len());
    let mut val = Vec::with_capacity(t.len());
    let mut cur = s.cursor();
    for &tk in t {
        let (z, d1, d2) = cur.eval_all(tk);
        val.push(z);
        v.push(d1);
        a.push(d2);
    }
    Ok(Smoothed {
        value: val,
        d1: v,
        d2: a,
    })
}

/// Identify J, T_c, T_s, v_s, σ (and T_0) from one trace of position and torque or current.
///
/// The effort channel may have its own timestamps: it is smoothed on its own knots and read
/// at the position times (samples outside its span are not used).
///
/// # Errors
/// [`IdentError::NotIdentifiable`] when the trace has no reversal (both directions are needed
/// to separate friction from a constant torque), fewer than
/// [`IdentParams::min_speed_octaves`] speed octaves, or no acceleration; parameter and spline
/// errors.
pub fn identify(
    trace: &Trace,
    axis: &AxisParams,
    params: &IdentParams,
) -> Result<Identification, IdentError> {
    check_params(params)?;
    let tp = &trace.position_m.time_s;
    let n = tp.len();
    if n < 8 || trace.effort.len() < 8 {
        return Err(IdentError::NotIdentifiable {
            reason: format!(
                "too few samples ({n} position, {} effort; at least 8 each)",
                trace.effort.len()
            ),
        });
    }
    let h = (tp[n - 1] - tp[0]) / (n - 1) as f64;
    let cutoff = params
        .cutoff_hz
        .unwrap_or_else(|| (30.0f64).min(1.0 / (8.0 * h)));
    let guard = params.reversal_guard_s.unwrap_or(1.5 / cutoff);

    // Step 1: velocity and acceleration from the smoothed position.
    let Smoothed {
        d1: vel, d2: acc, ..
    } = smooth(tp, &trace.position_m.value, cutoff, "position")?;
    // Step 2: the torque through the same smoother.
    let ke = match trace.effort_kind {
        EffortKind::CurrentA => axis.torque_constant_nm_per_a,
        EffortKind::TorqueNm => 1.0,
    };
    let te = &trace.effort.time_s;
    let torque_raw: Vec<f64> = trace.effort.value.iter().map(|e| e * ke).collect();
    let torque_s = smooth(te, &torque_raw, cutoff, "torque")?.value;
    let synchronous = te == tp;
    let mut torque = vec![f64::NAN; n];
    if synchronous {
        torque.copy_from_slice(&torque_s);
    } else {
        let s = CubicSpline::new(te, &torque_s, crate::spline::EndCondition::NotAKnot).map_err(
            |error| IdentError::Spline {
                channel: "torque",
                error,
            },
        )?;
        let mut c = s.cursor();
        for (k, &t) in tp.iter().enumerate() {
            if t >= te[0] && t <= te[te.len() - 1] {
                torque[k] = c.eval(t);
            }
        }
    }

    let k_rad = 2.0 * PI / axis.lead_m();
    let mut reg = Regressors::default();
    for k in 0..n {
        reg.push(vel[k], k_rad * acc[k], torque[k]);
    }

    // Step 3: exclude slow samples and those near them (reversals, starts, stops) and the
    // spline's end regions.
    let v_min = feed_mm_min_to_m_s(params.min_speed_mm_min);
    let slow: Vec<bool> = vel.iter().map(|v| v.abs() < v_min).collect();
    let mut used = vec![true; n];
    let mut last_slow = f64::NEG_INFINITY;
    for k in 0..n {
        if slow[k] {
            last_slow = tp[k];
        }
        if tp[k] - last_slow < guard {
            used[k] = false;
        }
    }
    let mut next_slow = f64::INFINITY;
    for k in (0..n).rev() {
        if slow[k] {
            next_slow = tp[k];
        }
        if next_slow - tp[k] < guard
            || tp[k] - tp[0] < guard
            || tp[n - 1] - tp[k] < guard
            || !torque[k].is_finite()
        {
            used[k] = false;
        }
    }
    // A sign change between two samples without a slow sample (fast reversal at coarse
    // sampling) is guarded too.
    for k in 1..n {
        // (Slow samples are guarded already; skipping them keeps a noisy standstill cheap.)
        if !slow[k] && !slow[k - 1] && sign(vel[k]) * sign(vel[k - 1]) < 0.0 {
            let tr = 0.5 * (tp[k] + tp[k - 1]);
            let lo = tp.partition_point(|&t| t < tr - guard);
            let hi = tp.partition_point(|&t| t <= tr + guard);
            used[lo..hi].iter_mut().for_each(|u| *u = false);
        }
    }

    let mut sub = Regressors::default();
    for k in (0..n).filter(|&k| used[k]) {
        sub.push(
            reg.velocity_m_s[k],
            reg.angular_accel_rad_s2[k],
            reg.torque_nm[k],
        );
    }
    check_excitation(&sub, params, guard, true)?;

    // Step 4-5.
    let mut fit = fit_torque(&sub, params)?;
    let used_time: f64 = (1..n)
        .filter(|&k| used[k] && used[k - 1])
        .map(|k| tp[k] - tp[k - 1])
        .sum();
    let n_eff = (2.0 * cutoff * used_time).max(8.0);
    let inflate = (sub.len() as f64 / n_eff).max(1.0).sqrt();
    let se = &mut fit.std_error;
    for x in [
        &mut se.j_total_kgm2,
        &mut se.tc_nm,
        &mut se.ts_nm,
        &mut se.vs_mm_min,
        &mut se.sigma_nm_s_per_m,
        &mut se.offset_nm,
    ] {
        *x *= inflate;
    }

    let computed: Vec<f64> = (0..n)
        .map(|k| fit.torque_nm(reg.velocity_m_s[k], reg.angular_accel_rad_s2[k]))
        .collect();
    let mut warnings = fit_warnings(&fit);
    if cutoff < 5.0 {
        warnings.push(format!(
            "the smoothing cut-off is {cutoff:.2} Hz (sampling {:.1} Hz): acceleration phases \
             shorter than the {guard:.2} s guard are excluded or smeared, so J is unreliable; \
             sample at 80 Hz or more for J",
            1.0 / h
        ));
    }
    if !synchronous {
        warnings.push(
            "position and effort have different timestamps: the torque was interpolated to the \
             position times"
                .to_string(),
        );
    }
    let p = axis.lead_m();
    let axis_j = axis.inertia_kgm2 + axis.table_mass_kg * (p / (2.0 * PI)).powi(2);
    Ok(Identification {
        force: ForceSide::from_fit(&fit, p),
        fit,
        axis_j_total_kgm2: axis_j,
        cutoff_hz: cutoff,
        reversal_guard_s: guard,
        sample_interval_s: h,
        samples_total: n,
        time_s: tp.clone(),
        regressors: reg,
        used,
        computed_torque_nm: computed,
        warnings,
    })
}

fn fit_warnings(fit: &TorqueFit) -> Vec<String> {
    let mut w = Vec::new();
    if fit.vs_at_bound {
        w.push(format!(
            "the Stribeck velocity ended at a bound of its search ({:.3} mm/min): the test does \
             not resolve it; slower or faster levels are needed",
            fit.vs_mm_min
        ));
    }
    if fit.ts_nm < fit.tc_nm {
        w.push("T_s < T_c: no Stribeck drop was found; v_s is meaningless".to_string());
    }
    let rel = |x: f64, se: f64| se > 0.5 * x.abs();
    if rel(fit.j_total_kgm2, fit.std_error.j_total_kgm2) {
        w.push("J has a standard error above 50 %: too little acceleration".to_string());
    }
    if rel(fit.vs_mm_min, fit.std_error.vs_mm_min) {
        w.push("v_s has a standard error above 50 %".to_string());
    }
    w
}

/// Reject data that cannot identify the model, with a reason a user can act on.
fn check_excitation(
    r: &Regressors,
    params: &IdentParams,
    guard_s: f64,
    need_accel: bool,
) -> Result<(), IdentError> {
    let not = |reason: String| Err(IdentError::NotIdentifiable { reason });
    let n = r.len();
    if n < 20 {
        return not(format!(
            "only {n} samples remain after excluding speeds below {} mm/min and {guard_s:.3} s \
             around every slow sample (reversals, starts, stops); the strokes must cruise well \
             over {guard_s:.3} s: plan a longer --cruise-s, sample faster, or shorten the guard",
            params.min_speed_mm_min
        ));
    }
    let fwd = r.velocity_m_s.iter().filter(|&&v| v > 0.0).count();
    let bwd = n - fwd;
    if fwd.min(bwd) < 10 {
        return not(format!(
            "no motion reversal: {fwd} samples forward and {bwd} backward; friction and a \
             constant torque separate only when the axis moves both ways"
        ));
    }
    // Speed octaves that hold a real share of the samples.
    let mut bins = std::collections::BTreeMap::<i64, usize>::new();
    for v in &r.velocity_m_s {
        *bins
            .entry(feed_m_s_to_mm_min(v.abs()).log2().floor() as i64)
            .or_default() += 1;
    }
    let min_count = (n / 200).max(5);
    let octaves = bins.values().filter(|&&c| c >= min_count).count();
    if octaves < params.min_speed_octaves {
        return not(format!(
            "the speeds span only {octaves} octave(s) (at least {} needed): a Stribeck curve \
             cannot be fitted to one speed; run the test at several feeds",
            params.min_speed_octaves
        ));
    }
    if need_accel {
        let amax = r
            .angular_accel_rad_s2
            .iter()
            .fold(0.0f64, |m, a| m.max(a.abs()));
        let busy = r
            .angular_accel_rad_s2
            .iter()
            .filter(|a| a.abs() > 0.1 * amax)
            .count();
        if amax <= 0.0 || busy < 10 {
            return not(
                "no acceleration in the used samples: the inertia J cannot be identified"
                    .to_string(),
            );
        }
    }
    Ok(())
}

/// The separable least-squares problem: fixed columns (linear in the data) plus the Stribeck
/// column sgn(v)·exp(−(|v|/v_s)^δ) whose shape depends on v_s.
struct Separable<'a> {
    /// Columns that do not depend on v_s, each of length n.
    fixed: Vec<Vec<f64>>,
    v: &'a [f64],
    y: &'a [f64],
    delta: f64,
}

struct LinSolve {
    theta: Vec<f64>,
    rss: f64,
}

impl Separable<'_> {
    fn stribeck_col(&self, vs: f64) -> Vec<f64> {
        self.v
            .iter()
            .map(|&v| sign(v) * (-(v.abs() / vs).powf(self.delta)).exp())
            .collect()
    }

    /// Design matrix with columns scaled to unit norm; returns it and the scales.
    fn design(&self, extra: &[Vec<f64>]) -> (DMatrix<f64>, Vec<f64>) {
        let n = self.y.len();
        let cols: Vec<&Vec<f64>> = self.fixed.iter().chain(extra.iter()).collect();
        let mut scales = Vec::with_capacity(cols.len());
        let mut a = DMatrix::zeros(n, cols.len());
        for (j, c) in cols.iter().enumerate() {
            let norm = c.iter().map(|x| x * x).sum::<f64>().sqrt();
            let s = if norm > 0.0 { 1.0 / norm } else { 1.0 };
            scales.push(s);
            for i in 0..n {
                a[(i, j)] = c[i] * s;
            }
        }
        (a, scales)
    }

    /// Residual sum of squares at fixed v_s from the normal equations of the column-scaled
    /// problem (k × k, cheap); used by the search, [`Separable::solve`] gives the answer.
    fn rss_fast(&self, vs: f64) -> f64 {
        let sc = self.stribeck_col(vs);
        let cols: Vec<&[f64]> = self
            .fixed
            .iter()
            .map(|c| c.as_slice())
            .chain(std::iter::once(sc.as_slice()))
            .collect();
        let k = cols.len();
        let scale: Vec<f64> = cols
            .iter()
            .map(|c| {
                let n = c.iter().map(|x| x * x).sum::<f64>().sqrt();
                if n > 0.0 {
                    1.0 / n
                } else {
                    1.0
                }
            })
            .collect();
        let mut g = DMatrix::<f64>::zeros(k, k);
        let mut rhs = DVector::<f64>::zeros(k);
        for i in 0..k {
            for j in i..k {
                let s: f64 = cols[i].iter().zip(cols[j]).map(|(a, b)| a * b).sum();
                g[(i, j)] = s * scale[i] * scale[j];
                g[(j, i)] = g[(i, j)];
            }
            rhs[i] = cols[i].iter().zip(self.y).map(|(a, b)| a * b).sum::<f64>() * scale[i];
        }
        let svd = g.svd(true, true);
        let eps = 1e-13 * svd.singular_values.max();
        let x = match svd.solve(&rhs, eps) {
            Ok(x) => x,
            Err(_) => return f64::INFINITY,
        };
        let mut rss = 0.0;
        for (i, &yi) in self.y.iter().enumerate() {
            let mut m = 0.0;
            for j in 0..k {
                m += cols[j][i] * scale[j] * x[j];
            }
            rss += (yi - m) * (yi - m);
        }
        rss
    }

    /// Linear least squares at fixed v_s; θ in the column order fixed…, Stribeck.
    fn solve(&self, vs: f64) -> LinSolve {
        let sc = self.stribeck_col(vs);
        let (a, scales) = self.design(std::slice::from_ref(&sc));
        let b = DVector::from_column_slice(self.y);
        let svd = a.clone().svd(true, true);
        let eps = 1e-12 * svd.singular_values.max();
        let x = svd
            .solve(&b, eps)
            .unwrap_or_else(|_| DVector::zeros(a.ncols()));
        let r = &b - &a * &x;
        LinSolve {
            theta: x.iter().zip(&scales).map(|(x, s)| x * s).collect(),
            rss: r.norm_squared(),
        }
    }

    /// Grid over log v_s and golden-section refinement. Returns (v_s, solve, evaluations,
    /// at_bound).
    fn minimise(&self, lo: f64, hi: f64, points: usize) -> (f64, LinSolve, usize, bool) {
        let (l0, l1) = (lo.ln(), hi.ln());
        let grid: Vec<f64> = (0..points)
            .map(|k| l0 + (l1 - l0) * k as f64 / (points - 1) as f64)
            .collect();
        let rss: Vec<f64> = grid.iter().map(|&g| self.rss_fast(g.exp())).collect();
        let mut evals = points;
        let best = (0..points)
            .min_by(|&a, &b| rss[a].total_cmp(&rss[b]))
            .unwrap_or(0);
        let (mut a, mut b) = (
            grid[best.saturating_sub(1)],
            grid[(best + 1).min(points - 1)],
        );
        // Golden section on log v_s inside the bracketing grid cells.
        let gr = 0.5 * (5f64.sqrt() - 1.0);
        let mut c = b - gr * (b - a);
        let mut d = a + gr * (b - a);
        let mut fc = self.rss_fast(c.exp());
        let mut fd = self.rss_fast(d.exp());
        evals += 2;
        while (b - a) > 1e-7 {
            if fc < fd {
                b = d;
                d = c;
                fd = fc;
                c = b - gr * (b - a);
                fc = self.rss_fast(c.exp());
            } else {
                a = c;
                c = d;
                fc = fd;
                d = a + gr * (b - a);
                fd = self.rss_fast(d.exp());
            }
            evals += 1;
        }
        let mut lv = 0.5 * (a + b);
        let mut sol = self.solve(lv.exp());
        evals += 1;
        if rss[best] < self.rss_fast(lv.exp()) {
            lv = grid[best];
            sol = self.solve(lv.exp());
        }
        let at_bound = (lv - l0).abs() < 1e-3 || (lv - l1).abs() < 1e-3;
        (lv.exp(), sol, evals, at_bound)
    }

    /// Covariance factor (JᵀJ)⁻¹ of all parameters (fixed…, Stribeck amplitude, v_s) and the
    /// condition number of the scaled Jacobian.
    fn covariance(&self, vs: f64, amplitude: f64) -> (DMatrix<f64>, f64) {
        let sc = self.stribeck_col(vs);
        let dvs: Vec<f64> = self
            .v
            .iter()
            .zip(&sc)
            .map(|(&v, &e)| {
                let u = (v.abs() / vs).powf(self.delta);
                amplitude * e * self.delta * u / vs
            })
            .collect();
        let (a, scales) = self.design(&[sc, dvs]);
        let svd = a.svd(false, true);
        let smax = svd.singular_values.max();
        let smin = svd.singular_values.min();
        let cond = if smin > 0.0 {
            smax / smin
        } else {
            f64::INFINITY
        };
        let vt = svd.v_t.expect("v_t was requested");
        let p = scales.len();
        let mut cov = DMatrix::zeros(p, p);
        for i in 0..p {
            for j in 0..p {
                let mut s = 0.0;
                for k in 0..p {
                    let sk = svd.singular_values[k];
                    if sk > 1e-14 * smax {
                        s += vt[(k, i)] * vt[(k, j)] / (sk * sk);
                    }
                }
                cov[(i, j)] = s * scales[i] * scales[j];
            }
        }
        (cov, cond)
    }
}

/// Fit the torque model of the module docs to prepared samples (all of them are used).
///
/// # Errors
/// [`IdentError::InvalidParam`] for bad settings; [`IdentError::NotIdentifiable`] for fewer
/// samples than parameters.
pub fn fit_torque(r: &Regressors, params: &IdentParams) -> Result<TorqueFit, IdentError> {
    check_params(params)?;
    let n = r.len();
    let mut fixed = vec![
        r.angular_accel_rad_s2.clone(),
        r.velocity_m_s.iter().map(|&v| sign(v)).collect(),
        r.velocity_m_s.clone(),
    ];
    if params.fit_offset {
        fixed.push(vec![1.0; n]);
    }
    let p = fixed.len() + 2;
    if n <= p {
        return Err(IdentError::NotIdentifiable {
            reason: format!("{n} samples for {p} parameters"),
        });
    }
    let sep = Separable {
        fixed,
        v: &r.velocity_m_s,
        y: &r.torque_nm,
        delta: params.delta,
    };
    let (vs, sol, evals, at_bound) = sep.minimise(
        feed_mm_min_to_m_s(params.vs_min_mm_min),
        feed_mm_min_to_m_s(params.vs_max_mm_min),
        params.vs_grid_points,
    );
    let th = &sol.theta;
    let (j, tc, sigma) = (th[0], th[1], th[2]);
    let offset = if params.fit_offset { th[3] } else { 0.0 };
    let ds = th[th.len() - 1];
    let (cov, cond) = sep.covariance(vs, ds);
    let s2 = sol.rss / (n - p) as f64;
    let var = |i: usize| (cov[(i, i)] * s2).max(0.0).sqrt();
    let ia = p - 2; // Stribeck amplitude
    let iv = p - 1; // v_s
    let ts_se = ((cov[(1, 1)] + cov[(ia, ia)] + 2.0 * cov[(1, ia)]) * s2)
        .max(0.0)
        .sqrt();
    Ok(TorqueFit {
        j_total_kgm2: j,
        tc_nm: tc,
        ts_nm: tc + ds,
        vs_mm_min: feed_m_s_to_mm_min(vs),
        sigma_nm_s_per_m: sigma,
        offset_nm: offset,
        delta: params.delta,
        std_error: TorqueStdError {
            j_total_kgm2: var(0),
            tc_nm: var(1),
            ts_nm: ts_se,
            vs_mm_min: feed_m_s_to_mm_min(var(iv)),
            sigma_nm_s_per_m: var(2),
            offset_nm: if params.fit_offset { var(3) } else { 0.0 },
        },
        residual_rms_nm: (sol.rss / n as f64).sqrt(),
        condition_number: cond,
        iterations: evals,
        samples_used: n,
        vs_at_bound: at_bound,
    })
}

/// One constant-speed group: the mean friction of one stroke of the traditional test.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Group {
    /// Stroke number in the trace.
    pub stroke: usize,
    /// Direction of travel.
    pub direction: Direction,
    /// Measured plateau feed (mm/min, unsigned).
    pub feed_mm_min: f64,
    /// Mean friction torque of the stroke, signed with the direction, bearing damping
    /// included so that it is comparable with the one-test σ (N·m).
    pub friction_torque_nm: f64,
}

/// The traditional identification (paper 002 Section 2.2.1): the same friction model fitted
/// to the mean friction of constant-speed strokes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GroupFit {
    /// The groups used.
    pub groups: Vec<Group>,
    /// The fit (J is not identified by constant-speed groups and is reported as 0).
    pub fit: TorqueFit,
}

/// Fit the friction model to constant-speed groups of a trace of idle strokes (paper 000's
/// test): each stroke's mean friction from [`crate::estimate::estimate`] at its feed.
///
/// Eq. 5 of paper 000 removes the bearing damping (4π²B/p²)·v from the friction; it is added
/// back so that σ means the same as in [`identify`] (all viscous losses).
///
/// # Errors
/// Estimation errors; [`IdentError::NotIdentifiable`] with fewer than six groups, without
/// both directions, or with speeds spanning fewer than three distinct feeds.
pub fn fit_groups(
    trace: &Trace,
    axis: &AxisParams,
    params: &IdentParams,
    estimate_params: &EstimateParams,
) -> Result<GroupFit, IdentError> {
    check_params(params)?;
    let est = estimate(trace, axis, estimate_params)?;
    let to_torque = axis.lead_m() / (2.0 * PI);
    let b_eq = axis.equivalent_damping_n_s_per_m();
    let groups: Vec<Group> = est
        .strokes
        .iter()
        .map(|s| {
            let sgn = match s.summary.direction {
                Direction::Forward => 1.0,
                Direction::Backward => -1.0,
            };
            let v = feed_mm_min_to_m_s(sgn * s.summary.feed_mm_min);
            Group {
                stroke: s.summary.stroke,
                direction: s.summary.direction,
                feed_mm_min: s.summary.feed_mm_min,
                friction_torque_nm: (s.summary.mean_friction_n + b_eq * v) * to_torque,
            }
        })
        .collect();
    let mut r = Regressors::default();
    for g in &groups {
        let sgn = match g.direction {
            Direction::Forward => 1.0,
            Direction::Backward => -1.0,
        };
        r.push(
            feed_mm_min_to_m_s(sgn * g.feed_mm_min),
            0.0,
            g.friction_torque_nm,
        );
    }
    let fwd = r.velocity_m_s.iter().filter(|&&v| v > 0.0).count();
    let mut feeds: Vec<f64> = groups.iter().map(|g| g.feed_mm_min).collect();
    feeds.sort_by(f64::total_cmp);
    // Feeds within 5 % count as one speed.
    let distinct = feeds.windows(2).filter(|w| w[1] > 1.05 * w[0]).count() + 1;
    if groups.len() < 6 || fwd == 0 || fwd == groups.len() || distinct < 3 {
        return Err(IdentError::NotIdentifiable {
            reason: format!(
                "constant-speed groups: {} strokes ({fwd} forward) at {distinct} distinct \
                 feed(s); at least 6 strokes, both directions and 3 feeds are needed",
                groups.len()
            ),
        });
    }
    let mut fixed = vec![
        r.velocity_m_s
            .iter()
            .map(|&v| sign(v))
            .collect::<Vec<f64>>(),
        r.velocity_m_s.clone(),
    ];
    if params.fit_offset {
        fixed.push(vec![1.0; r.len()]);
    }
    let p = fixed.len() + 2;
    let sep = Separable {
        fixed,
        v: &r.velocity_m_s,
        y: &r.torque_nm,
        delta: params.delta,
    };
    let (vs, sol, evals, at_bound) = sep.minimise(
        feed_mm_min_to_m_s(params.vs_min_mm_min),
        feed_mm_min_to_m_s(params.vs_max_mm_min),
        params.vs_grid_points,
    );
    let th = &sol.theta;
    let ds = th[th.len() - 1];
    let (cov, cond) = sep.covariance(vs, ds);
    let n = r.len();
    let s2 = if n > p {
        sol.rss / (n - p) as f64
    } else {
        f64::NAN
    };
    let var = |i: usize| (cov[(i, i)] * s2).max(0.0).sqrt();
    let ia = p - 2;
    let fit = TorqueFit {
        j_total_kgm2: 0.0,
        tc_nm: th[0],
        ts_nm: th[0] + ds,
        vs_mm_min: feed_m_s_to_mm_min(vs),
        sigma_nm_s_per_m: th[1],
        offset_nm: if params.fit_offset { th[2] } else { 0.0 },
        delta: params.delta,
        std_error: TorqueStdError {
            j_total_kgm2: 0.0,
            tc_nm: var(0),
            ts_nm: ((cov[(0, 0)] + cov[(ia, ia)] + 2.0 * cov[(0, ia)]) * s2)
                .max(0.0)
                .sqrt(),
            vs_mm_min: feed_m_s_to_mm_min(var(p - 1)),
            sigma_nm_s_per_m: var(1),
            offset_nm: if params.fit_offset { var(2) } else { 0.0 },
        },
        residual_rms_nm: (sol.rss / n as f64).sqrt(),
        condition_number: cond,
        iterations: evals,
        samples_used: n,
        vs_at_bound: at_bound,
    };
    Ok(GroupFit { groups, fit })
}
