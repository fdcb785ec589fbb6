//! Throughput of stroke segmentation (`find_moves`): turning points, chord speeds, the plateau
//! speed and the strokes of every move.
//!
//! Two traces of 1 M position samples at 1 kHz, quantised to 0.1 µm: back-and-forth 400 mm
//! strokes at 600 mm/min with 0.5 s dwells and 50 ms cosine ramps (the `estimate` bench's
//! motion, so its segmentation share is this), and the same strokes with the feed modulated
//! by ±50 % at a 1.5 s period (more chords near the steady threshold, where the cut rule
//! decides).
//!
//! Run: `cargo bench -p feedscope --bench segment`.
use std::hint::black_box;

#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use feedscope::estimate::segment::{find_moves, SegmentParams};
use feedscope::trace::Channel;

/// Position (m) at `t` for strokes 0 ↔ 400 mm at 10 mm/s with 0.5 s dwells and 50 ms cosine
/// ramps; with `modulated`, the travel runs through a phase whose speed is 1 ± 0.5·sin at a
/// 1.5 s period (the path is the same, only its timing changes).
fn position(t: f64, modulated: bool) -> f64 {
    let (v, len, dwell, ramp) = (0.01, 0.4, 0.5, 0.05);
    let move_t = len / v + ramp;
    let period = 2.0 * (move_t + dwell);
    let tp = t.rem_euclid(period);
    let (sign, base, tt) = if tp < move_t + dwell {
        (1.0, 0.0, tp)
    } else {
        (-1.0, len, tp - move_t - dwell)
    };
    if tt >= move_t {
        return base + sign * len;
    }
    let w = std::f64::consts::PI / ramp;
    // Time along the path: a modulated clock whose rate is 1 + 0.5·sin(2π·tt/1.5) (its
    // integral), held inside the ramps so they stay as they are.
    let clock = |u: f64| {
        if !modulated || u < ramp {
            return u;
        }
        let f = 2.0 * std::f64::consts::PI / 1.5;
        u + 0.5 * (1.0 - (f * (u - ramp)).cos()) / f
    };
    let tt = clock(tt).min(move_t);
    let z = if tt < ramp {
        0.5 * v * (tt - (w * tt).sin() / w)
    } else if tt < move_t - ramp {
        0.5 * v * ramp + v * (tt - ramp)
    } else {
        let u = tt - (move_t - ramp);
        0.5 * v * ramp + v * (move_t - 2.0 * ramp) + 0.5 * v * (u + (w * u).sin() / w)
    };
    base + sign * z
}

fn channel(n: usize, modulated: bool) -> Channel {
    let time_s: Vec<f64> = (0..n).map(|k| k as f64 * 1e-3).collect();
    let value = time_s
        .iter()
        .map(|&t| (position(t, modulated) * 1e7).round() * 1e-7)
        .collect();
    Channel { time_s, value }
}

fn bench_segment(c: &mut Criterion) {
    let params = SegmentParams::default();
    let mut g = c.benchmark_group("find_moves");
    g.sample_size(30);
    let n = 1_000_000;
    g.throughput(Throughput::Elements(n as u64));
    for (name, modulated) in [("steady", false), ("modulated", true)] {
        let ch = channel(n, modulated);
        g.bench_with_input(BenchmarkId::new(name, n), &ch, |b, ch| {
            b.iter(|| black_box(find_moves(ch, &params)))
        });
    }
    g.finish();
}

criterion_group!(benches, bench_segment);
criterion_main!(benches);
