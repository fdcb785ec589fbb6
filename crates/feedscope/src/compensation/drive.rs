//! Friction force at the table ↔ motor torque ↔ motor current.

use std::f64::consts::PI;

use super::CompensationError;
use crate::axis::AxisParams;

/// The steady-speed relation between the friction force at the table and the motor's torque
/// and current that overcome it, for one axis.
///
/// T = F·p/(2π·η), i = T/k_e (paper 000 Eq. 3 and 5 at steady speed; paper 001 Eq. 15,
/// F = 2π·η·T/p, inverted), with p the screw lead (m), η ∈ (0, 1] the screw's forward
/// efficiency that was used to compute F from a torque (1 when F came from Eq. 5, as in
/// `feedscope map` and `estimate`: Eq. 5 reports every loss of the drive as one force at the
/// table), k_e the motor torque constant (N·m/A).
///
/// Signs are kept: a friction force signed as in Eq. 5 (positive forward) gives the torque and
/// current that push the table the same way, i.e. the additive current to feed forward.
///
/// # Example
/// ```
/// # use feedscope::compensation::DriveConversion;
/// // 300 N on a 10 mm lead with η = 0.9 and k_e = 1.5 N·m/A:
/// // T = 300·0.01/(2π·0.9) = 0.530516 N·m, i = T/1.5 = 0.353678 A.
/// let d = DriveConversion::new(0.010, 1.5, 0.9)?;
/// assert!((d.torque_nm(300.0) - 0.530_516_5).abs() < 1e-6);
/// assert!((d.current_a(300.0) - 0.353_677_7).abs() < 1e-6);
/// assert!((d.friction_from_current_n(d.current_a(-300.0)) + 300.0).abs() < 1e-9);
/// # Ok::<(), feedscope::compensation::CompensationError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriveConversion {
    /// Screw lead p (m).
    pub lead_m: f64,
    /// Motor torque constant k_e (N·m/A).
    pub torque_constant_nm_per_a: f64,
    /// Forward efficiency η ∈ (0, 1] of the torque → force conversion the friction came from.
    pub efficiency: f64,
}

impl DriveConversion {
    /// A conversion from its three constants.
    ///
    /// # Errors
    /// [`CompensationError::BadParameter`] for a lead or torque constant that is not positive
    /// and finite (named as the axis file's keys), or η outside (0, 1].
    pub fn new(
        lead_m: f64,
        torque_constant_nm_per_a: f64,
        efficiency: f64,
    ) -> Result<Self, CompensationError> {
        let positive = |name, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(CompensationError::BadParameter {
                    name,
                    value: v,
                    expected: "a positive finite number",
                })
            }
        };
        positive("lead_mm", lead_m * 1e3)?;
        positive("torque_constant_nm_per_a", torque_constant_nm_per_a)?;
        if !(efficiency > 0.0 && efficiency <= 1.0) {
            return Err(CompensationError::BadParameter {
                name: "efficiency",
                value: efficiency,
                expected: "0 < efficiency <= 1",
            });
        }
        Ok(Self {
            lead_m,
            torque_constant_nm_per_a,
            efficiency,
        })
    }

    /// The conversion of an axis file (`lead_mm`, `torque_constant_nm_per_a`) with efficiency η.
    ///
    /// # Errors
    /// As [`DriveConversion::new`].
    pub fn from_axis(axis: &AxisParams, efficiency: f64) -> Result<Self, CompensationError> {
        Self::new(axis.lead_m(), axis.torque_constant_nm_per_a, efficiency)
    }

    /// Motor torque (N·m) that overcomes the friction force `friction_n` (N): F·p/(2π·η).
    pub fn torque_nm(&self, friction_n: f64) -> f64 {
        friction_n * self.lead_m / (2.0 * PI * self.efficiency)
    }

    /// Motor current (A) that overcomes the friction force `friction_n` (N): T/k_e.
    pub fn current_a(&self, friction_n: f64) -> f64 {
        self.torque_nm(friction_n) / self.torque_constant_nm_per_a
    }

    /// The friction force (N) a motor current (A) overcomes: the inverse of
    /// [`Self::current_a`].
    pub fn friction_from_current_n(&self, current_a: f64) -> f64 {
        self.friction_from_torque_n(current_a * self.torque_constant_nm_per_a)
    }

    /// The friction force (N) a motor torque (N·m) overcomes: 2π·η·T/p (paper 001 Eq. 15).
    pub fn friction_from_torque_n(&self, torque_nm: f64) -> f64 {
        2.0 * PI * self.efficiency * torque_nm / self.lead_m
    }
}
