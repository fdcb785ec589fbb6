//! Feed-drive dynamics: the 200 feed rates × 50 positions sweep (target: under 1 s), and one
//! (position, feed) solve by the plan's rank-one path against the naive path (assemble the full
//! K, factor M, project, solve).
use criterion::{criterion_group, criterion_main, Criterion};
use feedscope::dynamics::{DriveConfig, DriveModel};
use nalgebra::DMatrix;
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let model = DriveModel::from_config(&DriveConfig::default()).unwrap();
    let feeds: Vec<f64> = (0..200).map(|i| i as f64 * 80.0 / 199.0 / 60.0).collect();
    let positions: Vec<f64> = (0..50).map(|i| 0.1 + i as f64 * 1.2 / 49.0).collect();

    let mut g = c.benchmark_group("dynamics");
    g.sample_size(10);
    g.bench_function("sweep_grid_200_feeds_x_50_positions_3_modes", |b| {
        b.iter(|| {
            model
                .sweep_grid(black_box(&positions), black_box(&feeds), 3)
                .unwrap()
        })
    });

    let plan = model.at_position(0.7).unwrap();
    let mut scratch = DMatrix::zeros(0, 0);
    let mut out = [0.0; 3];
    g.bench_function("one_point_plan", |b| {
        b.iter(|| {
            plan.frequencies_into(black_box(0.2), &mut scratch, &mut out);
            out[0]
        })
    });
    g.bench_function("one_point_naive_reference", |b| {
        b.iter(|| {
            let (k, m) = model.system_matrices(0.7, black_box(0.2)).unwrap();
            let l = m.cholesky().unwrap().l();
            let x = l.solve_lower_triangular(&k).unwrap();
            let a = l.solve_lower_triangular(&x.transpose()).unwrap();
            a.symmetric_eigenvalues().min()
        })
    });
    g.bench_function("plan_one_position", |b| {
        b.iter(|| model.at_position(black_box(0.7)).unwrap().dofs())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
