//! The cubic smoothing spline (Reinsch) and its banded solve.

#[cfg(doc)]
use super::CubicSpline;
use super::{validate_knots, SplineError};

/// Cubic smoothing spline (Reinsch): the g minimising
/// Σ (y_k − g(x_k))² + α ∫ g''(x)² dx, a natural cubic spline with knots at x.
///
/// Writes the smoothed values g(x_k) into `g` and returns the second derivatives at the knots
/// (zero at both ends); `CubicSpline::from_moments(x, g, m)` then evaluates it. Straight lines
/// pass unchanged for any α; α = 0 gives the natural interpolating spline. For evenly spaced
/// knots h apart the smoother acts like the filter 1/(1 + α·h·ω⁴), so α = 1/(h·ω_c⁴) puts its
/// half-power point at ω_c (see [`alpha_for_cutoff`]).
///
/// O(n): the system (R + α QᵀQ) γ = Qᵀy is symmetric positive definite and pentadiagonal,
/// solved by a banded LDLᵀ.
///
/// # Reference
/// C. H. Reinsch, "Smoothing by spline functions", Numer. Math. 10 (1967); P. J. Green and
/// B. W. Silverman, *Nonparametric Regression and Generalized Linear Models* (1994), §2.3.
///
/// # Errors
/// As [`CubicSpline::new`]; α must be finite and ≥ 0.
pub fn smoothing_moments(
    x: &[f64],
    y: &[f64],
    alpha: f64,
    g: &mut Vec<f64>,
) -> Result<Vec<f64>, SplineError> {
    validate_knots(x, y)?;
    if !(alpha.is_finite() && alpha >= 0.0) {
        return Err(SplineError::NonFinite { index: 0 });
    }
    Ok(smoothing_moments_valid(x, y, alpha, g))
}

/// [`smoothing_moments`] of knots already validated, with α finite and ≥ 0 (the windowed
/// solves check the whole once, not every window again).
pub(super) fn smoothing_moments_valid(
    x: &[f64],
    y: &[f64],
    alpha: f64,
    g: &mut Vec<f64>,
) -> Vec<f64> {
    let n = x.len();
    let mut m = vec![0.0; n];
    if n < 3 {
        g.clear();
        g.extend_from_slice(y);
        return m;
    }
    // Unknowns γ_1..γ_{n−2}. Five work arrays, reused per thread: allocating them afresh for
    // every stroke costs more in page faults than the solve itself.
    let nn = n - 2;
    SMOOTH_SCRATCH.with_borrow_mut(|work| {
        let [ih, wd, u, v, rhs] = work;
        // Not cleared: the solve writes every element before reading it (except u[0], v[0]
        // and v[1], which it never reads), so zeroing them again for each stroke is wasted.
        ih.resize(n - 1, 0.0);
        for a in [&mut *wd, &mut *u, &mut *v, &mut *rhs] {
            a.resize(nn, 0.0);
        }
        smooth_solve(x, y, alpha, ih, wd, u, v, rhs, g, &mut m);
    });
    m
}

thread_local! {
    pub(super) static SMOOTH_SCRATCH: std::cell::RefCell<[Vec<f64>; 5]> =
        const { std::cell::RefCell::new([const { Vec::new() }; 5]) };
}

/// Rows of the smoothing system from which [`smooth_solve`] eliminates from both ends at once.
const TWIST_MIN_ROWS: usize = 6;

/// Row i = j − 1 of the smoothing system's diagonal and right-hand side (Qᵀy)_j, from h_{j−1},
/// h_j, a_j, c_j, b_j, a_j² and y_{j−1..=j+1}; also c_j².
#[inline(always)]
fn smooth_diag(
    (h0, h1): (f64, f64),
    (a, c, b, aa): (f64, f64, f64, f64),
    (y0, y1, y2): (f64, f64, f64),
    alpha: f64,
) -> (f64, f64, f64) {
    let cc = c * c;
    // R's h/3 and h/6 as products: a division by a constant costs the divider as much as any
    // (1 ulp of R is far below what the elimination rounds anyway).
    let di = (h0 + h1) * (1.0 / 3.0) + alpha * (aa + b * b + cc);
    let r = a * y0 + b * y1 + c * y2;
    (di, r, cc)
}

