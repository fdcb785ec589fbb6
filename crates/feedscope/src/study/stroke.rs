//! The stroke test (paper 000): friction estimate → IAFV and spectra of every stroke →
//! mean friction per position interval and component amplitudes as condition indicators.
use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::axis::AxisParams;
use crate::estimate::{estimate, Direction, EstimateParams};
use crate::history::{GridBuilder, GridProfile, Indicator};
use crate::order::{FluctuationAnalysis, SignificantComponent, SpectrumAnalyzer};
use crate::profile::{analyze_stroke, AnalysisParams};
use crate::stroke::StrokeView;
use crate::trace::Trace;
use crate::verdict::{DataVerdict, Support};

use super::withhold::{self, WithheldStroke};
use super::{IndicatorValue, StudyError};

/// Settings of [`stroke_test`].
#[derive(Debug, Clone, PartialEq)]
pub struct StrokeStudyParams {
    /// The friction estimate (defaults: [`EstimateParams::default`]).
    pub estimate: EstimateParams,
    /// IAFV and spectra of each stroke (defaults: [`AnalysisParams::default`]).
    pub analysis: AnalysisParams,
    /// Width of the position intervals of the mean-friction indicators (mm), aligned at 0.
    /// Default 50 mm.
    pub interval_mm: f64,
    /// Cells per lead of the position grid kept for the position-resolved comparison
    /// ([`Curves::grid`], [`crate::history::profile_changes`]). Default 8.
    pub grid_cells_per_lead: u32,
}

impl Default for StrokeStudyParams {
    fn default() -> Self {
        Self {
            estimate: EstimateParams::default(),
            analysis: AnalysisParams::default(),
            interval_mm: 50.0,
            grid_cells_per_lead: 8,
        }
    }
}

/// Mean friction of one direction over one position interval.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IntervalMean {
    /// Stroke direction.
    pub direction: Direction,
    /// Interval start (mm).
    pub start_mm: f64,
    /// Interval end (mm).
    pub end_mm: f64,
    /// Mean of the IAFV magnitude over the interval (N), all strokes of the direction.
    pub mean_n: f64,
    /// Standard deviation of the estimated friction about the IAFV there (N).
    pub std_n: f64,
    /// Samples in the interval.
    pub samples: usize,
}

/// One significant fluctuation component of one stroke.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StrokeComponent {
    /// Direction of the stroke.
    pub direction: Direction,
    /// The component.
    pub component: SignificantComponent,
}

/// What a condition report draws from a stroke test beyond its indicators.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Curves {
    /// First stroke of each direction: friction and IAFV along the travel.
    pub profiles: Vec<ProfileCurve>,
    /// Segment spectra of the FFS, one heat map per direction.
    pub heatmaps: Vec<HeatmapData>,
    /// The test's data verdict (absent in curves stored before it existed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub verdict: Option<DataVerdict>,
    /// Friction magnitude along the travel on a grid of lead/8, averaged over the strokes the
    /// verdict supports as a profile, one per direction: what
    /// [`crate::history::profile_changes`] compares (empty in curves stored before it
    /// existed).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub grid: Vec<GridProfile>,
}

/// Friction and IAFV of one stroke, thinned to at most about 1,500 points.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProfileCurve {
    /// `forward` or `backward`.
    pub direction: String,
    /// Feed (mm/min).
    pub feed_mm_min: f64,
    /// Positions (mm).
    pub position_mm: Vec<f64>,
    /// Estimated friction (N, signed as paper 000 Eq. 5).
    pub friction_n: Vec<f64>,
    /// IAFV (N).
    pub iafv_n: Vec<f64>,
    /// IAFV interval ends (mm).
    pub breaks_mm: Vec<f64>,
}

/// Amplitude over order (x) and segment centre (y).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeatmapData {
    /// `forward` or `backward`.
    pub direction: String,
    /// Orders (cycles per lead).
    pub orders: Vec<f64>,
    /// Segment centres (mm).
    pub position_mm: Vec<f64>,
    /// Amplitudes (N), one row per segment.
    pub amplitude_n: Vec<Vec<f64>>,
}

/// Results of a stroke test.
#[derive(Debug, Clone, PartialEq)]
pub struct StrokeTest {
    /// Mean friction per direction and position interval (intervals covered to at least 80 %).
    pub intervals: Vec<IntervalMean>,
    /// Significant components of every stroke, whole stroke and segments.
    pub components: Vec<StrokeComponent>,
    /// Indicators: [`Indicator::MeanFriction`] per interval (standard error from the scatter
    /// about the IAFV), then [`Indicator::Component`] per direction and cause (mean over the
    /// strokes of the largest trusted whole-stroke amplitude of that cause; standard error
    /// from the spectrum's noise floor there: RMS floor/1.1774/√strokes).
    pub indicators: Vec<IndicatorValue>,
    /// Curves for a report.
    pub curves: Curves,
    /// Strokes whose data support no profile: no indicator comes from them.
    pub withheld: Vec<WithheldStroke>,
    /// The recording's verdict.
    pub verdict: DataVerdict,
}

