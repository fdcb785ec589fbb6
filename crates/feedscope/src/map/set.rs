//! Test sets: the index CSV and the parallel estimation of every run.

use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::MapError;
use crate::axis::AxisParams;
use crate::diag::{Code, Diagnostic};
use crate::estimate::{estimate, EstimateParams, StrokeFriction};
use crate::trace::Trace;

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
    /// What was left out and why (samples dropped as glitches when the trace was read,
    /// strokes at another feed, skipped strokes).
    pub warnings: Vec<Diagnostic>,
}

/// A run that could not be estimated.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunFailure {
    /// The run.
    pub run: TestRun,
    /// Why, for people (the whole error chain).
    pub error: String,
}

/// Result of [`estimate_set_with`]: the runs that worked and those that failed, in index order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SetEstimate {
    /// Estimated runs.
    pub ok: Vec<RunFriction>,
    /// Failed runs.
    pub failed: Vec<RunFailure>,
    /// Warnings from reading the traces (position samples dropped as glitches, see
    /// [`crate::trace::glitch`]), of runs that worked or failed, in index order. A run that
    /// worked also has its warning first in [`RunFriction::warnings`].
    pub read_warnings: Vec<RunWarning>,
}

/// A warning about one run of a test set.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunWarning {
    /// The run's name as written in the index.
    pub run: String,
    /// Its code in the diagnostics catalogue.
    pub code: Code,
    /// The warning, for people.
    pub message: String,
}

/// Estimate every run of a test set in parallel, with each trace from `load` (in memory, or
/// read from its file by `feedscope_io::test_set::estimate_set`). `progress` is called once
/// per finished run (from worker threads).
///
/// Never fails as a whole: a run whose trace cannot be loaded, or that has no usable stroke,
/// becomes a [`RunFailure`].
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
    estimate_set_with_warnings(
        runs,
        |run| load(run).map(|t| (t, Vec::new())),
        axis,
        params,
        stroke_feed_tolerance,
        progress,
    )
}

/// [`estimate_set_with`] with a loader that also returns the read's diagnostics (e.g.
/// position samples dropped as glitches); they are listed in
/// [`SetEstimate::read_warnings`] and first in [`RunFriction::warnings`].
pub fn estimate_set_with_warnings<L>(
    runs: &[TestRun],
    load: L,
    axis: &AxisParams,
    params: &EstimateParams,
    stroke_feed_tolerance: f64,
    progress: &(dyn Fn(&TestRun) + Sync),
) -> SetEstimate
where
    L: Fn(&TestRun) -> Result<(Trace, Vec<Diagnostic>), String> + Sync,
{
    let results: Vec<(Vec<Diagnostic>, Result<RunFriction, RunFailure>)> = runs
        .par_iter()
        .map(|run| {
            let (warning, r) = match load(run) {
                Ok((trace, warning)) => {
                    let r =
                        estimate_run(run, &trace, &warning, axis, params, stroke_feed_tolerance);
                    (warning, r)
                }
                Err(e) => (Vec::new(), Err(e)),
            };
            progress(run);
            let r = r.map_err(|error| RunFailure {
                run: run.clone(),
                error,
            });
            (warning, r)
        })
        .collect();
    let mut out = SetEstimate::default();
    for (run, (warning, r)) in runs.iter().zip(results) {
        for d in warning {
            out.read_warnings.push(RunWarning {
                run: run.name.clone(),
                code: d.code,
                message: d.message,
            });
        }
        match r {
            Ok(x) => out.ok.push(x),
            Err(e) => out.failed.push(e),
        }
    }
    out
}

fn estimate_run(
    run: &TestRun,
    trace: &Trace,
    read_warnings: &[Diagnostic],
    axis: &AxisParams,
    params: &EstimateParams,
    stroke_feed_tolerance: f64,
) -> Result<RunFriction, String> {
    let est = estimate(trace, axis, params).map_err(|e| e.to_string())?;
    let mut warnings = read_warnings.to_vec();
    warnings.extend(
        est.skipped
            .into_iter()
            .map(|s| Diagnostic::new(Code::StrokeSkipped, s)),
    );
    let mut strokes = Vec::with_capacity(est.strokes.len());
    for s in est.strokes {
        let rel = (s.summary.feed_mm_min - run.feed_mm_min).abs() / run.feed_mm_min;
        if rel > stroke_feed_tolerance {
            warnings.push(Diagnostic::new(
                Code::StrokeOffFeed,
                format!(
                    "stroke {} ({:?}) at {:.3} mm/min left out: the run's feed is {} mm/min",
                    s.summary.stroke, s.summary.direction, s.summary.feed_mm_min, run.feed_mm_min
                ),
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
                let m: Vec<&str> = warnings.iter().map(|w| w.message.as_str()).collect();
                format!(" ({})", m.join("; "))
            }
        ));
    }
    Ok(RunFriction {
        run: run.clone(),
        strokes,
        warnings,
    })
}
