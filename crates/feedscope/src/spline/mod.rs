//! Interpolating cubic splines with first and second derivatives.
//!
//! The spline is held in moment form: the knots (x_k, y_k) are borrowed and only the second
//! derivatives m_k = S''(x_k) are stored (8 bytes a knot), found by one O(n) tridiagonal solve.
//! On [x_k, x_{k+1}] with h = x_{k+1} − x_k, a = x_{k+1} − t, b = t − x_k:
//!
//! S(t)   = (m_k a³ + m_{k+1} b³)/(6h) + (y_k/h − m_k h/6)·a + (y_{k+1}/h − m_{k+1} h/6)·b
//! S'(t)  = (m_{k+1} b² − m_k a²)/(2h) + (y_{k+1} − y_k)/h − (m_{k+1} − m_k)·h/6
//! S''(t) = (m_k a + m_{k+1} b)/h
//!
//! End conditions: not-a-knot (third derivative continuous at x_1 and x_{n−2}, as MATLAB's
//! `spline`; with 3 knots the parabola through them, with 2 the line) or natural (m = 0 at both
//! ends). Outside [x_0, x_{n−1}] the end cubics are extended.
//!
//! # Layout
//! - this file: the interpolating spline [`CubicSpline`] (construction, evaluation, the
//!   moments' not-a-knot/natural solve), [`EndCondition`] and [`SplineError`];
//! - `smoothing`: the smoothing spline ([`smoothing_moments`], [`alpha_for_cutoff`]) and its
//!   banded solve;
//! - `windowed`: long traces solved in overlapping windows ([`CubicSpline::new_windowed`],
//!   [`smoothing_moments_windowed`], [`WindowedSmoothing`], [`WindowedSpline`]);
//! - `cursor`: power-form pieces ([`Piece`]), the piece table and the sequential [`Cursor`].
//!
//! # Reference
//! Paper 000, Section 3.2 steps (1)-(2): spline interpolation of z(t) and i(t) and the
//! derivatives z'(t), z''(t).
//!
//! # Example
//! ```
//! use feedscope::spline::{CubicSpline, EndCondition};
//! let x = [0.0, 0.7, 1.5, 2.0, 3.1, 4.0, 5.2];
//! let y: Vec<f64> = x.iter().map(|&x| x * x * x - 2.0 * x).collect();
//! let s = CubicSpline::new(&x, &y, EndCondition::NotAKnot).unwrap();
//! // A cubic is reproduced exactly, derivatives included.
//! let (v, d1, d2) = s.eval_all(5.0);
//! assert!((v - 115.0).abs() < 1e-9 && (d1 - 73.0).abs() < 1e-9 && (d2 - 30.0).abs() < 1e-9);
//! ```

mod cursor;
mod smoothing;
#[cfg(test)]
mod tests;
mod windowed;

pub(crate) use cursor::PieceTable;
pub use cursor::{Cursor, Piece};
pub use smoothing::{alpha_for_cutoff, smoothing_moments};
pub use windowed::{
    smoothing_moments_windowed, WindowedSmoothing, WindowedSpline, DEFAULT_WINDOW_KNOTS,
};

/// Boundary condition at both ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum EndCondition {
    /// Third derivative continuous across the second and the second-to-last knot (MATLAB).
    #[default]
    NotAKnot,
    /// Zero second derivative at both ends.
    Natural,
}

/// Why a spline could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SplineError {
    /// x and y differ in length.
    #[error("x has {x} values but y has {y}")]
    LengthMismatch {
        /// Length of x.
        x: usize,
        /// Length of y.
        y: usize,
    },
    /// Fewer than two knots.
    #[error("a spline needs at least 2 knots, got {0}")]
    TooFewKnots(usize),
    /// x does not strictly increase.
    #[error("knot abscissae must strictly increase: x[{index}] = {value} after {previous}")]
    NotIncreasing {
        /// Index of the offending knot.
        index: usize,
        /// Its abscissa.
        value: f64,
        /// The previous abscissa.
        previous: f64,
    },
    /// A knot is NaN or infinite.
    #[error("knot {index} is not finite")]
    NonFinite {
        /// Index of the offending knot.
        index: usize,
    },
}

impl SplineError {
    /// What the error means to a caller: always [`BadInput`](crate::ErrorKind::BadInput): the knots do not define a spline.
    pub fn kind(&self) -> crate::ErrorKind {
        use crate::ErrorKind;
        ErrorKind::BadInput
    }
}

