//! Dense least-squares kernels for the IAFV fit: Householder QR, the null space of the
//! continuity constraints, Legendre bases and Forsythe orthogonal polynomials.
//!
//! Everything here works on small column counts (tens) and many rows, column-major.

/// Column-major dense matrix.
#[derive(Debug, Clone)]
pub(crate) struct Mat {
    pub rows: usize,
    pub cols: usize,
    pub data: Vec<f64>,
}

impl Mat {
    pub fn zeros(rows: usize, cols: usize) -> Self {
        Self {
            rows,
            cols,
            data: vec![0.0; rows * cols],
        }
    }
    pub fn col_mut(&mut self, j: usize) -> &mut [f64] {
        &mut self.data[j * self.rows..(j + 1) * self.rows]
    }
    pub fn get(&self, i: usize, j: usize) -> f64 {
        self.data[j * self.rows + i]
    }
    pub fn add(&mut self, i: usize, j: usize, v: f64) {
        self.data[j * self.rows + i] += v;
    }
}

/// Result of [`lstsq`].
#[derive(Debug, Clone)]
pub(crate) struct LstsqResult {
    pub x: Vec<f64>,
    pub rss: f64,
    /// max |R_jj| / min |R_jj| after column normalisation: a cheap conditioning indicator.
    pub cond_estimate: f64,
}

/// Minimise ‖A x − b‖₂ by Householder QR (no normal equations).
///
/// Columns are normalised to unit 2-norm first so the rank test is scale-free. Returns
/// `Err(column)` when column `column` is (numerically) a combination of the previous ones:
/// its remaining norm after the earlier reflections is below 1e-10 of its own norm.
pub(crate) fn lstsq(mut a: Mat, mut b: Vec<f64>) -> Result<LstsqResult, usize> {
    let (n, p) = (a.rows, a.cols);
    if p == 0 {
        let rss = b.iter().map(|v| v * v).sum();
        return Ok(LstsqResult {
            x: Vec::new(),
            rss,
            cond_estimate: 1.0,
        });
    }
    if n < p {
        return Err(n);
    }
    let mut scale = vec![1.0; p];
    for (j, s) in scale.iter_mut().enumerate() {
        let c = a.col_mut(j);
        let norm = c.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !(norm > 0.0 && norm.is_finite()) {
            return Err(j);
        }
        c.iter_mut().for_each(|v| *v /= norm);
        *s = norm;
    }
    let mut diag = vec![0.0; p];
    let mut v = vec![0.0; n];
    for j in 0..p {
        let m = n - j;
        let (head, tail) = a.data.split_at_mut((j + 1) * n);
        let cj = &mut head[j * n..];
        let norm = cj[j..].iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm <= 1e-10 {
            return Err(j);
        }
        let alpha = if cj[j] > 0.0 { -norm } else { norm };
        v[..m].copy_from_slice(&cj[j..]);
        v[0] -= alpha;
        let vnorm2: f64 = v[..m].iter().map(|x| x * x).sum();
        diag[j] = alpha;
        cj[j] = alpha;
        cj[j + 1..].iter_mut().for_each(|x| *x = 0.0);
        if vnorm2 == 0.0 {
            continue;
        }
        let apply = |col: &mut [f64]| {
            let s: f64 = v[..m].iter().zip(&col[j..]).map(|(a, b)| a * b).sum();
            let f = 2.0 * s / vnorm2;
            col[j..]
                .iter_mut()
                .zip(&v[..m])
                .for_each(|(c, vi)| *c -= f * vi);
        };
        for k in 0..(p - j - 1) {
            apply(&mut tail[k * n..(k + 1) * n]);
        }
        apply(&mut b);
    }
    // Back substitution R x = Qᵀb (upper triangle stored in a).
    let mut x = vec![0.0; p];
    for j in (0..p).rev() {
        let mut s = b[j];
        for (k, xk) in x.iter().enumerate().skip(j + 1) {
            s -= a.get(j, k) * xk;
        }
        x[j] = s / diag[j];
    }
    let rss = b[p..].iter().map(|v| v * v).sum();
    for (xj, s) in x.iter_mut().zip(&scale) {
        *xj /= s;
    }
    let (mut dmax, mut dmin) = (0.0f64, f64::INFINITY);
    for d in &diag {
        dmax = dmax.max(d.abs());
        dmin = dmin.min(d.abs());
    }
    Ok(LstsqResult {
        x,
        rss,
        cond_estimate: dmax / dmin,
    })
}

