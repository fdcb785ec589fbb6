//! `feedscope history`: store every test of an axis and follow its indicators over time.
use std::collections::BTreeMap;
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::builder::{EnumValueParser, TypedValueParser};
use clap::{Subcommand, ValueEnum};
use feedscope::axis::AxisParams;
use feedscope::estimate::{estimate, Direction, EstimateParams};
use feedscope::history::{
    assess, diagnose, BaselineSpec, Indicator, IndicatorTrend, Threshold, TrendParams,
};
use feedscope::ident::{identify, IdentParams, Identification};
use feedscope::order::SpectrumAnalyzer;
use feedscope::profile::{analyze_stroke, AnalysisParams, StrokeView};
use feedscope::trace::{GlitchParams, Trace};
use feedscope_io::trace::{read_trace_file_with, ReadOptions};
use feedscope_store::time::{format_rfc3339, parse_rfc3339};
use feedscope_store::{
    AddOutcome, ComponentRow, Filter, Identified, IndicatorRow, IntervalRow, NewTest, SqliteStore,
    Store, StoreError, TestKind,
};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use super::BadInput;

/// Condition history: store tests in a database and trend their indicators.
///
/// The database is one SQLite file: --db, else the environment variable FEEDSCOPE_DB, else
/// feedscope.db in the current folder. Its schema is documented in docs/history.md.
///
/// Exit codes: 0 success; 1 `trend --fail-on-warning` found a warning, or an integrity check
/// failed; 2 bad input (unreadable trace or axis, foreign or damaged database file, no such
/// test).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Database file [env: FEEDSCOPE_DB] [default: feedscope.db].
    #[arg(long, global = true)]
    pub db: Option<PathBuf>,
    #[command(subcommand)]
    pub command: HistoryCommand,
}

#[derive(Debug, Subcommand)]
pub enum HistoryCommand {
    /// Analyse a test trace and store it with its results (one transaction).
    ///
    /// --kind strokes: constant-feed idle strokes → estimate + analyze (paper 000): mean
    /// friction per position interval and direction, amplitudes of the classified
    /// components. --kind triangle: the triangular-wave test → one-test identification
    /// (paper 002): Fs, Fc, σ, vs, J with standard errors. A trace whose bytes are already
    /// stored for the same axis and kind is not stored again.
    Add(AddArgs),
    /// List the stored tests.
    List(ListArgs),
    /// Show one test with its results.
    Show(ShowArgs),
    /// Export the indicator values of the tests (one row per test and indicator).
    Export(ExportArgs),
    /// Remove a test and its results (asks for confirmation unless --yes).
    Remove(RemoveArgs),
    /// Trend every indicator of an axis: baseline, limits, EWMA, CUSUM, projections, diagnosis.
    Trend(TrendArgs),
    /// Mark a test as the reference (baseline) of its axis; trends then compare with it.
    Reference(ShowArgs),
    /// Check the database file's integrity and schema version.
    Check,
}

#[derive(Debug, clap::Args)]
pub struct AddArgs {
    /// Trace file of the test (CSV or Parquet, as for `estimate`).
    pub trace: PathBuf,
    /// Axis parameters (TOML or JSON).
    #[arg(long)]
    pub axis: PathBuf,
    /// Kind of test.
    #[arg(long, value_parser = EnumValueParser::<KindArg>::new().map(TestKind::from))]
    pub kind: TestKind,
    /// Test time, RFC 3339 (e.g. 2026-11-21T14:30:00Z) [default: the trace file's mtime].
    #[arg(long)]
    pub time: Option<String>,
    /// Machine name.
    #[arg(long, default_value = "machine")]
    pub machine: String,
    /// Axis name [default: the axis file's `name`, else its file stem].
    #[arg(long)]
    pub axis_name: Option<String>,
    /// NC program the test ran (stored as given: a file name or an id).
    #[arg(long)]
    pub program: Option<String>,
    /// Compensation table in force during the test (stored as given).
    #[arg(long)]
    pub compensation: Option<String>,
    /// Mark this test as the axis's reference (baseline) test.
    #[arg(long)]
    pub reference: bool,
    /// Width of the position intervals of the mean-friction indicators (mm), aligned at 0.
    #[arg(long, default_value_t = 50.0)]
    pub interval_mm: f64,
    /// What to print on stdout.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    pub format: Format,
}

#[derive(Debug, clap::Args)]
pub struct ListArgs {
    /// Only this machine.
    #[arg(long)]
    pub machine: Option<String>,
    /// Only this axis.
    #[arg(long)]
    pub axis_name: Option<String>,
    /// What to print on stdout.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    pub format: Format,
}

