//! Where the condition history is kept and how a command opens it: `--store SPEC` (env
//! `FEEDSCOPE_STORE`), a PostgreSQL URL or an SQLite file, or `--db FILE` (env
//! `FEEDSCOPE_DB`), an SQLite file; `feedscope.db` in the current folder when none is given.
//!
//! Precedence: a flag before an environment variable, `FEEDSCOPE_STORE` before
//! `FEEDSCOPE_DB`; `--store` and `--db` together are a usage error (exit code 2). A password in
//! a URL never appears in a message: [`StoreSpec::describe`] shows it as `***`.
use std::path::{Path, PathBuf};

use anyhow::Result;
#[cfg(doc)]
use feedscope_app::store::open_options;
pub use feedscope_app::store::StoreSpec;
use feedscope_app::store::{store_error, Opener};
use feedscope_store::{Store, StoreError};

use feedscope_app::AppError;

/// The environment variable read when `--store` is not given.
pub const STORE_VAR: &str = "FEEDSCOPE_STORE";
/// The environment variable read when neither `--store`, `--db` nor [`STORE_VAR`] is given.
pub const DB_VAR: &str = "FEEDSCOPE_DB";
/// The SQLite file when nothing says where the store is.
const DEFAULT_DB: &str = "feedscope.db";

/// The store of the flags and the environment: `--store`, `--db`, [`STORE_VAR`], [`DB_VAR`],
/// `feedscope.db`, the first one given.
///
/// # Errors
/// [`AppError::bad_input`] when both `--db` and `--store` are given.
pub fn resolve(db: Option<&Path>, store: Option<&str>) -> Result<StoreSpec> {
    let env = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty());
    Ok(match (db, store) {
        (Some(d), Some(s)) => {
            return Err(AppError::bad_input(format!(
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

/// How the command line opens a store: [`open_options`] each time, with a wait for
/// another process's lock said on stderr.
pub fn opener() -> Opener {
    Opener::saying(|m| eprintln!("{m}"))
}

/// [`opener`] as a method of the store to open.
pub trait Open {
    /// Open the store (creating or migrating its schema).
    ///
    /// # Errors
    /// As [`Opener::open_versioned`].
    fn open(&self) -> Result<Box<dyn Store>> {
        Ok(self.open_with_version()?.0)
    }

    /// [`open`](Self::open), with the schema version of the store.
    fn open_with_version(&self) -> Result<(Box<dyn Store>, i64)>;
}

impl Open for StoreSpec {
    fn open_with_version(&self) -> Result<(Box<dyn Store>, i64)> {
        Ok(opener().open_versioned(self)?)
    }
}

/// Open the history store that `--db` and `--store` (or the environment) name.
///
/// # Errors
/// As [`resolve`] and [`Open::open`].
pub fn open_store(db: Option<&Path>, store: Option<&str>) -> Result<Box<dyn Store>> {
    resolve(db, store)?.open()
}

/// The store that `--db` and `--store` (or the environment) name, for messages (its password
/// hidden); both flags together are described as the `--store` one.
pub fn describe(db: Option<&Path>, store: Option<&str>) -> String {
    match resolve(db, store) {
        Ok(s) => s.describe(),
        Err(_) => store.map_or_else(String::new, |s| StoreSpec::parse(s).describe()),
    }
}

/// A store error with the store named once ([`feedscope_app::store::store_error`]).
pub fn store_err(e: StoreError, spec: &StoreSpec) -> anyhow::Error {
    store_error(e, spec).into()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_beat_the_environment_and_do_not_go_together() {
        let d = resolve(Some(Path::new("a.db")), None).unwrap();
        assert_eq!(d, StoreSpec::Sqlite("a.db".into()));
        let s = resolve(None, Some("postgres://u@h/x")).unwrap();
        assert_eq!(s, StoreSpec::Postgres("postgres://u@h/x".into()));
        let e = resolve(Some(Path::new("a.db")), Some("postgres://u:pw@h/x")).unwrap_err();
        assert_eq!(crate::cmd::exit_code(&e), 2);
        assert!(!e.to_string().contains("pw@"), "{e}");
        assert_eq!(
            describe(Some(Path::new("a.db")), Some("postgres://u:pw@h/x")),
            "postgres://u:***@h/x"
        );
    }
}
