//! `feedscope history`: store every test of an axis and follow its indicators over time. The
//! use cases are `feedscope_app::history`, `::trend` and `::transfer`; this maps the flags to
//! their requests and renders what they return as tables.
use crate::output::outln;
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};

use anyhow::Result;
use clap::builder::{EnumValueParser, TypedValueParser};
use clap::{Subcommand, ValueEnum};
use feedscope::history::LocalParams;
use feedscope::study::{StrokeStudyParams, TrendStudyParams};
use feedscope_app::history::{AddOptions, AddRequest, ListRequest};
use feedscope_app::transfer::MigrateRequest;
use feedscope_app::trend::{
    median_limit_n, whole_travel_limit_percent, TrendOptions, TrendRequest,
};
use feedscope_app::Outcome;
use feedscope_store::{StoreError, TestKind};

use crate::front::Cli;
use crate::store::Open as _;
use crate::store::{store_err, StoreSpec};

use feedscope_app::AppError;

/// Condition history: store tests in a database and trend their indicators.
///
/// The store is an SQLite file or a PostgreSQL database: --store SPEC (a postgres:// URL or a
/// file), else --db FILE, else the environment variable FEEDSCOPE_STORE, else FEEDSCOPE_DB,
/// else feedscope.db in the current folder. The schema is documented in docs/history.md.
///
/// Exit codes: 0 success; 1 `trend --fail-on-warning` found a warning, an integrity check
/// failed, or the database server cannot be reached; 2 bad input (unreadable trace or axis,
/// foreign or damaged database, bad store URL, no such test).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Database file [env: FEEDSCOPE_DB] [default: feedscope.db].
    #[arg(long, global = true)]
    pub db: Option<PathBuf>,
    /// Store: postgres://USER[:PASSWORD]@HOST[:PORT]/DB (PostgreSQL, no TLS) or an SQLite
    /// file [env: FEEDSCOPE_STORE]; not with --db.
    #[arg(long, global = true, value_name = "SPEC")]
    pub store: Option<String>,
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
    ///
    /// The stroke tests' friction is also compared with its baseline (the first 2 stroke
    /// tests, or the reference test) position by position along the travel: a local change
    /// beyond 6× the baseline's scatter is flagged with its position range, height and width
    /// (local wear), a change of the whole travel apart from it (see docs/history.md).
    Trend(TrendArgs),
    /// Mark a test as the reference (baseline) of its axis; trends then compare with it.
    Reference(ShowArgs),
    /// Check the database's integrity and schema version.
    Check,
    /// Copy every test of a history into another store (SQLite or PostgreSQL).
    ///
    /// Copies each test with everything stored for it: its results (identified parameters,
    /// intervals, components, indicators), its report curves, the axis parameters, the
    /// reference flag, the test time and the time it was added, source, SHA-256, program and
    /// compensation table. A test whose trace is already in the target (same axis, kind and
    /// SHA-256) is not copied again, so a second run adds nothing. Test ids are given anew
    /// by the target, in the order of the source's ids.
    ///
    /// Example: feedscope history migrate --from feedscope.db --to
    /// postgres://feedscope@db.example:5432/history
    Migrate(MigrateArgs),
}

#[derive(Debug, clap::Args)]
pub struct MigrateArgs {
    /// The store to read: a postgres:// URL or an SQLite file.
    #[arg(long, value_name = "SPEC")]
    pub from: String,
    /// The store to write (created when empty): a postgres:// URL or an SQLite file.
    #[arg(long, value_name = "SPEC")]
    pub to: String,
    /// What to print on stdout.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    pub format: Format,
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
    #[arg(long, default_value_t = StrokeStudyParams::default().interval_mm)]
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
    /// Machine name [default: the only machine in the store].
    #[arg(long)]
    pub machine: Option<String>,
    /// Axis name [default: the only axis of the machine].
    #[arg(long)]
    pub axis_name: Option<String>,
    /// Baseline: mean and σ of the first N tests of each indicator; with a reference test
    /// marked, μ₀ is its value and σ the scatter of these N.
    #[arg(long, default_value_t = TrendStudyParams::default().baseline_tests)]
    pub baseline_tests: usize,
    /// Thresholds file (TOML): a `[thresholds]` table of indicator = { upper = .., lower = .. }.
    #[arg(long)]
    pub thresholds: Option<PathBuf>,
    #[command(flatten)]
    pub detectors: DetectorArgs,
    /// Exit with code 1 when any indicator is not `ok`.
    #[arg(long)]
    pub fail_on_warning: bool,
    /// What to print on stdout.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    pub format: Format,
}