/// Orthonormal basis (as columns, N × q) of the null space of the constraint rows `c`
/// (each of length `n`), by twice-iterated modified Gram–Schmidt: first an orthonormal basis of
/// the row space (dependent rows dropped), then unit vectors completed against it.
pub(crate) fn null_space(c: &[Vec<f64>], n: usize) -> Vec<Vec<f64>> {
    fn orth(v: &mut [f64], basis: &[Vec<f64>]) {
        for _ in 0..2 {
            for q in basis {
                let d: f64 = q.iter().zip(v.iter()).map(|(a, b)| a * b).sum();
                v.iter_mut().zip(q).for_each(|(x, qi)| *x -= d * qi);
            }
        }
    }
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let mut row_space: Vec<Vec<f64>> = Vec::new();
    for row in c {
        let r0 = norm(row);
        if r0 == 0.0 {
            continue;
        }
        let mut v = row.clone();
        orth(&mut v, &row_space);
        let r = norm(&v);
        if r > 1e-12 * r0 {
            v.iter_mut().for_each(|x| *x /= r);
            row_space.push(v);
        }
    }
    let mut all = row_space;
    let rank = all.len();
    for i in 0..n {
        if all.len() == n {
            break;
        }
        let mut v = vec![0.0; n];
        v[i] = 1.0;
        orth(&mut v, &all);
        let r = norm(&v);
        if r > 0.1 {
            v.iter_mut().for_each(|x| *x /= r);
            all.push(v);
        }
    }
    all.split_off(rank)
}

/// Legendre polynomials P_0..P_m at t (m + 1 = `out.len()`), three-term recurrence.
pub(crate) fn legendre(t: f64, out: &mut [f64]) {
    if out.is_empty() {
        return;
    }
    out[0] = 1.0;
    if out.len() > 1 {
        out[1] = t;
    }
    for k in 1..out.len().saturating_sub(1) {
        let kf = k as f64;
        out[k + 1] = ((2.0 * kf + 1.0) * t * out[k] - kf * out[k - 1]) / (kf + 1.0);
    }
}

/// Derivatives P'_0..P'_m given the values `p` from [`legendre`]:
/// P'_{k+1} = P'_{k−1} + (2k + 1) P_k.
pub(crate) fn legendre_derivative(p: &[f64], out: &mut [f64]) {
    if out.is_empty() {
        return;
    }
    out[0] = 0.0;
    if out.len() > 1 {
        out[1] = 1.0;
    }
    for k in 1..out.len().saturating_sub(1) {
        out[k + 1] = out[k - 1] + (2.0 * k as f64 + 1.0) * p[k];
    }
}

