//! Workflows: from a trace (or a test set's estimates) and an axis to the results a person or
//! a condition history reads, with typed results and one source of defaults.
//!
//! Each workflow chains the domain modules in the order of its paper and stops at values in
//! memory; reading files is `feedscope-io`'s job, keeping results `feedscope-store`'s.
//!
//! | workflow | function | parameters | result |
//! |---|---|---|---|
//! | stroke test (paper 000): estimate → IAFV and spectra → indicators | [`stroke_test`] | [`StrokeStudyParams`] | [`StrokeTest`] |
//! | triangle test (paper 002): identification → indicators | [`triangle_test`] | [`TriangleStudyParams`] | [`TriangleTest`] |
//! | either, by [`TestKind`] | [`analyze_test`] | [`TestStudyParams`] | [`TestAnalysis`] |
//! | friction along the travel (paper 000 Section 4.1): IAFV, spectra, Table 2 of estimated strokes | [`analyze_strokes`] ([`analyze_trace`] from a trace) | [`AnalyzeStudyParams`] | [`AnalyzeStudy`] |
//! | friction map and Stribeck fits of a test set (paper 000 Section 4.2) | [`map_study`] | [`MapStudyParams`] | [`MapStudy`] |
//! | trends and diagnosis of an axis's indicator series | [`axis_trends`] | [`TrendStudyParams`] | [`AxisTrendStudy`] |
//! | the same with the stroke tests' friction compared position by position (local wear) | [`axis_study`] | [`TrendStudyParams`] | [`AxisTrendStudy`] |
//!
//! ```
//! use feedscope::study::{triangle_test, TriangleStudyParams};
//! use feedscope::sim::{simulate_profile, SimConfig};
//! use feedscope::plan::{triangle_program, Limits, TriangleParams};
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let mut cfg = SimConfig::default();
//! cfg.sampling.mode = feedscope::sim::SamplingMode::Synchronous;
//! cfg.sampling.synchronous_rate_hz = 1000.0;
//! cfg.sampling.effort_kind = feedscope::trace::EffortKind::TorqueNm;
//! let program = triangle_program(
//!     &TriangleParams {
//!         window_min_mm: 120.0,
//!         window_max_mm: 200.0,
//!         feed_max_mm_min: 3000.0,
//!         levels: 6,
//!         min_cruise_s: 0.5,
//!         vs_guess_mm_min: 60.0,
//!         ..TriangleParams::default()
//!     },
//!     &Limits::default(),
//! )?;
//! let sim = simulate_profile(&cfg, &program, &mut |_| {})?;
//! let test = triangle_test(&sim.trace, &cfg.axis, &TriangleStudyParams::default())?;
//! // Fs, Fc, σ, vs and J, each with its standard error.
//! assert_eq!(test.indicators.len(), 5);
//! assert!(test.identification.force.fs_n > test.identification.force.fc_n);
//! # Ok(())
//! # }
//! ```
use serde::{Deserialize, Serialize};

use crate::axis::AxisParams;
use crate::estimate::EstimateError;
use crate::history::{HistoryError, Indicator};
use crate::ident::IdentError;
use crate::map::MapError;
use crate::profile::ProfileError;
use crate::trace::Trace;
use crate::ErrorKind;

mod analyze;
mod map;
mod stroke;
mod trend;
mod triangle;
mod withhold;

pub use analyze::{analyze_strokes, analyze_trace, AnalyzeStudy, AnalyzeStudyParams};
pub use map::{map_grid, map_study, MapStudy, MapStudyParams};
pub use stroke::{
    stroke_test, Curves, HeatmapData, IntervalMean, ProfileCurve, StrokeComponent,
    StrokeStudyParams, StrokeTest,
};
pub use trend::{axis_study, axis_trends, AxisTrendStudy, IndicatorSeries, TrendStudyParams};
pub use triangle::{triangle_test, TriangleStudyParams, TriangleTest};
pub use withhold::WithheldStroke;

/// Errors of the workflows: the failing step's error, with where it happened.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StudyError {
    /// The friction estimate of a stroke test failed.
    #[error(transparent)]
    Estimate(#[from] EstimateError),
    /// The analysis of one stroke failed.
    #[error("analysing stroke {stroke} ({direction}): {source}")]
    Stroke {
        /// Stroke number (as the estimate numbers them).
        stroke: usize,
        /// `forward` or `backward`.
        direction: &'static str,
        /// Where the stroke starts (mm).
        start_mm: f64,
        /// Where it ends (mm).
        end_mm: f64,
        /// Why.
        source: ProfileError,
    },
    /// The single polynomial of a stroke's best scanned order could not be fitted.
    #[error("single-polynomial fit of order {order} to stroke {stroke}: {source}")]
    SinglePolynomial {
        /// Stroke number (as the estimate numbers them).
        stroke: usize,
        /// Polynomial order.
        order: usize,
        /// Why.
        source: ProfileError,
    },
    /// Table 2 (the order scan averaged per direction) could not be computed.
    #[error("order scan table: {0}")]
    OrderScanTable(ProfileError),
    /// The one-test identification of a triangle test failed.
    #[error("identification failed: {0}")]
    Identify(#[from] IdentError),
    /// The friction map or a Stribeck fit of a map study failed.
    #[error(transparent)]
    Map(#[from] MapError),
    /// A map needs friction at two feeds or more to say how it changes with feed.
    #[error(
        "a map needs at least two feeds; this test set has only {feed_mm_min} mm/min \
         ({direction:?} strokes)"
    )]
    OneFeed {
        /// Direction with a single feed.
        direction: crate::stroke::Direction,
        /// The feed (mm/min).
        feed_mm_min: f64,
    },
    /// A position asked for the Stribeck fits lies outside a direction's mapped span.
    #[error("Stribeck position: {0}")]
    Position(MapError),
    /// A feed asked for the compensation table lies outside the measured feeds.
    #[error("table feed: {0}")]
    TableFeed(MapError),
    /// No stroke of the recording supports what the workflow needs (see [`crate::verdict`]).
    #[error(
        "no stroke of this recording supports {needed}: {strokes} stroke(s) support {best} at \
         most ({reasons}); `feedscope estimate` prints the data verdict"
    )]
    NotSupported {
        /// What the workflow needs, in words.
        needed: &'static str,
        /// Strokes estimated.
        strokes: usize,
        /// The most any of them supports.
        best: &'static str,
        /// The binding reasons, by code, joined.
        reasons: String,
    },
    /// A parameter of a workflow is out of range.
    #[error("{name} = {value} is out of range: {expected}")]
    BadParameter {
        /// Parameter name.
        name: &'static str,
        /// Its value.
        value: f64,
        /// What it must be.
        expected: &'static str,
    },
    /// The trend of one indicator failed for a reason other than too few tests.
    #[error("trend of {indicator}: {source}")]
    Trend {
        /// Indicator key.
        indicator: String,
        /// Why.
        source: HistoryError,
    },
}

