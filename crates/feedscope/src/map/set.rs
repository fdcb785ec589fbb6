//! Test sets: the index CSV and the parallel estimation of every run.

use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::MapError;
use crate::axis::AxisParams;
use crate::estimate::{estimate, EstimateParams, StrokeFriction};
use crate::trace::{read_trace_file, ReadOptions, Trace};

/// One run of a test set: a trace recorded at one nominal feed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TestRun {
    /// Name as written in the index (the relative path), used in every report.
    pub name: String,
    /// Path of the trace file (the index's folder joined with the name).
    pub file: PathBuf,
    /// Nominal feed of the run (mm/min), > 0.
    pub feed_mm_min: f64,
    /// Repeat number at that feed.
    pub repeat: u32,
}

/// The runs listed in an index CSV.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TestSet {
    /// Name of the index file.
    pub source_name: String,
    /// Runs in index order.
    pub runs: Vec<TestRun>,
}

impl TestSet {
    /// Read an index CSV (see [`TestSet::parse_index`]); paths are relative to its folder.
    ///
    /// # Errors
    /// [`MapError::Index`] when the file cannot be read or is malformed.
    pub fn read_index(path: &Path) -> Result<Self, MapError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| MapError::Index {
            source_name: name.clone(),
            line: 0,
            message: format!("cannot read: {e}"),
        })?;
        let base = path.parent().unwrap_or(Path::new(""));
        Self::parse_index(&text, base, &name)
    }

    /// Parse an index: a header naming at least the columns `file`, `feed_mm_min` and `repeat`
    /// (any order, more columns allowed, `#` lines and blank lines skipped), then one run per
    /// line. `file` is a path relative to `base_dir` (or absolute).
    ///
    /// # Errors
    /// [`MapError::Index`] naming the line: a missing column, a wrong field count, a feed that
    /// is not a positive number, a repeat that is not a non-negative integer, no runs.
    pub fn parse_index(text: &str, base_dir: &Path, source_name: &str) -> Result<Self, MapError> {
        let err = |line: usize, message: String| MapError::Index {
            source_name: source_name.to_string(),
            line,
            message,
        };
        let mut lines = text
            .lines()
            .enumerate()
            .map(|(k, l)| (k + 1, l.trim()))
            .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
        let (hline, header) = lines.next().ok_or_else(|| {
            err(
                0,
                "empty index: expected a header `file,feed_mm_min,repeat`".into(),
            )
        })?;
        let cols: Vec<&str> = header.split(',').map(str::trim).collect();
        let col = |name: &str| {
            cols.iter().position(|c| *c == name).ok_or_else(|| {
                err(
                    hline,
                    format!("no `{name}` column in the header (need file,feed_mm_min,repeat)"),
                )
            })
        };
        let (cf, cv, cr) = (col("file")?, col("feed_mm_min")?, col("repeat")?);
        let mut runs = Vec::new();
        for (line, l) in lines {
            let f: Vec<&str> = l.split(',').map(str::trim).collect();
            if f.len() != cols.len() {
                return Err(err(
                    line,
                    format!("{} fields, the header has {}", f.len(), cols.len()),
                ));
            }
            let feed: f64 = f[cv]
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite() && *v > 0.0)
                .ok_or_else(|| {
                    err(
                        line,
                        format!("feed_mm_min `{}` is not a positive number", f[cv]),
                    )
                })?;
            let repeat: u32 = f[cr].parse().map_err(|_| {
                err(
                    line,
                    format!("repeat `{}` is not a non-negative integer", f[cr]),
                )
            })?;
            if f[cf].is_empty() {
                return Err(err(line, "empty file name".into()));
            }
            runs.push(TestRun {
                name: f[cf].to_string(),
                file: base_dir.join(f[cf]),
                feed_mm_min: feed,
                repeat,
            });
        }
        if runs.is_empty() {
            return Err(err(0, "the index lists no runs".into()));
        }
        Ok(Self {
            source_name: source_name.to_string(),
            runs,
        })
    }
}

