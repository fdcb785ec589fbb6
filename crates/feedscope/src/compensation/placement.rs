//! Where the N points of a compensation table go, and what the table's straight lines cost.
//!
//! # Choice: minimax knots of the piecewise-linear interpolant
//! A control interpolates linearly between the velocities of its table (assumed for TF5200,
//! see [`super::tf5200`]), so the table's error is the error of the piecewise-linear
//! interpolant L through the chosen points: e(v) = L(v) − F(v). The points are chosen to
//! make the **largest** |e| over the measured range as small as possible (minimax), because
//! a compensation is judged by its worst error, and the worst errors sit where the curve bends
//! (the Stribeck hump at low speed): the knots come out dense there and sparse along the
//! nearly straight viscous part. Equidistributing the curvature (knot density ∝ |F''|^½, the
//! asymptotically optimal density for N → ∞) was the alternative; for the 10-20 points a
//! control holds it is not optimal, and the minimax placement below is exact up to the
//! candidate grid.
//!
//! # Method
//! 1. Candidate grid: M velocities (default 4096) log-spaced over [v_min, v_max], the measured
//!    range, with F evaluated once at each. The first and last are the range's ends exactly.
//! 2. For an error level ε, a greedy sweep from v_min takes each next knot as far right as
//!    the chord from the previous knot stays within ε of F at every grid point between them.
//!    The number of knots the sweep needs is non-increasing in ε, and for a chord error that
//!    grows with the interval the greedy count is the least possible at that level.
//! 3. Bisection on ε (to 1e-10 of the two-point error) finds the least level whose sweep
//!    needs at most N knots; those knots are the table. When fewer than N suffice (e.g. a
//!    straight Coulomb + viscous line), the interval of largest chord error (ties: the longest
//!    in ln v) is split at its point of largest error (its middle when the error is zero) until
//!    there are N.
//! 4. The stated error ([`interpolation_error`]) is measured afterwards on the continuous
//!    curve, not on the grid: `error_points_per_interval` points per table interval (default
//!    256), uniform in ln v.
//!
//! # Error measures
//! - max: max |e(v)| (N), where it is, and max |e(v)|/F(v) (%), over the measured range;
//! - RMS: √(∫ e² d(ln v) / ∫ d(ln v)) (N) and the same of e/F (%), i.e. every decade of
//!   velocity weighs the same (feeds are measured log-spaced, and a uniform weight in v would
//!   let the fast end hide the Stribeck hump), by the trapezoidal rule on the same points.
//!
//! # Reference
//! de Boor, *A Practical Guide to Splines*, Springer 1978, Ch. III (broken-line
//! interpolation, its error and optimal knots).

use super::{CompensationError, FrictionCurve};
use crate::units::feed_m_s_to_mm_min;

/// Settings of [`place_points`] and [`interpolation_error`].
#[derive(Debug, Clone, PartialEq)]
pub struct PlacementParams {
    /// Candidate velocities, log-spaced over the measured range; knots are chosen among them.
    /// Default 2048 (adjacent candidates 0.2 % apart over two decades), at least 16.
    pub grid_points: usize,
    /// Points per table interval, uniform in ln v, at which the stated error is measured.
    /// Default 256, at least 2.
    pub error_points_per_interval: usize,
}

impl Default for PlacementParams {
    fn default() -> Self {
        Self {
            grid_points: 2048,
            error_points_per_interval: 256,
        }
    }
}

impl PlacementParams {
    /// The most table points a placement on this grid gives: a quarter of the grid, so that
    /// every table interval spans several candidates.
    pub fn max_points(&self) -> usize {
        self.grid_points / 4
    }
}

/// The error of a piecewise-linear table against the continuous curve over the range the
/// table spans (module docs, "Error measures").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InterpolationError {
    /// Largest |table − curve| (N).
    pub max_n: f64,
    /// Where it is (m/s).
    pub max_at_m_s: f64,
    /// Largest |table − curve| / curve (%), wherever it is.
    pub max_pct: f64,
    /// RMS of table − curve over ln v (N).
    pub rms_n: f64,
    /// RMS of (table − curve)/curve over ln v (%).
    pub rms_pct: f64,
    /// Points at which the curve was evaluated.
    pub samples: usize,
}

