//! The fuzz targets: one per parser and per configuration format. Each takes an input's bytes
//! and answers whether the library accepted it, refused it as bad input, or did something a
//! user must never see (a [`Finding`]): a refusal of another kind (an exit code other than 2
//! for bad input), or an accepted value that fails the sanity checks a user relies on.

use std::path::{Path, PathBuf};

use feedscope::trace::{EffortKind, Trace};
use feedscope::ErrorKind;
use feedscope_io::trace::{parse_trace, Layout, ReadOptions};

use crate::mutate::{self, ParquetSeed};
use crate::rng::Rng;
use crate::seeds;

/// What a target did with an input.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Verdict {
    /// Ok, and the result passed the sanity checks.
    Accepted,
    /// A typed error of kind bad input (exit 2).
    Rejected,
}

/// Something a user must never see; the text says what.
pub type Finding = String;

/// How inputs of a target are mutated.
pub enum Mutator {
    /// Structure-aware text mutations.
    Text,
    /// Byte-level mutations of a binary file.
    Binary,
    /// Column-level mutations of a Parquet file (plus byte-level).
    Parquet(Vec<ParquetSeed>),
}

/// Per-run context: a scratch directory for the targets that must go through a file (the
/// SQLite store, the JSON summary read beside a friction CSV, and non-UTF-8 inputs, whose
/// refusal happens in the file readers).
pub struct Ctx {
    /// Scratch directory (a temporary directory of the run; [`scratch_dir`] puts it in memory).
    pub dir: PathBuf,
}

/// A temporary directory for [`Ctx`]: under `/dev/shm` (a RAM file system: a write and read
/// per input there costs microseconds, not the milliseconds of a disk's file system) when it
/// exists, else in the system's temporary directory.
///
/// # Errors
/// When neither can hold a new directory.
pub fn scratch_dir() -> std::io::Result<tempfile::TempDir> {
    let shm = Path::new("/dev/shm");
    if shm.is_dir() {
        if let Ok(d) = tempfile::Builder::new()
            .prefix("feedscope-fuzz-")
            .tempdir_in(shm)
        {
            return Ok(d);
        }
    }
    tempfile::Builder::new().prefix("feedscope-fuzz-").tempdir()
}

impl Ctx {
    /// Write `bytes` as `name` in the scratch directory.
    fn file(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let p = self.dir.join(name);
        std::fs::write(&p, bytes).expect("the scratch directory is writable");
        p
    }
}

/// One fuzz target.
pub struct Target {
    /// Name on the command line and of the regression folder.
    pub name: &'static str,
    /// What it reads.
    pub about: &'static str,
    seeds: fn() -> Vec<Vec<u8>>,
    mutator: fn() -> Mutator,
    run: fn(&[u8], &Ctx) -> Result<Verdict, Finding>,
}

impl Target {
    /// The seed inputs.
    pub fn seeds(&self) -> Vec<Vec<u8>> {
        (self.seeds)()
    }
    /// The mutator (Parquet targets decode their seeds here, once).
    pub fn mutator(&self) -> Mutator {
        (self.mutator)()
    }
    /// Run one input.
    ///
    /// # Errors
    /// A [`Finding`].
    pub fn run(&self, input: &[u8], ctx: &Ctx) -> Result<Verdict, Finding> {
        (self.run)(input, ctx)
    }
}

/// A new input from a seed.
pub fn mutate(m: &Mutator, rng: &mut Rng, seed: &[u8]) -> Vec<u8> {
    match m {
        Mutator::Text => mutate::mutate_text(rng, seed),
        Mutator::Binary => mutate::mutate_binary(rng, seed),
        Mutator::Parquet(seeds) => {
            if rng.one_in(4) || seeds.is_empty() {
                mutate::mutate_binary(rng, seed)
            } else {
                let k = rng.below(seeds.len());
                mutate::mutate_parquet(rng, &seeds[k])
            }
        }
    }
}

fn text() -> Mutator {
    Mutator::Text
}

fn binary() -> Mutator {
    Mutator::Binary
}

fn parquet_mutator() -> Mutator {
    Mutator::Parquet(
        seeds::trace_parquet()
            .iter()
            .map(|b| mutate::parquet_seed(b))
            .collect(),
    )
}

