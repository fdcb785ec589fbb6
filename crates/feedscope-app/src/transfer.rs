//! A history taken out of its store: the indicator values of its tests as one flat table
//! ([`export`], for a spreadsheet or another tool), and every test copied into another store
//! ([`migrate`], e.g. a gateway's SQLite file into the fleet's PostgreSQL database;
//! [`MigrateRequest`] is `history migrate` whole, the two stores opened).
use std::collections::BTreeMap;

use feedscope_store::{AddOutcome, Filter, NewTest, Store, Stored};
use serde::{Deserialize, Serialize};

use crate::store::{store_error, Opener, StoreSpec};
use crate::{AppError, FrontEnd};

/// One indicator value of one stored test: a line of `history export` (the JSON layout, and
/// the CSV columns in this order).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ExportRow {
    /// Test id in the store.
    pub test_id: i64,
    /// Machine name.
    pub machine: String,
    /// Axis name.
    pub axis: String,
    /// Test time, RFC 3339 UTC.
    pub time_utc: String,
    /// Kind of test (`strokes`, `triangle`).
    pub kind: &'static str,
    /// Indicator key (`feedscope::history::Indicator::name`).
    pub indicator: String,
    /// Value, in `unit`.
    pub value: f64,
    /// Its standard error, when known.
    pub std_error: Option<f64>,
    /// Unit of the value.
    pub unit: String,
}

/// The CSV header of [`export_csv`].
pub const EXPORT_CSV_HEADER: &str =
    "test_id,machine,axis,time_utc,kind,indicator,value,std_error,unit";

/// Every indicator value of the tests `filter` selects, ordered by machine, axis, time and
/// test id, then by indicator key.
///
/// # Errors
/// The store's, naming it.
pub fn export(
    store: &dyn Store,
    spec: &StoreSpec,
    filter: &Filter,
) -> Result<Vec<ExportRow>, AppError> {
    let err = |e| store_error(e, spec);
    let mut rows = Vec::new();
    for t in store.list(filter).map_err(err)? {
        let d = store.get(t.id).map_err(err)?;
        rows.extend(d.indicators.into_iter().map(|i| ExportRow {
            test_id: t.id,
            machine: t.machine.clone(),
            axis: t.axis.clone(),
            time_utc: t.time_utc.clone(),
            kind: t.kind.as_str(),
            indicator: i.name,
            value: i.value,
            std_error: i.std_error,
            unit: i.unit,
        }));
    }
    Ok(rows)
}

/// [`export`]'s rows as CSV with [`EXPORT_CSV_HEADER`] (RFC 4180 quoting of names; an unknown
/// standard error is an empty field; numbers as the shortest text that reads back exactly).
pub fn export_csv(rows: &[ExportRow]) -> String {
    let mut s = format!("{EXPORT_CSV_HEADER}\n");
    for r in rows {
        s.push_str(&format!(
            "{},{},{},{},{},{},{},{},{}\n",
            r.test_id,
            csv_field(&r.machine),
            csv_field(&r.axis),
            r.time_utc,
            r.kind,
            csv_field(&r.indicator),
            r.value,
            r.std_error.map_or(String::new(), |x| x.to_string()),
            csv_field(&r.unit)
        ));
    }
    s
}

/// A CSV field, quoted when it holds a comma, a quote or a line break (RFC 4180).
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// What [`migrate`] did: the JSON layout of `history migrate --format json`.
#[derive(Debug, Default, Clone, PartialEq, Eq, Serialize)]
pub struct MigrateReport {
    /// Tests in the source.
    pub tests: usize,
    /// Copied into the target.
    pub added: usize,
    /// Already in the target (same axis, kind and trace content), not copied again.
    pub already_there: usize,
}

