//! Steady-state Stribeck friction: the model, its identification from (speed, friction)
//! points with uncertainties, and the detection of non-conventional behaviour.
//!
//! # Model
//! F(v) = sgn(v)·[F_c + (F_s − F_c)·exp(−(|v|/v_s)^δ)] + σ·v
//!
//! (paper 000 Eq. 9 and paper 001 Eq. 3 with δ = 2; δ is free here as an option). Every
//! quantity is SI inside: speeds in m/s, forces in N, σ in N·s/m. Friction is signed as in
//! paper 000 Eq. 5: positive while moving forward; the fit works on magnitudes of one
//! direction at a time.
//!
//! # Operations
//! - [`StribeckFitter`] / [`fit_stribeck`]: bounded nonlinear least squares with a grid start
//!   over (v_s, δ) and Levenberg–Marquardt refinement ([`fit`]), standard errors, 95 %
//!   intervals and identifiability warnings.
//! - [`detect_nonconventional`]: feed ranges where friction falls where a conventional
//!   Stribeck curve rises (paper 000 Section 4.2.1, "nonconventional Stribeck behaviour").
//! - [`friction_from_torque_n`]: steady-speed motor torque to friction force (paper 001
//!   Eq. 15).
//!
//! # Example
//! ```
//! use feedscope::stribeck::{fit_stribeck, StribeckFitParams, StribeckParams};
//! use feedscope::units::feed_mm_min_to_m_s;
//!
//! let truth = StribeckParams { fc_n: 180.0, fs_n: 250.0, vs_m_s: feed_mm_min_to_m_s(30.0),
//!                              sigma_n_s_per_m: 4000.0, delta: 2.0 };
//! // 18 log-spaced feeds from 5 to 600 mm/min
//! let speed: Vec<f64> = (0..18)
//!     .map(|k| feed_mm_min_to_m_s(5.0 * 120f64.powf(k as f64 / 17.0)))
//!     .collect();
//! let friction: Vec<f64> = speed.iter().map(|&v| truth.magnitude_n(v)).collect();
//! let fit = fit_stribeck(&speed, &friction, &StribeckFitParams::default()).unwrap();
//! assert!((fit.params.fc_n - 180.0).abs() < 1e-6);
//! assert!((fit.params.vs_mm_min() - 30.0).abs() < 1e-6);
//! assert!(fit.warnings.is_empty());
//! ```
//!
//! # Reference
//! Paper 000 Eq. 9 (with δ = 2) and Section 4.2.1, paper 001 Eq. 2-3 (static part of LuGre)
//! and Eq. 15, paper 002 Eq. 1.

mod behaviour;
pub mod fit;

pub use behaviour::{detect_nonconventional, FallingRange, NonConventional, NonConventionalParams};
pub use fit::{
    fit_stribeck, DeltaMode, FitWarning, FrictionModel, ParamEstimate, Reduction, StribeckFit,
    StribeckFitParams, StribeckFitter, StribeckUncertainty, Termination, Undetermined,
};

use serde::{Deserialize, Serialize};

pub use crate::units::M_S_PER_MM_MIN;

/// Why a Stribeck operation failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum StribeckError {
    /// Speed and friction slices differ in length.
    #[error("{speeds} speeds but {frictions} friction values")]
    LengthMismatch {
        /// Number of speeds.
        speeds: usize,
        /// Number of friction values.
        frictions: usize,
    },
    /// Fewer points than the fit needs to run at all.
    #[error("{points} points; the fit needs at least {needed}")]
    TooFewPoints {
        /// Points given.
        points: usize,
        /// Points needed.
        needed: usize,
    },
    /// An input value is NaN or infinite.
    #[error("{quantity} number {index} is not finite ({value})")]
    NonFinite {
        /// Which input (`"speed"`, `"friction"`, `"torque"`) or result
        /// (`"friction from torque"`).
        quantity: &'static str,
        /// Index in the input slice (0-based).
        index: usize,
        /// The value.
        value: f64,
    },
    /// Every speed is zero: nothing moved.
    #[error("every speed is zero; a Stribeck curve needs motion")]
    NoMotion,
    /// A setting is out of its range.
    #[error("{name} = {value} is out of range: {expected}")]
    BadParameter {
        /// Setting name.
        name: &'static str,
        /// Its value.
        value: f64,
        /// The allowed range, for people.
        expected: &'static str,
    },
}

impl StribeckError {
    /// What the error means to a caller: always [`BadInput`](crate::ErrorKind::BadInput): the points or a parameter do not allow the fit.
    pub fn kind(&self) -> crate::ErrorKind {
        use crate::ErrorKind;
        ErrorKind::BadInput
    }
}