/// Every target, in the order `--target all` runs them.
pub fn all() -> Vec<Target> {
    vec![
        Target {
            name: "trace_csv_long",
            about: "trace CSV, long layout (parse_trace)",
            seeds: || seeds::trace_csv(Layout::Long),
            mutator: text,
            run: run_trace,
        },
        Target {
            name: "trace_csv_wide",
            about: "trace CSV, wide layout (parse_trace)",
            seeds: || seeds::trace_csv(Layout::Wide),
            mutator: text,
            run: run_trace,
        },
        Target {
            name: "trace_parquet",
            about: "trace Parquet, wide and long (parse_trace)",
            seeds: seeds::trace_parquet,
            mutator: parquet_mutator,
            run: run_trace,
        },
        Target {
            name: "shdr",
            about: "MTConnect SHDR log with its Devices.xml (parse, to_trace per axis)",
            seeds: shdr_seeds,
            mutator: text,
            run: run_shdr,
        },
        Target {
            name: "umich",
            about: "UMich CNC mill CSV (parse, to_trace per axis)",
            seeds: || seeds::UMICH.iter().map(|s| s.as_bytes().to_vec()).collect(),
            mutator: text,
            run: run_umich,
        },
        Target {
            name: "sinumerik",
            about: "SINUMERIK Operate servo trace XML (list, then read per axis)",
            seeds: || vec![seeds::SINUMERIK.as_bytes().to_vec()],
            mutator: text,
            run: run_sinumerik,
        },
        Target {
            name: "twincat",
            about: "TwinCAT Scope CSV export (list, then read two named channels)",
            seeds: || {
                seeds::TWINCAT
                    .iter()
                    .map(|s| s.as_bytes().to_vec())
                    .collect()
            },
            mutator: text,
            run: run_twincat,
        },
        Target {
            name: "axis_toml",
            about: "axis file, TOML (feedscope_io::axis::load)",
            seeds: seeds::axis_toml,
            mutator: text,
            run: |b, c| run_axis(b, c, "axis.toml"),
        },
        Target {
            name: "axis_json",
            about: "axis file, JSON (feedscope_io::axis::load)",
            seeds: seeds::axis_json,
            mutator: text,
            run: |b, c| run_axis(b, c, "axis.json"),
        },
        Target {
            name: "drive",
            about: "drive file of `feedscope dynamics` (DriveConfig, modes at mid-screw)",
            seeds: seeds::drive,
            mutator: text,
            run: run_drive,
        },
        Target {
            name: "sim",
            about: "simulator config (feedscope_io::sim::read_config)",
            seeds: seeds::sim,
            mutator: text,
            run: run_sim,
        },
        Target {
            name: "sim_run",
            about: "simulator config, run (simulate, servo work bound)",
            seeds: seeds::sim_run,
            mutator: text,
            run: run_sim_run,
        },
        Target {
            name: "effort_glitch",
            about: "trace CSV with effort glitches, screened and estimated (parse_trace, estimate)",
            seeds: seeds::effort_glitch,
            mutator: text,
            run: run_effort_glitch,
        },
        Target {
            name: "map_index",
            about: "test-set index of `feedscope map` (read_index)",
            seeds: seeds::map_index,
            mutator: text,
            run: run_map_index,
        },
        Target {
            name: "stribeck_table",
            about: "steady-speed table of `fit-stribeck` (stribeck_table::read)",
            seeds: seeds::stribeck_table,
            mutator: text,
            run: run_stribeck,
        },
        Target {
            name: "friction_csv",
            about: "friction CSV of `estimate`, read back (friction_csv::read)",
            seeds: || vec![seeds::friction_csv_and_summary().0],
            mutator: text,
            run: run_friction_csv,
        },
        Target {
            name: "summary_json",
            about: "JSON summary beside a friction CSV (friction_csv::read)",
            seeds: || vec![seeds::friction_csv_and_summary().1],
            mutator: text,
            run: run_summary,
        },
        Target {
            name: "thresholds",
            about: "thresholds file (feedscope_io::thresholds::read)",
            seeds: seeds::thresholds,
            mutator: text,
            run: run_thresholds,
        },
        Target {
            name: "store",
            about: "condition-history store, SQLite (SqliteStore::open, list, series)",
            seeds: seeds::store,
            mutator: binary,
            run: run_store,
        },
    ]
}

