//! Steps 1-2 of the method in the [module docs](super): kernel averages of the torque and of
//! the model's columns that make the inertia column exact.
//!
//! # Why a hat kernel
//! For position samples at t_{k−m} < t_k < t_{k+m}, the second divided difference is an
//! average of the acceleration with the normalised linear B-spline ("hat") M_k whose knots are
//! those three instants (Peano kernel of the divided difference):
//!
//! ā_k = 2·z[t_{k−m}, t_k, t_{k+m}] = ∫ z''(t)·M_k(t) dt, ∫ M_k dt = 1,
//!
//! exactly, for any motion, with no smoothing and no model of the trajectory. Averaging the
//! model T = J·θ'' + T_f(v) with the same M_k gives
//!
//! T̄_k = J·(2π/p)·ā_k + T̄_f,k,
//!
//! so J multiplies an exactly known regressor. T̄_k and T̄_f,k are computed with the
//! quadrature that is exact when T (and T_f) is linear between samples,
//! ∫ T·M_k = Σ_i w_ki·T_i (the weights below). At an acceleration step (the corner of a
//! trapezoidal move) the quadrature errs, but the error is in the torque, not in the
//! regressor, and averages to zero over the position of the step between two samples; a
//! pointwise fit of T_k on a differentiated position instead has its error in the regressor
//! and is biased (errors in variables).
//!
//! The velocity in T_f is the central difference v̂_i = (z_{i+m} − z_{i−m})/(t_{i+m} − t_{i−m}),
//! the mean velocity over the window: exact on cruise and on constant-acceleration ramps.
//! Where the velocity changes sign or stands still inside a kernel's support T_f is not a
//! function of v̂ (pre-sliding, the sign step); those rows are excluded (the reversal guard).

/// A sparse averaging operator K: row k is Σ_i w_ki·x_i over the samples x_i (row-compressed).
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct Averaging {
    start: Vec<usize>,
    index: Vec<usize>,
    weight: Vec<f64>,
    /// Number of samples the rows refer to.
    samples: usize,
}

impl Averaging {
    /// Number of samples the rows refer to.
    pub(super) fn samples_len(&self) -> usize {
        self.samples
    }

    /// Number of rows.
    pub(super) fn rows(&self) -> usize {
        self.start.len() - 1
    }

    /// The rows of `self` listed in `keep`, in that order.
    pub(super) fn select(&self, keep: &[usize]) -> Self {
        let mut out = Self {
            start: vec![0],
            index: Vec::new(),
            weight: Vec::new(),
            samples: self.samples,
        };
        for &k in keep {
            let r = self.start[k]..self.start[k + 1];
            out.index.extend_from_slice(&self.index[r.clone()]);
            out.weight.extend_from_slice(&self.weight[r]);
            out.start.push(out.index.len());
        }
        out
    }

    /// K·x.
    pub(super) fn apply(&self, x: &[f64]) -> Vec<f64> {
        debug_assert_eq!(x.len(), self.samples);
        (0..self.rows())
            .map(|k| {
                let r = self.start[k]..self.start[k + 1];
                self.index[r.clone()]
                    .iter()
                    .zip(&self.weight[r])
                    .map(|(&i, &w)| w * x[i])
                    .sum()
            })
            .collect()
    }

    /// Kᵀ·r (one value per sample).
    pub(super) fn apply_transpose(&self, r: &[f64]) -> Vec<f64> {
        debug_assert_eq!(r.len(), self.rows());
        let mut out = vec![0.0; self.samples];
        for (k, &rk) in r.iter().enumerate() {
            let s = self.start[k]..self.start[k + 1];
            for (&i, &w) in self.index[s.clone()].iter().zip(&self.weight[s]) {
                out[i] += w * rk;
            }
        }
        out
    }

    /// tr(K·Kᵀ) = Σ w_ki²: the noise variance the rows carry, in units of the samples'.
    pub(super) fn trace_kkt(&self) -> f64 {
        self.weight.iter().map(|w| w * w).sum()
    }
}

/// Hat-kernel weights w_ki (i = k−m … k+m) of ∫ T·M_k dt for T linear between the samples
/// t_i: on each interval [t_i, t_{i+1}] the product of two linear functions integrates to
/// Δ/6·(2·f_i·g_i + f_i·g_{i+1} + f_{i+1}·g_i + 2·f_{i+1}·g_{i+1}), g = M_k at the samples.
fn hat_weights(t: &[f64], k: usize, m: usize, out: &mut Vec<(usize, f64)>) {
    out.clear();
    let (a, c, b) = (t[k - m], t[k], t[k + m]);
    let height = 2.0 / (b - a);
    let g = |i: usize| {
        let x = t[i];
        if i <= k {
            height * (x - a) / (c - a)
        } else {
            height * (b - x) / (b - c)
        }
    };
    for i in k - m..=k + m {
        let mut w = 0.0;
        if i > k - m {
            let d = t[i] - t[i - 1];
            w += d / 6.0 * (2.0 * g(i) + g(i - 1));
        }
        if i < k + m {
            let d = t[i + 1] - t[i];
            w += d / 6.0 * (2.0 * g(i) + g(i + 1));
        }
        out.push((i, w));
    }
}

/// The kernel quantities of a trace for half-width `m` samples.
#[derive(Debug, Clone)]
pub(super) struct KernelSeries {
    /// v̂_i, the central difference over ±m samples (m/s); NaN within m of the ends.
    pub(super) velocity_m_s: Vec<f64>,
    /// ā_k = 2·z[t_{k−m}, t_k, t_{k+m}] (m/s²); NaN within 2m of the ends (rows need v̂ over
    /// their whole support).
    pub(super) accel_m_s2: Vec<f64>,
    /// The hat average operator, one row per sample; rows within 2m of the ends are empty.
    pub(super) averaging: Averaging,
}

