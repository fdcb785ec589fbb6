//! The time of a position: t(z) by safeguarded Newton iteration on the position spline's
//! pieces (step 3).

#[cfg(doc)]
use super::stroke::GridWalk;
use super::stroke::KnotRead;
use crate::spline::Piece;

/// t(z) at one grid point after another, as [`GridWalk::invert`] solves it.
pub(super) struct Solve<'a> {
    /// The position spline's knots (s).
    pub(super) tz: &'a [f64],
    /// Output window (s).
    pub(super) w_lo: f64,
    pub(super) w_hi: f64,
    /// Time of the last point (s).
    pub(super) t_prev: f64,
    /// Whether the inversion found no bracketing interval somewhere.
    pub(super) non_monotone: bool,
}

impl<'a> Solve<'a> {
    /// Time, velocity and acceleration where the position spline reaches zg (m), on interval
    /// k, whose cubic is p and right knot's value z1.
    #[inline(always)]
    pub(super) fn at<Z: KnotRead<'a>>(
        &mut self,
        zs: &mut Z,
        k: usize,
        p: &Piece,
        z1: f64,
        zg: f64,
    ) -> (f64, f64, f64) {
        let (t, v, a) = match newton_in_piece(p, z1, zg) {
            Some((u, v, a)) => (p.x0 + u, v, a),
            None => {
                // Not monotone here: the safeguarded search over neighbours.
                let guess = self.t_prev.max(self.tz[k]);
                let (t, k, ok) = invert_in(zs, k, zg, guess, self.w_lo, self.w_hi);
                self.non_monotone |= !ok;
                let (_, v, a) = zs.eval_in(k, t);
                (t, v, a)
            }
        };
        self.t_prev = t;
        (t, v, a)
    }
}

/// Newton's method for z(x0 + u) = target inside one monotone piece, started from linear
/// interpolation between the piece's ends (`z1` is the value at its right knot). Returns
/// (u, z', z'') or `None` when the piece does not bracket the target monotonically (then
/// [`invert_in`] takes over).
#[inline(always)]
pub(super) fn newton_in_piece(
    p: &crate::spline::Piece,
    z1: f64,
    target: f64,
) -> Option<(f64, f64, f64)> {
    let dz = z1 - p.c0;
    if dz == 0.0 {
        return None;
    }
    let frac = (target - p.c0) / dz;
    if !(0.0..=1.0).contains(&frac) {
        return None;
    }
    // The sign of the rise as a constant: each slope test is then one comparison.
    if dz > 0.0 {
        chord_newton::<true>(p, frac, target)
    } else {
        chord_newton::<false>(p, frac, target)
    }
}

/// The iteration of [`newton_in_piece`] from `frac` of the way along piece p, on a piece
/// that rises (`RISING`) or falls from its left knot to its right.
#[inline(always)]
fn chord_newton<const RISING: bool>(
    p: &crate::spline::Piece,
    frac: f64,
    target: f64,
) -> Option<(f64, f64, f64)> {
    let mut u = frac * p.h;
    // Chord-Newton: the slope from the start point is kept, which trades one division per
    // step for a slightly slower (still fast: the start is within O(h²) of the root)
    // convergence. Steps below 1e-13 of the interval are rounding noise.
    let tol = 1e-13 * p.h;
    // One evaluation per step: the start's slope fixes the chord, each new point's values are
    // both the next residual and, once the step is below tolerance, the answer.
    let (mut z, d1_0, _) = p.eval(u);
    if d1_0 == 0.0 || (d1_0 > 0.0) != RISING {
        return None;
    }
    let inv_d1 = 1.0 / d1_0;
    // No contraction estimate before the second step (NaN fails every comparison).
    let mut du_prev = f64::NAN;
    for _ in 0..16 {
        let du = (z - target) * inv_d1;
        u -= du;
        let (z_new, d1, d2) = p.eval(u);
        z = z_new;
        if (d1 > 0.0) != RISING {
            return None;
        }
        // The chord iteration contracts by ρ per step, so the error left after this step is
        // about |du|·ρ/(1 − ρ): stop as soon as that, or the step itself, is below tolerance.
        // The ratio is formed only when the step alone does not decide: the first step nearly
        // always does, and the division cost every point.
        if du.abs() <= tol || {
            let rho = (du / du_prev).abs();
            rho < 0.5 && du.abs() * rho <= 0.5 * tol
        } {
            if !(-tol..=p.h + tol).contains(&u) {
                return None;
            }
            return Some((u, d1, d2));
        }
        du_prev = du;
    }
    None
}

/// Solve z(t) = target on knot interval k (then its neighbours) by Newton steps safeguarded
/// with bisection. Returns the time, the interval holding it, and whether a bracketing
/// interval was found.
fn invert_in<'a>(
    zs: &mut impl KnotRead<'a>,
    k: usize,
    target: f64,
    guess: f64,
    w_lo: f64,
    w_hi: f64,
) -> (f64, usize, bool) {
    let x = zs.x();
    let n_int = x.len() - 1;
    // Search this interval and a few after it for a sign change (the spline can overshoot
    // between knots when the position is noisy).
    for kk in k..(k + 4).min(n_int) {
        let (a, b) = (x[kk].max(w_lo), x[kk + 1].min(w_hi));
        if b < a {
            continue;
        }
        let fa = zs.eval_in(kk, a).0 - target;
        if fa == 0.0 {
            return (a, kk, true);
        }
        let fb = zs.eval_in(kk, b).0 - target;
        if fa * fb > 0.0 {
            continue;
        }
        // Converged when a step is below a few ulps of t.
        let tol = 4.0 * f64::EPSILON * b.abs().max(1.0);
        let (mut lo, mut hi) = (a, b);
        let mut t = if guess > a && guess < b {
            guess
        } else {
            a + (b - a) * fa / (fa - fb)
        };
        for _ in 0..100 {
            let (v, d1, _) = zs.eval_in(kk, t);
            let f = v - target;
            if f == 0.0 {
                return (t, kk, true);
            }
            if (f < 0.0) == (fa < 0.0) {
                lo = t;
            } else {
                hi = t;
            }
            let newton = t - f / d1;
            if d1 != 0.0 && newton >= lo && newton <= hi {
                // Newton from one side lands on the bracket's edge when it has converged,
                // so test convergence before anything else.
                if (newton - t).abs() <= tol {
                    return (newton, kk, true);
                }
                t = newton;
            } else {
                t = 0.5 * (lo + hi);
                if hi - lo <= tol {
                    return (t, kk, true);
                }
            }
        }
        return (t, kk, true);
    }
    let t = guess.clamp(w_lo, w_hi);
    (t, zs.interval(t), false)
}
