//! Friction over position and feed from a test set of many runs (paper 000 Section 4.2).
//!
//! # Method
//! 1. **Test set** ([`TestSet`]): runs of one axis listed in an index CSV
//!    `file,feed_mm_min,repeat` (paths relative to the index, more columns allowed). Every run
//!    is estimated in parallel ([`estimate_set_with`]; from files: `feedscope_io::test_set`); a
//!    run that fails is kept as a
//!    [`RunFailure`] with its name and the others go on. Strokes whose measured feed differs
//!    from the run's nominal feed by more than [`MapParams::stroke_feed_tolerance`] (e.g. a
//!    rapid return) are left out with a warning. The map uses the nominal feeds of the index:
//!    the measured plateau feed of a slow stroke is biased by position quantisation.
//! 2. **Common breakpoints** ([`build_map`]): per direction, the mapped span is the
//!    intersection of every stroke's span, shrunk by [`MapParams::margin_mm`] at both ends and
//!    put on the resampling grid k·p/m. Its interior breakpoints are given, or by default
//!    K = clamp(⌊L/(4·p)⌋, 1, 3) equal intervals (L the span, p the lead: at least four leads
//!    per interval, at most the paper's three), quartic in each interval (paper 000 Table 2).
//!    Every stroke is fitted with these breakpoints and orders by
//!    [`fit_piecewise`](crate::profile::fit_piecewise) (Eq. 6 with value and slope continuity).
//! 3. **PPOCM** (piecewise polynomials of the coefficient means, Section 4.2.1): the repeats of
//!    one feed are averaged coefficient by coefficient. The basis is linear in the
//!    coefficients, so the PPOCM is the pointwise mean of the repeats' IAFV curves — the
//!    paper's MVOIAF. The **repeatability** of each interval ([`IntervalRepeatability`]) is the
//!    RMS over the interval of the pointwise sample standard deviation of the repeats (n − 1
//!    in the denominator) and the largest pointwise spread max − min.
//! 4. **Feed dependence** (Eq. 8, [`FeedPolynomial`]): each mean coefficient ā_{ijk} is a
//!    polynomial of the feed, fitted by least squares in the scaled variable
//!    u = 2·(g(f) − g(f_min))/(g(f_max) − g(f_min)) − 1 ∈ [−1, 1] with g = ln (default) or the
//!    identity, in a Legendre basis of u (well conditioned at any order used here). The order
//!    is q = min([`MapParams::feed_order`] (default 5, the paper's quintic), n_feeds − 2),
//!    never below 0: at least one residual degree of freedom is kept so that the misfit shows;
//!    one or two feeds give a map constant in feed. The result is the friction map F(z, v) of
//!    each direction ([`DirectionMap`], [`FrictionMap`]), valid over the mapped span and the
//!    measured feeds only: evaluating outside them is an error unless extrapolation is asked.
//! 5. **Stribeck along the travel** ([`stribeck_profile`], Eq. 9): at a position z the data
//!    points are |PPOCM_f(z)| for every measured feed f; one
//!    [`StribeckFitter`](crate::stribeck::StribeckFitter) is planned per direction and reused
//!    at every position. Where the feeds do not determine a Stribeck curve (fewer than 4
//!    distinct feeds, a singular or ill-conditioned fit, non-physical values) the fit is the
//!    Coulomb + viscous line instead, said so in
//!    [`StribeckFit::model`](crate::stribeck::StribeckFit::model) and
//!    [`StribeckFit::reductions`](crate::stribeck::StribeckFit::reductions) (module
//!    [`stribeck::fit::reduce`](crate::stribeck::fit::reduce)); one feed is refused by the
//!    map study. Non-conventional behaviour (friction falling with feed where the
//!    Stribeck curve rises) is detected at each position by
//!    [`detect_nonconventional`](crate::stribeck::detect_nonconventional) and gathered into
//!    position spans by [`nonconventional_spans`].
//!
//! # Conventions
//! Positions in mm (machine coordinates), feeds in mm/min, friction in N signed as in paper 000
//! Eq. 5: positive while moving forward (position increasing), negative backward. Stribeck
//! parameters are magnitudes.
//!
//! # Example
//! ```
//! use feedscope::estimate::{Direction, StrokeFriction, StrokeSummary};
//! use feedscope::map::{build_map, FeedScale, MapParams, RunFriction, TestRun};
//!
//! // Two feeds × two identical repeats of a 40 mm forward stroke on a 10 mm lead, synthetic:
//! // F = 200 + 0.5·z + 3000·v (N, z in mm, v in m/s).
//! let stroke = |feed: f64| {
//!     let step = 0.01 / 1024.0;
//!     let z: Vec<f64> = (0..4097).map(|k| 0.01 + k as f64 * step).collect();
//!     let v = feedscope::units::feed_mm_min_to_m_s(feed);
//!     let f: Vec<f64> = z.iter().map(|&z| 200.0 + 500.0 * z + 3000.0 * v).collect();
//!     let n = z.len();
//!     StrokeFriction {
//!         summary: StrokeSummary {
//!             stroke: 0, direction: Direction::Forward, feed_mm_min: feed,
//!             feed_min_mm_min: None, feed_max_mm_min: None,
//!             start_mm: 10.0, end_mm: 50.0, length_mm: 40.0, start_time_s: 0.0,
//!             end_time_s: 1.0, mean_friction_n: 0.0, friction_std_n: 0.0,
//!             position_samples: n, effort_samples: n, points: n,
//!             raw_samples_per_lead: 100.0, max_order: 40.0, position_cutoff_order: None,
//!             kind: feedscope::estimate::MoveKind::Measuring, position_cutoff_hz: None,
//!             settle_margin_s: 0.0, noise_floor: Default::default(), program_line: None,
//!             mean_friction_se_n: None,
//!             effort_quantum_n: 0.0,
//!             verdict: None,
//!             programmed_feed_mm_min: None,
//!             warnings: vec![],
//!         },
//!         time_s: vec![0.0; n], velocity_m_s: vec![v; n], accel_m_s2: vec![0.0; n],
//!         effort: vec![0.0; n], position_m: z, friction_n: f,
//!     }
//! };
//! let mut runs = Vec::new();
//! for feed in [100.0, 500.0, 1000.0] {
//!     for repeat in 1..=2 {
//!         let run = TestRun { name: format!("f{feed}-{repeat}"), file: "".into(),
//!                             feed_mm_min: feed, repeat };
//!         runs.push(RunFriction { run, strokes: vec![stroke(feed)], warnings: vec![] });
//!     }
//! }
//! // Three feeds: a feed polynomial of order 3 − 2 = 1, here in the feed itself.
//! let params = MapParams { feed_scale: FeedScale::Linear, ..MapParams::default() };
//! let map = build_map(&runs, 0.01, &params).unwrap();
//! let fwd = map.direction(Direction::Forward).unwrap();
//! assert_eq!(fwd.feeds.len(), 3);
//! assert_eq!(fwd.feed_model.order, 1);
//! let f = fwd.friction_n(30.0, 1000.0, false).unwrap();
//! assert!((f - (200.0 + 15.0 + 50.0)).abs() < 1e-6);
//! assert!(fwd.friction_n(30.0, 2000.0, false).is_err()); // beyond the measured feeds
//! ```
//!
//! # Reference
//! Paper 000 Section 4.2.1, Eq. 6, 8 and 9, Table 3, Figures 11-15.

