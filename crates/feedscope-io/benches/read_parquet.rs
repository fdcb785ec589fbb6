//! Throughput of reading a Parquet trace.
//!
//! The trace is the one of `crates/feedscope/benches/estimate.rs` in shape: 10 M samples per
//! channel at 1 kHz, the current 0.4 ms after the position (asynchronous), so the long layout
//! (20 M rows: `time_s`, dictionary-encoded `channel`, `value`). A wide file of the same size (both channels
//! on one clock, 10 M rows) is read too. Both are written once to `target/bench-data/` and
//! reused.
//!
//! A third file holds 600,000 wide rows in 6,000 row groups of 100 (a logger that flushes
//! every 0.1 s): its read time must grow with the rows, not with the square of the groups.
//!
//! Run: `cargo bench -p feedscope-io --bench read_parquet`. Criterion reports bytes/s of the file;
//! samples/s (both channels) is printed for each file beside it.
use std::hint::black_box;
use std::path::PathBuf;

// As in the estimate bench: measure under the binary's allocator.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use feedscope::trace::{Channel, EffortKind, Trace};
use feedscope_io::trace::{read_trace_file, write_parquet, Layout, ReadOptions};

const N: usize = 10_000_000;

/// Strokes 0 ↔ 400 mm at 10 mm/s with a 1 µm quantised position and a current ripple; the
/// numbers only need to look like a trace (the reader does not care what they mean).
fn make_trace(n: usize, sync: bool) -> Trace {
    let mut pos = Channel {
        time_s: Vec::with_capacity(n),
        value: Vec::with_capacity(n),
    };
    let mut cur = Channel {
        time_s: Vec::with_capacity(n),
        value: Vec::with_capacity(n),
    };
    let period = 81.0;
    for k in 0..n {
        let t = k as f64 * 1e-3;
        let u = (t % period) / period;
        let z = 0.4 * (1.0 - (2.0 * u - 1.0).abs());
        pos.time_s.push(t);
        pos.value.push((z * 1e6).round() * 1e-6);
        let te = if sync { t } else { t + 4e-4 };
        let dir = if u < 0.5 { 1.0 } else { -1.0 };
        cur.time_s.push(te);
        cur.value
            .push(dir * (1.2 + 0.05 * (2.0 * std::f64::consts::PI * z / 0.01).sin()));
    }
    Trace {
        position_m: pos,
        effort: cur,
        effort_kind: EffortKind::CurrentA,
        facts: Default::default(),
    }
}

fn data_file(name: &str, layout: Layout) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../target/bench-data");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    if !path.exists() {
        let tmp = dir.join(format!("{name}.tmp"));
        let trace = make_trace(N, layout == Layout::Wide);
        write_parquet(&trace, std::fs::File::create(&tmp).unwrap(), layout).unwrap();
        std::fs::rename(&tmp, &path).unwrap();
    }
    path
}

fn bench_read(c: &mut Criterion) {
    let mut g = c.benchmark_group("read_parquet");
    g.sample_size(10);
    for (name, layout, label) in [
        ("trace_10m.parquet", Layout::Long, "long_10m_per_channel"),
        (
            "trace_10m_wide.parquet",
            Layout::Wide,
            "wide_10m_per_channel",
        ),
    ] {
        let path = data_file(name, layout);
        let bytes = std::fs::metadata(&path).unwrap().len();
        // One timed read outside criterion for samples/s (criterion shows one throughput).
        let t0 = std::time::Instant::now();
        let (trace, _) = read_trace_file(&path, &ReadOptions::default()).unwrap();
        let s = t0.elapsed().as_secs_f64();
        let samples = (trace.position_m.len() + trace.effort.len()) as f64;
        eprintln!(
            "{name}: {:.0} MB, one read {:.3} s = {:.0} MB/s, {:.1} M samples/s",
            bytes as f64 / 1e6,
            s,
            bytes as f64 / 1e6 / s,
            samples / 1e6 / s
        );
        drop(trace);
        g.throughput(Throughput::Bytes(bytes));
        g.bench_function(label, |b| {
            b.iter(|| black_box(read_trace_file(&path, &ReadOptions::default()).unwrap()))
        });
    }
    g.finish();
}

/// 6,000 row groups of 100 wide rows (`time_s`, `position_mm`, `current_a`).
fn many_groups_file() -> PathBuf {
    use arrow_array::{ArrayRef, Float64Array, RecordBatch};
    use parquet::arrow::ArrowWriter;
    use parquet::file::properties::WriterProperties;
    use std::sync::Arc;
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../target/bench-data");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("trace_6000_groups.parquet");
    if path.exists() {
        return path;
    }
    let tmp = dir.join("trace_6000_groups.parquet.tmp");
    let props = WriterProperties::builder()
        .set_max_row_group_row_count(Some(100))
        .build();
    let (groups, rows) = (6000usize, 100usize);
    let mut w: Option<ArrowWriter<std::fs::File>> = None;
    for g in 0..groups {
        let t: Vec<f64> = (0..rows).map(|k| (g * rows + k) as f64 * 1e-3).collect();
        let z: Vec<f64> = t
            .iter()
            .map(|t| 200.0 - ((t * 10.0) % 400.0 - 200.0).abs())
            .collect();
        let i: Vec<f64> = t.iter().map(|t| 1.2 + 0.05 * (t * 7.0).sin()).collect();
        let cols: Vec<(&str, ArrayRef)> = vec![
            ("time_s", Arc::new(Float64Array::from(t))),
            ("position_mm", Arc::new(Float64Array::from(z))),
            ("current_a", Arc::new(Float64Array::from(i))),
        ];
        let batch = RecordBatch::try_from_iter(cols).unwrap();
        let writer = w.get_or_insert_with(|| {
            ArrowWriter::try_new(
                std::fs::File::create(&tmp).unwrap(),
                batch.schema(),
                Some(props.clone()),
            )
            .unwrap()
        });
        writer.write(&batch).unwrap();
        writer.flush().unwrap();
    }
    w.unwrap().close().unwrap();
    std::fs::rename(&tmp, &path).unwrap();
    path
}

fn bench_many_groups(c: &mut Criterion) {
    let path = many_groups_file();
    let mut g = c.benchmark_group("read_parquet");
    g.sample_size(10);
    g.bench_function("wide_600k_rows_in_6000_groups", |b| {
        b.iter(|| black_box(read_trace_file(&path, &ReadOptions::default()).unwrap()))
    });
    g.finish();
}

criterion_group!(benches, bench_read, bench_many_groups);
criterion_main!(benches);
