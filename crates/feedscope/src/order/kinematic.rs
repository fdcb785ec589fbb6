//! The kinematic orders of a ball-screw drive (paper 000 Eq. 7) and the classification of a
//! spectral component by the nearest one.

use serde::{Deserialize, Serialize};

use super::Cause;
use crate::axis::AxisParams;

/// The cause of harmonic h of one refeed mechanism.
type Harmonic = fn(u8) -> Cause;

/// A kinematic order of the drive and its cause.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct KinematicOrder {
    /// Cycles per lead.
    pub order: f64,
    /// Cause, written e.g. `shaft 1x`, `nut ball refeed 2x`, `declared: rolling-tool mark`.
    pub cause: Cause,
}

/// The kinematic orders of an axis: shaft orders 1-4 (pitch errors), ball refeeding in the nut
/// and in the guides by Eq. 7 with their 2× and 3× harmonics (when the geometry is given), and
/// the user-declared orders.
///
/// # Reference
/// Paper 000, Eq. 7 and section 4.1.2 (groups 1-4 of significant components).
///
/// # Example
/// ```
/// use feedscope::axis::{AxisParams, ConfigFormat};
/// use feedscope::order::{kinematic_orders, Cause};
/// let axis = AxisParams::parse(
///     "lead_mm = 10\ntable_mass_kg = 425\ninertia_kgm2 = 0.004\n\
///      damping_nms_per_rad = 0.002\ntorque_constant_nm_per_a = 1.82\n\
///      guide_balls_per_raceway = 19\n",
///     ConfigFormat::Toml,
///     "axis.toml",
/// )
/// .unwrap();
/// let k = kinematic_orders(&axis);
/// let g2 = k.iter().find(|k| k.cause == Cause::GuideRefeed(2)).unwrap();
/// assert!((g2.order - 19.0).abs() < 1e-12); // z/2 · 2 with z = 19 (Eq. 7, d → ∞)
/// ```
pub fn kinematic_orders(axis: &AxisParams) -> Vec<KinematicOrder> {
    let mut out: Vec<KinematicOrder> = (1..=4)
        .map(|h| KinematicOrder {
            order: h as f64,
            cause: Cause::Shaft(h),
        })
        .collect();
    let refeeds: [(Option<f64>, Harmonic); 2] = [
        (axis.nut_refeed_order(), Cause::NutRefeed),
        (axis.guide_refeed_order(), Cause::GuideRefeed),
    ];
    for (base, cause) in refeeds {
        if let Some(f) = base.filter(|f| f.is_finite() && *f > 0.0) {
            for h in 1..=3 {
                out.push(KinematicOrder {
                    order: f * h as f64,
                    cause: cause(h),
                });
            }
        }
    }
    for d in &axis.declared_orders {
        out.push(KinematicOrder {
            order: d.order,
            cause: Cause::Declared(d.cause.clone()),
        });
    }
    out
}

/// The kinematic order explaining a component at `order`: the nearest one within
/// tolerance max(`resolution`, `tolerance_fraction` × its order), nearness measured in units of
/// that tolerance. `None` means unexplained.
pub fn classify(
    order: f64,
    resolution: f64,
    tolerance_fraction: f64,
    kinematic: &[KinematicOrder],
) -> Option<&KinematicOrder> {
    kinematic
        .iter()
        .filter_map(|k| {
            let tol = resolution.max(tolerance_fraction * k.order);
            let d = (order - k.order).abs() / tol;
            (d <= 1.0).then_some((d, k))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, k)| k)
}
