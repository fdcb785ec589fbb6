//! Piecewise polynomial least squares with global C¹ continuity (the paper's "piecewise least
//! squares combined with global continuity", section 4.1.1 and its reference 17).
//!
//! Each interval k carries a Legendre series in its own scaled variable
//! t = 2(x − b_k)/(b_{k+1} − b_k) − 1 ∈ [−1, 1], so the columns stay orthogonal-ish and the
//! problem well conditioned at any order used here. Continuity of value and slope at every
//! interior breakpoint is a set of homogeneous linear equations C c = 0; the fit is solved in
//! the null space of C (c = Z z, Z orthonormal), so the constraints hold to rounding whatever
//! the data, and the reduced problem min ‖W^½(A Z z − y)‖ is solved by Householder QR.

use serde::{Deserialize, Serialize};

use super::lsq::{legendre, legendre_derivative, lstsq, null_space, Mat};
use super::ProfileError;

/// Highest polynomial order accepted per interval.
pub const MAX_INTERVAL_ORDER: usize = 20;

/// A piecewise polynomial in a per-interval Legendre basis: the IAFV of Eq. 6 split into
/// intervals.
///
/// In interval k, F(x) = Σ_j `coeffs_n[k][j]` · P_j(t) with t = 2(x − b_k)/(b_{k+1} − b_k) − 1,
/// P_j the Legendre polynomials and b = `breaks_mm`. Outside the first/last interval the end
/// polynomials are extrapolated. A poly whose field lengths disagree (built or deserialized by
/// hand) evaluates to NaN rather than panicking; coefficients beyond order 20 are ignored.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PiecewisePoly {
    /// Interval boundaries in mm (machine coordinates), K + 1 strictly increasing values; the
    /// first and last are the ends of the fitted data.
    pub breaks_mm: Vec<f64>,
    /// Polynomial order of each of the K intervals.
    pub orders: Vec<usize>,
    /// Legendre coefficients (N) of each interval, `orders[k] + 1` per interval.
    pub coeffs_n: Vec<Vec<f64>>,
}

impl PiecewisePoly {
    /// Index of the interval holding `position_mm` (clamped to the first/last interval).
    pub fn interval_of(&self, position_mm: f64) -> usize {
        let k = self.orders.len();
        // breaks_mm[1..k] are the interior breakpoints.
        match self.breaks_mm.get(1..k) {
            Some(interior) if k > 1 => interior.partition_point(|&b| b <= position_mm),
            _ => 0,
        }
    }

    /// (value, slope per mm); NaN for a malformed poly (e.g. edited or deserialized fields
    /// whose lengths disagree) instead of a panic.
    fn eval_interval(&self, k: usize, position_mm: f64) -> (f64, f64) {
        let (Some(&a), Some(&b), Some(c)) = (
            self.breaks_mm.get(k),
            self.breaks_mm.get(k + 1),
            self.coeffs_n.get(k),
        ) else {
            return (f64::NAN, f64::NAN);
        };
        let h = b - a;
        let t = 2.0 * (position_mm - a) / h - 1.0;
        let mut p = [0.0; MAX_INTERVAL_ORDER + 1];
        let mut d = [0.0; MAX_INTERVAL_ORDER + 1];
        let m = c.len().min(MAX_INTERVAL_ORDER + 1);
        legendre(t, &mut p[..m]);
        legendre_derivative(&p[..m], &mut d[..m]);
        let v: f64 = c.iter().zip(&p[..m]).map(|(a, b)| a * b).sum();
        let s: f64 = c.iter().zip(&d[..m]).map(|(a, b)| a * b).sum::<f64>() * 2.0 / h;
        (v, s)
    }

    /// Value (N) at `position_m` (metres, machine coordinates).
    pub fn value_n(&self, position_m: f64) -> f64 {
        let x = position_m * 1e3;
        self.eval_interval(self.interval_of(x), x).0
    }

    /// Slope dF/dx (N per metre) at `position_m`.
    pub fn slope_n_per_m(&self, position_m: f64) -> f64 {
        let x = position_m * 1e3;
        self.eval_interval(self.interval_of(x), x).1 * 1e3
    }

    /// Value (N) and slope (N/m) of interval `k`'s polynomial at `position_m`, evaluated even
    /// outside the interval (to check the continuity at its ends). `None` if `k` is out of range.
    pub fn interval_value_slope(&self, k: usize, position_m: f64) -> Option<(f64, f64)> {
        (k < self.orders.len()).then(|| {
            let (v, s) = self.eval_interval(k, position_m * 1e3);
            (v, s * 1e3)
        })
    }

