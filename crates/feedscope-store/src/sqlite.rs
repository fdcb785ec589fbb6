//! SQLite backend of the [`Store`]: one file, WAL journal, versioned schema.
//!
//! Opening never writes to a file it does not recognise: a non-empty file must carry the
//! SQLite header, and an SQLite file must either be empty of tables or carry feedscope's
//! `application_id`; both are checked on a read-only connection before the read-write one
//! is opened. Every `add` is one `BEGIN IMMEDIATE` transaction (so two writers queue on the
//! busy timeout instead of deadlocking on a lock upgrade).
//!
//! Opening takes the write lock only when the schema must be migrated: the version is read
//! first without a lock (WAL readers never wait for a writer) and read again inside the
//! migration's transaction, so a reader opens and answers while another process writes.
//! A writer that finds the lock held waits up to [`OpenOptions::busy_timeout`], tells the
//! caller once through [`OpenOptions::on_wait`] when the wait is not short, and then fails with
//! [`StoreError::Busy`].
use std::collections::BTreeMap;
use std::fmt;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use feedscope::history::Point;
use rusqlite::{params, Connection, OpenFlags, OptionalExtension, TransactionBehavior};

use super::{
    AddOutcome, BackendError, BackendErrorKind, ComponentRow, Filter, Identified, IndicatorRow,
    IntervalRow, NewTest, Series, Store, StoreError, Stored, TestDetail, TestRow,
};
use feedscope::axis::AxisParams;
use feedscope::study::Curves;

/// SQLite's error codes as [`BackendErrorKind`]s: a file SQLite does not recognise or finds
/// damaged is the user's wrong file; everything else is a failure of the operation.
///
/// A file whose content does not fit feedscope's schema although it carries feedscope's
/// application id and passed the quick check (a table or column missing, a value of the wrong
/// type in a column) is damaged too: every statement of this backend is fixed and tested
/// against the schema, so only the file can be wrong.
impl From<rusqlite::Error> for BackendError {
    fn from(e: rusqlite::Error) -> Self {
        let kind = match e.sqlite_error_code() {
            Some(rusqlite::ErrorCode::NotADatabase) => BackendErrorKind::NotADatabase,
            Some(rusqlite::ErrorCode::DatabaseCorrupt) => BackendErrorKind::Corrupt,
            Some(rusqlite::ErrorCode::Unknown) if schema_mismatch(&e) => BackendErrorKind::Corrupt,
            _ => match e {
                rusqlite::Error::InvalidColumnType(..)
                | rusqlite::Error::FromSqlConversionFailure(..)
                | rusqlite::Error::IntegralValueOutOfRange(..)
                | rusqlite::Error::Utf8Error(..) => BackendErrorKind::Corrupt,
                _ => BackendErrorKind::Other,
            },
        };
        BackendError::new(kind, e)
    }
}

