//! Tests of the interpolating spline, and the comparisons of the interpolating and the
//! smoothing solves with their reference copies (they share the reference helpers).

use super::smoothing::SMOOTH_SCRATCH;
use super::*;
use proptest::prelude::*;

/// Dense reference: assemble the full n×n system and solve it with nalgebra's LU.
fn dense_moments(x: &[f64], y: &[f64], end: EndCondition) -> Vec<f64> {
    let n = x.len();
    let mut a = nalgebra::DMatrix::<f64>::zeros(n, n);
    let mut r = nalgebra::DVector::<f64>::zeros(n);
    let h = |k: usize| x[k + 1] - x[k];
    for k in 1..n - 1 {
        a[(k, k - 1)] = h(k - 1);
        a[(k, k)] = 2.0 * (h(k - 1) + h(k));
        a[(k, k + 1)] = h(k);
        r[k] = 6.0 * ((y[k + 1] - y[k]) / h(k) - (y[k] - y[k - 1]) / h(k - 1));
    }
    match end {
        EndCondition::Natural => {
            a[(0, 0)] = 1.0;
            a[(n - 1, n - 1)] = 1.0;
        }
        EndCondition::NotAKnot => {
            // (m1 − m0)/h0 = (m2 − m1)/h1
            a[(0, 0)] = -1.0 / h(0);
            a[(0, 1)] = 1.0 / h(0) + 1.0 / h(1);
            a[(0, 2)] = -1.0 / h(1);
            a[(n - 1, n - 3)] = -1.0 / h(n - 3);
            a[(n - 1, n - 2)] = 1.0 / h(n - 3) + 1.0 / h(n - 2);
            a[(n - 1, n - 1)] = -1.0 / h(n - 2);
        }
    }
    a.lu().solve(&r).unwrap().iter().copied().collect()
}

#[test]
fn cubic_reproduced_exactly_on_uneven_knots() {
    let x = [0.0, 0.7, 1.5, 2.0, 3.1, 4.0, 5.2];
    let f = |t: f64| (t * t * t - 2.0 * t, 3.0 * t * t - 2.0, 6.0 * t);
    let y: Vec<f64> = x.iter().map(|&t| f(t).0).collect();
    let s = CubicSpline::new(&x, &y, EndCondition::NotAKnot).unwrap();
    for k in 0..=104 {
        let t = -0.1 + 0.05 * k as f64;
        let (v, d1, d2) = s.eval_all(t);
        let (ev, ed1, ed2) = f(t);
        // Tolerance: a few ulps of the largest magnitude involved (~150).
        assert!((v - ev).abs() < 1e-11, "t={t}: {v} vs {ev}");
        assert!((d1 - ed1).abs() < 1e-11, "t={t}");
        assert!((d2 - ed2).abs() < 1e-11, "t={t}");
    }
}

#[test]
fn few_knots() {
    let x = [0.0, 1.0];
    let y = [1.0, 3.0];
    let s = CubicSpline::new(&x, &y, EndCondition::NotAKnot).unwrap();
    assert!((s.eval(0.5) - 2.0).abs() < 1e-15);
    let x = [0.0, 1.0, 3.0];
    let y: Vec<f64> = x.iter().map(|&t| 2.0 * t * t - t + 1.0).collect();
    let s = CubicSpline::new(&x, &y, EndCondition::NotAKnot).unwrap();
    let (v, d1, d2) = s.eval_all(2.0);
    assert!((v - 7.0).abs() < 1e-12 && (d1 - 7.0).abs() < 1e-12 && (d2 - 4.0).abs() < 1e-12);
    assert!(matches!(
        CubicSpline::new(&x[..1], &y[..1], EndCondition::Natural),
        Err(SplineError::TooFewKnots(1))
    ));
}

#[test]
fn bad_knots_are_errors() {
    let y = [0.0; 4];
    assert!(matches!(
        CubicSpline::new(&[0.0, 1.0, 1.0, 2.0], &y, EndCondition::NotAKnot),
        Err(SplineError::NotIncreasing { index: 2, .. })
    ));
    assert!(matches!(
        CubicSpline::new(&[0.0, 1.0, f64::NAN, 2.0], &y, EndCondition::NotAKnot),
        Err(SplineError::NonFinite { index: 2 })
    ));
    assert!(matches!(
        CubicSpline::new(&[0.0, 1.0], &y, EndCondition::NotAKnot),
        Err(SplineError::LengthMismatch { .. })
    ));
}

