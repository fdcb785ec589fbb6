//! The separable least-squares fit of the torque model (steps 4-5 of the method in the
//! [module docs](super)): variable projection over v_s, standard errors from the full
//! Jacobian.

use nalgebra::{DMatrix, DVector};

use super::model::{Regressors, TorqueFit, TorqueStdError};
use super::{check_params, IdentError, IdentParams};
use crate::lugre::sign;
use crate::units::{feed_m_s_to_mm_min, feed_mm_min_to_m_s};

/// The separable least-squares problem: fixed columns (linear in the data) plus the Stribeck
/// column sgn(v)·exp(−(|v|/v_s)^δ) whose shape depends on v_s.
pub(super) struct Separable<'a> {
    /// Columns that do not depend on v_s, each of length n.
    pub(super) fixed: Vec<Vec<f64>>,
    pub(super) v: &'a [f64],
    pub(super) y: &'a [f64],
    pub(super) delta: f64,
}

pub(super) struct LinSolve {
    pub(super) theta: Vec<f64>,
    pub(super) rss: f64,
}

impl Separable<'_> {
    pub(super) fn stribeck_col(&self, vs: f64) -> Vec<f64> {
        self.v
            .iter()
            .map(|&v| sign(v) * (-(v.abs() / vs).powf(self.delta)).exp())
            .collect()
    }

    /// Design matrix with columns scaled to unit norm; returns it and the scales.
    pub(super) fn design(&self, extra: &[Vec<f64>]) -> (DMatrix<f64>, Vec<f64>) {
        let n = self.y.len();
        let cols: Vec<&Vec<f64>> = self.fixed.iter().chain(extra.iter()).collect();
        let mut scales = Vec::with_capacity(cols.len());
        let mut a = DMatrix::zeros(n, cols.len());
        for (j, c) in cols.iter().enumerate() {
            let norm = c.iter().map(|x| x * x).sum::<f64>().sqrt();
            let s = if norm > 0.0 { 1.0 / norm } else { 1.0 };
            scales.push(s);
            for i in 0..n {
                a[(i, j)] = c[i] * s;
            }
        }
        (a, scales)
    }

    /// Residual sum of squares at fixed v_s from the normal equations of the column-scaled
    /// problem (k × k, cheap); used by the search, [`Separable::solve`] gives the answer.
    pub(super) fn rss_fast(&self, vs: f64) -> f64 {
        let sc = self.stribeck_col(vs);
        let cols: Vec<&[f64]> = self
            .fixed
            .iter()
            .map(|c| c.as_slice())
            .chain(std::iter::once(sc.as_slice()))
            .collect();
        let k = cols.len();
        let scale: Vec<f64> = cols
            .iter()
            .map(|c| {
                let n = c.iter().map(|x| x * x).sum::<f64>().sqrt();
                if n > 0.0 {
                    1.0 / n
                } else {
                    1.0
                }
            })
            .collect();
        let mut g = DMatrix::<f64>::zeros(k, k);
        let mut rhs = DVector::<f64>::zeros(k);
        for i in 0..k {
            for j in i..k {
                let s: f64 = cols[i].iter().zip(cols[j]).map(|(a, b)| a * b).sum();
                g[(i, j)] = s * scale[i] * scale[j];
                g[(j, i)] = g[(i, j)];
            }
            rhs[i] = cols[i].iter().zip(self.y).map(|(a, b)| a * b).sum::<f64>() * scale[i];
        }
        let svd = g.svd(true, true);
        let eps = 1e-13 * svd.singular_values.max();
        let x = match svd.solve(&rhs, eps) {
            Ok(x) => x,
            Err(_) => return f64::INFINITY,
        };
        let mut rss = 0.0;
        for (i, &yi) in self.y.iter().enumerate() {
            let mut m = 0.0;
            for j in 0..k {
                m += cols[j][i] * scale[j] * x[j];
            }
            rss += (yi - m) * (yi - m);
        }
        rss
    }

    /// Linear least squares at fixed v_s; θ in the column order fixed…, Stribeck.
    pub(super) fn solve(&self, vs: f64) -> LinSolve {
        let sc = self.stribeck_col(vs);
        let (a, scales) = self.design(std::slice::from_ref(&sc));
        let b = DVector::from_column_slice(self.y);
        let svd = a.clone().svd(true, true);
        let eps = 1e-12 * svd.singular_values.max();
        let x = svd
            .solve(&b, eps)
            .unwrap_or_else(|_| DVector::zeros(a.ncols()));
        let r = &b - &a * &x;
        LinSolve {
            theta: x.iter().zip(&scales).map(|(x, s)| x * s).collect(),
            rss: r.norm_squared(),
        }
    }

    /// Grid over log v_s and golden-section refinement. Returns (v_s, solve, evaluations,
    /// at_bound).
    pub(super) fn minimise(&self, lo: f64, hi: f64, points: usize) -> (f64, LinSolve, usize, bool) {
        let (l0, l1) = (lo.ln(), hi.ln());
        let grid: Vec<f64> = (0..points)
            .map(|k| l0 + (l1 - l0) * k as f64 / (points - 1) as f64)
            .collect();
        let rss: Vec<f64> = grid.iter().map(|&g| self.rss_fast(g.exp())).collect();
        let mut evals = points;
        let best = (0..points)
            .min_by(|&a, &b| rss[a].total_cmp(&rss[b]))
            .unwrap_or(0);
        let (mut a, mut b) = (
            grid[best.saturating_sub(1)],
            grid[(best + 1).min(points - 1)],
        );
        // Golden section on log v_s inside the bracketing grid cells.
        let gr = 0.5 * (5f64.sqrt() - 1.0);
        let mut c = b - gr * (b - a);
        let mut d = a + gr * (b - a);
        let mut fc = self.rss_fast(c.exp());
        let mut fd = self.rss_fast(d.exp());
        evals += 2;
        while (b - a) > 1e-7 {
            if fc < fd {
                b = d;
                d = c;
                fd = fc;
                c = b - gr * (b - a);
                fc = self.rss_fast(c.exp());
            } else {
                a = c;
                c = d;
                fc = fd;
                d = a + gr * (b - a);
                fd = self.rss_fast(d.exp());
            }
            evals += 1;
        }
        let mut lv = 0.5 * (a + b);
        let mut sol = self.solve(lv.exp());
        evals += 1;
        if rss[best] < self.rss_fast(lv.exp()) {
            lv = grid[best];
            sol = self.solve(lv.exp());
        }
        let at_bound = (lv - l0).abs() < 1e-3 || (lv - l1).abs() < 1e-3;
        (lv.exp(), sol, evals, at_bound)
    }

    /// Covariance factor (JᵀJ)⁻¹ of all parameters (fixed…, Stribeck amplitude, v_s) and the
    /// condition number of the scaled Jacobian.
    pub(super) fn covariance(&self, vs: f64, amplitude: f64) -> (DMatrix<f64>, f64) {
        let sc = self.stribeck_col(vs);
        let dvs: Vec<f64> = self
            .v
            .iter()
            .zip(&sc)
            .map(|(&v, &e)| {
                let u = (v.abs() / vs).powf(self.delta);
                amplitude * e * self.delta * u / vs
            })
            .collect();
        let (a, scales) = self.design(&[sc, dvs]);
        let svd = a.svd(false, true);
        let smax = svd.singular_values.max();
        let smin = svd.singular_values.min();
        let cond = if smin > 0.0 {
            smax / smin
        } else {
            f64::INFINITY
        };
        let vt = svd.v_t.expect("v_t was requested");
        let p = scales.len();
        let mut cov = DMatrix::zeros(p, p);
        for i in 0..p {
            for j in 0..p {
                let mut s = 0.0;
                for k in 0..p {
                    let sk = svd.singular_values[k];
                    if sk > 1e-14 * smax {
                        s += vt[(k, i)] * vt[(k, j)] / (sk * sk);
                    }
                }
                cov[(i, j)] = s * scales[i] * scales[j];
            }
        }
        (cov, cond)
    }
}