/// The strokes of one run that were estimated.
#[derive(Debug, Clone, PartialEq)]
pub struct RunFriction {
    /// The run.
    pub run: TestRun,
    /// Its strokes (positions on the absolute grid k·p/m, friction signed as Eq. 5).
    pub strokes: Vec<StrokeFriction>,
    /// What was left out and why (strokes at another feed, skipped strokes).
    pub warnings: Vec<String>,
}

/// A run that could not be estimated.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunFailure {
    /// The run.
    pub run: TestRun,
    /// Why, for people (the whole error chain).
    pub error: String,
}

/// Result of [`estimate_set`]: the runs that worked and those that failed, in index order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SetEstimate {
    /// Estimated runs.
    pub ok: Vec<RunFriction>,
    /// Failed runs.
    pub failed: Vec<RunFailure>,
}

/// Estimate every run of a test set in parallel, reading each trace with
/// [`read_trace_file`]. `progress` is called once per finished run (from worker threads).
///
/// Never fails as a whole: a run whose file is missing or malformed, or that has no usable
/// stroke, becomes a [`RunFailure`].
pub fn estimate_set(
    set: &TestSet,
    axis: &AxisParams,
    params: &EstimateParams,
    read: &ReadOptions,
    stroke_feed_tolerance: f64,
    progress: &(dyn Fn(&TestRun) + Sync),
) -> SetEstimate {
    // Runs are the parallel unit; parse each file on one thread to avoid nested fan-out.
    let read = ReadOptions {
        threads: 1,
        ..read.clone()
    };
    estimate_set_with(
        &set.runs,
        |run| {
            read_trace_file(&run.file, &read)
                .map(|(t, _)| t)
                .map_err(|e| e.to_string())
        },
        axis,
        params,
        stroke_feed_tolerance,
        progress,
    )
}

/// As [`estimate_set`] with traces from `load` (e.g. in memory).
///
/// Strokes whose measured feed differs from the run's nominal feed by more than the fraction
/// `stroke_feed_tolerance` are left out with a warning (a rapid return, a test at another feed); a
/// run with no stroke left fails.
pub fn estimate_set_with<L>(
    runs: &[TestRun],
    load: L,
    axis: &AxisParams,
    params: &EstimateParams,
    stroke_feed_tolerance: f64,
    progress: &(dyn Fn(&TestRun) + Sync),
) -> SetEstimate
where
    L: Fn(&TestRun) -> Result<Trace, String> + Sync,
{
    let results: Vec<Result<RunFriction, RunFailure>> = runs
        .par_iter()
        .map(|run| {
            let r = estimate_run(run, &load, axis, params, stroke_feed_tolerance);
            progress(run);
            r.map_err(|error| RunFailure {
                run: run.clone(),
                error,
            })
        })
        .collect();
    let mut out = SetEstimate::default();
    for r in results {
        match r {
            Ok(x) => out.ok.push(x),
            Err(e) => out.failed.push(e),
        }
    }
    out
}

fn estimate_run<L>(
    run: &TestRun,
    load: &L,
    axis: &AxisParams,
    params: &EstimateParams,
    stroke_feed_tolerance: f64,
) -> Result<RunFriction, String>
where
    L: Fn(&TestRun) -> Result<Trace, String>,
{
    let trace = load(run)?;
    let est = estimate(&trace, axis, params).map_err(|e| e.to_string())?;
    let mut warnings = est.skipped;
    let mut strokes = Vec::with_capacity(est.strokes.len());
    for s in est.strokes {
        let rel = (s.summary.feed_mm_min - run.feed_mm_min).abs() / run.feed_mm_min;
        if rel > stroke_feed_tolerance {
            warnings.push(format!(
                "stroke {} ({:?}) at {:.3} mm/min left out: the run's feed is {} mm/min",
                s.summary.stroke, s.summary.direction, s.summary.feed_mm_min, run.feed_mm_min
            ));
        } else {
            strokes.push(s);
        }
    }
    if strokes.is_empty() {
        return Err(format!(
            "no stroke at the run's feed of {} mm/min{}",
            run.feed_mm_min,
            if warnings.is_empty() {
                String::new()
            } else {
                format!(" ({})", warnings.join("; "))
            }
        ));
    }
    Ok(RunFriction {
        run: run.clone(),
        strokes,
        warnings,
    })
}
