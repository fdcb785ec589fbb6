//! The condition-history store: every test of every axis with its analysis results.
//!
//! The CLI talks to a [`Store`]; the only backend today is [`sqlite::SqliteStore`] (one file,
//! WAL mode, versioned schema, documented in docs/history.md). A PostgreSQL backend for a fleet
//! would implement the same trait; nothing outside this module sees SQL.
use std::collections::BTreeMap;

use feedscope::history::Point;
use serde::Serialize;

pub mod sqlite;
pub mod time;

pub use sqlite::SqliteStore;

/// Errors of the store.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StoreError {
    /// The file exists but is not an SQLite database (left untouched).
    #[error("{path} is not a feedscope database (not an SQLite file); it was not modified")]
    NotADatabase {
        /// The file.
        path: String,
    },
    /// An SQLite database of another application (left untouched).
    #[error(
        "{path} is an SQLite database of another application (application_id {application_id:#x}, \
         {tables} tables); it was not modified"
    )]
    Foreign {
        /// The file.
        path: String,
        /// Its `PRAGMA application_id`.
        application_id: i64,
        /// Number of tables in it.
        tables: i64,
    },
    /// Written by a newer feedscope.
    #[error("{path} has schema version {found}; this feedscope reads up to {supported}")]
    NewerSchema {
        /// The file.
        path: String,
        /// Its `PRAGMA user_version`.
        found: i64,
        /// Newest schema this build knows.
        supported: i64,
    },
    /// The integrity check failed.
    #[error("{path} failed the SQLite integrity check ({detail}); it was not modified")]
    Corrupt {
        /// The file.
        path: String,
        /// First message of `PRAGMA integrity_check`.
        detail: String,
    },
    /// No such test.
    #[error("no test with id {0}")]
    NoSuchTest(i64),
    /// SQLite said no.
    #[error(transparent)]
    Sqlite(#[from] rusqlite::Error),
    /// File system.
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

impl StoreError {
    /// `true` when the user pointed at the wrong file (exit code 2).
    pub fn is_bad_input(&self) -> bool {
        match self {
            StoreError::Sqlite(rusqlite::Error::SqliteFailure(e, _)) => matches!(
                e.code,
                rusqlite::ErrorCode::NotADatabase | rusqlite::ErrorCode::DatabaseCorrupt
            ),
            StoreError::Sqlite(_) | StoreError::Io(_) => false,
            _ => true,
        }
    }
}

/// Kind of test.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum TestKind {
    /// Constant-feed idle strokes: estimate + analyze (paper 000).
    Strokes,
    /// Variable-amplitude, variable-velocity triangular wave: one-test identification (paper 002).
    Triangle,
}

impl TestKind {
    /// The word stored in `tests.kind`.
    pub fn as_str(self) -> &'static str {
        match self {
            TestKind::Strokes => "strokes",
            TestKind::Triangle => "triangle",
        }
    }
}

/// Identified parameters with standard errors (force side, table units).
#[derive(Debug, Clone, Default, Serialize)]
pub struct Identified {
    /// Total inertia at the motor (kg·m²) and its standard error.
    pub j_total_kgm2: f64,
    /// Standard error of J (kg·m²).
    pub j_std_kgm2: f64,
    /// Coulomb friction F_c (N).
    pub fc_n: f64,
    /// Standard error of F_c (N).
    pub fc_std_n: f64,
    /// Static friction F_s (N).
    pub fs_n: f64,
    /// Standard error of F_s (N).
    pub fs_std_n: f64,
    /// Viscous coefficient σ (N·s/m).
    pub sigma_n_s_per_m: f64,
    /// Standard error of σ (N·s/m).
    pub sigma_std_n_s_per_m: f64,
    /// Stribeck velocity v_s (mm/min).
    pub vs_mm_min: f64,
    /// Standard error of v_s (mm/min).
    pub vs_std_mm_min: f64,
    /// Stribeck shape exponent δ.
    pub delta: f64,
    /// Constant force F_0 (N).
    pub offset_n: f64,
    /// Residual RMS of the torque fit (N·m).
    pub residual_rms_nm: f64,
    /// Samples used in the fit.
    pub samples_used: i64,
}

/// Mean friction of one direction over one position interval.
#[derive(Debug, Clone, Serialize)]
pub struct IntervalRow {
    /// `forward` or `backward`.
    pub direction: String,
    /// Interval start (mm).
    pub start_mm: f64,
    /// Interval end (mm).
    pub end_mm: f64,
    /// Mean of the IAFV over the interval (N).
    pub mean_n: f64,
    /// Standard deviation of the estimated friction about the IAFV there (N).
    pub std_n: f64,
    /// Samples in the interval.
    pub samples: i64,
}