/// Fit the torque model of the module docs to prepared samples (all of them are used).
///
/// # Errors
/// [`IdentError::InvalidParam`] for bad settings; [`IdentError::NotIdentifiable`] for fewer
/// samples than parameters.
pub fn fit_torque(r: &Regressors, params: &IdentParams) -> Result<TorqueFit, IdentError> {
    check_params(params)?;
    let n = r.len();
    let mut fixed = vec![
        r.angular_accel_rad_s2.clone(),
        r.velocity_m_s.iter().map(|&v| sign(v)).collect(),
        r.velocity_m_s.clone(),
    ];
    if params.fit_offset {
        fixed.push(vec![1.0; n]);
    }
    let p = fixed.len() + 2;
    if n <= p {
        return Err(IdentError::NotIdentifiable {
            reason: format!("{n} samples for {p} parameters"),
        });
    }
    let sep = Separable {
        fixed,
        v: &r.velocity_m_s,
        y: &r.torque_nm,
        delta: params.delta,
    };
    let (vs, sol, evals, at_bound) = sep.minimise(
        feed_mm_min_to_m_s(params.vs_min_mm_min),
        feed_mm_min_to_m_s(params.vs_max_mm_min),
        params.vs_grid_points,
    );
    let th = &sol.theta;
    let (j, tc, sigma) = (th[0], th[1], th[2]);
    let offset = if params.fit_offset { th[3] } else { 0.0 };
    let ds = th[th.len() - 1];
    let (cov, cond) = sep.covariance(vs, ds);
    let s2 = sol.rss / (n - p) as f64;
    let var = |i: usize| (cov[(i, i)] * s2).max(0.0).sqrt();
    let ia = p - 2; // Stribeck amplitude
    let iv = p - 1; // v_s
    let ts_se = ((cov[(1, 1)] + cov[(ia, ia)] + 2.0 * cov[(1, ia)]) * s2)
        .max(0.0)
        .sqrt();
    Ok(TorqueFit {
        j_total_kgm2: j,
        tc_nm: tc,
        ts_nm: tc + ds,
        vs_mm_min: feed_m_s_to_mm_min(vs),
        sigma_nm_s_per_m: sigma,
        offset_nm: offset,
        delta: params.delta,
        std_error: TorqueStdError {
            j_total_kgm2: var(0),
            tc_nm: var(1),
            ts_nm: ts_se,
            vs_mm_min: feed_m_s_to_mm_min(var(iv)),
            sigma_nm_s_per_m: var(2),
            offset_nm: if params.fit_offset { var(3) } else { 0.0 },
        },
        residual_rms_nm: (sol.rss / n as f64).sqrt(),
        condition_number: cond,
        iterations: evals,
        samples_used: n,
        vs_at_bound: at_bound,
    })
}
