//! `feedscope report`: the condition report of an axis as one self-contained HTML file.
use feedscope_app::AppError;
use std::path::{Path, PathBuf};

use anyhow::Result;

use super::history::DetectorArgs;
use crate::front::Cli;
use crate::store::StoreSpec;
use feedscope_app::report::ReportRequest;
use feedscope_app::trend::TrendRequest;

/// Write the condition report of an axis: one self-contained HTML file.
///
/// Reads the tests of the axis from the history database (see `feedscope history`) and writes
/// one HTML file with everything inline (SVG plots, no script, no network): the diagnosis and
/// warnings, the latest friction profile with its IAFV and the flagged position ranges, a
/// position × test heat map of the friction change (where is it wearing), the spectra heat
/// maps, the Stribeck
/// curves of the triangle tests, a trend chart per indicator with baseline, ±3σ limits, EWMA
/// and its limits, thresholds and projected crossings, and the tables behind them.
///
/// The store is found as for `feedscope history`: --store SPEC (a postgres:// URL or an
/// SQLite file), --db FILE, FEEDSCOPE_STORE, FEEDSCOPE_DB, feedscope.db.
///
/// Exit codes: 0 success; 1 the database server cannot be reached; 2 bad input (no such
/// database, axis or tests, bad thresholds file or store URL).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Database file [env: FEEDSCOPE_DB] [default: feedscope.db].
    #[arg(long)]
    pub db: Option<PathBuf>,
    /// Store: postgres://USER[:PASSWORD]@HOST[:PORT]/DB (PostgreSQL, no TLS) or an SQLite
    /// file [env: FEEDSCOPE_STORE]; not with --db.
    #[arg(long, value_name = "SPEC")]
    pub store: Option<String>,
    /// Machine name [default: the only machine in the store].
    #[arg(long)]
    pub machine: Option<String>,
    /// Axis name [default: the only axis of the machine].
    #[arg(long)]
    pub axis_name: Option<String>,
    /// Baseline: mean and σ of the first N tests of each indicator; with a reference test
    /// marked, μ₀ is its value and σ the scatter of these N.
    #[arg(long, default_value_t = feedscope::study::TrendStudyParams::default().baseline_tests)]
    pub baseline_tests: usize,
    /// Thresholds file (TOML, a `[thresholds]` table; see docs/history.md).
    #[arg(long)]
    pub thresholds: Option<PathBuf>,
    #[command(flatten)]
    pub detectors: DetectorArgs,
    /// HTML file to write.
    #[arg(short = 'o', long = "output", default_value = "report.html")]
    pub output: PathBuf,
}

/// Write the report of `machine`/`axis` from the store `spec` to `out`.
pub fn write_report(
    spec: &StoreSpec,
    machine: Option<&str>,
    axis: Option<&str>,
    baseline_tests: usize,
    detectors: &DetectorArgs,
    thresholds: Option<&Path>,
    out: &Path,
) -> Result<()> {
    let request = ReportRequest {
        trend: TrendRequest {
            machine: machine.map(str::to_string),
            axis_name: axis.map(str::to_string),
            options: detectors.options(baseline_tests, thresholds),
        },
        output: out.to_path_buf(),
    };
    Ok(request.run(spec, &crate::store::opener(), &Cli::default())?)
}

/// Where the database was looked for, in words, when the file is not there: the flag, the
/// environment variable, or the default name in the current folder, and how to make one.
fn no_database(flag: Option<&Path>, store_flag: bool, db: &Path) -> AppError {
    let looked = if flag.is_some() {
        format!("{} (--db)", db.display())
    } else if store_flag {
        format!("{} (--store)", db.display())
    } else if std::env::var_os(crate::store::STORE_VAR).is_some_and(|v| !v.is_empty()) {
        format!("{} (from FEEDSCOPE_STORE)", db.display())
    } else if std::env::var_os("FEEDSCOPE_DB").is_some() {
        format!("{} (from FEEDSCOPE_DB)", db.display())
    } else {
        let here = std::env::current_dir()
            .map(|d| format!(" in {}", d.display()))
            .unwrap_or_default();
        format!(
            "{}{here} (no --db given and FEEDSCOPE_DB not set)",
            db.display()
        )
    };
    AppError::bad_input(format!(
        "no database at {looked}; a report reads the tests that `feedscope history add` \
         stores: make one with `{}`",
        super::series::how_to_add(flag)
    ))
}

pub fn run(args: Args) -> Result<()> {
    let spec = crate::store::resolve(args.db.as_deref(), args.store.as_deref())?;
    if let Some(db) = spec.sqlite_path() {
        if !db.exists() {
            return Err(no_database(args.db.as_deref(), args.store.is_some(), db).into());
        }
    }
    write_report(
        &spec,
        args.machine.as_deref(),
        args.axis_name.as_deref(),
        args.baseline_tests,
        &args.detectors,
        args.thresholds.as_deref(),
        &args.output,
    )?;
    eprintln!("wrote {}", args.output.display());
    Ok(())
}
