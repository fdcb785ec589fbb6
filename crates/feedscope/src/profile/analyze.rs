//! The full analysis of one stroke: order scan, IAFV, FFS and its spectra in screw orders.

use serde::{Deserialize, Serialize};

use super::iafv::{fit_iafv, iafv_and_ffs, IafvFit, ProfileParams};
use super::scan::{order_scan, OrderScan};
use super::ProfileError;
use crate::axis::AxisParams;
use crate::order::{
    analyze_fluctuation, kinematic_orders, FluctuationAnalysis, SpectrumAnalyzer, SpectrumParams,
};
use crate::stroke::{Direction, StrokeView};

/// Highest order of the Table 2 scan when [`AnalysisParams::scan_max_order`] is left at 0.
pub const DEFAULT_SCAN_MAX_ORDER: usize = 8;

/// Options of [`analyze_stroke`].
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AnalysisParams {
    /// IAFV fit.
    pub profile: ProfileParams,
    /// Spectra and significant components.
    pub spectrum: SpectrumParams,
    /// Highest order of the Table 2 scan; 0 (the default) means [`DEFAULT_SCAN_MAX_ORDER`].
    /// A `usize` with 0 for "default" rather than an `Option`, so that a config or report
    /// written before keeps its meaning; read it through [`AnalysisParams::scan_max_order`].
    pub scan_max_order: usize,
}

impl AnalysisParams {
    /// The highest order of the Table 2 scan in effect: `scan_max_order`, or
    /// [`DEFAULT_SCAN_MAX_ORDER`] when it is 0.
    pub fn scan_max_order(&self) -> usize {
        if self.scan_max_order == 0 {
            DEFAULT_SCAN_MAX_ORDER
        } else {
            self.scan_max_order
        }
    }
}

/// Everything issue 3 reports for one stroke.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StrokeAnalysis {
    /// Direction of the stroke.
    pub direction: Direction,
    /// Table 2 scan.
    pub order_scan: OrderScan,
    /// The IAFV fit (with the linear trend).
    pub iafv: IafvFit,
    /// IAFV (N) at each sample, aligned with the input positions.
    pub iafv_n: Vec<f64>,
    /// FFS (N) at each sample, aligned with the input positions.
    pub ffs_n: Vec<f64>,
    /// Spectra of the FFS, significant components and their causes.
    pub fluctuation: FluctuationAnalysis,
}

/// Full analysis of one stroke: order scan (Table 2), IAFV fit (automatic or user layout),
/// FFS, segment spectra in screw orders, significant components classified against the axis'
/// kinematic orders (Eq. 7), aliasing guard.
///
/// # Reference
/// Paper 000, section 4.1 (Eq. 6-7, Table 2, Figs 6-10).
///
/// # Errors
/// As [`fit_iafv`] and [`analyze_fluctuation`].
///
/// # Example
/// ```
/// use feedscope::axis::{AxisParams, ConfigFormat};
/// use feedscope::order::SpectrumAnalyzer;
/// use feedscope::profile::{analyze_stroke, AnalysisParams, Direction, StrokeView};
/// let axis = AxisParams::parse(
///     "lead_mm = 10\ntable_mass_kg = 425\ninertia_kgm2 = 0.004\n\
///      damping_nms_per_rad = 0.002\ntorque_constant_nm_per_a = 1.82\n",
///     ConfigFormat::Toml,
///     "axis.toml",
/// )
/// .unwrap();
/// // 200 mm at 256 samples per lead: mean 70 N + a 5 N shaft-1x ripple.
/// let x: Vec<f64> = (0..=20 * 256).map(|i| i as f64 * 0.01 / 256.0).collect();
/// let f: Vec<f64> =
///     x.iter().map(|&p| 70.0 + 5.0 * (2.0 * std::f64::consts::PI * p / 0.01).cos()).collect();
/// let stroke = StrokeView {
///     direction: Direction::Forward,
///     position_m: &x,
///     friction_n: &f,
///     lead_m: 0.01,
///     max_trusted_order: 20.0,
///     feed_mm_min: Some(100.0),
/// };
/// let a = analyze_stroke(&stroke, &axis, &AnalysisParams::default(), &mut SpectrumAnalyzer::new())
///     .unwrap();
/// let c = a.fluctuation.components.iter().find(|c| c.segment.is_whole()).unwrap();
/// assert_eq!(c.cause, feedscope::order::Cause::Shaft(1));
/// assert!((c.amplitude_n - 5.0).abs() < 0.05);
/// ```
pub fn analyze_stroke(
    stroke: &StrokeView<'_>,
    axis: &AxisParams,
    params: &AnalysisParams,
    analyzer: &mut SpectrumAnalyzer,
) -> Result<StrokeAnalysis, ProfileError> {
    let order_scan = order_scan(stroke, params.scan_max_order())?;
    let iafv = fit_iafv(stroke, &params.profile, analyzer)?;
    let (iafv_n, ffs_n) = iafv_and_ffs(stroke, &iafv);
    let kin = kinematic_orders(axis);
    let fluctuation = analyze_fluctuation(
        analyzer,
        stroke,
        &ffs_n,
        &iafv.poly.breaks_mm,
        &kin,
        &params.spectrum,
    )?;
    Ok(StrokeAnalysis {
        direction: stroke.direction,
        order_scan,
        iafv,
        iafv_n,
        ffs_n,
        fluctuation,
    })
}
