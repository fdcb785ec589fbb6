//! The machine/axis series of the history store in words: which ones exist when a name is not
//! among them, and which one `history add` started or added to.
use std::path::Path;

use anyhow::Result;
use feedscope_store::{AddOutcome, Filter, NewTest, Store};

use feedscope_app::AppError;

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
        [] => Err(AppError::bad_input(format!(
            "the database holds no tests yet; store one with `{}`",
            how_to_add(None)
        ))
        .into()),
        [one] => Ok(one.clone()),
        many if many.iter().any(|m| m == DEFAULT_MACHINE) => Ok(DEFAULT_MACHINE.to_string()),
        many => Err(AppError::bad_input(format!(
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
        let bad = feedscope_app::store::busy_timeout(Some("soon")).unwrap_err();
        assert_eq!(super::super::exit_code(&bad.into()), 2);
    }
}