/// Settings of the change detectors, shared by `history trend` and `report`
/// (docs/history.md).
#[derive(Debug, clap::Args, Clone, PartialEq)]
pub struct DetectorArgs {
    /// Stroke tests whose friction profiles form the baseline of the position-resolved
    /// comparison (the first N; ≥ 2, their scatter sets the limits). With a reference test
    /// marked, its profile is the baseline and these N its scatter.
    #[arg(long, default_value_t = LocalParams::default().baseline_tests, value_name = "N")]
    pub profile_baseline_tests: usize,
    /// Flag width of the position-resolved comparison, in σ of the baseline's own
    /// test-to-test scatter at each position.
    #[arg(long, default_value_t = LocalParams::default().k, value_name = "K")]
    pub profile_limit_sigma: f64,
    /// Chance per test that any of the axis's component amplitudes raises a false alarm
    /// although nothing changed (their limits are widened together); in (0, 0.5).
    #[arg(
        long,
        default_value_t = TrendStudyParams::default().component_false_alarm_per_test,
        value_name = "P"
    )]
    pub component_false_alarm: f64,
}

impl Default for DetectorArgs {
    fn default() -> Self {
        Self {
            profile_baseline_tests: LocalParams::default().baseline_tests,
            profile_limit_sigma: LocalParams::default().k,
            component_false_alarm: TrendStudyParams::default().component_false_alarm_per_test,
        }
    }
}

impl DetectorArgs {
    /// The trend request's settings, with the baseline and the thresholds file.
    pub fn options(&self, baseline_tests: usize, thresholds: Option<&Path>) -> TrendOptions {
        TrendOptions {
            baseline_tests,
            thresholds: thresholds.map(Path::to_path_buf),
            profile_baseline_tests: self.profile_baseline_tests,
            profile_limit_sigma: self.profile_limit_sigma,
            component_false_alarm: self.component_false_alarm,
        }
    }
}

