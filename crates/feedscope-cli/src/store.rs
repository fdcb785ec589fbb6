//! Where the condition history is kept and how a command opens it: `--store SPEC` (env
//! `FEEDSCOPE_STORE`), a PostgreSQL URL or an SQLite file, or `--db FILE` (env
//! `FEEDSCOPE_DB`), an SQLite file; `feedscope.db` in the current folder when none is given.
//!
//! Precedence: a flag before an environment variable, `FEEDSCOPE_STORE` before
//! `FEEDSCOPE_DB`; `--store` and `--db` together are a usage error (exit code 2). A password in
//! a URL never appears in a message: [`StoreSpec::describe`] shows it as `***`.
use std::path::{Path, PathBuf};

use anyhow::Result;
use feedscope_store::{PgStore, Store, StoreError};

use crate::cmd::BadInput;

/// The environment variable read when `--store` is not given.
pub const STORE_VAR: &str = "FEEDSCOPE_STORE";
/// The environment variable read when neither `--store`, `--db` nor [`STORE_VAR`] is given.
pub const DB_VAR: &str = "FEEDSCOPE_DB";
/// The SQLite file when nothing says where the store is.
const DEFAULT_DB: &str = "feedscope.db";

/// A history store, parsed from the command line or the environment before anything is
/// opened.
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

    /// The store of the flags and the environment: `--store`, `--db`, [`STORE_VAR`],
    /// [`DB_VAR`], `feedscope.db`, the first one given.
    ///
    /// # Errors
    /// [`BadInput`] when both `--db` and `--store` are given.
    pub fn resolve(db: Option<&Path>, store: Option<&str>) -> Result<Self> {
        let env = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty());
        Ok(match (db, store) {
            (Some(d), Some(s)) => {
                return Err(BadInput(format!(
                    "--db {} and --store {} both say where the history is; give one",
                    d.display(),
                    StoreSpec::parse(s).describe()
                ))
                .into())
            }
            (None, Some(s)) => StoreSpec::parse(s),
            (Some(d), None) => StoreSpec::Sqlite(d.to_path_buf()),
            (None, None) => match (env(STORE_VAR), env(DB_VAR)) {
                (Some(s), _) => StoreSpec::parse(&s.to_string_lossy()),
                (None, Some(d)) => StoreSpec::Sqlite(PathBuf::from(d)),
                (None, None) => StoreSpec::Sqlite(PathBuf::from(DEFAULT_DB)),
            },
        })
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

    /// Open the store (creating or migrating its schema).
    ///
    /// # Errors
    /// As [`feedscope_store::SqliteStore::open_with`] and [`PgStore::open`], each naming the store: a bad URL
    /// or a database that is not feedscope's is bad input (exit code 2), a server that
    /// cannot be reached is not (exit code 1).
    pub fn open(&self) -> Result<Box<dyn Store>> {
        Ok(self.open_versioned()?.0)
    }

    /// [`open`](Self::open), with the schema version of the store.
    pub fn open_versioned(&self) -> Result<(Box<dyn Store>, i64)> {
        match self {
            StoreSpec::Sqlite(p) => {
                let s = crate::cmd::history::open_sqlite(p)?;
                let v = s.schema_version().map_err(|e| store_err(e, self))?;
                Ok((Box::new(s) as Box<dyn Store>, v))
            }
            StoreSpec::Postgres(url) => {
                let s = PgStore::open(url).map_err(|e| store_err(e, self))?;
                let v = s.schema_version().map_err(|e| store_err(e, self))?;
                Ok((Box::new(s) as Box<dyn Store>, v))
            }
        }
    }
}

/// Open the history store that `--db` and `--store` (or the environment) name.
///
/// # Errors
/// As [`StoreSpec::resolve`] and [`StoreSpec::open`].
pub fn open_store(db: Option<&Path>, store: Option<&str>) -> Result<Box<dyn Store>> {
    StoreSpec::resolve(db, store)?.open()
}

/// The store that `--db` and `--store` (or the environment) name, for messages (its password
/// hidden); both flags together are described as the `--store` one.
pub fn describe(db: Option<&Path>, store: Option<&str>) -> String {
    match StoreSpec::resolve(db, store) {
        Ok(s) => s.describe(),
        Err(_) => store.map_or_else(String::new, |s| StoreSpec::parse(s).describe()),
    }
}

/// A store error with the store named once: the variants whose message names it stand
/// alone, the others get the store as context. The exit code follows the error's kind.
pub fn store_err(e: StoreError, spec: &StoreSpec) -> anyhow::Error {
    let name = spec.describe();
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
        ) => anyhow::Error::new(e),
        (StoreError::NoSuchTest(_), _) => anyhow::Error::new(e).context(name),
        (_, StoreSpec::Postgres(_)) => {
            anyhow::Error::new(e).context(format!("PostgreSQL store {name}"))
        }
        (StoreError::Backend(_), StoreSpec::Sqlite(_)) if e.is_bad_input() => {
            anyhow::Error::new(e).context(name)
        }
        _ => anyhow::Error::new(e).context(format!("database {name}")),
    }
}

/// A failed [`Store::add`] of `history add` (and `watch`) as the user needs it: a commit whose
/// outcome is unknown says so, how to find out and that adding again is safe (the same trace
/// is recognised and not stored twice); any other failure of a PostgreSQL add says that
/// nothing was stored (its transaction was rolled back). Otherwise as [`store_err`].
pub fn add_err(e: StoreError, spec: &StoreSpec) -> anyhow::Error {
    match (&e, spec) {
        (StoreError::CommitUnknown { .. }, _) => {
            let context = format!(
                "the connection to the database closed while the test was being committed: \
                 whether it was stored is unknown; check with `feedscope history list --store \
                 {}`; adding it again is safe (the same trace is not stored twice)",
                spec.describe()
            );
            anyhow::Error::new(e).context(context)
        }
        (_, StoreSpec::Postgres(_)) => store_err(e, spec).context("the test was not stored"),
        _ => store_err(e, spec),
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
    fn flags_beat_the_environment_and_do_not_go_together() {
        let d = StoreSpec::resolve(Some(Path::new("a.db")), None).unwrap();
        assert_eq!(d, StoreSpec::Sqlite("a.db".into()));
        let s = StoreSpec::resolve(None, Some("postgres://u@h/x")).unwrap();
        assert_eq!(s, StoreSpec::Postgres("postgres://u@h/x".into()));
        let e =
            StoreSpec::resolve(Some(Path::new("a.db")), Some("postgres://u:pw@h/x")).unwrap_err();
        assert_eq!(crate::cmd::exit_code(&e), 2);
        assert!(!e.to_string().contains("pw@"), "{e}");
        assert_eq!(
            describe(Some(Path::new("a.db")), Some("postgres://u:pw@h/x")),
            "postgres://u:***@h/x"
        );
    }
}
