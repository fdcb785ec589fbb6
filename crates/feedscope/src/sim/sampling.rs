//! Sampling of the simulated drive as a controller does it: instants with jitter, offsets and
//! dropouts, reported stamps with delay and error, values with noise and quantisation.

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};

use super::config::Timing;

/// Sample instants of one channel.
#[derive(Debug, Clone, Default)]
pub(crate) struct SampleTimes {
    /// True sampling instants (s), strictly increasing.
    pub true_s: Vec<f64>,
    /// Stamps reported with the samples (s), strictly increasing.
    pub stamp_s: Vec<f64>,
}

/// Independent random stream `k` of a simulation seed (so that changing one channel's
/// settings does not change the draws of another).
pub(crate) fn stream(seed: u64, k: u64) -> StdRng {
    StdRng::seed_from_u64(seed ^ 0x9E37_79B9_7F4A_7C15u64.wrapping_mul(k + 1))
}

/// Asynchronous instants on [0, duration]: t₀ = offset, t_{n+1} = t_n + interval + U(−j, j);
/// each dropped with probability `dropout`; stamp = t + delay + U(−e, e).
pub(crate) fn asynchronous(timing: &Timing, duration_s: f64, rng: &mut StdRng) -> SampleTimes {
    let mut out = SampleTimes::default();
    let mut t = timing.offset_s;
    while t <= duration_s {
        // Draw every random number for every instant, dropped or not, so the stream stays
        // aligned whatever the dropout probability.
        let drop = rng.random::<f64>() < timing.dropout;
        let stamp_err = symmetric(rng, timing.stamp_jitter_s);
        if !drop {
            out.true_s.push(t);
            out.stamp_s.push(t + timing.delay_s + stamp_err);
        }
        t += timing.interval_s + symmetric(rng, timing.jitter_s);
    }
    out
}

/// Synchronous instants offset 0, 1/rate, 2/rate, ... on [0, duration] with row dropouts.
pub(crate) fn synchronous(
    rate_hz: f64,
    dropout: f64,
    duration_s: f64,
    rng: &mut StdRng,
) -> SampleTimes {
    let n = (duration_s * rate_hz).floor() as usize + 1;
    let mut out = SampleTimes::default();
    for k in 0..n {
        let drop = rng.random::<f64>() < dropout;
        if !drop {
            let t = k as f64 / rate_hz;
            out.true_s.push(t);
            out.stamp_s.push(t);
        }
    }
    out
}

/// U(−h, h), or 0 without a draw when h = 0.
fn symmetric(rng: &mut StdRng, half_width: f64) -> f64 {
    if half_width > 0.0 {
        rng.random_range(-half_width..half_width)
    } else {
        0.0
    }
}

/// round((x + N(0, σ²))/q)·q, in place; q = 0 leaves the noisy value, σ = 0 draws nothing.
pub(crate) fn measure(values: &mut [f64], noise_std: f64, quantum: f64, rng: &mut StdRng) {
    // σ is validated finite and ≥ 0, for which Normal::new cannot fail.
    let normal = Normal::new(0.0, noise_std).ok().filter(|_| noise_std > 0.0);
    for x in values.iter_mut() {
        if let Some(n) = &normal {
            *x += n.sample(rng);
        }
        if quantum > 0.0 {
            // `+ 0.0` turns −0 into 0 so files never show "-0"
            *x = (*x / quantum).round() * quantum + 0.0;
        }
    }
}
