//! The machine/axis series of the history store in words: which ones exist when a name is not
//! among them, and which one `history add` started or added to.
use std::path::Path;

use anyhow::Result;
use feedscope_store::{AddOutcome, AxisSeries, Filter, NewTest, Store};

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

/// The default of `--machine` in `history add`, `history trend` and `report`.
const DEFAULT_MACHINE: &str = "machine";

/// `"a" (3 tests)`.
fn one(a: &AxisSeries) -> String {
    format!(
        "{:?} ({} test{})",
        a.axis,
        a.tests,
        if a.tests == 1 { "" } else { "s" }
    )
}

/// Refuse a machine, or an axis of a machine, that the store does not hold, listing those it
/// does: the machines with their axes, or the machine's axes, saying which one is taken when
/// `--axis-name` is not given. `Ok` when the names are known (or `axis` is `None` and the
/// machine is known).
///
/// # Errors
/// [`BadInput`] with that list; store errors.
pub fn check_known(store: &dyn Store, machine: &str, axis: Option<&str>) -> Result<()> {
    let all = store.axes()?;
    if all.is_empty() {
        return Err(BadInput(format!(
            "the database holds no tests yet; store one with `{}`",
            how_to_add(None)
        ))
        .into());
    }
    let mine: Vec<&AxisSeries> = all.iter().filter(|a| a.machine == machine).collect();
    if mine.is_empty() {
        let mut machines: Vec<String> = Vec::new();
        for a in &all {
            let axes: Vec<String> = all
                .iter()
                .filter(|b| b.machine == a.machine)
                .map(one)
                .collect();
            let line = format!("{:?} (axes {})", a.machine, axes.join(", "));
            if !machines.contains(&line) {
                machines.push(line);
            }
        }
        let hint = if machines.len() == 1 && all[0].machine == DEFAULT_MACHINE {
            "; it is the only one, the default when --machine is not given".to_string()
        } else if machines.len() == 1 {
            format!("; it is the only one: give --machine {:?}", all[0].machine)
        } else {
            "; choose one with --machine".to_string()
        };
        return Err(BadInput(format!(
            "no machine {machine:?} in the database; machines stored: {}{hint}",
            machines.join("; ")
        ))
        .into());
    }
    match axis {
        Some(ax) if !mine.iter().any(|a| a.axis == ax) => {
            let hint = if mine.len() == 1 {
                "; it is the only one, the default when --axis-name is not given"
            } else {
                "; choose one with --axis-name"
            };
            Err(BadInput(format!(
                "machine {machine:?} has no axis {ax:?}; axes stored: {}{hint}",
                mine.iter().map(|a| one(a)).collect::<Vec<_>>().join(", ")
            ))
            .into())
        }
        _ => Ok(()),
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