/// A_{i,i−1} = h_{j−1}/6 + α (b_{j−1} a_j + a_j b_j) for j = i + 1 (c_{j−1} = a_j).
#[inline(always)]
fn smooth_off1(h0: f64, b0: f64, a: f64, b: f64, alpha: f64) -> f64 {
    h0 * (1.0 / 6.0) + alpha * (b0 * a + a * b)
}

/// The smoothing system's bands for [`smooth_eliminate_twisted`], from x (knots) and `ih`
/// (1/h): row i's diagonal into `diag[i]`, right-hand side into `rhs[i]`, A_{i,i−1} into
/// `off1[i]` (i ≥ 1) and A_{i,i−2} into `off2[i]` (i ≥ 2). One pass without a serial
/// dependence, so it vectorises; the eliminations then only eliminate.
#[allow(clippy::too_many_arguments)]
fn smooth_bands(
    x: &[f64],
    y: &[f64],
    alpha: f64,
    ih: &[f64],
    diag: &mut [f64],
    rhs: &mut [f64],
    off1: &mut [f64],
    off2: &mut [f64],
) {
    let n = x.len();
    let nn = n - 2;
    // Row i: h_i, h_{i+1} (h_{j−1}, h_j), a_j = ih[i], c_j = ih[i+1], y_{i..=i+2}.
    let hs = x[..nn].iter().zip(&x[1..=nn]).zip(&x[2..]);
    let cs = ih[..nn].iter().zip(&ih[1..]);
    let ys = y[..nn].iter().zip(&y[1..=nn]).zip(&y[2..]);
    for ((((d, r), ((&x0, &x1), &x2)), (&a, &c)), ((&y0, &y1), &y2)) in
        diag.iter_mut().zip(rhs.iter_mut()).zip(hs).zip(cs).zip(ys)
    {
        let b = -a - c;
        (*d, *r, _) = smooth_diag((x1 - x0, x2 - x1), (a, c, b, a * a), (y0, y1, y2), alpha);
    }
    // Row i ≥ 1: h_{j−1} = h_i, b_{j−1} = −ih[i−1] − ih[i], a_j = ih[i], b_j = −ih[i] − ih[i+1].
    let hs = x[1..nn].iter().zip(&x[2..=nn]);
    let cs = ih[..nn - 1].iter().zip(&ih[1..nn]).zip(&ih[2..=nn]);
    for (o, ((&x0, &x1), ((&a0, &a), &c))) in off1[1..nn].iter_mut().zip(hs.zip(cs)) {
        *o = smooth_off1(x1 - x0, -a0 - a, a, -a - c, alpha);
    }
    // Row i ≥ 2: A_{i,i−2} = α c_{j−2} a_j = α ih[i−1] ih[i].
    for (o, (&c0, &a)) in off2[2..nn]
        .iter_mut()
        .zip(ih[1..nn - 1].iter().zip(&ih[2..nn]))
    {
        *o = alpha * c0 * a;
    }
}

