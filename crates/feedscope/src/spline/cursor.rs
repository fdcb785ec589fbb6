//! Power-form pieces, the table of a run of them, and the cursor for sequential queries.

use super::CubicSpline;

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

/// The cubic of interval k of knots `x`, values `y` and moments `m` in power form around
/// x_k ([`CubicSpline::piece`]).
#[inline(always)]
pub(super) fn piece_knots(x: &[f64], y: &[f64], m: &[f64], k: usize) -> Piece {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spline::EndCondition;

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
}
