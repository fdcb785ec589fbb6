//! Joint stiffness from Hertz point contact (paper Eq. 4-6) and its change with feed rate
//! through the friction force f(v) (paper Eq. 3).
//!
//! # Derivation (rebuilt; the paper's Eq. 4-6 are garbled in the available text)
//!
//! One ball pressed by the normal force Q approaches its raceways by δ with the Hertz law
//! Q = K_h·δ^{3/2} (K_h in N/m^{3/2}). Z balls share an axial force F at an effective angle
//! with sine s (s = sin α for a bearing, s = sin α·cos φ for the nut, φ the lead angle), so
//! F = Z·Q·s, and an axial displacement δ_a gives the normal approach δ = s·δ_a:
//!
//! F = Z·K_h·s^{5/2}·δ_a^{3/2},
//! k = dF/dδ_a = (3/2)·Z·K_h·s^{5/2}·δ_a^{1/2} = (3/2)·K_h^{2/3}·Z^{2/3}·s^{5/3}·F^{1/3}.
//!
//! This is the paper's form: Eq. 4 with Z = i·π·d0/(db·cos φ) balls in i loaded turns and
//! (P + f) as the nut load; Eq. 5-6 with Z = N·n and (Fas ∓ f/2) as the bearing loads. Each is
//! multiplied by the weight c_w = 0.9. A contact whose load is zero or negative has lifted off
//! and contributes no stiffness: that is how a bearing "unloads" at high feed.

use std::f64::consts::PI;

use serde::{Deserialize, Serialize};

use crate::stribeck::StribeckParams;

use super::config::DriveConfig;
use crate::units::{feed_mm_min_to_m_s, MM_MIN_PER_M_S};

/// Axial stiffness of `balls` Hertz point contacts sharing the axial load `load_n` (N) at an
/// effective angle whose sine is `sin_eff`:
/// k = 1.5·K_h^{2/3}·Z^{2/3}·s^{5/3}·F^{1/3} (N/m); 0 for F ≤ 0 (contact lifted off).
///
/// # Reference
/// Paper 001 Eq. 4-6 (rebuilt, see the module docs).
///
/// ```
/// use feedscope::dynamics::hertz_axial_stiffness_n_per_m;
/// let k1 = hertz_axial_stiffness_n_per_m(1000.0, 20.0, 1e10, 0.5);
/// let k8 = hertz_axial_stiffness_n_per_m(8000.0, 20.0, 1e10, 0.5);
/// assert!((k8 / k1 - 2.0).abs() < 1e-12); // k ∝ F^{1/3}
/// assert!(hertz_axial_stiffness_n_per_m(-5.0, 20.0, 1e10, 0.5) == 0.0); // lifted off
/// ```
pub fn hertz_axial_stiffness_n_per_m(
    load_n: f64,
    balls: f64,
    hertz_n_per_m1_5: f64,
    sin_eff: f64,
) -> f64 {
    if load_n <= 0.0 {
        return 0.0;
    }
    1.5 * hertz_n_per_m1_5.powf(2.0 / 3.0)
        * balls.powf(2.0 / 3.0)
        * sin_eff.powf(5.0 / 3.0)
        * load_n.cbrt()
}

/// Loads and stiffnesses of the three joints at one feed rate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct JointState {
    /// Feed rate v (m/s), signed; positive moves the table away from the rear bearing.
    pub feed_m_s: f64,
    /// Friction force f(v) (N), signed like the feed rate, 0 at rest (Eq. 3).
    pub friction_n: f64,
    /// Axial load of the rear bearing unit Fas − f/2 (N); ≤ 0 means unloaded.
    pub rear_load_n: f64,
    /// Axial load of the front bearing unit Fas + f/2 (N); ≤ 0 means unloaded.
    pub front_load_n: f64,
    /// Load of the screw-nut joint P + |f| (N).
    pub nut_load_n: f64,
    /// Rear bearing stiffness k1by (N/m), Eq. 5.
    pub k_rear_n_per_m: f64,
    /// Front bearing stiffness k2by (N/m), Eq. 6.
    pub k_front_n_per_m: f64,
    /// Screw-nut joint stiffness knut (N/m), Eq. 4.
    pub k_nut_n_per_m: f64,
}

/// The joint laws of one drive, in SI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct JointModel {
    pub friction: StribeckParams,
    pub nut_preload_n: f64,
    /// 1.5·c_wn·K_h^{2/3}·Z^{2/3}·s^{5/3}: k_nut = nut_coeff·F^{1/3}.
    pub nut_coeff: f64,
    pub bearing_pretension_n: f64,
    /// 1.5·c_wb·K_h^{2/3}·(N·n)^{2/3}·sin^{5/3} αb.
    pub bearing_coeff: f64,
}

