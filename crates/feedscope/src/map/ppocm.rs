//! Common breakpoints, piecewise fits of every stroke, PPOCM per feed and repeatability
//! (paper 000 Section 4.2.1, Eq. 6), then the feed polynomial of every mean coefficient.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::feed::FeedPolynomial;
use super::{MapError, MapParams, RunFriction};
use crate::profile::{fit_piecewise, PiecewisePoly};
use crate::stroke::Direction;

/// One repeat's IAFV: a stroke fitted with the common breakpoints and orders.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RepeatCurve {
    /// Run name (from the index).
    pub run: String,
    /// Repeat number from the index.
    pub repeat: u32,
    /// Stroke number within the run's trace.
    pub stroke: usize,
    /// Measured feed of the stroke (mm/min).
    pub measured_feed_mm_min: f64,
    /// The fitted piecewise polynomial (signed friction, N).
    pub poly: PiecewisePoly,
    /// Residual standard deviation of the fit (N): the fluctuation left around the IAFV.
    pub residual_std_n: f64,
}

/// How well the repeats of one feed agree over one interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct IntervalRepeatability {
    /// Interval start (mm).
    pub start_mm: f64,
    /// Interval end (mm).
    pub end_mm: f64,
    /// Mean of the PPOCM over the interval (N, signed).
    pub mean_n: f64,
    /// RMS over the interval of the pointwise sample standard deviation of the repeats' IAFV
    /// (N); `None` with a single repeat.
    pub std_n: Option<f64>,
    /// Largest pointwise spread max − min of the repeats' IAFV over the interval (N); 0 with a
    /// single repeat.
    pub max_spread_n: f64,
}

/// The repeats of one feed and their mean parameter curve.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FeedGroup {
    /// Nominal feed (mm/min): the mean of the runs' index feeds.
    pub feed_mm_min: f64,
    /// The repeats (one per stroke of this direction).
    pub repeats: Vec<RepeatCurve>,
    /// Piecewise polynomial of the coefficient means (PPOCM): the MVOIAF curve (N, signed).
    pub ppocm: PiecewisePoly,
    /// Repeatability per interval.
    pub repeatability: Vec<IntervalRepeatability>,
}

/// The friction map of one direction.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DirectionMap {
    /// Direction.
    pub direction: Direction,
    /// Start of the mapped span (mm).
    pub start_mm: f64,
    /// End of the mapped span (mm).
    pub end_mm: f64,
    /// Breakpoints including both ends (mm), common to every feed.
    pub breaks_mm: Vec<f64>,
    /// Polynomial order of every interval.
    pub orders: Vec<usize>,
    /// Feed groups by increasing feed.
    pub feeds: Vec<FeedGroup>,
    /// Eq. 8: every PPOCM coefficient as a polynomial of the feed.
    pub feed_model: FeedPolynomial,
}

impl DirectionMap {
    /// Map value F(z, v) (N, signed) at `position_mm` and `feed_mm_min` (Eq. 6 with the
    /// coefficients of Eq. 8).
    ///
    /// # Errors
    /// [`MapError::PositionOutside`] outside the mapped span; [`MapError::FeedOutside`]
    /// outside the measured feeds unless `extrapolate`.
    pub fn friction_n(
        &self,
        position_mm: f64,
        feed_mm_min: f64,
        extrapolate: bool,
    ) -> Result<f64, MapError> {
        self.check_position(position_mm)?;
        let poly = self.poly_at(feed_mm_min, extrapolate)?;
        Ok(poly.value_n(position_mm * 1e-3))
    }

    /// The map's section at one feed: the piecewise polynomial over the span (N, signed).
    ///
    /// # Errors
    /// [`MapError::FeedOutside`] outside the measured feeds unless `extrapolate`.
    pub fn poly_at(&self, feed_mm_min: f64, extrapolate: bool) -> Result<PiecewisePoly, MapError> {
        let m = &self.feed_model;
        // Relative slack for feeds written with rounding (e.g. 12.0 for 11.99999).
        let slack = 1e-9;
        let inside = feed_mm_min >= m.feed_min_mm_min * (1.0 - slack)
            && feed_mm_min <= m.feed_max_mm_min * (1.0 + slack);
        if !(extrapolate || inside) {
            return Err(MapError::FeedOutside {
                direction: self.direction,
                feed_mm_min,
                min_mm_min: m.feed_min_mm_min,
                max_mm_min: m.feed_max_mm_min,
            });
        }
        Ok(PiecewisePoly {
            breaks_mm: self.breaks_mm.clone(),
            orders: self.orders.clone(),
            coeffs_n: m.coefficients_at(feed_mm_min),
        })
    }