/// Column `col` of a row as a typed label (segment, cause) written as text.
fn label<T>(r: &rusqlite::Row<'_>, col: usize) -> rusqlite::Result<T>
where
    T: std::str::FromStr,
    T::Err: std::error::Error + Send + Sync + 'static,
{
    let text: String = r.get(col)?;
    text.parse().map_err(|e| {
        rusqlite::Error::FromSqlConversionFailure(col, rusqlite::types::Type::Text, Box::new(e))
    })
}

/// `SQLITE_ERROR` saying that a table or column of the schema is not there.
fn schema_mismatch(e: &rusqlite::Error) -> bool {
    match e {
        rusqlite::Error::SqliteFailure(_, Some(msg)) => {
            msg.starts_with("no such table") || msg.starts_with("no such column")
        }
        _ => false,
    }
}

/// `SQLITE_BUSY` or `SQLITE_LOCKED`: another connection holds a lock we need.
fn is_busy(e: &StoreError) -> bool {
    let StoreError::Backend(b) = e else {
        return false;
    };
    b.get_ref()
        .downcast_ref::<rusqlite::Error>()
        .and_then(rusqlite::Error::sqlite_error_code)
        .is_some_and(|c| {
            matches!(
                c,
                rusqlite::ErrorCode::DatabaseBusy | rusqlite::ErrorCode::DatabaseLocked
            )
        })
}

impl From<rusqlite::Error> for StoreError {
    fn from(e: rusqlite::Error) -> Self {
        StoreError::Backend(e.into())
    }
}

/// `PRAGMA application_id` of a feedscope database: ASCII "FSCP".
pub const APPLICATION_ID: i64 = 0x4653_4350;

/// Migrations in order; migration k (0-based) takes the schema from version k to k + 1.
/// `PRAGMA user_version` holds the version. Never edit a released migration: append one.
const MIGRATIONS: &[&str] = &[r#"
CREATE TABLE machines (
    id    INTEGER PRIMARY KEY,
    name  TEXT NOT NULL UNIQUE
);
CREATE TABLE axes (
    id           INTEGER PRIMARY KEY,
    machine_id   INTEGER NOT NULL REFERENCES machines(id),
    name         TEXT NOT NULL,
    params_json  TEXT NOT NULL,
    UNIQUE (machine_id, name)
);
CREATE TABLE tests (
    id                 INTEGER PRIMARY KEY,
    axis_id            INTEGER NOT NULL REFERENCES axes(id),
    time_utc           TEXT NOT NULL,
    time_s             REAL NOT NULL,
    kind               TEXT NOT NULL CHECK (kind IN ('strokes', 'triangle')),
    source             TEXT NOT NULL,
    content_sha256     TEXT NOT NULL,
    program            TEXT,
    reference          INTEGER NOT NULL DEFAULT 0 CHECK (reference IN (0, 1)),
    compensation_ref   TEXT,
    added_utc          TEXT NOT NULL,
    feedscope_version  TEXT NOT NULL,
    UNIQUE (axis_id, kind, content_sha256)
);
CREATE INDEX tests_axis_time ON tests (axis_id, time_s);
CREATE TABLE identified (
    test_id              INTEGER PRIMARY KEY REFERENCES tests(id) ON DELETE CASCADE,
    j_total_kgm2         REAL NOT NULL,
    j_std_kgm2           REAL,
    fc_n                 REAL NOT NULL,
    fc_std_n             REAL,
    fs_n                 REAL NOT NULL,
    fs_std_n             REAL,
    sigma_n_s_per_m      REAL NOT NULL,
    sigma_std_n_s_per_m  REAL,
    vs_mm_min            REAL NOT NULL,
    vs_std_mm_min        REAL,
    delta                REAL NOT NULL,
    offset_n             REAL NOT NULL,
    residual_rms_nm      REAL NOT NULL,
    samples_used         INTEGER NOT NULL
);
CREATE TABLE interval_friction (
    test_id    INTEGER NOT NULL REFERENCES tests(id) ON DELETE CASCADE,
    direction  TEXT NOT NULL CHECK (direction IN ('forward', 'backward')),
    start_mm   REAL NOT NULL,
    end_mm     REAL NOT NULL,
    mean_n     REAL NOT NULL,
    std_n      REAL NOT NULL,
    samples    INTEGER NOT NULL,
    PRIMARY KEY (test_id, direction, start_mm)
);
CREATE TABLE components (
    id           INTEGER PRIMARY KEY,
    test_id      INTEGER NOT NULL REFERENCES tests(id) ON DELETE CASCADE,
    direction    TEXT NOT NULL CHECK (direction IN ('forward', 'backward')),
    segment      TEXT NOT NULL,
    position_mm  REAL NOT NULL,
    order_cpl    REAL NOT NULL,
    amplitude_n  REAL NOT NULL,
    floor_n      REAL NOT NULL,
    cause        TEXT NOT NULL,
    trusted      INTEGER NOT NULL
);
CREATE INDEX components_test ON components (test_id);
CREATE TABLE indicators (
    test_id    INTEGER NOT NULL REFERENCES tests(id) ON DELETE CASCADE,
    name       TEXT NOT NULL,
    value      REAL NOT NULL,
    std_error  REAL,
    unit       TEXT NOT NULL,
    PRIMARY KEY (test_id, name)
) WITHOUT ROWID;
CREATE INDEX indicators_name ON indicators (name, test_id);
CREATE TABLE curves (
    test_id  INTEGER PRIMARY KEY REFERENCES tests(id) ON DELETE CASCADE,
    json     TEXT NOT NULL
);
"#];

/// Newest schema version this build writes.
pub const SCHEMA_VERSION: i64 = MIGRATIONS.len() as i64;

/// A wait for the lock shorter than this is not reported through [`OpenOptions::on_wait`]:
/// two writers routinely queue for a few milliseconds.
const QUIET_WAIT: Duration = Duration::from_millis(500);

/// Called once per wait for another process's lock, with the database and the longest time
/// the wait will last.
pub type OnWait = dyn Fn(&Path, Duration) + Send + Sync;

/// How [`SqliteStore::open_with`] waits for another process that holds the database's write
/// lock.
///
/// ```
/// use std::time::Duration;
/// use feedscope_store::sqlite::OpenOptions;
///
/// let opts = OpenOptions::default()
///     .busy_timeout(Duration::from_secs(5))
///     .on_wait(|path, up_to| eprintln!("{} is busy; waiting up to {up_to:?}", path.display()))
///     .busy_hint("set MY_TIMEOUT to wait longer");
/// assert_eq!(opts.timeout(), Duration::from_secs(5));
/// ```
#[derive(Clone)]
pub struct OpenOptions {
    busy_timeout: Duration,
    on_wait: Option<Arc<OnWait>>,
    busy_hint: Option<String>,
}

impl Default for OpenOptions {
    /// Wait up to 30 s, silently, with no hint.
    fn default() -> Self {
        Self {
            busy_timeout: Duration::from_secs(30),
            on_wait: None,
            busy_hint: None,
        }
    }
}

impl fmt::Debug for OpenOptions {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("OpenOptions")
            .field("busy_timeout", &self.busy_timeout)
            .field("on_wait", &self.on_wait.as_ref().map(|_| "Fn"))
            .field("busy_hint", &self.busy_hint)
            .finish()
    }
}

impl OpenOptions {
    /// How long an operation waits for another process's lock before [`StoreError::Busy`]
    /// (default 30 s; zero fails at once).
    #[must_use]
    pub fn busy_timeout(mut self, timeout: Duration) -> Self {
        self.busy_timeout = timeout;
        self
    }

    /// Called once when a wait for the lock lasts longer than half a second, with the
    /// database path and the busy timeout; e.g. to tell the user why nothing happens.
    #[must_use]
    pub fn on_wait(mut self, f: impl Fn(&Path, Duration) + Send + Sync + 'static) -> Self {
        self.on_wait = Some(Arc::new(f));
        self
    }

    /// Advice appended to the message of [`StoreError::Busy`]: how the user waits longer.
    #[must_use]
    pub fn busy_hint(mut self, hint: impl Into<String>) -> Self {
        self.busy_hint = Some(hint.into());
        self
    }

    /// The busy timeout in force.
    pub fn timeout(&self) -> Duration {
        self.busy_timeout
    }
}

/// Install the busy handler of `opts` on `conn`: sleep and retry until the timeout, report a
/// wait longer than [`QUIET_WAIT`] once. Returns where the handler records how long the last
/// wait lasted (ms), for [`StoreError::Busy`].
fn install_busy_handler(
    conn: &mut Connection,
    path: &Path,
    opts: &OpenOptions,
) -> Result<Arc<AtomicU64>, StoreError> {
    let waited_ms = Arc::new(AtomicU64::new(0));
    let record = Arc::clone(&waited_ms);
    let timeout = opts.busy_timeout;
    let on_wait = opts.on_wait.clone();
    let path = path.to_path_buf();
    let mut start = Instant::now();
    let mut told = false;
    conn.busy_handler(Some(move |count: i32| -> bool {
        // `count` is 0 at the first retry of each new wait.
        if count == 0 {
            start = Instant::now();
            told = false;
        }
        let waited = start.elapsed();
        record.store(
            u64::try_from(waited.as_millis()).unwrap_or(u64::MAX),
            Ordering::Relaxed,
        );
        if waited >= timeout {
            return false;
        }
        if !told && waited >= QUIET_WAIT {
            told = true;
            if let Some(f) = &on_wait {
                f(&path, timeout);
            }
        }
        std::thread::sleep(retry_step(count).min(timeout - waited));
        true
    }))?;
    Ok(waited_ms)
}

/// The sleep before retry `count` (0-based) of one wait for a lock: short sleeps first (a
/// queued writer usually gets the lock within milliseconds), then 50 ms, so that the delay
/// between the lock's release and the retry stays small.
fn retry_step(count: i32) -> Duration {
    Duration::from_millis(match count {
        0..=4 => 2,
        5..=9 => 10,
        _ => 50,
    })
}

/// A feedscope database in one SQLite file.
///
/// Test hook: when the environment variable `FEEDSCOPE_TEST_SLEEP_IN_TX_MS` holds a number,
/// [`Store::add`] sleeps that many milliseconds inside its open transaction (and says so on
/// stderr), so that a test can kill the process there.
pub struct SqliteStore {
    conn: Connection,
    path: PathBuf,
    busy_hint: Option<String>,
    waited_ms: Arc<AtomicU64>,
}

/// Look at an existing file without writing to it.
fn probe(path: &Path, opts: &OpenOptions) -> Result<(), StoreError> {
    let shown = path.display().to_string();
    let len = match std::fs::metadata(path) {
        Ok(m) => m.len(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            // SQLite would only say "unable to open database file".
            return match path.parent() {
                Some(dir) if !dir.as_os_str().is_empty() && !dir.is_dir() => {
                    Err(StoreError::NoFolder {
                        path: shown,
                        folder: dir.display().to_string(),
                    })
                }
                _ => Ok(()),
            };
        }
        Err(e) => return Err(e.into()),
    };
    if len == 0 {
        return Ok(());
    }
    let mut head = [0u8; 16];
    let mut f = std::fs::File::open(path)?;
    if f.read_exact(&mut head).is_err() || &head != b"SQLite format 3\0" {
        return Err(StoreError::NotADatabase { path: shown });
    }
    let mut c = Connection::open_with_flags(
        path,
        OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX,
    )?;
    install_busy_handler(&mut c, path, opts)?;
    let app: i64 = c.query_row("PRAGMA application_id", [], |r| r.get(0))?;
    let version: i64 = c.query_row("PRAGMA user_version", [], |r| r.get(0))?;
    let tables: i64 = c.query_row(
        "SELECT count(*) FROM sqlite_schema WHERE type = 'table'",
        [],
        |r| r.get(0),
    )?;
    if app != APPLICATION_ID && !(app == 0 && tables == 0) {
        return Err(StoreError::Foreign {
            path: shown,
            application_id: app,
            tables,
        });
    }
    if version > SCHEMA_VERSION {
        return Err(StoreError::NewerSchema {
            path: shown,
            found: version,
            supported: SCHEMA_VERSION,
        });
    }
    // The application id and the version are set in the same transaction: one without the
    // other is a damaged header, and migrating would only fail on the existing tables.
    if app == APPLICATION_ID && version == 0 {
        return Err(StoreError::Corrupt {
            path: shown,
            detail: "damaged header: feedscope's application id with schema version 0".into(),
        });
    }
    // Damaged pages show here, before anything is written.
    let detail: String = c.query_row("PRAGMA quick_check(1)", [], |r| r.get(0))?;
    if detail != "ok" {
        return Err(StoreError::Corrupt {
            path: shown,
            detail,
        });
    }
    Ok(())
}

impl SqliteStore {
    /// Open (creating it when missing) and migrate to [`SCHEMA_VERSION`].
    ///
    /// # Errors
    /// A file that is not SQLite, an SQLite file of another application, a newer schema or a
    /// failed quick check: the file is not modified.
    pub fn open(path: &Path) -> Result<Self, StoreError> {
        Self::open_with(path, &OpenOptions::default())
    }

    /// [`open`](Self::open) with the busy timeout and wait report of `opts`.
    ///
    /// # Errors
    /// As [`open`](Self::open); [`StoreError::Busy`] when the schema must be created or
    /// migrated and another process holds the write lock beyond the busy timeout.
    pub fn open_with(path: &Path, opts: &OpenOptions) -> Result<Self, StoreError> {
        let busy = |e: StoreError| busy_error(e, path, opts.busy_hint.as_deref(), opts.timeout());
        probe(path, opts).map_err(busy)?;
        let mut conn = Connection::open(path)?;
        let waited_ms = install_busy_handler(&mut conn, path, opts)?;
        let mut s = Self {
            conn,
            path: path.to_path_buf(),
            busy_hint: opts.busy_hint.clone(),
            waited_ms,
        };
        s.setup(opts).map_err(|e| s.busy(e))?;
        Ok(s)
    }

    fn setup(&mut self, opts: &OpenOptions) -> Result<(), StoreError> {
        // WAL: readers do not block the writer; NORMAL sync is safe against a killed
        // process (the WAL is replayed), only an OS crash can lose the last commits. On a file
        // already in WAL mode (every feedscope database but a new one) this takes no lock.
        self.enter_wal(opts)?;
        self.conn.pragma_update(None, "synchronous", "NORMAL")?;
        self.conn.pragma_update(None, "foreign_keys", "ON")?;
        self.migrate()
    }

    fn migrate(&mut self) -> Result<(), StoreError> {
        // Without a lock first: a current schema (every open but the first) needs no write.
        if self.schema_version()? == SCHEMA_VERSION {
            return Ok(());
        }
        let tx = self
            .conn
            .transaction_with_behavior(TransactionBehavior::Immediate)?;
        // Again under the lock: another process may have migrated meanwhile.
        let version: i64 = tx.query_row("PRAGMA user_version", [], |r| r.get(0))?;
        if version > SCHEMA_VERSION {
            return Err(StoreError::NewerSchema {
                path: self.path.display().to_string(),
                found: version,
                supported: SCHEMA_VERSION,
            });
        }
        // No version of feedscope writes a negative one (found by the `store` fuzz target: it
        // skipped every migration and stamped the file current).
        if version < 0 {
            return Err(StoreError::Corrupt {
                path: self.path.display().to_string(),
                detail: format!("schema version {version} is negative"),
            });
        }
        for (k, sql) in MIGRATIONS.iter().enumerate().skip(version as usize) {
            tx.execute_batch(sql).map_err(|e| {
                let e = StoreError::from(e);
                if e.is_bad_input() || is_busy(&e) {
                    return e;
                }
                // The tables of this version are not as the migration expects: the file's
                // version number or its schema was changed by something else.
                StoreError::Corrupt {
                    path: self.path.display().to_string(),
                    detail: format!("migration {k} -> {} failed: {e}", k + 1),
                }
            })?;
        }
        if version < SCHEMA_VERSION {
            tx.pragma_update(None, "user_version", SCHEMA_VERSION)?;
            tx.pragma_update(None, "application_id", APPLICATION_ID)?;
        }
        tx.commit()?;
        Ok(())
    }

    /// `PRAGMA journal_mode = WAL`, waiting for another process's lock as the busy handler
    /// would. SQLite does not call the busy handler here: the pragma holds a read lock while
    /// it asks for the exclusive one, and a reader that waits for a writer could deadlock, so
    /// SQLite answers `SQLITE_BUSY` at once when another connection holds the write lock of a
    /// file still in rollback-journal mode (a new file whose schema another program is
    /// creating). The same schedule, report and timeout as the busy handler apply; the time
    /// waited is recorded for [`StoreError::Busy`].
    fn enter_wal(&mut self, opts: &OpenOptions) -> Result<(), StoreError> {
        let start = Instant::now();
        let mut told = false;
        let mut count = 0;
        loop {
            let e = match self.conn.pragma_update(None, "journal_mode", "WAL") {
                Ok(()) => return Ok(()),
                Err(e) => StoreError::from(e),
            };
            let waited = start.elapsed();
            self.waited_ms.store(
                u64::try_from(waited.as_millis()).unwrap_or(u64::MAX),
                Ordering::Relaxed,
            );
            if !is_busy(&e) || waited >= opts.busy_timeout {
                return Err(e);
            }
            if !told && waited >= QUIET_WAIT {
                told = true;
                if let Some(f) = &opts.on_wait {
                    f(&self.path, opts.busy_timeout);
                }
            }
            std::thread::sleep(retry_step(count).min(opts.busy_timeout - waited));
            count = count.saturating_add(1);
        }
    }

    /// An engine error that is another process's lock as [`StoreError::Busy`].
    fn busy(&self, e: StoreError) -> StoreError {
        let waited = Duration::from_millis(self.waited_ms.load(Ordering::Relaxed));
        busy_error(e, &self.path, self.busy_hint.as_deref(), waited)
    }

    /// Schema version of the open file.
    pub fn schema_version(&self) -> Result<i64, StoreError> {
        Ok(self
            .conn
            .query_row("PRAGMA user_version", [], |r| r.get(0))?)
    }
}

/// `e` as [`StoreError::Busy`] when it is a lock held by another connection, else unchanged.
fn busy_error(e: StoreError, path: &Path, hint: Option<&str>, waited: Duration) -> StoreError {
    if is_busy(&e) {
        StoreError::Busy {
            path: path.display().to_string(),
            waited_s: waited.as_secs_f64(),
            hint: hint.map(str::to_string),
        }
    } else {
        e
    }
}

const TEST_COLS: &str = "t.id, m.name, a.name, t.time_utc, t.time_s, t.kind, t.source, \
    t.content_sha256, t.program, t.reference, t.compensation_ref, t.added_utc";

fn test_row(r: &rusqlite::Row<'_>) -> rusqlite::Result<TestRow> {
    Ok(TestRow {
        id: r.get(0)?,
        machine: r.get(1)?,
        axis: r.get(2)?,
        time_utc: r.get(3)?,
        time_s: r.get(4)?,
        kind: label(r, 5)?,
        source: r.get(6)?,
        content_sha256: r.get(7)?,
        program: r.get(8)?,
        reference: r.get::<_, i64>(9)? != 0,
        compensation_ref: r.get(10)?,
        added_utc: r.get(11)?,
    })
}

impl SqliteStore {
    fn add_tx(&mut self, t: &NewTest, added_utc: Option<&str>) -> Result<AddOutcome, StoreError> {
        // The documents as JSON before the write lock is taken: it is held no longer than
        // the statements take.
        let params_json = t.axis_params.to_json();
        let curves_json = t.curves.as_ref().map(|c| c.to_json());
        let tx = self
            .conn
            .transaction_with_behavior(TransactionBehavior::Immediate)?;
        tx.execute(
            "INSERT INTO machines (name) VALUES (?1) ON CONFLICT (name) DO NOTHING",
            [&t.machine],
        )?;
        let machine_id: i64 = tx.query_row(
            "SELECT id FROM machines WHERE name = ?1",
            [&t.machine],
            |r| r.get(0),
        )?;
        tx.execute(
            "INSERT INTO axes (machine_id, name, params_json) VALUES (?1, ?2, ?3)
             ON CONFLICT (machine_id, name) DO UPDATE SET params_json = excluded.params_json",
            params![machine_id, t.axis, params_json],
        )?;
        let axis_id: i64 = tx.query_row(
            "SELECT id FROM axes WHERE machine_id = ?1 AND name = ?2",
            params![machine_id, t.axis],
            |r| r.get(0),
        )?;
        let dup: Option<i64> = tx
            .query_row(
                "SELECT id FROM tests WHERE axis_id = ?1 AND kind = ?2 AND content_sha256 = ?3",
                params![axis_id, t.kind.as_str(), t.content_sha256],
                |r| r.get(0),
            )
            .optional()?;
        if let Some(id) = dup {
            // Nothing new: the machine/axis upserts are dropped with the transaction.
            return Ok(AddOutcome::Duplicate(id));
        }
        if t.reference {
            tx.execute(
                "UPDATE tests SET reference = 0 WHERE axis_id = ?1",
                [axis_id],
            )?;
        }
        tx.execute(
            "INSERT INTO tests (axis_id, time_utc, time_s, kind, source, content_sha256, program,
                                reference, compensation_ref, added_utc, feedscope_version)
             VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11)",
            params![
                axis_id,
                t.time_utc,
                t.time_s,
                t.kind.as_str(),
                t.source,
                t.content_sha256,
                t.program,
                i64::from(t.reference),
                t.compensation_ref,
                added_utc.map_or_else(
                    || super::time::format_rfc3339(super::time::now_s()),
                    str::to_string
                ),
                env!("CARGO_PKG_VERSION"),
            ],
        )?;
        let id = tx.last_insert_rowid();
        if let Some(p) = &t.identified {
            tx.execute(
                "INSERT INTO identified VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11,
                                                ?12, ?13, ?14, ?15)",
                params![
                    id,
                    p.j_total_kgm2,
                    p.j_std_kgm2,
                    p.fc_n,
                    p.fc_std_n,
                    p.fs_n,
                    p.fs_std_n,
                    p.sigma_n_s_per_m,
                    p.sigma_std_n_s_per_m,
                    p.vs_mm_min,
                    p.vs_std_mm_min,
                    p.delta,
                    p.offset_n,
                    p.residual_rms_nm,
                    p.samples_used
                ],
            )?;
        }
        {
            let mut st = tx.prepare_cached(
                "INSERT INTO interval_friction VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)",
            )?;
            for r in &t.intervals {
                st.execute(params![
                    id,
                    r.direction,
                    r.start_mm,
                    r.end_mm,
                    r.mean_n,
                    r.std_n,
                    r.samples
                ])?;
            }
            let mut st = tx.prepare_cached(
                "INSERT INTO components (test_id, direction, segment, position_mm, order_cpl,
                                         amplitude_n, floor_n, cause, trusted)
                 VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)",
            )?;
            for c in &t.components {
                st.execute(params![
                    id,
                    c.direction,
                    c.segment.to_string(),
                    c.position_mm,
                    c.order,
                    c.amplitude_n,
                    c.floor_n,
                    c.cause.to_string(),
                    i64::from(c.trusted)
                ])?;
            }
            let mut st = tx.prepare_cached("INSERT INTO indicators VALUES (?1, ?2, ?3, ?4, ?5)")?;
            for i in &t.indicators {
                st.execute(params![id, i.name, i.value, i.std_error, i.unit])?;
            }
        }
        if let Some(c) = &curves_json {
            tx.execute("INSERT INTO curves VALUES (?1, ?2)", params![id, c])?;
        }
        // Test hook for the kill test: stay inside the open transaction for a while.
        if let Some(ms) = std::env::var("FEEDSCOPE_TEST_SLEEP_IN_TX_MS")
            .ok()
            .and_then(|v| v.parse::<u64>().ok())
        {
            eprintln!("history add: inside the transaction, sleeping {ms} ms (test hook)");
            std::thread::sleep(Duration::from_millis(ms));
        }
        tx.commit()?;
        Ok(AddOutcome::Added(id))
    }

    fn remove_tx(&mut self, id: i64) -> Result<bool, StoreError> {
        let tx = self
            .conn
            .transaction_with_behavior(TransactionBehavior::Immediate)?;
        let n = tx.execute("DELETE FROM tests WHERE id = ?1", [id])?;
        tx.commit()?;
        Ok(n > 0)
    }

    fn set_reference_tx(&mut self, id: i64) -> Result<(), StoreError> {
        let tx = self
            .conn
            .transaction_with_behavior(TransactionBehavior::Immediate)?;
        let axis: Option<i64> = tx
            .query_row("SELECT axis_id FROM tests WHERE id = ?1", [id], |r| {
                r.get(0)
            })
            .optional()?;
        let axis = axis.ok_or(StoreError::NoSuchTest(id))?;
        tx.execute("UPDATE tests SET reference = 0 WHERE axis_id = ?1", [axis])?;
        tx.execute("UPDATE tests SET reference = 1 WHERE id = ?1", [id])?;
        tx.commit()?;
        Ok(())
    }
}

