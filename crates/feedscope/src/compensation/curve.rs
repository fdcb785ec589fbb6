//! The friction magnitude curve a table is made from, on the velocity range where it was
//! measured.

use super::{direction_name, CompensationError};
use crate::map::{legendre, DirectionMap, FeedPolynomial};
use crate::profile::PiecewisePoly;
use crate::stribeck::{FitWarning, FrictionModel, StribeckFit, StribeckParams, Termination};
use crate::stroke::Direction;
use crate::units::feed_m_s_to_mm_min;

/// Where a [`FrictionCurve`] comes from.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum CurveSource {
    /// A Stribeck fit (paper 000 Eq. 9), or the reduced model its data determine.
    Stribeck {
        /// The model the fit reports.
        model: FrictionModel,
        /// Its parameters (SI; F_s = F_c and v_s = 0 for a reduced model).
        params: StribeckParams,
    },
    /// The friction map's section at one position: F(z, v) of Eq. 6 with the coefficients of
    /// Eq. 8, as a function of the feed.
    MapSection {
        /// The position z (mm).
        position_mm: f64,
    },
    /// The mean of the two directions' magnitudes, (|F_fwd(v)| + |F_bwd(v)|)/2, on their
    /// common velocity range.
    DirectionMean,
}

#[derive(Debug, Clone, PartialEq)]
enum Shape {
    Stribeck(StribeckParams),
    /// Σ_r d_r·P_r(u(f)): the map's feed polynomial collapsed at one position (signed N).
    FeedSeries {
        feed: Box<FeedPolynomial>,
        coeffs_n: Vec<f64>,
    },
    Mean(Box<FrictionCurve>, Box<FrictionCurve>),
}

/// A friction magnitude curve |F(v)| (N) of one direction (or the mean of both), valid on the
/// velocity range where it was measured.
///
/// Plan once, evaluate many times: a map section is collapsed at its position into one series
/// in the scaled feed when the curve is made, so an evaluation costs a handful of flops.
#[derive(Debug, Clone, PartialEq)]
pub struct FrictionCurve {
    direction: Option<Direction>,
    source: CurveSource,
    shape: Shape,
    lo_m_s: f64,
    hi_m_s: f64,
}

impl FrictionCurve {
    /// The curve of a Stribeck fit of one direction, valid between its slowest and fastest
    /// speed ([`StribeckFit::min_speed_m_s`], [`StribeckFit::max_speed_m_s`]).
    ///
    /// A reduced model (a Coulomb + viscous line where the data do not determine a Stribeck
    /// curve) is accepted: it is what the data determine, and the table says which model it
    /// is. A fit that stopped at its iteration limit is not.
    ///
    /// # Errors
    /// [`CompensationError::NotConverged`] for a fit with [`FitWarning::NotConverged`] or
    /// [`Termination::MaxIterations`]; [`CompensationError::NoRange`] when its speeds do not
    /// span a range (one distinct speed); [`CompensationError::BadParameter`] for a parameter
    /// that is not finite.
    pub fn from_stribeck(
        direction: Direction,
        fit: &StribeckFit,
    ) -> Result<Self, CompensationError> {
        let stalled = fit
            .warnings
            .iter()
            .any(|w| matches!(w, FitWarning::NotConverged { .. }))
            || fit.termination == Termination::MaxIterations;
        if stalled {
            return Err(CompensationError::NotConverged {
                direction: direction.as_str(),
                iterations: fit.iterations,
            });
        }
        let p = fit.params;
        check_finite(&p)?;
        Self::new(
            Some(direction),
            CurveSource::Stribeck {
                model: fit.model,
                params: p,
            },
            Shape::Stribeck(p),
            fit.min_speed_m_s,
            fit.max_speed_m_s,
        )
    }

    /// A Stribeck curve with known parameters (e.g. a simulation's truth) on the velocity
    /// range `lo_m_s`..`hi_m_s` (m/s) where it is to be trusted.
    ///
    /// # Errors
    /// [`CompensationError::NoRange`] for a range that is not two distinct positive speeds;
    /// [`CompensationError::BadParameter`] for a parameter that is not finite.
    pub fn from_params(
        direction: Direction,
        params: StribeckParams,
        lo_m_s: f64,
        hi_m_s: f64,
    ) -> Result<Self, CompensationError> {
        check_finite(&params)?;
        Self::new(
            Some(direction),
            CurveSource::Stribeck {
                model: FrictionModel::Stribeck,
                params,
            },
            Shape::Stribeck(params),
            lo_m_s,
            hi_m_s,
        )
    }