/// A cubic spline through borrowed knots; see the module docs for the formulas.
#[derive(Debug, Clone)]
pub struct CubicSpline<'a> {
    x: &'a [f64],
    y: &'a [f64],
    m: Vec<f64>,
}

impl<'a> CubicSpline<'a> {
    /// Build the spline through (x_k, y_k).
    ///
    /// # Errors
    /// [`SplineError`] when lengths differ, fewer than 2 knots are given, x does not strictly
    /// increase, or a value is not finite.
    pub fn new(x: &'a [f64], y: &'a [f64], end: EndCondition) -> Result<Self, SplineError> {
        // The sweep buffer is reused per thread (fresh large allocations cost page faults).
        thread_local! {
            static SCRATCH: std::cell::RefCell<Vec<f64>> = const { std::cell::RefCell::new(Vec::new()) };
        }
        SCRATCH.with_borrow_mut(|scratch| Self::with_scratch(x, y, end, scratch))
    }

    /// As [`CubicSpline::new`], reusing `scratch` for the tridiagonal sweep.
    ///
    /// # Errors
    /// As [`CubicSpline::new`].
    pub fn with_scratch(
        x: &'a [f64],
        y: &'a [f64],
        end: EndCondition,
        scratch: &mut Vec<f64>,
    ) -> Result<Self, SplineError> {
        validate_knots(x, y)?;
        let m = moments(x, y, end, scratch);
        Ok(Self { x, y, m })
    }

    /// The knots' abscissae.
    pub fn x(&self) -> &'a [f64] {
        self.x
    }

    /// The knots' ordinates.
    pub fn y(&self) -> &[f64] {
        self.y
    }

    /// Second derivatives at the knots.
    pub fn moments(&self) -> &[f64] {
        &self.m
    }

    /// Index k of the interval [x_k, x_{k+1}] holding t (clamped to the end intervals).
    #[inline]
    pub fn interval(&self, t: f64) -> usize {
        let n = self.x.len();
        let k = self.x.partition_point(|&xi| xi <= t);
        k.saturating_sub(1).min(n - 2)
    }

    /// Value at t.
    #[inline]
    pub fn eval(&self, t: f64) -> f64 {
        self.eval_in(self.interval(t), t).0
    }

    /// Value, first and second derivative at t.
    #[inline]
    pub fn eval_all(&self, t: f64) -> (f64, f64, f64) {
        self.eval_in(self.interval(t), t)
    }

    /// Value, first and second derivative at t using the cubic of interval k.
    ///
    /// # Panics
    /// When `k + 1` is not a knot index (a caller's mistake).
    #[inline]
    pub fn eval_in(&self, k: usize, t: f64) -> (f64, f64, f64) {
        eval_knots(self.x, self.y, &self.m, k, t)
    }
}

/// Value, first and second derivative at t of interval k of knots `x`, values `y` and
/// moments `m` ([`CubicSpline::eval_in`]).
#[inline]
fn eval_knots(x: &[f64], y: &[f64], m: &[f64], k: usize, t: f64) -> (f64, f64, f64) {
    let (x0, x1) = (x[k], x[k + 1]);
    let (y0, y1) = (y[k], y[k + 1]);
    let (m0, m1) = (m[k], m[k + 1]);
    let h = x1 - x0;
    let a = x1 - t;
    let b = t - x0;
    let inv_h = 1.0 / h;
    let c0 = y0 * inv_h - m0 * h / 6.0;
    let c1 = y1 * inv_h - m1 * h / 6.0;
    let v = (m0 * a * a * a + m1 * b * b * b) * inv_h / 6.0 + c0 * a + c1 * b;
    let d1 = (m1 * b * b - m0 * a * a) * 0.5 * inv_h + c1 - c0;
    let d2 = (m0 * a + m1 * b) * inv_h;
    (v, d1, d2)
}

impl<'a> CubicSpline<'a> {
    /// A spline from knots and their second derivatives (e.g. from [`smoothing_moments`]).
    ///
    /// # Errors
    /// As [`CubicSpline::new`], plus a length mismatch of `m`.
    pub fn from_moments(x: &'a [f64], y: &'a [f64], m: Vec<f64>) -> Result<Self, SplineError> {
        if y.len() != x.len() || m.len() != x.len() {
            return Err(SplineError::LengthMismatch {
                x: x.len(),
                y: y.len().min(m.len()),
            });
        }
        if x.len() < 2 {
            return Err(SplineError::TooFewKnots(x.len()));
        }
        Ok(Self { x, y, m })
    }
}