#[test]
fn natural_ends_have_zero_curvature_and_keep_lines() {
    let x = [0.0, 0.3, 1.1, 1.5, 2.7];
    let y = [1.0, -1.0, 2.0, 0.5, 0.0];
    let s = CubicSpline::new(&x, &y, EndCondition::Natural).unwrap();
    assert!(s.moments()[0].abs() < 1e-15 && s.moments()[4].abs() < 1e-15);
    let yl: Vec<f64> = x.iter().map(|&t| 3.0 * t - 1.0).collect();
    let s = CubicSpline::new(&x, &yl, EndCondition::Natural).unwrap();
    assert!(s.moments().iter().all(|m| m.abs() < 1e-12));
}

/// Error of value, 1st and 2nd derivative of the spline of sin on a uniform grid.
fn sin_errors(n: usize) -> (f64, f64, f64) {
    let x: Vec<f64> = (0..n).map(|k| 3.0 * k as f64 / (n - 1) as f64).collect();
    let y: Vec<f64> = x.iter().map(|t| t.sin()).collect();
    let s = CubicSpline::new(&x, &y, EndCondition::NotAKnot).unwrap();
    let mut e = (0.0f64, 0.0f64, 0.0f64);
    let mut c = s.cursor();
    for k in 0..3000 {
        let t = 3.0 * (k as f64 + 0.5) / 3000.0;
        let (v, d1, d2) = c.eval_all(t);
        e.0 = e.0.max((v - t.sin()).abs());
        e.1 = e.1.max((d1 - t.cos()).abs());
        e.2 = e.2.max((d2 + t.sin()).abs());
    }
    e
}

#[test]
fn derivatives_converge_at_expected_order() {
    // Halving h divides the error by 2^4, 2^3, 2^2 for S, S', S''.
    let (a, b) = (sin_errors(41), sin_errors(81));
    let order = |ea: f64, eb: f64| (ea / eb).log2();
    assert!(order(a.0, b.0) > 3.7, "value order {}", order(a.0, b.0));
    assert!(order(a.1, b.1) > 2.7, "slope order {}", order(a.1, b.1));
    assert!(order(a.2, b.2) > 1.8, "curvature order {}", order(a.2, b.2));
}

#[test]
fn smallest_systems_match_dense_solve() {
    // The twisted elimination's edge cases: one interior row, and one row per direction.
    for (x, end) in [
        (vec![0.0, 0.7, 2.0], EndCondition::Natural),
        (vec![0.0, 0.7, 2.0, 2.5], EndCondition::Natural),
        (vec![0.0, 0.7, 2.0, 2.5], EndCondition::NotAKnot),
        (vec![0.0, 0.7, 2.0, 2.5, 4.0], EndCondition::NotAKnot),
    ] {
        let y: Vec<f64> = x
            .iter()
            .map(|v: &f64| (1.3 * v).sin() + 0.2 * v * v)
            .collect();
        let s = CubicSpline::new(&x, &y, end).unwrap();
        let want = dense_moments(&x, &y, end);
        for (a, b) in s.moments().iter().zip(&want) {
            assert!((a - b).abs() <= 1e-12 * (1.0 + b.abs()), "{a} vs {b}");
        }
    }
}