    /// Coefficients a_0..a_m of interval `k` in the paper's power form (Eq. 6) in the local
    /// variable s = x − b_k (mm): F(x) = Σ_j a_j s^j, a_j in N/mm^j. Informative only: the power
    /// basis is ill-conditioned for high orders, evaluate with [`Self::value_n`].
    /// `None` if `k` is out of range.
    pub fn power_coefficients(&self, k: usize) -> Option<Vec<f64>> {
        let c = self.coeffs_n.get(k)?;
        let h = self.breaks_mm.get(k + 1)? - self.breaks_mm.get(k)?;
        let m = c.len();
        // Legendre polynomials in the power basis of t.
        let mut p_t = vec![0.0; m];
        let mut prev: Vec<f64> = vec![1.0];
        let mut cur: Vec<f64> = vec![0.0, 1.0];
        for (j, cj) in c.iter().enumerate() {
            let lj: &[f64] = if j == 0 { &prev } else { &cur };
            for (i, v) in lj.iter().enumerate() {
                p_t[i] += cj * v;
            }
            if j >= 1 {
                let jf = j as f64;
                let mut next = vec![0.0; j + 2];
                for (i, v) in cur.iter().enumerate() {
                    next[i + 1] += (2.0 * jf + 1.0) * v / (jf + 1.0);
                }
                for (i, v) in prev.iter().enumerate() {
                    next[i] -= jf * v / (jf + 1.0);
                }
                prev = std::mem::replace(&mut cur, next);
            }
        }
        // Substitute t = (2/h)·s − 1 by Horner's scheme on polynomials.
        let alpha = 2.0 / h;
        let mut out = vec![0.0; m];
        for &pi in p_t.iter().rev() {
            let mut next = vec![0.0; m];
            for (i, v) in out.iter().enumerate() {
                if i + 1 < m {
                    next[i + 1] += alpha * v;
                }
                next[i] -= v;
            }
            next[0] += pi;
            out = next;
        }
        Some(out)
    }

    /// Relative jumps of value and slope at every interior breakpoint:
    /// |F_k(b) − F_{k+1}(b)| / max(|F_k(b)|, |F_{k+1}(b)|, tiny), the same for the slope.
    pub fn continuity_defects(&self) -> Vec<ContinuityDefect> {
        (1..self.orders.len())
            .map(|k| {
                let b = self.breaks_mm.get(k).copied().unwrap_or(f64::NAN);
                let (v0, s0) = self.eval_interval(k - 1, b);
                let (v1, s1) = self.eval_interval(k, b);
                let rel = |a: f64, c: f64| (a - c).abs() / a.abs().max(c.abs()).max(1e-300);
                ContinuityDefect {
                    position_mm: b,
                    value_relative: rel(v0, v1),
                    slope_relative: rel(s0, s1),
                }
            })
            .collect()
    }
}

/// Continuity check at one interior breakpoint (see [`PiecewisePoly::continuity_defects`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ContinuityDefect {
    /// Breakpoint (mm).
    pub position_mm: f64,
    /// Relative jump of the value.
    pub value_relative: f64,
    /// Relative jump of the slope.
    pub slope_relative: f64,
}

/// Result of [`fit_piecewise`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PiecewiseFit {
    /// The fitted curve.
    pub poly: PiecewisePoly,
    /// Residual standard deviation sqrt(RSS / (n − free parameters)) (N).
    pub residual_std_n: f64,
    /// Number of free parameters after the continuity constraints.
    pub free_parameters: usize,
    /// Number of points fitted.
    pub points: usize,
    /// Conditioning indicator of the reduced least-squares problem (ratio of the largest to the
    /// smallest |R_jj| of the column-normalised QR).
    pub condition_estimate: f64,
}

/// Interval layout in an internal coordinate u (any affine image of the position).
#[derive(Debug, Clone)]
pub(crate) struct Layout {
    pub breaks: Vec<f64>,
    pub orders: Vec<usize>,
    pub offsets: Vec<usize>,
}

