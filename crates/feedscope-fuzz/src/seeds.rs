//! Seed inputs: real recordings committed with the CLI tests (SHDR logs and their
//! `Devices.xml`, UMich CSV excerpts), traces of the digital twin (`feedscope::sim`) written in
//! every layout, and configuration files written from the library's own defaults and examples.

use feedscope::axis::AxisParams;
use feedscope::estimate::{estimate, EstimateParams};
use feedscope::sim::{simulate, DynamicsMode, SimConfig};
use feedscope_io::trace::{write_csv, write_parquet, Layout};

/// Real SHDR log excerpts with their device models: `(Devices.xml, log)`.
pub const SHDR: &[(&str, &str)] = &[
    (
        include_str!("../../feedscope-cli/tests/data/import/okuma_Devices.xml"),
        include_str!("../../feedscope-cli/tests/data/import/okuma_head640.txt"),
    ),
    (
        include_str!("../../feedscope-cli/tests/data/import/nist_Devices.xml"),
        include_str!("../../feedscope-cli/tests/data/import/mazak01_20161020_excerpt.txt"),
    ),
];

/// Real UMich CNC mill CSV excerpts (120 rows each).
pub const UMICH: &[&str] = &[
    include_str!("../../feedscope-cli/tests/data/import/umich_experiment_01_head120.csv"),
    include_str!("../../feedscope-cli/tests/data/import/umich_experiment_12_head120.csv"),
];

/// The SINUMERIK servo trace fixture (two axes, the structure of a real trace).
pub const SINUMERIK: &str =
    include_str!("../../feedscope-cli/tests/data/controllers/sinumerik_2axes_structure.xml");

/// Real TwinCAT Scope CSV export excerpts (BSD-3-Clause, see the fixtures' README): comma,
/// shared time column, CRLF, and an `EOF` line.
pub const TWINCAT: &[&str] = &[
    include_str!("../../feedscope-cli/tests/data/controllers/tc3_scope_comma_head60.csv"),
    include_str!("../../feedscope-cli/tests/data/controllers/tc3_scope_default_head60_eof.csv"),
    include_str!("../../feedscope-cli/tests/data/controllers/tc3_scope_noOS_crlf_head60.csv"),
    include_str!("../../feedscope-cli/tests/data/controllers/tc3_scope_shared_time_head60.csv"),
];

/// The example configs of the repository.
pub const DRIVE_EXAMPLE: &str = include_str!("../../../examples/drive.toml");
/// The simulator example (with its axis, friction and motion tables).
pub const SIM_EXAMPLE: &str = include_str!("../../../examples/nc-mill.toml");

/// A short twin recording: two 8 mm strokes at 600 mm/min, and the axis it was simulated with.
pub fn twin() -> (feedscope::trace::Trace, AxisParams) {
    twin_of(8.0)
}

/// The twin with strokes of `mm`.
fn twin_of(mm: f64) -> (feedscope::trace::Trace, AxisParams) {
    let mut cfg = SimConfig::from_toml_str(&format!(
        "[motion]\nlead_in_s = 0.1\nlead_out_s = 0.1\n\
         [[motion.stroke]]\nto_mm = {mm}\nfeed_mm_min = 600\n\
         [[motion.stroke]]\nto_mm = 0\nfeed_mm_min = 600\n"
    ))
    .expect("the twin config is valid");
    cfg.dynamics.mode = DynamicsMode::Ideal;
    let sim = simulate(&cfg, &mut |_| {}).expect("the twin runs");
    (sim.trace, sim.truth.axis)
}

/// The twin trace resampled onto the position's time stamps, so that it can be written wide.
fn twin_sync(t: &feedscope::trace::Trace) -> feedscope::trace::Trace {
    let mut s = t.clone();
    let e = &t.effort;
    s.effort.time_s = t.position_m.time_s.clone();
    s.effort.value = t
        .position_m
        .time_s
        .iter()
        .map(|&x| {
            let k = e.time_s.partition_point(|&u| u < x).min(e.len() - 1);
            e.value[k]
        })
        .collect();
    s
}

/// Trace CSV seeds of one layout: the twin, and for the long layout a real UMich axis.
pub fn trace_csv(layout: Layout) -> Vec<Vec<u8>> {
    let (t, _) = twin();
    let t = if layout == Layout::Wide {
        twin_sync(&t)
    } else {
        t
    };
    let mut out = Vec::new();
    let mut twin_csv = Vec::new();
    write_csv(&t, &mut twin_csv, layout).expect("written to memory");
    out.push(twin_csv);
    let table = feedscope_io::import::umich::parse_umich(UMICH[0], "umich.csv").expect("seed");
    if let Ok(imp) = table.to_trace("X", &Default::default()) {
        let mut b = Vec::new();
        write_csv(&imp.trace, &mut b, layout).expect("written to memory");
        out.push(b);
    }
    out
}

