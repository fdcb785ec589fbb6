//! Where the condition history is kept and how a front end opens it: a PostgreSQL URL or an
//! SQLite file ([`StoreSpec`]), the busy timeout every opening of an SQLite file honours
//! ([`BUSY_TIMEOUT_VAR`]), how a front end opens the stores a use case names ([`Opener`]), and
//! store errors with the store named once ([`store_error`], [`add_error`]). A password in a URL
//! never appears in a message: [`StoreSpec::describe`] shows it as `***`.
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use feedscope::ErrorKind;
use feedscope_store::{OpenOptions, PgStore, SqliteStore, Store, StoreError};

use crate::AppError;

/// A history store, parsed before anything is opened.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum StoreSpec {
    /// An SQLite file.
    Sqlite(PathBuf),
    /// A PostgreSQL database: the URL as given (with its password, if any).
    Postgres(String),
}

impl StoreSpec {
    /// `postgres://…` and `postgresql://…` (any case of the scheme) name a PostgreSQL
    /// database; anything else is an SQLite file's path.
    pub fn parse(spec: &str) -> Self {
        let lower = spec.get(..13).unwrap_or(spec).to_ascii_lowercase();
        if lower.starts_with("postgres://") || lower.starts_with("postgresql://") {
            StoreSpec::Postgres(spec.to_string())
        } else {
            StoreSpec::Sqlite(PathBuf::from(spec))
        }
    }

    /// The store in messages: the SQLite file's path, or the URL with its password replaced
    /// by `***`.
    pub fn describe(&self) -> String {
        match self {
            StoreSpec::Sqlite(p) => p.display().to_string(),
            StoreSpec::Postgres(url) => feedscope_store::postgres::redact(url),
        }
    }

    /// The SQLite file, if the store is one.
    pub fn sqlite_path(&self) -> Option<&Path> {
        match self {
            StoreSpec::Sqlite(p) => Some(p),
            StoreSpec::Postgres(_) => None,
        }
    }

    /// Open the store (creating or migrating its schema), with its schema version; an
    /// SQLite file with `options` ([`open_options`]).
    ///
    /// # Errors
    /// As [`SqliteStore::open_with`] and [`PgStore::open`], each naming the store
    /// ([`store_error`]): a bad URL or a database that is not feedscope's is bad input, a
    /// server that cannot be reached is not.
    pub fn open_versioned(&self, options: &OpenOptions) -> Result<(Box<dyn Store>, i64), AppError> {
        match self {
            StoreSpec::Sqlite(p) => {
                let s = SqliteStore::open_with(p, options).map_err(|e| store_error(e, self))?;
                let v = s.schema_version().map_err(|e| store_error(e, self))?;
                Ok((Box::new(s) as Box<dyn Store>, v))
            }
            StoreSpec::Postgres(url) => {
                let s = PgStore::open(url).map_err(|e| store_error(e, self))?;
                let v = s.schema_version().map_err(|e| store_error(e, self))?;
                Ok((Box::new(s) as Box<dyn Store>, v))
            }
        }
    }
}

/// The environment variable that sets how long an opening waits for another process's write
/// lock on an SQLite history, in seconds (default 30).
pub const BUSY_TIMEOUT_VAR: &str = "FEEDSCOPE_BUSY_TIMEOUT_S";

/// The busy timeout when [`BUSY_TIMEOUT_VAR`] is not set.
const DEFAULT_BUSY_TIMEOUT_S: f64 = 30.0;

/// The busy timeout given by the value of [`BUSY_TIMEOUT_VAR`] (`None`: not set).
///
/// # Errors
/// Bad input naming the variable when the value is not a number of seconds from 0 to one
/// day.
pub fn busy_timeout(value: Option<&str>) -> Result<Duration, AppError> {
    let Some(v) = value else {
        return Ok(Duration::from_secs_f64(DEFAULT_BUSY_TIMEOUT_S));
    };
    match v.trim().parse::<f64>() {
        Ok(s) if (0.0..=86_400.0).contains(&s) => Ok(Duration::from_secs_f64(s)),
        _ => Err(AppError::bad_input(format!(
            "{BUSY_TIMEOUT_VAR}={v:?} is not a number of seconds from 0 to 86400"
        ))),
    }
}

/// What is said when an opening starts waiting for another process's lock.
pub fn waiting_message(db: &Path, up_to: Duration) -> String {
    format!(
        "the history database {} is busy (another process, probably another feedscope, is \
         writing to it); waiting up to {} s (set {BUSY_TIMEOUT_VAR} to change this)",
        db.display(),
        up_to.as_secs_f64()
    )
}

/// Where a front end says a line while the work goes on (the command line: stderr).
pub type Say = Box<dyn Fn(&str) + Send + Sync>;

