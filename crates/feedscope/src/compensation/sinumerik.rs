//! SINUMERIK 840D: starting values of the conventional friction compensation (quadrant-error
//! compensation), to be tuned on the machine with the circularity test.
//!
//! # What the documentation states
//! SINUMERIK 840D sl Function Manual Extended Functions, K3 "Compensations", Section 4.6
//! "Friction compensation (quadrant error compensation)", 03/2013, 6FC5397-1BP40-3BA1,
//! pp. 293-296 (also 09/2009, 6FC5397-1BP20-0BA0, p. 419; the SINUMERIK 808D function manual
//! 01/2017, p. 122, repeats it):
//! - MD32490 `$MA_FRICT_COMP_MODE` = 1 enables the friction compensation;
//!   MD32500 `$MA_FRICT_COMP_ENABLE` = 1 switches it on; MD32510
//!   `$MA_FRICT_COMP_ADAPT_ENABLE` switches the acceleration-dependent adaptation
//!   characteristic on (1) or off (0).
//! - The compensation value Δn (a speed, "n": injected into the speed setpoint) is
//!   MD32520 `$MA_FRICT_COMP_CONST_MAX` (maximum) and MD32530 `$MA_FRICT_COMP_CONST_MIN`
//!   (minimum); with adaptation Δn depends on the axis acceleration a at the quadrant
//!   transition (a = v²/r on a circle of radius r at path velocity v) through MD32550
//!   `$MA_FRICT_COMP_ACCEL1`, MD32560 `$MA_FRICT_COMP_ACCEL2`, MD32570
//!   `$MA_FRICT_COMP_ACCEL3` (a1 < a2 < a3): Δn = Δn_max·a/a1 below a1, Δn_max up to a2, a
//!   straight line to Δn_min at a3, Δn_min above.
//! - MD32580 `$MA_FRICT_COMP_INC_FACTOR`: a percentage of the compensation value for
//!   traversing blocks that last one interpolation cycle, found empirically.
//! - The values are found with the circularity test, repeated with small changes, at radii
//!   and path velocities typical of the machine's work, averaged where they differ.
//!
//! # Not confirmed
//! - MD32540 `$MA_FRICT_COMP_TIME` (the decay time constant of the injected pulse) and its
//!   unit (s) were not in the pages found; the name is the one of the SINUMERIK machine-data
//!   list as commonly cited.
//! - The unit of MD32520/MD32530 (mm/min for a linear axis, as a speed-setpoint value) was
//!   not in the pages found. The manual's symbol Δn says it is a speed.
//! - The `$MA_NAME[AXn]=value` notation of the output file is the part-program/INI notation
//!   of axis machine data; check it against an archive of the control before loading.
//!
//! # Starting values (the formulas)
//! At a reversal the friction steps from −F_s,bwd to +F_s,fwd (or back): ΔF = F_s,fwd +
//! F_s,bwd (2·F_s with one direction measured), the breakaway friction of the Stribeck fits.
//! The velocity controller holds the old friction in its integrator; the injected speed
//! setpoint Δn should make its proportional part supply the step at once:
//!
//! Δn·K_p = ΔF·p/(2π), with K_p = J·ω_c
//!
//! K_p the speed controller's P gain on the motor shaft (N·m·s/rad), J = m_eq·(p/2π)² the
//! total inertia on the motor shaft (m_eq = m_t + 4π²J_m/p², the equivalent mass of Eq. 5)
//! and ω_c = 2π·f_c the speed loop's crossover (the P gain of a loop with crossover ω_c on a
//! rigid inertia). As a table velocity:
//!
//! **MD32520 = Δv = ΔF/(m_eq·2π·f_c)** (m/s; × 60 000 for mm/min)
//!
//! The pulse should last while the reversal passes the Stribeck region: on a circle the axis
//! velocity after the quadrant transition grows as a·t, a = v_c²/r, and leaves the region of
//! static friction (|v| < v_s) after
//!
//! **MD32540 = T = v_s/a = v_s·r/v_c²** (s)
//!
//! with v_s the fitted Stribeck velocity (mean of the directions) and (r, v_c) the circle of
//! the circularity test the values will be tuned with. MD32510 = 0 (constant injection, the
//! first commissioning stage); the adaptation characteristic and MD32580 are left to the
//! circularity tests. The assumptions (f_c, r, v_c) are in [`SinumerikParams`] and stated in
//! the file.

use std::f64::consts::PI;

use super::{CompensationError, FrictionCurve};
use crate::axis::AxisParams;
use crate::stroke::Direction;
use crate::units::{feed_m_s_to_mm_min, feed_mm_min_to_m_s};

/// The assumptions of [`SinumerikStartValues::compute`] (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct SinumerikParams {
    /// Crossover frequency f_c of the speed control loop (Hz), which sets the assumed P gain
    /// K_p = J·2π·f_c. Default 50 Hz. With the drive's P gain K_p known (SINAMICS p1460,
    /// N·m·s/rad), f_c = K_p/(2π·J).
    pub speed_loop_hz: f64,
    /// Radius r of the circularity test (mm). Default 10.
    pub circle_radius_mm: f64,
    /// Path feed v_c of the circularity test (mm/min). Default 1000.
    pub circle_feed_mm_min: f64,
}

