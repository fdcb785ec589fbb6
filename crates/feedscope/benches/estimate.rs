//! Throughput of friction estimation.
//!
//! The trace: back-and-forth 400 mm strokes at 600 mm/min (10 mm/s) with short dwells, lead
//! 10 mm, both channels sampled at 1 kHz but 0.4 ms apart (asynchronous), friction with a
//! mean, a trend and three orders, the current from the inverse dynamics of Eq. 5. That gives
//! about 1000 raw samples and 1024 resampled points per lead, the hardest ratio for the
//! resampling stage.
//!
//! Run: `cargo bench -p feedscope --bench estimate`. Reading the same trace as a 10 M-sample CSV
//! is `cargo bench -p feedscope-io --bench read_csv`; the end-to-end timing of
//! `feedscope estimate` on it is `scripts/bench-e2e.sh`.
use std::hint::black_box;

// The `feedscope` binary runs on mimalloc (it keeps freed pages instead of returning them to
// the OS for every stroke); measure the library under the same allocator.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use feedscope::axis::{AxisParams, ConfigFormat};
use feedscope::estimate::{estimate, estimate_streaming, EstimateParams};
use feedscope::trace::{Channel, EffortKind, Trace};

const AXIS: &str = "lead_mm = 10\ntable_mass_kg = 425\ninertia_kgm2 = 0.004\n\
    damping_nms_per_rad = 0.002\ntorque_constant_nm_per_a = 1.82\n";

fn axis() -> AxisParams {
    AxisParams::parse(AXIS, ConfigFormat::Toml, "bench").unwrap()
}

/// Position (m), velocity, acceleration at t for strokes 0 ↔ 400 mm at 10 mm/s with 0.5 s
/// dwells and 50 ms cosine ramps.
fn motion(t: f64) -> (f64, f64, f64) {
    let (v, len, dwell, ramp) = (0.01, 0.4, 0.5, 0.05);
    let move_t = len / v + ramp; // a cosine ramp at each end adds ramp/2 each
    let period = 2.0 * (move_t + dwell);
    let tp = t.rem_euclid(period);
    let (sign, base, tt) = if tp < move_t + dwell {
        (1.0, 0.0, tp)
    } else {
        (-1.0, len, tp - move_t - dwell)
    };
    if tt >= move_t {
        return (base + sign * len, 0.0, 0.0);
    }
    // Velocity profile: cosine ramp up over `ramp`, plateau, cosine ramp down.
    let w = std::f64::consts::PI / ramp;
    let (z, vel, acc) = if tt < ramp {
        let s = 0.5 * v * (tt - (w * tt).sin() / w);
        (
            s,
            0.5 * v * (1.0 - (w * tt).cos()),
            0.5 * v * w * (w * tt).sin(),
        )
    } else if tt < move_t - ramp {
        (0.5 * v * ramp + v * (tt - ramp), v, 0.0)
    } else {
        let u = tt - (move_t - ramp);
        let s = 0.5 * v * ramp + v * (move_t - 2.0 * ramp) + 0.5 * v * (u + (w * u).sin() / w);
        (
            s,
            0.5 * v * (1.0 + (w * u).cos()),
            -0.5 * v * w * (w * u).sin(),
        )
    };
    (base + sign * z, sign * vel, sign * acc)
}

fn make_trace(n: usize) -> Trace {
    let ax = axis();
    let gain = ax.force_per_torque_n_per_nm() * ax.torque_constant_nm_per_a;
    let (m_eq, b_eq, lead) = (
        ax.equivalent_mass_kg(),
        ax.equivalent_damping_n_s_per_m(),
        ax.lead_m(),
    );
    let mut pos = Channel {
        time_s: Vec::with_capacity(n),
        value: Vec::with_capacity(n),
    };
    let mut cur = Channel {
        time_s: Vec::with_capacity(n),
        value: Vec::with_capacity(n),
    };
    for k in 0..n {
        let t = k as f64 * 1e-3;
        pos.time_s.push(t);
        pos.value.push((motion(t).0 * 1e7).round() * 1e-7);
        let te = t + 4e-4;
        let (z, v, a) = motion(te);
        let th = 2.0 * std::f64::consts::PI * z / lead;
        let f =
            (250.0 + 100.0 * z + 8.0 * th.sin() + 4.0 * (2.0 * th).sin() + 3.0 * (8.6 * th).sin())
                * (v / 1e-4).tanh();
        cur.time_s.push(te);
        cur.value.push((m_eq * a + b_eq * v + f) / gain);
    }
    Trace {
        position_m: pos,
        effort: cur,
        effort_kind: EffortKind::CurrentA,
        facts: Default::default(),
    }
}

fn bench_estimate(c: &mut Criterion) {
    let ax = axis();
    let params = EstimateParams::default();
    let mut g = c.benchmark_group("estimate");
    g.sample_size(10);
    for n in [1_000_000usize, 10_000_000] {
        let trace = make_trace(n);
        // Throughput counts input samples of both channels (position + effort), like the
        // memory target's "per input sample".
        g.throughput(Throughput::Elements(2 * n as u64));
        g.bench_with_input(
            BenchmarkId::new("samples_per_channel", n),
            &trace,
            |b, tr| b.iter(|| black_box(estimate(tr, &ax, &params).unwrap())),
        );
        // As `feedscope estimate` runs it: strokes in batches, each dropped (there: written)
        // once finished, so the output never piles up in memory.
        g.bench_with_input(
            BenchmarkId::new("samples_per_channel_streamed", n),
            &trace,
            |b, tr| {
                b.iter(|| {
                    let batch = 2 * rayon::current_num_threads();
                    let mut points = 0usize;
                    estimate_streaming(
                        tr,
                        &ax,
                        &params,
                        batch,
                        |s| -> Result<(), feedscope::estimate::EstimateError> {
                            points += s.friction_n.len();
                            Ok(())
                        },
                    )
                    .unwrap();
                    black_box(points)
                })
            },
        );
        if n == 1_000_000 {
            // The paper's exact interpolation, without position smoothing.
            let exact = EstimateParams {
                position_smoothing: feedscope::estimate::PositionSmoothing::Off,
                ..EstimateParams::default()
            };
            g.bench_with_input(
                BenchmarkId::new("samples_per_channel_no_smoothing", n),
                &trace,
                |b, tr| b.iter(|| black_box(estimate(tr, &ax, &exact).unwrap())),
            );
        }
    }
    g.finish();
}

criterion_group!(benches, bench_estimate);
criterion_main!(benches);