/// How every front end opens an SQLite history: the busy timeout from [`BUSY_TIMEOUT_VAR`]
/// (default 30 s), `say` told [`waiting_message`] when a wait for another process's lock
/// lasts, and the variable named in the error when the wait ends without the lock.
///
/// # Errors
/// Bad input when [`BUSY_TIMEOUT_VAR`] holds no valid number of seconds.
pub fn open_options(say: Option<Say>) -> Result<OpenOptions, AppError> {
    let value = std::env::var(BUSY_TIMEOUT_VAR).ok();
    let mut options = OpenOptions::default()
        .busy_timeout(busy_timeout(value.as_deref())?)
        .busy_hint(format!(
            "to wait longer, set {BUSY_TIMEOUT_VAR} (e.g. {BUSY_TIMEOUT_VAR}=300)"
        ));
    if let Some(say) = say {
        options = options.on_wait(move |db, up_to| say(&waiting_message(db, up_to)));
    }
    Ok(options)
}

/// How a front end opens the stores its use cases name: with [`open_options`] each time (the
/// busy timeout read when the store is opened), a wait for another process's lock said where
/// the front end says things (the command line: on stderr). A use case that decides when a
/// store is opened (after its request is checked, a new SQLite file only once there is
/// something to store) takes one.
#[derive(Clone, Default)]
pub struct Opener {
    say: Option<Arc<SayFn>>,
}

/// What an [`Opener`] tells of a wait, shared by every opening ([`Say`] is one opening's).
type SayFn = dyn Fn(&str) + Send + Sync;

impl std::fmt::Debug for Opener {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Opener")
            .field("say", &self.say.as_ref().map(|_| "Fn"))
            .finish()
    }
}

impl Opener {
    /// An opener that says nothing of a wait (only its end, as the error, if the lock never
    /// comes).
    pub fn quiet() -> Self {
        Self::default()
    }

    /// An opener that tells `say` [`waiting_message`] when a wait for a lock lasts.
    pub fn saying(say: impl Fn(&str) + Send + Sync + 'static) -> Self {
        Self {
            say: Some(Arc::new(say)),
        }
    }

    /// The options of an SQLite opening ([`open_options`] with this opener's `say`).
    ///
    /// # Errors
    /// As [`open_options`].
    pub fn options(&self) -> Result<OpenOptions, AppError> {
        open_options(
            self.say
                .clone()
                .map(|say| Box::new(move |m: &str| say(m)) as Say),
        )
    }

    /// Open the store `spec` (creating or migrating its schema), with its schema version.
    ///
    /// # Errors
    /// As [`Opener::options`] and [`StoreSpec::open_versioned`].
    pub fn open_versioned(&self, spec: &StoreSpec) -> Result<(Box<dyn Store>, i64), AppError> {
        spec.open_versioned(&self.options()?)
    }

    /// Open the store `spec` (creating or migrating its schema).
    ///
    /// # Errors
    /// As [`Opener::open_versioned`].
    pub fn open(&self, spec: &StoreSpec) -> Result<Box<dyn Store>, AppError> {
        Ok(self.open_versioned(spec)?.0)
    }
}

/// A failed [`Store::add`] (`history add`, a gateway's stored test) as the user needs it: a
/// commit whose outcome is unknown says so, how to find out and that adding again is safe (the
/// same trace is recognised and not stored twice); any other failure of a PostgreSQL add says
/// that nothing was stored (its transaction was rolled back). Otherwise as [`store_error`].
pub fn add_error(e: StoreError, spec: &StoreSpec) -> AppError {
    match (&e, spec) {
        (StoreError::CommitUnknown { .. }, _) => {
            let context = format!(
                "the connection to the database closed while the test was being committed: \
                 whether it was stored is unknown; check with `feedscope history list --store \
                 {}`; adding it again is safe (the same trace is not stored twice)",
                spec.describe()
            );
            AppError::caused(e.kind(), context, e)
        }
        (_, StoreSpec::Postgres(_)) => {
            let e = store_error(e, spec);
            AppError::caused(e.kind(), "the test was not stored", e)
        }
        _ => store_error(e, spec),
    }
}