/// The banded solve as it was before its back substitution kept γ in registers and g
/// was written without a copy of y: the new one must give the same bits.
#[allow(clippy::too_many_arguments)]
fn reference_smooth_solve(
    n: usize,
    y: &[f64],
    alpha: f64,
    hs: &[f64],
    ih: &[f64],
    d: &mut [f64],
    inv_d: &mut [f64],
    u: &mut [f64],
    v: &mut [f64],
    w: &mut [f64],
    g: &mut [f64],
    m: &mut [f64],
) {
    let nn = n - 2;
    // Unknown i is γ at knot j = i + 1; column j of Q holds a_j = 1/h_{j−1},
    // b_j = −a_j − c_j, c_j = 1/h_j at rows j−1, j, j+1.
    for i in 0..nn {
        let j = i + 1;
        let (a, c) = (ih[j - 1], ih[j]);
        let b = -a - c;
        let mut di = (hs[j - 1] + hs[j]) / 3.0 + alpha * (a * a + b * b + c * c);
        let mut r = a * y[j - 1] + b * y[j] + c * y[j + 1];
        if i >= 1 {
            // A_{i,i−1} = h_{j−1}/6 + α (b_{j−1} a_j + c_{j−1} b_j)
            let (a0, c0) = (ih[j - 2], ih[j - 1]);
            let mut num = hs[j - 1] / 6.0 + alpha * ((-a0 - c0) * a + c0 * b);
            if i >= 2 {
                // A_{i,i−2} = α c_{j−2} a_j
                v[i] = alpha * ih[j - 2] * ih[j - 1] * inv_d[i - 2];
                num -= v[i] * u[i - 1] * d[i - 2];
                di -= v[i] * v[i] * d[i - 2];
                r -= v[i] * w[i - 2];
            }
            u[i] = num * inv_d[i - 1];
            di -= u[i] * u[i] * d[i - 1];
            r -= u[i] * w[i - 1];
        }
        d[i] = di;
        inv_d[i] = 1.0 / di;
        w[i] = r;
    }
    // Back substitution: γ_i = w_i/d_i − u_{i+1} γ_{i+1} − v_{i+2} γ_{i+2}.
    for i in (0..nn).rev() {
        let mut x = w[i] * inv_d[i];
        if i + 1 < nn {
            x -= u[i + 1] * m[i + 2];
        }
        if i + 2 < nn {
            x -= v[i + 2] * m[i + 3];
        }
        m[i + 1] = x;
    }
    // g = y − α Q γ; row k of Q touches columns k−1, k, k+1 (interior knots only).
    for k in 0..n {
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
        g[k] = y[k] - alpha * qg;
    }
}

