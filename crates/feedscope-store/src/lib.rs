//! The condition-history store of feedscope: every test of every axis with its analysis
//! results, and the indicator series the trends are computed from.
//!
//! # The layers
//! ```text
//!   feedscope           maths: estimation, fits, identification, the twin
//!       ↑
//!   feedscope-io        files       feedscope-store   the condition history     ← this crate: the store
//!   feedscope-live      live sources (MTConnect, OPC UA)
//!       ↑
//!   feedscope-app       use cases: Request → run → Report
//!       ↑
//!   feedscope-cli (`feedscope`), feedscope-py (`import feedscope`), a server
//! ```
//!
//! # Example
//! ```
//! use feedscope_store::{AddOutcome, Filter, NewTest, SqliteStore, Store, Stored, TestKind};
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let dir = tempfile::tempdir()?;
//! let mut store = SqliteStore::open(&dir.path().join("history.db"))?;
//! let test = NewTest {
//!     machine: "lathe 3".into(),
//!     axis: "Z".into(),
//!     axis_params: Stored::from_json("{}"),
//!     time_utc: "2026-01-05T08:00:00Z".into(),
//!     time_s: feedscope_store::time::parse_rfc3339("2026-01-05T08:00:00Z").unwrap(),
//!     kind: TestKind::Triangle,
//!     source: "week-01.csv".into(),
//!     content_sha256: "00".repeat(32),
//!     program: None,
//!     reference: false,
//!     compensation_ref: None,
//!     identified: None,
//!     intervals: vec![],
//!     components: vec![],
//!     indicators: vec![],
//!     curves: None,
//! };
//! let AddOutcome::Added(id) = store.add(&test)? else { unreachable!("a fresh database") };
//! // The same trace content again is recognised, not stored twice.
//! assert_eq!(store.add(&test)?, AddOutcome::Duplicate(id));
//! let rows = store.list(&Filter::default())?;
//! assert_eq!(rows.len(), 1);
//! assert_eq!(rows[0].kind, TestKind::Triangle);
//! assert_eq!(store.get(id)?.test.source, "week-01.csv");
//! // `{}` is no axis file (its required keys are missing): kept as it was, with the reason.
//! let Some(Stored::Unread { json, .. }) = store.axis_params("lathe 3", "Z")? else {
//!     unreachable!("an empty document")
//! };
//! assert_eq!(json, "{}");
//! # Ok(())
//! # }
//! ```
//!
//! Callers talk to the [`Store`] trait, which two backends implement: [`SqliteStore`] (one
//! file, WAL journal, versioned schema) and [`PgStore`] (a PostgreSQL database shared by a
//! fleet's gateways, the same logical schema, many writers at once); both are documented in
//! docs/history.md. No method and no row type mentions an engine's type, and engine errors
//! reach callers as a [`BackendError`] classified by [`BackendErrorKind`].
#![warn(missing_docs)]
#![deny(clippy::float_cmp)]
use std::collections::BTreeMap;
use std::fmt;

use feedscope::axis::AxisParams;
use feedscope::history::Point;
use feedscope::study::Curves;
use feedscope::ErrorKind;
use serde::de::DeserializeOwned;
use serde::Serialize;

mod from_study;
pub use from_study::content_sha256;
pub mod postgres;
pub mod sqlite;
pub mod time;