/// A store error with the store named once: the variants whose message names it stand
/// alone, the others get the store as context. The kind is the store's.
pub fn store_error(e: StoreError, spec: &StoreSpec) -> AppError {
    let name = spec.describe();
    let kind = e.kind();
    match (&e, spec) {
        (
            StoreError::NotADatabase { .. }
            | StoreError::Foreign { .. }
            | StoreError::ForeignSchema { .. }
            | StoreError::BadAddress { .. }
            | StoreError::NewerSchema { .. }
            | StoreError::Corrupt { .. }
            | StoreError::NoFolder { .. }
            | StoreError::Busy { .. }
            | StoreError::CommitUnknown { .. },
            _,
        ) => AppError::from_error(e),
        (StoreError::NoSuchTest(_), _) => AppError::caused(kind, name, e),
        (_, StoreSpec::Postgres(_)) => {
            AppError::caused(kind, format!("PostgreSQL store {name}"), e)
        }
        (StoreError::Backend(_), StoreSpec::Sqlite(_)) if e.is_bad_input() => {
            AppError::caused(ErrorKind::BadInput, name, e)
        }
        _ => AppError::caused(kind, format!("database {name}"), e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_are_urls_or_paths() {
        assert_eq!(
            StoreSpec::parse("postgres://u@h/db"),
            StoreSpec::Postgres("postgres://u@h/db".into())
        );
        assert_eq!(
            StoreSpec::parse("PostgreSQL://u@h/db"),
            StoreSpec::Postgres("PostgreSQL://u@h/db".into())
        );
        assert_eq!(
            StoreSpec::parse("history.db"),
            StoreSpec::Sqlite("history.db".into())
        );
        assert_eq!(
            StoreSpec::parse("postgres.db"),
            StoreSpec::Sqlite("postgres.db".into())
        );
        assert_eq!(
            StoreSpec::parse("postgres://ann:secret@h/db").describe(),
            "postgres://ann:***@h/db"
        );
    }

    #[test]
    fn busy_timeout_from_the_environment_value() {
        assert_eq!(busy_timeout(None).unwrap(), Duration::from_secs(30));
        assert_eq!(
            busy_timeout(Some(" 2.5")).unwrap(),
            Duration::from_millis(2500)
        );
        assert_eq!(busy_timeout(Some("0")).unwrap(), Duration::ZERO);
        for bad in ["", "soon", "-1", "NaN", "inf", "1e9"] {
            let e = busy_timeout(Some(bad)).unwrap_err();
            assert_eq!(e.kind(), ErrorKind::BadInput, "{bad}: {e}");
            assert!(e.to_string().contains(BUSY_TIMEOUT_VAR), "{e}");
        }
    }

    #[test]
    fn the_waiting_message_says_who_how_long_and_how_to_change_it() {
        let m = waiting_message(Path::new("h.db"), Duration::from_secs(30));
        assert_eq!(
            m,
            "the history database h.db is busy (another process, probably another feedscope, \
             is writing to it); waiting up to 30 s (set FEEDSCOPE_BUSY_TIMEOUT_S to change this)"
        );
    }

    /// A store error keeps its kind and names the store once.
    #[test]
    fn store_errors_name_the_store_once() {
        let sqlite = StoreSpec::Sqlite("h.db".into());
        let e = store_error(StoreError::NoSuchTest(7), &sqlite);
        assert_eq!(e.kind(), ErrorKind::BadInput);
        assert_eq!(e.to_string(), "h.db");
        let busy = StoreError::Busy {
            path: "h.db".into(),
            waited_s: 30.0,
            hint: None,
        };
        let e = store_error(busy, &sqlite);
        assert_eq!(e.kind(), ErrorKind::Io);
        assert!(e.to_string().contains("h.db"), "{e}");
        let pg = StoreSpec::Postgres("postgres://u:pw@h/x".into());
        let e = store_error(StoreError::Io(std::io::ErrorKind::Other.into()), &pg);
        assert_eq!(e.to_string(), "PostgreSQL store postgres://u:***@h/x");
    }

    /// A failed add says what became of the test: a commit of unknown outcome how to find
    /// out, a PostgreSQL add that nothing was stored; an SQLite one as any store error.
    #[test]
    fn a_failed_add_says_what_became_of_the_test() {
        use feedscope_store::{BackendError, BackendErrorKind};
        let pg = StoreSpec::Postgres("postgres://u:pw@h/x".into());
        let unknown = StoreError::CommitUnknown {
            path: "postgres://u:***@h/x".into(),
            error: BackendError::new(BackendErrorKind::Other, "connection closed"),
        };
        let e = add_error(unknown, &pg);
        assert_eq!(e.kind(), ErrorKind::Io);
        assert!(
            e.to_string().ends_with(
                "check with `feedscope history list --store postgres://u:***@h/x`; adding it \
                 again is safe (the same trace is not stored twice)"
            ),
            "{e}"
        );
        let io = || StoreError::Io(std::io::ErrorKind::Other.into());
        let e = add_error(io(), &pg);
        assert_eq!(e.to_string(), "the test was not stored");
        let below = std::error::Error::source(&e).unwrap().to_string();
        assert_eq!(below, "PostgreSQL store postgres://u:***@h/x");
        let sqlite = StoreSpec::Sqlite("h.db".into());
        assert_eq!(add_error(io(), &sqlite).to_string(), "database h.db");
    }
}