#[derive(Debug, clap::Args)]
pub struct ShowArgs {
    /// Test id (see `history list`).
    pub id: i64,
    /// What to print on stdout.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    pub format: Format,
}

#[derive(Debug, clap::Args)]
pub struct ExportArgs {
    /// Only this machine.
    #[arg(long)]
    pub machine: Option<String>,
    /// Only this axis.
    #[arg(long)]
    pub axis_name: Option<String>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = ExportFormat::Csv)]
    pub format: ExportFormat,
    /// File to write [default: stdout].
    #[arg(short = 'o', long)]
    pub output: Option<PathBuf>,
}

#[derive(Debug, clap::Args)]
pub struct RemoveArgs {
    /// Test id.
    pub id: i64,
    /// Do not ask.
    #[arg(long)]
    pub yes: bool,
}

#[derive(Debug, clap::Args, Clone)]
pub struct TrendArgs {
    /// Machine name.
    #[arg(long, default_value = "machine")]
    pub machine: String,
    /// Axis name [default: the only axis of the machine].
    #[arg(long)]
    pub axis_name: Option<String>,
    /// Baseline: mean and σ of the first N tests of each indicator; with a reference test
    /// marked, μ₀ is its value and σ the scatter of these N.
    #[arg(long, default_value_t = 5)]
    pub baseline_tests: usize,
    /// Thresholds file (TOML): a `[thresholds]` table of indicator = { upper = .., lower = .. }.
    #[arg(long)]
    pub thresholds: Option<PathBuf>,
    /// Exit with code 1 when any indicator is not `ok`.
    #[arg(long)]
    pub fail_on_warning: bool,
    /// What to print on stdout.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    pub format: Format,
}

/// `--kind`: the store's [`TestKind`] as clap sees it (the store crate knows no clap).
#[derive(Debug, Clone, Copy, ValueEnum)]
enum KindArg {
    /// Constant-feed idle strokes: estimate + analyze (paper 000).
    Strokes,
    /// Variable-amplitude, variable-velocity triangular wave: one-test identification (paper 002).
    Triangle,
}

impl From<KindArg> for TestKind {
    fn from(k: KindArg) -> Self {
        match k {
            KindArg::Strokes => TestKind::Strokes,
            KindArg::Triangle => TestKind::Triangle,
        }
    }
}

#[derive(Debug, Clone, Copy, ValueEnum, PartialEq, Eq)]
pub enum Format {
    /// A table for people.
    Text,
    /// JSON.
    Json,
}

#[derive(Debug, Clone, Copy, ValueEnum, PartialEq, Eq)]
pub enum ExportFormat {
    /// test_id,machine,axis,time_utc,kind,indicator,value,std_error,unit
    Csv,
    /// An array of the same rows.
    Json,
}

/// The database path: flag, then FEEDSCOPE_DB, then feedscope.db.
pub fn db_path(flag: Option<&Path>) -> PathBuf {
    flag.map(Path::to_path_buf)
        .or_else(|| std::env::var_os("FEEDSCOPE_DB").map(PathBuf::from))
        .unwrap_or_else(|| PathBuf::from("feedscope.db"))
}

/// Open the store; a foreign or damaged file is bad input (exit 2).
pub fn open_store(path: &Path) -> Result<SqliteStore> {
    SqliteStore::open(path).map_err(|e| store_err(e, path))
}

fn store_err(e: StoreError, path: &Path) -> anyhow::Error {
    if e.is_bad_input() {
        // the store's messages name the file already
        let msg = match &e {
            StoreError::Backend(_) | StoreError::NoSuchTest(_) => {
                format!("{}: {e}", path.display())
            }
            _ => e.to_string(),
        };
        anyhow::Error::new(BadInput(msg))
    } else {
        anyhow::Error::new(e).context(format!("database {}", path.display()))
    }
}

/// The `[thresholds]` file of `history trend` and `report`.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThresholdFile {
    /// Indicator key → threshold.
    #[serde(default)]
    pub thresholds: BTreeMap<String, Threshold>,
}

/// The thresholds in force: those of the axis file stored with the tests (`[thresholds]`),
/// each overridden by the same key of a `--thresholds` file.
pub fn with_axis_thresholds(
    store: &dyn Store,
    machine: &str,
    axis: &str,
    from_file: BTreeMap<String, Threshold>,
) -> Result<BTreeMap<String, Threshold>> {
    let mut out = BTreeMap::new();
    if let Some(json) = store
        .axis_params(machine, axis)
        .map_err(anyhow::Error::new)?
    {
        // Stored by `history add` from a validated axis file; an old or foreign shape simply
        // carries no thresholds.
        if let Ok(p) = serde_json::from_str::<feedscope::axis::AxisParams>(&json) {
            out = p.thresholds;
        }
    }
    out.extend(from_file);
    Ok(out)
}

