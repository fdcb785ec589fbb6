//! A test analysed for the condition history (docs/history.md): a stroke test estimated and
//! analysed (paper 000), or a triangle test identified (paper 002), and the result made the
//! row the store keeps, with its indicators and report curves.
//!
//! [`AddOptions`] are what a user says about the test (kind, time, machine, axis name, program,
//! compensation, reference); [`prepare_test`] reads a trace file and analyses it,
//! [`analyse_for_store`] analyses a trace already read (a live gateway's). `history add` whole
//! is [`AddRequest::analyse`] then [`PendingAdd::store`]: the store opened before the analysis
//! when it exists (a new SQLite file only once there is a test to put in it), the [`NewTest`]
//! stored, what that did to its series said ([`SeriesNote`]) and an [`AddReport`] made
//! (`history add --format json`).
//!
//! The stored tests as the other `history` commands see them: [`ListRequest`] (`history
//! list`, and the selection of `history export`), [`show`] and [`remove`] (after the front
//! end's confirmation).
use std::path::{Path, PathBuf};

use feedscope::axis::AxisParams;
use feedscope::study::{analyze_test, StrokeStudyParams, TestAnalysis, TestKind, TestStudyParams};
use feedscope::trace::{GlitchParams, Trace};
use feedscope_io::trace::{read_trace_file_with, ReadOptions};
use feedscope_store::time::{format_rfc3339, parse_rfc3339};
use feedscope_store::{AddOutcome, Filter, IndicatorRow, NewTest, Store, TestDetail, TestRow};
use serde::{Deserialize, Serialize};

use crate::output::io_error;
use crate::store::{add_error, store_error, Opener, StoreSpec};
use crate::{AppError, FrontEnd};

/// What a user says about a test to store.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AddOptions {
    /// Kind of test: constant-feed strokes or the triangular wave.
    pub kind: TestKind,
    /// Test time, RFC 3339 (e.g. 2026-11-21T14:30:00Z); default: the trace file's
    /// modification time.
    pub time: Option<String>,
    /// Machine name.
    pub machine: String,
    /// Axis name; default: the axis file's `name`, else its file stem.
    pub axis_name: Option<String>,
    /// NC program the test ran (stored as given: a file name or an id).
    pub program: Option<String>,
    /// Compensation table in force during the test (stored as given).
    pub compensation: Option<String>,
    /// This test is the axis's reference (baseline) test.
    pub reference: bool,
    /// Width of the position intervals of the mean-friction indicators (mm), aligned at 0.
    pub interval_mm: f64,
}

impl Default for AddOptions {
    fn default() -> Self {
        Self {
            kind: TestKind::Strokes,
            time: None,
            machine: "machine".to_string(),
            axis_name: None,
            program: None,
            compensation: None,
            reference: false,
            interval_mm: StrokeStudyParams::default().interval_mm,
        }
    }
}

impl AddOptions {
    /// Check the options; the test time they give (s since the Unix epoch), when they give one.
    ///
    /// # Errors
    /// [`AppError::invalid`] naming the field: an interval that is not a positive length, a
    /// time that is not RFC 3339.
    pub fn validate(&self, front: &dyn FrontEnd) -> Result<Option<f64>, AppError> {
        if !(self.interval_mm.is_finite() && self.interval_mm > 0.0) {
            return Err(AppError::invalid(
                "interval_mm",
                format!("{} must be a positive length", front.name("interval_mm")),
            ));
        }
        match &self.time {
            Some(s) => parse_rfc3339(s).map(Some).ok_or_else(|| {
                AppError::invalid(
                    "time",
                    format!(
                        "{} {s:?} is not an RFC 3339 time such as 2026-11-21T14:30:00Z",
                        front.name("time")
                    ),
                )
            }),
            None => Ok(None),
        }
    }

    /// The axis name the test is stored under: the option, else the axis file's `name`, else
    /// the file's stem (`axis` without a file).
    pub fn axis_label(&self, axis: &AxisParams, file: Option<&Path>) -> String {
        axis_label(self.axis_name.as_deref(), axis, file)
    }
}

