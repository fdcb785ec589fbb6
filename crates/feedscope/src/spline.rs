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

    /// As [`CubicSpline::new`], solved in overlapping windows of `window` knots so that the
    /// sweep's work array stays bounded on a long stroke: each window's core takes its moments
    /// from a solve reaching 48 knots beyond it, where the influence of the window's own ends
    /// has fallen below double precision; the true ends keep `end`. Equal to the whole solve
    /// to rounding (tested to 1e-9 relative); up to `window` knots it is exactly
    /// [`CubicSpline::new`].
    ///
    /// # Errors
    /// As [`CubicSpline::new`].
    pub fn new_windowed(
        x: &'a [f64],
        y: &'a [f64],
        end: EndCondition,
        window: usize,
    ) -> Result<Self, SplineError> {
        let window = window.max(4 * INTERP_OVERLAP_KNOTS);
        let n = x.len();
        if n <= window + 2 * INTERP_OVERLAP_KNOTS {
            return Self::new(x, y, end);
        }
        validate_knots(x, y)?;
        let reach = |a: usize, b: usize| {
            (
                a.saturating_sub(INTERP_OVERLAP_KNOTS),
                (b + INTERP_OVERLAP_KNOTS).min(n),
            )
        };
        let mut m = vec![0.0; n];
        let mut cp = Vec::new();
        for (lo, a, b, hi) in windows(n, window, reach) {
            let mw = moments(&x[lo..hi], &y[lo..hi], end, &mut cp);
            m[a..b].copy_from_slice(&mw[a - lo..b - lo]);
        }
        Ok(Self { x, y, m })
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

/// The cubic of interval k of knots `x`, values `y` and moments `m` in power form around
/// x_k ([`CubicSpline::piece`]).
#[inline(always)]
fn piece_knots(x: &[f64], y: &[f64], m: &[f64], k: usize) -> Piece {
    // One bounds check per array (the resampling loop builds a piece per output point).
    let (x, y, m) = (&x[k..k + 2], &y[k..k + 2], &m[k..k + 2]);
    let [h, c1, c2, c3] = coefficients(x[0], x[1], y[0], y[1], m[0], m[1]);
    Piece {
        x0: x[0],
        h,
        c0: y[0],
        c1,
        c2,
        c3,
    }
}

/// h, c1, c2 and c3 of the [`Piece`] on [x0, x1] with values y0, y1 and moments m0, m1: the
/// one place they are formed, so that a [`PieceTable`] holds the bits of [`piece_knots`].
#[inline(always)]
fn coefficients(x0: f64, x1: f64, y0: f64, y1: f64, m0: f64, m1: f64) -> [f64; 4] {
    let h = x1 - x0;
    let inv_h = 1.0 / h;
    [
        h,
        (y1 - y0) * inv_h - h * (2.0 * m0 + m1) * (1.0 / 6.0),
        0.5 * m0,
        (m1 - m0) * inv_h * (1.0 / 6.0),
    ]
}

/// Knots a [`PieceTable`] holds: a power of two, so that a read masks its index into the
/// table instead of checking it.
const TABLE_KNOTS: usize = 512;

/// The cubics of a run of consecutive intervals in power form, formed in one pass over their
/// knots for the reads of a block of queries.
///
/// Where queries come about once an interval (the grid walk's 1024 points per lead against
/// some 1000 samples), building each query's [`Piece`] on arrival cost a division, four bounds
/// checks and eight loads a query; the table's pass forms two intervals per vector operation
/// and leaves a query a few loads. Its values are those of [`CubicSpline::piece`], bit for bit
/// ([`coefficients`]).
///
/// Reads name an interval or knot by its offset from the first one held, which a mask keeps
/// inside the table (held ones only are meant).
#[derive(Debug, Clone)]
pub(crate) struct PieceTable {
    /// Knots and values of knots `first..=first + intervals`.
    x: [f64; TABLE_KNOTS],
    y: [f64; TABLE_KNOTS],
    /// h, c1, c2 and c3 of intervals `first..first + intervals`.
    h: [f64; TABLE_KNOTS],
    c1: [f64; TABLE_KNOTS],
    c2: [f64; TABLE_KNOTS],
    c3: [f64; TABLE_KNOTS],
}

impl PieceTable {
    /// Intervals a table holds at most.
    pub(crate) const INTERVALS: usize = TABLE_KNOTS - 1;

    /// An empty table (on the heap: it is 24 kB).
    pub(crate) fn new() -> Box<Self> {
        Box::new(Self {
            x: [0.0; TABLE_KNOTS],
            y: [0.0; TABLE_KNOTS],
            h: [0.0; TABLE_KNOTS],
            c1: [0.0; TABLE_KNOTS],
            c2: [0.0; TABLE_KNOTS],
            c3: [0.0; TABLE_KNOTS],
        })
    }

    /// Hold intervals `first..first + intervals` of knots `x`, values `y` and moments `m`.
    ///
    /// # Panics
    /// When `intervals` exceeds [`INTERVALS`](Self::INTERVALS) or the knots end before
    /// `first + intervals` (a caller's mistake).
    #[inline]
    fn fill_knots(&mut self, x: &[f64], y: &[f64], m: &[f64], first: usize, intervals: usize) {
        let n = intervals;
        let end = first + n;
        let (x, y, m) = (&x[first..=end], &y[first..=end], &m[first..=end]);
        self.x[..=n].copy_from_slice(x);
        self.y[..=n].copy_from_slice(y);
        // Every slice n long, so that the loop has no bounds checks and vectorises.
        let (x0, x1, y0, y1, m0, m1) = (&x[..n], &x[1..], &y[..n], &y[1..], &m[..n], &m[1..]);
        let (h, c1, c2, c3) = (
            &mut self.h[..n],
            &mut self.c1[..n],
            &mut self.c2[..n],
            &mut self.c3[..n],
        );
        for i in 0..n {
            [h[i], c1[i], c2[i], c3[i]] = coefficients(x0[i], x1[i], y0[i], y1[i], m0[i], m1[i]);
        }
    }

    /// The knot at offset i.
    #[inline(always)]
    fn knot(&self, i: usize) -> f64 {
        self.x[i & (TABLE_KNOTS - 1)]
    }

    /// The value at the knot at offset i.
    #[inline(always)]
    pub(crate) fn value(&self, i: usize) -> f64 {
        self.y[i & (TABLE_KNOTS - 1)]
    }

    /// The cubic of the interval at offset i.
    #[inline(always)]
    pub(crate) fn piece(&self, i: usize) -> Piece {
        let i = i & (TABLE_KNOTS - 1);
        Piece {
            x0: self.x[i],
            h: self.h[i],
            c0: self.y[i],
            c1: self.c1[i],
            c2: self.c2[i],
            c3: self.c3[i],
        }
    }

    /// The value at t on the interval at offset i (as [`Piece::value`]).
    #[inline(always)]
    fn value_at(&self, i: usize, t: f64) -> f64 {
        let i = i & (TABLE_KNOTS - 1);
        let u = t - self.x[i];
        self.y[i] + u * (self.c1[i] + u * (self.c2[i] + u * self.c3[i]))
    }
}

impl<'a> CubicSpline<'a> {
    /// The cubic of interval k in power form around x_k (cheap repeated evaluation).
    ///
    /// # Panics
    /// When `k + 1` is not a knot index (a caller's mistake).
    #[inline(always)]
    pub fn piece(&self, k: usize) -> Piece {
        piece_knots(self.x, self.y, &self.m, k)
    }

    /// Hold intervals `first..first + intervals` in `table`.
    ///
    /// # Panics
    /// As [`PieceTable::fill_knots`].
    #[inline]
    pub(crate) fn fill_table(&self, first: usize, intervals: usize, table: &mut PieceTable) {
        table.fill_knots(self.x, self.y, &self.m, first, intervals);
    }

    /// A cursor for queries at non-decreasing t: O(1) amortised per query.
    pub fn cursor(&self) -> Cursor<'_, 'a> {
        Cursor {
            s: self,
            k: 0,
            kp: 0,
            piece: self.piece(0),
        }
    }
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
fn smoothing_moments_valid(x: &[f64], y: &[f64], alpha: f64, g: &mut Vec<f64>) -> Vec<f64> {
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

/// Knots that [`smoothing_moments_windowed`] and [`CubicSpline::new_windowed`] solve at once
/// (each window's core; the overlap comes on top): 2¹⁶ knots keep the per-thread work arrays
/// near 3 MB whatever the stroke's length, and the overlaps' extra work small (0.6 % at a
/// 50 Hz cut-off on 1 kHz samples, 12 % at 2 Hz).
pub const DEFAULT_WINDOW_KNOTS: usize = 1 << 16;

/// Knots an interpolating spline's windowed solve reaches beyond its core on each side: the
/// influence of a moment on its neighbours falls by about 2 − √3 ≈ 0.27 per knot on even
/// spacing, so an end condition 48 knots away reaches the core as 0.27⁴⁸ ≈ 1e-27 of itself
/// (uneven spacing slows that decay somewhat; the margin covers it).
const INTERP_OVERLAP_KNOTS: usize = 48;

/// Settling time constants of the smoother's kernel that a windowed solve reaches beyond its
/// core: e^(−36) ≈ 2e-16, so the artificial ends do not show in the core's moments at double
/// precision even where knots sit up to 1.5× sparser than on average (the kernel's time
/// constant grows with the local spacing as h^(1/4)).
const SMOOTH_OVERLAP_TIME_CONSTANTS: f64 = 36.0;

/// Windows (solve_lo, core_lo, core_hi, solve_hi) covering 0..n: cores of `core` knots, each
/// solved with its neighbours from `reach(core_lo, core_hi)`.
fn windows(
    n: usize,
    core: usize,
    reach: impl Fn(usize, usize) -> (usize, usize),
) -> impl Iterator<Item = (usize, usize, usize, usize)> {
    (0..n.div_ceil(core)).map(move |w| {
        let (a, b) = (w * core, ((w + 1) * core).min(n));
        let (lo, hi) = reach(a, b);
        (lo, a, b, hi)
    })
}

/// As [`smoothing_moments`], solved in overlapping windows of `window` knots so that the
/// work arrays stay bounded on a long stroke: each window's core takes its moments and
/// smoothed values from a solve that reaches 36 settling time
/// constants τ = √2/ω_c (ω_c from α and the mean spacing, [`alpha_for_cutoff`]) and 48 knots
/// beyond it, where the kernel has decayed below double precision: the result equals the
/// whole solve to rounding (tested to 1e-9 relative). Up to `window` knots plus the overlaps
/// it is exactly [`smoothing_moments`].
///
/// # Errors
/// As [`smoothing_moments`].
pub fn smoothing_moments_windowed(
    x: &[f64],
    y: &[f64],
    alpha: f64,
    window: usize,
    g: &mut Vec<f64>,
) -> Result<Vec<f64>, SplineError> {
    validate_knots(x, y)?;
    if !(alpha.is_finite() && alpha >= 0.0) {
        return Err(SplineError::NonFinite { index: 0 });
    }
    let n = x.len();
    let reach_s = smoothing_reach_s(x, alpha);
    let reach = |a: usize, b: usize| smoothing_window(x, a, b, reach_s);
    let window = window.max(4 * INTERP_OVERLAP_KNOTS);
    if n <= window || reach(0, window.min(n)).1 >= n {
        return Ok(smoothing_moments_valid(x, y, alpha, g));
    }
    let mut m = vec![0.0; n];
    g.clear();
    g.resize(n, 0.0);
    let mut gw = Vec::new();
    for (lo, a, b, hi) in windows(n, window, reach) {
        let mw = smoothing_moments_valid(&x[lo..hi], &y[lo..hi], alpha, &mut gw);
        m[a..b].copy_from_slice(&mw[a - lo..b - lo]);
        g[a..b].copy_from_slice(&gw[a - lo..b - lo]);
    }
    Ok(m)
}

/// How far (s) a windowed smoothing solve reaches beyond its core: α = 1/(h·ω_c⁴)
/// ([`alpha_for_cutoff`], h the mean spacing) gives ω_c, and the kernel's settling time
/// constant is √2/ω_c; 0 for α = 0 (interpolation).
fn smoothing_reach_s(x: &[f64], alpha: f64) -> f64 {
    let n = x.len();
    let h_mean = (x[n - 1] - x[0]) / (n - 1) as f64;
    if alpha > 0.0 {
        let omega = (alpha * h_mean).powf(-0.25);
        SMOOTH_OVERLAP_TIME_CONSTANTS * std::f64::consts::SQRT_2 / omega
    } else {
        0.0
    }
}

/// The knots (lo, hi) a smoothing solve for the core `a..b` spans.
fn smoothing_window(x: &[f64], a: usize, b: usize, reach_s: f64) -> (usize, usize) {
    let lo = x.partition_point(|&t| t < x[a] - reach_s);
    let hi = x.partition_point(|&t| t <= x[b - 1] + reach_s);
    (
        lo.saturating_sub(INTERP_OVERLAP_KNOTS),
        (hi + INTERP_OVERLAP_KNOTS).min(x.len()),
    )
}

/// A long smoothing spline ([`smoothing_moments`]) read one window at a time: only the
/// smoothed values and moments of the window in use are held, each window solved as
/// [`smoothing_moments_windowed`] solves it, so every value equals the whole solve's to
/// rounding while memory stays bounded by `window`. Reads anywhere are allowed; they are
/// cheapest in order (a read outside the window in use solves another).
#[derive(Debug)]
pub struct WindowedSmoothing<'a> {
    x: &'a [f64],
    y: &'a [f64],
    alpha: f64,
    window: usize,
    reach_s: f64,
    /// Knots `lo..lo + g.len()` are held.
    lo: usize,
    /// Knots `core.0..core.1` may be read (intervals up to `core.1 − 1`).
    core: (usize, usize),
    g: Vec<f64>,
    m: Vec<f64>,
}

impl<'a> WindowedSmoothing<'a> {
    /// Validate every knot and α, and solve the first window.
    ///
    /// # Errors
    /// As [`smoothing_moments`]; also fewer than 3 knots
    /// ([`SplineError::TooFewKnots`]: use [`smoothing_moments`] for those).
    pub fn new(x: &'a [f64], y: &'a [f64], alpha: f64, window: usize) -> Result<Self, SplineError> {
        validate_knots(x, y)?;
        if !(alpha.is_finite() && alpha >= 0.0) {
            return Err(SplineError::NonFinite { index: 0 });
        }
        if x.len() < 3 {
            return Err(SplineError::TooFewKnots(x.len()));
        }
        let mut s = Self {
            x,
            y,
            alpha,
            window: window.max(4 * INTERP_OVERLAP_KNOTS),
            reach_s: smoothing_reach_s(x, alpha),
            lo: 0,
            core: (0, 0),
            g: Vec::new(),
            m: Vec::new(),
        };
        s.load(0);
        Ok(s)
    }

    /// Knots.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// Always false (at least 3 knots).
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The knots' abscissae.
    pub fn x(&self) -> &'a [f64] {
        self.x
    }

    /// Solve the window whose core holds knot `k`.
    #[cold]
    fn load(&mut self, k: usize) {
        let n = self.x.len();
        let a = k / self.window * self.window;
        let b = (a + self.window).min(n);
        let (lo, hi) = smoothing_window(self.x, a, b, self.reach_s);
        // The knots were validated whole, so a part of them is valid too.
        self.m = smoothing_moments_valid(&self.x[lo..hi], &self.y[lo..hi], self.alpha, &mut self.g);
        self.lo = lo;
        self.core = (a, b);
    }

    /// Make knots `k` and `k + 1` readable (`k + 1` lies in the overlap past a core's end).
    #[inline(always)]
    fn hold(&mut self, k: usize) -> usize {
        if k < self.core.0 || k >= self.core.1 {
            self.load(k);
        }
        k - self.lo
    }

    /// Smoothed value g(x_k).
    #[inline]
    pub fn value(&mut self, k: usize) -> f64 {
        let i = self.hold(k);
        self.g[i]
    }

    /// Second derivative at knot k.
    #[inline]
    pub fn moment(&mut self, k: usize) -> f64 {
        let i = self.hold(k);
        self.m[i]
    }

    /// As [`CubicSpline::eval_in`].
    #[inline]
    pub fn eval_in(&mut self, k: usize, t: f64) -> (f64, f64, f64) {
        let i = self.hold(k);
        eval_knots(&self.x[self.lo..], &self.g, &self.m, i, t)
    }

    /// As [`CubicSpline::piece`].
    #[inline]
    pub fn piece(&mut self, k: usize) -> Piece {
        let i = self.hold(k);
        piece_knots(&self.x[self.lo..], &self.g, &self.m, i)
    }

    /// As [`CubicSpline::interval`].
    #[inline]
    pub fn interval(&self, t: f64) -> usize {
        let k = self.x.partition_point(|&xi| xi <= t);
        k.saturating_sub(1).min(self.x.len() - 2)
    }
}

thread_local! {
    static SMOOTH_SCRATCH: std::cell::RefCell<[Vec<f64>; 5]> =
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

/// One interval's cubic c0 + c1·u + c2·u² + c3·u³ with u = t − x0, for 0 ≤ u ≤ h.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Piece {
    /// Left knot.
    pub x0: f64,
    /// Interval length.
    pub h: f64,
    /// Value at x0.
    pub c0: f64,
    /// First derivative at x0.
    pub c1: f64,
    /// Half the second derivative at x0.
    pub c2: f64,
    /// A sixth of the third derivative.
    pub c3: f64,
}

impl Piece {
    /// Value at offset u from x0.
    #[inline]
    pub fn value(&self, u: f64) -> f64 {
        self.c0 + u * (self.c1 + u * (self.c2 + u * self.c3))
    }

    /// Value, first and second derivative at offset u from x0.
    #[inline]
    pub fn eval(&self, u: f64) -> (f64, f64, f64) {
        let v = self.c0 + u * (self.c1 + u * (self.c2 + u * self.c3));
        let d1 = self.c1 + u * (2.0 * self.c2 + 3.0 * u * self.c3);
        let d2 = 2.0 * self.c2 + 6.0 * u * self.c3;
        (v, d1, d2)
    }
}

/// A long interpolating spline evaluated forward in time one window at a time: only the
/// moments of the window in use are held (a window's core and 48 knots either side), each
/// solved as [`CubicSpline::new_windowed`] solves it, so values equal the whole spline's to
/// rounding while memory stays bounded by `window`, not by the knots.
#[derive(Debug)]
pub struct WindowedSpline<'a> {
    x: &'a [f64],
    y: &'a [f64],
    end: EndCondition,
    window: usize,
    /// The spline of the window in use, over knots `lo..` of `x`.
    part: CubicSpline<'a>,
    lo: usize,
    /// Intervals `core.0..core.1` (global) are evaluated from `part`.
    core: (usize, usize),
    /// Interval of the last query (global).
    k: usize,
    cp: Vec<f64>,
}