/// [`smooth_solve`] by twisted ("burn at both ends") elimination: with the bands formed first
/// ([`smooth_bands`]), rows 0..p−1 are eliminated from the top and rows nn−1 down to p+2 from
/// the bottom in one loop, so that the two serial chains of pivots (a division and a few
/// products each, the solve's whole cost) overlap; the bottom then hands what its rows add
/// to rows p and p+1 over to the top, which finishes them, and the back substitution runs
/// outwards from there, again both ways at once. The system is symmetric positive definite,
/// so neither direction needs pivoting, and both eliminate the same floating-point bands:
/// the result differs from the one-way elimination by rounding only (the tests hold its
/// backward error to a few ε).
///
/// Work arrays (length nn = n − 2): `wd` comes in with the diagonal and leaves with w/d;
/// `u` with A_{i,i−1} and `v` with A_{i,i−2}, leaving with L's entries: the top's towards
/// the rows before it at the row's index, the bottom's towards the rows after it (row k's
/// at k + 1 and k + 2, where the band entries it reads lie), so that γ_i = w_i/d_i −
/// u_{i+1} γ_{i+1} − v_{i+2} γ_{i+2} at the top and w_i/d_i − u_i γ_{i−1} − v_i γ_{i−2}
/// at the bottom.
fn smooth_eliminate_twisted(
    wd: &mut [f64],
    rhs: &[f64],
    u: &mut [f64],
    v: &mut [f64],
    m: &mut [f64],
) {
    let nn = wd.len();
    let p = (nn - 2) / 2;
    // Each way: pivot d, 1/d and eliminated right-hand side w of the last two rows
    // (1: the last), and the last row's L entry towards the one before it. Row i's
    // u_i² d_{i−1} is num·u_i and v_i² d_{i−2} is v_i·A_{i,i−2}: a product fewer each on
    // the chain from one pivot to the next.
    // Top, rows 0 and 1.
    let (t_d2, t_w2) = (wd[0], rhs[0]);
    let t_id2 = 1.0 / t_d2;
    wd[0] = t_w2 * t_id2;
    let t_u1 = u[1] * t_id2;
    let t_d1 = wd[1] - u[1] * t_u1;
    let t_w1 = rhs[1] - t_u1 * t_w2;
    let t_id1 = 1.0 / t_d1;
    (u[1], wd[1]) = (t_u1, t_w1 * t_id1);
    let mut top = (t_d1, t_id1, t_w1, t_d2, t_id2, t_w2, t_u1);
    // Bottom, rows nn−1 and nn−2 (A_{nn−2,nn−1} lies at u[nn−1]; its L entry goes there).
    let (b_d2, b_w2) = (wd[nn - 1], rhs[nn - 1]);
    let b_id2 = 1.0 / b_d2;
    wd[nn - 1] = b_w2 * b_id2;
    let b_u1 = u[nn - 1] * b_id2;
    let b_d1 = wd[nn - 2] - u[nn - 1] * b_u1;
    let b_w1 = rhs[nn - 2] - b_u1 * b_w2;
    let b_id1 = 1.0 / b_d1;
    (u[nn - 1], wd[nn - 2]) = (b_u1, b_w1 * b_id1);
    let mut bottom = (b_d1, b_id1, b_w1, b_d2, b_id2, b_w2, b_u1);
    // One row either way: its diagonal, right-hand side, entries towards the last row and
    // the one before (`e1`, `e2`), and what the other way adds (`corr`: diagonal, e1,
    // right-hand side). Returns u, v and w/d.
    #[inline(always)]
    fn row(
        st: &mut (f64, f64, f64, f64, f64, f64, f64),
        (diag, r, e1, e2): (f64, f64, f64, f64),
        corr: [f64; 3],
    ) -> (f64, f64, f64) {
        let (d1, id1, w1, d2, id2, w2, u1) = *st;
        let vi = e2 * id2;
        let num = e1 - corr[1] - vi * u1 * d2;
        let ui = num * id1;
        let di = diag - corr[0] - vi * e2 - num * ui;
        let wi = r - corr[2] - vi * w2 - ui * w1;
        let idi = 1.0 / di;
        *st = (di, idi, wi, d1, id1, w1, ui);
        (ui, vi, wi * idi)
    }
    let zero = [0.0; 3];
    {
        // Top rows 2..p (band entries at the row's index) and bottom rows nn−3 down to p+2
        // (at k + 1 and k + 2), as many, or one more at the bottom.
        let (wd_t, wd_b) = wd.split_at_mut(p);
        let (u_t, u_b) = u.split_at_mut(p);
        let (v_t, v_b) = v.split_at_mut(p);
        let tops = wd_t[2..]
            .iter_mut()
            .zip(&rhs[2..p])
            .zip(u_t[2..].iter_mut().zip(&mut v_t[2..]));
        // Bottom row k = p + 2 + q: wd_b[q + 2], u_b[q + 3], v_b[q + 4].
        let rows_b = nn - 2 - (p + 2);
        let mut bottoms = wd_b[2..2 + rows_b]
            .iter_mut()
            .zip(&rhs[p + 2..nn - 2])
            .zip(u_b[3..3 + rows_b].iter_mut().zip(&mut v_b[4..4 + rows_b]))
            .rev();
        for ((wd_i, &r_i), (u_i, v_i)) in tops {
            (*u_i, *v_i, *wd_i) = row(&mut top, (*wd_i, r_i, *u_i, *v_i), zero);
            if let Some(((wd_k, &r_k), (u_k, v_k))) = bottoms.next() {
                (*u_k, *v_k, *wd_k) = row(&mut bottom, (*wd_k, r_k, *u_k, *v_k), zero);
            }
        }
        for ((wd_k, &r_k), (u_k, v_k)) in bottoms {
            (*u_k, *v_k, *wd_k) = row(&mut bottom, (*wd_k, r_k, *u_k, *v_k), zero);
        }
    }
    // What the bottom's rows (p+2 and p+3 reach them) add to rows p+1 and p.
    let (_, id1, w1, d2, id2, w2, u1) = bottom;
    let (e1, e2, e2p) = (u[p + 2], v[p + 3], v[p + 2]);
    let vn = e2 * id2;
    let num = e1 - vn * u1 * d2;
    let un = num * id1;
    let va = e2p * id1;
    let next = [vn * e2 + num * un, e2p * un, vn * w2 + un * w1];
    let after = [va * e2p, 0.0, va * w1];
    (u[p], v[p], wd[p]) = row(&mut top, (wd[p], rhs[p], u[p], v[p]), after);
    (u[p + 1], v[p + 1], wd[p + 1]) =
        row(&mut top, (wd[p + 1], rhs[p + 1], u[p + 1], v[p + 1]), next);
    (u[p + 2], v[p + 2], v[p + 3]) = (un, va, vn);
    // Back substitution outwards, both ways at once; γ_i is m[i + 1], and the last two γ of
    // each way ride in registers.
    let g1 = wd[p + 1];
    let g0 = wd[p] - u[p + 1] * g1;
    (m[p + 1], m[p + 2]) = (g0, g1);
    let (mut t1, mut t2) = (g0, g1);
    let (mut b1, mut b2) = (g1, g0);
    let (m_t, m_b) = m.split_at_mut(p + 1);
    // Top rows p−1 down to 0 (m[1..=p]), bottom rows p+2 up to nn−1 (m[p+3..=nn]).
    let tops = m_t[1..]
        .iter_mut()
        .zip(&wd[..p])
        .zip(u[1..=p].iter().zip(&v[2..p + 2]))
        .rev();
    let mut bottoms = m_b[2..nn - p]
        .iter_mut()
        .zip(&wd[p + 2..])
        .zip(u[p + 2..].iter().zip(&v[p + 2..]));
    for ((m_i, &wd_i), (&u_i, &v_i)) in tops {
        let g = wd_i - u_i * t1 - v_i * t2;
        *m_i = g;
        (t2, t1) = (t1, g);
        if let Some(((m_k, &wd_k), (&u_k, &v_k))) = bottoms.next() {
            let g = wd_k - u_k * b1 - v_k * b2;
            *m_k = g;
            (b2, b1) = (b1, g);
        }
    }
    for ((m_k, &wd_k), (&u_k, &v_k)) in bottoms {
        let g = wd_k - u_k * b1 - v_k * b2;
        *m_k = g;
        (b2, b1) = (b1, g);
    }
}