/// The target named `name`.
pub fn by_name(name: &str) -> Option<Target> {
    all().into_iter().find(|t| t.name == name)
}

/// A refusal is fine when it is bad input with a message of sensible size.
fn refused(kind: ErrorKind, message: String) -> Result<Verdict, Finding> {
    if kind != ErrorKind::BadInput {
        return Err(format!(
            "refused as {kind:?} (exit 1), not BadInput (exit 2): {message}"
        ));
    }
    if message.trim().is_empty() {
        return Err("refused with an empty message".into());
    }
    if message.len() > 20_000 {
        return Err(format!("refused with a message of {} bytes", message.len()));
    }
    Ok(Verdict::Rejected)
}

/// The sanity checks of an accepted trace: finite, time strictly increasing, position and
/// effort within the bounds of a feed axis ([`feedscope_io::trace::limits`]).
pub fn check_trace(t: &Trace) -> Result<(), Finding> {
    use feedscope_io::trace::limits;
    let eff_max = match t.effort_kind {
        EffortKind::CurrentA => limits::MAX_ABS_CURRENT_A,
        EffortKind::TorqueNm => limits::MAX_ABS_TORQUE_NM,
    };
    for (ch, name, max) in [
        (&t.position_m, "position_m", limits::MAX_ABS_POSITION_M),
        (&t.effort, "effort", eff_max),
    ] {
        if ch.time_s.len() != ch.value.len() {
            return Err(format!(
                "{name}: {} times, {} values",
                ch.time_s.len(),
                ch.value.len()
            ));
        }
        if ch.len() < feedscope::trace::MIN_SAMPLES {
            return Err(format!("{name}: only {} samples accepted", ch.len()));
        }
        for k in 0..ch.len() {
            let (t_s, v) = (ch.time_s[k], ch.value[k]);
            if !t_s.is_finite() || !v.is_finite() {
                return Err(format!("{name}[{k}]: time {t_s}, value {v} accepted"));
            }
            if v.abs() > max {
                return Err(format!("{name}[{k}] = {v} accepted (bound {max})"));
            }
            if k > 0 && t_s <= ch.time_s[k - 1] {
                return Err(format!(
                    "{name}[{k}]: time {t_s} not after {}",
                    ch.time_s[k - 1]
                ));
            }
        }
    }
    if let Some(q) = t.facts.effort_quantum {
        if !(q.is_finite() && q > 0.0) {
            return Err(format!("effort_quantum {q} accepted"));
        }
    }
    Ok(())
}

fn run_trace(b: &[u8], _: &Ctx) -> Result<Verdict, Finding> {
    let opts = ReadOptions {
        effort: None,
        threads: 1,
    };
    match parse_trace(b, "fuzz", &opts) {
        Ok((t, _)) => check_trace(&t).map(|()| Verdict::Accepted),
        Err(e) => refused(e.kind(), e.to_string()),
    }
}

/// SHDR inputs hold the device model and the log, split at this line.
pub const SHDR_SPLIT: &str = "\n#==== feedscope-fuzz: SHDR log below ====\n";

fn shdr_seeds() -> Vec<Vec<u8>> {
    seeds::SHDR
        .iter()
        .map(|(xml, log)| format!("{xml}{SHDR_SPLIT}{log}").into_bytes())
        .collect()
}

fn run_shdr(b: &[u8], _: &Ctx) -> Result<Verdict, Finding> {
    use feedscope_io::import::devices::DeviceModel;
    use feedscope_io::import::shdr::{parse_shdr, ShdrConvertParams};
    let text = String::from_utf8_lossy(b);
    let Some((xml, log)) = text.split_once(SHDR_SPLIT) else {
        return Ok(Verdict::Rejected);
    };
    let model = match DeviceModel::parse(xml, "Devices.xml") {
        Ok(m) => m,
        Err(e) => return refused(e.kind(), e.to_string()),
    };
    let parsed = match parse_shdr(log, "log.txt", &model, None) {
        Ok(p) => p,
        Err(e) => return refused(e.kind(), e.to_string()),
    };
    let params = ShdrConvertParams {
        torque_per_load_nm: Some(2.0),
        ..Default::default()
    };
    let mut verdict = Verdict::Rejected;
    let labels: Vec<String> = parsed
        .device(&model)
        .axes
        .iter()
        .take(4)
        .map(|a| a.label().to_string())
        .collect();
    for axis in labels {
        match parsed.to_trace(&model, &axis, &params) {
            Ok(imp) => {
                check_trace(&imp.trace).map_err(|f| format!("axis {axis}: {f}"))?;
                verdict = Verdict::Accepted;
            }
            Err(e) => {
                refused(e.kind(), e.to_string())?;
            }
        }
    }
    Ok(verdict)
}