impl Layout {
    pub fn new(breaks: Vec<f64>, orders: Vec<usize>) -> Self {
        let mut offsets = Vec::with_capacity(orders.len() + 1);
        let mut acc = 0;
        offsets.push(0);
        for m in &orders {
            acc += m + 1;
            offsets.push(acc);
        }
        Self {
            breaks,
            orders,
            offsets,
        }
    }
    pub fn n_coef(&self) -> usize {
        *self.offsets.last().unwrap_or(&0)
    }
    /// Value and slope continuity rows C (C c = 0), slope rows scaled by the mean half-width.
    pub fn constraints(&self) -> Vec<Vec<f64>> {
        let n = self.n_coef();
        let mut rows = Vec::new();
        for k in 1..self.orders.len() {
            let (ml, mr) = (self.orders[k - 1], self.orders[k]);
            let hl = self.breaks[k] - self.breaks[k - 1];
            let hr = self.breaks[k + 1] - self.breaks[k];
            let scale = 0.25 * (hl + hr);
            let mut val = vec![0.0; n];
            let mut slope = vec![0.0; n];
            // P_j(1) = 1, P_j(−1) = (−1)^j, P'_j(1) = j(j+1)/2, P'_j(−1) = (−1)^(j+1) j(j+1)/2.
            for j in 0..=ml {
                val[self.offsets[k - 1] + j] = 1.0;
                slope[self.offsets[k - 1] + j] = scale * (j * (j + 1)) as f64 / hl;
            }
            for j in 0..=mr {
                let sgn = if j % 2 == 0 { 1.0 } else { -1.0 };
                val[self.offsets[k] + j] = -sgn;
                slope[self.offsets[k] + j] = scale * sgn * (j * (j + 1)) as f64 / hr;
            }
            rows.push(val);
            rows.push(slope);
        }
        rows
    }
    pub fn to_poly(&self, coef: &[f64], to_mm: impl Fn(f64) -> f64) -> PiecewisePoly {
        PiecewisePoly {
            breaks_mm: self.breaks.iter().map(|&b| to_mm(b)).collect(),
            orders: self.orders.clone(),
            coeffs_n: (0..self.orders.len())
                .map(|k| coef[self.offsets[k]..self.offsets[k + 1]].to_vec())
                .collect(),
        }
    }
}

/// Solution of the internal constrained problem.
#[derive(Debug, Clone)]
pub(crate) struct Solution {
    pub coef: Vec<f64>,
    /// (cos, sin) coefficients (N) of each nuisance sinusoid, in cos(2π f u), sin(2π f u).
    pub sinusoids: Vec<(f64, f64)>,
    pub rss: f64,
    pub free_parameters: usize,
    pub condition_estimate: f64,
}

/// Block-averaged constrained fit.
///
/// `u` sorted increasing; points are grouped into consecutive blocks of `block` points, each
/// block contributing its mean value with weight = its point count. Polynomial columns are the
/// exact block means of the basis; the sinusoid columns (orders `sin_orders`, cycles per unit
/// of u) use the closed-form mean over a uniform block (Dirichlet kernel), exact on a uniform
/// grid. With `block == 1` this is the plain fit on the points.
pub(crate) fn solve(
    layout: &Layout,
    u: &[f64],
    y: &[f64],
    block: usize,
    sin_orders: &[f64],
) -> Result<Solution, ProfileError> {
    let n = u.len();
    let block = block.max(1);
    let nb = n.div_ceil(block);
    let ncoef = layout.n_coef();
    let kint = layout.orders.len();
    let mut d = Mat::zeros(nb, ncoef);
    let mut ybar = vec![0.0; nb];
    let mut wts = vec![0.0; nb];
    let mut centre = vec![0.0; nb];
    let mut spacing = vec![0.0; nb];
    let mut p = [0.0; MAX_INTERVAL_ORDER + 1];
    let mut k = 0;
    for b in 0..nb {
        let (lo, hi) = (b * block, ((b + 1) * block).min(n));
        for i in lo..hi {
            while k + 1 < kint && u[i] >= layout.breaks[k + 1] {
                k += 1;
            }
            let m = layout.orders[k];
            let h = layout.breaks[k + 1] - layout.breaks[k];
            let t = 2.0 * (u[i] - layout.breaks[k]) / h - 1.0;
            legendre(t, &mut p[..=m]);
            for (j, pj) in p[..=m].iter().enumerate() {
                d.add(b, layout.offsets[k] + j, *pj);
            }
            ybar[b] += y[i];
            centre[b] += u[i];
        }
        let cnt = (hi - lo) as f64;
        for j in 0..ncoef {
            d.data[j * nb + b] /= cnt;
        }
        ybar[b] /= cnt;
        centre[b] /= cnt;
        wts[b] = cnt;
        spacing[b] = if hi - lo > 1 {
            (u[hi - 1] - u[lo]) / (cnt - 1.0)
        } else {
            0.0
        };
    }
    let z = null_space(&layout.constraints(), ncoef);
    let q = z.len();
    let s = sin_orders.len();
    let mut a = Mat::zeros(nb, q + 2 * s);
    for (c, zc) in z.iter().enumerate() {
        let col = a.col_mut(c);
        for (j, zj) in zc.iter().enumerate() {
            if *zj != 0.0 {
                let dj = &d.data[j * nb..(j + 1) * nb];
                col.iter_mut().zip(dj).for_each(|(x, v)| *x += zj * v);
            }
        }
    }
    for (si, &f) in sin_orders.iter().enumerate() {
        let w = 2.0 * std::f64::consts::PI * f;
        for b in 0..nb {
            let cnt = wts[b];
            // Mean of cos/sin over `cnt` equally spaced points = Dirichlet factor × centre value.
            let half = 0.5 * w * spacing[b];
            let dir = if cnt > 1.0 && half.sin().abs() > 1e-12 {
                (cnt * half).sin() / (cnt * half.sin())
            } else {
                1.0
            };
            let (sn, cs) = (w * centre[b]).sin_cos();
            a.data[(q + 2 * si) * nb + b] = dir * cs;
            a.data[(q + 2 * si + 1) * nb + b] = dir * sn;
        }
    }
    let mut rhs = ybar;
    for b in 0..nb {
        let sw = wts[b].sqrt();
        rhs[b] *= sw;
        for c in 0..a.cols {
            a.data[c * nb + b] *= sw;
        }
    }
    let r = lstsq(a, rhs).map_err(|column| ProfileError::RankDeficient { column })?;
    let mut coef = vec![0.0; ncoef];
    for (zc, zz) in z.iter().zip(&r.x[..q]) {
        coef.iter_mut().zip(zc).for_each(|(c, v)| *c += zz * v);
    }
    let sinusoids = (0..s)
        .map(|i| (r.x[q + 2 * i], r.x[q + 2 * i + 1]))
        .collect();
    Ok(Solution {
        coef,
        sinusoids,
        rss: r.rss,
        free_parameters: q + 2 * s,
        condition_estimate: r.cond_estimate,
    })
}