impl Store for SqliteStore {
    fn add(&mut self, t: &NewTest) -> Result<AddOutcome, StoreError> {
        self.add_tx(t, None).map_err(|e| self.busy(e))
    }

    fn add_copy(&mut self, t: &NewTest, added_utc: &str) -> Result<AddOutcome, StoreError> {
        self.add_tx(t, Some(added_utc)).map_err(|e| self.busy(e))
    }

    fn list(&self, f: &Filter) -> Result<Vec<TestRow>, StoreError> {
        let sql = format!(
            "SELECT {TEST_COLS} FROM tests t JOIN axes a ON a.id = t.axis_id
             JOIN machines m ON m.id = a.machine_id
             WHERE (?1 IS NULL OR m.name = ?1) AND (?2 IS NULL OR a.name = ?2)
             ORDER BY m.name, a.name, t.time_s, t.id"
        );
        let mut st = self.conn.prepare(&sql)?;
        let rows = st
            .query_map(params![f.machine, f.axis], test_row)?
            .collect::<Result<Vec<_>, _>>()?;
        Ok(rows)
    }

    fn get(&self, id: i64) -> Result<TestDetail, StoreError> {
        let sql = format!(
            "SELECT {TEST_COLS} FROM tests t JOIN axes a ON a.id = t.axis_id
             JOIN machines m ON m.id = a.machine_id WHERE t.id = ?1"
        );
        let test = self
            .conn
            .query_row(&sql, [id], test_row)
            .optional()?
            .ok_or(StoreError::NoSuchTest(id))?;
        let identified = self
            .conn
            .query_row(
                "SELECT j_total_kgm2, j_std_kgm2, fc_n, fc_std_n, fs_n, fs_std_n,
                        sigma_n_s_per_m, sigma_std_n_s_per_m, vs_mm_min, vs_std_mm_min, delta,
                        offset_n, residual_rms_nm, samples_used
                 FROM identified WHERE test_id = ?1",
                [id],
                |r| {
                    Ok(Identified {
                        j_total_kgm2: r.get(0)?,
                        j_std_kgm2: r.get::<_, Option<f64>>(1)?.unwrap_or(f64::NAN),
                        fc_n: r.get(2)?,
                        fc_std_n: r.get::<_, Option<f64>>(3)?.unwrap_or(f64::NAN),
                        fs_n: r.get(4)?,
                        fs_std_n: r.get::<_, Option<f64>>(5)?.unwrap_or(f64::NAN),
                        sigma_n_s_per_m: r.get(6)?,
                        sigma_std_n_s_per_m: r.get::<_, Option<f64>>(7)?.unwrap_or(f64::NAN),
                        vs_mm_min: r.get(8)?,
                        vs_std_mm_min: r.get::<_, Option<f64>>(9)?.unwrap_or(f64::NAN),
                        delta: r.get(10)?,
                        offset_n: r.get(11)?,
                        residual_rms_nm: r.get(12)?,
                        samples_used: r.get(13)?,
                    })
                },
            )
            .optional()?;
        let mut st = self.conn.prepare(
            "SELECT direction, start_mm, end_mm, mean_n, std_n, samples FROM interval_friction
             WHERE test_id = ?1 ORDER BY direction DESC, start_mm",
        )?;
        let intervals = st
            .query_map([id], |r| {
                Ok(IntervalRow {
                    direction: r.get(0)?,
                    start_mm: r.get(1)?,
                    end_mm: r.get(2)?,
                    mean_n: r.get(3)?,
                    std_n: r.get(4)?,
                    samples: r.get(5)?,
                })
            })?
            .collect::<Result<Vec<_>, _>>()?;
        let mut st = self.conn.prepare(
            "SELECT direction, segment, position_mm, order_cpl, amplitude_n, floor_n, cause,
                    trusted FROM components WHERE test_id = ?1 ORDER BY id",
        )?;
        let components = st
            .query_map([id], |r| {
                Ok(ComponentRow {
                    direction: r.get(0)?,
                    segment: label(r, 1)?,
                    position_mm: r.get(2)?,
                    order: r.get(3)?,
                    amplitude_n: r.get(4)?,
                    floor_n: r.get(5)?,
                    cause: label(r, 6)?,
                    trusted: r.get::<_, i64>(7)? != 0,
                })
            })?
            .collect::<Result<Vec<_>, _>>()?;
        let mut st = self.conn.prepare(
            "SELECT name, value, std_error, unit FROM indicators WHERE test_id = ?1 ORDER BY name",
        )?;
        let indicators = st
            .query_map([id], |r| {
                Ok(IndicatorRow {
                    name: r.get(0)?,
                    value: r.get(1)?,
                    std_error: r.get(2)?,
                    unit: r.get(3)?,
                })
            })?
            .collect::<Result<Vec<_>, _>>()?;
        Ok(TestDetail {
            test,
            identified,
            intervals,
            components,
            indicators,
        })
    }