/// The axis name of a test: `given`, else the axis's `name`, else the stem of its `file`,
/// else `axis`.
pub fn axis_label(given: Option<&str>, axis: &AxisParams, file: Option<&Path>) -> String {
    given
        .map(str::to_string)
        .or_else(|| axis.name.clone())
        .or_else(|| {
            file.and_then(Path::file_stem)
                .map(|s| s.to_string_lossy().into_owned())
        })
        .unwrap_or_else(|| "axis".into())
}

/// Read the axis file a test of `kind` needs: a triangle test identifies J and B, so its axis
/// file may leave them out.
///
/// # Errors
/// The reader's error, naming the file and the key.
pub fn load_axis(kind: TestKind, path: &Path) -> Result<AxisParams, AppError> {
    match kind {
        TestKind::Triangle => feedscope_io::axis::load_for_identification(path),
        _ => feedscope_io::axis::load(path),
    }
    .map_err(|e| AppError::from_error(e).for_field("axis"))
}

/// What a store keeps with a test besides its analysis.
#[derive(Debug, Clone, PartialEq)]
pub struct TestMeta {
    pub machine: String,
    pub axis: String,
    /// Test time (s since the Unix epoch, UTC).
    pub time_s: f64,
    /// The trace's source (a path as given, or a live gateway's name for it).
    pub source: String,
    pub program: Option<String>,
    pub reference: bool,
    pub compensation: Option<String>,
}

/// A test analysed and ready to store.
#[derive(Debug, Clone)]
pub struct Analysed {
    /// The row to store, with its indicators and curves.
    pub test: NewTest,
    /// What the data support, in lines for the user: the verdict's headline and the strokes
    /// that give no indicator (stroke tests; none for a triangle test).
    pub verdict: Vec<String>,
}

/// Analyse `trace` as its kind asks and make it the row a store keeps (`bytes` are the
/// trace's content, whose hash finds duplicates). A triangle test's identified inertia fills
/// in what the axis file left out.
///
/// # Errors
/// The analysis's errors, under "analysing SOURCE".
pub fn analyse_for_store(
    trace: &Trace,
    axis: &mut AxisParams,
    kind: TestKind,
    interval_mm: f64,
    bytes: &[u8],
    meta: TestMeta,
) -> Result<Analysed, AppError> {
    let params = TestStudyParams {
        strokes: StrokeStudyParams {
            interval_mm,
            ..StrokeStudyParams::default()
        },
        ..TestStudyParams::default()
    };
    let analysis = analyze_test(trace, axis, kind, &params)
        .map_err(|e| AppError::within(format!("analysing {}", meta.source), e))?;
    let mut verdict = Vec::new();
    if let TestAnalysis::Strokes(st) = &analysis {
        verdict.push(st.verdict.headline());
        if !st.withheld.is_empty() {
            let which: Vec<String> = st.withheld.iter().map(|w| w.stroke.to_string()).collect();
            verdict.push(format!(
                "verdict: {} stroke(s) give no indicator, their data support no profile \
                 (strokes {}; `feedscope estimate` says why)",
                st.withheld.len(),
                which.join(", ")
            ));
        }
    }
    if let TestAnalysis::Triangle(tri) = &analysis {
        axis.resolve_identified(tri.identification.fit.j_total_kgm2);
    }
    let mut t = NewTest::from_analysis(&analysis, axis, bytes);
    t.machine = meta.machine;
    t.axis = meta.axis;
    t.time_s = meta.time_s;
    t.time_utc = format_rfc3339(meta.time_s);
    t.source = meta.source;
    t.program = meta.program;
    t.reference = meta.reference;
    t.compensation_ref = meta.compensation;
    Ok(Analysed { test: t, verdict })
}