/// Every test of `source` added to `target` in the order of its ids, with all its results,
/// its report curves, its axis's parameters and the time it was first added; a test the
/// target already holds is counted, not copied. Documents another version wrote are copied
/// as they are ([`Stored::Unread`]). Running it again after an interruption copies what is
/// missing.
///
/// # Errors
/// Bad input when `from` and `to` are the same store (naming the fields `from` and `to`); the stores' errors, naming the store and
/// (while copying) the test.
pub fn migrate(
    source: &dyn Store,
    from: &StoreSpec,
    target: &mut dyn Store,
    to: &StoreSpec,
    front: &dyn FrontEnd,
) -> Result<MigrateReport, AppError> {
    if from == to {
        return Err(AppError::bad_input(format!(
            "{} and {} are the same store ({}); nothing to copy",
            front.name("from"),
            front.name("to"),
            from.describe()
        )));
    }
    let src_err = |e| store_error(e, from);
    let mut rows = source.list(&Filter::default()).map_err(src_err)?;
    rows.sort_by_key(|r| r.id);
    let mut n = MigrateReport {
        tests: rows.len(),
        ..MigrateReport::default()
    };
    // The axis parameters of each axis, read once.
    let mut params: BTreeMap<(String, String), Stored<feedscope::axis::AxisParams>> =
        BTreeMap::new();
    for (k, r) in rows.iter().enumerate() {
        front.progress("copying tests", k, rows.len());
        let key = (r.machine.clone(), r.axis.clone());
        let axis_params = match params.get(&key) {
            Some(p) => p.clone(),
            None => {
                let p = source
                    .axis_params(&r.machine, &r.axis)
                    .map_err(src_err)?
                    .unwrap_or_else(|| Stored::from_json("{}"));
                params.insert(key, p.clone());
                p
            }
        };
        let d = source.get(r.id).map_err(src_err)?;
        let t = NewTest {
            machine: r.machine.clone(),
            axis: r.axis.clone(),
            axis_params,
            time_utc: r.time_utc.clone(),
            time_s: r.time_s,
            kind: r.kind,
            source: r.source.clone(),
            content_sha256: r.content_sha256.clone(),
            program: r.program.clone(),
            reference: r.reference,
            compensation_ref: r.compensation_ref.clone(),
            identified: d.identified,
            intervals: d.intervals,
            components: d.components,
            indicators: d.indicators,
            curves: source.curves(r.id).map_err(src_err)?,
        };
        match target.add_copy(&t, &r.added_utc) {
            Ok(AddOutcome::Added(_)) => n.added += 1,
            Ok(AddOutcome::Duplicate(_)) => n.already_there += 1,
            Err(e) => {
                let e = store_error(e, to);
                return Err(AppError::caused(
                    e.kind(),
                    format!("copying test {} of {}", r.id, from.describe()),
                    e,
                ));
            }
        }
    }
    front.progress("copying tests", rows.len(), rows.len());
    Ok(n)
}

/// `history migrate`: copy every test of one store into another.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MigrateRequest {
    /// The store to read: a `postgres://` URL or an SQLite file ([`StoreSpec::parse`]).
    pub from: String,
    /// The store to write, created when empty: a `postgres://` URL or an SQLite file.
    pub to: String,
}

impl MigrateRequest {
    /// The store read.
    pub fn from_spec(&self) -> StoreSpec {
        StoreSpec::parse(&self.from)
    }

    /// The store written.
    pub fn to_spec(&self) -> StoreSpec {
        StoreSpec::parse(&self.to)
    }

    /// Open both stores with `opener` and [`migrate`]. A source SQLite file must exist
    /// (opening it would create an empty database there); the same store as both is refused
    /// by [`migrate`] before anything is copied.
    ///
    /// # Errors
    /// Bad input naming the `from` field when its SQLite file does not exist; an opening's
    /// error under which store it was (`from` or `to`); as [`migrate`].
    pub fn run(&self, opener: &Opener, front: &dyn FrontEnd) -> Result<MigrateReport, AppError> {
        let (from, to) = (self.from_spec(), self.to_spec());
        if from != to {
            if let Some(p) = from.sqlite_path() {
                if !p.exists() {
                    return Err(AppError::invalid(
                        "from",
                        format!(
                            "{} {}: no such database file",
                            front.name("from"),
                            p.display()
                        ),
                    ));
                }
            }
        }
        let opening = |spec: &StoreSpec, which: &str, field: &str| {
            opener.open(spec).map_err(|e| {
                let context = format!("opening the {which} ({})", front.name(field));
                AppError::caused(e.kind(), context, e)
            })
        };
        let source = opening(&from, "source", "from")?;
        let mut target = opening(&to, "target", "to")?;
        migrate(&*source, &from, &mut *target, &to, front)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Quiet;
    use feedscope::ErrorKind;

    /// A source file that is not there is refused naming `from`, and none is made; an
    /// empty source copies nothing into a new target.
    #[test]
    fn a_migration_needs_its_source() {
        let d = tempfile::tempdir().unwrap();
        let path = |f: &str| d.path().join(f).display().to_string();
        let request = MigrateRequest {
            from: path("gone.db"),
            to: path("new.db"),
        };
        let e = request.run(&Opener::quiet(), &Quiet).unwrap_err();
        assert_eq!((e.kind(), e.field()), (ErrorKind::BadInput, Some("from")));
        assert!(e.to_string().starts_with("`from` "), "{e}");
        assert!(
            e.to_string().ends_with("gone.db: no such database file"),
            "{e}"
        );
        assert!(!d.path().join("gone.db").exists() && !d.path().join("new.db").exists());

        feedscope_store::SqliteStore::open(&d.path().join("empty.db")).unwrap();
        let request = MigrateRequest {
            from: path("empty.db"),
            to: path("new.db"),
        };
        let n = request.run(&Opener::quiet(), &Quiet).unwrap();
        assert_eq!(n, MigrateReport::default());
        assert_eq!(
            request.to_spec(),
            StoreSpec::Sqlite(d.path().join("new.db"))
        );
    }
}