    fn remove(&mut self, id: i64) -> Result<bool, StoreError> {
        self.remove_tx(id).map_err(|e| self.busy(e))
    }

    fn set_reference(&mut self, id: i64) -> Result<(), StoreError> {
        self.set_reference_tx(id).map_err(|e| self.busy(e))
    }

    fn series(&self, machine: &str, axis: &str) -> Result<BTreeMap<String, Series>, StoreError> {
        let mut st = self.conn.prepare_cached(
            "SELECT i.name, t.id, t.time_s, i.value, i.std_error
             FROM indicators i JOIN tests t ON t.id = i.test_id
             JOIN axes a ON a.id = t.axis_id JOIN machines m ON m.id = a.machine_id
             WHERE m.name = ?1 AND a.name = ?2
             ORDER BY i.name, t.time_s, t.id",
        )?;
        let mut out: BTreeMap<String, Series> = BTreeMap::new();
        let mut rows = st.query(params![machine, axis])?;
        while let Some(r) = rows.next()? {
            let name: String = r.get(0)?;
            out.entry(name).or_default().push((
                r.get(1)?,
                Point {
                    time_s: r.get(2)?,
                    value: r.get(3)?,
                    std_error: r.get(4)?,
                },
            ));
        }
        Ok(out)
    }

    fn curves(&self, id: i64) -> Result<Option<Stored<Curves>>, StoreError> {
        let json: Option<String> = self
            .conn
            .query_row("SELECT json FROM curves WHERE test_id = ?1", [id], |r| {
                r.get(0)
            })
            .optional()?;
        Ok(json.as_deref().map(Stored::from_json))
    }