/// Read a thresholds file; unknown indicator keys are bad input.
pub fn load_thresholds(path: Option<&Path>) -> Result<BTreeMap<String, Threshold>> {
    let Some(p) = path else {
        return Ok(BTreeMap::new());
    };
    let text = std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
    let f: ThresholdFile =
        toml::from_str(&text).with_context(|| format!("parsing {}", p.display()))?;
    for k in f.thresholds.keys() {
        if Indicator::parse(k).is_none() {
            return Err(BadInput(format!(
                "{}: unknown indicator {k:?} (see `feedscope history show` for the keys)",
                p.display()
            ))
            .into());
        }
    }
    Ok(f.thresholds)
}

/// What the report needs from a stroke test beyond the indicators (stored as JSON in `curves`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Curves {
    /// First stroke of each direction: friction and IAFV along the travel.
    pub profiles: Vec<ProfileCurve>,
    /// Segment spectra of the FFS, one heat map per direction.
    pub heatmaps: Vec<HeatmapData>,
}

/// Friction and IAFV of one stroke.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ProfileCurve {
    /// `forward` or `backward`.
    pub direction: String,
    /// Feed (mm/min).
    pub feed_mm_min: f64,
    /// Positions (mm).
    pub position_mm: Vec<f64>,
    /// Estimated friction (N, signed as paper 000 Eq. 5).
    pub friction_n: Vec<f64>,
    /// IAFV (N).
    pub iafv_n: Vec<f64>,
    /// IAFV interval ends (mm).
    pub breaks_mm: Vec<f64>,
}

/// Amplitude over order (x) and segment centre (y).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct HeatmapData {
    /// `forward` or `backward`.
    pub direction: String,
    /// Orders (cycles per lead).
    pub orders: Vec<f64>,
    /// Segment centres (mm).
    pub position_mm: Vec<f64>,
    /// Amplitudes (N), one row per segment.
    pub amplitude_n: Vec<Vec<f64>>,
}

/// What `history add` derives from a test, before it is stored.
pub struct TestInput<'a> {
    /// The trace.
    pub trace: &'a Trace,
    /// The trace file's bytes (hashed).
    pub bytes: &'a [u8],
    /// The axis.
    pub axis: &'a AxisParams,
    /// Kind of test.
    pub kind: TestKind,
    /// Position interval width of the mean-friction indicators (mm).
    pub interval_mm: f64,
}

fn ind(i: &Indicator, value: f64, std_error: Option<f64>) -> IndicatorRow {
    IndicatorRow {
        name: i.name(),
        value,
        std_error: std_error.filter(|s| s.is_finite()),
        unit: i.unit().to_string(),
    }
}

/// Results of a triangle test from its identification.
pub fn identified_results(id: &Identification) -> (Identified, Vec<IndicatorRow>) {
    let (f, s, force) = (&id.fit, &id.fit.std_error, &id.force);
    let p = Identified {
        j_total_kgm2: f.j_total_kgm2,
        j_std_kgm2: s.j_total_kgm2,
        fc_n: force.fc_n,
        fc_std_n: force.fc_std_n,
        fs_n: force.fs_n,
        fs_std_n: force.fs_std_n,
        sigma_n_s_per_m: force.sigma_n_s_per_m,
        sigma_std_n_s_per_m: force.sigma_std_n_s_per_m,
        vs_mm_min: force.vs_mm_min,
        vs_std_mm_min: s.vs_mm_min,
        delta: f.delta,
        offset_n: force.offset_n,
        residual_rms_nm: f.residual_rms_nm,
        samples_used: f.samples_used as i64,
    };
    let rows = vec![
        ind(&Indicator::StaticFriction, p.fs_n, Some(p.fs_std_n)),
        ind(&Indicator::CoulombFriction, p.fc_n, Some(p.fc_std_n)),
        ind(
            &Indicator::Viscous,
            p.sigma_n_s_per_m,
            Some(p.sigma_std_n_s_per_m),
        ),
        ind(
            &Indicator::StribeckVelocity,
            p.vs_mm_min,
            Some(p.vs_std_mm_min),
        ),
        ind(&Indicator::Inertia, p.j_total_kgm2, Some(p.j_std_kgm2)),
    ];
    (p, rows)
}

