//! Throughput of reading a trace CSV.
//!
//! The trace is the one of the estimate benchmark (`crates/feedscope/benches/estimate.rs`):
//! back-and-forth 400 mm strokes at 600 mm/min, lead 10 mm, both channels at 1 kHz but 0.4 ms
//! apart (asynchronous), the current from the inverse dynamics of Eq. 5; 10 M samples per
//! channel. The CSV (≈ 640 MB, long layout) is written once to `target/bench-data/trace_10m.csv`
//! with its axis (`axis.toml`) and reused, also by `scripts/bench-e2e.sh`.
//!
//! Run: `cargo bench -p feedscope-io --bench read_csv`. Criterion reports bytes/s of the file.
use std::hint::black_box;
use std::path::PathBuf;

// As in the estimate bench: measure under the binary's allocator.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use feedscope::axis::{AxisParams, ConfigFormat};
use feedscope::trace::{Channel, EffortKind, Trace};
use feedscope_io::trace::{read_trace_file, write_csv, Layout, ReadOptions};

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

fn data_file() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../target/bench-data");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("trace_10m.csv");
    if !path.exists() {
        let tmp = dir.join("trace_10m.csv.tmp");
        let trace = make_trace(10_000_000);
        write_csv(&trace, std::fs::File::create(&tmp).unwrap(), Layout::Long).unwrap();
        std::fs::write(dir.join("axis.toml"), AXIS).unwrap();
        std::fs::rename(&tmp, &path).unwrap();
    }
    path
}

fn bench_read(c: &mut Criterion) {
    let path = data_file();
    let bytes = std::fs::metadata(&path).unwrap().len();
    let mut g = c.benchmark_group("read_csv");
    g.sample_size(10);
    g.throughput(Throughput::Bytes(bytes));
    g.bench_function("long_10m_per_channel", |b| {
        b.iter(|| black_box(read_trace_file(&path, &ReadOptions::default()).unwrap()))
    });
    g.finish();
}

criterion_group!(benches, bench_read);
criterion_main!(benches);