pub use postgres::PgStore;
pub use sqlite::{OpenOptions, SqliteStore};

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
    /// The integrity check failed (SQLite's `PRAGMA integrity_check`, or for PostgreSQL the
    /// schema version, tables and constraints that [`Store::check`] verifies).
    #[error("{path} failed the integrity check ({detail}); it was not modified")]
    Corrupt {
        /// The file.
        path: String,
        /// First message of `PRAGMA integrity_check`.
        detail: String,
    },
    /// A database schema that holds another application's tables and no feedscope schema
    /// version (PostgreSQL; left untouched).
    #[error(
        "{path}: schema {schema:?} holds {tables} tables of another application (e.g. {example:?}) \
         and no feedscope schema version; it was not modified (give an empty database or \
         schema)"
    )]
    ForeignSchema {
        /// The store (a URL without its password).
        path: String,
        /// The database schema (PostgreSQL: the first of the `search_path`).
        schema: String,
        /// Number of tables in it.
        tables: i64,
        /// One of them.
        example: String,
    },
    /// The address of the store cannot be used as given: a malformed URL, or an option this
    /// build does not support (TLS); nothing was contacted.
    #[error("{path}: {detail}")]
    BadAddress {
        /// The address as given (without its password).
        path: String,
        /// What is wrong with it.
        detail: String,
    },
    /// No such test.
    #[error("no test with id {0}")]
    NoSuchTest(i64),
    /// The folder the database file would be in does not exist (nothing was created).
    #[error("{path}: the folder {folder} does not exist; create it first or choose another --db")]
    NoFolder {
        /// The database file asked for.
        path: String,
        /// Its parent folder, which is missing.
        folder: String,
    },
    /// Another process held a lock on the database for longer than the busy timeout
    /// ([`sqlite::OpenOptions::busy_timeout`]); nothing was written.
    #[error(
        "{path} is busy: another process holds its write lock (another feedscope adding or \
         removing a test, or a program with a write transaction open on it); gave up after \
         waiting {waited_s:.1} s{}",
        hint.as_ref().map(|h| format!("; {h}")).unwrap_or_default()
    )]
    Busy {
        /// The file.
        path: String,
        /// How long it waited (s).
        waited_s: f64,
        /// How to wait longer, as the caller put it ([`sqlite::OpenOptions::busy_hint`]).
        hint: Option<String>,
    },
    /// The connection to the database server failed while a transaction's `COMMIT` was
    /// under way (sent, or about to be, with no answer): the server may have committed it or
    /// not, and nothing here can tell which (PostgreSQL only; SQLite commits in-process).
    /// Look at the store to find out; [`Store::add`] again is safe, as the same trace is
    /// never stored twice.
    #[error("{path}: connection lost during COMMIT, outcome unknown")]
    CommitUnknown {
        /// The store (a URL without its password).
        path: String,
        /// What the connection said (closed, an I/O error, the server shutting down).
        #[source]
        error: BackendError,
    },
    /// The database engine said no (its message unchanged).
    #[error(transparent)]
    Backend(#[from] BackendError),
    /// File system.
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

impl StoreError {
    /// `true` when the user pointed at the wrong file (exit code 2): every variant that names
    /// the file or the test but [`StoreError::Busy`] and [`StoreError::CommitUnknown`], and an
    /// engine error of kind [`BackendErrorKind::NotADatabase`] or
    /// [`BackendErrorKind::Corrupt`]; other engine errors and file-system errors are not.
    pub fn is_bad_input(&self) -> bool {
        self.kind() == ErrorKind::BadInput
    }

    /// What the error means to a caller: [`ErrorKind::BadInput`] as
    /// [`is_bad_input`](Self::is_bad_input) says; [`ErrorKind::Io`] for file-system errors,
    /// engine errors of kind [`BackendErrorKind::Other`] (a full disk),
    /// [`StoreError::Busy`] (another process's lock: not the input's fault) and
    /// [`StoreError::CommitUnknown`] (a connection lost during `COMMIT`).
    pub fn kind(&self) -> ErrorKind {
        match self {
            StoreError::Busy { .. } | StoreError::CommitUnknown { .. } => ErrorKind::Io,
            StoreError::Backend(e) => match e.kind() {
                BackendErrorKind::NotADatabase | BackendErrorKind::Corrupt => ErrorKind::BadInput,
                BackendErrorKind::Other => ErrorKind::Io,
            },
            StoreError::Io(_) => ErrorKind::Io,
            StoreError::NotADatabase { .. }
            | StoreError::Foreign { .. }
            | StoreError::ForeignSchema { .. }
            | StoreError::BadAddress { .. }
            | StoreError::NewerSchema { .. }
            | StoreError::Corrupt { .. }
            | StoreError::NoSuchTest(_)
            | StoreError::NoFolder { .. } => ErrorKind::BadInput,
        }
    }
}

/// What an engine error means to a caller, whatever the engine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum BackendErrorKind {
    /// The engine does not recognise the file or database as one of its own
    /// (SQLite: `SQLITE_NOTADB`; PostgreSQL: the database does not exist or refuses the
    /// user of the URL, SQLSTATE 3D000, 28000, 28P01).
    NotADatabase,
    /// The engine found the database damaged (SQLite: `SQLITE_CORRUPT`), or its content does
    /// not fit the schema its version promises (a table or column missing, a value of the
    /// wrong type).
    Corrupt,
    /// Anything else: a full disk, an I/O failure inside the engine, a violated constraint,
    /// a database server that cannot be reached. (A lock held beyond the busy timeout is
    /// [`StoreError::Busy`].)
    Other,
}