/// Equal lengths, at least two knots, all finite, x strictly increasing.
fn validate_knots(x: &[f64], y: &[f64]) -> Result<(), SplineError> {
    let n = x.len();
    if y.len() != n {
        return Err(SplineError::LengthMismatch { x: n, y: y.len() });
    }
    if n < 2 {
        return Err(SplineError::TooFewKnots(n));
    }
    // One pass without early exits first (it vectorises, and every stroke's knots pass
    // through here); the loop that names the first bad knot runs only when there is one.
    // Strictly increasing between finite ends is finite throughout (a NaN compares false),
    // so x needs one comparison a knot.
    let mut good = x[0].is_finite() && x[n - 1].is_finite() && y[n - 1].is_finite();
    for ((&x0, &x1), &yk) in x[..n - 1].iter().zip(&x[1..]).zip(&y[..n - 1]) {
        good &= (x1 > x0) & yk.is_finite();
    }
    let bad = !good;
    if !bad {
        return Ok(());
    }
    for k in 0..n {
        if !(x[k].is_finite() && y[k].is_finite()) {
            return Err(SplineError::NonFinite { index: k });
        }
        if k > 0 && x[k] <= x[k - 1] {
            return Err(SplineError::NotIncreasing {
                index: k,
                value: x[k],
                previous: x[k - 1],
            });
        }
    }
    Ok(())
}