fn run_umich(b: &[u8], _: &Ctx) -> Result<Verdict, Finding> {
    use feedscope_io::import::umich::parse_umich;
    let text = String::from_utf8_lossy(b);
    let table = match parse_umich(&text, "umich.csv") {
        Ok(t) => t,
        Err(e) => return refused(e.kind(), e.to_string()),
    };
    let mut verdict = Verdict::Rejected;
    for axis in table.axes().into_iter().take(4) {
        match table.to_trace(&axis, &Default::default()) {
            Ok(imp) => {
                check_trace(&imp.trace).map_err(|f| format!("axis {axis}: {f}"))?;
                verdict = Verdict::Accepted;
            }
            Err(e) => {
                refused(e.kind(), e.to_string())?;
            }
        }
    }
    Ok(verdict)
}

fn run_sinumerik(b: &[u8], _: &Ctx) -> Result<Verdict, Finding> {
    use feedscope_io::import::sinumerik::{list_sinumerik_from, parse_sinumerik, SinumerikParams};
    let listing = match list_sinumerik_from(b, "trace.xml") {
        Ok(l) => l,
        Err(e) => return refused(e.kind(), e.to_string()),
    };
    let mut verdict = Verdict::Rejected;
    for (axis, _) in listing.axes().into_iter().take(4) {
        let params = SinumerikParams {
            axis: Some(axis.clone()),
            ..Default::default()
        };
        match parse_sinumerik(b, "trace.xml", &params) {
            Ok(imp) => {
                check_trace(&imp.imported.trace).map_err(|f| format!("axis {axis}: {f}"))?;
                verdict = Verdict::Accepted;
            }
            Err(e) => {
                refused(e.kind(), e.to_string())?;
            }
        }
    }
    Ok(verdict)
}

fn run_twincat(b: &[u8], _: &Ctx) -> Result<Verdict, Finding> {
    use feedscope_io::import::twincat::{list_twincat_from, parse_twincat, TwincatParams};
    use feedscope_io::import::units::{EffortUnit, PositionUnit};
    if let Err(e) = list_twincat_from(b, "scope.csv") {
        return refused(e.kind(), e.to_string());
    }
    // The real excerpts are pytcs's test recordings, not a drive: their channels are named
    // (as `feedscope import twincat --position var_REAL64 --effort func_scaled` would).
    let params = TwincatParams {
        position: Some("var_REAL64".into()),
        position_unit: Some(PositionUnit::Millimetre),
        effort: Some("func_scaled".into()),
        effort_unit: Some(EffortUnit::NewtonMetre),
    };
    match parse_twincat(b, "scope.csv", &params) {
        Ok(imp) => {
            check_trace(&imp.imported.trace)?;
            Ok(Verdict::Accepted)
        }
        Err(e) => refused(e.kind(), e.to_string()),
    }
}

/// True when a value, serialised into TOML values, holds no NaN or infinity. The walk is over
/// typed values (not the text): a multi-line string such as an NC program may say `nan`.
fn toml_finite<T: serde::Serialize>(v: &T) -> Result<(), Finding> {
    fn walk(path: &str, v: &toml::Value) -> Result<(), Finding> {
        match v {
            toml::Value::Float(x) if !x.is_finite() => {
                Err(format!("accepted a non-finite value: `{path} = {x}`"))
            }
            toml::Value::Array(a) => a
                .iter()
                .enumerate()
                .try_for_each(|(k, x)| walk(&format!("{path}[{k}]"), x)),
            toml::Value::Table(t) => t.iter().try_for_each(|(k, x)| {
                walk(
                    &if path.is_empty() {
                        k.clone()
                    } else {
                        format!("{path}.{k}")
                    },
                    x,
                )
            }),
            _ => Ok(()),
        }
    }
    let value =
        toml::Value::try_from(v).map_err(|e| format!("accepted value does not serialise: {e}"))?;
    walk("", &value)
}

