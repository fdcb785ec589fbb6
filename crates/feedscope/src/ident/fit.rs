//! The separable least-squares fit of the torque model (steps 4-5 of the method in the
//! [module docs](super)): variable projection over v_s, standard errors from the full
//! Jacobian, with the sandwich form when the rows are kernel averages of the samples.

use nalgebra::{DMatrix, DVector};

use super::kernel::Averaging;
use super::model::{Regressors, TorqueFit, TorqueStdError};
use super::{check_params, IdentError, IdentParams};
use crate::lugre::sign;
use crate::units::{feed_m_s_to_mm_min, feed_mm_min_to_m_s};

/// The separable least-squares problem: fixed columns (linear in the data) plus the Stribeck
/// column sgn(v)·exp(−(|v|/v_s)^δ) whose shape depends on v_s.
pub(super) struct Separable<'a> {
    /// Columns that do not depend on v_s, each of length n (the rows).
    pub(super) fixed: Vec<Vec<f64>>,
    /// Velocities the Stribeck column is evaluated at: one per row, or one per sample when
    /// `avg` is given.
    pub(super) v: &'a [f64],
    pub(super) y: &'a [f64],
    pub(super) delta: f64,
    /// When the rows are kernel averages K·(samples): K, applied to the Stribeck column and
    /// used for the sandwich covariance. `None`: pointwise rows.
    pub(super) avg: Option<&'a Averaging>,
}

pub(super) struct LinSolve {
    pub(super) theta: Vec<f64>,
    pub(super) rss: f64,
}

impl Separable<'_> {
    pub(super) fn stribeck_col(&self, vs: f64) -> Vec<f64> {
        let c: Vec<f64> = self
            .v
            .iter()
            .map(|&v| sign(v) * (-(v.abs() / vs).powf(self.delta)).exp())
            .collect();
        match self.avg {
            Some(k) => k.apply(&c),
            None => c,
        }
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
        let (a, scales) = self.design(&self.jacobian_vs_columns(vs, amplitude));
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

    /// The Stribeck column and ∂(model)/∂v_s at v_s, each averaged like the rows.
    fn jacobian_vs_columns(&self, vs: f64, amplitude: f64) -> [Vec<f64>; 2] {
        let (mut sc, mut dvs) = (Vec::with_capacity(self.v.len()), Vec::new());
        for &v in self.v {
            let u = (v.abs() / vs).powf(self.delta);
            let e = sign(v) * (-u).exp();
            sc.push(e);
            dvs.push(amplitude * e * self.delta * u / vs);
        }
        match self.avg {
            Some(k) => [k.apply(&sc), k.apply(&dvs)],
            None => [sc, dvs],
        }
    }

    /// Covariance of all parameters (fixed…, Stribeck amplitude, v_s) at the optimum, and the
    /// condition number of the scaled Jacobian X.
    ///
    /// Pointwise rows: s²·(XᵀX)⁻¹ with s² = RSS/(n − p). Kernel rows ȳ = K·y: if the sample
    /// noise is white with variance s², the rows' noise has covariance s²·KKᵀ (neighbouring
    /// rows share samples), and the least-squares estimate has the sandwich covariance
    /// s²·C·(XᵀK)(KᵀX)·C with C = (XᵀX)⁻¹; E(RSS) = s²·(tr KKᵀ − tr(C·XᵀKKᵀX)) gives s².
    pub(super) fn parameter_covariance(
        &self,
        vs: f64,
        amplitude: f64,
        rss: f64,
    ) -> (DMatrix<f64>, f64) {
        let (c, cond) = self.covariance(vs, amplitude);
        let n = self.y.len();
        let p = c.nrows();
        let Some(k) = self.avg else {
            let s2 = if n > p {
                rss / (n - p) as f64
            } else {
                f64::NAN
            };
            return (c * s2, cond);
        };
        let extra = self.jacobian_vs_columns(vs, amplitude);
        let cols: Vec<&Vec<f64>> = self.fixed.iter().chain(extra.iter()).collect();
        // KᵀX, one column per parameter, then B = (KᵀX)ᵀ(KᵀX).
        let ktx: Vec<Vec<f64>> = cols.iter().map(|c| k.apply_transpose(c)).collect();
        let mut b = DMatrix::<f64>::zeros(p, p);
        for i in 0..p {
            for j in i..p {
                let s: f64 = ktx[i].iter().zip(&ktx[j]).map(|(x, y)| x * y).sum();
                b[(i, j)] = s;
                b[(j, i)] = s;
            }
        }
        let cb = &c * &b;
        let dof = k.trace_kkt() - cb.trace();
        let s2 = if dof > 0.0 { rss / dof } else { f64::NAN };
        ((&cb * &c) * s2, cond)
    }
}

