//! Tests stored per second into PostgreSQL with 1 and 8 writers (each its own connection, as
//! one gateway per machine would), and the delay of one `add` from call to commit.
//!
//! Each test is realistic in size: identified parameters with standard errors, 16 interval
//! means, 6 components, 27 indicators and a 4 kB curves document; every add is new content
//! (no duplicates), on one of 4 axes.
//!
//! Needs a server: `scripts/postgres-tests.sh --bench` starts one (fsync on, the defaults)
//! and sets `FEEDSCOPE_TEST_POSTGRES`; without it the benchmark says so and measures nothing.
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use feedscope::order::{Cause, Segment};
use feedscope_store::{
    ComponentRow, Identified, IndicatorRow, IntervalRow, NewTest, PgStore, Store, TestKind,
};

/// Content numbers: every add of the run is a new trace.
static NEXT: AtomicU64 = AtomicU64::new(0);

fn synthetic() -> NewTest {
    let k = NEXT.fetch_add(1, Ordering::Relaxed);
    let w = k as f64;
    let wobble = ((k * 7919) % 101) as f64 / 101.0 - 0.5;
    let dirs = ["forward", "backward"];
    let intervals: Vec<IntervalRow> = (0..16)
        .map(|b| IntervalRow {
            direction: dirs[b / 8].into(),
            start_mm: 50.0 * (b % 8) as f64,
            end_mm: 50.0 * (b % 8 + 1) as f64,
            mean_n: 300.0 + wobble,
            std_n: 4.0,
            samples: 800,
        })
        .collect();
    let components: Vec<ComponentRow> = (0..6)
        .map(|c| ComponentRow {
            direction: dirs[c / 3].into(),
            segment: Segment::Whole,
            position_mm: 200.0,
            order: 1.0 + c as f64,
            amplitude_n: 5.0 + wobble,
            floor_n: 0.5,
            cause: Cause::Shaft(1 + (c % 3) as u8),
            trusted: true,
        })
        .collect();
    let mut indicators: Vec<IndicatorRow> = (0..27)
        .map(|i| IndicatorRow {
            name: format!("indicator_{i:02}"),
            value: 100.0 + wobble,
            std_error: Some(1.0),
            unit: "N".into(),
        })
        .collect();
    indicators[0].std_error = None;
    NewTest {
        machine: "bench".into(),
        axis: ["X", "Y", "Z", "C"][(k % 4) as usize].into(),
        axis_params: feedscope_store::Stored::from_json("{\"lead_mm\":10.0}"),
        time_utc: feedscope_store::time::format_rfc3339(1.7e9 + w * 60.0),
        time_s: 1.7e9 + w * 60.0,
        kind: TestKind::Triangle,
        source: format!("test-{k}.csv"),
        content_sha256: format!("{k:064x}"),
        program: Some("O1000".into()),
        reference: false,
        compensation_ref: None,
        identified: Some(Identified {
            j_total_kgm2: 0.0085,
            fs_n: 360.0 + wobble,
            fc_n: 280.0,
            ..Identified::default()
        }),
        intervals,
        components,
        indicators,
        // Not a `Curves` document: stored as it is, at the size of a real one.
        curves: Some(feedscope_store::Stored::from_json(&format!(
            "{{\"grid\":[{}]}}",
            "1.25,".repeat(800) + "0"
        ))),
    }
}

/// A fresh database on the server of `admin` for this run.
fn fresh_database(admin: &str) -> String {
    let name = format!("fs_bench_{}", std::process::id());
    let mut c = postgres::Client::connect(admin, postgres::NoTls).expect("connect");
    c.batch_execute(&format!("DROP DATABASE IF EXISTS {name}"))
        .unwrap();
    c.batch_execute(&format!("CREATE DATABASE {name}")).unwrap();
    let rest = admin.find("://").map_or(0, |i| i + 3);
    match admin[rest..].find('/') {
        Some(p) => format!("{}/{name}", &admin[..rest + p]),
        None => format!("{admin}/{name}"),
    }
}

/// `n` adds shared by the writers, each on its own thread and connection; the wall time.
fn add_concurrently(stores: &[Mutex<PgStore>], n: u64) -> Duration {
    let per = n.div_ceil(stores.len() as u64);
    let tests: Vec<Vec<NewTest>> = stores
        .iter()
        .map(|_| (0..per).map(|_| synthetic()).collect())
        .collect();
    let t0 = Instant::now();
    std::thread::scope(|s| {
        for (store, tests) in stores.iter().zip(&tests) {
            s.spawn(move || {
                let mut st = store.lock().unwrap();
                for t in tests {
                    st.add(t).unwrap();
                }
            });
        }
    });
    // the wall time of n adds: per writer's share scaled (n is rarely a multiple)
    t0.elapsed()
        .mul_f64(n as f64 / (per * stores.len() as u64) as f64)
}

fn bench(c: &mut Criterion) {
    let Ok(admin) = std::env::var("FEEDSCOPE_TEST_POSTGRES") else {
        eprintln!(
            "postgres bench: FEEDSCOPE_TEST_POSTGRES is not set; nothing measured \
             (run scripts/postgres-tests.sh --bench)"
        );
        return;
    };
    let url = fresh_database(&admin);
    // The delay of one add, call to commit, over 500 adds (printed for the record).
    {
        let mut s = PgStore::open(&url).unwrap();
        let mut ms: Vec<f64> = (0..500)
            .map(|_| {
                let t = synthetic();
                let t0 = Instant::now();
                s.add(&t).unwrap();
                t0.elapsed().as_secs_f64() * 1e3
            })
            .collect();
        ms.sort_by(f64::total_cmp);
        eprintln!(
            "one add, 1 writer, 500 adds: median {:.2} ms, p90 {:.2} ms, p99 {:.2} ms, max {:.2} ms",
            ms[250], ms[450], ms[495], ms[499]
        );
    }
    let mut g = c.benchmark_group("postgres add");
    g.sample_size(10);
    g.throughput(Throughput::Elements(1));
    for writers in [1usize, 8] {
        let stores: Vec<Mutex<PgStore>> = (0..writers)
            .map(|_| Mutex::new(PgStore::open(&url).unwrap()))
            .collect();
        g.bench_function(format!("{writers} writers"), |b| {
            b.iter_custom(|iters| add_concurrently(&stores, iters))
        });
    }
    g.finish();
    let n = PgStore::open(&url)
        .unwrap()
        .list(&feedscope_store::Filter::default())
        .unwrap()
        .len();
    eprintln!("postgres bench: {n} tests stored in {url}");
}

criterion_group!(benches, bench);
criterion_main!(benches);