/// The interpolating moments as they were before the twisted elimination carried cp and
/// m in registers: the new ones must be the same bits.
fn reference_moments(x: &[f64], y: &[f64], end: EndCondition, cp: &mut Vec<f64>) -> Vec<f64> {
    let n = x.len();
    let mut m = vec![0.0; n];
    if n == 2 {
        return m; // a straight line
    }
    let h = |k: usize| x[k + 1] - x[k];
    let d = |k: usize| (y[k + 1] - y[k]) / h(k);
    if n == 3 && end == EndCondition::NotAKnot {
        // Not-a-knot through 3 points is the interpolating parabola (MATLAB does the same).
        let c = 2.0 * (d(1) - d(0)) / (x[2] - x[0]);
        m.fill(c);
        return m;
    }
    // Interior rows k = 1..=n−2: sub·m_{k−1} + diag·m_k + sup·m_{k+1} = r_k, with the
    // not-a-knot ends eliminated into rows 1 and n−2 (natural ends: m_0 = m_{n−1} = 0).
    let nak = end == EndCondition::NotAKnot;
    let row = |k: usize, h0: f64, h1: f64, d0: f64, d1: f64| {
        let (mut sub, mut diag, mut sup) = (h0, 2.0 * (h0 + h1), h1);
        if k == 1 {
            if nak {
                // m_0 = ((h0 + h1)·m_1 − h0·m_2)/h1
                diag += h0 * (h0 + h1) / h1;
                sup -= h0 * h0 / h1;
            }
            sub = 0.0;
        }
        if k == n - 2 {
            if nak {
                // m_{n−1} = ((a + b)·m_{n−2} − b·m_{n−3})/a with a = h_{n−3}, b = h_{n−2}
                diag += h1 * (h0 + h1) / h0;
                sub -= h1 * h1 / h0;
            }
            sup = 0.0;
        }
        (sub, diag, sup, 6.0 * (d1 - d0))
    };
    // Twisted ("burn at both ends") elimination: rows 1..p−1 from the top and rows
    // n−2..p+1 from the bottom in one loop, so the two serial chains of divisions overlap;
    // row p joins them. Rows are diagonally dominant (also the not-a-knot rows:
    // |h1 − h0²/h1| < (h0 + h1)(2 + h0/h1)), so no pivoting is needed in either direction.
    // Top: m_k = m'_k − cp_k·m_{k+1}; bottom: m_k = m'_k − cp_k·m_{k−1}; m' is kept in `m`
    // (m_0 = m_{n−1} = 0 start both recurrences) and cp in `cp`. h and the slope d roll
    // along each way so each is computed once.
    let p = (n - 1) / 2;
    cp.clear();
    cp.resize(n, 0.0);
    let top = |k: usize, h0: f64, d0: f64, cp: &mut [f64], m: &mut [f64]| {
        let h1 = x[k + 1] - x[k];
        let d1 = (y[k + 1] - y[k]) / h1;
        let (sub, diag, sup, r) = row(k, h0, h1, d0, d1);
        let inv = 1.0 / (diag - sub * cp[k - 1]);
        cp[k] = sup * inv;
        m[k] = (r - sub * m[k - 1]) * inv;
        (h1, d1)
    };
    let bottom = |k: usize, h1: f64, d1: f64, cp: &mut [f64], m: &mut [f64]| {
        let h0 = x[k] - x[k - 1];
        let d0 = (y[k] - y[k - 1]) / h0;
        let (sub, diag, sup, r) = row(k, h0, h1, d0, d1);
        let inv = 1.0 / (diag - sup * cp[k + 1]);
        cp[k] = sub * inv;
        m[k] = (r - sup * m[k + 1]) * inv;
        (h0, d0)
    };
    let (n_top, n_bottom) = (p - 1, n - 2 - p);
    let (mut ht, mut dt) = (h(0), d(0));
    let (mut hb, mut db) = (h(n - 2), d(n - 2));
    for j in 0..n_top.min(n_bottom) {
        (ht, dt) = top(1 + j, ht, dt, cp, &mut m);
        (hb, db) = bottom(n - 2 - j, hb, db, cp, &mut m);
    }
    for j in n_bottom.min(n_top)..n_top {
        (ht, dt) = top(1 + j, ht, dt, cp, &mut m);
    }
    for j in n_top.min(n_bottom)..n_bottom {
        (hb, db) = bottom(n - 2 - j, hb, db, cp, &mut m);
    }
    let (sub, diag, sup, r) = row(p, h(p - 1), h(p), d(p - 1), d(p));
    m[p] = (r - sub * m[p - 1] - sup * m[p + 1]) / (diag - sub * cp[p - 1] - sup * cp[p + 1]);
    // Back substitution outwards from p, again both ways at once.
    for j in 1..=n_top.max(n_bottom) {
        if j <= n_top {
            let k = p - j;
            m[k] -= cp[k] * m[k + 1];
        }
        if j <= n_bottom {
            let k = p + j;
            m[k] -= cp[k] * m[k - 1];
        }
    }
    if nak {
        let (h0, h1) = (h(0), h(1));
        m[0] = ((h0 + h1) * m[1] - h0 * m[2]) / h1;
        let (a, b) = (h(n - 3), h(n - 2));
        m[n - 1] = ((a + b) * m[n - 2] - b * m[n - 3]) / a;
    }
    m
}

/// The componentwise backward error of moments `m` as a solution of the smoothing system
/// (R + α QᵀQ) γ = Qᵀy, assembled here from its definition: the largest
/// |r − Aγ|_i / (Σ_j |A_ij γ_j| + |r_i|). A backward-stable solve keeps it at a few ε
/// however ill-conditioned the system (α over dozens of decades), which a comparison of
/// γ itself cannot promise.
fn smoothing_backward_error(x: &[f64], y: &[f64], alpha: f64, m: &[f64]) -> f64 {
    let n = x.len();
    let h = |k: usize| x[k + 1] - x[k];
    let (a, c) = (|j: usize| 1.0 / h(j - 1), |j: usize| 1.0 / h(j));
    let b = |j: usize| -a(j) - c(j);
    let mut worst = 0.0f64;
    for j in 1..n - 1 {
        // Row j − 1 (knot j): columns j − 2 ..= j + 2 (knots), γ of knot k is m[k].
        let mut terms = vec![(
            (h(j - 1) + h(j)) / 3.0 + alpha * (a(j) * a(j) + b(j) * b(j) + c(j) * c(j)),
            m[j],
        )];
        if j >= 2 {
            let off = h(j - 1) / 6.0 + alpha * (b(j - 1) * a(j) + a(j) * b(j));
            terms.push((off, m[j - 1]));
        }
        if j + 2 < n {
            let off = h(j) / 6.0 + alpha * (b(j) * a(j + 1) + a(j + 1) * b(j + 1));
            terms.push((off, m[j + 1]));
        }
        if j >= 3 {
            terms.push((alpha * c(j - 2) * a(j), m[j - 2]));
        }
        if j + 3 < n {
            terms.push((alpha * c(j) * a(j + 2), m[j + 2]));
        }
        let r = a(j) * y[j - 1] + b(j) * y[j] + c(j) * y[j + 1];
        let ag: f64 = terms.iter().map(|(e, g)| e * g).sum();
        let scale: f64 = terms.iter().map(|(e, g)| (e * g).abs()).sum::<f64>() + r.abs();
        if scale > 0.0 {
            worst = worst.max((r - ag).abs() / scale);
        }
    }
    worst
}