fn run_axis(b: &[u8], ctx: &Ctx, name: &str) -> Result<Verdict, Finding> {
    use feedscope::axis::{AxisParams, ConfigFormat};
    // Text parses from memory (the parser `load` calls); other bytes go through the file,
    // where reading them as UTF-8 is what refuses them.
    let parsed = match std::str::from_utf8(b) {
        Ok(text) => AxisParams::parse(text, ConfigFormat::from_path(Path::new(name)), name)
            .map_err(feedscope_io::axis::AxisFileError::from),
        Err(_) => feedscope_io::axis::load(&ctx.file(name, b)),
    };
    match parsed {
        Ok(a) => {
            toml_finite(&a)?;
            let derived = [
                ("equivalent_mass_kg", a.equivalent_mass_kg()),
                ("equivalent_damping", a.equivalent_damping_n_s_per_m()),
                ("force_per_torque", a.force_per_torque_n_per_nm()),
                ("nut_refeed_order", a.nut_refeed_order().unwrap_or(1.0)),
            ];
            for (k, v) in derived {
                if !(v.is_finite() && v >= 0.0) {
                    return Err(format!("accepted axis gives {k} = {v}"));
                }
            }
            Ok(Verdict::Accepted)
        }
        Err(e) => refused(e.kind(), e.to_string()),
    }
}

fn run_drive(b: &[u8], _: &Ctx) -> Result<Verdict, Finding> {
    use feedscope::dynamics::{DriveConfig, DriveModel};
    let text = String::from_utf8_lossy(b);
    let cfg = match DriveConfig::from_toml_str(&text, "drive.toml") {
        Ok(c) => c,
        Err(e) => return refused(e.kind(), e.to_string()),
    };
    toml_finite(&cfg)?;
    let model = match DriveModel::from_config(&cfg) {
        Ok(m) => m,
        Err(e) => return Err(format!("a validated drive file fails to build: {e}")),
    };
    let y = 0.5 * model.length_m();
    let v = cfg.sweep.feed_max_mm_min / 60e3;
    match model.sweep_feed(y, &[0.0, v], 3) {
        Ok(f) => {
            for (k, modes) in f.iter().enumerate() {
                if modes.iter().any(|x| !x.is_finite()) || modes.iter().all(|&x| x <= 0.0) {
                    return Err(format!(
                        "accepted drive gives natural frequencies {modes:?} Hz (feed {k})"
                    ));
                }
            }
            Ok(Verdict::Accepted)
        }
        Err(e) => Err(format!(
            "a validated drive file fails its modal analysis: {e}"
        )),
    }
}

fn run_sim(b: &[u8], ctx: &Ctx) -> Result<Verdict, Finding> {
    // A relative `motion.program_file` resolves in the scratch directory, as beside a file.
    let parsed = match std::str::from_utf8(b) {
        Ok(text) => feedscope_io::sim::config_from_toml_str_in_dir(text, &ctx.dir),
        Err(_) => feedscope_io::sim::read_config(&ctx.file("sim.toml", b)),
    };
    match parsed {
        Ok(c) => toml_finite(&c).map(|()| Verdict::Accepted),
        Err(e) => refused(e.kind(), e.to_string()),
    }
}

/// Largest run the `sim_run` target simulates: RK4 steps in the worst case
/// (`integration_steps_bound`), and samples of any channel. Larger accepted configs are only
/// parsed and bounded.
const SIM_RUN_MAX_STEPS: f64 = 200_000.0;
const SIM_RUN_MAX_SAMPLES: f64 = 50_000.0;