/// Fit the torque model of the module docs to prepared samples (all of them are used, each
/// as one row: a pointwise fit).
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
    let sep = Separable {
        fixed,
        v: &r.velocity_m_s,
        y: &r.torque_nm,
        delta: params.delta,
        avg: None,
    };
    fit_separable(&sep, params)
}

/// The joint fit on kernel rows: T̄ = J·θ̄'' + K·T_f(v̂) (see `kernel.rs`). `accel_rad_s2` and
/// `torque_nm` hold one value per row, `velocity_m_s` one per sample; `avg` maps samples to
/// rows.
pub(super) fn fit_kernel(
    accel_rad_s2: Vec<f64>,
    velocity_m_s: &[f64],
    torque_nm: &[f64],
    avg: &Averaging,
    params: &IdentParams,
) -> Result<TorqueFit, IdentError> {
    check_params(params)?;
    let n = avg.samples_len();
    let sgn: Vec<f64> = velocity_m_s.iter().map(|&v| sign(v)).collect();
    let mut fixed = vec![accel_rad_s2, avg.apply(&sgn), avg.apply(velocity_m_s)];
    if params.fit_offset {
        fixed.push(avg.apply(&vec![1.0; n]));
    }
    let sep = Separable {
        fixed,
        v: velocity_m_s,
        y: torque_nm,
        delta: params.delta,
        avg: Some(avg),
    };
    fit_separable(&sep, params)
}

/// Steps 4-5 on a prepared problem whose first fixed columns are θ'', sgn v, v (and 1).
fn fit_separable(sep: &Separable<'_>, params: &IdentParams) -> Result<TorqueFit, IdentError> {
    let n = sep.y.len();
    let p = sep.fixed.len() + 2;
    if n <= p {
        return Err(IdentError::NotIdentifiable {
            reason: format!("{n} samples for {p} parameters"),
        });
    }
    let (vs, sol, evals, at_bound) = sep.minimise(
        feed_mm_min_to_m_s(params.vs_min_mm_min),
        feed_mm_min_to_m_s(params.vs_max_mm_min),
        params.vs_grid_points,
    );
    let th = &sol.theta;
    let (j, tc, sigma) = (th[0], th[1], th[2]);
    let offset = if params.fit_offset { th[3] } else { 0.0 };
    let ds = th[th.len() - 1];
    let (cov, cond) = sep.parameter_covariance(vs, ds, sol.rss);
    let se = |i: usize| cov[(i, i)].max(0.0).sqrt();
    let ia = p - 2; // Stribeck amplitude
    let iv = p - 1; // v_s
    let ts_se = (cov[(1, 1)] + cov[(ia, ia)] + 2.0 * cov[(1, ia)])
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
            j_total_kgm2: se(0),
            tc_nm: se(1),
            ts_nm: ts_se,
            vs_mm_min: feed_m_s_to_mm_min(se(iv)),
            sigma_nm_s_per_m: se(2),
            offset_nm: if params.fit_offset { se(3) } else { 0.0 },
        },
        residual_rms_nm: (sol.rss / n as f64).sqrt(),
        condition_number: cond,
        iterations: evals,
        samples_used: n,
        vs_at_bound: at_bound,
    })
}
