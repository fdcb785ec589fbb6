//! Friction model with a known truth: position-dependent mean level per direction, a
//! Stribeck/viscous velocity term, and fluctuation components at screw-revolution orders.
//!
//! # Sign convention
//! The friction F_f is signed as in paper 000 Eq. 5: positive while the table moves forward
//! (z increasing), negative backward. It opposes motion, so in Eq. 5 it appears as
//! (m_t + 4π²J/p²)·z'' + (4π²B/p²)·z' = (2π/p)·k_e·i − F_f.
//!
//! # Model
//! F_f(z, v) = s(v)·[L_d(z) + V(v) + Σ_k A_k·sin(2π·n_k·z/p + φ_k)]
//!
//! - d = direction of v (forward for v ≥ 0), L_d the slow mean level of that direction
//!   (offset + linear trend + Gaussian bumps over position, [`MeanLevel`]),
//! - V(v) = (F_s − F_c)·exp(−(|v|/v_s)^δ) + σ·|v| (Stribeck excess + viscous, [`VelocityTerm`];
//!   F_c is the mean level itself),
//! - components k with order n_k (cycles per lead of travel = cycles per screw revolution),
//!   amplitude A_k and phase φ_k, active in the direction(s) they are declared for
//!   ([`Component`]),
//! - s(v) = tanh(v/v_ε), a smooth sign so that reversals integrate; v_ε is
//!   [`FrictionParams::sign_smoothing_mm_s`] (default 0.01 mm/s = 0.6 mm/min, so that
//!   |s(v)| = 1 to better than 1e-7 at 5 mm/min and exactly 1 in f64 above 30 mm/min).
//!
//! The magnitude is not clamped: configure the components smaller than the mean level.
//!
//! # Reference
//! Paper 000 Eq. 5 (sign), Eq. 7 (ball-refeed orders), Eq. 9 (Stribeck curve) and Section 4
//! (orders 0.56, 1-4, nut and guide refeed orders and their harmonics).

use std::f64::consts::PI;

use serde::{Deserialize, Serialize};

use crate::axis::AxisParams;

pub use crate::stroke::Direction;
use crate::units::feed_mm_min_to_m_s;

/// In which direction(s) of travel a fluctuation component acts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ComponentDirection {
    /// Both directions (default).
    #[default]
    Both,
    /// Forward travel only.
    Forward,
    /// Backward travel only.
    Backward,
}

impl ComponentDirection {
    /// Whether the component acts while moving in `direction`.
    pub fn acts_in(self, direction: Direction) -> bool {
        matches!(
            (self, direction),
            (Self::Both, _)
                | (Self::Forward, Direction::Forward)
                | (Self::Backward, Direction::Backward)
        )
    }
}

/// A Gaussian bump of the mean level: height·exp(−½·((z − center)/width)²).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Bump {
    /// Centre position (mm).
    pub center_mm: f64,
    /// Standard deviation of the Gaussian (mm), > 0.
    pub width_mm: f64,
    /// Height at the centre (N); negative for a dip.
    pub height_n: f64,
}

/// Slow position-dependent mean friction level of one direction (magnitude, N):
/// L(z) = offset + trend·z + Σ bumps(z), z in mm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeanLevel {
    /// Level at z = 0 without bumps (N).
    pub offset_n: f64,
    /// Linear trend (N per mm of position).
    #[serde(default)]
    pub trend_n_per_mm: f64,
    /// Gaussian bumps (TOML `[[friction.forward.bump]]`).
    #[serde(default, rename = "bump")]
    pub bumps: Vec<Bump>,
}

impl MeanLevel {
    /// L(z) in N for a position in metres.
    pub fn level_n(&self, position_m: f64) -> f64 {
        let z_mm = position_m * 1e3;
        let mut l = self.offset_n + self.trend_n_per_mm * z_mm;
        for b in &self.bumps {
            let u = (z_mm - b.center_mm) / b.width_mm;
            l += b.height_n * (-0.5 * u * u).exp();
        }
        l
    }
}

