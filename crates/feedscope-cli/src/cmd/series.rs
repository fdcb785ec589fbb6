//! The machine/axis series of the history store in words: which ones exist when a name is not
//! among them, and which one `history add` started or added to; and how every command opens
//! the store ([`store_options`]: the busy timeout and what is said while waiting).
use std::path::Path;
use std::time::Duration;

use anyhow::Result;
use feedscope_store::{AddOutcome, Filter, NewTest, OpenOptions, Store};

use super::BadInput;

/// How to store a test, for messages about an empty or missing database; `db` is the
/// database when it was given with `--db` (the environment variable and the default name
/// apply to `history add` as they do to the other commands).
pub fn how_to_add(db: Option<&Path>) -> String {
    let db = db.map_or(String::new(), |p| format!(" --db {}", p.display()));
    format!(
        "feedscope history{db} add TRACE --axis AXIS.toml --kind strokes|triangle \
         [--machine NAME]"
    )
}

/// The environment variable that sets how long a command waits for another process's write
/// lock on the history database, in seconds.
pub const BUSY_TIMEOUT_VAR: &str = "FEEDSCOPE_BUSY_TIMEOUT_S";

/// The busy timeout when [`BUSY_TIMEOUT_VAR`] is not set.
const DEFAULT_BUSY_TIMEOUT_S: f64 = 30.0;

/// The busy timeout given by the value of [`BUSY_TIMEOUT_VAR`] (`None`: not set).
///
/// # Errors
/// [`BadInput`] naming the variable when the value is not a number of seconds from 0 to
/// one day.
fn busy_timeout(value: Option<&str>) -> Result<Duration> {
    let Some(v) = value else {
        return Ok(Duration::from_secs_f64(DEFAULT_BUSY_TIMEOUT_S));
    };
    match v.trim().parse::<f64>() {
        Ok(s) if (0.0..=86_400.0).contains(&s) => Ok(Duration::from_secs_f64(s)),
        _ => Err(BadInput(format!(
            "{BUSY_TIMEOUT_VAR}={v:?} is not a number of seconds from 0 to 86400"
        ))
        .into()),
    }
}

/// What a command says on stderr when it starts waiting for another process's lock.
fn waiting_message(db: &Path, up_to: Duration) -> String {
    format!(
        "the history database {} is busy (another process, probably another feedscope, is \
         writing to it); waiting up to {} s (set {BUSY_TIMEOUT_VAR} to change this)",
        db.display(),
        up_to.as_secs_f64()
    )
}

/// How every command opens the history store: the busy timeout from [`BUSY_TIMEOUT_VAR`]
/// (default 30 s), one line on stderr when a wait for another process's lock lasts, and the
/// variable named in the error when the wait ends without the lock.
///
/// # Errors
/// [`BadInput`] when [`BUSY_TIMEOUT_VAR`] holds no valid number of seconds.
pub fn store_options() -> Result<OpenOptions> {
    let value = std::env::var(BUSY_TIMEOUT_VAR).ok();
    let timeout = busy_timeout(value.as_deref())?;
    Ok(OpenOptions::default()
        .busy_timeout(timeout)
        .on_wait(|db, up_to| eprintln!("{}", waiting_message(db, up_to)))
        .busy_hint(format!(
            "to wait longer, set {BUSY_TIMEOUT_VAR} (e.g. {BUSY_TIMEOUT_VAR}=300)"
        )))
}

/// The default of `--machine` in `history add` (and of `history trend` and `report` among
/// several machines, one of them named so).
const DEFAULT_MACHINE: &str = "machine";

/// The machine `history trend` and `report` look at: `given`, or without `--machine` the only
/// machine in the store (or, among several, the one named [`DEFAULT_MACHINE`], what `history
/// add` stores without `--machine`). Otherwise bad input listing the machines.
pub fn resolve_machine(store: &dyn Store, given: Option<&str>) -> Result<String> {
    if let Some(m) = given {
        return Ok(m.to_string());
    }
    let mut machines: Vec<String> = store.axes()?.into_iter().map(|a| a.machine).collect();
    machines.sort_unstable();
    machines.dedup();
    match machines.as_slice() {
        [] => Err(BadInput(format!(
            "the database holds no tests yet; store one with `{}`",
            how_to_add(None)
        ))
        .into()),
        [one] => Ok(one.clone()),
        many if many.iter().any(|m| m == DEFAULT_MACHINE) => Ok(DEFAULT_MACHINE.to_string()),
        many => Err(BadInput(format!(
            "the database holds several machines ({}): choose one with --machine",
            many.iter()
                .map(|m| format!("{m:?}"))
                .collect::<Vec<_>>()
                .join(", ")
        ))
        .into()),
    }
}

/// Say on stderr what `history add` did to the series: started it or added to it (with the
/// machine and axis names, which may be defaults the user never typed), and where the test
/// time came from when it is the trace file's modification time (`time_from`).
///
/// # Errors
/// Store errors.
pub fn announce_add(
    store: &dyn Store,
    t: &NewTest,
    outcome: AddOutcome,
    time_from: Option<&Path>,
) -> Result<()> {
    if matches!(outcome, AddOutcome::Duplicate(_)) {
        return Ok(());
    }
    let n = store
        .list(&Filter {
            machine: Some(t.machine.clone()),
            axis: Some(t.axis.clone()),
        })?
        .len();
    if n <= 1 {
        eprintln!(
            "started the series of machine {:?}, axis {:?} (its first test)",
            t.machine, t.axis
        );
    } else {
        eprintln!(
            "added to the series of machine {:?}, axis {:?} ({n} tests now)",
            t.machine, t.axis
        );
    }
    if let Some(p) = time_from {
        eprintln!(
            "note: test time {} is the modification time of {} (give --time to set it)",
            t.time_utc,
            p.display()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

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
            assert!(e.is::<BadInput>(), "{bad}: {e:#}");
            assert!(e.to_string().contains(BUSY_TIMEOUT_VAR), "{e}");
        }
    }

    /// A lock held too long is not the input's fault (exit 1); a bad timeout value is (2).
    #[test]
    fn exit_codes_of_a_busy_store() {
        let busy = feedscope_store::StoreError::Busy {
            path: "h.db".into(),
            waited_s: 30.0,
            hint: None,
        };
        let e = anyhow::Error::new(busy).context("database h.db");
        assert_eq!(super::super::exit_code(&e), 1);
        assert_eq!(
            super::super::exit_code(&busy_timeout(Some("soon")).unwrap_err()),
            2
        );
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
}
