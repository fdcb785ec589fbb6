//! Test sets: the index CSV and the parallel estimation of every run.

use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::MapError;
use crate::axis::AxisParams;
use crate::estimate::{estimate, EstimateParams, StrokeFriction};
use crate::trace::{read_trace_file_with, GlitchParams, ReadOptions, Trace};

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
    /// What was left out and why (position samples dropped as glitches when the trace was
    /// read, strokes at another feed, skipped strokes).
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
    /// The warning, for people.
    pub message: String,
}

/// Estimate every run of a test set in parallel, reading each trace with
/// [`read_trace_file_with`] and the position screened at the axis' speed limit
/// ([`GlitchParams::for_axis`]). `progress` is called once per finished run (from worker
/// threads).
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
    let glitch = GlitchParams::for_axis(axis);
    estimate_runs(
        &set.runs,
        |run| {
            read_trace_file_with(&run.file, &read, &glitch)
                .map(|(t, report)| (t, report.glitch_warning()))
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
    estimate_runs(
        runs,
        |run| load(run).map(|t| (t, None)),
        axis,
        params,
        stroke_feed_tolerance,
        progress,
    )
}

/// [`estimate_set_with`] with a loader that may also return a warning about the read.
fn estimate_runs<L>(
    runs: &[TestRun],
    load: L,
    axis: &AxisParams,
    params: &EstimateParams,
    stroke_feed_tolerance: f64,
    progress: &(dyn Fn(&TestRun) + Sync),
) -> SetEstimate
where
    L: Fn(&TestRun) -> Result<(Trace, Option<String>), String> + Sync,
{
    let results: Vec<(Option<String>, Result<RunFriction, RunFailure>)> = runs
        .par_iter()
        .map(|run| {
            let (warning, r) = match load(run) {
                Ok((trace, warning)) => {
                    let r = estimate_run(
                        run,
                        &trace,
                        warning.as_deref(),
                        axis,
                        params,
                        stroke_feed_tolerance,
                    );
                    (warning, r)
                }
                Err(e) => (None, Err(e)),
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
        if let Some(message) = warning {
            out.read_warnings.push(RunWarning {
                run: run.name.clone(),
                message,
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
    read_warning: Option<&str>,
    axis: &AxisParams,
    params: &EstimateParams,
    stroke_feed_tolerance: f64,
) -> Result<RunFriction, String> {
    let est = estimate(trace, axis, params).map_err(|e| e.to_string())?;
    let mut warnings: Vec<String> = read_warning.map(String::from).into_iter().collect();
    warnings.extend(est.skipped);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axis::ConfigFormat;

    /// A wide 500 Hz trace: 0 → 20 mm at 600 mm/min and back, with a 5 mm spike at sample 700
    /// (t = 1.4 s, line 702) and a 1e308 at sample 2000 (t = 4 s, line 2002).
    fn spiky_trace() -> String {
        let mut s = String::from("time_s,position_mm,current_a\n");
        for k in 0..2750 {
            let t = k as f64 / 500.0;
            let (mm, dir) = match t {
                t if t < 0.5 => (0.0, 0.0),
                t if t < 2.5 => (10.0 * (t - 0.5), 1.0),
                t if t < 3.0 => (20.0, 0.0),
                t if t < 5.0 => (20.0 - 10.0 * (t - 3.0), -1.0),
                _ => (0.0, 0.0),
            };
            let z = match k {
                700 => format!("{:.4}", mm + 5.0),
                2000 => "1e308".into(),
                _ => format!("{mm:.4}"),
            };
            s.push_str(&format!("{t:.6},{z},{:.6}\n", dir * 0.8));
        }
        s
    }

    #[test]
    fn read_warnings_name_the_run_and_use_the_axis_rapid_rate() {
        let d = tempfile::tempdir().unwrap();
        for name in ["r1.csv", "r2.csv"] {
            std::fs::write(d.path().join(name), spiky_trace()).unwrap();
        }
        let index = d.path().join("index.csv");
        std::fs::write(
            &index,
            "file,feed_mm_min,repeat\nr1.csv,600,1\nr2.csv,600,2\n",
        )
        .unwrap();
        let set = TestSet::read_index(&index).unwrap();
        let text = "lead_mm = 10\ntable_mass_kg = 300\ninertia_kgm2 = 0.002\n\
                    damping_nms_per_rad = 0\ntorque_constant_nm_per_a = 1.5\n";
        for (rapid, dropped) in [
            ("", "1 position sample"),
            ("rapid_rate_mm_min = 15000\n", "2 position samples"),
        ] {
            let axis =
                AxisParams::parse(&format!("{text}{rapid}"), ConfigFormat::Toml, "a").unwrap();
            let est = estimate_set(
                &set,
                &axis,
                &EstimateParams::default(),
                &ReadOptions::default(),
                0.1,
                &|_| {},
            );
            assert_eq!(est.ok.len(), 2, "{:?}", est.failed);
            let names: Vec<&str> = est.read_warnings.iter().map(|w| w.run.as_str()).collect();
            assert_eq!(names, ["r1.csv", "r2.csv"]);
            let w = &est.read_warnings[0].message;
            assert!(w.contains(dropped) && w.contains("4 s (line 2002)"), "{w}");
            assert_eq!(&est.ok[0].warnings[0], w);
        }
    }
}