/// The banded solve of [`smoothing_moments`]: one forward pass forms the spacings'
/// reciprocals `ih` (n − 1 of them, kept for the last pass), builds row i of
/// A = R + α QᵀQ, factors it (LDLᵀ with sub-diagonals u, v) and forward-substitutes into
/// `wd` = w·(1/d); one backward pass solves for γ; a last pass forms g. `wd`, `u`, `v` have
/// length n − 2. From [`TWIST_MIN_ROWS`] rows on, the bands are formed first ([`smooth_bands`])
/// and eliminated from both ends at once ([`smooth_eliminate_twisted`]).
#[allow(clippy::too_many_arguments)]
fn smooth_solve(
    x: &[f64],
    y: &[f64],
    alpha: f64,
    ih: &mut [f64],
    wd: &mut [f64],
    u: &mut [f64],
    v: &mut [f64],
    rhs: &mut [f64],
    g: &mut Vec<f64>,
    m: &mut [f64],
) {
    let n = x.len();
    let nn = n - 2;
    if nn >= TWIST_MIN_ROWS {
        // The spacings' reciprocals, the bands, then only the elimination: each of the first
        // two a pass that vectorises.
        for ((c, &x0), &x1) in ih.iter_mut().zip(&x[..n - 1]).zip(&x[1..]) {
            *c = 1.0 / (x1 - x0);
        }
        smooth_bands(x, y, alpha, ih, wd, rhs, u, v);
        smooth_eliminate_twisted(wd, rhs, u, v, m);
        smooth_values(y, alpha, ih, m, g);
        return;
    }
    // A short system one way. Unknown i is γ at knot j = i + 1; column j of Q holds
    // a_j = 1/h_{j−1}, b_j = −a_j − c_j, c_j = 1/h_j at rows j−1, j, j+1. Rows 0 and 1 lack
    // the bands that reach before the matrix and are done first.
    let (diag, off1) = (smooth_diag, smooth_off1);
    let h0 = x[1] - x[0];
    let h1 = x[2] - x[1];
    let (a0, a1) = (1.0 / h0, 1.0 / h1);
    ih[0] = a0;
    ih[1] = a1;
    // Row 0 (j = 1): a = 1/h_0, c = 1/h_1.
    let b1 = -a0 - a1;
    let (d0, r0, cc1) = diag((h0, h1), (a0, a1, b1, a0 * a0), (y[0], y[1], y[2]), alpha);
    let id0 = 1.0 / d0;
    let wd0 = r0 * id0;
    wd[0] = wd0;
    if nn == 1 {
        m[1] = wd0;
        smooth_values(y, alpha, ih, m, g);
        return;
    }
    // Row 1 (j = 2): a = 1/h_1, c = 1/h_2.
    let h2 = x[3] - x[2];
    let a2 = 1.0 / h2;
    ih[2] = a2;
    let b2 = -a1 - a2;
    let (mut di, mut r, cc2) = diag((h1, h2), (a1, a2, b2, cc1), (y[1], y[2], y[3]), alpha);
    let u1 = off1(h1, b1, a1, b2, alpha) * id0;
    u[1] = u1;
    di -= u1 * u1 * d0;
    r -= u1 * r0;
    let id1 = 1.0 / di;
    wd[1] = r * id1;
    // (d, 1/d, w) of rows i−1 and i−2, u of row i−1, and of row i−1's knot j − 1: h_{j−1},
    // a_{j−1} = ih[j−2], c_{j−1} = ih[j−1], b_{j−1}, c_{j−1}², x_j, y_{j−1}, y_j.
    let (mut d1, mut id1, mut w1) = (di, id1, r);
    let (mut d2, mut id2, mut w2) = (d0, id0, r0);
    let mut u1 = u1;
    let (mut hp, mut ap, mut cp, mut bp, mut ccp) = (h2, a1, a2, b2, cc2);
    let (mut xj, mut yp, mut yj) = (x[3], y[2], y[3]);
    // Rows 2..nn (j = 3..=n−2): knot j + 1 comes in, ih[j] and row i's factors go out.
    let rows = x[4..]
        .iter()
        .zip(&y[4..])
        .zip(&mut ih[3..])
        .zip(u[2..].iter_mut().zip(&mut v[2..]).zip(&mut wd[2..]));
    for (((&xn, &yn), ih_j), ((u_i, v_i), wd_i)) in rows {
        let h = xn - xj;
        let c = 1.0 / h;
        *ih_j = c;
        // a_j = c_{j−1}; b_j = −a_j − c_j
        let (a, b) = (cp, -cp - c);
        let (mut di, mut r, cc) = diag((hp, h), (a, c, b, ccp), (yp, yj, yn), alpha);
        let mut num = off1(hp, bp, a, b, alpha);
        // A_{i,i−2} = α c_{j−2} a_j
        let vi = alpha * ap * a * id2;
        *v_i = vi;
        num -= vi * u1 * d2;
        di -= vi * vi * d2;
        r -= vi * w2;
        let ui = num * id1;
        *u_i = ui;
        di -= ui * ui * d1;
        r -= ui * w1;
        let idi = 1.0 / di;
        *wd_i = r * idi;
        (d2, id2, w2) = (d1, id1, w1);
        (d1, id1, w1) = (di, idi, r);
        u1 = ui;
        (hp, ap, cp, bp, ccp) = (h, a, c, b, cc);
        (xj, yp, yj) = (xn, yj, yn);
    }
    // Back substitution: γ_i = w_i/d_i − u_{i+1} γ_{i+1} − v_{i+2} γ_{i+2}. The last two γ
    // ride in registers: read back from `m`, each row waited for the store of the one before.
    // The last two rows lack terms and are done first.
    let mut g1 = wd[nn - 1]; // γ_{i+1} (m[i + 2])
    m[nn] = g1;
    let mut x = wd[nn - 2];
    x -= u[nn - 1] * g1;
    m[nn - 1] = x;
    let mut g2 = g1; // γ_{i+2} (m[i + 3])
    g1 = x;
    let back = wd[..nn - 2]
        .iter()
        .zip(&u[1..nn - 1])
        .zip(&v[2..nn])
        .zip(&mut m[1..nn - 1])
        .rev();
    for (((&wdi, &ui), &vi), mi) in back {
        let mut x = wdi;
        x -= ui * g1;
        x -= vi * g2;
        *mi = x;
        (g2, g1) = (g1, x);
    }
    smooth_values(y, alpha, ih, m, g);
}