/// Check user breakpoints and orders against sorted positions `x` (any unit, same as breaks);
/// returns the full break list (with the data ends).
pub(crate) fn validate_layout(
    x: &[f64],
    interior_breaks: &[f64],
    orders: &[usize],
    to_mm: impl Fn(f64) -> f64,
) -> Result<Vec<f64>, ProfileError> {
    let (lo, hi) = (x[0], x[x.len() - 1]);
    if orders.len() != interior_breaks.len() + 1 {
        return Err(ProfileError::OrdersMismatch {
            orders: orders.len(),
            intervals: interior_breaks.len() + 1,
        });
    }
    let mut prev = lo;
    for (i, &b) in interior_breaks.iter().enumerate() {
        if !b.is_finite() || b <= lo || b >= hi {
            return Err(ProfileError::BreakpointOutsideStroke {
                break_mm: to_mm(b),
                start_mm: to_mm(lo),
                end_mm: to_mm(hi),
            });
        }
        if i > 0 && b <= prev {
            return Err(ProfileError::BreakpointsUnsorted {
                previous_mm: to_mm(prev),
                break_mm: to_mm(b),
            });
        }
        prev = b;
    }
    let mut breaks = Vec::with_capacity(orders.len() + 1);
    breaks.push(lo);
    breaks.extend_from_slice(interior_breaks);
    breaks.push(hi);
    for (k, &m) in orders.iter().enumerate() {
        let (a, b) = (breaks[k], breaks[k + 1]);
        let points = if k + 1 == orders.len() {
            x.iter().filter(|&&v| v >= a && v <= b).count()
        } else {
            x.iter().filter(|&&v| v >= a && v < b).count()
        };
        if m > MAX_INTERVAL_ORDER || points < m + 1 {
            return Err(ProfileError::OrderTooHigh {
                interval: k,
                order: m,
                points,
                start_mm: to_mm(a),
                end_mm: to_mm(b),
            });
        }
    }
    Ok(breaks)
}