/// Analyse a stroke test: estimate the friction of every stroke ([`estimate`]), fit its IAFV
/// and spectra ([`analyze_stroke`]) and condense them into condition indicators.
///
/// # Errors
/// [`StudyError::Estimate`] when no stroke can be estimated, [`StudyError::Stroke`] when a
/// stroke cannot be analysed, [`StudyError::BadParameter`] for an interval width that is not
/// a positive length.
pub fn stroke_test(
    trace: &Trace,
    axis: &AxisParams,
    params: &StrokeStudyParams,
) -> Result<StrokeTest, StudyError> {
    let interval_mm = params.interval_mm;
    if !(interval_mm.is_finite() && interval_mm > 0.0) {
        return Err(StudyError::BadParameter {
            name: "interval_mm",
            value: interval_mm,
            expected: "a positive length",
        });
    }
    if params.grid_cells_per_lead == 0 {
        return Err(StudyError::BadParameter {
            name: "grid_cells_per_lead",
            value: 0.0,
            expected: "at least 1",
        });
    }
    let est = estimate(trace, axis, &params.estimate)?;
    // Only what the data support becomes an indicator: interval means need a profile,
    // component amplitudes need causes.
    let (strokes, withheld) = withhold::split(est.strokes, Support::Profile);
    if strokes.is_empty() {
        return Err(withhold::not_supported(
            "a friction profile (the condition indicators need one)",
            &withheld,
        ));
    }
    let lead = axis.lead_m();
    let mut analyzer = SpectrumAnalyzer::new();
    // (direction, bin) → its sums; forward first (Direction has no order)
    let mut bins: BTreeMap<(u8, i64), Bin> = BTreeMap::new();
    let mut components = Vec::new();
    // (direction, cause) → amplitudes of each stroke (max over its components of that cause)
    let mut amp: BTreeMap<(u8, crate::order::Cause), Vec<f64>> = BTreeMap::new();
    let mut curves = Curves {
        profiles: vec![],
        heatmaps: vec![],
        verdict: Some(est.verdict.clone()),
        grid: vec![],
    };
    let lead_mm = lead * 1e3;
    // Only strokes the verdict supports as a profile reach here: withheld ones feed no grid.
    let mut grids = [
        GridBuilder::new(Direction::Forward, lead_mm, params.grid_cells_per_lead),
        GridBuilder::new(Direction::Backward, lead_mm, params.grid_cells_per_lead),
    ];
    // (direction, cause) → noise floors (N) of the components picked, one per stroke
    let mut floors: BTreeMap<(u8, crate::order::Cause), Vec<f64>> = BTreeMap::new();
    for s in &strokes {
        let v = StrokeView::from_estimate(s, lead);
        let d = s.summary.direction;
        let dk = key(d);
        // Raw effort samples per resampled point: the independent samples behind a mean.
        let raw_per_point = s.summary.effort_samples as f64 / s.summary.points.max(1) as f64;
        let mut a =
            analyze_stroke(&v, axis, &params.analysis, &mut analyzer).map_err(|source| {
                StudyError::Stroke {
                    stroke: s.summary.stroke,
                    direction: d.as_str(),
                    start_mm: s.summary.start_mm,
                    end_mm: s.summary.end_mm,
                    source,
                }
            })?;
        withhold::apply(&mut a, withhold::support_of(s));
        // Half a lead at each end is left out: the stroke's acceleration transients.
        grids[usize::from(dk)].add_stroke(&s.position_m, &s.friction_n, 0.5 * lead_mm);
        for ((&z, &f), &m) in s.position_m.iter().zip(&s.friction_n).zip(&a.iafv_n) {
            let b = (z * 1e3 / interval_mm).floor() as i64;
            let e = bins.entry((dk, b)).or_default();
            e.sum_abs_iafv_n += m.abs();
            e.sum_sq_residual_n2 += (f - m).powi(2);
            e.points += 1;
            e.raw_samples += raw_per_point;
            e.quantum_n = e.quantum_n.max(s.summary.effort_quantum_n);
        }
        let mut best: BTreeMap<crate::order::Cause, (f64, f64)> = BTreeMap::new();
        for c in &a.fluctuation.components {
            components.push(StrokeComponent {
                direction: d,
                component: c.clone(),
            });
            if c.segment.is_whole() && c.trusted && c.cause.is_kinematic() {
                let e = best.entry(c.cause.clone()).or_insert((0.0, 0.0));
                if c.amplitude_n > e.0 {
                    *e = (c.amplitude_n, c.floor_n);
                }
            }
        }
        for (cause, (x, floor)) in best {
            amp.entry((dk, cause.clone())).or_default().push(x);
            floors.entry((dk, cause)).or_default().push(floor);
        }
        if !curves.profiles.iter().any(|p| p.direction == d.as_str()) {
            let step = s.position_m.len().div_ceil(1500).max(1);
            let pick = |v: &[f64], k: f64| v.iter().step_by(step).map(|x| x * k).collect();
            curves.profiles.push(ProfileCurve {
                direction: d.as_str().into(),
                feed_mm_min: s.summary.feed_mm_min,
                position_mm: pick(&s.position_m, 1e3),
                friction_n: pick(&s.friction_n, 1.0),
                iafv_n: pick(&a.iafv_n, 1.0),
                breaks_mm: a.iafv.poly.breaks_mm.clone(),
            });
            curves.heatmaps.extend(heatmap(&a.fluctuation, d));
        }
    }
    // A bin counts when samples cover at least 80 % of it (grid spacing lead/samples-per-lead).
    let spacing_mm = lead * 1e3 / f64::from(params.estimate.samples_per_lead);
    let min_n = (0.8 * interval_mm / spacing_mm).floor().max(2.0) as usize;
    let mut intervals = Vec::new();
    let mut indicators = Vec::new();
    for ((dk, b), bin) in bins {
        let Bin {
            sum_abs_iafv_n: sum,
            sum_sq_residual_n2: ss,
            points: n,
            raw_samples: raw,
            quantum_n: q_n,
        } = bin;
        if n < min_n {
            continue;
        }
        let direction = direction_of(dk);
        let (start_mm, end_mm) = (b as f64 * interval_mm, (b + 1) as f64 * interval_mm);
        let mean_n = sum / n as f64;
        let std_n = (ss / n as f64).sqrt();
        intervals.push(IntervalMean {
            direction,
            start_mm,
            end_mm,
            mean_n,
            std_n,
            samples: n,
        });
        let i = Indicator::MeanFriction {
            direction,
            start_mm,
            end_mm,
        };
        // The scatter averages over the raw effort samples behind the interval (the
        // resampled points are interpolated from them, not independent); the effort
        // quantum's rounding need not average out at all.
        let se = (std_n * std_n / raw.max(1.0) + q_n * q_n / 12.0).sqrt();
        indicators.push(IndicatorValue::new(i, mean_n, Some(se)));
    }
    for ((dk, cause), v) in amp {
        // The noise moves an amplitude by about one noise σ per bin, and the floor is the
        // median noise amplitude, a Rayleigh median = 1.1774 σ: SE ≈ RMS floor/1.1774/√strokes.
        let fl = floors.get(&(dk, cause.clone())).map_or(0.0, |f| {
            (f.iter().map(|x| x * x).sum::<f64>() / f.len() as f64).sqrt()
        });
        let se = fl / RAYLEIGH_MEDIAN_PER_SIGMA / (v.len() as f64).sqrt();
        let i = Indicator::Component {
            direction: direction_of(dk),
            cause,
        };
        indicators.push(IndicatorValue::new(
            i,
            v.iter().sum::<f64>() / v.len() as f64,
            (se > 0.0).then_some(se),
        ));
    }
    curves.grid = grids.into_iter().filter_map(GridBuilder::finish).collect();
    Ok(StrokeTest {
        intervals,
        components,
        indicators,
        curves,
        withheld,
        verdict: est.verdict,
    })
}