/// Weighted residual sums of squares of the least-squares polynomial fits of orders
/// 0..=`max_order` to (x, y), by Forsythe's orthogonal polynomials generated on the points
/// (x scaled to [−1, 1]); the residual is updated in modified Gram–Schmidt form.
/// Entries beyond the number of distinct points repeat the last reachable value.
pub(crate) fn forsythe_rss(x: &[f64], y: &[f64], w: Option<&[f64]>, max_order: usize) -> Vec<f64> {
    let n = x.len();
    let mut out = Vec::with_capacity(max_order + 1);
    if n == 0 {
        return vec![0.0; max_order + 1];
    }
    let (lo, hi) = (x[0].min(x[n - 1]), x[0].max(x[n - 1]));
    let half = 0.5 * (hi - lo);
    let mid = 0.5 * (hi + lo);
    let t: Vec<f64> = x
        .iter()
        .map(|&v| if half > 0.0 { (v - mid) / half } else { 0.0 })
        .collect();
    let wt = |i: usize| w.map_or(1.0, |w| w[i]);
    let mut r = y.to_vec();
    let mut p_prev = vec![0.0; n];
    let mut p = vec![1.0; n];
    let mut norm_prev = 1.0;
    let mut stalled = false;
    for j in 0..=max_order {
        let norm: f64 = (0..n).map(|i| wt(i) * p[i] * p[i]).sum();
        if !stalled && j < n && norm > 1e-300 {
            let c = (0..n).map(|i| wt(i) * r[i] * p[i]).sum::<f64>() / norm;
            r.iter_mut().zip(&p).for_each(|(ri, pi)| *ri -= c * pi);
        } else {
            stalled = true;
        }
        out.push((0..n).map(|i| wt(i) * r[i] * r[i]).sum());
        if stalled || j == max_order {
            continue;
        }
        let alpha = (0..n).map(|i| wt(i) * t[i] * p[i] * p[i]).sum::<f64>() / norm;
        let beta = if j == 0 { 0.0 } else { norm / norm_prev };
        for i in 0..n {
            let next = (t[i] - alpha) * p[i] - beta * p_prev[i];
            p_prev[i] = p[i];
            p[i] = next;
        }
        norm_prev = norm;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lstsq_matches_exact_solution_of_consistent_system() {
        // y = 2 − 3x + 0.5x² sampled at 7 points: the fit is exact, rss at rounding level.
        let xs: Vec<f64> = (0..7).map(|i| i as f64 * 0.4 - 1.0).collect();
        let mut a = Mat::zeros(7, 3);
        for (i, &x) in xs.iter().enumerate() {
            a.add(i, 0, 1.0);
            a.add(i, 1, x);
            a.add(i, 2, x * x);
        }
        let b: Vec<f64> = xs.iter().map(|x| 2.0 - 3.0 * x + 0.5 * x * x).collect();
        let r = lstsq(a, b).unwrap();
        for (got, want) in r.x.iter().zip([2.0, -3.0, 0.5]) {
            assert!((got - want).abs() < 1e-13, "{got} vs {want}");
        }
        assert!(r.rss < 1e-25);
    }

    #[test]
    fn lstsq_reports_dependent_column() {
        let mut a = Mat::zeros(5, 2);
        for i in 0..5 {
            a.add(i, 0, i as f64);
            a.add(i, 1, 2.0 * i as f64);
        }
        assert_eq!(lstsq(a, vec![1.0; 5]).unwrap_err(), 1);
    }

    #[test]
    fn null_space_is_orthonormal_and_annihilated() {
        let c = vec![
            vec![1.0, 1.0, 0.0, 0.0],
            vec![0.0, 1.0, -1.0, 2.0],
            vec![1.0, 2.0, -1.0, 2.0],
        ];
        let z = null_space(&c, 4);
        assert_eq!(z.len(), 2); // the third row is the sum of the first two
        for v in &z {
            for row in &c {
                let d: f64 = row.iter().zip(v).map(|(a, b)| a * b).sum();
                assert!(d.abs() < 1e-14);
            }
        }
        let d: f64 = z[0].iter().zip(&z[1]).map(|(a, b)| a * b).sum();
        assert!(d.abs() < 1e-14);
    }

    #[test]
    fn forsythe_matches_qr() {
        let x: Vec<f64> = (0..50).map(|i| i as f64 * 0.37).collect();
        let y: Vec<f64> = x.iter().map(|v| (v * 0.9).sin() + 0.1 * v).collect();
        let rss = forsythe_rss(&x, &y, None, 5);
        for (m, want) in rss.iter().enumerate() {
            let mut a = Mat::zeros(50, m + 1);
            for (i, &v) in x.iter().enumerate() {
                let mut p = vec![0.0; m + 1];
                legendre(v / 9.065 - 1.0, &mut p);
                for (j, pj) in p.iter().enumerate() {
                    a.add(i, j, *pj);
                }
            }
            let r = lstsq(a, y.clone()).unwrap();
            assert!((r.rss - want).abs() < 1e-10 * (1.0 + r.rss), "order {m}");
        }
    }
}
