//! The analysis of friction along the travel (paper 000 Section 4.1): for every stroke the
//! Table 2 order scan, the IAFV, the FFS and its spectra in screw orders; the single polynomial
//! of the best scanned order (the paper's dotted line); Table 2 averaged per direction.
use crate::axis::AxisParams;
use crate::diag::{Code, Diagnostic};
use crate::estimate::{estimate, EstimateParams, StrokeFriction, StrokeSummary};
use crate::order::SpectrumAnalyzer;
use crate::profile::{
    analyze_stroke, fit_piecewise, order_scan_table, AnalysisParams, OrderScanTable, PiecewiseFit,
    StrokeAnalysis, DEFAULT_SCAN_MAX_ORDER,
};
use crate::stroke::StrokeView;
use crate::trace::Trace;
use crate::verdict::{DataVerdict, Support};

use super::withhold::{self, WithheldStroke};
use super::StudyError;

/// Settings of [`analyze_strokes`] and [`analyze_trace`]; the defaults are those of
/// `feedscope analyze`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AnalyzeStudyParams {
    /// The friction estimate, used by [`analyze_trace`] only (defaults:
    /// [`EstimateParams::default`], 1024 samples per lead).
    pub estimate: EstimateParams,
    /// IAFV, spectra and order scan of each stroke (defaults: [`AnalysisParams::default`]).
    /// Table 2 over all strokes runs to [`AnalysisParams::scan_max_order`] but never below
    /// [`DEFAULT_SCAN_MAX_ORDER`], so that its rows are those of the paper.
    pub analysis: AnalysisParams,
}

impl AnalyzeStudyParams {
    /// Highest polynomial order of Table 2 over all strokes: the stroke scans' order when it
    /// is higher than [`DEFAULT_SCAN_MAX_ORDER`], else [`DEFAULT_SCAN_MAX_ORDER`].
    pub fn table_max_order(&self) -> usize {
        self.analysis.scan_max_order.max(DEFAULT_SCAN_MAX_ORDER)
    }
}

/// Results of [`analyze_strokes`]: three vectors aligned with [`strokes`](Self::strokes)
/// (element `k` of each belongs to stroke `k`) and Table 2.
#[derive(Debug, Clone, PartialEq)]
pub struct AnalyzeStudy {
    /// The strokes analysed, as given or estimated.
    pub strokes: Vec<StrokeFriction>,
    /// Order scan, IAFV, FFS, spectra and significant components of each stroke.
    pub analyses: Vec<StrokeAnalysis>,
    /// The single polynomial of each stroke's best scanned order
    /// ([`OrderScan::best_order`](crate::profile::OrderScan::best_order)) over the whole
    /// stroke: the paper's dotted line beside the piecewise IAFV.
    pub single_polynomials: Vec<PiecewiseFit>,
    /// The paper's Table 2: mean residual standard deviation of single polynomials per order
    /// and direction, orders 1 to [`AnalyzeStudyParams::table_max_order`].
    pub order_scan_table: OrderScanTable,
    /// Strokes left out because their data support no profile (see [`crate::verdict`]).
    pub withheld: Vec<WithheldStroke>,
    /// The recording's verdict, when the strokes were estimated here ([`analyze_trace`]).
    pub verdict: Option<DataVerdict>,
}