/// Read the trace file `trace` (its bytes identify duplicates; without a time in the options
/// the test time is its modification time) and analyse it for the store. The reader's warning
/// goes to [`FrontEnd::notice`].
///
/// # Errors
/// As [`AddOptions::validate`]; reading the trace (naming the file and line); the analysis.
pub fn prepare_test(
    trace: &Path,
    mut axis: AxisParams,
    axis_label: String,
    options: &AddOptions,
    front: &dyn FrontEnd,
) -> Result<Analysed, AppError> {
    let time_given = options.validate(front)?;
    let reading = |e| io_error(format!("reading {}", trace.display()), e);
    let bytes = std::fs::read(trace).map_err(reading)?;
    let time_s = match time_given {
        Some(t) => t,
        None => std::fs::metadata(trace)
            .and_then(|m| m.modified())
            .map_err(reading)?
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0.0, |d| d.as_secs_f64()),
    };
    let source = trace.display().to_string();
    let (samples, read) = read_trace_file_with(
        trace,
        &ReadOptions::default(),
        &GlitchParams::for_axis(&axis),
    )
    .map_err(AppError::from_error)?;
    if let Some(w) = read.warning() {
        front.notice(&format!("{source}: {w}"));
    }
    let meta = TestMeta {
        machine: options.machine.clone(),
        axis: axis_label,
        time_s,
        source,
        program: options.program.clone(),
        reference: options.reference,
        compensation: options.compensation.clone(),
    };
    analyse_for_store(
        &samples,
        &mut axis,
        options.kind,
        options.interval_mm,
        &bytes,
        meta,
    )
}

/// What storing a test did: `history add --format json`.
#[derive(Debug, Clone, Serialize)]
pub struct AddReport {
    /// Test id in the store.
    pub id: i64,
    /// The same trace content was already stored for the axis and kind (nothing was added).
    pub duplicate: bool,
    /// The test's indicators (name, value in its unit, standard error, unit).
    pub indicators: Vec<IndicatorRow>,
}

impl AddReport {
    /// The report of storing `test` with `outcome`.
    pub fn new(test: &NewTest, outcome: AddOutcome) -> Self {
        let (id, duplicate) = match outcome {
            AddOutcome::Added(id) => (id, false),
            AddOutcome::Duplicate(id) => (id, true),
        };
        Self {
            id,
            duplicate,
            indicators: test.indicators.clone(),
        }
    }
}

/// A test to add from files: the trace and the axis file.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AddRequest {
    /// Trace file of the test (CSV or Parquet).
    pub trace: PathBuf,
    /// Axis parameters (TOML or JSON).
    pub axis: PathBuf,
    /// What the user says about the test.
    #[serde(flatten)]
    pub options: AddOptions,
}

impl AddRequest {
    /// Check the request without reading anything.
    ///
    /// # Errors
    /// [`AppError::invalid`] naming the field.
    pub fn validate(&self, front: &dyn FrontEnd) -> Result<(), AppError> {
        for (field, p) in [("trace", &self.trace), ("axis", &self.axis)] {
            if p.as_os_str().is_empty() {
                return Err(AppError::invalid(
                    field,
                    format!("{} names no file", front.name(field)),
                ));
            }
        }
        self.options.validate(front).map(|_| ())
    }

    /// Read the axis file and the trace and analyse the test for the store.
    ///
    /// # Errors
    /// As [`AddRequest::validate`], [`load_axis`] and [`prepare_test`].
    pub fn prepare(&self, front: &dyn FrontEnd) -> Result<Analysed, AppError> {
        self.validate(front)?;
        let axis = load_axis(self.options.kind, &self.axis)?;
        let label = self.options.axis_label(&axis, Some(&self.axis));
        prepare_test(&self.trace, axis, label, &self.options, front)
    }