/// A table placed on a curve: velocities and the curve's values there, with its error.
#[derive(Debug, Clone, PartialEq)]
pub struct PlacedTable {
    /// Table velocities (m/s), strictly increasing; the first and last are the ends of the
    /// measured range.
    pub velocity_m_s: Vec<f64>,
    /// The curve's friction magnitude at each (N).
    pub friction_n: Vec<f64>,
    /// The minimax level reached on the candidate grid (N): the largest chord error at grid
    /// points. The continuous error is in `error`.
    pub grid_level_n: f64,
    /// The table's error against the continuous curve.
    pub error: InterpolationError,
}

/// Place `points` table velocities on the measured range of `curve` so that the largest error
/// of linear interpolation between them is as small as possible (module docs).
///
/// # Errors
/// [`CompensationError::TooFewPoints`] below 2; [`CompensationError::TooManyPoints`] above
/// [`PlacementParams::max_points`]; [`CompensationError::BadParameter`] for a grid below 16
/// points or fewer than 2 error points per interval; [`CompensationError::BadValue`] where
/// the curve is not a positive finite force.
pub fn place_points(
    curve: &FrictionCurve,
    points: usize,
    params: &PlacementParams,
) -> Result<PlacedTable, CompensationError> {
    if params.grid_points < 16 {
        return Err(CompensationError::BadParameter {
            name: "grid_points",
            value: params.grid_points as f64,
            expected: "at least 16",
        });
    }
    if points < 2 {
        return Err(CompensationError::TooFewPoints { points });
    }
    if points > params.max_points() {
        return Err(CompensationError::TooManyPoints {
            points,
            max: params.max_points(),
            what: "the placement grid (a quarter of PlacementParams::grid_points)",
        });
    }
    let (lo, hi) = curve.range_m_s();
    let m = params.grid_points;
    let ratio = (hi / lo).ln();
    let g: Vec<f64> = (0..m)
        .map(|i| match i {
            0 => lo,
            i if i == m - 1 => hi,
            i => lo * (ratio * i as f64 / (m - 1) as f64).exp(),
        })
        .collect();
    let f = g
        .iter()
        .map(|&v| curve.checked_n(v))
        .collect::<Result<Vec<f64>, _>>()?;

    let full = chord_error(&g, &f, 0, m - 1, f64::INFINITY);
    let mut knots = vec![0, m - 1];
    let mut level = full;
    // A straight curve (to rounding) needs two knots at any level; otherwise bisect.
    if full > 1e-12 * f.iter().fold(0.0f64, |a, &b| a.max(b)) {
        // A level the sweep meets with `points` knots: the two-point level, unless a chord to
        // an interior point strays further (the chord error need not grow with the interval);
        // at an infinite level the sweep takes two knots, so doubling ends.
        let (mut below, mut above) = (0.0, full);
        knots = loop {
            match greedy(&g, &f, above, points) {
                Some(k) => break k,
                None => above *= 2.0,
            }
        };
        while above - below > 1e-7 * full {
            let mid = 0.5 * (below + above);
            match greedy(&g, &f, mid, points) {
                Some(k) => {
                    above = mid;
                    knots = k;
                }
                None => below = mid,
            }
        }
        level = above;
    }
    fill(&g, &f, &mut knots, points);
    let grid_level_n = knots
        .windows(2)
        .map(|w| chord_error(&g, &f, w[0], w[1], f64::INFINITY))
        .fold(0.0, f64::max);
    let velocity_m_s: Vec<f64> = knots.iter().map(|&k| g[k]).collect();
    let friction_n: Vec<f64> = knots.iter().map(|&k| f[k]).collect();
    let error = interpolation_error(curve, &velocity_m_s, &friction_n, params)?;
    debug_assert!(grid_level_n <= level * (1.0 + 1e-9) + 1e-12);
    Ok(PlacedTable {
        velocity_m_s,
        friction_n,
        grid_level_n,
        error,
    })
}