/// The reference solve of smoothing_moments (reference_smooth_solve on fresh arrays).
fn reference_smoothing(x: &[f64], y: &[f64], alpha: f64) -> (Vec<f64>, Vec<f64>) {
    let n = x.len();
    let mut g = y.to_vec();
    let mut m = vec![0.0; n];
    let hs: Vec<f64> = x.windows(2).map(|p| p[1] - p[0]).collect();
    let ih: Vec<f64> = hs.iter().map(|h| 1.0 / h).collect();
    let mut a = vec![vec![0.0; n - 2]; 5];
    let [d, inv_d, u, v, w] = &mut a[..] else {
        unreachable!()
    };
    reference_smooth_solve(n, y, alpha, &hs, &ih, d, inv_d, u, v, w, &mut g, &mut m);
    (g, m)
}

proptest! {
    #[test]
    fn solves_match_the_reference(
        steps in prop::collection::vec(0.01f64..2.0, 2..60),
        ys in prop::collection::vec(-100.0f64..100.0, 61),
        alpha in 0.0f64..10.0,
        natural in any::<bool>(),
    ) {
        let mut x = vec![0.0];
        for s in &steps { x.push(x.last().unwrap() + s); }
        let y = &ys[..x.len()];
        let end = if natural { EndCondition::Natural } else { EndCondition::NotAKnot };
        let bits = |v: &[f64]| v.iter().map(|a| a.to_bits()).collect::<Vec<_>>();
        let s = CubicSpline::new(&x, y, end).unwrap();
        let want = reference_moments(&x, y, end, &mut Vec::new());
        prop_assert_eq!(bits(s.moments()), bits(&want));
        // Twice, so that the second solve runs on the first one's work arrays.
        let mut first = None;
        for _ in 0..2 {
            let mut g = vec![7.0; 3];
            let m = smoothing_moments(&x, y, alpha, &mut g).unwrap();
            let omega = smoothing_backward_error(&x, y, alpha, &m);
            prop_assert!(omega <= 8.0 * f64::EPSILON, "backward error {:e}", omega);
            match &first {
                None => first = Some((bits(&m), bits(&g))),
                Some(f) => prop_assert_eq!(f, &(bits(&m), bits(&g))),
            }
        }
    }
}

