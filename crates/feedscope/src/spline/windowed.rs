//! Long traces solved in overlapping windows, so that the work arrays stay bounded.

use super::cursor::piece_knots;
use super::smoothing::smoothing_moments_valid;
#[cfg(doc)]
use super::{alpha_for_cutoff, smoothing_moments};
use super::{eval_knots, moments, validate_knots, CubicSpline, EndCondition, Piece, SplineError};

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

impl<'a> CubicSpline<'a> {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spline::{alpha_for_cutoff, smoothing_moments};

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
