//! `feedscope.History`: the condition history (SQLite), as `feedscope history add|list|trend`.
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use feedscope::study::TestKind;
use feedscope_store::{AddOutcome, Filter, NewTest, SqliteStore, Store, StoreError};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

use crate::axis::Axis;
use crate::convert::to_py;
use crate::errors::{py_err, to_py as err_to_py};
use crate::front::Keywords;
use feedscope_app::history::{load_axis, prepare_test, AddOptions, AddReport};
use feedscope_app::store::{open_options, store_error, StoreSpec};
use feedscope_app::trend::{axis_trend, AxisTrends, TrendOptions};

/// A store error with the store named once, as the binary says it.
fn store_err(e: StoreError, path: &Path) -> anyhow::Error {
    store_error(e, &StoreSpec::Sqlite(path.to_path_buf())).into()
}

/// What `History.add` stored: `id`, `duplicate` (the same trace content was stored before),
/// `indicators` (name, value in its unit, standard error); `to_dict()` is the binary's
/// `history add --format json`.
#[pyclass(module = "feedscope", frozen)]
pub struct HistoryEntry {
    /// Test id in the database.
    #[pyo3(get)]
    id: i64,
    /// True when the same trace content was already stored (nothing was added).
    #[pyo3(get)]
    duplicate: bool,
    report: AddReport,
}

#[pymethods]
impl HistoryEntry {
    /// The indicator values of the test (list of dicts).
    #[getter]
    fn indicators<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report.indicators)
    }
    /// `{"id", "duplicate", "indicators"}`.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report)
    }
    fn __repr__(&self) -> String {
        format!(
            "HistoryEntry(id={}, duplicate={}, {} indicators)",
            self.id,
            if self.duplicate { "True" } else { "False" },
            self.report.indicators.len()
        )
    }
}

/// The trends of an axis: `trends` (one dict per indicator: baseline, points, change,
/// status), `diagnosis` (sentences), `profiles` (the position-resolved comparison), `tests`;
/// `warning` is True when any indicator is not `ok` (the binary's `--fail-on-warning`);
/// `to_dict()` is the binary's `history trend --format json`.
#[pyclass(module = "feedscope", frozen)]
pub struct TrendResult {
    report: AxisTrends,
    /// True when any indicator's status is not `ok`.
    #[pyo3(get)]
    warning: bool,
}

#[pymethods]
impl TrendResult {
    /// One dict per indicator with enough tests.
    #[getter]
    fn trends<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report.trends)
    }
    /// Diagnosis sentences (list of str).
    #[getter]
    fn diagnosis<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report.diagnosis)
    }
    /// The stroke tests' friction compared with their baseline position by position (dict or
    /// None).
    #[getter]
    fn profiles<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report.profiles)
    }
    /// The tests of the axis in time order (list of dicts).
    #[getter]
    fn tests<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report.tests)
    }
    /// The binary's `history trend --format json` as a dict.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report)
    }
    fn __repr__(&self) -> String {
        let r = &self.report;
        let lines: Vec<String> = r
            .trends
            .iter()
            .map(|t| {
                format!(
                    "  {}: {} ({:+.1} %)",
                    t.indicator.name(),
                    t.status.as_str(),
                    t.change_percent
                )
            })
            .collect();
        format!(
            "TrendResult({} {}: {} tests, {} indicators{}\n{})",
            r.machine,
            r.axis,
            r.tests.len(),
            lines.len(),
            if self.warning { ", WARNING" } else { "" },
            lines.join("\n")
        )
    }
}

/// The condition history of a machine's axes in an SQLite database, as `feedscope history
/// --db PATH`: `add` a test, `list` the tests, `trend` an axis. The file is created when
/// missing. `FEEDSCOPE_BUSY_TIMEOUT_S` sets how long to wait for another writer (default 30 s).
#[pyclass(module = "feedscope", frozen)]
pub struct History {
    path: PathBuf,
    store: Mutex<SqliteStore>,
}

impl History {
    fn with_store<T>(
        &self,
        f: impl FnOnce(&mut SqliteStore) -> anyhow::Result<T>,
    ) -> anyhow::Result<T> {
        let mut guard = self
            .store
            .lock()
            .map_err(|_| anyhow::anyhow!("the history store was poisoned by a panic"))?;
        f(&mut guard)
    }
}

#[pymethods]
impl History {
    #[new]
    fn new(path: PathBuf) -> PyResult<Self> {
        // The binary's busy timeout (FEEDSCOPE_BUSY_TIMEOUT_S); a wait is not said (no
        // terminal to say it on), only its end if the lock never comes.
        let opts = open_options(None).map_err(py_err)?;
        let store =
            SqliteStore::open_with(&path, &opts).map_err(|e| err_to_py(store_err(e, &path)))?;
        Ok(Self {
            path,
            store: Mutex::new(store),
        })
    }