mod feed;
mod ppocm;
mod set;
mod stribeck_map;
#[cfg(test)]
mod tests;

pub use feed::{FeedPolynomial, FeedScale};
pub use ppocm::{
    build_map, DirectionMap, FeedGroup, FrictionMap, IntervalRepeatability, RepeatCurve,
};
pub use set::{
    estimate_set_with, estimate_set_with_warnings, RunFailure, RunFriction, RunWarning,
    SetEstimate, TestRun, TestSet,
};
pub use stribeck_map::{
    nonconventional_spans, stribeck_profile, NonConventionalSpan, StribeckAtPosition,
    StribeckProfile,
};

use serde::{Deserialize, Serialize};

use crate::profile::ProfileError;
use crate::stribeck::{NonConventionalParams, StribeckError, StribeckFitParams};
use crate::stroke::Direction;

/// Why building or using a friction map failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MapError {
    /// The index CSV is unreadable or malformed.
    #[error("{source_name}:{line}: {message}")]
    Index {
        /// Index file name.
        source_name: String,
        /// Line (1-based; 0 for the whole file).
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// No stroke of any run is usable.
    #[error("no run gave a usable stroke (at the run's feed) in either direction")]
    NoStrokes,
    /// The strokes of one direction share too short a span.
    #[error(
        "the {direction:?} strokes share only [{lo_mm:.3}, {hi_mm:.3}] mm (after the margin); \
         a map needs a common span of at least {min_mm:.3} mm"
    )]
    NoCommonSpan {
        /// Direction.
        direction: Direction,
        /// Start of the common span (mm).
        lo_mm: f64,
        /// End of the common span (mm).
        hi_mm: f64,
        /// Shortest span accepted (mm).
        min_mm: f64,
    },
    /// A position lies outside the mapped span of a direction.
    #[error(
        "position {position_mm} mm is outside the mapped travel [{lo_mm:.3}, {hi_mm:.3}] mm \
         of the {direction:?} direction"
    )]
    PositionOutside {
        /// Direction.
        direction: Direction,
        /// The position asked for (mm).
        position_mm: f64,
        /// Start of the mapped span (mm).
        lo_mm: f64,
        /// End of the mapped span (mm).
        hi_mm: f64,
    },
    /// A feed lies outside the measured feeds and extrapolation was not asked for.
    #[error(
        "feed {feed_mm_min} mm/min is outside the measured feeds [{min_mm_min}, {max_mm_min}] \
         mm/min of the {direction:?} direction (no extrapolation without asking)"
    )]
    FeedOutside {
        /// Direction.
        direction: Direction,
        /// The feed asked for (mm/min).
        feed_mm_min: f64,
        /// Slowest measured feed (mm/min).
        min_mm_min: f64,
        /// Fastest measured feed (mm/min).
        max_mm_min: f64,
    },
    /// A setting is out of its range.
    #[error("{name} = {value} is out of range: {expected}")]
    BadParameter {
        /// Setting name.
        name: &'static str,
        /// Its value.
        value: f64,
        /// The allowed range, for people.
        expected: &'static str,
    },
    /// A piecewise fit of one stroke failed.
    #[error("run {run}, {direction:?} stroke: {source}")]
    Profile {
        /// Run name.
        run: String,
        /// Direction.
        direction: Direction,
        /// The cause.
        source: ProfileError,
    },
    /// The Stribeck fit could not be planned or run.
    #[error(transparent)]
    Stribeck(#[from] StribeckError),
}