/// v̂, ā and the hat averages for positions `z` at times `t` (strictly increasing).
///
/// # Panics
/// If `m` is 0 or `t` and `z` differ in length (programmer's errors).
pub(super) fn kernel_series(t: &[f64], z: &[f64], m: usize) -> KernelSeries {
    assert!(m >= 1, "kernel half-width must be at least one sample");
    assert_eq!(t.len(), z.len());
    let n = t.len();
    let mut v = vec![f64::NAN; n];
    for i in m..n.saturating_sub(m) {
        v[i] = (z[i + m] - z[i - m]) / (t[i + m] - t[i - m]);
    }
    let mut a = vec![f64::NAN; n];
    let mut avg = Averaging {
        start: vec![0],
        index: Vec::new(),
        weight: Vec::new(),
        samples: n,
    };
    let mut w = Vec::with_capacity(2 * m + 1);
    for k in 0..n {
        if k >= 2 * m && k + 2 * m < n {
            let (h0, h1) = (t[k] - t[k - m], t[k + m] - t[k]);
            a[k] = 2.0 * ((z[k + m] - z[k]) / h1 - (z[k] - z[k - m]) / h0) / (h0 + h1);
            hat_weights(t, k, m, &mut w);
            for &(i, wi) in &w {
                avg.index.push(i);
                avg.weight.push(wi);
            }
        }
        avg.start.push(avg.index.len());
    }
    KernelSeries {
        velocity_m_s: v,
        accel_m_s2: a,
        averaging: avg,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Non-uniform times from a fixed pseudo-random sequence.
    fn times(n: usize) -> Vec<f64> {
        let mut t = vec![0.0];
        for i in 1..n {
            let jitter = ((i as f64 * 0.618_033_988_7).fract() - 0.5) * 0.6;
            t.push(t[i - 1] + 0.01 * (1.0 + jitter));
        }
        t
    }

    /// The divided difference is the hat average of z'': for a cubic z = t³ the average of
    /// 6t over the hat equals 6·(centroid of the hat) = 2·(a + c + b), and the quadrature of
    /// the same hat reproduces it (6t is linear between the samples: exact).
    #[test]
    fn divided_difference_is_the_hat_average_of_the_acceleration() {
        let t = times(60);
        let z: Vec<f64> = t.iter().map(|x| x * x * x).collect();
        let acc: Vec<f64> = t.iter().map(|x| 6.0 * x).collect();
        for m in [1, 3] {
            let s = kernel_series(&t, &z, m);
            let quad = s.averaging.apply(&acc);
            for k in 2 * m..t.len() - 2 * m {
                let centroid = (t[k - m] + t[k] + t[k + m]) / 3.0;
                // rounding of differences of O(1) numbers over 0.01² spacings: 1e-9
                assert!(
                    (s.accel_m_s2[k] - 6.0 * centroid).abs() < 1e-9,
                    "m {m} k {k}"
                );
                assert!((quad[k] - 6.0 * centroid).abs() < 1e-12, "m {m} k {k}");
            }
        }
    }

    /// Weights sum to 1 (∫M = 1) and Kᵀ is the transpose of K (⟨Kx, r⟩ = ⟨x, Kᵀr⟩).
    #[test]
    fn weights_are_normalised_and_transpose_is_adjoint() {
        let t = times(40);
        let s = kernel_series(&t, &t, 2);
        let ones = s.averaging.apply(&vec![1.0; 40]);
        for x in &ones[4..36] {
            assert!((x - 1.0).abs() < 1e-14);
        }
        assert!(ones[..4].iter().all(|&x| x == 0.0) && ones[36..].iter().all(|&x| x == 0.0));
        let x: Vec<f64> = (0..40).map(|i| (i as f64 * 0.7).sin()).collect();
        let r: Vec<f64> = (0..40).map(|i| (i as f64 * 1.3).cos()).collect();
        let lhs: f64 = s
            .averaging
            .apply(&x)
            .iter()
            .zip(&r)
            .map(|(a, b)| a * b)
            .sum();
        let rhs: f64 = x
            .iter()
            .zip(s.averaging.apply_transpose(&r))
            .map(|(a, b)| a * b)
            .sum();
        assert!((lhs - rhs).abs() < 1e-12);
        let sub = s.averaging.select(&[5, 9]);
        assert_eq!(
            sub.apply(&x),
            vec![s.averaging.apply(&x)[5], s.averaging.apply(&x)[9]]
        );
    }

    /// Uniform spacing, m = 1: the weights are (1, 4, 1)/6, Simpson's.
    #[test]
    fn uniform_weights_are_one_four_one() {
        let t: Vec<f64> = (0..10).map(|i| i as f64 * 0.012).collect();
        let mut w = Vec::new();
        hat_weights(&t, 4, 1, &mut w);
        let expect = [1.0 / 6.0, 4.0 / 6.0, 1.0 / 6.0];
        for ((i, wi), e) in w.iter().zip(expect) {
            assert!((wi - e).abs() < 1e-12, "{i}");
        }
        let s = kernel_series(&t, &t, 1);
        // trace of KKᵀ: 6 rows of (1 + 16 + 1)/36
        assert!((s.averaging.trace_kkt() - 6.0 * 0.5).abs() < 1e-12);
    }
}