/// Results of a stroke test: interval means, components, indicators, report curves.
type StrokeResults = (
    Vec<IntervalRow>,
    Vec<ComponentRow>,
    Vec<IndicatorRow>,
    Curves,
);

fn stroke_results(trace: &Trace, axis: &AxisParams, interval_mm: f64) -> Result<StrokeResults> {
    let est = estimate(trace, axis, &EstimateParams::default())?;
    let lead = axis.lead_m();
    let params = AnalysisParams::default();
    let mut analyzer = SpectrumAnalyzer::new();
    // (direction, bin) → (Σ iafv, Σ (f − iafv)², n, first z, last z)
    let mut bins: BTreeMap<(u8, i64), (f64, f64, usize)> = BTreeMap::new();
    let mut comps = Vec::new();
    // (direction, cause) → amplitudes of each stroke (max over its components of that cause)
    let mut amp: BTreeMap<(u8, String), Vec<f64>> = BTreeMap::new();
    let mut curves = Curves {
        profiles: vec![],
        heatmaps: vec![],
    };
    for s in &est.strokes {
        let v = StrokeView::from_estimate(s, lead);
        let a = analyze_stroke(&v, axis, &params, &mut analyzer).with_context(|| {
            format!(
                "analysing stroke {} ({})",
                s.summary.stroke,
                s.summary.direction.as_str()
            )
        })?;
        let d = s.summary.direction;
        let dk = u8::from(d == Direction::Backward);
        for ((&z, &f), &m) in s.position_m.iter().zip(&s.friction_n).zip(&a.iafv_n) {
            let b = (z * 1e3 / interval_mm).floor() as i64;
            let e = bins.entry((dk, b)).or_insert((0.0, 0.0, 0));
            e.0 += m.abs();
            e.1 += (f - m).powi(2);
            e.2 += 1;
        }
        let mut best: BTreeMap<String, f64> = BTreeMap::new();
        for c in &a.fluctuation.components {
            comps.push(ComponentRow {
                direction: d.as_str().to_string(),
                segment: c.segment.clone(),
                position_mm: c.position_mm,
                order: c.order,
                amplitude_n: c.amplitude_n,
                floor_n: c.floor_n,
                cause: c.cause.clone(),
                trusted: c.trusted,
            });
            if c.segment == "all" && c.trusted && c.cause != "unexplained" {
                let e = best.entry(c.cause.clone()).or_insert(0.0);
                *e = e.max(c.amplitude_n);
            }
        }
        for (cause, x) in best {
            amp.entry((dk, cause)).or_default().push(x);
        }
        if !curves.profiles.iter().any(|p| p.direction == d.as_str()) {
            let step = s.position_m.len().div_ceil(1500).max(1);
            let pick = |v: &[f64], k: f64| v.iter().step_by(step).map(|x| x * k).collect();
            curves.profiles.push(ProfileCurve {
                direction: d.as_str().into(),
                feed_mm_min: s.summary.feed_mm_min,
                position_mm: pick(&s.position_m, 1e3),
                friction_n: pick(&s.friction_n, 1.0),
                iafv_n: pick(&a.iafv_n, 1.0),
                breaks_mm: a.iafv.poly.breaks_mm.clone(),
            });
            curves.heatmaps.extend(heatmap(&a.fluctuation, d));
        }
    }
    let dir = |k: u8| {
        if k == 0 {
            Direction::Forward
        } else {
            Direction::Backward
        }
    };
    // A bin counts when samples cover at least 80 % of it (grid spacing lead/samples-per-lead).
    let spacing_mm = lead * 1e3 / EstimateParams::default().samples_per_lead as f64;
    let min_n = (0.8 * interval_mm / spacing_mm).floor().max(2.0) as usize;
    let mut intervals = Vec::new();
    let mut rows = Vec::new();
    for ((dk, b), (sum, ss, n)) in bins {
        if n < min_n {
            continue;
        }
        let (start, end) = (b as f64 * interval_mm, (b + 1) as f64 * interval_mm);
        let mean = sum / n as f64;
        let std = (ss / n as f64).sqrt();
        intervals.push(IntervalRow {
            direction: dir(dk).as_str().into(),
            start_mm: start,
            end_mm: end,
            mean_n: mean,
            std_n: std,
            samples: n as i64,
        });
        let i = Indicator::MeanFriction {
            direction: dir(dk),
            start_mm: start,
            end_mm: end,
        };
        rows.push(ind(&i, mean, Some(std / (n as f64).sqrt())));
    }
    for ((dk, cause), v) in amp {
        let i = Indicator::Component {
            direction: dir(dk),
            cause,
        };
        rows.push(ind(&i, v.iter().sum::<f64>() / v.len() as f64, None));
    }
    Ok((intervals, comps, rows, curves))
}