    /// The section of one direction of a friction map at `position_mm`: |F(z, v)| for the
    /// feeds between the slowest and the fastest measured one (Eq. 6 with the coefficients of
    /// Eq. 8).
    ///
    /// At a fixed position the map is linear in its feed-polynomial coefficients, so the
    /// section is one Legendre series in the scaled feed u(f):
    /// F(z, f) = Σ_r d_r·P_r(u(f)) with d_r = Σ_{k} c_{j,k,r}·P_k(t(z)), j the interval of z.
    ///
    /// # Errors
    /// [`CompensationError::BadParameter`] for a position outside the mapped span (named
    /// `position_mm`); [`CompensationError::NoRange`] for a map of one feed.
    pub fn from_map_section(
        map: &DirectionMap,
        position_mm: f64,
    ) -> Result<Self, CompensationError> {
        if map.check_position(position_mm).is_err() || !position_mm.is_finite() {
            return Err(CompensationError::BadParameter {
                name: "position_mm",
                value: position_mm,
                expected: "a position inside the mapped span of the direction",
            });
        }
        let feed = &map.feed_model;
        // d_r: the piecewise polynomial whose coefficients are the r-th Legendre coefficient
        // in u of every PPOCM coefficient, evaluated at z.
        let coeffs_n = (0..=feed.order)
            .map(|r| {
                PiecewisePoly {
                    breaks_mm: map.breaks_mm.clone(),
                    orders: map.orders.clone(),
                    coeffs_n: feed
                        .coeffs
                        .iter()
                        .map(|cj| {
                            cj.iter()
                                .map(|b| b.get(r).copied().unwrap_or(0.0))
                                .collect()
                        })
                        .collect(),
                }
                .value_n(position_mm * 1e-3)
            })
            .collect();
        Self::new(
            Some(map.direction),
            CurveSource::MapSection { position_mm },
            Shape::FeedSeries {
                feed: Box::new(feed.clone()),
                coeffs_n,
            },
            crate::units::feed_mm_min_to_m_s(feed.feed_min_mm_min),
            crate::units::feed_mm_min_to_m_s(feed.feed_max_mm_min),
        )
    }

    /// The mean of a forward and a backward curve, (|F_fwd(v)| + |F_bwd(v)|)/2, on the range
    /// both were measured over: one table for both directions (a control whose compensation
    /// table does not tell the directions apart).
    ///
    /// # Errors
    /// [`CompensationError::NoCommonRange`] when the ranges do not overlap;
    /// [`CompensationError::BadParameter`] when the curves are not one forward and one backward.
    pub fn direction_mean(forward: &Self, backward: &Self) -> Result<Self, CompensationError> {
        if forward.direction != Some(Direction::Forward)
            || backward.direction != Some(Direction::Backward)
        {
            return Err(CompensationError::BadParameter {
                name: "direction",
                value: f64::NAN,
                expected: "one forward and one backward curve",
            });
        }
        let lo = forward.lo_m_s.max(backward.lo_m_s);
        let hi = forward.hi_m_s.min(backward.hi_m_s);
        if hi <= lo {
            let mm = feed_m_s_to_mm_min;
            return Err(CompensationError::NoCommonRange {
                forward_lo_mm_min: mm(forward.lo_m_s),
                forward_hi_mm_min: mm(forward.hi_m_s),
                backward_lo_mm_min: mm(backward.lo_m_s),
                backward_hi_mm_min: mm(backward.hi_m_s),
            });
        }
        Self::new(
            None,
            CurveSource::DirectionMean,
            Shape::Mean(Box::new(forward.clone()), Box::new(backward.clone())),
            lo,
            hi,
        )
    }

    fn new(
        direction: Option<Direction>,
        source: CurveSource,
        shape: Shape,
        lo_m_s: f64,
        hi_m_s: f64,
    ) -> Result<Self, CompensationError> {
        let me = Self {
            direction,
            source,
            shape,
            lo_m_s,
            hi_m_s,
        };
        // Two speeds closer than 1 ppm are one feed written with rounding, not a range.
        if !(lo_m_s.is_finite()
            && hi_m_s.is_finite()
            && lo_m_s > 0.0
            && hi_m_s > lo_m_s * (1.0 + 1e-6))
        {
            return Err(CompensationError::NoRange {
                curve: me.label(),
                lo_mm_min: feed_m_s_to_mm_min(lo_m_s),
                hi_mm_min: feed_m_s_to_mm_min(hi_m_s),
            });
        }
        Ok(me)
    }

