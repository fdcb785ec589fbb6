//! Shared helpers: a short simulated test and error figures against the truth.
#![allow(dead_code)]

use feedscope::estimate::{estimate, Estimate, EstimateParams, StrokeFriction};
use feedscope::sim::{simulate, SimConfig, SimOutput, StrokeConfig};

/// A quick test program: start at 20 mm, forward to `to_mm`, dwell, back to 20 mm.
pub fn config(to_mm: f64, feed_mm_min: f64) -> SimConfig {
    let mut c = SimConfig::default();
    c.motion.start_mm = 20.0;
    c.motion.strokes = vec![
        StrokeConfig {
            to_mm,
            feed_mm_min,
            dwell_s: 1.0,
        },
        StrokeConfig {
            to_mm: 20.0,
            feed_mm_min,
            dwell_s: 0.0,
        },
    ];
    c
}

/// Remove every source of measurement noise (noise, quantisation, timestamp errors).
pub fn noise_free(c: &mut SimConfig) {
    let p = &mut c.sampling.position;
    p.quantum_mm = 0.0;
    p.noise_std_mm = 0.0;
    p.timestamp_jitter_ms = 0.0;
    p.timestamp_delay_ms = 0.0;
    let e = &mut c.sampling.effort;
    e.current_quantum_a = 0.0;
    e.current_noise_std_a = 0.0;
    e.torque_quantum_nm = 0.0;
    e.torque_noise_std_nm = 0.0;
    e.timestamp_jitter_ms = 0.0;
    e.timestamp_delay_ms = 0.0;
}

pub fn run(c: &SimConfig) -> SimOutput {
    simulate(c, &mut |_| {}).expect("simulation")
}

pub fn est(out: &SimOutput) -> Estimate {
    estimate(&out.trace, &out.truth.axis, &EstimateParams::default()).expect("estimate")
}

/// Indices of the points at least `margin_mm` from both ends of the stroke.
pub fn inner(s: &StrokeFriction, margin_mm: f64) -> Vec<usize> {
    let n = s.position_m.len();
    let (a, b) = (s.position_m[0], s.position_m[n - 1]);
    let (lo, hi) = (a.min(b) + margin_mm * 1e-3, a.max(b) - margin_mm * 1e-3);
    (0..n)
        .filter(|&j| s.position_m[j] >= lo && s.position_m[j] <= hi)
        .collect()
}

/// Errors of one stroke against the truth, over points ≥ 2 mm from the ends.
#[derive(Debug)]
pub struct Errors {
    /// RMS of estimate − truth (N).
    pub rms_n: f64,
    /// RMS of the true fluctuation (components only) over the same points (N).
    pub fluctuation_rms_n: f64,
    /// Mean of the estimate minus mean of the truth, relative to the truth's mean.
    pub mean_rel: f64,
    /// Mean of the truth over the same points (N, signed).
    pub mean_truth_n: f64,
}

impl Errors {
    /// |mean of the truth| (N).
    pub fn mean_abs_n(&self) -> f64 {
        self.mean_truth_n.abs()
    }
}

pub fn errors(out: &SimOutput, s: &StrokeFriction) -> Errors {
    let model = &out.truth.friction;
    let idx = inner(s, 2.0);
    assert!(idx.len() > 100, "too few points away from the ends");
    let (mut se, mut sf, mut me, mut mt) = (0.0, 0.0, 0.0, 0.0);
    for &j in &idx {
        let (z, v) = (s.position_m[j], s.velocity_m_s[j]);
        let truth = model.friction_n(z, v);
        se += (s.friction_n[j] - truth).powi(2);
        sf += model.fluctuation_n(s.summary.direction, z).powi(2);
        me += s.friction_n[j];
        mt += truth;
    }
    let n = idx.len() as f64;
    Errors {
        rms_n: (se / n).sqrt(),
        fluctuation_rms_n: (sf / n).sqrt(),
        mean_rel: (me - mt) / mt.abs(),
        mean_truth_n: mt / n,
    }
}

/// RMS difference between two estimates of the same stroke on the same absolute grid, over
/// points ≥ 2 mm from the ends.
pub fn rms_between(a: &StrokeFriction, b: &StrokeFriction) -> f64 {
    let step = (a.position_m[1] - a.position_m[0]).abs();
    let key = |z: f64| (z / step).round() as i64;
    let (ka, kb) = (key(a.position_m[0]), key(b.position_m[0]));
    let sign = if a.position_m[1] > a.position_m[0] {
        1
    } else {
        -1
    };
    let (mut se, mut n) = (0.0, 0.0);
    for j in inner(a, 2.0) {
        let k = (ka - kb) * sign + j as i64;
        if k >= 0 && (k as usize) < b.position_m.len() {
            let k = k as usize;
            assert_eq!(key(a.position_m[j]), key(b.position_m[k]));
            se += (a.friction_n[j] - b.friction_n[k]).powi(2);
            n += 1.0;
        }
    }
    (se / n).sqrt()
}