/// An error of the database engine behind a [`Store`], kept whole and classified.
///
/// Its `Display` and `source` are those of the engine's error, so messages read exactly as the
/// engine wrote them; [`kind`](Self::kind) is what callers decide on (see
/// [`StoreError::is_bad_input`]). The engine's own error stays reachable through
/// [`get_ref`](Self::get_ref) for a caller that knows the backend and wants to downcast
/// (`rusqlite::Error` for [`SqliteStore`]).
#[derive(Debug)]
pub struct BackendError {
    kind: BackendErrorKind,
    error: Box<dyn std::error::Error + Send + Sync + 'static>,
}

impl BackendError {
    /// Wrap an engine's error with its classification; for backends.
    pub fn new<E>(kind: BackendErrorKind, error: E) -> Self
    where
        E: Into<Box<dyn std::error::Error + Send + Sync + 'static>>,
    {
        Self {
            kind,
            error: error.into(),
        }
    }

    /// What the error means to a caller.
    pub fn kind(&self) -> BackendErrorKind {
        self.kind
    }

    /// The engine's own error.
    pub fn get_ref(&self) -> &(dyn std::error::Error + Send + Sync + 'static) {
        &*self.error
    }
}

/// The kind of one error of a chain when it is this crate's: a [`StoreError`] says its own;
/// a [`BackendError`] on its own is bad input when the file is not a database of ours or is
/// damaged, else an I/O failure. `None` for any other type (the library's and `feedscope-io`'s
/// are classified by their crates).
pub fn error_kind(e: &(dyn std::error::Error + 'static)) -> Option<ErrorKind> {
    if let Some(x) = e.downcast_ref::<StoreError>() {
        return Some(x.kind());
    }
    e.downcast_ref::<BackendError>().map(|b| match b.kind() {
        BackendErrorKind::NotADatabase | BackendErrorKind::Corrupt => ErrorKind::BadInput,
        _ => ErrorKind::Io,
    })
}

impl fmt::Display for BackendError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.error.fmt(f)
    }
}

impl std::error::Error for BackendError {
    // Transparent, like the engine's error itself: its source, not the error again (the
    // message is already this error's own).
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.error.source()
    }
}

/// Kind of test (the library's; stored as [`TestKind::as_str`]).
pub use feedscope::study::TestKind;

/// A document the store keeps as JSON (a test's report curves, an axis file's parameters),
/// typed when this version of feedscope reads it.
///
/// A document written by another version in a shape this one does not read (a key it does
/// not know) is kept exactly as it was, with the reason: nothing is lost or re-shaped, a
/// migration copies it whole, and a reader decides what to do without it. Serialised as the
/// document itself.
#[derive(Debug, Clone, PartialEq)]
pub enum Stored<T> {
    /// Read as this version's type.
    Read(T),
    /// Not readable as this version's type.
    Unread {
        /// The document as stored.
        json: String,
        /// Why it does not read (serde's message, with line and column).
        reason: String,
    },
}

impl<T: Serialize + DeserializeOwned> Stored<T> {
    /// The document `json` as stored: typed when it reads as `T`, else kept as it is.
    pub fn from_json(json: &str) -> Self {
        match serde_json::from_str(json) {
            Ok(v) => Stored::Read(v),
            Err(e) => Stored::Unread {
                json: json.to_string(),
                reason: e.to_string(),
            },
        }
    }

    /// The document to store: `T` as JSON, or an unread document unchanged.
    pub fn to_json(&self) -> String {
        match self {
            // Plain data with string keys: serialising cannot fail (a NaN becomes null).
            Stored::Read(v) => serde_json::to_string(v).expect("a stored document as JSON"),
            Stored::Unread { json, .. } => json.clone(),
        }
    }

    /// The typed document, when it read.
    pub fn read(&self) -> Option<&T> {
        match self {
            Stored::Read(v) => Some(v),
            Stored::Unread { .. } => None,
        }
    }

    /// [`read`](Self::read), by value.
    pub fn into_read(self) -> Option<T> {
        match self {
            Stored::Read(v) => Some(v),
            Stored::Unread { .. } => None,
        }
    }
}

impl<T> From<T> for Stored<T> {
    fn from(v: T) -> Self {
        Stored::Read(v)
    }
}