/// g = y − α Q γ of [`smooth_solve`] from `ih` = 1/h and the moments `m` (γ inside, zero at
/// both ends).
fn smooth_values(y: &[f64], alpha: f64, ih: &[f64], m: &[f64], g: &mut Vec<f64>) {
    let n = y.len();
    // Row k of Q touches columns k−1, k, k+1 (interior knots only). Written straight into
    // `g` (no copy of y first), its room reserved at once: the extends below would grow it
    // piecewise, copying it each time. The rows near the ends miss terms; the rest run
    // without a branch (and vectorise), each summed in the same order as the ends.
    let row = |k: usize| {
        let mut qg = 0.0;
        if k >= 2 {
            qg += ih[k - 1] * m[k - 1];
        }
        if (1..n - 1).contains(&k) {
            qg -= (ih[k - 1] + ih[k]) * m[k];
        }
        if k + 2 < n {
            qg += ih[k] * m[k + 1];
        }
        y[k] - alpha * qg
    };
    g.clear();
    g.reserve(n);
    if n < 5 {
        g.extend((0..n).map(row));
        return;
    }
    g.extend((0..2).map(row));
    // Rows 2..n−2: all three terms; m_{k−1..=k+1} and 1/h_{k−1..=k} come from the slices
    // read at shifted starts.
    let ms = m[1..n - 3].iter().zip(&m[2..n - 2]).zip(&m[3..n - 1]);
    let is = ih[1..n - 3].iter().zip(&ih[2..n - 2]);
    g.extend(
        ms.zip(is)
            .zip(&y[2..n - 2])
            .map(|((((&m0, &m1), &m2), (&i0, &i1)), &yk)| {
                let qg = 0.0 + i0 * m0 - (i0 + i1) * m1 + i1 * m2;
                yk - alpha * qg
            }),
    );
    g.extend((n - 2..n).map(row));
}

