//! Eq. 8: every PPOCM coefficient as a polynomial of the feed.

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use super::{legendre, FeedGroup, MapError};

/// The scaled feed variable of the feed polynomial.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FeedScale {
    /// u from ln(feed): suits log-spaced feeds (default).
    #[default]
    Log,
    /// u from the feed itself, as paper 000 Eq. 8.
    Linear,
}

/// ā_{ijk}(v) of paper 000 Eq. 8 for one direction i: for every interval j and coefficient k
/// of the PPOCM, a Legendre series in the scaled feed
/// u = 2·(g(f) − g(f_min))/(g(f_max) − g(f_min)) − 1 (g = ln or identity).
///
/// Fitted by least squares over the feed groups (one point per measured feed, the PPOCM
/// coefficient); order q = min(requested, n_feeds − 2), at least 0 (module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FeedPolynomial {
    /// Scaled variable.
    pub scale: FeedScale,
    /// Slowest measured feed (mm/min), u = −1.
    pub feed_min_mm_min: f64,
    /// Fastest measured feed (mm/min), u = +1.
    pub feed_max_mm_min: f64,
    /// Polynomial order q in u.
    pub order: usize,
    /// `coeffs[j][k]` = the q + 1 Legendre coefficients (N) in u of PPOCM coefficient k of
    /// interval j.
    pub coeffs: Vec<Vec<Vec<f64>>>,
    /// RMS over the feeds and a 64-point grid per interval of map − PPOCM at the measured feeds
    /// (N): how much of the feed dependence the polynomial misses.
    pub rms_misfit_n: f64,
    /// Largest |map − PPOCM| at the measured feeds on the same grid (N).
    pub max_misfit_n: f64,
    /// 2-norm condition number of the Legendre design matrix in u.
    pub condition_number: f64,
}

impl FeedPolynomial {
    /// Fit the feed polynomial to the PPOCMs of `groups` (increasing feed, common layout).
    ///
    /// # Errors
    /// [`MapError::BadParameter`] when there is no group or a feed is not positive with the
    /// log scale.
    pub fn fit(groups: &[FeedGroup], order: usize, scale: FeedScale) -> Result<Self, MapError> {
        let Some(first) = groups.first() else {
            return Err(MapError::NoStrokes);
        };
        let n = groups.len();
        let fmin = groups
            .iter()
            .map(|g| g.feed_mm_min)
            .fold(f64::INFINITY, f64::min);
        let fmax = groups.iter().map(|g| g.feed_mm_min).fold(0.0, f64::max);
        if fmin.is_nan() || fmin <= 0.0 {
            return Err(MapError::BadParameter {
                name: "feed_mm_min",
                value: fmin,
                expected: "> 0",
            });
        }
        let q = order.min(n.saturating_sub(2));
        let mut me = Self {
            scale,
            feed_min_mm_min: fmin,
            feed_max_mm_min: fmax,
            order: q,
            coeffs: Vec::new(),
            rms_misfit_n: 0.0,
            max_misfit_n: 0.0,
            condition_number: 1.0,
        };
        // Design matrix A[i][r] = P_r(u_i); planned once, solved for every coefficient.
        let a = DMatrix::from_fn(n, q + 1, |i, r| {
            let mut p = vec![0.0; q + 1];
            legendre(me.u(groups[i].feed_mm_min), &mut p);
            p[r]
        });
        let svd = a.clone().svd(true, true);
        let sv = &svd.singular_values;
        let (smax, smin) = sv
            .iter()
            .fold((0.0f64, f64::INFINITY), |(h, l), &s| (h.max(s), l.min(s)));
        me.condition_number = smax / smin;
        let eps = 1e-12 * smax;
        let layout = &first.ppocm;
        me.coeffs = layout
            .coeffs_n
            .iter()
            .enumerate()
            .map(|(j, cj)| {
                (0..cj.len())
                    .map(|k| {
                        let b = DVector::from_fn(n, |i, _| groups[i].ppocm.coeffs_n[j][k]);
                        let x = svd.solve(&b, eps).map_or_else(
                            |_| vec![f64::NAN; q + 1],
                            |x| x.iter().copied().collect(),
                        );
                        x
                    })
                    .collect()
            })
            .collect();
        // Misfit at the measured feeds.
        let (mut se, mut count, mut max) = (0.0, 0usize, 0.0f64);
        for g in groups {
            let poly = crate::profile::PiecewisePoly {
                breaks_mm: g.ppocm.breaks_mm.clone(),
                orders: g.ppocm.orders.clone(),
                coeffs_n: me.coefficients_at(g.feed_mm_min),
            };
            for j in 0..poly.orders.len() {
                let (a, b) = (poly.breaks_mm[j], poly.breaks_mm[j + 1]);
                for i in 0..64 {
                    let x = (a + (b - a) * (i as f64 + 0.5) / 64.0) * 1e-3;
                    let d = poly.value_n(x) - g.ppocm.value_n(x);
                    se += d * d;
                    count += 1;
                    max = max.max(d.abs());
                }
            }
        }
        me.rms_misfit_n = (se / count.max(1) as f64).sqrt();
        me.max_misfit_n = max;
        Ok(me)
    }

    /// The scaled feed u ∈ [−1, 1] over the measured feeds (outside it beyond them).
    pub fn u(&self, feed_mm_min: f64) -> f64 {
        let g = |f: f64| match self.scale {
            FeedScale::Log => f.ln(),
            FeedScale::Linear => f,
        };
        let (a, b) = (g(self.feed_min_mm_min), g(self.feed_max_mm_min));
        if b > a {
            2.0 * (g(feed_mm_min) - a) / (b - a) - 1.0
        } else {
            0.0
        }
    }

    /// The PPOCM coefficients (N, Legendre in position as [`PiecewisePoly`](crate::profile::PiecewisePoly))
    /// the polynomial gives at a feed (mm/min); no range check.
    pub fn coefficients_at(&self, feed_mm_min: f64) -> Vec<Vec<f64>> {
        let mut p = vec![0.0; self.order + 1];
        legendre(self.u(feed_mm_min), &mut p);
        self.coeffs
            .iter()
            .map(|cj| {
                cj.iter()
                    .map(|b| b.iter().zip(&p).map(|(x, y)| x * y).sum())
                    .collect()
            })
            .collect()
    }
}