/// Velocity-dependent part of the magnitude: (F_s − F_c)·exp(−(|v|/v_s)^δ) + σ·|v|
/// (paper 000 Eq. 9 without the Coulomb level, which is the mean level).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VelocityTerm {
    /// Static friction in excess of the Coulomb level, F_s − F_c (N), ≥ 0.
    pub static_excess_n: f64,
    /// Stribeck velocity v_s (mm/min), > 0.
    pub stribeck_velocity_mm_min: f64,
    /// Stribeck shape exponent δ (2 = Gaussian), > 0.
    pub shape_exponent: f64,
    /// Viscous coefficient σ (N·s/m), ≥ 0.
    pub viscous_n_s_per_m: f64,
}

impl VelocityTerm {
    /// V(v) in N (even in v).
    pub fn term_n(&self, velocity_m_s: f64) -> f64 {
        let s = velocity_m_s.abs();
        let vs = feed_mm_min_to_m_s(self.stribeck_velocity_mm_min);
        self.static_excess_n * (-(s / vs).powf(self.shape_exponent)).exp()
            + self.viscous_n_s_per_m * s
    }
}

/// One fluctuation component A·sin(2π·order·z/p + φ) of the friction magnitude.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Component {
    /// Order: cycles per screw revolution = cycles per lead of table travel, > 0.
    pub order: f64,
    /// Amplitude (N), ≥ 0.
    pub amplitude_n: f64,
    /// Phase φ (degrees) at z = 0.
    #[serde(default)]
    pub phase_deg: f64,
    /// Direction(s) in which it acts.
    #[serde(default)]
    pub direction: ComponentDirection,
    /// Mechanical cause, e.g. `"nut ball refeed (Eq. 7)"`.
    #[serde(default)]
    pub cause: String,
}

impl Component {
    /// Value (N) at a position (m) for a screw lead (m).
    pub fn value_n(&self, position_m: f64, lead_m: f64) -> f64 {
        self.amplitude_n
            * (2.0 * PI * self.order * position_m / lead_m + self.phase_deg.to_radians()).sin()
    }
}

/// Everything of the friction model except the screw lead (the `[friction]` table of a
/// simulator config).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrictionParams {
    /// Smooth-sign velocity v_ε of s(v) = tanh(v/v_ε) (mm/s), > 0. Default 0.01 mm/s.
    #[serde(default = "default_sign_smoothing_mm_s")]
    pub sign_smoothing_mm_s: f64,
    /// Mean level while moving forward.
    pub forward: MeanLevel,
    /// Mean level while moving backward (as a magnitude, ≥ 0 typically).
    pub backward: MeanLevel,
    /// Stribeck excess + viscous term.
    pub velocity: VelocityTerm,
    /// Fluctuation components (TOML `[[friction.component]]`).
    #[serde(default, rename = "component")]
    pub components: Vec<Component>,
}

fn default_sign_smoothing_mm_s() -> f64 {
    0.01
}