/// One significant fluctuation component.
#[derive(Debug, Clone, Serialize)]
pub struct ComponentRow {
    /// `forward` or `backward`.
    pub direction: String,
    /// `all` or segment number.
    pub segment: String,
    /// Segment centre (mm).
    pub position_mm: f64,
    /// Order (cycles per lead).
    pub order: f64,
    /// Amplitude (N).
    pub amplitude_n: f64,
    /// Local noise floor (N).
    pub floor_n: f64,
    /// Classified cause.
    pub cause: String,
    /// Below the highest trusted order.
    pub trusted: bool,
}

/// One indicator value of a test (the flat series the trends read).
#[derive(Debug, Clone, Serialize)]
pub struct IndicatorRow {
    /// Key, see [`feedscope::history::Indicator::name`].
    pub name: String,
    /// Value (unit of the indicator).
    pub value: f64,
    /// Standard error when known.
    pub std_error: Option<f64>,
    /// Unit.
    pub unit: String,
}

/// Everything about one test to store.
#[derive(Debug, Clone, Serialize)]
pub struct NewTest {
    /// Machine name.
    pub machine: String,
    /// Axis name.
    pub axis: String,
    /// Axis parameters as JSON.
    pub axis_params_json: String,
    /// Test time, RFC 3339 UTC.
    pub time_utc: String,
    /// Test time (s since the Unix epoch).
    pub time_s: f64,
    /// Kind of test.
    pub kind: TestKind,
    /// Source trace path as given.
    pub source: String,
    /// SHA-256 of the trace file's bytes (hex).
    pub content_sha256: String,
    /// NC program used, if known.
    pub program: Option<String>,
    /// Reference test of its axis (baseline).
    pub reference: bool,
    /// Compensation table the test was run with, if any (path or id).
    pub compensation_ref: Option<String>,
    /// Identified parameters (triangle tests).
    pub identified: Option<Identified>,
    /// Mean friction per interval (stroke tests).
    pub intervals: Vec<IntervalRow>,
    /// Significant components (stroke tests).
    pub components: Vec<ComponentRow>,
    /// Indicator values.
    pub indicators: Vec<IndicatorRow>,
    /// Curves for the report (JSON): friction profile with IAFV, spectra, Stribeck curve.
    pub curves_json: Option<String>,
}

/// Result of [`Store::add`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AddOutcome {
    /// Stored under this id.
    Added(i64),
    /// The same trace content was already stored for this axis and kind under this id.
    Duplicate(i64),
}

/// A stored test as listed.
#[derive(Debug, Clone, Serialize)]
pub struct TestRow {
    /// Test id.
    pub id: i64,
    /// Machine name.
    pub machine: String,
    /// Axis name.
    pub axis: String,
    /// Test time, RFC 3339 UTC.
    pub time_utc: String,
    /// Test time (s since the Unix epoch).
    pub time_s: f64,
    /// `strokes` or `triangle`.
    pub kind: String,
    /// Source trace.
    pub source: String,
    /// SHA-256 of the trace.
    pub content_sha256: String,
    /// NC program.
    pub program: Option<String>,
    /// Reference test.
    pub reference: bool,
    /// Compensation table reference.
    pub compensation_ref: Option<String>,
    /// When it was added (RFC 3339 UTC).
    pub added_utc: String,
}

/// A stored test with its results.
#[derive(Debug, Clone, Serialize)]
pub struct TestDetail {
    /// The test.
    #[serde(flatten)]
    pub test: TestRow,
    /// Identified parameters.
    pub identified: Option<Identified>,
    /// Mean friction per interval.
    pub intervals: Vec<IntervalRow>,
    /// Significant components.
    pub components: Vec<ComponentRow>,
    /// Indicator values.
    pub indicators: Vec<IndicatorRow>,
}

/// Which tests to list.
#[derive(Debug, Clone, Default)]
pub struct Filter {
    /// Only this machine.
    pub machine: Option<String>,
    /// Only this axis.
    pub axis: Option<String>,
}

/// One indicator's series, with the test id of each point.
pub type Series = Vec<(i64, Point)>;

/// The operations the CLI needs; SQL stays behind it.
pub trait Store {
    /// Store a test with its results in one transaction; a trace already stored for the
    /// axis and kind is not stored again.
    fn add(&mut self, t: &NewTest) -> Result<AddOutcome, StoreError>;
    /// Tests in time order.
    fn list(&self, f: &Filter) -> Result<Vec<TestRow>, StoreError>;
    /// One test with its results.
    fn get(&self, id: i64) -> Result<TestDetail, StoreError>;
    /// Remove a test and its results; `false` when there was none.
    fn remove(&mut self, id: i64) -> Result<bool, StoreError>;
    /// Every indicator of an axis, each in time order.
    fn series(&self, machine: &str, axis: &str) -> Result<BTreeMap<String, Series>, StoreError>;
    /// The report curves of a test.
    fn curves(&self, id: i64) -> Result<Option<String>, StoreError>;
    /// The axis parameters (JSON of the axis file) last stored for an axis.
    fn axis_params(&self, machine: &str, axis: &str) -> Result<Option<String>, StoreError>;
    /// Integrity check; `Ok(())` when the file is sound.
    fn check(&self) -> Result<(), StoreError>;
}