/// Largest |f_i − chord(a, b)(g_i)| for a < i < b; stops early once it exceeds `stop`.
fn chord_error(g: &[f64], f: &[f64], a: usize, b: usize, stop: f64) -> f64 {
    let (ga, fa) = (g[a], f[a]);
    let slope = (f[b] - fa) / (g[b] - ga);
    let mut worst = 0.0f64;
    for i in a + 1..b {
        worst = worst.max((f[i] - (fa + slope * (g[i] - ga))).abs());
        if worst > stop {
            break;
        }
    }
    worst
}

/// The greedy sweep at level `eps` (module docs, step 2): knot indices, or `None` when it
/// needs more than `cap` knots.
fn greedy(g: &[f64], f: &[f64], eps: f64, cap: usize) -> Option<Vec<usize>> {
    let last = g.len() - 1;
    let mut knots = vec![0];
    let mut a = 0;
    while a < last {
        if knots.len() >= cap {
            return None;
        }
        let mut b = a + 1;
        while b < last && chord_error(g, f, a, b + 1, eps) <= eps {
            b += 1;
        }
        knots.push(b);
        a = b;
    }
    Some(knots)
}

/// Split intervals until there are `points` knots (module docs, step 3).
fn fill(g: &[f64], f: &[f64], knots: &mut Vec<usize>, points: usize) {
    while knots.len() < points {
        let mut best: Option<(usize, f64, f64)> = None; // (interval, error, ln length)
        for (j, w) in knots.windows(2).enumerate() {
            if w[1] - w[0] < 2 {
                continue;
            }
            let e = chord_error(g, f, w[0], w[1], f64::INFINITY);
            let len = (g[w[1]] / g[w[0]]).ln();
            let better = match best {
                None => true,
                Some((_, be, bl)) => match e.total_cmp(&be) {
                    std::cmp::Ordering::Greater => true,
                    std::cmp::Ordering::Equal => len > bl,
                    std::cmp::Ordering::Less => false,
                },
            };
            if better {
                best = Some((j, e, len));
            }
        }
        let Some((j, e, _)) = best else {
            return;
        };
        let (a, b) = (knots[j], knots[j + 1]);
        let split = if e > 0.0 {
            let slope = (f[b] - f[a]) / (g[b] - g[a]);
            (a + 1..b)
                .max_by(|&x, &y| {
                    let ex = (f[x] - (f[a] + slope * (g[x] - g[a]))).abs();
                    let ey = (f[y] - (f[a] + slope * (g[y] - g[a]))).abs();
                    ex.total_cmp(&ey)
                })
                .expect("an interval of at least 2 grid steps")
        } else {
            (a + b) / 2
        };
        knots.insert(j + 1, split);
    }
}