    /// Friction magnitude |F(v)| (N) at speed |v| (m/s). Not range-checked: callers keep to
    /// [`Self::range_m_s`] (the table functions of this module do).
    pub fn magnitude_n(&self, speed_m_s: f64) -> f64 {
        let v = speed_m_s.abs();
        match &self.shape {
            Shape::Stribeck(p) => p.magnitude_n(v),
            Shape::FeedSeries { feed, coeffs_n } => {
                let mut p = [0.0; 32];
                let m = coeffs_n.len().min(p.len());
                legendre(feed.u(feed_m_s_to_mm_min(v)), &mut p[..m]);
                coeffs_n
                    .iter()
                    .zip(&p[..m])
                    .map(|(d, p)| d * p)
                    .sum::<f64>()
                    .abs()
            }
            Shape::Mean(a, b) => 0.5 * (a.magnitude_n(v) + b.magnitude_n(v)),
        }
    }

    /// The measured velocity range (m/s): the slowest and the fastest measured speed.
    pub fn range_m_s(&self) -> (f64, f64) {
        (self.lo_m_s, self.hi_m_s)
    }

    /// The direction; `None` for the mean of both directions.
    pub fn direction(&self) -> Option<Direction> {
        self.direction
    }

    /// Where the curve comes from.
    pub fn source(&self) -> &CurveSource {
        &self.source
    }

    /// The Stribeck parameters when the curve is a Stribeck curve (not a reduced model, not a
    /// map section).
    pub fn stribeck(&self) -> Option<&StribeckParams> {
        match &self.source {
            CurveSource::Stribeck {
                model: FrictionModel::Stribeck,
                params,
            } => Some(params),
            _ => None,
        }
    }

    /// What kind of curve it is, without its direction: `a stribeck fit`, `a coulomb-viscous
    /// fit`, `a map section at 40.000 mm`, `a mean of both directions`.
    pub fn kind(&self) -> String {
        match &self.source {
            CurveSource::Stribeck { model, .. } => format!("a {} fit", model.code()),
            CurveSource::MapSection { position_mm } => {
                format!("a map section at {position_mm:.3} mm")
            }
            CurveSource::DirectionMean => "a mean of both directions".to_string(),
        }
    }

    /// What the curve is, for people: e.g. `forward Stribeck fit (Eq. 9)`,
    /// `backward map section at 40.000 mm`, `mean of both directions`.
    pub fn label(&self) -> String {
        let dir = direction_name(self.direction);
        match &self.source {
            CurveSource::Stribeck {
                model: FrictionModel::Stribeck,
                ..
            } => format!("{dir} Stribeck fit (paper 000 Eq. 9)"),
            CurveSource::Stribeck { model, .. } => format!("{dir} {} fit", model.code()),
            CurveSource::MapSection { position_mm } => {
                format!("{dir} map section at {position_mm:.3} mm (Eq. 6 and 8)")
            }
            CurveSource::DirectionMean => match &self.shape {
                Shape::Mean(a, _) => format!(
                    "mean of the forward and backward {}",
                    a.label().trim_start_matches("forward ")
                ),
                _ => "mean of both directions".to_string(),
            },
        }
    }

    /// Check that every table velocity (m/s) lies in the measured range.
    ///
    /// # Errors
    /// [`CompensationError::OutsideRange`] naming the first velocity outside.
    pub(crate) fn check_inside(&self, velocities_m_s: &[f64]) -> Result<(), CompensationError> {
        // Rounding slack: 1e-12 relative, far below any velocity resolution of a control.
        let (lo, hi) = (self.lo_m_s * (1.0 - 1e-12), self.hi_m_s * (1.0 + 1e-12));
        match velocities_m_s.iter().find(|&&v| !(v >= lo && v <= hi)) {
            Some(&v) => Err(CompensationError::OutsideRange {
                curve: self.label(),
                velocity_mm_min: feed_m_s_to_mm_min(v),
                lo_mm_min: feed_m_s_to_mm_min(self.lo_m_s),
                hi_mm_min: feed_m_s_to_mm_min(self.hi_m_s),
            }),
            None => Ok(()),
        }
    }

    /// |F(v)| with a check that it is a positive finite force.
    pub(crate) fn checked_n(&self, speed_m_s: f64) -> Result<f64, CompensationError> {
        let f = self.magnitude_n(speed_m_s);
        if f.is_finite() && f > 0.0 {
            Ok(f)
        } else {
            Err(CompensationError::BadValue {
                curve: self.label(),
                velocity_mm_min: feed_m_s_to_mm_min(speed_m_s),
                value_n: f,
            })
        }
    }
}

fn check_finite(p: &StribeckParams) -> Result<(), CompensationError> {
    for (name, v) in [
        ("fc_n", p.fc_n),
        ("fs_n", p.fs_n),
        ("vs_m_s", p.vs_m_s),
        ("sigma_n_s_per_m", p.sigma_n_s_per_m),
        ("delta", p.delta),
    ] {
        if !v.is_finite() {
            return Err(CompensationError::BadParameter {
                name,
                value: v,
                expected: "a finite Stribeck parameter",
            });
        }
    }
    Ok(())
}