    fn axis_params(
        &self,
        machine: &str,
        axis: &str,
    ) -> Result<Option<Stored<AxisParams>>, StoreError> {
        let json: Option<String> = self
            .conn
            .query_row(
                "SELECT a.params_json FROM axes a JOIN machines m ON m.id = a.machine_id
                 WHERE m.name = ?1 AND a.name = ?2",
                params![machine, axis],
                |r| r.get(0),
            )
            .optional()?;
        Ok(json.as_deref().map(Stored::from_json))
    }

    fn check(&self) -> Result<(), StoreError> {
        let detail: String = self
            .conn
            .query_row("PRAGMA integrity_check(1)", [], |r| r.get(0))?;
        let fk: Option<String> = self
            .conn
            .query_row("PRAGMA foreign_key_check", [], |r| r.get(0))
            .optional()?;
        if detail != "ok" || fk.is_some() {
            return Err(StoreError::Corrupt {
                path: self.path.display().to_string(),
                detail: if detail == "ok" {
                    format!("foreign key violation in table {}", fk.unwrap_or_default())
                } else {
                    detail
                },
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{TestKind, TestRow};

    fn new_test(axis: &str, day: u32, kind: TestKind, content: u8) -> NewTest {
        let time_utc = format!("2026-01-{day:02}T08:00:00Z");
        NewTest {
            machine: "m".into(),
            axis: axis.into(),
            // Not an axis file: kept as stored, unread (a document of another version).
            axis_params: Stored::from_json(&format!("{{\"day\":{day}}}")),
            time_s: crate::time::parse_rfc3339(&time_utc).unwrap(),
            time_utc,
            kind,
            source: format!("day-{day}.csv"),
            content_sha256: format!("{content:064x}"),
            program: Some("O1000".into()),
            reference: false,
            compensation_ref: None,
            identified: (kind == TestKind::Triangle).then(|| Identified {
                fs_n: 360.0 + f64::from(day),
                fs_std_n: 2.0,
                // a standard error that is not known is stored as NULL and read back as NaN
                j_std_kgm2: f64::NAN,
                samples_used: 40_000,
                ..Identified::default()
            }),
            intervals: vec![IntervalRow {
                direction: "forward".into(),
                start_mm: 0.0,
                end_mm: 50.0,
                mean_n: 300.0,
                std_n: 4.0,
                samples: 800,
            }],
            components: vec![ComponentRow {
                direction: "backward".into(),
                segment: feedscope::order::Segment::Whole,
                position_mm: 200.0,
                order: 1.0,
                amplitude_n: 5.5,
                floor_n: 0.5,
                cause: feedscope::order::Cause::Shaft(1),
                trusted: true,
            }],
            indicators: vec![
                IndicatorRow {
                    name: "fs_n".into(),
                    value: 360.0 + f64::from(day),
                    std_error: Some(2.0),
                    unit: "N".into(),
                },
                IndicatorRow {
                    name: "fc_n".into(),
                    value: 280.0,
                    std_error: None,
                    unit: "N".into(),
                },
            ],
            curves: Some(Stored::from_json(&format!("{{\"day\":{day}}}"))),
        }
    }

    fn open(dir: &tempfile::TempDir) -> SqliteStore {
        SqliteStore::open(&dir.path().join("h.db")).unwrap()
    }

    fn added(o: AddOutcome) -> i64 {
        match o {
            AddOutcome::Added(id) => id,
            AddOutcome::Duplicate(id) => panic!("test {id} reported as a duplicate"),
        }
    }

    #[test]
    fn add_get_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let mut s = open(&dir);
        assert_eq!(s.schema_version().unwrap(), SCHEMA_VERSION);
        let t = new_test("Z", 5, TestKind::Triangle, 1);
        let id = added(s.add(&t).unwrap());
        let d = s.get(id).unwrap();
        assert_eq!(d.test.machine, "m");
        assert_eq!(d.test.axis, "Z");
        assert_eq!(d.test.kind, TestKind::Triangle);
        assert_eq!(d.test.time_utc, t.time_utc);
        assert_eq!(d.test.time_s.to_bits(), t.time_s.to_bits());
        assert_eq!(d.test.content_sha256, t.content_sha256);
        assert_eq!(d.test.program.as_deref(), Some("O1000"));
        assert!(!d.test.reference);
        // stored values come back bit for bit: REAL is an IEEE double in SQLite
        let p = d.identified.unwrap();
        assert_eq!(p.fs_n.to_bits(), 365f64.to_bits());
        assert_eq!(p.fs_std_n.to_bits(), 2f64.to_bits());
        assert!(p.j_std_kgm2.is_nan());
        assert_eq!(p.samples_used, 40_000);
        assert_eq!(d.intervals.len(), 1);
        assert_eq!(d.intervals[0].samples, 800);
        assert_eq!(d.components.len(), 1);
        assert_eq!(d.components[0].cause, feedscope::order::Cause::Shaft(1));
        assert!(d.components[0].trusted);
        // indicators by name
        let names: Vec<_> = d.indicators.iter().map(|i| i.name.as_str()).collect();
        assert_eq!(names, ["fc_n", "fs_n"]);
        assert_eq!(d.indicators[0].std_error, None);
        assert_eq!(
            s.curves(id).unwrap().map(|c| c.to_json()).as_deref(),
            Some("{\"day\":5}")
        );
        assert_eq!(
            s.axis_params("m", "Z")
                .unwrap()
                .map(|p| p.to_json())
                .as_deref(),
            Some("{\"day\":5}")
        );
        assert!(matches!(s.get(id + 1), Err(StoreError::NoSuchTest(i)) if i == id + 1));
        s.check().unwrap();
    }

    /// Typed documents come back equal to what was stored, to the bit (JSON numbers are read
    /// with serde_json's `float_roundtrip`); one with a key this version does not know is kept
    /// unchanged and says which key.
    #[test]
    fn typed_documents_come_back_equal_and_unread_ones_unchanged() {
        use feedscope::study::{Curves, ProfileCurve};
        let dir = tempfile::tempdir().unwrap();
        let mut s = open(&dir);
        let axis = feedscope::sim::SimConfig::default().axis;
        let third = 1.0 / 3.0;
        let curves = Curves {
            profiles: vec![ProfileCurve {
                direction: "forward".into(),
                feed_mm_min: 1000.0 * third,
                position_mm: vec![0.1 + 0.2, 1e-17, 123.456_789_012_345_67],
                friction_n: vec![-third, 2.0_f64.sqrt(), f64::MIN_POSITIVE],
                iafv_n: vec![third; 3],
                breaks_mm: vec![0.0, 0.3],
            }],
            heatmaps: vec![],
            verdict: None,
            grid: vec![],
        };
        let mut t = new_test("Z", 5, TestKind::Strokes, 1);
        t.axis_params = axis.clone().into();
        t.curves = Some(curves.clone().into());
        let id = added(s.add(&t).unwrap());
        assert_eq!(s.curves(id).unwrap(), Some(Stored::Read(curves)));
        assert_eq!(
            s.axis_params("m", "Z").unwrap(),
            Some(Stored::Read(axis.clone()))
        );

        let mut newer = serde_json::to_value(&axis).unwrap();
        newer["spindle_colour"] = "red".into();
        let json = newer.to_string();
        let mut t = new_test("X", 6, TestKind::Triangle, 2);
        t.axis_params = Stored::from_json(&json);
        added(s.add(&t).unwrap());
        match s.axis_params("m", "X").unwrap() {
            Some(Stored::Unread { json: back, reason }) => {
                assert_eq!(back, json);
                assert!(reason.contains("spindle_colour"), "{reason}");
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn duplicates_are_not_stored_again() {
        let dir = tempfile::tempdir().unwrap();
        let mut s = open(&dir);
        let id = added(s.add(&new_test("Z", 5, TestKind::Triangle, 1)).unwrap());
        // same content, axis and kind: a duplicate, whatever the time; the axis parameters of
        // the refused test are not stored either
        let again = new_test("Z", 6, TestKind::Triangle, 1);
        assert_eq!(s.add(&again).unwrap(), AddOutcome::Duplicate(id));
        assert_eq!(
            s.axis_params("m", "Z")
                .unwrap()
                .map(|p| p.to_json())
                .as_deref(),
            Some("{\"day\":5}")
        );
        // another kind or axis with the same content is a new test
        added(s.add(&new_test("Z", 6, TestKind::Strokes, 1)).unwrap());
        added(s.add(&new_test("X", 6, TestKind::Triangle, 1)).unwrap());
        assert_eq!(s.list(&Filter::default()).unwrap().len(), 3);
    }

    #[test]
    fn list_and_series_are_in_time_order() {
        let dir = tempfile::tempdir().unwrap();
        let mut s = open(&dir);
        // added out of time order, on two axes
        for (axis, day, content) in [("Z", 9, 1), ("Z", 2, 2), ("X", 4, 3), ("Z", 5, 4)] {
            added(
                s.add(&new_test(axis, day, TestKind::Triangle, content))
                    .unwrap(),
            );
        }
        let days = |rows: &[TestRow]| -> Vec<String> {
            rows.iter()
                .map(|r| format!("{} {}", r.axis, &r.time_utc[..10]))
                .collect()
        };
        let all = s.list(&Filter::default()).unwrap();
        assert_eq!(
            days(&all),
            [
                "X 2026-01-04",
                "Z 2026-01-02",
                "Z 2026-01-05",
                "Z 2026-01-09"
            ]
        );
        let z = s
            .list(&Filter {
                machine: Some("m".into()),
                axis: Some("Z".into()),
            })
            .unwrap();
        assert_eq!(z.len(), 3);
        assert!(s
            .list(&Filter {
                machine: Some("other".into()),
                axis: None,
            })
            .unwrap()
            .is_empty());
        let series = s.series("m", "Z").unwrap();
        assert_eq!(series.keys().collect::<Vec<_>>(), ["fc_n", "fs_n"]);
        let fs: Vec<f64> = series["fs_n"].iter().map(|(_, p)| p.value).collect();
        assert_eq!(fs, [362.0, 365.0, 369.0]);
        let ids: Vec<i64> = series["fs_n"].iter().map(|(id, _)| *id).collect();
        assert_eq!(ids, z.iter().map(|r| r.id).collect::<Vec<_>>());
    }

    #[test]
    fn axes_count_the_tests_of_each_series() {
        let dir = tempfile::tempdir().unwrap();
        let mut s = open(&dir);
        assert!(s.axes().unwrap().is_empty());
        for (axis, day, content) in [("Z", 9, 1), ("X", 4, 2), ("Z", 5, 3)] {
            added(
                s.add(&new_test(axis, day, TestKind::Triangle, content))
                    .unwrap(),
            );
        }
        let series = |axis: &str, tests| crate::AxisSeries {
            machine: "m".into(),
            axis: axis.into(),
            tests,
        };
        assert_eq!(s.axes().unwrap(), [series("X", 1), series("Z", 2)]);
    }

    #[test]
    fn a_missing_folder_is_named_and_not_created() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("no-such-folder").join("h.db");
        let e = SqliteStore::open(&path).err().expect("refused");
        assert!(
            matches!(&e, StoreError::NoFolder { folder, .. } if folder.ends_with("no-such-folder")),
            "{e}"
        );
        assert!(e.is_bad_input());
        assert!(!dir.path().join("no-such-folder").exists());
    }

    #[test]
    fn reference_and_remove() {
        let dir = tempfile::tempdir().unwrap();
        let mut s = open(&dir);
        let a = added(s.add(&new_test("Z", 2, TestKind::Triangle, 1)).unwrap());
        let mut t = new_test("Z", 3, TestKind::Triangle, 2);
        t.reference = true;
        let b = added(s.add(&t).unwrap());
        let x = added(s.add(&new_test("X", 3, TestKind::Triangle, 3)).unwrap());
        s.set_reference(x).unwrap();
        let refs = |s: &SqliteStore| -> Vec<i64> {
            let rows = s.list(&Filter::default()).unwrap();
            rows.iter().filter(|r| r.reference).map(|r| r.id).collect()
        };
        // one reference per axis
        assert_eq!(refs(&s), [x, b]);
        s.set_reference(a).unwrap();
        assert_eq!(refs(&s), [x, a]);
        assert!(matches!(
            s.set_reference(99),
            Err(StoreError::NoSuchTest(99))
        ));
        // removing a test removes its results with it
        assert!(s.remove(a).unwrap());
        assert!(!s.remove(a).unwrap());
        assert!(matches!(s.get(a), Err(StoreError::NoSuchTest(_))));
        assert_eq!(s.curves(a).unwrap(), None);
        assert_eq!(s.series("m", "Z").unwrap()["fs_n"].len(), 1);
        s.check().unwrap();
    }

    #[test]
    fn reopening_keeps_the_tests() {
        let dir = tempfile::tempdir().unwrap();
        let id = added(
            open(&dir)
                .add(&new_test("Z", 2, TestKind::Strokes, 1))
                .unwrap(),
        );
        let s = open(&dir);
        assert_eq!(s.schema_version().unwrap(), SCHEMA_VERSION);
        assert_eq!(s.get(id).unwrap().test.kind, TestKind::Strokes);
    }

    #[test]
    fn files_that_are_not_ours_are_refused_untouched() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("h.db");
        let junk: Vec<u8> = (0..10_000u32).map(|i| (i * 7919 % 251) as u8).collect();
        std::fs::write(&path, &junk).unwrap();
        let e = SqliteStore::open(&path).err().unwrap();
        assert!(matches!(e, StoreError::NotADatabase { .. }), "{e}");
        assert!(e.is_bad_input());
        assert_eq!(std::fs::read(&path).unwrap(), junk);

        std::fs::remove_file(&path).unwrap();
        Connection::open(&path)
            .unwrap()
            .execute_batch("CREATE TABLE invoices (id INTEGER PRIMARY KEY)")
            .unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let e = SqliteStore::open(&path).err().unwrap();
        assert!(
            matches!(
                e,
                StoreError::Foreign {
                    application_id: 0,
                    tables: 1,
                    ..
                }
            ),
            "{e}"
        );
        assert!(e.is_bad_input());
        assert_eq!(std::fs::read(&path).unwrap(), bytes);

        std::fs::remove_file(&path).unwrap();
        drop(SqliteStore::open(&path).unwrap());
        Connection::open(&path)
            .unwrap()
            .pragma_update(None, "user_version", SCHEMA_VERSION + 1)
            .unwrap();
        let e = SqliteStore::open(&path).err().unwrap();
        assert!(
            matches!(e, StoreError::NewerSchema { found, supported, .. }
                if found == SCHEMA_VERSION + 1 && supported == SCHEMA_VERSION),
            "{e}"
        );
        assert!(e.is_bad_input());
    }

    /// Another connection holding the write lock, as `history add` does inside `add`.
    fn hold_write_lock(path: &Path) -> Connection {
        let c = Connection::open(path).unwrap();
        c.execute_batch("BEGIN IMMEDIATE").unwrap();
        c
    }

    /// A reader opens and lists while another process holds the write lock: opening a
    /// current schema takes no lock (it used to run the migration in `BEGIN IMMEDIATE`).
    #[test]
    fn readers_do_not_wait_for_a_writer() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("h.db");
        added(
            open(&dir)
                .add(&new_test("Z", 2, TestKind::Strokes, 1))
                .unwrap(),
        );
        let lock = hold_write_lock(&path);
        // no waiting allowed: any lock taken on open or list fails at once
        let opts = OpenOptions::default().busy_timeout(Duration::ZERO);
        let s = SqliteStore::open_with(&path, &opts).unwrap();
        assert_eq!(s.list(&Filter::default()).unwrap().len(), 1);
        assert_eq!(s.series("m", "Z").unwrap()["fs_n"].len(), 1);
        s.check().unwrap();
        drop(lock);
    }

    /// A writer behind another's lock waits the busy timeout, reports the wait once, and
    /// fails with `Busy` (not the input's fault) carrying the hint; nothing is written.
    #[test]
    fn a_writer_behind_a_lock_waits_then_reports_busy() {
        use std::sync::atomic::AtomicUsize;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("h.db");
        drop(open(&dir));
        let lock = hold_write_lock(&path);
        let calls = Arc::new(AtomicUsize::new(0));
        let seen = Arc::clone(&calls);
        let timeout = Duration::from_millis(900);
        let opts = OpenOptions::default()
            .busy_timeout(timeout)
            .on_wait(move |p, up_to| {
                assert!(p.ends_with("h.db"));
                assert_eq!(up_to, timeout);
                seen.fetch_add(1, Ordering::SeqCst);
            })
            .busy_hint("wait longer with X=60");
        let mut s = SqliteStore::open_with(&path, &opts).unwrap();
        let e = s.add(&new_test("Z", 2, TestKind::Strokes, 1)).unwrap_err();
        let StoreError::Busy { waited_s, .. } = &e else {
            panic!("{e:?}")
        };
        // the handler gives up at the first retry past the timeout (sleeps of 50 ms at most)
        assert!(*waited_s >= 0.9 && *waited_s < 5.0, "{waited_s}");
        assert_eq!(calls.load(Ordering::SeqCst), 1, "reported once");
        assert_eq!(e.kind(), feedscope::ErrorKind::Io);
        let msg = e.to_string();
        assert!(msg.contains("h.db is busy"), "{msg}");
        assert!(msg.contains("holds its write lock"), "{msg}");
        assert!(msg.ends_with("; wait longer with X=60"), "{msg}");
        drop(lock);
        // the lock released, the same store writes
        added(s.add(&new_test("Z", 2, TestKind::Strokes, 1)).unwrap());
        // a short wait is not reported: the lock is released within the quiet time
        let lock = hold_write_lock(&path);
        let release = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(100));
            drop(lock);
        });
        added(s.add(&new_test("Z", 3, TestKind::Strokes, 2)).unwrap());
        release.join().unwrap();
        assert_eq!(calls.load(Ordering::SeqCst), 1, "a short wait is quiet");
    }

