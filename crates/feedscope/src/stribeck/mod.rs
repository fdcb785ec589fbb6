//! Steady-state Stribeck friction model.
//!
//! F(v) = sgn(v)·[F_c + (F_s − F_c)·exp(−(|v|/v_s)^δ)] + σ·v
//!
//! # Reference
//! Paper 000 Eq. 9 (with δ = 2), paper 001 Eq. 2-3 (static part of LuGre), paper 002.

use serde::{Deserialize, Serialize};

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
    }
}