impl FrictionParams {
    /// Plausible lathe-Z friction for an axis: mean levels of 250-330 N with trends and bumps,
    /// backward higher than forward near the motor end (paper 000 Fig. 5-7), static excess
    /// 80 N, Stribeck velocity 60 mm/min, viscous 2000 N·s/m, and the components of paper 000
    /// Section 4: 0.56 (rolling-tool mark), shaft orders 1-4, the nut refeed order of Eq. 7 and
    /// its 2nd harmonic, and the guide refeed order z/2 and its 2nd harmonic (the refeed
    /// components only when the axis declares the geometry).
    pub fn default_for(axis: &AxisParams) -> Self {
        let c = |order: f64, amplitude_n: f64, phase_deg: f64, direction, cause: &str| Component {
            order,
            amplitude_n,
            phase_deg,
            direction,
            cause: cause.to_string(),
        };
        use ComponentDirection::{Backward, Both, Forward};
        let mut components = vec![
            c(0.56, 6.0, 20.0, Both, "rolling-tool mark"),
            c(1.0, 8.0, 0.0, Forward, "shaft pitch error, order 1"),
            c(1.0, 18.0, 60.0, Backward, "shaft pitch error, order 1"),
            c(2.0, 7.0, 120.0, Both, "shaft pitch error, order 2"),
            c(3.0, 4.0, 200.0, Both, "shaft pitch error, order 3"),
            c(4.0, 3.0, 300.0, Both, "shaft pitch error, order 4"),
        ];
        if let Some(n) = axis.nut_refeed_order() {
            components.push(c(n, 5.0, 45.0, Both, "nut ball refeed (Eq. 7)"));
            components.push(c(2.0 * n, 2.0, 90.0, Both, "nut ball refeed, 2nd harmonic"));
        }
        if let Some(n) = axis.guide_refeed_order() {
            components.push(c(n, 4.0, 135.0, Both, "guide ball refeed (Eq. 7, d → ∞)"));
            components.push(c(
                2.0 * n,
                2.0,
                10.0,
                Both,
                "guide ball refeed, 2nd harmonic",
            ));
        }
        Self {
            sign_smoothing_mm_s: default_sign_smoothing_mm_s(),
            forward: MeanLevel {
                offset_n: 250.0,
                trend_n_per_mm: 0.08,
                bumps: vec![
                    Bump {
                        center_mm: 80.0,
                        width_mm: 25.0,
                        height_n: 40.0,
                    },
                    Bump {
                        center_mm: 300.0,
                        width_mm: 40.0,
                        height_n: -20.0,
                    },
                ],
            },
            backward: MeanLevel {
                offset_n: 300.0,
                trend_n_per_mm: -0.05,
                bumps: vec![Bump {
                    center_mm: 100.0,
                    width_mm: 30.0,
                    height_n: 50.0,
                }],
            },
            velocity: VelocityTerm {
                static_excess_n: 80.0,
                stribeck_velocity_mm_min: 60.0,
                shape_exponent: 2.0,
                viscous_n_s_per_m: 2000.0,
            },
            components,
        }
    }
}

/// The friction model of the simulated drive, with its screw lead: the known truth against
/// which estimators are checked.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrictionModel {
    /// Screw lead p (mm), the period unit of the orders.
    pub lead_mm: f64,
    /// The model parameters.
    pub params: FrictionParams,
}

impl FrictionModel {
    /// A model for a screw of lead `lead_mm`.
    pub fn new(lead_mm: f64, params: FrictionParams) -> Self {
        Self { lead_mm, params }
    }

    /// The model parameters.
    pub fn params(&self) -> &FrictionParams {
        &self.params
    }

    /// Smooth sign velocity v_ε (m/s).
    pub fn sign_smoothing_m_s(&self) -> f64 {
        self.params.sign_smoothing_mm_s * 1e-3
    }

    /// s(v) = tanh(v/v_ε), the smooth sign of the friction.
    pub fn smooth_sign(&self, velocity_m_s: f64) -> f64 {
        (velocity_m_s / self.sign_smoothing_m_s()).tanh()
    }

    /// The mean level of one direction.
    pub fn mean_level(&self, direction: Direction) -> &MeanLevel {
        match direction {
            Direction::Forward => &self.params.forward,
            Direction::Backward => &self.params.backward,
        }
    }

    /// Slow mean level L_d(z) (N, magnitude) of a direction at a position (m).
    pub fn mean_level_n(&self, direction: Direction, position_m: f64) -> f64 {
        self.mean_level(direction).level_n(position_m)
    }

    /// Velocity term V(v) (N, magnitude): Stribeck excess + viscous.
    pub fn velocity_term_n(&self, velocity_m_s: f64) -> f64 {
        self.params.velocity.term_n(velocity_m_s)
    }

    /// The fluctuation components.
    pub fn components(&self) -> &[Component] {
        &self.params.components
    }

    /// Mean friction magnitude L_d(z) + V(v) (N), without fluctuation components. The
    /// direction is given explicitly (it is not taken from the sign of v).
    pub fn mean_friction_n(&self, direction: Direction, position_m: f64, velocity_m_s: f64) -> f64 {
        self.mean_level_n(direction, position_m) + self.velocity_term_n(velocity_m_s)
    }