impl Default for SinumerikParams {
    fn default() -> Self {
        Self {
            speed_loop_hz: 50.0,
            circle_radius_mm: 10.0,
            circle_feed_mm_min: 1000.0,
        }
    }
}

/// Starting values of MD32490-MD32540 for one axis, with every quantity they come from.
#[derive(Debug, Clone, PartialEq)]
pub struct SinumerikStartValues {
    /// Breakaway friction F_s of each measured direction (N).
    pub breakaway_n: Vec<(Direction, f64)>,
    /// Stribeck velocity v_s of each measured direction (m/s).
    pub stribeck_velocity_m_s: Vec<(Direction, f64)>,
    /// The friction step at a reversal ΔF (N): F_s,fwd + F_s,bwd, or 2·F_s with one direction.
    pub breakaway_step_n: f64,
    /// Equivalent translational mass m_eq = m_t + 4π²J/p² (kg).
    pub equivalent_mass_kg: f64,
    /// Assumed speed-controller P gain K_p = m_eq·(p/2π)²·2π·f_c (N·m·s/rad on the motor).
    pub speed_gain_nms_per_rad: f64,
    /// Axis acceleration at the quadrant transition of the circularity test, a = v_c²/r (m/s²).
    pub quadrant_accel_m_s2: f64,
    /// MD32520 `FRICT_COMP_CONST_MAX`: Δv = ΔF/(m_eq·2π·f_c) (mm/min).
    pub const_max_mm_min: f64,
    /// MD32540 `FRICT_COMP_TIME`: T = v_s/a (s).
    pub time_s: f64,
    /// The assumptions.
    pub params: SinumerikParams,
}

impl SinumerikStartValues {
    /// Starting values from the Stribeck curves of the measured directions and the axis
    /// (module docs for the formulas).
    ///
    /// # Errors
    /// [`CompensationError::NeedsStribeck`] for a curve that is not a Stribeck curve (a
    /// reduced model or a map section); [`CompensationError::BadParameter`] for no curve, an
    /// assumption that is not positive and finite, or an axis without `inertia_kgm2`.
    pub fn compute(
        forward: Option<&FrictionCurve>,
        backward: Option<&FrictionCurve>,
        axis: &AxisParams,
        params: &SinumerikParams,
    ) -> Result<Self, CompensationError> {
        for (name, v) in [
            ("speed_loop_hz", params.speed_loop_hz),
            ("circle_radius_mm", params.circle_radius_mm),
            ("circle_feed_mm_min", params.circle_feed_mm_min),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(CompensationError::BadParameter {
                    name,
                    value: v,
                    expected: "a positive finite number",
                });
            }
        }
        let m_eq = axis.equivalent_mass_kg();
        if !(m_eq.is_finite() && m_eq > 0.0) {
            return Err(CompensationError::BadParameter {
                name: "inertia_kgm2",
                value: axis.inertia_kgm2,
                expected:
                    "the axis inertia (and table mass): the equivalent mass sets the amplitude",
            });
        }
        let mut breakaway_n = Vec::new();
        let mut vs = Vec::new();
        for c in [forward, backward].into_iter().flatten() {
            let d = c.direction().ok_or(CompensationError::BadParameter {
                name: "direction",
                value: f64::NAN,
                expected: "a curve of one direction",
            })?;
            let p = c
                .stribeck()
                .ok_or_else(|| CompensationError::NeedsStribeck {
                    what: "the SINUMERIK starting values",
                    direction: d.as_str(),
                    model: c.kind(),
                })?;
            breakaway_n.push((d, p.fs_n));
            vs.push((d, p.vs_m_s));
        }
        if breakaway_n.is_empty() {
            return Err(CompensationError::BadParameter {
                name: "direction",
                value: f64::NAN,
                expected: "a forward or a backward curve",
            });
        }
        let step = match breakaway_n.as_slice() {
            [(_, one)] => 2.0 * one,
            more => more.iter().map(|(_, f)| f).sum(),
        };
        let vs_mean = vs.iter().map(|(_, v)| v).sum::<f64>() / vs.len() as f64;
        let omega_c = 2.0 * PI * params.speed_loop_hz;
        let k = axis.lead_m() / (2.0 * PI);
        let dv_m_s = step / (m_eq * omega_c);
        let v_c = feed_mm_min_to_m_s(params.circle_feed_mm_min);
        let accel = v_c * v_c / (params.circle_radius_mm * 1e-3);
        Ok(Self {
            breakaway_n,
            stribeck_velocity_m_s: vs,
            breakaway_step_n: step,
            equivalent_mass_kg: m_eq,
            speed_gain_nms_per_rad: m_eq * k * k * omega_c,
            quadrant_accel_m_s2: accel,
            const_max_mm_min: feed_m_s_to_mm_min(dv_m_s),
            time_s: vs_mean / accel,
            params: params.clone(),
        })
    }
}