impl<'a> WindowedSpline<'a> {
    /// Validate every knot and solve the first window.
    ///
    /// # Errors
    /// As [`CubicSpline::new`].
    pub fn new(
        x: &'a [f64],
        y: &'a [f64],
        end: EndCondition,
        window: usize,
    ) -> Result<Self, SplineError> {
        validate_knots(x, y)?;
        let mut s = Self {
            x,
            y,
            end,
            window: window.max(4 * INTERP_OVERLAP_KNOTS),
            part: CubicSpline {
                x,
                y,
                m: Vec::new(),
            },
            lo: 0,
            core: (0, 0),
            k: 0,
            cp: Vec::new(),
        };
        s.load(0);
        Ok(s)
    }

    /// Solve the window whose core holds interval `k`.
    fn load(&mut self, k: usize) {
        let n = self.x.len();
        let a = k / self.window * self.window;
        let b = (a + self.window).min(n);
        let lo = a.saturating_sub(INTERP_OVERLAP_KNOTS);
        let hi = (b + INTERP_OVERLAP_KNOTS).min(n);
        let (x, y) = (&self.x[lo..hi], &self.y[lo..hi]);
        let m = moments(x, y, self.end, &mut self.cp);
        self.part = CubicSpline { x, y, m };
        self.lo = lo;
        // The last window's core reaches the last interval, n − 2.
        self.core = (a, if b == n { n - 1 } else { b });
    }