/// Parquet seeds: the twin, wide and long.
pub fn trace_parquet() -> Vec<Vec<u8>> {
    let (t, _) = twin();
    let mut out = Vec::new();
    for (trace, layout) in [(twin_sync(&t), Layout::Wide), (t, Layout::Long)] {
        let mut b = Vec::new();
        write_parquet(&trace, &mut b, layout).expect("written to memory");
        out.push(b);
    }
    out
}

/// Axis files: the twin's axis, and a full one with geometry, travel and thresholds.
pub fn axis_toml() -> Vec<Vec<u8>> {
    let (_, axis) = twin();
    let mut full = axis.clone();
    full.screw_diameter_mm = Some(40.0);
    full.screw_ball_diameter_mm = Some(6.35);
    full.contact_angle_deg = Some(45.0);
    full.screw_balls_per_turn = Some(19.0);
    full.travel_min_mm = Some(0.0);
    full.travel_max_mm = Some(600.0);
    full.rapid_rate_mm_min = Some(24_000.0);
    full.declared_orders = vec![feedscope::axis::DeclaredOrder {
        order: 0.56,
        cause: "mark".into(),
    }];
    full.thresholds.insert(
        "fs_n".into(),
        feedscope::history::Threshold {
            upper: Some(480.0),
            lower: None,
        },
    );
    [axis, full]
        .iter()
        .map(|a| toml::to_string(a).expect("serialisable").into_bytes())
        .collect()
}

/// The axis files as JSON.
pub fn axis_json() -> Vec<Vec<u8>> {
    axis_toml()
        .iter()
        .map(|t| {
            let a = AxisParams::parse(
                std::str::from_utf8(t).expect("utf-8"),
                feedscope::axis::ConfigFormat::Toml,
                "seed",
            )
            .expect("seed axis is valid");
            serde_json::to_vec_pretty(&a).expect("serialisable")
        })
        .collect()
}

/// Drive files: the example and the defaults.
pub fn drive() -> Vec<Vec<u8>> {
    let d = toml::to_string(&feedscope::dynamics::DriveConfig::default()).expect("serialisable");
    vec![DRIVE_EXAMPLE.as_bytes().to_vec(), d.into_bytes()]
}

/// Simulator configs: the example (without its program file) and the twin's.
pub fn sim() -> Vec<Vec<u8>> {
    let strokes = "[motion]\nlead_in_s = 0.1\nlead_out_s = 0.1\n\
         [[motion.stroke]]\nto_mm = 8\nfeed_mm_min = 600\n\
         [[motion.stroke]]\nto_mm = 0\nfeed_mm_min = 600\n[dynamics]\nmode = \"ideal\"\n";
    let example: String = SIM_EXAMPLE
        .lines()
        .filter(|l| !l.trim_start().starts_with("program_file"))
        .collect::<Vec<_>>()
        .join("\n");
    vec![strokes.as_bytes().to_vec(), example.into_bytes()]
}

/// Simulator configs small enough for the `sim_run` target to run: a servo run of 0.4 s with
/// the default friction on a light table (stiff near its reversals), an ideal-mode run.
pub fn sim_run() -> Vec<Vec<u8>> {
    let servo = "seed = 3\n[axis]\nlead_mm = 5.0\ntable_mass_kg = 20.0\ninertia_kgm2 = 0.0001\n\
         damping_nms_per_rad = 0.001\ntorque_constant_nm_per_a = 0.9\n[motion]\nlead_in_s = 0.05\nlead_out_s = 0.05\n\
         acceleration_mm_s2 = 2000.0\n[[motion.stroke]]\nto_mm = 3\nfeed_mm_min = 1200\n\
         [[motion.stroke]]\nto_mm = 0\nfeed_mm_min = 1200\n[dynamics]\nmode = \"servo\"\n\
         [sampling]\nmode = \"synchronous\"\nsynchronous_rate_hz = 2000.0\n\
         [truth]\ninterval_ms = 10.0\n";
    let ideal = "[motion]\nlead_in_s = 0.1\nlead_out_s = 0.1\n\
         [[motion.stroke]]\nto_mm = 8\nfeed_mm_min = 600\n\
         [[motion.stroke]]\nto_mm = 0\nfeed_mm_min = 600\n[dynamics]\nmode = \"ideal\"\n";
    vec![servo.as_bytes().to_vec(), ideal.as_bytes().to_vec()]
}

