//! The store + trend path: add 1,000 tests to a fresh database (one transaction each, WAL) and
//! compute the trends of every indicator. Target: under 5 s in all.
//!
//! The tests are synthetic (no simulation or identification: that cost is the analysis, not
//! the store): 5 identified parameters with standard errors, 16 interval means and 6 component
//! amplitudes per test, i.e. 27 indicators, like a triangle + stroke test pair.
//!
//! Run: `cargo bench -p feedscope-store --bench history`
use std::collections::BTreeMap;
use std::time::Instant;

use criterion::{criterion_group, criterion_main, Criterion};
use feedscope::estimate::Direction;
use feedscope::history::{assess, diagnose, BaselineSpec, Indicator, Threshold, TrendParams};
use feedscope::order::Cause;
use feedscope_store::{Identified, IndicatorRow, NewTest, SqliteStore, Store, TestKind};

fn synthetic(k: usize) -> NewTest {
    let w = k as f64;
    let drift = 1.0 + 0.0005 * w;
    let wobble = ((k * 7919) % 101) as f64 / 101.0 - 0.5;
    let p = Identified {
        j_total_kgm2: 0.0085,
        j_std_kgm2: 1e-5,
        fc_n: 280.0 + wobble,
        fc_std_n: 1.0,
        fs_n: 360.0 * drift + wobble,
        fs_std_n: 2.0,
        sigma_n_s_per_m: 2700.0 * drift,
        sigma_std_n_s_per_m: 40.0,
        vs_mm_min: 60.0,
        vs_std_mm_min: 1.5,
        delta: 2.0,
        offset_n: 15.0,
        residual_rms_nm: 0.01,
        samples_used: 40_000,
    };
    let row = |i: Indicator, v: f64| IndicatorRow {
        name: i.name(),
        value: v,
        std_error: Some(1.0),
        unit: i.unit().into(),
    };
    let mut ind = vec![
        row(Indicator::StaticFriction, p.fs_n),
        row(Indicator::CoulombFriction, p.fc_n),
        row(Indicator::Viscous, p.sigma_n_s_per_m),
        row(Indicator::StribeckVelocity, p.vs_mm_min),
        row(Indicator::Inertia, p.j_total_kgm2),
    ];
    for d in [Direction::Forward, Direction::Backward] {
        for b in 0..8 {
            let i = Indicator::MeanFriction {
                direction: d,
                start_mm: 50.0 * b as f64,
                end_mm: 50.0 * (b + 1) as f64,
            };
            ind.push(row(i, 300.0 + 3.0 * b as f64 + wobble));
        }
        for c in [Cause::Shaft(1), Cause::Shaft(2), Cause::NutRefeed(1)] {
            let i = Indicator::Component {
                direction: d,
                cause: c,
            };
            ind.push(row(i, 5.0 + wobble));
        }
    }
    NewTest {
        machine: "bench".into(),
        axis: "Z".into(),
        axis_params: feedscope_store::Stored::from_json("{}"),
        time_utc: feedscope_store::time::format_rfc3339(1.7e9 + w * 86_400.0),
        time_s: 1.7e9 + w * 86_400.0,
        kind: TestKind::Triangle,
        source: format!("week-{k}.csv"),
        content_sha256: format!("{k:064x}"),
        program: None,
        reference: false,
        compensation_ref: None,
        identified: Some(p),
        intervals: vec![],
        components: vec![],
        indicators: ind,
        curves: None,
    }
}

/// Add `n` tests to a fresh database and trend everything; returns the number of trends.
fn add_and_trend(n: usize, tests: &[NewTest]) -> usize {
    let dir = tempfile::tempdir().unwrap();
    let mut s = SqliteStore::open(&dir.path().join("bench.db")).unwrap();
    for t in &tests[..n] {
        s.add(t).unwrap();
    }
    let series = s.series("bench", "Z").unwrap();
    let params = TrendParams {
        baseline: BaselineSpec::FirstN { count: 10 },
        ..TrendParams::default()
    };
    let th = BTreeMap::<String, Threshold>::new();
    let trends: Vec<_> = series
        .iter()
        .map(|(name, pts)| {
            let pts: Vec<_> = pts.iter().map(|(_, p)| *p).collect();
            let i = Indicator::parse(name).unwrap();
            assess(
                &i,
                &pts,
                &params,
                th.get(name).unwrap_or(&Threshold::default()),
            )
            .unwrap()
        })
        .collect();
    let d = diagnose(&trends);
    assert!(!d.is_empty());
    trends.len()
}

fn bench(c: &mut Criterion) {
    let tests: Vec<NewTest> = (0..1000).map(synthetic).collect();
    // One timed run printed for the record (criterion's statistics follow).
    let t0 = Instant::now();
    let n = add_and_trend(1000, &tests);
    eprintln!(
        "1000 tests added and {n} indicators trended in {:.2} s",
        t0.elapsed().as_secs_f64()
    );
    let mut g = c.benchmark_group("history");
    g.sample_size(10);
    g.bench_function("add 1000 tests + trends", |b| {
        b.iter(|| add_and_trend(1000, &tests))
    });
    g.bench_function("add 100 tests + trends", |b| {
        b.iter(|| add_and_trend(100, &tests))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