impl<T: Serialize> Serialize for Stored<T> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Stored::Read(v) => v.serialize(s),
            // As the JSON it is; a document that is not JSON at all as its text.
            Stored::Unread { json, .. } => match serde_json::from_str::<serde_json::Value>(json) {
                Ok(v) => v.serialize(s),
                Err(_) => s.serialize_str(json),
            },
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
    /// The whole stroke (`all`) or a segment number.
    pub segment: feedscope::order::Segment,
    /// Segment centre (mm).
    pub position_mm: f64,
    /// Order (cycles per lead).
    pub order: f64,
    /// Amplitude (N).
    pub amplitude_n: f64,
    /// Local noise floor (N).
    pub floor_n: f64,
    /// Classified cause.
    pub cause: feedscope::order::Cause,
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
    /// The axis file's parameters.
    pub axis_params: Stored<AxisParams>,
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
    /// Curves for the report (stroke tests): friction profiles with IAFV, spectra, the data
    /// verdict, the position-grid profile.
    pub curves: Option<Stored<Curves>>,
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
    /// Kind of test (`strokes` or `triangle` in JSON).
    pub kind: TestKind,
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

/// One machine/axis series of a store, as [`Store::axes`] lists it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct AxisSeries {
    /// Machine name.
    pub machine: String,
    /// Axis name.
    pub axis: String,
    /// Tests stored for it.
    pub tests: usize,
}

/// One indicator's series, with the test id of each point.
pub type Series = Vec<(i64, Point)>;

/// The operations on a condition history; the engine (SQL or other) stays behind it.
///
/// Every method takes and returns the typed rows of this crate; an implementation maps engine
/// errors to [`StoreError::Backend`] with the [`BackendErrorKind`] that fits.
pub trait Store {
    /// Store a test with its results in one transaction; a trace already stored for the
    /// axis and kind (same `content_sha256`) is not stored again. Machine and axis are
    /// created on first use; the axis parameters are replaced by those of the new test.
    /// With `t.reference` the new test becomes the only reference of its axis.
    fn add(&mut self, t: &NewTest) -> Result<AddOutcome, StoreError>;
    /// [`add`](Self::add) a test copied from another store, keeping the time it was first
    /// added there (`added_utc`, RFC 3339 UTC) instead of stamping the present time; for
    /// copying a history between stores (`feedscope history migrate`).
    ///
    /// Provided as [`add`](Self::add), which stamps the present time; both backends of this
    /// crate keep `added_utc`.
    fn add_copy(&mut self, t: &NewTest, added_utc: &str) -> Result<AddOutcome, StoreError> {
        let _ = added_utc;
        self.add(t)
    }
    /// Tests ordered by machine, axis, time and id.
    fn list(&self, f: &Filter) -> Result<Vec<TestRow>, StoreError>;
    /// One test with its results.
    ///
    /// # Errors
    /// [`StoreError::NoSuchTest`] when there is no test `id`.
    fn get(&self, id: i64) -> Result<TestDetail, StoreError>;
    /// Remove a test and its results; `false` when there was none.
    fn remove(&mut self, id: i64) -> Result<bool, StoreError>;
    /// Mark a test as the reference (baseline) of its axis, clearing any other.
    ///
    /// # Errors
    /// [`StoreError::NoSuchTest`] when there is no test `id`.
    fn set_reference(&mut self, id: i64) -> Result<(), StoreError>;
    /// Every indicator of an axis by name, each ordered by time and test id.
    fn series(&self, machine: &str, axis: &str) -> Result<BTreeMap<String, Series>, StoreError>;
    /// The report curves of a test, if it has any.
    fn curves(&self, id: i64) -> Result<Option<Stored<Curves>>, StoreError>;
    /// The axis file's parameters last stored for an axis, if the axis is known.
    fn axis_params(
        &self,
        machine: &str,
        axis: &str,
    ) -> Result<Option<Stored<AxisParams>>, StoreError>;
    /// Every machine/axis series with its number of tests, ordered by machine and axis.
    ///
    /// Provided from [`Store::list`]; a backend may answer it more cheaply.
    fn axes(&self) -> Result<Vec<AxisSeries>, StoreError> {
        let mut out: Vec<AxisSeries> = Vec::new();
        // `list` orders by machine and axis, so one pass groups them.
        for t in self.list(&Filter::default())? {
            match out.last_mut() {
                Some(a) if a.machine == t.machine && a.axis == t.axis => a.tests += 1,
                _ => out.push(AxisSeries {
                    machine: t.machine,
                    axis: t.axis,
                    tests: 1,
                }),
            }
        }
        Ok(out)
    }
    /// Integrity check; `Ok(())` when the database is sound.
    ///
    /// # Errors
    /// [`StoreError::Corrupt`] naming the first problem found.
    fn check(&self) -> Result<(), StoreError>;
}
