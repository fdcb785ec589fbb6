//! Trends of an axis: every indicator's series against its baseline, ordered as a report
//! reads them, and the diagnosis in words.
use std::collections::BTreeMap;

use serde::Serialize;

use crate::history::{
    assess, diagnose_with_profiles, family_limit_width, profile_changes, BaselineSpec,
    HistoryError, Indicator, IndicatorTrend, LocalParams, Point, ProfileChanges, ProfileTest,
    Threshold, TrendParams,
};

use super::StudyError;

/// One indicator's series in time order, each point with the id its store gave the test.
pub type IndicatorSeries = Vec<(i64, Point)>;

/// Settings of [`axis_trends`].
#[derive(Debug, Clone, PartialEq)]
pub struct TrendStudyParams {
    /// Baseline: mean and σ of the first N tests of each indicator; with a reference test, μ₀
    /// is its value and σ the scatter of these N. Default 5.
    pub baseline_tests: usize,
    /// Alarm levels by indicator key; an indicator without one has none.
    pub thresholds: BTreeMap<String, Threshold>,
    /// The position-resolved comparison of the stroke tests' friction profiles (its own
    /// baseline: the first 2 stroke tests by default).
    pub profiles: LocalParams,
    /// Floor of σ of the component amplitudes relative to μ₀. Default 0.03: the amplitude of
    /// an unchanged component scatters by about ±3 % between identical tests (the
    /// spectrum's leakage and noise), more at low amplitude, where the amplitudes' own
    /// standard errors (noise floor) set the floor instead.
    pub component_min_relative_std: f64,
    /// Chance per test that any of the axis's component amplitudes raises a false alarm
    /// although the screw is unchanged: their Shewhart and EWMA limits are widened together
    /// ([`family_limit_width`]). Default 0.001 (one false alarm in about 1000 tests of an
    /// axis, 20 years of weekly tests; a single ±3σ chart has 0.0027).
    pub component_false_alarm_per_test: f64,
}

impl Default for TrendStudyParams {
    fn default() -> Self {
        Self {
            baseline_tests: 5,
            thresholds: BTreeMap::new(),
            profiles: LocalParams::default(),
            component_min_relative_std: 0.03,
            component_false_alarm_per_test: 0.001,
        }
    }
}

/// The trends of an axis and its diagnosis.
#[derive(Debug, Clone, Serialize)]
pub struct AxisTrendStudy {
    /// One per indicator with enough tests: the identified parameters (F_s, F_c, σ, v_s, J),
    /// then the mean friction along the travel (by direction, then position), then the
    /// components.
    pub trends: Vec<IndicatorTrend>,
    /// Keys with too few tests for a baseline, or not known to this version.
    pub skipped: Vec<String>,
    /// The stroke tests' friction profiles compared position by position with their baseline
    /// ([`profile_changes`]); `None` when no profile was given.
    pub profiles: Option<ProfileChanges>,
    /// Diagnosis sentences ([`diagnose_with_profiles`]).
    pub diagnosis: Vec<String>,
}

/// Trend every indicator series of an axis ([`assess`]) and diagnose them
/// ([`crate::history::diagnose`]): [`axis_study`] without friction profiles.
///
/// # Errors
/// As [`axis_study`].
pub fn axis_trends(
    series: &BTreeMap<String, IndicatorSeries>,
    reference: Option<i64>,
    params: &TrendStudyParams,
) -> Result<AxisTrendStudy, StudyError> {
    axis_study(series, reference, &[], params)
}