impl MapError {
    /// What the error means to a caller: [`BadInput`](crate::ErrorKind::BadInput), or the kind of the profile's error for [`MapError::Profile`].
    pub fn kind(&self) -> crate::ErrorKind {
        use crate::ErrorKind;
        match self {
            MapError::Profile { source, .. } => source.kind(),
            _ => ErrorKind::BadInput,
        }
    }
}

/// Settings of [`build_map`] and [`stribeck_profile`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MapParams {
    /// Interior breakpoints (mm) common to every feed and direction; `None` (default) = the
    /// equal-interval rule of the module docs, per direction.
    pub breaks_mm: Option<Vec<f64>>,
    /// Polynomial order of each interval; `None` (default) = 4 (quartic) in every interval.
    pub orders: Option<Vec<usize>>,
    /// Trimmed from both ends of the common span (mm), ≥ 0. Default 1.
    pub margin_mm: f64,
    /// Shortest common span accepted (mm), > 0. Default 2.
    pub min_span_mm: f64,
    /// Highest order of the feed polynomial (Eq. 8). Default 5 (quintic).
    pub feed_order: usize,
    /// Scaled feed variable of the feed polynomial. Default [`FeedScale::Log`].
    pub feed_scale: FeedScale,
    /// Runs whose nominal feeds differ by less than this fraction are one feed group.
    /// Default 0.02.
    pub feed_tolerance: f64,
    /// Strokes whose measured feed differs from the run's nominal feed by more than this
    /// fraction are left out (a rapid return, a move at another feed). Default 0.25: the
    /// measured plateau feed of slow strokes is biased by position quantisation (5 % at
    /// 16 mm/min with 1 µm steps every 20 ms).
    pub stroke_feed_tolerance: f64,
    /// Evaluation points per interval for the repeatability figures. Default 64.
    pub repeatability_points: usize,
    /// Stribeck fit settings (δ fixed at 2 by default, Eq. 9).
    pub stribeck: StribeckFitParams,
    /// Non-conventional behaviour detection settings.
    pub nonconventional: NonConventionalParams,
}