/// Fit a C¹-continuous piecewise polynomial to (position, friction) by least squares.
///
/// `interior_breaks_mm` are the breakpoints strictly inside the data range (machine
/// coordinates, strictly increasing), `orders` one order per interval
/// (`interior_breaks_mm.len() + 1`). Value and slope are continuous at every breakpoint
/// (equality-constrained least squares by the null-space method; the constraints hold to
/// rounding). Positions may be increasing or decreasing and need not be uniform.
///
/// # Reference
/// Paper 000, Eq. 6 (polynomial IAFV) and section 4.1.1 (piecewise fit with global continuity).
///
/// # Errors
/// [`ProfileError::TooFewPoints`], [`ProfileError::LengthMismatch`],
/// [`ProfileError::NonFinite`], [`ProfileError::NotMonotonic`] on bad data;
/// [`ProfileError::BreakpointOutsideStroke`], [`ProfileError::BreakpointsUnsorted`],
/// [`ProfileError::OrdersMismatch`], [`ProfileError::OrderTooHigh`] on a bad layout;
/// [`ProfileError::RankDeficient`] if the data cannot determine the coefficients.
///
/// # Example
/// ```
/// use feedscope::profile::fit_piecewise;
/// let x: Vec<f64> = (0..200).map(|i| i as f64 * 1e-3).collect(); // 0..199 mm
/// let y: Vec<f64> = x.iter().map(|&v| 50.0 + 100.0 * v - 400.0 * v * v).collect();
/// let fit = fit_piecewise(&x, &y, &[80.0], &[2, 3]).unwrap();
/// assert!((fit.poly.value_n(0.1234) - (50.0 + 12.34 - 400.0 * 0.1234 * 0.1234)).abs() < 1e-9);
/// ```
pub fn fit_piecewise(
    position_m: &[f64],
    friction_n: &[f64],
    interior_breaks_mm: &[f64],
    orders: &[usize],
) -> Result<PiecewiseFit, ProfileError> {
    if position_m.len() != friction_n.len() {
        return Err(ProfileError::LengthMismatch {
            position: position_m.len(),
            friction: friction_n.len(),
        });
    }
    let n = position_m.len();
    if n < 2 {
        return Err(ProfileError::TooFewPoints { needed: 2, got: n });
    }
    super::prepare::check_finite("position_m", position_m)?;
    super::prepare::check_finite("friction_n", friction_n)?;
    let increasing = position_m[n - 1] > position_m[0];
    let mut x: Vec<f64> = position_m.iter().map(|v| v * 1e3).collect();
    let mut y = friction_n.to_vec();
    if !increasing {
        x.reverse();
        y.reverse();
    }
    if let Some(i) = x.windows(2).position(|w| w[1] <= w[0]) {
        return Err(ProfileError::NotMonotonic { index: i + 1 });
    }
    let breaks = validate_layout(&x, interior_breaks_mm, orders, |v| v)?;
    let layout = Layout::new(breaks, orders.to_vec());
    let sol = solve(&layout, &x, &y, 1, &[])?;
    let dof = n.saturating_sub(sol.free_parameters).max(1);
    Ok(PiecewiseFit {
        poly: layout.to_poly(&sol.coef, |v| v),
        residual_std_n: (sol.rss / dof as f64).sqrt(),
        free_parameters: sol.free_parameters,
        points: n,
        condition_estimate: sol.condition_estimate,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn block_means_reproduce_data_in_the_model_span_exactly() {
        // y = C¹ piecewise cubic/quartic + 3 cos(2π 8.6 u) + 2 sin(2π 0.6 u) on a uniform grid of
        // 1/1024 lead, fitted on blocks of 21 samples (partial last block): the exact block
        // means of every column make the fit exact (to rounding), sinusoids included.
        let n = 12 * 1024 + 7;
        let u: Vec<f64> = (0..n).map(|i| i as f64 / 1024.0).collect();
        let layout = Layout::new(vec![0.0, 5.0, u[n - 1]], vec![3, 4]);
        // A feasible coefficient vector: project arbitrary data on the C¹ set.
        let rough: Vec<f64> = u.iter().map(|v| (v * 0.7).sin() * 30.0 + v * v).collect();
        let truth = solve(&layout, &u, &rough, 1, &[]).unwrap().coef;
        let poly = layout.to_poly(&truth, |v| v);
        let y: Vec<f64> = u
            .iter()
            .map(|&v| {
                poly.value_n(v * 1e-3)
                    + 3.0 * (2.0 * std::f64::consts::PI * 8.6 * v).cos()
                    + 2.0 * (2.0 * std::f64::consts::PI * 0.6 * v).sin()
            })
            .collect();
        let sol = solve(&layout, &u, &y, 21, &[8.6, 0.6]).unwrap();
        for (a, b) in sol.coef.iter().zip(&truth) {
            assert!((a - b).abs() < 1e-9 * (1.0 + b.abs()), "{a} vs {b}");
        }
        assert!((sol.sinusoids[0].0 - 3.0).abs() < 1e-9 && sol.sinusoids[0].1.abs() < 1e-9);
        assert!(sol.sinusoids[1].0.abs() < 1e-9 && (sol.sinusoids[1].1 - 2.0).abs() < 1e-9);
        assert!(sol.rss < 1e-16 * n as f64);
    }
}