    /// The first half of `history add`: check the request, read the axis file, open the
    /// store `spec` (so that a foreign or damaged one is refused before the costly analysis;
    /// a missing SQLite file is only created by [`PendingAdd::store`], so that a refused add
    /// leaves no database behind), then read and analyse the trace.
    ///
    /// # Errors
    /// As [`AddRequest::validate`], [`load_axis`], [`Opener::open`] and [`prepare_test`].
    pub fn analyse(
        &self,
        spec: &StoreSpec,
        opener: &Opener,
        front: &dyn FrontEnd,
    ) -> Result<PendingAdd, AppError> {
        self.validate(front)?;
        let axis = load_axis(self.options.kind, &self.axis)?;
        let store = match spec.sqlite_path() {
            Some(db) if !db.exists() => None,
            _ => Some(opener.open(spec)?),
        };
        let label = self.options.axis_label(&axis, Some(&self.axis));
        let analysed = prepare_test(&self.trace, axis, label, &self.options, front)?;
        Ok(PendingAdd {
            analysed,
            spec: spec.clone(),
            store,
            time_from: self.options.time.is_none().then(|| self.trace.clone()),
        })
    }
}

/// A test analysed by [`AddRequest::analyse`], not stored yet: a front end shows its
/// [`verdict`](Analysed::verdict) now, then [`stores`](PendingAdd::store) it.
pub struct PendingAdd {
    /// The test and what its data support.
    pub analysed: Analysed,
    spec: StoreSpec,
    /// The store, when it existed before the analysis.
    store: Option<Box<dyn Store>>,
    /// The trace file whose modification time is the test time (none was given).
    time_from: Option<PathBuf>,
}

impl PendingAdd {
    /// Store the test (one transaction; the same trace content already stored for the axis
    /// and kind is not stored again), opening the store with `opener` if it was not open,
    /// then count its series.
    ///
    /// # Errors
    /// As [`Opener::open`]; a failed add as [`add_error`] says it. Counting the series after
    /// the commit is not an error of the add: it is [`Added::series`].
    pub fn store(self, opener: &Opener) -> Result<Added, AppError> {
        let mut store = match self.store {
            Some(s) => s,
            None => opener.open(&self.spec)?,
        };
        let test = self.analysed.test;
        let outcome = store.add(&test).map_err(|e| add_error(e, &self.spec))?;
        // Committed: counting the series (another query) failing now, e.g. on a connection
        // lost just after the commit, must not make a stored test look like a failed add.
        let series = series_note(&*store, &test, outcome, self.time_from);
        Ok(Added {
            test,
            outcome,
            series,
        })
    }
}

/// A test stored by [`PendingAdd::store`].
#[derive(Debug)]
pub struct Added {
    /// The stored row with its results.
    pub test: NewTest,
    /// Added under a new id, or already stored.
    pub outcome: AddOutcome,
    /// What the add did to the machine/axis series (`None` for a duplicate); an error when
    /// the series could not be counted after the commit (the test is stored all the same).
    pub series: Result<Option<SeriesNote>, AppError>,
}

impl Added {
    /// `history add --format json`.
    pub fn report(&self) -> AddReport {
        AddReport::new(&self.test, self.outcome)
    }
}

/// What storing a test did to its series: started it or added to it, for the user who may
/// not have typed the machine and axis names (they can be defaults).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SeriesNote {
    /// Machine name.
    pub machine: String,
    /// Axis name.
    pub axis: String,
    /// Tests of the series now, this one included.
    pub tests: usize,
    /// The test time, RFC 3339 UTC.
    pub time_utc: String,
    /// The trace file whose modification time the test time is, when no time was given.
    pub time_from: Option<PathBuf>,
}

impl SeriesNote {
    /// The note in lines for the log: the series, then where the test time came from when it
    /// is a file's modification time (naming the `time` field as the front end spells it).
    pub fn lines(&self, front: &dyn FrontEnd) -> Vec<String> {
        let mut out = vec![if self.tests <= 1 {
            format!(
                "started the series of machine {:?}, axis {:?} (its first test)",
                self.machine, self.axis
            )
        } else {
            format!(
                "added to the series of machine {:?}, axis {:?} ({} tests now)",
                self.machine, self.axis, self.tests
            )
        }];
        if let Some(p) = &self.time_from {
            out.push(format!(
                "note: test time {} is the modification time of {} (give {} to set it)",
                self.time_utc,
                p.display(),
                front.name("time")
            ));
        }
        out
    }
}