fn run_sim_run(b: &[u8], ctx: &Ctx) -> Result<Verdict, Finding> {
    use feedscope::sim::{integration_steps_bound, simulate, MotionProfile, SamplingMode};
    let text = String::from_utf8_lossy(b);
    let cfg = match feedscope_io::sim::config_from_toml_str_in_dir(&text, &ctx.dir) {
        Ok(c) => c,
        Err(e) => return refused(e.kind(), e.to_string()),
    };
    toml_finite(&cfg)?;
    let path = match cfg.path() {
        Ok(p) => p,
        Err(e) => return refused(e.kind(), e.to_string()),
    };
    let duration = MotionProfile::duration_s(&path);
    let s = &cfg.sampling;
    let samples = match s.mode {
        SamplingMode::Asynchronous => {
            duration / (1e-3 * s.position.interval_ms.min(s.effort.interval_ms))
        }
        SamplingMode::Synchronous => duration * s.synchronous_rate_hz,
    }
    .max(duration / (1e-3 * cfg.truth.interval_ms));
    let bound = match integration_steps_bound(&cfg) {
        Ok(b) => b,
        Err(e) => return refused(e.kind(), e.to_string()),
    };
    if !(bound <= SIM_RUN_MAX_STEPS && samples <= SIM_RUN_MAX_SAMPLES) {
        return Ok(Verdict::Accepted);
    }
    match simulate(&cfg, &mut |_| {}) {
        Ok(out) => {
            if out.stats.integration_steps as f64 > bound {
                return Err(format!(
                    "{} RK4 steps for {} control steps, above the bound {bound}",
                    out.stats.integration_steps, out.stats.control_steps
                ));
            }
            let t = &out.trace;
            for (name, ch) in [("position", &t.position_m), ("effort", &t.effort)] {
                if let Some(x) = ch.time_s.iter().chain(&ch.value).find(|x| !x.is_finite()) {
                    return Err(format!("simulated {name} channel holds {x}"));
                }
            }
            Ok(Verdict::Accepted)
        }
        Err(e) => refused(e.kind(), e.to_string()),
    }
}

/// An accepted trace keeps no effort beyond the glitch screen's bound, and its estimate (on
/// the twin's axis) is finite in every column and every stroke summary: a glitch either goes
/// or is refused, it never turns into friction of −3.4e8 N.
fn run_effort_glitch(b: &[u8], _: &Ctx) -> Result<Verdict, Finding> {
    use feedscope::estimate::{estimate, EstimateParams};
    let opts = ReadOptions {
        effort: None,
        threads: 1,
    };
    let (t, report) = match parse_trace(b, "fuzz", &opts) {
        Ok(r) => r,
        Err(e) => return refused(e.kind(), e.to_string()),
    };
    check_trace(&t)?;
    if let Some(limit) = report.effort_glitch_limit {
        if let Some(e) = t.effort.value.iter().find(|e| e.abs() > limit) {
            return Err(format!(
                "effort {e} kept beyond the glitch bound {limit} ({} dropped)",
                report.dropped_effort.len()
            ));
        }
    }
    match estimate(&t, seeds::glitch_axis(), &EstimateParams::default()) {
        Ok(est) => {
            check_strokes(&est.strokes)?;
            for s in &est.strokes {
                let m = &s.summary;
                let se = m.mean_friction_se_n.unwrap_or(0.0);
                if !(m.mean_friction_n.is_finite()
                    && m.friction_std_n.is_finite()
                    && se.is_finite())
                {
                    return Err(format!(
                        "stroke {}: mean {} ± {se} N, std {}",
                        m.stroke, m.mean_friction_n, m.friction_std_n
                    ));
                }
            }
            Ok(Verdict::Accepted)
        }
        Err(e) => refused(e.kind(), e.to_string()),
    }
}

fn run_map_index(b: &[u8], ctx: &Ctx) -> Result<Verdict, Finding> {
    let parsed = match std::str::from_utf8(b) {
        Ok(text) => feedscope::map::TestSet::parse_index(text, &ctx.dir, "index.csv"),
        Err(_) => feedscope_io::test_set::read_index(&ctx.file("index.csv", b)),
    };
    match parsed {
        Ok(set) => {
            for r in &set.runs {
                if !(r.feed_mm_min.is_finite() && r.feed_mm_min > 0.0) {
                    return Err(format!("run {}: feed {} accepted", r.name, r.feed_mm_min));
                }
            }
            Ok(Verdict::Accepted)
        }
        Err(e) => refused(e.kind(), e.to_string()),
    }
}

fn run_stribeck(b: &[u8], ctx: &Ctx) -> Result<Verdict, Finding> {
    use feedscope_io::stribeck_table::{parse, read, TableOptions};
    let opts = TableOptions {
        lead_mm: Some(10.0),
        efficiency: 0.9,
    };
    let parsed = match std::str::from_utf8(b) {
        Ok(text) => parse(text, "table.csv", &opts),
        Err(_) => read(&ctx.file("table.csv", b), &opts),
    };
    match parsed {
        Ok(t) => {
            for pts in [&t.forward, &t.backward] {
                for (&v, &f) in pts.speed_m_s.iter().zip(&pts.friction_n) {
                    if !(v.is_finite() && v > 0.0 && f.is_finite() && f >= 0.0) {
                        return Err(format!("accepted point speed {v} m/s, friction {f} N"));
                    }
                }
            }
            Ok(Verdict::Accepted)
        }
        Err(e) => refused(e.kind(), e.to_string()),
    }
}