fn heatmap(fl: &feedscope::order::FluctuationAnalysis, d: Direction) -> Option<HeatmapData> {
    let g = fl.segment_grid(fl.max_trusted_order.clamp(4.0, 40.0), 400)?;
    Some(HeatmapData {
        direction: d.as_str().into(),
        orders: g.orders,
        position_mm: g.position_mm,
        amplitude_n: g.amplitude_n,
    })
}

/// Analyse a test into what the store keeps (everything but machine, axis name, time).
pub fn analyze_test(inp: &TestInput<'_>) -> Result<NewTest> {
    let mut t = NewTest {
        machine: String::new(),
        axis: String::new(),
        axis_params_json: serde_json::to_string(inp.axis)?,
        time_utc: String::new(),
        time_s: 0.0,
        kind: inp.kind,
        source: String::new(),
        content_sha256: hex(&Sha256::digest(inp.bytes)),
        program: None,
        reference: false,
        compensation_ref: None,
        identified: None,
        intervals: vec![],
        components: vec![],
        indicators: vec![],
        curves_json: None,
    };
    match inp.kind {
        TestKind::Triangle => {
            let id = identify(inp.trace, inp.axis, &IdentParams::default())
                .map_err(|e| BadInput(format!("identification failed: {e}")))?;
            let (p, rows) = identified_results(&id);
            t.identified = Some(p);
            t.indicators = rows;
        }
        TestKind::Strokes => {
            let (iv, comps, rows, curves) = stroke_results(inp.trace, inp.axis, inp.interval_mm)?;
            t.intervals = iv;
            t.components = comps;
            t.indicators = rows;
            t.curves_json = Some(serde_json::to_string(&curves)?);
        }
    }
    Ok(t)
}

fn hex(b: &[u8]) -> String {
    b.iter().map(|x| format!("{x:02x}")).collect()
}

fn axis_name(flag: Option<&str>, axis: &AxisParams, path: &Path) -> String {
    flag.map(str::to_string)
        .or_else(|| axis.name.clone())
        .unwrap_or_else(|| {
            path.file_stem()
                .map_or("axis".into(), |s| s.to_string_lossy().into_owned())
        })
}

fn add(db: &Path, a: &AddArgs) -> Result<()> {
    // Validate cheap things before the expensive analysis.
    if !(a.interval_mm.is_finite() && a.interval_mm > 0.0) {
        return Err(BadInput("--interval-mm must be a positive length".into()).into());
    }
    let time_given = match &a.time {
        Some(s) => Some(parse_rfc3339(s).ok_or_else(|| {
            BadInput(format!(
                "--time {s:?} is not an RFC 3339 time such as 2026-11-21T14:30:00Z"
            ))
        })?),
        None => None,
    };
    let axis = feedscope_io::axis::load(&a.axis)?;
    let bytes =
        std::fs::read(&a.trace).with_context(|| format!("reading {}", a.trace.display()))?;
    let time_s = match time_given {
        Some(t) => t,
        None => std::fs::metadata(&a.trace)?
            .modified()?
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0.0, |d| d.as_secs_f64()),
    };
    let mut store = open_store(db)?;
    let (trace, report) = read_trace_file_with(
        &a.trace,
        &ReadOptions::default(),
        &GlitchParams::for_axis(&axis),
    )?;
    crate::output::print_read_warnings(&a.trace.display().to_string(), &report);
    let mut t = analyze_test(&TestInput {
        trace: &trace,
        bytes: &bytes,
        axis: &axis,
        kind: a.kind,
        interval_mm: a.interval_mm,
    })
    .with_context(|| format!("analysing {}", a.trace.display()))?;
    t.machine = a.machine.clone();
    t.axis = axis_name(a.axis_name.as_deref(), &axis, &a.axis);
    t.time_s = time_s;
    t.time_utc = format_rfc3339(time_s);
    t.source = a.trace.display().to_string();
    t.program = a.program.clone();
    t.reference = a.reference;
    t.compensation_ref = a.compensation.clone();
    let outcome = store.add(&t).map_err(|e| store_err(e, db))?;
    let (id, dup) = match outcome {
        AddOutcome::Added(id) => (id, false),
        AddOutcome::Duplicate(id) => (id, true),
    };
    match a.format {
        Format::Json => println!(
            "{}",
            serde_json::json!({"id": id, "duplicate": dup, "indicators": t.indicators})
        ),
        Format::Text => {
            if dup {
                println!("already stored as test {id} (same trace content); nothing added");
            } else {
                println!(
                    "stored test {id}: {} {} {} at {}, {} indicators",
                    t.machine,
                    t.axis,
                    t.kind.as_str(),
                    t.time_utc,
                    t.indicators.len()
                );
            }
        }
    }
    Ok(())
}

