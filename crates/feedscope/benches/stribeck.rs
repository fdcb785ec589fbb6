//! Stribeck fit: one 18-feed fit, and a friction map of 200 positions × 2 directions × 18 feeds
//! (400 fits, each planned once per direction's feeds), serial and with rayon.
use criterion::{criterion_group, criterion_main, Criterion};
use feedscope::stribeck::{
    fit_stribeck, DeltaMode, StribeckFitParams, StribeckFitter, StribeckParams,
};
use feedscope::units::feed_mm_min_to_m_s;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use rayon::prelude::*;
use std::hint::black_box;

fn feeds() -> Vec<f64> {
    (0..18)
        .map(|k| feed_mm_min_to_m_s(5.0 * 120f64.powf(k as f64 / 17.0)))
        .collect()
}

/// Friction at every position of the map: a Stribeck curve whose Coulomb level drifts with
/// position, with 1 % noise.
fn map(direction: u64) -> Vec<Vec<f64>> {
    let v = feeds();
    let mut rng = rand::rngs::StdRng::seed_from_u64(direction);
    let noise = Normal::new(0.0, 2.0).unwrap();
    (0..200)
        .map(|i| {
            let p = StribeckParams {
                fc_n: 180.0 + 30.0 * (i as f64 / 30.0).sin() + 20.0 * direction as f64,
                fs_n: 250.0,
                vs_m_s: feed_mm_min_to_m_s(35.0),
                sigma_n_s_per_m: 9000.0,
                delta: 2.0,
            };
            v.iter()
                .map(|&s| p.magnitude_n(s) + noise.sample(&mut rng))
                .collect()
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let v = feeds();
    let maps = [map(0), map(1)];
    let mut g = c.benchmark_group("stribeck");
    g.sample_size(10);
    g.measurement_time(std::time::Duration::from_secs(3));
    g.bench_function("one_fit_18_feeds", |b| {
        b.iter(|| fit_stribeck(black_box(&v), black_box(&maps[0][0]), &Default::default()))
    });
    g.bench_function("one_fit_18_feeds_delta_free", |b| {
        let p = StribeckFitParams {
            delta: DeltaMode::Free,
            ..Default::default()
        };
        b.iter(|| fit_stribeck(black_box(&v), black_box(&maps[0][0]), &p))
    });
    let fitter = StribeckFitter::new(&v, &StribeckFitParams::default()).unwrap();
    g.bench_function("map_200_positions_x_2_directions_serial", |b| {
        b.iter(|| {
            maps.iter()
                .flat_map(|m| m.iter())
                .map(|f| fitter.fit(black_box(f)).unwrap().params.fc_n)
                .sum::<f64>()
        })
    });
    g.bench_function("map_200_positions_x_2_directions_rayon", |b| {
        b.iter(|| {
            maps.par_iter()
                .flat_map(|m| m.par_iter())
                .map(|f| fitter.fit(black_box(f)).unwrap().params.fc_n)
                .sum::<f64>()
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