/// The series `t` was stored into with `outcome`, counted; `None` for a duplicate.
///
/// # Errors
/// The store's, as it says them.
pub fn series_note(
    store: &dyn Store,
    t: &NewTest,
    outcome: AddOutcome,
    time_from: Option<PathBuf>,
) -> Result<Option<SeriesNote>, AppError> {
    if matches!(outcome, AddOutcome::Duplicate(_)) {
        return Ok(None);
    }
    let tests = store
        .list(&Filter {
            machine: Some(t.machine.clone()),
            axis: Some(t.axis.clone()),
        })
        .map_err(AppError::from_error)?
        .len();
    Ok(Some(SeriesNote {
        machine: t.machine.clone(),
        axis: t.axis.clone(),
        tests,
        time_utc: t.time_utc.clone(),
        time_from,
    }))
}

/// Which stored tests: `history list` (and `history export`'s selection).
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ListRequest {
    /// Only this machine.
    pub machine: Option<String>,
    /// Only this axis.
    pub axis_name: Option<String>,
}

impl ListRequest {
    /// The store's filter of the request.
    pub fn filter(&self) -> Filter {
        Filter {
            machine: self.machine.clone(),
            axis: self.axis_name.clone(),
        }
    }

    /// The tests selected, ordered by machine, axis, time and id: `history list --format
    /// json`.
    ///
    /// # Errors
    /// The store's, naming it ([`store_error`]).
    pub fn run(&self, store: &dyn Store, spec: &StoreSpec) -> Result<Vec<TestRow>, AppError> {
        store.list(&self.filter()).map_err(|e| store_error(e, spec))
    }
}

/// One stored test with its results: `history show --format json`.
///
/// # Errors
/// No such test (bad input), and the store's other errors, naming it ([`store_error`]).
pub fn show(store: &dyn Store, spec: &StoreSpec, id: i64) -> Result<TestDetail, AppError> {
    store.get(id).map_err(|e| store_error(e, spec))
}