fn list(db: &Path, a: &ListArgs) -> Result<()> {
    let store = open_store(db)?;
    let rows = store
        .list(&Filter {
            machine: a.machine.clone(),
            axis: a.axis_name.clone(),
        })
        .map_err(|e| store_err(e, db))?;
    let mut w = std::io::stdout().lock();
    match a.format {
        Format::Json => writeln!(w, "{}", serde_json::to_string_pretty(&rows)?)?,
        Format::Text => {
            writeln!(
                w,
                "{:>5}  {:<12} {:<12} {:<20}  {:<8} {:<3}  source",
                "id", "machine", "axis", "time (UTC)", "kind", "ref"
            )?;
            for r in &rows {
                writeln!(
                    w,
                    "{:>5}  {:<12} {:<12} {:<20}  {:<8} {:<3}  {}",
                    r.id,
                    r.machine,
                    r.axis,
                    r.time_utc,
                    r.kind,
                    if r.reference { "*" } else { "" },
                    r.source
                )?;
            }
        }
    }
    Ok(())
}

fn show(db: &Path, a: &ShowArgs) -> Result<()> {
    let store = open_store(db)?;
    let d = store.get(a.id).map_err(|e| store_err(e, db))?;
    let mut w = std::io::stdout().lock();
    match a.format {
        Format::Json => writeln!(w, "{}", serde_json::to_string_pretty(&d)?)?,
        Format::Text => {
            let t = &d.test;
            writeln!(
                w,
                "test {}: {} {} {} at {}{}",
                t.id,
                t.machine,
                t.axis,
                t.kind,
                t.time_utc,
                if t.reference { " (reference)" } else { "" }
            )?;
            writeln!(w, "  source {} (sha256 {})", t.source, t.content_sha256)?;
            if let Some(p) = &t.program {
                writeln!(w, "  program {p}")?;
            }
            writeln!(w, "  indicators:")?;
            for i in &d.indicators {
                let se = i
                    .std_error
                    .map_or(String::new(), |s| format!(" ± {}", num(s)));
                writeln!(w, "    {:<40} {}{se} {}", i.name, num(i.value), i.unit)?;
            }
            let n = d.components.iter().filter(|c| c.segment == "all").count();
            if n > 0 {
                writeln!(w, "  {n} significant components over whole strokes:")?;
                for c in d.components.iter().filter(|c| c.segment == "all") {
                    writeln!(
                        w,
                        "    {:<9} order {:>7.3}  {:>7.2} N  {}",
                        c.direction, c.order, c.amplitude_n, c.cause
                    )?;
                }
            }
        }
    }
    Ok(())
}

fn num(x: f64) -> String {
    if x == 0.0 || (1e-2..1e6).contains(&x.abs()) {
        format!("{x:.4}")
    } else {
        format!("{x:.4e}")
    }
}

#[derive(Serialize)]
struct ExportRow<'a> {
    test_id: i64,
    machine: &'a str,
    axis: &'a str,
    time_utc: &'a str,
    kind: &'a str,
    indicator: &'a str,
    value: f64,
    std_error: Option<f64>,
    unit: &'a str,
}