    /// Sum of the fluctuation components acting in `direction` at a position (N, magnitude).
    pub fn fluctuation_n(&self, direction: Direction, position_m: f64) -> f64 {
        let lead_m = self.lead_mm * 1e-3;
        self.params
            .components
            .iter()
            .filter(|c| c.direction.acts_in(direction))
            .map(|c| c.value_n(position_m, lead_m))
            .sum()
    }

    /// Friction magnitude L_d(z) + V(v) + Σ components (N), d from the sign of v.
    pub fn magnitude_n(&self, position_m: f64, velocity_m_s: f64) -> f64 {
        let d = Direction::of_velocity(velocity_m_s);
        self.mean_friction_n(d, position_m, velocity_m_s) + self.fluctuation_n(d, position_m)
    }

    /// Signed friction F_f(z, v) = tanh(v/v_ε)·magnitude (N), paper 000 Eq. 5 sign.
    pub fn friction_n(&self, position_m: f64, velocity_m_s: f64) -> f64 {
        self.smooth_sign(velocity_m_s) * self.magnitude_n(position_m, velocity_m_s)
    }

    /// An upper bound of |F_f| over the travel [lo, hi] (m) and speeds up to `max_speed_m_s`,
    /// used to size the integration step near reversals.
    pub(crate) fn magnitude_bound_n(&self, lo_m: f64, hi_m: f64, max_speed_m_s: f64) -> f64 {
        let level_bound = |l: &MeanLevel| {
            let trend = (l.trend_n_per_mm * lo_m * 1e3)
                .abs()
                .max((l.trend_n_per_mm * hi_m * 1e3).abs());
            l.offset_n.abs() + trend + l.bumps.iter().map(|b| b.height_n.abs()).sum::<f64>()
        };
        let v = &self.params.velocity;
        level_bound(&self.params.forward).max(level_bound(&self.params.backward))
            + v.static_excess_n.abs()
            + v.viscous_n_s_per_m.abs() * max_speed_m_s
            + self
                .params
                .components
                .iter()
                .map(|c| c.amplitude_n.abs())
                .sum::<f64>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axis() -> AxisParams {
        crate::sim::SimConfig::default().axis
    }

    fn model() -> FrictionModel {
        let a = axis();
        FrictionModel::new(a.lead_mm, FrictionParams::default_for(&a))
    }

    #[test]
    fn default_has_paper_orders() {
        let m = model();
        let orders: Vec<f64> = m.components().iter().map(|c| c.order).collect();
        let has = |o: f64| orders.iter().any(|x| (x - o).abs() < 1e-9);
        for o in [0.56, 1.0, 2.0, 3.0, 4.0, 9.5, 19.0] {
            assert!(has(o), "order {o} missing from {orders:?}");
        }
        let nut = axis().nut_refeed_order().unwrap();
        assert!(has(nut) && has(2.0 * nut), "{orders:?}");
        // Eq. 7 with the default geometry gives ≈ 8 as in paper 000
        assert!((nut - 8.0).abs() < 0.3, "{nut}");
    }

    #[test]
    fn friction_is_sign_times_parts_away_from_reversals() {
        let m = model();
        for &v in &[1.667e-3, -1.667e-3, 0.05, -0.05, 8.4e-5] {
            for k in 0..200 {
                let z = 0.41 * k as f64 / 199.0;
                let d = Direction::of_velocity(v);
                let parts = m.mean_friction_n(d, z, v) + m.fluctuation_n(d, z);
                let f = m.friction_n(z, v);
                // away from reversal 1 − tanh(x) ≈ 2e^(−2x) = 1.0e-7 at x = |v|/v_ε = 8.4 (5 mm/min)
                assert!(
                    (f - d.sign() * parts).abs() <= 1.1e-7 * parts.abs(),
                    "{z} {v}"
                );
            }
        }
        // continuous through zero
        assert!(m.friction_n(0.1, 0.0).abs() < 1e-12);
        assert!(m.friction_n(0.1, 1e-9).abs() < m.friction_n(0.1, 1e-8).abs());
    }

    #[test]
    fn mean_level_parts() {
        let l = MeanLevel {
            offset_n: 100.0,
            trend_n_per_mm: 0.5,
            bumps: vec![Bump {
                center_mm: 50.0,
                width_mm: 10.0,
                height_n: 20.0,
            }],
        };
        assert!((l.level_n(0.05) - (100.0 + 25.0 + 20.0)).abs() < 1e-12);
        let far = 100.0 + 0.5 * 200.0 + 20.0 * (-0.5f64 * 15.0 * 15.0).exp();
        assert!((l.level_n(0.2) - far).abs() < 1e-12);
    }

    #[test]
    fn velocity_term_matches_stribeck_params() {
        let m = model();
        let v = &m.params().velocity;
        let s = crate::stribeck::StribeckParams {
            fc_n: 0.0,
            fs_n: v.static_excess_n,
            vs_m_s: feed_mm_min_to_m_s(v.stribeck_velocity_mm_min),
            sigma_n_s_per_m: v.viscous_n_s_per_m,
            delta: v.shape_exponent,
        };
        for &sp in &[0.0, 1e-4, 1e-3, 0.01, 0.1] {
            assert!((m.velocity_term_n(sp) - s.magnitude_n(sp)).abs() < 1e-9);
            assert!((m.velocity_term_n(-sp) - s.magnitude_n(sp)).abs() < 1e-9);
        }
    }

    /// Direct DFT of the fluctuation over an integer number of cycles of each configured
    /// order recovers amplitude and phase; a non-configured order shows nothing.
    #[test]
    fn components_have_configured_orders_direct_dft() {
        let params = FrictionParams {
            components: vec![
                Component {
                    order: 1.0,
                    amplitude_n: 10.0,
                    phase_deg: 30.0,
                    direction: ComponentDirection::Both,
                    cause: String::new(),
                },
                Component {
                    order: 2.5,
                    amplitude_n: 4.0,
                    phase_deg: -70.0,
                    direction: ComponentDirection::Both,
                    cause: String::new(),
                },
                Component {
                    order: 8.0,
                    amplitude_n: 3.0,
                    phase_deg: 0.0,
                    direction: ComponentDirection::Forward,
                    cause: String::new(),
                },
            ],
            ..FrictionParams::default_for(&axis())
        };
        let m = FrictionModel::new(10.0, params);
        // 20 leads (200 mm) hold an integer number of cycles of 1, 2.5 and 8 (and of the probe
        // order 3), so the DFT bins are exact up to rounding.
        let n = 20_000;
        let leads = 20.0;
        let dft = |d: Direction, order: f64| {
            let (mut re, mut im) = (0.0, 0.0);
            for k in 0..n {
                let z = 0.01 * leads * k as f64 / n as f64;
                let x = m.fluctuation_n(d, z);
                let arg = 2.0 * PI * order * z / 0.01;
                re += x * arg.cos();
                im += x * arg.sin();
            }
            // A·sin(θ+φ) projects to (A sinφ, A cosφ)·n/2
            let (a, b) = (2.0 * im / n as f64, 2.0 * re / n as f64);
            ((a * a + b * b).sqrt(), b.atan2(a).to_degrees())
        };
        let (a1, p1) = dft(Direction::Forward, 1.0);
        assert!(
            (a1 - 10.0).abs() < 1e-9 && (p1 - 30.0).abs() < 1e-7,
            "{a1} {p1}"
        );
        let (a2, p2) = dft(Direction::Backward, 2.5);
        assert!(
            (a2 - 4.0).abs() < 1e-9 && (p2 + 70.0).abs() < 1e-7,
            "{a2} {p2}"
        );
        assert!((dft(Direction::Forward, 8.0).0 - 3.0).abs() < 1e-9);
        // forward-only component absent backward, absent order absent everywhere
        assert!(dft(Direction::Backward, 8.0).0 < 1e-9);
        assert!(dft(Direction::Forward, 3.0).0 < 1e-9);
    }
}