    /// The value at t (clamped to the end intervals like [`CubicSpline::eval`]); fastest for
    /// non-decreasing t.
    #[inline]
    pub fn eval(&mut self, t: f64) -> f64 {
        let x = self.x;
        let last = x.len() - 2;
        let search = |t: f64| x.partition_point(|&xi| xi <= t).saturating_sub(1).min(last);
        let mut k = self.k;
        if t < x[k] {
            k = search(t);
        } else if k < last && t >= x[k + 1] {
            // The next interval inline; anything further by a search.
            k = if k + 1 < last && t >= x[k + 2] {
                search(t)
            } else {
                k + 1
            };
        }
        self.k = k;
        if k < self.core.0 || k >= self.core.1 {
            self.load(k);
        }
        self.part.eval_in(k - self.lo, t).0
    }
}

/// Walks a spline's intervals for queries in non-decreasing order.
#[derive(Debug)]
pub struct Cursor<'s, 'a> {
    s: &'s CubicSpline<'a>,
    k: usize,
    /// The interval `piece` belongs to (`seek` may move `k` on alone).
    kp: usize,
    piece: Piece,
}

impl Cursor<'_, '_> {
    /// Move to the interval holding t (forward only; a smaller t falls back to a search).
    #[inline(always)]
    pub fn seek(&mut self, t: f64) -> usize {
        let x = self.s.x;
        let last = x.len() - 2;
        // The common cases inline (same or next interval); jumps and going back out of line.
        let k = self.k;
        if t < x[k] {
            return self.seek_far(t);
        }
        if k < last && t >= x[k + 1] {
            if k + 1 < last && t >= x[k + 2] {
                return self.seek_far(t);
            }
            self.k = k + 1;
        }
        self.k
    }