    /// Analyse a test and store it, as `feedscope history add TRACE --axis AXIS --kind KIND`:
    /// `trace` is the trace file (its content identifies duplicates), `axis` an axis file path
    /// or an `Axis` (then `axis_name=` or the axis' `name` names it), `kind` `"strokes"` or
    /// `"triangle"`; `time` an RFC 3339 time (default: the trace file's modification time);
    /// `machine`, `axis_name`, `program`, `compensation`, `reference`, and `interval_mm` (mm)
    /// the width of the mean-friction intervals. The GIL is released while analysing.
    #[pyo3(signature = (trace, axis, kind, *, time=None, machine="machine", axis_name=None,
                        program=None, compensation=None, reference=false, interval_mm=None))]
    #[allow(clippy::too_many_arguments)]
    fn add(
        &self,
        py: Python<'_>,
        trace: PathBuf,
        axis: &Bound<'_, PyAny>,
        kind: &str,
        time: Option<&str>,
        machine: &str,
        axis_name: Option<String>,
        program: Option<String>,
        compensation: Option<String>,
        reference: bool,
        interval_mm: Option<f64>,
    ) -> PyResult<HistoryEntry> {
        let kind = match kind {
            "strokes" => TestKind::Strokes,
            "triangle" => TestKind::Triangle,
            other => {
                return Err(PyValueError::new_err(format!(
                    "kind must be \"strokes\" or \"triangle\", not {other:?}"
                )))
            }
        };
        let options = AddOptions {
            kind,
            time: time.map(str::to_string),
            machine: machine.to_string(),
            axis_name,
            program,
            compensation,
            reference,
            interval_mm: interval_mm.unwrap_or(AddOptions::default().interval_mm),
        };
        options.validate(&Keywords).map_err(py_err)?;
        let (axis_params, label) = if let Ok(a) = axis.cast::<Axis>() {
            let a = a.get().inner.clone();
            let label = options.axis_label(&a, None);
            (a, label)
        } else if let Ok(path) = axis.extract::<PathBuf>() {
            let a = load_axis(kind, &path).map_err(py_err)?;
            let label = options.axis_label(&a, Some(&path));
            (a, label)
        } else {
            return Err(PyTypeError::new_err(
                "axis must be an Axis or the path of an axis file",
            ));
        };
        let db = self.path.clone();
        let outcome = py.detach(|| -> anyhow::Result<(NewTest, AddOutcome)> {
            let t = prepare_test(&trace, axis_params, label, &options, &Keywords)?.test;
            let outcome = self.with_store(|s| s.add(&t).map_err(|e| store_err(e, &db)))?;
            Ok((t, outcome))
        });
        let (t, outcome) = outcome.map_err(err_to_py)?;
        let report = AddReport::new(&t, outcome);
        Ok(HistoryEntry {
            id: report.id,
            duplicate: report.duplicate,
            report,
        })
    }

    /// The stored tests (list of dicts), optionally of one machine and axis, as `feedscope
    /// history list --format json`.
    #[pyo3(signature = (*, machine=None, axis_name=None))]
    fn list<'py>(
        &self,
        py: Python<'py>,
        machine: Option<String>,
        axis_name: Option<String>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let rows = self
            .with_store(|s| {
                s.list(&Filter {
                    machine,
                    axis: axis_name,
                })
                .map_err(|e| store_err(e, &self.path))
            })
            .map_err(err_to_py)?;
        to_py(py, &rows)
    }

    /// Trends and diagnosis of an axis, as `feedscope history trend --format json`:
    /// `machine`, `axis_name` (default: the machine's only axis), `baseline_tests` (the first
    /// N tests make the baseline), `thresholds` (a thresholds file, TOML), and the change
    /// detectors' `profile_baseline_tests`, `profile_limit_sigma` (σ) and
    /// `component_false_alarm` (probability per test).
    #[pyo3(signature = (*, machine="machine", axis_name=None, baseline_tests=None,
                        thresholds=None, profile_baseline_tests=None, profile_limit_sigma=None,
                        component_false_alarm=None))]
    #[allow(clippy::too_many_arguments)]
    fn trend(
        &self,
        py: Python<'_>,
        machine: &str,
        axis_name: Option<String>,
        baseline_tests: Option<usize>,
        thresholds: Option<PathBuf>,
        profile_baseline_tests: Option<usize>,
        profile_limit_sigma: Option<f64>,
        component_false_alarm: Option<f64>,
    ) -> PyResult<TrendResult> {
        let defaults = TrendOptions::default();
        let options = TrendOptions {
            baseline_tests: baseline_tests.unwrap_or(defaults.baseline_tests),
            thresholds,
            profile_baseline_tests: profile_baseline_tests
                .unwrap_or(defaults.profile_baseline_tests),
            profile_limit_sigma: profile_limit_sigma.unwrap_or(defaults.profile_limit_sigma),
            component_false_alarm: component_false_alarm.unwrap_or(defaults.component_false_alarm),
        };
        options.validate(&Keywords).map_err(py_err)?;
        let from_file = options.file_thresholds().map_err(py_err)?;
        let machine = machine.to_string();
        let report = py
            .detach(|| {
                self.with_store(|store| {
                    let axis = axis_name.as_deref();
                    Ok(axis_trend(
                        store, &machine, axis, &options, from_file, &Keywords,
                    )?)
                })
            })
            .map_err(err_to_py)?;
        Ok(TrendResult {
            warning: report.needs_attention(),
            report,
        })
    }

    fn __repr__(&self) -> String {
        format!("History({:?})", self.path.display().to_string())
    }
}