    /// Check that a position lies in the mapped span.
    ///
    /// # Errors
    /// [`MapError::PositionOutside`].
    pub fn check_position(&self, position_mm: f64) -> Result<(), MapError> {
        // Positions are compared to 1 nm: the span ends are grid values printed with rounding.
        let tol = 1e-6;
        if position_mm >= self.start_mm - tol && position_mm <= self.end_mm + tol {
            Ok(())
        } else {
            Err(MapError::PositionOutside {
                direction: self.direction,
                position_mm,
                lo_mm: self.start_mm,
                hi_mm: self.end_mm,
            })
        }
    }

    /// Nominal feeds of the groups (mm/min), increasing.
    pub fn feeds_mm_min(&self) -> Vec<f64> {
        self.feeds.iter().map(|g| g.feed_mm_min).collect()
    }
}

/// Friction maps of the directions that had strokes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrictionMap {
    /// One map per direction present (forward first).
    pub directions: Vec<DirectionMap>,
}

impl FrictionMap {
    /// The map of one direction, if it was measured.
    pub fn direction(&self, direction: Direction) -> Option<&DirectionMap> {
        self.directions.iter().find(|d| d.direction == direction)
    }
}

/// Build the friction map of a test set (module docs, steps 2-4). `lead_m` (m) sets the
/// default breakpoint rule.
///
/// # Errors
/// [`MapError::NoStrokes`] when no run has a stroke; [`MapError::NoCommonSpan`] when a
/// direction's strokes share less than [`MapParams::min_span_mm`]; [`MapError::Profile`]
/// when a stroke cannot be fitted with the common layout (e.g. a breakpoint outside the span,
/// an order too high for its points); [`MapError::BadParameter`] for bad settings.
pub fn build_map(
    runs: &[RunFriction],
    lead_m: f64,
    params: &MapParams,
) -> Result<FrictionMap, MapError> {
    params.validate()?;
    if !(lead_m.is_finite() && lead_m > 0.0) {
        return Err(MapError::BadParameter {
            name: "lead_m",
            value: lead_m,
            expected: "finite and > 0",
        });
    }
    let mut directions = Vec::new();
    for dir in [Direction::Forward, Direction::Backward] {
        if runs
            .iter()
            .any(|r| r.strokes.iter().any(|s| s.summary.direction == dir))
        {
            directions.push(direction_map(runs, dir, lead_m, params)?);
        }
    }
    if directions.is_empty() {
        return Err(MapError::NoStrokes);
    }
    Ok(FrictionMap { directions })
}