    /// [`seek`](Self::seek) beyond the next interval: a search back, or a few linear steps and
    /// then a galloping search forward.
    #[cold]
    #[inline(never)]
    fn seek_far(&mut self, t: f64) -> usize {
        let x = self.s.x;
        let last = x.len() - 2;
        if t < x[self.k] {
            self.k = self.s.interval(t);
            return self.k;
        }
        let mut steps = 0;
        while self.k < last && t >= x[self.k + 1] {
            self.k += 1;
            steps += 1;
            if steps == 8 {
                let rest = &x[self.k + 1..];
                let j = rest.partition_point(|&xi| xi <= t);
                self.k = (self.k + j).min(last);
                break;
            }
        }
        self.k
    }

    /// The piece of the interval holding t.
    #[inline(always)]
    fn piece_at(&mut self, t: f64) -> &Piece {
        let k = self.seek(t);
        if k != self.kp {
            self.piece = self.s.piece(k);
            self.kp = k;
        }
        &self.piece
    }

    /// Value, first and second derivative at t.
    #[inline]
    pub fn eval_all(&mut self, t: f64) -> (f64, f64, f64) {
        let p = self.piece_at(t);
        p.eval(t - p.x0)
    }

    /// Value at t.
    #[inline(always)]
    pub fn eval(&mut self, t: f64) -> f64 {
        let p = self.piece_at(t);
        p.value(t - p.x0)
    }