/// Solve for the second derivatives at the knots (x strictly increasing, n ≥ 2). `cp` is
/// work room, grown to 2n values and not cleared.
fn moments(x: &[f64], y: &[f64], end: EndCondition, cp: &mut Vec<f64>) -> Vec<f64> {
    let n = x.len();
    if n == 2 {
        return vec![0.0; 2]; // a straight line
    }
    let h = |k: usize| x[k + 1] - x[k];
    let d = |k: usize| (y[k + 1] - y[k]) / h(k);
    if n == 3 && end == EndCondition::NotAKnot {
        // Not-a-knot through 3 points is the interpolating parabola (MATLAB does the same).
        let c = 2.0 * (d(1) - d(0)) / (x[2] - x[0]);
        return vec![c; 3];
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
    // Top: m_k = m'_k − cp_k·m_{k+1}; bottom: m_k = m'_k − cp_k·m_{k−1}; m_0 = m_{n−1} = 0
    // start both recurrences. cp is kept in `cp[..n]`; the top's m' is pushed into the
    // moments as it comes (they are never zeroed first: every one is written), the bottom's
    // in `cp[n..2n]`, which it comes out of at the end. h, the slope d, cp and m' roll along
    // each way in registers, so each is computed once and no row waits for a store of the
    // row before to be read back (they are the serial chain).
    let p = (n - 1) / 2;
    let (n_top, n_bottom) = (p - 1, n - 2 - p);
    let both = n_top; // ≤ n_bottom
    if cp.len() < 2 * n {
        cp.resize(2 * n, 0.0);
    }
    let (c, mb) = cp.split_at_mut(n);
    let mb = &mut mb[..n];
    // The rows beyond each end: cp = m' = 0 (read by row p when it is row 1 or n−2).
    c[0] = 0.0;
    c[n - 1] = 0.0;
    mb[n - 1] = 0.0;
    let mut m = Vec::with_capacity(n);
    m.push(0.0);
    // (h, d, cp, m') of the last row done each way, h and d of its interval towards the next
    // row; x and y are read where they lie (an operand, not a register to shuffle).
    let mut st = (h(0), d(0), 0.0, 0.0);
    let mut sb = (h(n - 2), d(n - 2), 0.0, 0.0);
    // A row either way with the end rows' terms (rows 1 and n−2, and the bottom's odd row).
    let top_end = |k: usize, (h0, d0, cp0, m0): (f64, f64, f64, f64)| {
        let h1 = x[k + 1] - x[k];
        let d1 = (y[k + 1] - y[k]) / h1;
        let (sub, diag, sup, r) = row(k, h0, h1, d0, d1);
        let inv = 1.0 / (diag - sub * cp0);
        (h1, d1, sup * inv, (r - sub * m0) * inv)
    };
    let bottom_end = |k: usize, (h1, d1, cp1, m1): (f64, f64, f64, f64)| {
        let h0 = x[k] - x[k - 1];
        let d0 = (y[k] - y[k - 1]) / h0;
        let (sub, diag, sup, r) = row(k, h0, h1, d0, d1);
        let inv = 1.0 / (diag - sup * cp1);
        (h0, d0, sub * inv, (r - sup * m1) * inv)
    };
    if both > 0 {
        st = top_end(1, st);
        c[1] = st.2;
        m.push(st.3);
        sb = bottom_end(n - 2, sb);
        (c[n - 2], mb[n - 2]) = (sb.2, sb.3);
        // Rows 2..=both from the top, n−3 down to n−1−both from the bottom: interior rows
        // (sub = h0, diag = 2(h0 + h1), sup = h1), summed as `row` sums them.
        let (c_top, c_bottom) = c.split_at_mut(p);
        let (t, b) = (2..both + 1, n - 1 - both..n - 2);
        let top = (x[t.clone()].iter().zip(&x[t.start + 1..t.end + 1]))
            .zip(y[t.clone()].iter().zip(&y[t.start + 1..t.end + 1]))
            .zip(&mut c_top[t]);
        let bottom = (x[b.clone()].iter().zip(&x[b.start - 1..b.end - 1]))
            .zip(y[b.clone()].iter().zip(&y[b.start - 1..b.end - 1]))
            .zip(c_bottom[b.start - p..b.end - p].iter_mut().zip(&mut mb[b]))
            .rev();
        m.extend(top.zip(bottom).map(
            |((((&xk, &xn), (&yk, &yn)), c_k), (((&xk1, &xb), (&yk1, &yb)), (cb_k, mb_k)))| {
                let (h0, d0, cp0, m0) = st;
                let h1 = xn - xk;
                let d1 = (yn - yk) / h1;
                let (sub, diag, sup, r) = (h0, 2.0 * (h0 + h1), h1, 6.0 * (d1 - d0));
                let inv = 1.0 / (diag - sub * cp0);
                let (ct, mt) = (sup * inv, (r - sub * m0) * inv);
                *c_k = ct;
                st = (h1, d1, ct, mt);
                let (h1, d1, cp1, m1) = sb;
                let h0 = xk1 - xb;
                let d0 = (yk1 - yb) / h0;
                let (sub, diag, sup, r) = (h0, 2.0 * (h0 + h1), h1, 6.0 * (d1 - d0));
                let inv = 1.0 / (diag - sup * cp1);
                let (cb, mbk) = (sub * inv, (r - sup * m1) * inv);
                (*cb_k, *mb_k) = (cb, mbk);
                sb = (h0, d0, cb, mbk);
                mt
            },
        ));
    }
    if n_bottom > both {
        let k = n - 2 - both;
        sb = bottom_end(k, sb);
        (c[k], mb[k]) = (sb.2, sb.3);
    }
    let (sub, diag, sup, r) = row(p, h(p - 1), h(p), d(p - 1), d(p));
    let mp = (r - sub * m[p - 1] - sup * mb[p + 1]) / (diag - sub * c[p - 1] - sup * c[p + 1]);
    m.push(mp);
    // Back substitution outwards from p, again both ways at once, the last m of each way in
    // a register; the bottom's in place in `mb`, then appended.
    let (mut mt, mut mbk) = (mp, mp);
    let top = m[1..p].iter_mut().zip(&c[1..p]).rev();
    let bottom = mb[p + 1..p + 1 + both]
        .iter_mut()
        .zip(&c[p + 1..p + 1 + both]);
    for ((mt_k, &ct), (mb_k, &cb)) in top.zip(bottom) {
        mt = *mt_k - ct * mt;
        *mt_k = mt;
        mbk = *mb_k - cb * mbk;
        *mb_k = mbk;
    }
    if n_bottom > both {
        let k = n - 2;
        mb[k] -= c[k] * mbk;
    }
    m.extend_from_slice(&mb[p + 1..n - 1]);
    m.push(0.0);
    if nak {
        let (h0, h1) = (h(0), h(1));
        m[0] = ((h0 + h1) * m[1] - h0 * m[2]) / h1;
        let (a, b) = (h(n - 3), h(n - 2));
        m[n - 1] = ((a + b) * m[n - 2] - b * m[n - 3]) / a;
    }
    m
}