/// The error of the piecewise-linear table (`velocity_m_s`, `values_n`) against `curve`, over
/// the span of the table (module docs, "Error measures"). The table may hold any values (e.g.
/// a controller's rounded integers converted back to N), but its velocities must lie in the
/// curve's measured range.
///
/// # Errors
/// [`CompensationError::BadTable`] for fewer than 2 points, lengths that disagree, velocities
/// not strictly increasing or a value that is not finite;
/// [`CompensationError::OutsideRange`] for a velocity outside the measured range;
/// [`CompensationError::BadValue`] where the curve is not a positive finite force;
/// [`CompensationError::BadParameter`] for fewer than 2 error points per interval.
pub fn interpolation_error(
    curve: &FrictionCurve,
    velocity_m_s: &[f64],
    values_n: &[f64],
    params: &PlacementParams,
) -> Result<InterpolationError, CompensationError> {
    let bad = |reason: String| CompensationError::BadTable { reason };
    if velocity_m_s.len() != values_n.len() {
        return Err(bad(format!(
            "{} velocities but {} values",
            velocity_m_s.len(),
            values_n.len()
        )));
    }
    if velocity_m_s.len() < 2 {
        return Err(bad(format!("{} points; at least 2", velocity_m_s.len())));
    }
    if let Some(w) = velocity_m_s
        .windows(2)
        .find(|w| w[1].partial_cmp(&w[0]) != Some(std::cmp::Ordering::Greater))
    {
        return Err(bad(format!(
            "velocities not strictly increasing ({} then {} mm/min)",
            feed_m_s_to_mm_min(w[0]),
            feed_m_s_to_mm_min(w[1])
        )));
    }
    if let Some(x) = values_n.iter().find(|x| !x.is_finite()) {
        return Err(bad(format!("value {x} is not finite")));
    }
    let k = params.error_points_per_interval;
    if k < 2 {
        return Err(CompensationError::BadParameter {
            name: "error_points_per_interval",
            value: k as f64,
            expected: "at least 2",
        });
    }
    curve.check_inside(velocity_m_s)?;
    let (mut max_n, mut max_at, mut max_pct) = (0.0f64, velocity_m_s[0], 0.0f64);
    let (mut sq_n, mut sq_rel, mut span, mut samples) = (0.0, 0.0, 0.0, 0usize);
    for (w, y) in velocity_m_s.windows(2).zip(values_n.windows(2)) {
        let (va, vb) = (w[0], w[1]);
        // Linear in v between the table points, as the control interpolates.
        let err = |v: f64| -> Result<(f64, f64), CompensationError> {
            let truth = curve.checked_n(v)?;
            Ok((y[0] + (y[1] - y[0]) * (v - va) / (vb - va) - truth, truth))
        };
        let step = (vb / va).ln() / k as f64;
        let at = |j: usize| match j {
            0 => va,
            j if j == k => vb,
            j => va * (step * j as f64).exp(),
        };
        let mut prev: Option<(f64, f64)> = None;
        let (mut peak, mut peak_j) = (-1.0f64, 0);
        for j in 0..=k {
            let v = at(j);
            let (e, truth) = err(v)?;
            let rel = e / truth;
            samples += 1;
            if e.abs() > peak {
                (peak, peak_j) = (e.abs(), j);
            }
            max_pct = max_pct.max(100.0 * rel.abs());
            if let Some((pe, pr)) = prev {
                sq_n += 0.5 * step * (pe * pe + e * e);
                sq_rel += 0.5 * step * (pr * pr + rel * rel);
                span += step;
            }
            prev = Some((e, rel));
        }
        // The maximum between samples: golden section on the samples around the largest.
        let (mut a, mut b) = (at(peak_j.saturating_sub(1)), at((peak_j + 1).min(k)));
        const R: f64 = 0.618_033_988_749_894_9;
        let mut c = b - R * (b - a);
        let mut d = a + R * (b - a);
        let (mut ec, mut ed) = (err(c)?.0.abs(), err(d)?.0.abs());
        for _ in 0..60 {
            if ec > ed {
                (b, d, ed) = (d, c, ec);
                c = b - R * (b - a);
                ec = err(c)?.0.abs();
            } else {
                (a, c, ec) = (c, d, ed);
                d = a + R * (b - a);
                ed = err(d)?.0.abs();
            }
            samples += 1;
        }
        let (v, e) = [(at(peak_j), peak), (c, ec), (d, ed)]
            .into_iter()
            .fold((va, -1.0), |best, x| if x.1 > best.1 { x } else { best });
        max_pct = max_pct.max(100.0 * e / curve.checked_n(v)?);
        if e > max_n {
            (max_n, max_at) = (e, v);
        }
    }
    Ok(InterpolationError {
        max_n,
        max_at_m_s: max_at,
        max_pct,
        rms_n: (sq_n / span).sqrt(),
        rms_pct: 100.0 * (sq_rel / span).sqrt(),
        samples,
    })
}
