//! The torque model's regressors and its fitted parameters, motor side and table side.

use std::f64::consts::PI;

use serde::{Deserialize, Serialize};

use crate::lugre::sign;
use crate::stribeck::StribeckParams;
use crate::units::feed_mm_min_to_m_s;

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