fn export(db: &Path, a: &ExportArgs) -> Result<()> {
    let store = open_store(db)?;
    let tests = store
        .list(&Filter {
            machine: a.machine.clone(),
            axis: a.axis_name.clone(),
        })
        .map_err(|e| store_err(e, db))?;
    let details = tests
        .iter()
        .map(|t| store.get(t.id))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| store_err(e, db))?;
    let rows: Vec<ExportRow> = details
        .iter()
        .flat_map(|d| {
            d.indicators.iter().map(move |i| ExportRow {
                test_id: d.test.id,
                machine: &d.test.machine,
                axis: &d.test.axis,
                time_utc: &d.test.time_utc,
                kind: &d.test.kind,
                indicator: &i.name,
                value: i.value,
                std_error: i.std_error,
                unit: &i.unit,
            })
        })
        .collect();
    let text = match a.format {
        ExportFormat::Json => serde_json::to_string_pretty(&rows)? + "\n",
        ExportFormat::Csv => {
            let mut s =
                String::from("test_id,machine,axis,time_utc,kind,indicator,value,std_error,unit\n");
            for r in &rows {
                s.push_str(&format!(
                    "{},{},{},{},{},{},{},{},{}\n",
                    r.test_id,
                    csv_field(r.machine),
                    csv_field(r.axis),
                    r.time_utc,
                    r.kind,
                    csv_field(r.indicator),
                    r.value,
                    r.std_error.map_or(String::new(), |x| x.to_string()),
                    csv_field(r.unit)
                ));
            }
            s
        }
    };
    match &a.output {
        Some(p) => crate::output::write_atomic(p, text.as_bytes())?,
        None => std::io::stdout().lock().write_all(text.as_bytes())?,
    }
    Ok(())
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn remove(db: &Path, a: &RemoveArgs) -> Result<()> {
    let mut store = open_store(db)?;
    let d = store.get(a.id).map_err(|e| store_err(e, db))?;
    if !a.yes {
        eprint!(
            "remove test {} ({} {} {} at {}, {}) and its results? [y/N] ",
            d.test.id, d.test.machine, d.test.axis, d.test.kind, d.test.time_utc, d.test.source
        );
        let mut line = String::new();
        std::io::stdin().lock().read_line(&mut line)?;
        if !matches!(line.trim(), "y" | "Y" | "yes") {
            eprintln!("not removed");
            return Ok(());
        }
    }
    store.remove(a.id).map_err(|e| store_err(e, db))?;
    println!("removed test {}", a.id);
    Ok(())
}

/// The trends of an axis and its diagnosis.
#[derive(Debug, Serialize)]
pub struct AxisTrends {
    /// Machine name.
    pub machine: String,
    /// Axis name.
    pub axis: String,
    /// Tests of the axis in time order.
    pub tests: Vec<feedscope_store::TestRow>,
    /// One per indicator with enough tests.
    pub trends: Vec<IndicatorTrend>,
    /// Indicators with too few tests for a baseline.
    pub skipped: Vec<String>,
    /// Diagnosis sentences.
    pub diagnosis: Vec<String>,
}

/// Resolve the axis name: given, or the only axis of the machine.
pub fn resolve_axis(store: &dyn Store, machine: &str, axis: Option<&str>) -> Result<String> {
    if let Some(a) = axis {
        return Ok(a.to_string());
    }
    let tests = store.list(&Filter {
        machine: Some(machine.to_string()),
        axis: None,
    })?;
    let mut axes: Vec<&str> = tests.iter().map(|t| t.axis.as_str()).collect();
    axes.dedup();
    axes.sort_unstable();
    axes.dedup();
    match axes.as_slice() {
        [one] => Ok(one.to_string()),
        [] => Err(BadInput(format!("no tests stored for machine {machine:?}")).into()),
        many => Err(BadInput(format!(
            "machine {machine:?} has several axes ({}): choose one with --axis-name",
            many.join(", ")
        ))
        .into()),
    }
}