/// Median of a Rayleigh-distributed amplitude in units of the per-quadrature noise σ:
/// √(2 ln 2).
const RAYLEIGH_MEDIAN_PER_SIGMA: f64 = 1.177_410_022_515_474_8;

/// Sums over the resampled points of one direction in one position interval.
#[derive(Default)]
struct Bin {
    /// Σ |IAFV| (N).
    sum_abs_iafv_n: f64,
    /// Σ (friction − IAFV)² (N²).
    sum_sq_residual_n2: f64,
    /// Resampled points.
    points: usize,
    /// Raw effort samples behind them.
    raw_samples: f64,
    /// Largest effort quantum of the strokes there, as force (N).
    quantum_n: f64,
}

fn key(d: Direction) -> u8 {
    u8::from(d == Direction::Backward)
}

fn direction_of(k: u8) -> Direction {
    if k == 0 {
        Direction::Forward
    } else {
        Direction::Backward
    }
}

fn heatmap(fl: &FluctuationAnalysis, d: Direction) -> Option<HeatmapData> {
    let g = fl.segment_grid(fl.max_trusted_order.clamp(4.0, 40.0), 400)?;
    Some(HeatmapData {
        direction: d.as_str().into(),
        orders: g.orders,
        position_mm: g.position_mm,
        amplitude_n: g.amplitude_n,
    })
}