impl Default for MapParams {
    fn default() -> Self {
        Self {
            breaks_mm: None,
            orders: None,
            margin_mm: 1.0,
            min_span_mm: 2.0,
            feed_order: 5,
            feed_scale: FeedScale::Log,
            feed_tolerance: 0.02,
            stroke_feed_tolerance: 0.25,
            repeatability_points: 64,
            stribeck: StribeckFitParams::default(),
            nonconventional: NonConventionalParams::default(),
        }
    }
}

impl MapParams {
    /// Check the settings.
    ///
    /// # Errors
    /// [`MapError::BadParameter`] for a negative or non-finite margin, a non-positive minimum
    /// span or tolerance, or fewer than 2 repeatability points.
    pub fn validate(&self) -> Result<(), MapError> {
        let bad = |name, value: f64, expected| MapError::BadParameter {
            name,
            value,
            expected,
        };
        if !(self.margin_mm.is_finite() && self.margin_mm >= 0.0) {
            return Err(bad("margin_mm", self.margin_mm, "finite and ≥ 0"));
        }
        if !(self.min_span_mm.is_finite() && self.min_span_mm > 0.0) {
            return Err(bad("min_span_mm", self.min_span_mm, "finite and > 0"));
        }
        if !(self.feed_tolerance.is_finite() && self.feed_tolerance > 0.0) {
            return Err(bad("feed_tolerance", self.feed_tolerance, "finite and > 0"));
        }
        if self.repeatability_points < 2 {
            return Err(bad(
                "repeatability_points",
                self.repeatability_points as f64,
                "at least 2",
            ));
        }
        if let Some(b) = &self.breaks_mm {
            if let Some(&x) = b.iter().find(|x| !x.is_finite()) {
                return Err(bad("breaks_mm", x, "finite positions"));
            }
            if b.windows(2).any(|w| w[1] <= w[0]) {
                return Err(bad("breaks_mm", f64::NAN, "strictly increasing"));
            }
            let n = self.orders.as_ref().map_or(b.len() + 1, Vec::len);
            if n != b.len() + 1 {
                return Err(bad("orders", n as f64, "one more than the breakpoints"));
            }
        }
        Ok(())
    }
}

/// Legendre polynomials P_0..P_{n−1} at t (three-term recurrence).
pub(crate) fn legendre(t: f64, out: &mut [f64]) {
    for j in 0..out.len() {
        out[j] = match j {
            0 => 1.0,
            1 => t,
            _ => {
                let jf = j as f64;
                ((2.0 * jf - 1.0) * t * out[j - 1] - (jf - 1.0) * out[j - 2]) / jf
            }
        };
    }
}