    /// The values at times `t` into `out`, the same bits as [`eval`](Self::eval) at each.
    ///
    /// When the times do not decrease and their intervals fit a [`PieceTable`], the intervals'
    /// cubics are formed together in `table` and the walk over them keeps its interval in a
    /// register: what is left of a query is a step or two of the search and the cubic.
    /// Otherwise (times sparser than knots, or going back) each is read as
    /// [`eval`](Self::eval) reads it.
    ///
    /// # Panics
    /// When `out` is shorter than `t` (a caller's mistake).
    #[inline]
    pub(crate) fn eval_block(&mut self, t: &[f64], out: &mut [f64], table: &mut PieceTable) {
        let out = &mut out[..t.len()];
        let (Some(&t_first), Some(&t_last)) = (t.first(), t.last()) else {
            return;
        };
        // All compared, not stopping at the first failure, so that the loop vectorises; a
        // NaN fails too.
        let ordered = t[..t.len() - 1]
            .iter()
            .zip(&t[1..])
            .fold(true, |ok, (a, b)| ok & (a <= b));
        let k0 = self.seek(t_first);
        let k1 = self.s.interval(t_last);
        let last = self.s.x.len() - 2;
        if !(ordered && t_last < f64::INFINITY && k1 - k0 < PieceTable::INTERVALS) {
            for (&t, e) in t.iter().zip(out) {
                *e = self.eval(t);
            }
            return;
        }
        // Every time lies in intervals k0..=k1 (offsets 0..=n − 1), each found by stepping
        // on from the last one: no time reaches the knot after k1, or, after the spline's
        // last interval, +∞ in its place (t_last is finite), so the steps need no bound.
        let n = k1 - k0 + 1;
        self.s.fill_table(k0, n, table);
        if k1 == last {
            table.x[n] = f64::INFINITY;
        }
        let mut i = 0;
        for (&t, e) in t.iter().zip(out) {
            while t >= table.knot(i + 1) {
                i += 1;
            }
            *e = table.value_at(i, t);
        }
        self.k = k1;
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

#[cfg(test)]
mod tests {
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
    fn power_form_piece_agrees() {
        let x = [0.0, 0.4, 1.1, 1.5, 2.9, 3.0];
        let y = [1.0, -2.0, 0.5, 0.7, 3.0, -1.0];
        let s = CubicSpline::new(&x, &y, EndCondition::NotAKnot).unwrap();
        for k in 0..5 {
            let p = s.piece(k);
            for j in 0..=10 {
                let t = x[k] + (x[k + 1] - x[k]) * j as f64 / 10.0;
                let (a, b, c) = s.eval_in(k, t);
                let (d, e, f) = p.eval(t - x[k]);
                assert!(
                    (a - d).abs() + (b - e).abs() + (c - f).abs() < 1e-11,
                    "k={k} t={t}"
                );
            }
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
    fn cursor_agrees_with_search_and_goes_back() {
        let x: Vec<f64> = (0..200).map(|k| (k as f64).powf(1.3)).collect();
        let y: Vec<f64> = x.iter().map(|t| (0.1 * t).cos()).collect();
        let s = CubicSpline::new(&x, &y, EndCondition::NotAKnot).unwrap();
        let mut c = s.cursor();
        for &t in &[0.5, 0.6, 300.0, 301.0, 50.0, 900.0, 2.0] {
            let (a, b, cc) = c.eval_all(t);
            let (d, e, f) = s.eval_all(t);
            assert!(
                (a - d).abs() + (b - e).abs() + (cc - f).abs() < 1e-13,
                "t={t}"
            );
        }
    }

    /// Knots 0.2 to 5 ms apart at random, and a smooth curve with a little noise on them.
    fn random_knots(rng: &mut impl rand::Rng, n: usize) -> (Vec<f64>, Vec<f64>) {
        let mut t = -3.0;
        let x = (0..n)
            .map(|_| {
                t += 1e-3 * (0.2 + 4.8 * rng.random::<f64>());
                t
            })
            .collect();
        let y = (0..n)
            .map(|k| (0.05 * k as f64).sin() + 1e-3 * (rng.random::<f64>() - 0.5))
            .collect();
        (x, y)
    }

    /// The table's cubics are those of `piece`, bit for bit, wherever the run starts and
    /// however long it is, up to the spline's last interval.
    #[test]
    fn table_holds_the_bits_of_the_pieces() {
        use rand::SeedableRng;
        let mut rng = rand::rngs::StdRng::seed_from_u64(0x7ab1e);
        let (x, y) = random_knots(&mut rng, 2000);
        let s = CubicSpline::new(&x, &y, EndCondition::NotAKnot).unwrap();
        let mut table = PieceTable::new();
        let last = x.len() - 2;
        for (first, n) in [
            (0, 1),
            (0, 511),
            (17, 300),
            (last + 1 - 511, 511),
            (last, 1),
        ] {
            s.fill_table(first, n, &mut table);
            for i in 0..n {
                let (a, b) = (table.piece(i), s.piece(first + i));
                for (u, v) in [(a.x0, b.x0), (a.h, b.h), (a.c0, b.c0)].into_iter().chain([
                    (a.c1, b.c1),
                    (a.c2, b.c2),
                    (a.c3, b.c3),
                ]) {
                    assert_eq!(u.to_bits(), v.to_bits(), "first {first} interval {i}");
                }
                assert_eq!(table.value(i + 1).to_bits(), y[first + i + 1].to_bits());
            }
        }
    }

    /// A block read gives the bits of one query at a time, whether the times come several to
    /// an interval or several intervals apart, repeat, go back, leave the knots' span or are
    /// not finite.
    #[test]
    fn block_read_gives_the_bits_of_one_query_at_a_time() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(0xb10c);
        let (x, y) = random_knots(&mut rng, 3000);
        let s = CubicSpline::new(&x, &y, EndCondition::NotAKnot).unwrap();
        let (lo, hi) = (x[0], x[x.len() - 1]);
        let mean_h = (hi - lo) / (x.len() - 1) as f64;
        let mut table = PieceTable::new();
        let same = |a: f64, b: f64| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
        // Mean knot intervals between queries: dense, about one, and sparser than the table.
        for per_query in [0.1, 0.97, 1.0, 1.03, 2.5, 40.0] {
            let (mut block, mut one) = (s.cursor(), s.cursor());
            let mut t = lo - 20.0 * mean_h;
            while t < hi + 20.0 * mean_h {
                let mut ts: Vec<f64> = (0..256)
                    .map(|_| {
                        t += per_query * mean_h * 2.0 * rng.random::<f64>();
                        t
                    })
                    .collect();
                match rng.random_range(0..8) {
                    0 => ts.reverse(),
                    1 => ts[100] = ts[90],
                    2 => ts[255] = f64::INFINITY,
                    3 => ts[7] = f64::NAN,
                    4 => ts[0] = f64::NEG_INFINITY,
                    _ => {}
                }
                let mut out = vec![0.0; ts.len()];
                block.eval_block(&ts, &mut out, &mut table);
                for (&t, &e) in ts.iter().zip(&out) {
                    let r = one.eval(t);
                    assert!(same(e, r), "{per_query} per query, t {t}: {e} against {r}");
                }
            }
        }
    }

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

    /// A slow stroke as a controller logs it: asynchronous times (0.5-1.5 ms apart), a ramp
    /// to a constant speed with a screw-like ripple, noise and a 1 µm quantum.
    fn logged_stroke(n: usize) -> (Vec<f64>, Vec<f64>) {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(14);
        let mut t: f64 = 0.0;
        let (mut x, mut y) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for _ in 0..n {
            t += rng.random_range(0.5e-3..1.5e-3);
            let z = 0.01 * (t - 1.0 + (-t).exp()) + 2e-6 * (2.0 * std::f64::consts::PI * t).sin();
            let noisy = z + rng.random_range(-0.3e-6..0.3e-6);
            x.push(t);
            y.push((noisy / 1e-6).round() * 1e-6);
        }
        (x, y)
    }

    #[test]
    fn windowed_smoothing_equals_the_whole_solve() {
        let (x, y) = logged_stroke(60_000);
        let h = (x[x.len() - 1] - x[0]) / (x.len() - 1) as f64;
        for cutoff_hz in [2.0, 10.0, 100.0] {
            let alpha = alpha_for_cutoff(h, cutoff_hz);
            let (mut g_whole, mut g_win) = (Vec::new(), Vec::new());
            let whole = smoothing_moments(&x, &y, alpha, &mut g_whole).unwrap();
            let win = smoothing_moments_windowed(&x, &y, alpha, 5_000, &mut g_win).unwrap();
            let scale = whole.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            let worst = whole
                .iter()
                .zip(&win)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(
                worst <= 1e-9 * scale,
                "{cutoff_hz} Hz: moments differ by {worst:e} of {scale:e}"
            );
            let worst_g = g_whole
                .iter()
                .zip(&g_win)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            // The smoothed positions against the travel (0.6 m): 1e-9 relative is 0.6 nm.
            assert!(
                worst_g <= 1e-9 * 0.6,
                "{cutoff_hz} Hz: smoothed values differ by {worst_g:e}"
            );
            assert_eq!(g_win.len(), x.len());
        }
        // Short inputs take the whole solve, bit for bit.
        let (mut a, mut b) = (Vec::new(), Vec::new());
        let alpha = alpha_for_cutoff(h, 10.0);
        let m1 = smoothing_moments(&x[..3000], &y[..3000], alpha, &mut a).unwrap();
        let m2 = smoothing_moments_windowed(&x[..3000], &y[..3000], alpha, 5_000, &mut b).unwrap();
        assert!(m1.iter().zip(&m2).all(|(p, q)| p.to_bits() == q.to_bits()));
    }

    #[test]
    fn windowed_interpolation_equals_the_whole_solve() {
        let (x, y) = logged_stroke(20_000);
        for end in [EndCondition::NotAKnot, EndCondition::Natural] {
            let whole = CubicSpline::new(&x, &y, end).unwrap();
            let win = CubicSpline::new_windowed(&x, &y, end, 500).unwrap();
            let scale = whole.moments().iter().fold(0.0f64, |a, v| a.max(v.abs()));
            let worst = whole
                .moments()
                .iter()
                .zip(win.moments())
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(worst <= 1e-9 * scale, "{end:?}: {worst:e} of {scale:e}");
        }
        // Bad knots are refused as by the whole solve.
        let mut bad = x.clone();
        bad[15_000] = bad[14_999];
        assert!(matches!(
            CubicSpline::new_windowed(&bad, &y, EndCondition::NotAKnot, 500),
            Err(SplineError::NotIncreasing { index: 15_000, .. })
        ));
    }

    #[test]
    fn windowed_evaluation_equals_the_whole_spline() {
        let (x, y) = logged_stroke(20_000);
        let whole = CubicSpline::new(&x, &y, EndCondition::NotAKnot).unwrap();
        let mut win = WindowedSpline::new(&x, &y, EndCondition::NotAKnot, 500).unwrap();
        let scale = y.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        // Forward queries between and on knots, a jump back, and beyond both ends.
        let mut ts: Vec<f64> = (0..60_000)
            .map(|k| x[0] + k as f64 * (x[19_999] - x[0]) / 59_999.0)
            .collect();
        ts.extend([x[100], x[0] - 1e-3, x[19_999] + 1e-3, x[12_345]]);
        for t in ts {
            let (a, b) = (whole.eval(t), win.eval(t));
            assert!((a - b).abs() <= 1e-12 * scale, "t {t}: {a} vs {b}");
        }
    }

    #[test]
    fn windowed_smoothing_reads_equal_the_whole_solve() {
        let (x, y) = logged_stroke(30_000);
        let h = (x[x.len() - 1] - x[0]) / (x.len() - 1) as f64;
        let alpha = alpha_for_cutoff(h, 5.0);
        let mut g = Vec::new();
        let m = smoothing_moments(&x, &y, alpha, &mut g).unwrap();
        let whole = CubicSpline::from_moments(&x, &g, m).unwrap();
        let mut win = WindowedSmoothing::new(&x, &y, alpha, 3_000).unwrap();
        let ms = whole.moments().iter().fold(0.0f64, |a, v| a.max(v.abs()));
        // Forward, then a jump to the end and back to the start, as the estimator reads.
        let order: Vec<usize> = (0..x.len() - 1)
            .chain([x.len() - 2, 5, 29_000, 17])
            .collect();
        for k in order {
            assert!(
                (whole.y()[k] - win.value(k)).abs() <= 1e-9 * 0.6,
                "value {k}"
            );
            assert!(
                (whole.moments()[k] - win.moment(k)).abs() <= 1e-9 * ms,
                "moment {k}"
            );
            let t = 0.5 * (x[k] + x[k + 1]);
            let (a, b) = (whole.eval_in(k, t), win.eval_in(k, t));
            assert!(
                (a.0 - b.0).abs() <= 1e-9 * 0.6 && (a.2 - b.2).abs() <= 1e-9 * ms,
                "eval {k}"
            );
            let (p, q) = (whole.piece(k), win.piece(k));
            assert!(
                (p.c1 - q.c1).abs() <= 1e-9 * p.c1.abs().max(1e-3),
                "piece {k}"
            );
        }
        assert_eq!(win.interval(x[100] + 1e-9), whole.interval(x[100] + 1e-9));
    }
}