    /// A new database cannot be created while another process holds the lock: `Busy` from
    /// `open_with`, not an engine error.
    #[test]
    fn creating_behind_a_lock_is_busy() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("h.db");
        // an empty WAL database with no schema yet, locked
        {
            let c = Connection::open(&path).unwrap();
            c.pragma_update(None, "journal_mode", "WAL").unwrap();
        }
        let lock = hold_write_lock(&path);
        let opts = OpenOptions::default().busy_timeout(Duration::from_millis(50));
        let e = SqliteStore::open_with(&path, &opts).err().expect("busy");
        assert!(matches!(e, StoreError::Busy { hint: None, .. }), "{e:?}");
        drop(lock);
        SqliteStore::open_with(&path, &opts).unwrap();
    }

    /// Four writers in threads, each with its own connection: every test lands once.
    #[test]
    fn concurrent_writers_lose_and_duplicate_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("h.db");
        drop(open(&dir));
        // Writer w stores contents 10w..10w+9, and also offers contents 0..9 (writer 0's):
        // each content must be stored exactly once, whoever comes first.
        let writers: Vec<_> = (0..4u8)
            .map(|w| {
                let path = path.clone();
                std::thread::spawn(move || {
                    let mut s = SqliteStore::open(&path).unwrap();
                    let mut stored = 0;
                    for k in 0..10u8 {
                        let day = 1 + u32::from(k);
                        for content in [w * 10 + k, k] {
                            let t = new_test("Z", day, TestKind::Strokes, content);
                            if let AddOutcome::Added(_) = s.add(&t).unwrap() {
                                stored += 1;
                            }
                        }
                    }
                    stored
                })
            })
            .collect();
        let stored: usize = writers.into_iter().map(|w| w.join().unwrap()).sum();
        assert_eq!(stored, 40, "each content reported stored once");
        let s = open(&dir);
        let rows = s.list(&Filter::default()).unwrap();
        let mut shas: Vec<&str> = rows.iter().map(|r| r.content_sha256.as_str()).collect();
        assert_eq!(shas.len(), 40);
        shas.sort_unstable();
        shas.dedup();
        assert_eq!(shas.len(), 40, "no duplicates");
        s.check().unwrap();
    }

    /// Damage that the quick check does not see is still the user's wrong file (exit code 2):
    /// A test kind that is neither `strokes` nor `triangle` (written by something else) is
    /// damage, refused as the row is read, not a row a front end compares as text.
    #[test]
    fn an_unknown_test_kind_is_damage() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("h.db");
        open(&dir)
            .add(&new_test("Z", 2, TestKind::Strokes, 1))
            .unwrap();
        let rows = open(&dir).list(&Filter::default()).unwrap();
        assert_eq!(rows[0].kind, TestKind::Strokes);
        // The schema's CHECK refuses it; another writer that ignores checks does not.
        let raw = Connection::open(&path).unwrap();
        assert!(raw.execute("UPDATE tests SET kind = 'spiral'", []).is_err());
        raw.pragma_update(None, "ignore_check_constraints", true)
            .unwrap();
        raw.execute("UPDATE tests SET kind = 'spiral'", []).unwrap();
        drop(raw);
        let e = open(&dir).list(&Filter::default()).unwrap_err();
        assert!(e.is_bad_input(), "{e:?}");
        assert!(format!("{e}").contains("spiral"), "{e}");
    }

    /// a header whose version was reset, a table missing, a value of the wrong type.
    #[test]
    fn damage_past_the_quick_check_is_bad_input() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("h.db");
        let id = added(
            open(&dir)
                .add(&new_test("Z", 2, TestKind::Triangle, 1))
                .unwrap(),
        );
        let raw = || Connection::open(&path).unwrap();
        // a value of the wrong type in a REAL column
        raw()
            .execute("UPDATE tests SET time_s = 'yesterday'", [])
            .unwrap();
        let e = open(&dir).list(&Filter::default()).unwrap_err();
        assert!(e.is_bad_input(), "{e:?}");
        // a table missing
        raw().execute_batch("DROP TABLE curves").unwrap();
        let e = open(&dir).curves(id).unwrap_err();
        assert!(e.is_bad_input(), "{e:?}");
        // the schema version reset: refused before anything is written
        raw().pragma_update(None, "user_version", 0).unwrap();
        let before = std::fs::read(&path).unwrap();
        let e = SqliteStore::open(&path).err().expect("refused");
        assert!(matches!(e, StoreError::Corrupt { .. }), "{e:?}");
        assert!(e.is_bad_input());
        assert_eq!(std::fs::read(&path).unwrap(), before);
        // a negative schema version (the fuzz finding): damage, not a panic or a silent stamp
        raw()
            .pragma_update(None, "user_version", -2_147_483_647)
            .unwrap();
        let before = std::fs::read(&path).unwrap();
        let e = SqliteStore::open(&path).err().expect("refused");
        assert!(matches!(e, StoreError::Corrupt { .. }), "{e:?}");
        assert_eq!(std::fs::read(&path).unwrap(), before);
    }

    #[test]
    fn sqlite_errors_are_classified_and_read_unchanged() {
        let failure = |code| rusqlite::Error::SqliteFailure(rusqlite::ffi::Error::new(code), None);
        for (code, kind, bad_input) in [
            (
                rusqlite::ffi::SQLITE_NOTADB,
                BackendErrorKind::NotADatabase,
                true,
            ),
            (
                rusqlite::ffi::SQLITE_CORRUPT,
                BackendErrorKind::Corrupt,
                true,
            ),
            (rusqlite::ffi::SQLITE_BUSY, BackendErrorKind::Other, false),
            (rusqlite::ffi::SQLITE_FULL, BackendErrorKind::Other, false),
        ] {
            let e = StoreError::from(failure(code));
            let StoreError::Backend(b) = &e else {
                panic!("{e:?}")
            };
            assert_eq!(b.kind(), kind, "{e}");
            assert_eq!(e.is_bad_input(), bad_input, "{e}");
            // the message is SQLite's own, and the engine's error can be had back
            assert_eq!(e.to_string(), failure(code).to_string());
            assert!(b.get_ref().downcast_ref::<rusqlite::Error>().is_some());
        }
        let e = StoreError::from(rusqlite::Error::QueryReturnedNoRows);
        assert!(!e.is_bad_input());
        assert_eq!(e.to_string(), "Query returned no rows");
    }
}
