//! Friction map of a test set of 100 runs: 25 feeds (10-1000 mm/min, log-spaced) × 4 repeats,
//! each run a 40 mm forward and backward stroke sampled every 5 ms on both channels (≈ 4 M
//! samples in all, 0.1 µm position steps), simulated once in memory; timed: estimating every run (rayon), the PPOCM and feed
//! polynomial, and the Stribeck profile at every 1 mm of the travel in both directions.
//!
//! Run: `cargo bench -p feedscope --bench map`
use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use feedscope::estimate::EstimateParams;
use feedscope::map::{build_map, estimate_set_with, stribeck_profile, MapParams, TestRun};
use feedscope::sim::{simulate, DynamicsMode, SimConfig, StrokeConfig};
use feedscope::trace::Trace;
use rayon::prelude::*;

fn test_set() -> (Vec<TestRun>, Vec<Trace>, feedscope::axis::AxisParams) {
    let feeds: Vec<f64> = (0..25)
        .map(|k| 10.0 * 100f64.powf(k as f64 / 24.0))
        .collect();
    let runs: Vec<TestRun> = feeds
        .iter()
        .flat_map(|&f| {
            (1..=4).map(move |r| TestRun {
                name: format!("f{f:.1}_r{r}.csv"),
                file: "".into(),
                feed_mm_min: f,
                repeat: r,
            })
        })
        .collect();
    let outs: Vec<_> = runs
        .par_iter()
        .enumerate()
        .map(|(k, r)| {
            let mut c = SimConfig {
                seed: k as u64 + 1,
                ..SimConfig::default()
            };
            c.dynamics.mode = DynamicsMode::Ideal;
            c.motion.start_mm = 20.0;
            c.motion.strokes = vec![
                StrokeConfig {
                    to_mm: 60.0,
                    feed_mm_min: r.feed_mm_min,
                    dwell_s: 0.5,
                },
                StrokeConfig {
                    to_mm: 20.0,
                    feed_mm_min: r.feed_mm_min,
                    dwell_s: 0.0,
                },
            ];
            // 0.1 µm encoder steps: with the default 1 µm, a 5 ms chord at 10 mm/min (0.83 µm)
            // is below one step and the stroke segmentation finds no steady stroke.
            c.sampling.position.quantum_mm = 1e-4;
            c.sampling.position.interval_ms = 5.0;
            c.sampling.position.jitter_ms = 0.2;
            c.sampling.effort.interval_ms = 5.0;
            c.sampling.effort.jitter_ms = 0.2;
            c.sampling.effort.start_offset_ms = 2.5;
            c.truth.interval_ms = 1000.0;
            simulate(&c, &mut |_| {}).expect("simulation")
        })
        .collect();
    let axis = outs[0].truth.axis.clone();
    let traces = outs.into_iter().map(|o| o.trace).collect();
    (runs, traces, axis)
}

fn bench(c: &mut Criterion) {
    let (runs, traces, axis) = test_set();
    let samples: usize = traces
        .iter()
        .map(|t| t.position_m.len() + t.effort.len())
        .sum();
    eprintln!("test set: {} runs, {samples} samples", runs.len());
    let params = MapParams::default();
    let mut g = c.benchmark_group("map");
    g.sample_size(10);
    g.bench_function("estimate_and_map_18x3x2", |b| {
        b.iter(|| {
            let est = estimate_set_with(
                &runs,
                |r| {
                    let k = runs.iter().position(|x| x.name == r.name).expect("run");
                    Ok(traces[k].clone())
                },
                &axis,
                &EstimateParams::default(),
                params.stroke_feed_tolerance,
                &|_| {},
            );
            assert!(est.failed.is_empty(), "{:?}", est.failed);
            let map = build_map(&est.ok, axis.lead_m(), &params).expect("map");
            for d in &map.directions {
                let grid: Vec<f64> = (0..)
                    .map(|i| d.start_mm + i as f64)
                    .take_while(|&z| z <= d.end_mm)
                    .collect();
                black_box(stribeck_profile(d, &grid, &params).expect("profile"));
            }
            black_box(map)
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