/// `--kind`: the store's [`TestKind`] as clap sees it (the store crate knows no clap).
#[derive(Debug, Clone, Copy, ValueEnum)]
pub(crate) enum KindArg {
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

/// `history check` found the database damaged: a check that failed (exit 1), as
/// docs/history.md promises, although the same damage found on opening is bad input (exit 2).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct CheckFailed(pub StoreError);

impl AddArgs {
    fn request(&self) -> AddRequest {
        AddRequest {
            trace: self.trace.clone(),
            axis: self.axis.clone(),
            options: AddOptions {
                kind: self.kind,
                time: self.time.clone(),
                machine: self.machine.clone(),
                axis_name: self.axis_name.clone(),
                program: self.program.clone(),
                compensation: self.compensation.clone(),
                reference: self.reference,
                interval_mm: self.interval_mm,
            },
        }
    }
}

impl TrendArgs {
    fn request(&self) -> TrendRequest {
        TrendRequest {
            machine: self.machine.clone(),
            axis_name: self.axis_name.clone(),
            options: self
                .detectors
                .options(self.baseline_tests, self.thresholds.as_deref()),
        }
    }
}

/// The selection of `history list` and `history export`.
fn selection(machine: &Option<String>, axis_name: &Option<String>) -> ListRequest {
    ListRequest {
        machine: machine.clone(),
        axis_name: axis_name.clone(),
    }
}

fn add(spec: &StoreSpec, a: &AddArgs) -> Result<()> {
    let front = Cli::default();
    let opener = crate::store::opener();
    let pending = a.request().analyse(spec, &opener, &front)?;
    for line in &pending.analysed.verdict {
        eprintln!("{line}");
    }
    let added = pending.store(&opener)?;
    let report = added.report();
    match added.series {
        Ok(note) => {
            for line in note.iter().flat_map(|n| n.lines(&front)) {
                eprintln!("{line}");
            }
        }
        Err(e) => eprintln!(
            "warning: stored, but its series could not be counted: {:#}",
            anyhow::Error::new(e)
        ),
    }
    let t = &added.test;
    match a.format {
        Format::Json => outln!("{}", serde_json::to_string(&report)?),
        Format::Text => {
            if report.duplicate {
                outln!(
                    "already stored as test {} (same trace content); nothing added",
                    report.id
                );
            } else {
                outln!(
                    "stored test {}: {} {} {} at {}, {} indicators",
                    report.id,
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

fn list(spec: &StoreSpec, a: &ListArgs) -> Result<()> {
    let store = spec.open()?;
    let rows = selection(&a.machine, &a.axis_name).run(&*store, spec)?;
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

fn show(spec: &StoreSpec, a: &ShowArgs) -> Result<()> {
    let store = spec.open()?;
    let d = feedscope_app::history::show(&*store, spec, a.id)?;
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
            let n = d.components.iter().filter(|c| c.segment.is_whole()).count();
            if n > 0 {
                writeln!(w, "  {n} significant components over whole strokes:")?;
                for c in d.components.iter().filter(|c| c.segment.is_whole()) {
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

fn export(spec: &StoreSpec, a: &ExportArgs) -> Result<()> {
    let store = spec.open()?;
    let filter = selection(&a.machine, &a.axis_name).filter();
    let rows = feedscope_app::transfer::export(&*store, spec, &filter)?;
    let text = match a.format {
        ExportFormat::Json => serde_json::to_string_pretty(&rows)? + "\n",
        ExportFormat::Csv => feedscope_app::transfer::export_csv(&rows),
    };
    match &a.output {
        Some(p) => crate::output::write_atomic(p, text.as_bytes())?,
        None => std::io::stdout().lock().write_all(text.as_bytes())?,
    }
    Ok(())
}

fn remove(spec: &StoreSpec, a: &RemoveArgs) -> Result<()> {
    let mut store = spec.open()?;
    let removed = feedscope_app::history::remove(&mut *store, spec, a.id, |t| -> Result<bool> {
        if a.yes {
            return Ok(true);
        }
        eprint!(
            "remove test {} ({} {} {} at {}, {}) and its results? [y/N] ",
            t.id, t.machine, t.axis, t.kind, t.time_utc, t.source
        );
        let mut line = String::new();
        std::io::stdin().lock().read_line(&mut line)?;
        Ok(matches!(line.trim(), "y" | "Y" | "yes"))
    })?;
    if removed {
        outln!("removed test {}", a.id);
    } else {
        eprintln!("not removed");
    }
    Ok(())
}

fn trend(spec: &StoreSpec, a: &TrendArgs) -> Result<Outcome> {
    let t = a
        .request()
        .run(spec, &crate::store::opener(), &Cli::default())?;
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
            if let Some(p) = &t.profiles {
                write_profile_changes(&mut w, p)?;
            }
            writeln!(w, "\ndiagnosis:")?;
            for s in &t.diagnosis {
                writeln!(w, "  - {s}")?;
            }
        }
    }
    Ok(t.outcome())
}

/// The position-resolved comparison as text: per direction its baseline and limit, then per
/// compared test its whole-travel change and flagged ranges.
fn write_profile_changes(w: &mut impl Write, p: &feedscope::history::ProfileChanges) -> Result<()> {
    writeln!(w, "\nfriction along the travel (position by position):")?;
    for d in &p.directions {
        writeln!(
            w,
            "  {}: baseline tests {:?}{}, {:.0}-{:.0} mm compared, limit ±{} N (median over \
             the travel), whole-travel limit ±{:.1} %",
            d.direction.as_str(),
            d.baseline_ids,
            d.reference_id
                .map_or(String::new(), |r| format!(", reference test {r}")),
            d.position_mm.first().copied().unwrap_or(f64::NAN),
            d.position_mm.last().copied().unwrap_or(f64::NAN),
            num(median_limit_n(d)),
            whole_travel_limit_percent(d, p.params.level_k)
        )?;
        for t in d.tests.iter().filter(|t| !t.in_baseline) {
            let ranges: Vec<String> = t
                .ranges
                .iter()
                .map(|r| {
                    format!(
                        "{:.0}-{:.0} mm peak {:.0} mm {:+.1} N ({:+.1} %) {}",
                        r.start_mm,
                        r.end_mm,
                        r.peak_mm,
                        r.height_n,
                        r.height_percent,
                        match r.extent {
                            feedscope::history::Extent::Local => "local",
                            feedscope::history::Extent::WholeTravel => "whole travel",
                        }
                    )
                })
                .collect();
            writeln!(
                w,
                "    test {:>4}: level {:+.1} N ({:+.2} %){}; {}",
                t.test_id,
                t.level_n,
                t.level_percent,
                if t.level_flagged { " FLAGGED" } else { "" },
                if ranges.is_empty() {
                    "no position flagged".to_string()
                } else {
                    ranges.join(", ")
                }
            )?;
        }
    }
    for (dir, n) in &p.not_compared {
        writeln!(
            w,
            "  {}: {n} stroke test(s), not compared yet",
            dir.as_str()
        )?;
    }
    for (id, why) in &p.skipped {
        writeln!(w, "  test {id} left out: {why}")?;
    }
    Ok(())
}

pub fn run(args: Args) -> Result<Outcome> {
    if let HistoryCommand::Migrate(a) = &args.command {
        if args.db.is_some() || args.store.is_some() {
            return Err(AppError::bad_input(
                "history migrate reads --from and writes --to; --db and --store do not apply",
            )
            .into());
        }
        return migrate(a).map(|()| Outcome::Done);
    }
    let spec = crate::store::resolve(args.db.as_deref(), args.store.as_deref())?;
    let db = &spec;
    let done = match &args.command {
        HistoryCommand::Migrate(_) => unreachable!("handled above"),
        HistoryCommand::Add(a) => add(db, a),
        HistoryCommand::List(a) => list(db, a),
        HistoryCommand::Show(a) => show(db, a),
        HistoryCommand::Export(a) => export(db, a),
        HistoryCommand::Remove(a) => remove(db, a),
        HistoryCommand::Trend(a) => {
            let outcome = trend(db, a)?;
            return Ok(if a.fail_on_warning {
                outcome
            } else {
                Outcome::Done
            });
        }
        HistoryCommand::Reference(a) => {
            let (db, name) = (args.db.as_deref(), args.store.as_deref());
            let mut store = crate::store::open_store(db, name)?;
            store
                .set_reference(a.id)
                .map_err(|e| anyhow::Error::new(e).context(crate::store::describe(db, name)))?;
            outln!("test {} is now the reference of its axis", a.id);
            Ok(())
        }
        HistoryCommand::Check => {
            let (store, version) = spec.open_with_version()?;
            store.check().map_err(|e| match e {
                StoreError::Corrupt { .. } => anyhow::Error::new(CheckFailed(e)),
                e => store_err(e, &spec),
            })?;
            outln!(
                "{}: integrity ok, schema version {version}",
                spec.describe()
            );
            Ok(())
        }
    };
    done.map(|()| Outcome::Done)
}

/// `history migrate`: [`MigrateRequest`] run, what it did said.
fn migrate(a: &MigrateArgs) -> Result<()> {
    let request = MigrateRequest {
        from: a.from.clone(),
        to: a.to.clone(),
    };
    let n = request.run(&crate::store::opener(), &Cli::default())?;
    match a.format {
        Format::Json => outln!("{}", serde_json::to_string_pretty(&n)?),
        Format::Text => outln!(
            "{} tests in {}: {} added to {}, {} already there",
            n.tests,
            request.from_spec().describe(),
            n.added,
            request.to_spec().describe(),
            n.already_there
        ),
    }
    Ok(())
}