/// Friction force from a steady-speed motor torque (paper 001 Eq. 15): F = 2π·η·T/p (N).
///
/// At steady speed the motor torque T (N·m) only overcomes friction, and a screw of lead p (m)
/// turns torque into axial force with the factor 2π/p. The transmission efficiency η ∈ (0, 1]
/// multiplies the torque: it is the forward efficiency of the screw (torque → force), so η < 1
/// attributes the fraction 1 − η of the torque to losses inside the screw and bearings and
/// reports only the rest as friction at the table. η = 1 (paper 001) reports all of the drive's
/// losses as one equivalent friction force at the table, which is what the feed axis feels.
///
/// The sign of T is kept (negative torque gives negative force).
///
/// # Errors
/// [`StribeckError::BadParameter`] when p is not positive and finite or η is not in (0, 1];
/// [`StribeckError::NonFinite`] when T, or the force it gives, is not finite.
///
/// # Example
/// ```
/// # use feedscope::stribeck::friction_from_torque_n;
/// // 1.5 N·m on a 10 mm lead: 2π·1.5/0.01 = 942.48 N
/// let f = friction_from_torque_n(1.5, 0.010, 1.0).unwrap();
/// assert!((f - 942.477_796).abs() < 1e-5);
/// ```
///
/// # Reference
/// Paper 001 Eq. 15 (T_r·P_T = T).
pub fn friction_from_torque_n(
    torque_nm: f64,
    lead_m: f64,
    efficiency: f64,
) -> Result<f64, StribeckError> {
    if !(lead_m.is_finite() && lead_m > 0.0) {
        return Err(StribeckError::BadParameter {
            name: "lead_m",
            value: lead_m,
            expected: "a positive, finite screw lead",
        });
    }
    if !(efficiency > 0.0 && efficiency <= 1.0) {
        return Err(StribeckError::BadParameter {
            name: "efficiency",
            value: efficiency,
            expected: "0 < efficiency <= 1",
        });
    }
    if !torque_nm.is_finite() {
        return Err(StribeckError::NonFinite {
            quantity: "torque",
            index: 0,
            value: torque_nm,
        });
    }
    let force_n = 2.0 * std::f64::consts::PI * efficiency * torque_nm / lead_m;
    // A finite torque on a tiny lead can still overflow.
    if !force_n.is_finite() {
        return Err(StribeckError::NonFinite {
            quantity: "friction from torque",
            index: 0,
            value: force_n,
        });
    }
    Ok(force_n)
}

/// Parameters of the Stribeck curve, SI units.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StribeckParams {
    /// Coulomb friction F_c (N).
    pub fc_n: f64,
    /// Static (breakaway) friction F_s (N).
    pub fs_n: f64,
    /// Stribeck velocity v_s (m/s).
    pub vs_m_s: f64,
    /// Viscous coefficient σ (N·s/m).
    pub sigma_n_s_per_m: f64,
    /// Stribeck shape exponent δ (2 = Gaussian, the usual choice).
    pub delta: f64,
}

impl StribeckParams {
    /// Stribeck velocity v_s in mm/min (user unit).
    pub fn vs_mm_min(&self) -> f64 {
        self.vs_m_s / M_S_PER_MM_MIN
    }

    /// Static excess F_s − F_c (N), the height of the Stribeck hump (negative if F_s < F_c).
    pub fn static_excess_n(&self) -> f64 {
        self.fs_n - self.fc_n
    }

    /// Friction magnitude at speed |v| (N), without sign: F_c + (F_s − F_c)·e^{−(|v|/v_s)^δ} + σ·|v|.
    pub fn magnitude_n(&self, speed_m_s: f64) -> f64 {
        let s = speed_m_s.abs();
        let stribeck = if self.vs_m_s > 0.0 {
            (-(s / self.vs_m_s).powf(self.delta)).exp()
        } else {
            0.0
        };
        self.fc_n + (self.fs_n - self.fc_n) * stribeck + self.sigma_n_s_per_m * s
    }

    /// Signed friction force opposing motion at velocity v (N); 0 at v = 0.
    pub fn force_n(&self, velocity_m_s: f64) -> f64 {
        if velocity_m_s > 0.0 {
            self.magnitude_n(velocity_m_s)
        } else if velocity_m_s < 0.0 {
            -self.magnitude_n(velocity_m_s)
        } else {
            0.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limits() {
        let p = StribeckParams {
            fc_n: 100.0,
            fs_n: 150.0,
            vs_m_s: 1e-3,
            sigma_n_s_per_m: 2000.0,
            delta: 2.0,
        };
        assert!((p.magnitude_n(0.0) - 150.0).abs() < 1e-12);
        // far above v_s only Coulomb + viscous remain
        assert!((p.magnitude_n(0.1) - (100.0 + 200.0)).abs() < 1e-9);
        assert!((p.force_n(-0.1) + 300.0).abs() < 1e-9);
        assert!((p.vs_mm_min() - 60.0).abs() < 1e-9);
    }

    /// Paper 001 Eq. 15 with the numbers of its Table 1-2: p = 12 mm, 1.73 N·m at 0.05 m/min
    /// gives 2π·1.73/0.012 = 905.83 N; η = 0.9 scales it to 815.24 N; bad leads and
    /// efficiencies are errors.
    #[test]
    fn eq15_torque_to_force() {
        let f = friction_from_torque_n(1.73, 0.012, 1.0).unwrap();
        assert!((f - 905.8259).abs() < 1e-3, "{f}");
        let f9 = friction_from_torque_n(1.73, 0.012, 0.9).unwrap();
        assert!((f9 - 0.9 * f).abs() < 1e-9);
        assert!((friction_from_torque_n(-2.0, 0.005, 1.0).unwrap() + 2513.2741).abs() < 1e-3);
        assert!(friction_from_torque_n(1.0, 0.0, 1.0).is_err());
        assert!(friction_from_torque_n(1.0, -0.01, 1.0).is_err());
        assert!(friction_from_torque_n(1.0, 0.01, 0.0).is_err());
        assert!(friction_from_torque_n(1.0, 0.01, 1.2).is_err());
        assert!(friction_from_torque_n(f64::NAN, 0.01, 1.0).is_err());
    }
}