fn direction_map(
    runs: &[RunFriction],
    dir: Direction,
    lead_m: f64,
    params: &MapParams,
) -> Result<DirectionMap, MapError> {
    // (run, stroke) pairs of this direction with at least two points.
    let strokes: Vec<(&RunFriction, &crate::estimate::StrokeFriction)> = runs
        .iter()
        .flat_map(|r| r.strokes.iter().map(move |s| (r, s)))
        .filter(|(_, s)| s.summary.direction == dir && s.position_m.len() >= 2)
        .collect();
    // Common span on the resampling grid (all strokes share the grid k·p/m).
    let step_m = strokes
        .iter()
        .map(|(_, s)| (s.position_m[1] - s.position_m[0]).abs())
        .fold(f64::INFINITY, f64::min);
    let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
    for (_, s) in &strokes {
        let (a, b) = (s.position_m[0], s.position_m[s.position_m.len() - 1]);
        lo = lo.max(a.min(b));
        hi = hi.min(a.max(b));
    }
    let margin_m = params.margin_mm * 1e-3;
    let lo_m = ((lo + margin_m) / step_m - 1e-6).ceil() * step_m;
    let hi_m = ((hi - margin_m) / step_m + 1e-6).floor() * step_m;
    let (start_mm, end_mm) = (lo_m * 1e3, hi_m * 1e3);
    // NaN spans (no stroke) fail too.
    if (end_mm - start_mm).is_nan() || end_mm - start_mm < params.min_span_mm {
        return Err(MapError::NoCommonSpan {
            direction: dir,
            lo_mm: start_mm,
            hi_mm: end_mm,
            min_mm: params.min_span_mm,
        });
    }
    let interior: Vec<f64> = match &params.breaks_mm {
        Some(b) => b.clone(),
        None => {
            let k = ((end_mm - start_mm) / (4.0 * lead_m * 1e3))
                .floor()
                .clamp(1.0, 3.0) as usize;
            (1..k)
                .map(|i| start_mm + (end_mm - start_mm) * i as f64 / k as f64)
                .collect()
        }
    };
    if let Some(&b) = interior.iter().find(|&&b| b <= start_mm || b >= end_mm) {
        return Err(MapError::PositionOutside {
            direction: dir,
            position_mm: b,
            lo_mm: start_mm,
            hi_mm: end_mm,
        });
    }
    let orders = params
        .orders
        .clone()
        .unwrap_or_else(|| vec![4; interior.len() + 1]);
    let mut breaks_mm = Vec::with_capacity(interior.len() + 2);
    breaks_mm.push(start_mm);
    breaks_mm.extend_from_slice(&interior);
    breaks_mm.push(end_mm);

    // Fit every stroke over the common span (step 2), in parallel.
    let tol = 1e-6 * step_m;
    let fits: Vec<Result<(f64, RepeatCurve), MapError>> = strokes
        .par_iter()
        .map(|(r, s)| {
            let idx: Vec<usize> = (0..s.position_m.len())
                .filter(|&j| s.position_m[j] >= lo_m - tol && s.position_m[j] <= hi_m + tol)
                .collect();
            let z: Vec<f64> = idx.iter().map(|&j| s.position_m[j]).collect();
            let f: Vec<f64> = idx.iter().map(|&j| s.friction_n[j]).collect();
            let fit =
                fit_piecewise(&z, &f, &interior, &orders).map_err(|source| MapError::Profile {
                    run: r.run.name.clone(),
                    direction: dir,
                    source,
                })?;
            // The fit's end breaks are its data ends, equal to the span ends up to rounding;
            // use the common ones exactly so that coefficients of repeats are comparable.
            let mut poly = fit.poly;
            poly.breaks_mm.clone_from(&breaks_mm);
            Ok((
                r.run.feed_mm_min,
                RepeatCurve {
                    run: r.run.name.clone(),
                    repeat: r.run.repeat,
                    stroke: s.summary.stroke,
                    measured_feed_mm_min: s.summary.feed_mm_min,
                    poly,
                    residual_std_n: fit.residual_std_n,
                },
            ))
        })
        .collect();
    let mut fits = fits.into_iter().collect::<Result<Vec<_>, _>>()?;
    fits.sort_by(|a, b| a.0.total_cmp(&b.0));

    // Group by nominal feed (step 3).
    let mut groups: Vec<(Vec<f64>, Vec<RepeatCurve>)> = Vec::new();
    for (feed, curve) in fits {
        match groups.last_mut() {
            Some((feeds, curves))
                if (feed - feeds[0]).abs() <= params.feed_tolerance * feeds[0] =>
            {
                feeds.push(feed);
                curves.push(curve);
            }
            _ => groups.push((vec![feed], vec![curve])),
        }
    }
    let feeds: Vec<FeedGroup> = groups
        .into_iter()
        .map(|(f, repeats)| {
            let feed_mm_min = f.iter().sum::<f64>() / f.len() as f64;
            feed_group(feed_mm_min, repeats, &breaks_mm, &orders, params)
        })
        .collect();
    let feed_model = FeedPolynomial::fit(&feeds, params.feed_order, params.feed_scale)?;
    Ok(DirectionMap {
        direction: dir,
        start_mm,
        end_mm,
        breaks_mm,
        orders,
        feeds,
        feed_model,
    })
}

/// PPOCM and repeatability of the repeats of one feed.
fn feed_group(
    feed_mm_min: f64,
    repeats: Vec<RepeatCurve>,
    breaks_mm: &[f64],
    orders: &[usize],
    params: &MapParams,
) -> FeedGroup {
    let n = repeats.len() as f64;
    let coeffs_n: Vec<Vec<f64>> = orders
        .iter()
        .enumerate()
        .map(|(k, &o)| {
            (0..=o)
                .map(|j| repeats.iter().map(|r| r.poly.coeffs_n[k][j]).sum::<f64>() / n)
                .collect()
        })
        .collect();
    let ppocm = PiecewisePoly {
        breaks_mm: breaks_mm.to_vec(),
        orders: orders.to_vec(),
        coeffs_n,
    };
    let m = params.repeatability_points;
    let repeatability = (0..orders.len())
        .map(|k| {
            let (a, b) = (breaks_mm[k], breaks_mm[k + 1]);
            let (mut sum_mean, mut sum_var, mut spread) = (0.0, 0.0, 0.0f64);
            let mut vals = Vec::with_capacity(repeats.len());
            for i in 0..m {
                let x_m = (a + (b - a) * i as f64 / (m - 1) as f64) * 1e-3;
                vals.clear();
                vals.extend(repeats.iter().map(|r| {
                    r.poly
                        .interval_value_slope(k, x_m)
                        .map_or(f64::NAN, |v| v.0)
                }));
                let mean = vals.iter().sum::<f64>() / n;
                sum_mean += mean;
                if repeats.len() > 1 {
                    sum_var += vals.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
                }
                let (lo, hi) = vals
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                        (l.min(v), h.max(v))
                    });
                spread = spread.max(hi - lo);
            }
            IntervalRepeatability {
                start_mm: a,
                end_mm: b,
                mean_n: sum_mean / m as f64,
                std_n: (repeats.len() > 1).then(|| (sum_var / m as f64).sqrt()),
                max_spread_n: spread,
            }
        })
        .collect();
    FeedGroup {
        feed_mm_min,
        repeats,
        ppocm,
        repeatability,
    }
}