/// Trends of every indicator of an axis.
pub fn axis_trends(
    store: &dyn Store,
    machine: &str,
    axis: &str,
    baseline_tests: usize,
    thresholds: &BTreeMap<String, Threshold>,
) -> Result<AxisTrends> {
    let tests = store.list(&Filter {
        machine: Some(machine.to_string()),
        axis: Some(axis.to_string()),
    })?;
    if tests.is_empty() {
        return Err(BadInput(format!("no tests stored for {machine} {axis}")).into());
    }
    let reference = tests.iter().find(|t| t.reference).map(|t| t.id);
    let series = store.series(machine, axis)?;
    let mut trends = Vec::new();
    let mut skipped = Vec::new();
    for (name, s) in &series {
        let Some(ind) = Indicator::parse(name) else {
            skipped.push(name.clone());
            continue;
        };
        let pts: Vec<_> = s.iter().map(|(_, p)| *p).collect();
        let spec = match reference.and_then(|r| s.iter().position(|(id, _)| *id == r)) {
            Some(index) => BaselineSpec::Reference {
                index,
                spread_count: baseline_tests.min(pts.len()),
            },
            None => BaselineSpec::FirstN {
                count: baseline_tests,
            },
        };
        let params = TrendParams {
            baseline: spec,
            ..TrendParams::default()
        };
        let th = thresholds.get(name).copied().unwrap_or_default();
        match assess(&ind, &pts, &params, &th) {
            Ok(t) => trends.push(t),
            Err(feedscope::history::HistoryError::TooFewPoints { .. }) => {
                skipped.push(name.clone())
            }
            Err(e) => return Err(anyhow::Error::new(e).context(format!("trend of {name}"))),
        }
    }
    // Identification first (Fs, Fc, σ, vs, J), then mean friction along the travel, then the
    // components: the order of the report.
    let rank = |i: &Indicator| match i {
        Indicator::StaticFriction => 0,
        Indicator::CoulombFriction => 1,
        Indicator::Viscous => 2,
        Indicator::StribeckVelocity => 3,
        Indicator::Inertia => 4,
        Indicator::MeanFriction { .. } => 5,
        Indicator::Component { .. } => 6,
    };
    let start = |i: &Indicator| match i {
        Indicator::MeanFriction { start_mm, .. } => *start_mm,
        _ => 0.0,
    };
    // stable: within a rank, names (direction first) stay in order; intervals by position
    trends.sort_by(|a, b| {
        rank(&a.indicator)
            .cmp(&rank(&b.indicator))
            .then_with(|| {
                let (da, db) = (a.indicator.name(), b.indicator.name());
                let dir = |n: &str| n.split('/').nth(1).map(str::to_string);
                dir(&da).cmp(&dir(&db))
            })
            .then(start(&a.indicator).total_cmp(&start(&b.indicator)))
    });
    let diagnosis = diagnose(&trends);
    Ok(AxisTrends {
        machine: machine.to_string(),
        axis: axis.to_string(),
        tests,
        trends,
        skipped,
        diagnosis,
    })
}

fn trend(db: &Path, a: &TrendArgs) -> Result<bool> {
    let thresholds = load_thresholds(a.thresholds.as_deref())?;
    let store = open_store(db)?;
    let axis = resolve_axis(&store, &a.machine, a.axis_name.as_deref())?;
    let thresholds = with_axis_thresholds(&store, &a.machine, &axis, thresholds)?;
    let t = axis_trends(&store, &a.machine, &axis, a.baseline_tests, &thresholds)?;
    let warn = t
        .trends
        .iter()
        .any(|x| x.status != feedscope::history::Status::Ok);
    let mut w = std::io::stdout().lock();
    match a.format {
        Format::Json => writeln!(w, "{}", serde_json::to_string_pretty(&t)?)?,
        Format::Text => {
            writeln!(w, "{} {}: {} tests", t.machine, t.axis, t.tests.len())?;
            writeln!(
                w,
                "  {:<40} {:>11} {:>11} {:>8} {:>7}  status",
                "indicator", "baseline", "latest", "change", "σ"
            )?;
            for x in &t.trends {
                let last = x.points.last().map_or(f64::NAN, |p| p.value);
                writeln!(
                    w,
                    "  {:<40} {:>11} {:>11} {:>+7.1}% {:>+7.1}  {}",
                    x.indicator.name(),
                    num(x.baseline.mean),
                    num(last),
                    x.change_percent,
                    x.change_sigma,
                    x.status.as_str()
                )?;
            }
            if !t.skipped.is_empty() {
                writeln!(
                    w,
                    "  too few tests for a baseline: {}",
                    t.skipped.join(", ")
                )?;
            }
            writeln!(w, "\ndiagnosis:")?;
            for s in &t.diagnosis {
                writeln!(w, "  - {s}")?;
            }
        }
    }
    Ok(warn)
}

pub fn run(args: Args) -> Result<()> {
    let db = db_path(args.db.as_deref());
    match &args.command {
        HistoryCommand::Add(a) => add(&db, a),
        HistoryCommand::List(a) => list(&db, a),
        HistoryCommand::Show(a) => show(&db, a),
        HistoryCommand::Export(a) => export(&db, a),
        HistoryCommand::Remove(a) => remove(&db, a),
        HistoryCommand::Trend(a) => {
            let warn = trend(&db, a)?;
            if warn && a.fail_on_warning {
                anyhow::bail!("an indicator is not ok (--fail-on-warning)");
            }
            Ok(())
        }
        HistoryCommand::Reference(a) => {
            let mut store = open_store(&db)?;
            store.set_reference(a.id).map_err(|e| store_err(e, &db))?;
            println!("test {} is now the reference of its axis", a.id);
            Ok(())
        }
        HistoryCommand::Check => {
            let store = open_store(&db)?;
            store.check()?;
            println!(
                "{}: integrity ok, schema version {}",
                db.display(),
                store.schema_version()?
            );
            Ok(())
        }
    }
}