/// The solves against the reference copies (the code before the solves were restructured)
/// over what the proptest above does not reach: up to 5000 knots, spacings over three
/// decades in one stroke, abscissae and values from 1e-9 to 1e9, α = 0 and cut-offs six
/// decades either side of 1/h (48 decades of α), and work arrays left longer, shorter or
/// full of NaN by the solve before. Interpolation gives the reference's bits; smoothing
/// (eliminated from both ends, the reference one way) its backward error.
#[test]
fn solves_match_the_reference_on_large_random_inputs() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand::rngs::StdRng::seed_from_u64(0x5eed_5b1e_u64 ^ 14);
    let bits = |v: &[f64]| v.iter().map(|a| a.to_bits()).collect::<Vec<_>>();
    let sizes = (3..=12).chain((0..300).map(|_| {
        // Log-uniform in 3..=5000: the short strokes' edge cases as often as long ones.
        (3.0 * (5000.0f64 / 3.0).powf(rng.random::<f64>())).round() as usize
    }));
    let sizes: Vec<usize> = sizes.collect();
    for (case, &n) in sizes.iter().enumerate() {
        let x_scale = 10f64.powf(rng.random_range(-9.0..9.0));
        let y_scale = 10f64.powf(rng.random_range(-9.0..9.0));
        let mut x = Vec::with_capacity(n);
        let mut t = rng.random_range(-1.0..1.0) * x_scale;
        for _ in 0..n {
            x.push(t);
            // Steps over three decades, a fifth of them all the same.
            let step = if rng.random_bool(0.2) {
                1.0
            } else {
                10f64.powf(rng.random_range(-1.5..1.5))
            };
            t += step * x_scale * 1e-2;
        }
        let y: Vec<f64> = x
            .iter()
            .map(|&t| {
                let u = t / x_scale;
                y_scale * ((7.0 * u).sin() + 0.3 * u * u + rng.random_range(-0.1..0.1))
            })
            .collect();
        if case % 7 == 3 {
            // Stale work arrays must not leak into the result.
            SMOOTH_SCRATCH.with_borrow_mut(|w| {
                for a in w.iter_mut() {
                    a.clear();
                    a.resize(rng.random_range(0..6000), f64::NAN);
                }
            });
        }
        for end in [EndCondition::NotAKnot, EndCondition::Natural] {
            let want = reference_moments(&x, &y, end, &mut Vec::new());
            let s = CubicSpline::new(&x, &y, end).unwrap();
            assert_eq!(
                bits(s.moments()),
                bits(&want),
                "case {case}, n {n}, {end:?}"
            );
            let mut junk = vec![f64::NAN; rng.random_range(0..3 * n)];
            let s = CubicSpline::with_scratch(&x, &y, end, &mut junk).unwrap();
            assert_eq!(
                bits(s.moments()),
                bits(&want),
                "case {case}, n {n}, {end:?}"
            );
        }
        let h = (x[n - 1] - x[0]) / (n - 1) as f64;
        let alpha = if case % 11 == 0 {
            0.0
        } else {
            // α = 1/(h ω⁴): ω from 1e-6 to 1e6 of 1/h.
            alpha_for_cutoff(h, 10f64.powf(rng.random_range(-6.0..6.0)) / h)
        };
        let (_, m_want) = reference_smoothing(&x, &y, alpha);
        let mut g = vec![f64::NAN; rng.random_range(0..2 * n)];
        let m = smoothing_moments(&x, &y, alpha, &mut g).unwrap();
        // Both ends at once is as backward stable as the reference's one way: 1.5 ε at
        // worst here, the reference 1.3 ε; a wrong term shows as 1e-13 and more.
        let omega = smoothing_backward_error(&x, &y, alpha, &m);
        let omega_ref = smoothing_backward_error(&x, &y, alpha, &m_want);
        assert!(
            omega <= 8.0 * f64::EPSILON,
            "case {case}, n {n}, α {alpha:e}: backward error {omega:e} (reference: \
             {omega_ref:e})"
        );
    }
}

proptest! {
    #[test]
    fn matches_dense_solve_and_passes_through_knots(
        steps in prop::collection::vec(0.01f64..2.0, 3..40),
        ys in prop::collection::vec(-100.0f64..100.0, 41),
        natural in any::<bool>(),
    ) {
        let mut x = vec![0.0];
        for s in &steps { x.push(x.last().unwrap() + s); }
        let y = &ys[..x.len()];
        let end = if natural { EndCondition::Natural } else { EndCondition::NotAKnot };
        let s = CubicSpline::new(&x, y, end).unwrap();
        let reference = dense_moments(&x, y, end);
        // Conditioning: spacing ratios up to 200 and |y| ≤ 100 give |m| up to ~1e7;
        // allow 1e-9 relative to that scale.
        let scale = reference.iter().fold(1.0f64, |a, v| a.max(v.abs()));
        for (a, b) in s.moments().iter().zip(&reference) {
            prop_assert!((a - b).abs() <= 1e-9 * scale, "{a} vs {b}");
        }
        for (xk, yk) in x.iter().zip(y) {
            prop_assert!((s.eval(*xk) - yk).abs() <= 1e-9 * (1.0 + yk.abs()));
        }
        // First derivative continuous across interior knots.
        for (k, xk) in x.iter().enumerate().take(x.len() - 1).skip(1) {
            let left = s.eval_in(k - 1, *xk).1;
            let right = s.eval_in(k, *xk).1;
            prop_assert!((left - right).abs() <= 1e-7 * (1.0 + scale));
        }
    }
}