impl JointModel {
    pub fn from_config(cfg: &DriveConfig) -> Self {
        let n = &cfg.nut;
        let phi = n.lead_angle_deg.to_radians();
        let balls_nut =
            n.loaded_turns * PI * cfg.screw.nominal_diameter_mm / (n.ball_diameter_mm * phi.cos());
        let s_nut = n.contact_angle_deg.to_radians().sin() * phi.cos();
        let nut_coeff = n.stiffness_weight
            * hertz_axial_stiffness_n_per_m(1.0, balls_nut, n.hertz_constant_n_per_m1_5, s_nut);
        let b = &cfg.bearings;
        let bearing_coeff = b.stiffness_weight
            * hertz_axial_stiffness_n_per_m(
                1.0,
                b.loaded_rows * b.balls_per_row,
                b.hertz_constant_n_per_m1_5,
                b.contact_angle_deg.to_radians().sin(),
            );
        let f = &cfg.friction;
        // Eq. 3 in SI: mm/min → m/s is ÷ 60 000, N per mm/min → N·s/m is × 60 000.
        let friction = StribeckParams {
            fc_n: f.coulomb_n,
            fs_n: f.static_n,
            vs_m_s: feed_mm_min_to_m_s(f.stribeck_velocity_mm_min),
            sigma_n_s_per_m: f.viscous_n_per_mm_min * MM_MIN_PER_M_S,
            delta: f.shape_exponent,
        };
        Self {
            friction,
            nut_preload_n: n.rated_dynamic_load_kn * 1e3 * n.preload_fraction,
            nut_coeff,
            bearing_pretension_n: b.screw_pretension_kn * 1e3,
            bearing_coeff,
        }
    }

    /// Joint loads and stiffnesses at feed rate v (m/s), Eq. 3-6. The friction is split
    /// equally and oppositely on the two bearing units (the paper's assumption); for v > 0 it
    /// unloads the rear unit, for v < 0 the front one.
    pub fn state(&self, feed_m_s: f64) -> JointState {
        let f = self.friction.force_n(feed_m_s);
        let rear = self.bearing_pretension_n - 0.5 * f;
        let front = self.bearing_pretension_n + 0.5 * f;
        let nut = self.nut_preload_n + f.abs();
        let k = |coeff: f64, load: f64| if load > 0.0 { coeff * load.cbrt() } else { 0.0 };
        JointState {
            feed_m_s,
            friction_n: f,
            rear_load_n: rear,
            front_load_n: front,
            nut_load_n: nut,
            k_rear_n_per_m: k(self.bearing_coeff, rear),
            k_front_n_per_m: k(self.bearing_coeff, front),
            k_nut_n_per_m: k(self.nut_coeff, nut),
        }
    }

    /// Smallest feed rate v > 0 (m/s) at which the rear bearing unit unloads, f(v) ≥ 2·Fas;
    /// `Some(0.0)` if it unloads as soon as the table moves (F_s ≥ 2·Fas), `None` if it does
    /// not unload below 100 m/s.
    pub fn unload_feed_m_s(&self) -> Option<f64> {
        let g = |v: f64| self.friction.magnitude_n(v) - 2.0 * self.bearing_pretension_n;
        if g(0.0) >= 0.0 {
            return Some(0.0);
        }
        // Scan geometrically (the Stribeck dip makes f non-monotone near v_s), then bisect
        // the first bracket.
        let mut lo = 0.0;
        let mut hi = 1e-7;
        while g(hi) < 0.0 {
            lo = hi;
            hi *= 1.02;
            if hi > 100.0 {
                return None;
            }
        }
        for _ in 0..100 {
            let mid = 0.5 * (lo + hi);
            if g(mid) < 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Some(hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// k = dF/dδ: differentiate the Hertz force-deflection law numerically and compare.
    #[test]
    fn hertz_stiffness_is_the_derivative_of_the_load_law() {
        let (z, kh, s) = (40.0_f64, 6e9_f64, 0.86_f64);
        let force = |d: f64| z * kh * s.powf(2.5) * d.powf(1.5);
        for d in [1e-6, 5e-6, 2e-5] {
            let h = d * 1e-5;
            let k_num = (force(d + h) - force(d - h)) / (2.0 * h);
            let k = hertz_axial_stiffness_n_per_m(force(d), z, kh, s);
            // central difference error ~ h²·F''' / 6 relative ~ 1e-10; allow 1e-7
            assert!((k / k_num - 1.0).abs() < 1e-7, "{k} vs {k_num}");
        }
        assert!(hertz_axial_stiffness_n_per_m(0.0, z, kh, s) == 0.0);
    }

    #[test]
    fn friction_moves_stiffness_as_the_paper_says() {
        let j = JointModel::from_config(&DriveConfig::default());
        let rest = j.state(0.0);
        let moving = j.state(0.5);
        assert!(rest.friction_n.abs() < 1e-12);
        assert!(moving.k_nut_n_per_m > rest.k_nut_n_per_m);
        assert!(moving.k_front_n_per_m > rest.k_front_n_per_m);
        assert!(moving.k_rear_n_per_m < rest.k_rear_n_per_m);
        assert!((rest.k_rear_n_per_m - rest.k_front_n_per_m).abs() < 1e-6);
    }

    #[test]
    fn unload_feed_solves_friction_equals_twice_pretension() {
        let j = JointModel::from_config(&DriveConfig::default());
        let v = j.unload_feed_m_s().unwrap();
        // Above v_s the Stribeck term vanishes: v = (2 Fas − Fc) / σ exactly.
        let exact = (2.0 * 1800.0 - 658.89) / (40.17 * 60.0);
        assert!((v - exact).abs() < 1e-9 * exact, "{v} vs {exact}");
        assert!(j.state(v * 1.001).k_rear_n_per_m == 0.0);
        assert!(j.state(v * 0.999).k_rear_n_per_m > 0.0);
        // reversed feed unloads the front unit instead
        assert!(j.state(-v * 1.001).k_front_n_per_m == 0.0);
    }
}