/// Remove test `id` and its results once `confirm` agrees, shown the test; `false` when it
/// did not (nothing removed).
///
/// # Errors
/// As [`show`]; `confirm`'s own; the store's, naming it.
pub fn remove<E: From<AppError>>(
    store: &mut dyn Store,
    spec: &StoreSpec,
    id: i64,
    confirm: impl FnOnce(&TestRow) -> Result<bool, E>,
) -> Result<bool, E> {
    let d = show(store, spec, id)?;
    if !confirm(&d.test)? {
        return Ok(false);
    }
    store.remove(id).map_err(|e| store_error(e, spec))?;
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Quiet;
    use feedscope::sim::{simulate, SamplingMode, SimConfig, StrokeConfig};
    use feedscope::ErrorKind;
    use feedscope_io::trace::{write_csv, Layout};

    /// A 60 mm stroke test of the twin at 1 kHz (`t.csv`, and the same samples in the wide
    /// layout, other bytes, as `wide.csv`) with its axis file `slide.toml`.
    fn files(dir: &Path) {
        let mut cfg = SimConfig::default();
        cfg.axis.name = Some("slide".into());
        cfg.axis.travel_min_mm = Some(-2.0);
        cfg.axis.travel_max_mm = Some(62.0);
        cfg.sampling.mode = SamplingMode::Synchronous;
        cfg.sampling.synchronous_rate_hz = 1000.0;
        cfg.motion.start_mm = 0.0;
        cfg.motion.strokes = [60.0, 0.0]
            .into_iter()
            .map(|to_mm| StrokeConfig {
                to_mm,
                feed_mm_min: 400.0,
                dwell_s: 0.5,
            })
            .collect();
        let out = simulate(&cfg, &mut |_| {}).unwrap();
        for (name, layout) in [("t.csv", Layout::Long), ("wide.csv", Layout::Wide)] {
            let f = std::fs::File::create(dir.join(name)).unwrap();
            write_csv(&out.trace, f, layout).unwrap();
        }
        let axis = toml::to_string_pretty(&cfg.axis).unwrap();
        std::fs::write(dir.join("slide.toml"), axis).unwrap();
    }

    fn request(dir: &Path, trace: &str, time: Option<&str>) -> AddRequest {
        AddRequest {
            trace: dir.join(trace),
            axis: dir.join("slide.toml"),
            options: AddOptions {
                machine: "mill 3".into(),
                time: time.map(str::to_string),
                ..AddOptions::default()
            },
        }
    }

    /// `history add` whole: a refused add leaves no database, the first test starts the
    /// series, the same trace is a duplicate, another one adds to the series and says where
    /// its time came from; then the tests are listed, shown and removed.
    #[test]
    fn add_then_list_show_and_remove() {
        let d = tempfile::tempdir().unwrap();
        files(d.path());
        let spec = StoreSpec::Sqlite(d.path().join("h.db"));
        let opener = Opener::quiet();
        let e = request(d.path(), "missing.csv", None)
            .analyse(&spec, &opener, &Quiet)
            .err()
            .unwrap();
        assert_eq!(e.kind(), ErrorKind::BadInput);
        assert!(
            !d.path().join("h.db").exists(),
            "a refused add made a database"
        );

        let pending = request(d.path(), "t.csv", Some("2026-11-21T14:30:00Z"))
            .analyse(&spec, &opener, &Quiet)
            .unwrap();
        assert!(!pending.analysed.verdict.is_empty());
        let added = pending.store(&opener).unwrap();
        assert_eq!(added.outcome, AddOutcome::Added(1));
        assert_eq!(
            (added.test.axis.as_str(), added.test.machine.as_str()),
            ("slide", "mill 3")
        );
        let note = added.series.unwrap().unwrap();
        assert_eq!(
            note.lines(&Quiet),
            ["started the series of machine \"mill 3\", axis \"slide\" (its first test)"]
        );

        let again = request(d.path(), "t.csv", None)
            .analyse(&spec, &opener, &Quiet)
            .unwrap()
            .store(&opener)
            .unwrap();
        assert_eq!(again.outcome, AddOutcome::Duplicate(1));
        assert!(again.report().duplicate);
        assert_eq!(again.series.unwrap(), None);

        let wide = request(d.path(), "wide.csv", None)
            .analyse(&spec, &opener, &Quiet)
            .unwrap()
            .store(&opener)
            .unwrap();
        assert_eq!(wide.outcome, AddOutcome::Added(2));
        let lines = wide.series.unwrap().unwrap().lines(&Quiet);
        assert_eq!(
            lines[0],
            "added to the series of machine \"mill 3\", axis \"slide\" (2 tests now)"
        );
        assert!(
            lines[1].starts_with("note: test time ")
                && lines[1].ends_with("wide.csv (give `time` to set it)"),
            "{lines:?}"
        );

        let mut store = opener.open(&spec).unwrap();
        let all = ListRequest::default().run(&*store, &spec).unwrap();
        assert_eq!(all.iter().map(|r| r.id).collect::<Vec<_>>(), [1, 2]);
        let none = ListRequest {
            machine: Some("lathe".into()),
            axis_name: None,
        };
        assert!(none.run(&*store, &spec).unwrap().is_empty());
        assert_eq!(
            show(&*store, &spec, 2).unwrap().test.source,
            wide.test.source
        );
        let e = show(&*store, &spec, 9).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::BadInput);

        let asked = |answer: bool| {
            move |t: &TestRow| -> Result<bool, AppError> {
                assert_eq!(t.id, 1);
                Ok(answer)
            }
        };
        assert!(!remove(&mut *store, &spec, 1, asked(false)).unwrap());
        assert_eq!(ListRequest::default().run(&*store, &spec).unwrap().len(), 2);
        assert!(remove(&mut *store, &spec, 1, asked(true)).unwrap());
        assert_eq!(ListRequest::default().run(&*store, &spec).unwrap().len(), 1);
    }
}