fn check_strokes(s: &[feedscope::estimate::StrokeFriction]) -> Result<(), Finding> {
    for st in s {
        for (k, v) in [
            &st.position_m,
            &st.time_s,
            &st.velocity_m_s,
            &st.accel_m_s2,
            &st.effort,
            &st.friction_n,
        ]
        .iter()
        .enumerate()
        {
            if let Some(x) = v.iter().find(|x| !x.is_finite()) {
                return Err(format!(
                    "stroke {}: column {k} holds {x}",
                    st.summary.stroke
                ));
            }
        }
    }
    Ok(())
}

fn run_friction_csv(b: &[u8], ctx: &Ctx) -> Result<Verdict, Finding> {
    // Without a summary beside it, as `read` of a CSV that has none.
    let parsed = match std::str::from_utf8(b) {
        Ok(text) => {
            feedscope_io::friction_csv::parse(text, "friction.csv", 0.01, None, "friction.json")
        }
        Err(_) => {
            let p = ctx.file("friction.csv", b);
            let _ = std::fs::remove_file(p.with_extension("json"));
            feedscope_io::friction_csv::read(&p, 0.01)
        }
    };
    match parsed {
        Ok(s) => check_strokes(&s).map(|()| Verdict::Accepted),
        Err(e) => refused(e.kind(), e.to_string()),
    }
}

fn run_summary(b: &[u8], ctx: &Ctx) -> Result<Verdict, Finding> {
    use feedscope_io::friction_csv::{parse, read_summary};
    thread_local! {
        static CSV: String = String::from_utf8(seeds::friction_csv_and_summary().0)
            .expect("the friction CSV seed is text");
    }
    // The summary is only read from a file; the CSV it goes with parses from memory, as in
    // `friction_csv::read`.
    let json = ctx.file("est.json", b);
    let parsed = read_summary(&json)
        .and_then(|summary| CSV.with(|c| parse(c, "est.csv", 0.01, summary.as_ref(), "est.json")));
    match parsed {
        Ok(s) => check_strokes(&s).map(|()| Verdict::Accepted),
        Err(e) => refused(e.kind(), e.to_string()),
    }
}

fn run_thresholds(b: &[u8], ctx: &Ctx) -> Result<Verdict, Finding> {
    let parsed = match std::str::from_utf8(b) {
        Ok(text) => feedscope_io::thresholds::parse(text, "thresholds.toml"),
        Err(_) => feedscope_io::thresholds::read(&ctx.file("thresholds.toml", b)),
    };
    match parsed {
        Ok(m) => {
            for (k, t) in &m {
                for v in [t.upper, t.lower].into_iter().flatten() {
                    if !v.is_finite() {
                        return Err(format!("threshold {k} = {v} accepted"));
                    }
                }
            }
            Ok(Verdict::Accepted)
        }
        Err(e) => refused(e.kind(), e.to_string()),
    }
}

fn run_store(b: &[u8], ctx: &Ctx) -> Result<Verdict, Finding> {
    use feedscope_store::{Filter, SqliteStore, Store};
    let p = ctx.dir.join("store.db");
    for ext in ["db-wal", "db-shm"] {
        let _ = std::fs::remove_file(p.with_extension(ext));
    }
    std::fs::write(&p, b).expect("the scratch directory is writable");
    let run = |p: &Path| -> Result<(), feedscope_store::StoreError> {
        let s = SqliteStore::open(p)?;
        for a in s.axes()? {
            s.series(&a.machine, &a.axis)?;
        }
        s.list(&Filter::default())?;
        Ok(())
    };
    // Any typed error is an answer here: a damaged store may be unreadable (exit 1) as well
    // as not a store (exit 2); what must not happen is a panic or a hang.
    match run(&p) {
        Ok(()) => Ok(Verdict::Accepted),
        Err(_) => Ok(Verdict::Rejected),
    }
}