impl StudyError {
    /// What the error means to a caller: the kind of the failing step's error; a single feed,
    /// a position or feed outside the data and a bad parameter are [`ErrorKind::BadInput`].
    pub fn kind(&self) -> ErrorKind {
        match self {
            StudyError::Estimate(e) => e.kind(),
            StudyError::Stroke { source, .. } | StudyError::SinglePolynomial { source, .. } => {
                source.kind()
            }
            StudyError::OrderScanTable(e) => e.kind(),
            StudyError::Identify(e) => e.kind(),
            StudyError::Map(e) | StudyError::Position(e) | StudyError::TableFeed(e) => e.kind(),
            StudyError::Trend { source, .. } => source.kind(),
            StudyError::OneFeed { .. }
            | StudyError::BadParameter { .. }
            | StudyError::NotSupported { .. } => ErrorKind::BadInput,
        }
    }
}

/// Kind of condition test.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TestKind {
    /// Constant-feed idle strokes: estimate + analyze (paper 000).
    Strokes,
    /// Variable-amplitude, variable-velocity triangular wave: one-test identification (paper 002).
    Triangle,
}

impl TestKind {
    /// The word used in files and databases: `strokes` or `triangle`.
    pub fn as_str(self) -> &'static str {
        match self {
            TestKind::Strokes => "strokes",
            TestKind::Triangle => "triangle",
        }
    }
}

/// [`TestKind::as_str`], padded to a width when one is given (`{:<8}`).
impl std::fmt::Display for TestKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.pad(self.as_str())
    }
}

/// The inverse of [`TestKind::as_str`].
impl std::str::FromStr for TestKind {
    type Err = crate::label::LabelError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "strokes" => Ok(TestKind::Strokes),
            "triangle" => Ok(TestKind::Triangle),
            _ => Err(crate::label::LabelError {
                text: s.to_string(),
                what: "test kind",
                expected: "`strokes` or `triangle`",
            }),
        }
    }
}

/// Settings of [`analyze_test`]: those of each kind of test.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TestStudyParams {
    /// For [`TestKind::Strokes`].
    pub strokes: StrokeStudyParams,
    /// For [`TestKind::Triangle`].
    pub triangle: TriangleStudyParams,
}

/// One value of a condition indicator from one test.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IndicatorValue {
    /// Which indicator.
    pub indicator: Indicator,
    /// Value, in [`Indicator::unit`].
    pub value: f64,
    /// Standard error when known and finite.
    pub std_error: Option<f64>,
}

impl IndicatorValue {
    /// A value; a non-finite standard error is dropped (unknown).
    pub fn new(indicator: Indicator, value: f64, std_error: Option<f64>) -> Self {
        Self {
            indicator,
            value,
            std_error: std_error.filter(|s| s.is_finite()),
        }
    }
}

/// The results of one condition test.
#[derive(Debug, Clone)]
pub enum TestAnalysis {
    /// A stroke test (boxed: its curves and verdict make it large).
    Strokes(Box<StrokeTest>),
    /// A triangle test (boxed: the identification's diagnostics make it the large one).
    Triangle(Box<TriangleTest>),
}

impl TestAnalysis {
    /// Kind of the test.
    pub fn kind(&self) -> TestKind {
        match self {
            TestAnalysis::Strokes(_) => TestKind::Strokes,
            TestAnalysis::Triangle(_) => TestKind::Triangle,
        }
    }

    /// Its indicator values.
    pub fn indicators(&self) -> &[IndicatorValue] {
        match self {
            TestAnalysis::Strokes(t) => &t.indicators,
            TestAnalysis::Triangle(t) => &t.indicators,
        }
    }
}

/// Analyse a condition test of the given kind: [`stroke_test`] or [`triangle_test`].
///
/// # Errors
/// As the workflow of the kind.
pub fn analyze_test(
    trace: &Trace,
    axis: &AxisParams,
    kind: TestKind,
    params: &TestStudyParams,
) -> Result<TestAnalysis, StudyError> {
    Ok(match kind {
        TestKind::Strokes => {
            TestAnalysis::Strokes(Box::new(stroke_test(trace, axis, &params.strokes)?))
        }
        TestKind::Triangle => {
            TestAnalysis::Triangle(Box::new(triangle_test(trace, axis, &params.triangle)?))
        }
    })
}

#[cfg(test)]
mod tests;