/// α for [`smoothing_moments`] that puts the smoother's half-power point at `cutoff_hz`, for
/// knots `mean_spacing` apart on average: α = 1/(h·(2π f_c)⁴).
pub fn alpha_for_cutoff(mean_spacing: f64, cutoff_hz: f64) -> f64 {
    let w = 2.0 * std::f64::consts::PI * cutoff_hz;
    1.0 / (mean_spacing * w * w * w * w)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spline::{CubicSpline, EndCondition};

    /// Dense oracle: minimise Σ(y − g)² + α ∫ g''² over natural splines by solving
    /// (I + α Q R⁻¹ Qᵀ) g = y.
    fn dense_smooth(x: &[f64], y: &[f64], alpha: f64) -> Vec<f64> {
        let n = x.len();
        let h = |k: usize| x[k + 1] - x[k];
        let mut q = nalgebra::DMatrix::<f64>::zeros(n, n - 2);
        let mut r = nalgebra::DMatrix::<f64>::zeros(n - 2, n - 2);
        for j in 1..n - 1 {
            q[(j - 1, j - 1)] = 1.0 / h(j - 1);
            q[(j, j - 1)] = -1.0 / h(j - 1) - 1.0 / h(j);
            q[(j + 1, j - 1)] = 1.0 / h(j);
            r[(j - 1, j - 1)] = (h(j - 1) + h(j)) / 3.0;
            if j < n - 2 {
                r[(j - 1, j)] = h(j) / 6.0;
                r[(j, j - 1)] = h(j) / 6.0;
            }
        }
        let k = &q * r.try_inverse().unwrap() * q.transpose();
        let a = nalgebra::DMatrix::<f64>::identity(n, n) + k * alpha;
        let yv = nalgebra::DVector::from_column_slice(y);
        a.lu().solve(&yv).unwrap().iter().copied().collect()
    }

    #[test]
    fn smoothing_matches_dense_oracle() {
        let x: Vec<f64> = (0..40)
            .map(|k| k as f64 * 0.1 + 0.03 * ((k * 7) % 5) as f64)
            .collect();
        let y: Vec<f64> = x
            .iter()
            .map(|t| (3.0 * t).sin() + 0.1 * (37.0 * t).cos())
            .collect();
        for alpha in [0.0, 1e-4, 1e-2, 1.0] {
            let mut g = Vec::new();
            let m = smoothing_moments(&x, &y, alpha, &mut g).unwrap();
            let want = dense_smooth(&x, &y, alpha);
            for (a, b) in g.iter().zip(&want) {
                assert!((a - b).abs() < 1e-10, "alpha {alpha}: {a} vs {b}");
            }
            // The natural interpolating spline through g has the returned moments.
            let s = CubicSpline::new(&x, &g, EndCondition::Natural).unwrap();
            for (a, b) in s.moments().iter().zip(&m) {
                assert!((a - b).abs() < 1e-8 * (1.0 + b.abs()), "{a} vs {b}");
            }
        }
    }

    #[test]
    fn smoothing_keeps_lines_and_filters_noise() {
        let x: Vec<f64> = (0..2000).map(|k| k as f64 * 1e-3).collect();
        let line: Vec<f64> = x.iter().map(|t| 3.0 * t - 1.0).collect();
        let alpha = alpha_for_cutoff(1e-3, 20.0);
        let mut g = Vec::new();
        let m = smoothing_moments(&x, &line, alpha, &mut g).unwrap();
        assert!(g.iter().zip(&line).all(|(a, b)| (a - b).abs() < 1e-9));
        assert!(m.iter().all(|v| v.abs() < 1e-6));
        // A 2 Hz sine passes (cut-off 20 Hz: gain 1/(1 + 1e-4) ≈ 1); a 200 Hz one is removed
        // (gain 1/(1 + 1e4)).
        let y: Vec<f64> = x
            .iter()
            .map(|t| {
                (2.0 * 2.0 * std::f64::consts::PI * t).sin()
                    + (200.0 * 2.0 * std::f64::consts::PI * t).sin()
            })
            .collect();
        smoothing_moments(&x, &y, alpha, &mut g).unwrap();
        let err = x[200..1800]
            .iter()
            .zip(&g[200..1800])
            .map(|(t, v)| (v - (2.0 * 2.0 * std::f64::consts::PI * t).sin()).abs())
            .fold(0.0f64, f64::max);
        assert!(err < 2e-3, "{err}");
    }
}