/// The twin of the `effort_glitch` target: 20 mm strokes at 600 mm/min sampled at 200 Hz,
/// with the seed's effort glitches written in.
fn glitch_twin() -> (feedscope::trace::Trace, AxisParams) {
    let mut cfg = SimConfig::from_toml_str(
        "[motion]\nlead_in_s = 0.2\nlead_out_s = 0.2\n\
         [[motion.stroke]]\nto_mm = 20\nfeed_mm_min = 600\ndwell_s = 0.3\n\
         [[motion.stroke]]\nto_mm = 0\nfeed_mm_min = 600\n\
         [sampling]\nmode = \"synchronous\"\nsynchronous_rate_hz = 200.0\n",
    )
    .expect("the glitch twin config is valid");
    cfg.dynamics.mode = DynamicsMode::Ideal;
    let sim = simulate(&cfg, &mut |_| {}).expect("the glitch twin runs");
    (sim.trace, sim.truth.axis)
}

/// The axis the `effort_glitch` target estimates with (the twin's), simulated once: the
/// target asks for it on every input.
pub fn glitch_axis() -> &'static AxisParams {
    static AXIS: std::sync::OnceLock<AxisParams> = std::sync::OnceLock::new();
    AXIS.get_or_init(|| glitch_twin().1)
}

/// Long-layout CSVs of the glitch twin: clean, and with one and three effort samples scaled by
/// −10³ (a garbled drive reading, within the ±10⁴ A a reader accepts at all).
pub fn effort_glitch() -> Vec<Vec<u8>> {
    let (t, _) = glitch_twin();
    let mut out = Vec::new();
    for at in [&[][..], &[300][..], &[150, 151, 500][..]] {
        let mut g = t.clone();
        for &k in at {
            g.effort.value[k] *= -1e3;
        }
        let mut b = Vec::new();
        write_csv(&g, &mut b, Layout::Long).expect("written to memory");
        out.push(b);
    }
    out
}

/// Test-set indexes of `feedscope map`.
pub fn map_index() -> Vec<Vec<u8>> {
    vec![
        b"file,feed_mm_min,repeat\nrun600a.csv,600,1\nrun600b.csv,600,2\nrun1200.csv,1200,1\n# note\n\nrun3000.csv,3000,1\n".to_vec(),
        b"repeat,notes,feed_mm_min,file\n0,warm,100,a/b.csv\n1,,250.5,c.parquet\n".to_vec(),
    ]
}

/// Steady-speed tables of `feedscope fit-stribeck`.
pub fn stribeck_table() -> Vec<Vec<u8>> {
    vec![
        b"feed_mm_min,torque_nm,direction\n100,1.52,forward\n-100,1.49,backward\n300,1.60,+\n-300,1.58,-\n1000,1.9,forward\n-1000,1.85,backward\n".to_vec(),
        b"# steady speed\nfeed_mm_min,force_n\n600,250\n-600,-245\n1200,262\n-1200,-260\n50,300\n-50,-298\n".to_vec(),
    ]
}

/// A friction CSV and its JSON summary, estimated from the twin.
pub fn friction_csv_and_summary() -> (Vec<u8>, Vec<u8>) {
    // Strokes long enough for the estimate's minimum of spline knots.
    let (t, axis) = twin_of(40.0);
    // 64 points per lead instead of 1024: the parser sees every column and stroke, with a
    // sixteenth of the rows, so a long run gets through its million inputs.
    let params = EstimateParams {
        samples_per_lead: 64,
        ..EstimateParams::default()
    };
    let est = estimate(&t, &axis, &params).expect("the twin estimates");
    let mut csv = Vec::new();
    feedscope_io::friction_csv::write(&mut csv, est.effort_kind, &est.strokes).expect("memory");
    let summaries: Vec<_> = est.strokes.iter().map(|s| &s.summary).collect();
    let json = serde_json::json!({
        "strokes": summaries,
        "params": { "samples_per_lead": params.samples_per_lead },
    });
    (csv, serde_json::to_vec_pretty(&json).expect("serialisable"))
}

/// Threshold files of `history trend` and `report`.
pub fn thresholds() -> Vec<Vec<u8>> {
    vec![
        b"[thresholds]\nfs_n = { upper = 480 }\nfc_n = { lower = 10, upper = 400 }\n\"mean_n/forward/0-100mm\" = { upper = 900 }\n\"amplitude_n/backward/nut ball refeed 1x\" = { upper = 12.5 }\n".to_vec(),
    ]
}

/// An empty condition-history store (schema migrated), as its SQLite file.
pub fn store() -> Vec<Vec<u8>> {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let p = dir.path().join("seed.db");
    drop(feedscope_store::SqliteStore::open(&p).expect("a new store"));
    vec![std::fs::read(&p).expect("the store file")]
}