/// Analyse estimated strokes along the travel: strokes whose data verdict is below
/// [`Support::Profile`] are withheld (listed in [`AnalyzeStudy::withheld`]); for each other
/// stroke [`analyze_stroke`] (order scan,
/// IAFV, FFS, segment spectra, significant components named from the axis geometry) and the
/// single polynomial of its best scanned order ([`fit_piecewise`] with no breakpoint); then
/// Table 2 over all strokes ([`order_scan_table`]).
///
/// `progress(done, total)` is called before the first stroke and after each stroke with the
/// number of strokes analysed so far and their total.
///
/// # Reference
/// Paper 000, Section 4.1 (Eq. 6-7, Table 2, Figs 6-10).
///
/// # Errors
/// [`StudyError::NotSupported`] when every stroke was withheld; [`StudyError::Stroke`] when a
/// stroke cannot be analysed (too few points, a breakpoint
/// outside it, ...), [`StudyError::SinglePolynomial`] when its single polynomial cannot be
/// fitted, [`StudyError::OrderScanTable`] when Table 2 cannot be computed.
///
/// # Example
/// ```
/// use feedscope::axis::{AxisParams, ConfigFormat};
/// use feedscope::estimate::StrokeFriction;
/// use feedscope::study::{analyze_strokes, AnalyzeStudyParams};
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let axis = AxisParams::parse(
///     "lead_mm = 10\ntable_mass_kg = 425\ninertia_kgm2 = 0.004\n\
///      damping_nms_per_rad = 0.002\ntorque_constant_nm_per_a = 1.82\n",
///     ConfigFormat::Toml,
///     "axis.toml",
/// )?;
/// let strokes: Vec<StrokeFriction> = vec![]; // e.g. feedscope_io::friction_csv::read
/// let study = analyze_strokes(strokes, &axis, &AnalyzeStudyParams::default(), &|_, _| {})?;
/// assert!(study.analyses.is_empty() && study.order_scan_table.rows.is_empty());
/// # Ok(())
/// # }
/// ```
pub fn analyze_strokes(
    strokes: Vec<StrokeFriction>,
    axis: &AxisParams,
    params: &AnalyzeStudyParams,
    progress: &dyn Fn(usize, usize),
) -> Result<AnalyzeStudy, StudyError> {
    let (strokes, withheld) = withhold::split(strokes, Support::Profile);
    if strokes.is_empty() && !withheld.is_empty() {
        return Err(withhold::not_supported("a friction profile", &withheld));
    }
    let lead = axis.lead_m();
    let views: Vec<StrokeView> = strokes
        .iter()
        .map(|s| StrokeView::from_estimate(s, lead))
        .collect();
    let mut analyzer = SpectrumAnalyzer::new();
    let mut analyses = Vec::with_capacity(views.len());
    let mut singles = Vec::with_capacity(views.len());
    progress(0, views.len());
    for (k, (s, v)) in strokes.iter().zip(&views).enumerate() {
        let mut a = analyze_stroke(v, axis, &params.analysis, &mut analyzer).map_err(|source| {
            StudyError::Stroke {
                stroke: s.summary.stroke,
                direction: s.summary.direction.as_str(),
                start_mm: s.summary.start_mm,
                end_mm: s.summary.end_mm,
                source,
            }
        })?;
        withhold::apply(&mut a, withhold::support_of(s));
        if let Some(d) = mixed_feeds(&s.summary) {
            a.fluctuation.warnings.push(d);
        }
        let order = a.order_scan.best_order;
        let single =
            fit_piecewise(v.position_m, v.friction_n, &[], &[order]).map_err(|source| {
                StudyError::SinglePolynomial {
                    stroke: s.summary.stroke,
                    order,
                    source,
                }
            })?;
        singles.push(single);
        analyses.push(a);
        progress(k + 1, views.len());
    }
    let order_scan_table =
        order_scan_table(&views, params.table_max_order()).map_err(StudyError::OrderScanTable)?;
    Ok(AnalyzeStudy {
        strokes,
        analyses,
        single_polynomials: singles,
        order_scan_table,
        withheld,
        verdict: None,
    })
}

/// Estimate the friction of every stroke of a trace ([`estimate`] with
/// [`AnalyzeStudyParams::estimate`]) and analyse it with [`analyze_strokes`].
///
/// # Errors
/// [`StudyError::Estimate`] when no stroke can be estimated; else as [`analyze_strokes`].
pub fn analyze_trace(
    trace: &Trace,
    axis: &AxisParams,
    params: &AnalyzeStudyParams,
    progress: &dyn Fn(usize, usize),
) -> Result<AnalyzeStudy, StudyError> {
    let est = estimate(trace, axis, &params.estimate)?;
    let mut study = analyze_strokes(est.strokes, axis, params, progress)?;
    study.verdict = Some(est.verdict);
    Ok(study)
}

/// How far (relative) a stroke's feed range may reach from its feed before the analysis says
/// the profile mixes feeds: as the estimate's settling window, ±25 %.
const MIXED_FEED_FRACTION: f64 = 0.25;

/// A warning (`feed-varies-along-stroke`) when the feed of a stroke varied beyond ±25 % of its
/// mean (an override turned during the stroke, a modulated feed): the IAFV (paper 000 Eq. 6)
/// is one mean profile, so where friction depends on the feed (the Stribeck and viscous
/// terms) it averages the feeds the stroke ran at, and follows a step of the override only
/// over its window. The orders are unaffected: they are fixed in position.
fn mixed_feeds(s: &StrokeSummary) -> Option<Diagnostic> {
    let (lo, hi) = (s.feed_min_mm_min?, s.feed_max_mm_min?);
    let f = s.feed_mm_min;
    let mixed = lo < (1.0 - MIXED_FEED_FRACTION) * f || hi > (1.0 + MIXED_FEED_FRACTION) * f;
    mixed.then(|| {
        Diagnostic::new(
            Code::FeedVariesAlongStroke,
            format!(
                "the feed varied from {lo:.1} to {hi:.1} mm/min along this stroke (mean {f:.1}; \
                 an override turned or a modulated feed): the mean profile (IAFV) mixes the \
                 friction of these feeds where it depends on the feed, and follows a step of \
                 the feed only over its window; the orders are fixed in position and are not \
                 affected. A steady feed per stroke gives a profile of one feed"
            ),
        )
    })
}