/// Trend every indicator series of an axis ([`assess`]), compare the stroke tests' friction
/// profiles with their baseline position by position ([`profile_changes`]) and diagnose both
/// ([`diagnose_with_profiles`]).
///
/// `series` maps indicator keys ([`Indicator::name`]) to their points; `reference` is the id
/// of the axis's reference test, whose value (and profile) then is the baseline. `profiles`:
/// the grid profiles of the stroke tests in time order ([`super::Curves::grid`]), only of
/// tests the store kept (a test whose strokes the data verdict withheld from a profile has
/// none: they do not reach the comparison).
///
/// Component amplitudes get σ ≥ √(SE² + (c·μ₀)²), c =
/// [`TrendStudyParams::component_min_relative_std`], SE their own standard errors
/// ([`TrendParams::std_error_floor`]), and, being judged together at every test, Shewhart and
/// EWMA limits of the family width ([`family_limit_width`]): the axis's m amplitudes together
/// raise a false alarm in [`TrendStudyParams::component_false_alarm_per_test`] of the tests
/// (0.1 %), not in m × 0.27 % as m independent ±3σ charts would; the limits hold the baseline mean's own error
/// ([`TrendParams::baseline_mean_error`]).
///
/// # Errors
/// [`StudyError::Trend`] when a series cannot be assessed for a reason other than too few
/// tests (those are listed in [`AxisTrendStudy::skipped`]) or the profiles cannot be
/// compared (times not increasing, non-finite values, parameters out of range).
pub fn axis_study(
    series: &BTreeMap<String, IndicatorSeries>,
    reference: Option<i64>,
    profiles: &[ProfileTest],
    params: &TrendStudyParams,
) -> Result<AxisTrendStudy, StudyError> {
    let mut trends = Vec::new();
    let mut skipped = Vec::new();
    // The component amplitudes are judged together at every test: their limits are widened so
    // that the family as a whole keeps the chosen false-alarm rate (Šidák).
    let components = series
        .keys()
        .filter(|n| matches!(Indicator::parse(n), Some(Indicator::Component { .. })))
        .count();
    let component_l = family_limit_width(params.component_false_alarm_per_test, components);
    for (name, s) in series {
        let Some(ind) = Indicator::parse(name) else {
            skipped.push(name.clone());
            continue;
        };
        let pts: Vec<Point> = s.iter().map(|(_, p)| *p).collect();
        let baseline = match reference.and_then(|r| s.iter().position(|(id, _)| *id == r)) {
            Some(index) => BaselineSpec::Reference {
                index,
                spread_count: params.baseline_tests.min(pts.len()),
            },
            None => BaselineSpec::FirstN {
                count: params.baseline_tests,
            },
        };
        let trend_params = if matches!(ind, Indicator::Component { .. }) {
            TrendParams {
                baseline,
                min_relative_std: params.component_min_relative_std,
                std_error_floor: true,
                shewhart_l: component_l,
                ewma_l: component_l,
                baseline_mean_error: true,
                ..TrendParams::default()
            }
        } else {
            TrendParams {
                baseline,
                ..TrendParams::default()
            }
        };
        let th = params.thresholds.get(name).copied().unwrap_or_default();
        match assess(&ind, &pts, &trend_params, &th) {
            Ok(t) => trends.push(t),
            Err(HistoryError::TooFewPoints { .. }) => skipped.push(name.clone()),
            Err(source) => {
                return Err(StudyError::Trend {
                    indicator: name.clone(),
                    source,
                })
            }
        }
    }
    let rank = |i: &Indicator| match i {
        Indicator::StaticFriction => 0,
        Indicator::CoulombFriction => 1,
        Indicator::Viscous => 2,
        Indicator::StribeckVelocity => 3,
        Indicator::Inertia => 4,
        Indicator::MeanFriction { .. } => 5,
        Indicator::Component { .. } => 6,
    };
    let start = |i: &Indicator| match i {
        Indicator::MeanFriction { start_mm, .. } => *start_mm,
        _ => 0.0,
    };
    // Stable: within a rank, names (direction first) stay in order; intervals by position.
    trends.sort_by(|a, b| {
        rank(&a.indicator)
            .cmp(&rank(&b.indicator))
            .then_with(|| {
                let (da, db) = (a.indicator.name(), b.indicator.name());
                let dir = |n: &str| n.split('/').nth(1).map(str::to_string);
                dir(&da).cmp(&dir(&db))
            })
            .then(start(&a.indicator).total_cmp(&start(&b.indicator)))
    });
    // Without a baseline nothing can have left it: say what is missing instead of reading
    // silence as health.
    let most = series.values().map(|s| s.len()).max().unwrap_or(0);
    let short = skipped
        .iter()
        .filter(|n| Indicator::parse(n).is_some())
        .count();
    let changes = if profiles.is_empty() {
        None
    } else {
        Some(
            profile_changes(profiles, reference, &params.profiles).map_err(|source| {
                StudyError::Trend {
                    indicator: "friction profile".into(),
                    source,
                }
            })?,
        )
    };
    let mut diagnosis = if trends.is_empty() {
        vec![format!(
            "No indicator has a baseline yet: a baseline needs {} tests and the series have \
             at most {most}; {} more test(s) are needed before a change can be detected (no \
             statement about the condition is possible yet).",
            params.baseline_tests,
            params.baseline_tests.saturating_sub(most).max(1)
        )]
    } else {
        diagnose_with_profiles(&trends, changes.as_ref())
    };
    if trends.is_empty() {
        // What the profiles already allow (after 1, 2, 3 stroke tests) is worth saying even
        // before the indicators have a baseline.
        diagnosis.extend(
            diagnose_with_profiles(&[], changes.as_ref())
                .into_iter()
                .filter(|s| !s.starts_with("No indicator has left its baseline band")),
        );
    }
    if !trends.is_empty() && short > 0 {
        diagnosis.push(format!(
            "{short} indicator(s) have too few tests for a baseline and are not assessed."
        ));
    }
    Ok(AxisTrendStudy {
        trends,
        skipped,
        profiles: changes,
        diagnosis,
    })
}
