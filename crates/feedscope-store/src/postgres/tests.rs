//! Tests of [`PgStore`] against a real server: `scripts/postgres-tests.sh` starts one and
//! sets `FEEDSCOPE_TEST_POSTGRES`; each test makes its own database, so they run in parallel.
//! Those without a server (URL handling, error classification) run everywhere.
use std::collections::{BTreeMap, BTreeSet};
use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::sync::{Arc, Barrier};

use super::*;
use crate::{AxisSeries, SqliteStore, TestKind};

const NEEDS: &str = "needs a PostgreSQL server: scripts/postgres-tests.sh";

/// The server's URL; a PostgreSQL test run without it fails (it is never silently skipped).
fn server_url() -> String {
    std::env::var("FEEDSCOPE_TEST_POSTGRES").unwrap_or_else(|_| {
        panic!("FEEDSCOPE_TEST_POSTGRES is not set: run these tests with scripts/postgres-tests.sh")
    })
}

/// `url` with its database name replaced by `db`.
fn with_dbname(url: &str, db: &str) -> String {
    let rest = url.find("://").map_or(0, |i| i + 3);
    let path = url[rest..].find('/').map(|i| rest + i);
    let query = url[rest..].find('?').map(|i| rest + i);
    match (path, query) {
        (Some(p), Some(q)) if p < q => format!("{}/{db}{}", &url[..p], &url[q..]),
        (Some(p), None) => format!("{}/{db}", &url[..p]),
        (_, Some(q)) => format!("{}/{db}{}", &url[..q], &url[q..]),
        (None, None) => format!("{url}/{db}"),
    }
}

/// A database of its own for one test, dropped at the end.
struct FreshDb {
    admin: String,
    name: String,
    url: String,
}

impl FreshDb {
    fn new(tag: &str) -> Self {
        use std::sync::atomic::{AtomicUsize, Ordering};
        static N: AtomicUsize = AtomicUsize::new(0);
        let admin = server_url();
        let name = format!(
            "fs_{tag}_{}_{}",
            std::process::id(),
            N.fetch_add(1, Ordering::SeqCst)
        );
        let mut c = postgres::Client::connect(&admin, NoTls).expect("connect to the test server");
        c.batch_execute(&format!("CREATE DATABASE {name}")).unwrap();
        let url = with_dbname(&admin, &name);
        Self { admin, name, url }
    }

    fn raw(&self) -> postgres::Client {
        postgres::Client::connect(&self.url, NoTls).unwrap()
    }
}

impl Drop for FreshDb {
    fn drop(&mut self) {
        if let Ok(mut c) = postgres::Client::connect(&self.admin, NoTls) {
            let _ = c.batch_execute(&format!(
                "DROP DATABASE IF EXISTS {} WITH (FORCE)",
                self.name
            ));
        }
    }
}

/// An error with its sources, as the CLI prints it (`{:#}`).
fn chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut src = e.source();
    while let Some(x) = src {
        s.push_str(&format!(": {x}"));
        src = x.source();
    }
    s
}

/// A realistic test: an identification with one unknown standard error (NaN), intervals in
/// both directions, components of several causes and segments, indicators with and without
/// a standard error, curves.
fn new_test(machine: &str, axis: &str, day: u32, kind: TestKind, content: u32) -> NewTest {
    use feedscope::order::{Cause, Segment};
    let time_utc = format!("2026-01-{day:02}T08:00:00Z");
    let d = f64::from(day);
    NewTest {
        machine: machine.into(),
        axis: axis.into(),
        axis_params: crate::Stored::from_json(&format!("{{\"day\":{day},\"lead_mm\":10.0}}")),
        time_s: crate::time::parse_rfc3339(&time_utc).unwrap(),
        time_utc,
        kind,
        source: format!("week-{day}.csv"),
        content_sha256: format!("{content:064x}"),
        program: day.is_multiple_of(2).then(|| "O1000".into()),
        reference: false,
        compensation_ref: day.is_multiple_of(3).then(|| "comp-7".into()),
        identified: (kind == TestKind::Triangle).then(|| Identified {
            j_total_kgm2: 0.0085 + 1e-6 * d,
            j_std_kgm2: f64::NAN,
            fc_n: 280.0 + 0.1 * d,
            fc_std_n: 1.25,
            fs_n: 360.0 + d,
            fs_std_n: 2.0,
            sigma_n_s_per_m: 2700.0,
            sigma_std_n_s_per_m: 40.0,
            vs_mm_min: 60.0,
            vs_std_mm_min: 1.5,
            delta: 2.0,
            offset_n: -15.0,
            residual_rms_nm: 0.01,
            samples_used: 40_000,
        }),
        intervals: ["forward", "backward"]
            .iter()
            .flat_map(|dir| {
                (0..3).map(move |k| IntervalRow {
                    direction: (*dir).into(),
                    start_mm: 50.0 * f64::from(k),
                    end_mm: 50.0 * f64::from(k + 1),
                    mean_n: 300.0 + d + f64::from(k) / 3.0,
                    std_n: 4.0,
                    samples: 800 + i64::from(k),
                })
            })
            .collect(),
        components: vec![
            ComponentRow {
                direction: "backward".into(),
                segment: Segment::Whole,
                position_mm: 200.0,
                order: 1.0,
                amplitude_n: 5.5 + 0.01 * d,
                floor_n: 0.5,
                cause: Cause::Shaft(1),
                trusted: true,
            },
            ComponentRow {
                direction: "forward".into(),
                segment: "2".parse().unwrap(),
                position_mm: 75.5,
                order: 0.1,
                amplitude_n: 1.0 / 3.0,
                floor_n: 0.1,
                cause: Cause::Unexplained,
                trusted: false,
            },
        ],
        indicators: vec![
            IndicatorRow {
                name: "fs_n".into(),
                value: 360.0 + d,
                std_error: Some(2.0),
                unit: "N".into(),
            },
            IndicatorRow {
                name: "fc_n".into(),
                value: 280.0 + 0.1 * d,
                std_error: None,
                unit: "N".into(),
            },
            IndicatorRow {
                name: "Interval forward 0-50 mm".into(),
                value: 1.0 / 7.0,
                std_error: Some(1e-300),
                unit: "N".into(),
            },
        ],
        curves: content
            .is_multiple_of(2)
            .then(|| crate::Stored::from_json(&format!("{{\"grid\":[],\"day\":{day}}}"))),
    }
}

/// A series as plain values: test id, time (s), value, standard error.
type Points = Vec<(i64, f64, f64, Option<f64>)>;

/// Everything a caller can read from a store, as JSON with the time of adding blanked (it is
/// the present time in both).
fn snapshot(s: &dyn Store) -> serde_json::Value {
    let mut list = serde_json::to_value(s.list(&Filter::default()).unwrap()).unwrap();
    for r in list.as_array_mut().unwrap() {
        r["added_utc"] = "".into();
    }
    let rows = s.list(&Filter::default()).unwrap();
    let mut details = Vec::new();
    let mut curves = Vec::new();
    for r in &rows {
        let mut d = serde_json::to_value(s.get(r.id).unwrap()).unwrap();
        d["added_utc"] = "".into();
        details.push(d);
        curves.push(s.curves(r.id).unwrap());
    }
    let axes = s.axes().unwrap();
    let mut series = BTreeMap::new();
    let mut params = BTreeMap::new();
    for a in &axes {
        let key = format!("{}/{}", a.machine, a.axis);
        let ser: BTreeMap<String, Points> = s
            .series(&a.machine, &a.axis)
            .unwrap()
            .into_iter()
            .map(|(k, v)| {
                let pts = v
                    .into_iter()
                    .map(|(id, p)| (id, p.time_s, p.value, p.std_error))
                    .collect();
                (k, pts)
            })
            .collect();
        series.insert(key.clone(), ser);
        params.insert(key, s.axis_params(&a.machine, &a.axis).unwrap());
    }
    let filtered = s
        .list(&Filter {
            machine: Some("lathe 3".into()),
            axis: Some("Z".into()),
        })
        .unwrap()
        .iter()
        .map(|r| r.id)
        .collect::<Vec<_>>();
    serde_json::json!({
        "list": list, "details": details, "curves": curves, "axes": axes,
        "series": series, "params": params, "filtered": filtered,
        "unknown_params": s.axis_params("lathe 3", "nope").unwrap(),
    })
}

/// One sequence of operations, with what each returned, as text.
fn exercise(s: &mut dyn Store) -> Vec<String> {
    let mut log = Vec::new();
    let mut out = |what: &str, x: String| log.push(format!("{what}: {x}"));
    // machines and axes in an order that is not the sorted one; names whose byte order is
    // not a locale's ("Z" < "a", "lathe 3" < "lathe10")
    let plan = [
        ("lathe10", "a", 9, TestKind::Triangle, 1),
        ("lathe 3", "Z", 5, TestKind::Triangle, 2),
        ("lathe 3", "Z", 2, TestKind::Strokes, 3),
        ("lathe 3", "X", 4, TestKind::Triangle, 4),
        ("lathe 3", "Z", 7, TestKind::Triangle, 5),
        ("lathe 3", "Z", 7, TestKind::Triangle, 5), // duplicate
        ("lathe 3", "Z", 8, TestKind::Strokes, 5),  // same content, other kind: new
        ("lathe 3", "X", 8, TestKind::Triangle, 5), // same content, other axis: new
        ("lathe 3", "Z", 1, TestKind::Triangle, 6),
    ];
    let mut ids = Vec::new();
    for (k, (m, a, day, kind, content)) in plan.iter().enumerate() {
        let mut t = new_test(m, a, *day, *kind, *content);
        t.reference = k == 1 || k == 4;
        let o = s.add(&t).unwrap();
        out("add", format!("{o:?}"));
        if let AddOutcome::Added(id) = o {
            ids.push(id);
        }
    }
    out("set_reference", format!("{:?}", s.set_reference(ids[2])));
    out(
        "set_reference 999",
        format!("{:?}", s.set_reference(999).map_err(|e| e.to_string())),
    );
    out("remove", format!("{:?}", s.remove(ids[3])));
    out("remove again", format!("{:?}", s.remove(ids[3])));
    out(
        "get removed",
        format!("{:?}", s.get(ids[3]).map(|_| ()).map_err(|e| e.to_string())),
    );
    out("curves removed", format!("{:?}", s.curves(ids[3])));
    // the removed test's content can be stored again
    out(
        "add again",
        format!(
            "{:?}",
            s.add(&new_test("lathe 3", "X", 4, TestKind::Triangle, 4))
        ),
    );
    let mut t = new_test("lathe 3", "Z", 11, TestKind::Strokes, 7);
    t.reference = true;
    out("add reference", format!("{:?}", s.add(&t)));
    out(
        "check",
        format!("{:?}", s.check().map_err(|e| e.to_string())),
    );
    log
}

#[test]
#[ignore = "needs a PostgreSQL server: scripts/postgres-tests.sh"]
fn postgres_and_sqlite_give_the_same_answers() {
    let db = FreshDb::new("parity");
    let dir = tempfile::tempdir().unwrap();
    let mut lite = SqliteStore::open(&dir.path().join("h.db")).unwrap();
    let mut pg = PgStore::open(&db.url).unwrap();
    assert_eq!(pg.schema_version().unwrap(), SCHEMA_VERSION);
    let a = exercise(&mut lite);
    let b = exercise(&mut pg);
    assert_eq!(a, b);
    let (sa, sb) = (snapshot(&lite), snapshot(&pg));
    assert_eq!(sa, sb);
    // one reference per axis: the last one set
    let refs: Vec<(String, String)> = pg
        .list(&Filter::default())
        .unwrap()
        .into_iter()
        .filter(|r| r.reference)
        .map(|r| (r.machine, r.axis))
        .collect();
    assert_eq!(refs, [("lathe 3".to_string(), "Z".to_string())]);
    // floats come back bit for bit, NaN standard errors as NaN
    let t = new_test("m", "Z", 3, TestKind::Triangle, 99);
    let AddOutcome::Added(id) = pg.add(&t).unwrap() else {
        panic!("fresh content")
    };
    let d = pg.get(id).unwrap();
    assert_eq!(d.test.time_s.to_bits(), t.time_s.to_bits());
    assert!(d.identified.as_ref().unwrap().j_std_kgm2.is_nan());
    assert_eq!(d.indicators[0].name, "Interval forward 0-50 mm");
    assert_eq!(d.indicators[0].value.to_bits(), (1.0f64 / 7.0).to_bits());
    assert_eq!(d.indicators[0].std_error, Some(1e-300));
    // a second open finds the schema current and the tests there
    let again = PgStore::open(&db.url).unwrap();
    assert_eq!(snapshot(&again), snapshot(&pg));
    assert_eq!(again.axes().unwrap().len(), 4);
    assert_eq!(
        again.axes().unwrap()[0],
        AxisSeries {
            machine: "lathe 3".into(),
            axis: "X".into(),
            tests: 2
        }
    );
}

#[test]
#[ignore = "needs a PostgreSQL server: scripts/postgres-tests.sh"]
fn postgres_add_copy_keeps_the_time_of_adding() {
    let db = FreshDb::new("copy");
    let mut pg = PgStore::open(&db.url).unwrap();
    let t = new_test("m", "Z", 3, TestKind::Triangle, 1);
    let AddOutcome::Added(id) = pg.add_copy(&t, "2025-12-31T23:59:59Z").unwrap() else {
        panic!("fresh")
    };
    assert_eq!(pg.get(id).unwrap().test.added_utc, "2025-12-31T23:59:59Z");
    assert_eq!(
        pg.add_copy(&t, "2026-01-01T00:00:00Z").unwrap(),
        AddOutcome::Duplicate(id)
    );
}

/// A database holding other tables, a newer schema and damage are refused as the SQLite
/// backend refuses them, with the same kinds (bad input, exit code 2).
#[test]
#[ignore = "needs a PostgreSQL server: scripts/postgres-tests.sh"]
fn postgres_foreign_newer_and_damaged_schemas_are_refused() {
    let db = FreshDb::new("foreign");
    db.raw()
        .batch_execute("CREATE TABLE invoices (id INTEGER PRIMARY KEY)")
        .unwrap();
    let e = PgStore::open(&db.url).unwrap_err();
    assert!(
        matches!(&e, StoreError::ForeignSchema { schema, tables: 1, example, .. }
            if schema == "public" && example == "invoices"),
        "{e}"
    );
    assert!(e.is_bad_input());
    // untouched: still the one table
    let n: i64 = db
        .raw()
        .query_one(
            "SELECT count(*) FROM information_schema.tables WHERE table_schema = 'public'",
            &[],
        )
        .unwrap()
        .get(0);
    assert_eq!(n, 1);

    let db = FreshDb::new("newer");
    drop(PgStore::open(&db.url).unwrap());
    db.raw()
        .batch_execute("UPDATE feedscope_schema SET version = version + 1")
        .unwrap();
    let e = PgStore::open(&db.url).unwrap_err();
    assert!(
        matches!(e, StoreError::NewerSchema { found, supported, .. }
            if found == SCHEMA_VERSION + 1 && supported == SCHEMA_VERSION),
        "{e}"
    );
    assert!(e.is_bad_input());

    // damage: check() names it; the engine errors it causes are bad input too
    let db = FreshDb::new("damaged");
    let mut s = PgStore::open(&db.url).unwrap();
    let AddOutcome::Added(id) = s
        .add(&new_test("m", "Z", 3, TestKind::Triangle, 1))
        .unwrap()
    else {
        panic!("fresh")
    };
    s.check().unwrap();
    db.raw()
        .batch_execute("DROP INDEX tests_one_reference")
        .unwrap();
    let e = s.check().unwrap_err();
    assert!(
        matches!(&e, StoreError::Corrupt { detail, .. } if detail.contains("tests_one_reference")),
        "{e}"
    );
    db.raw().batch_execute("DROP TABLE curves").unwrap();
    let s = PgStore::open(&db.url).unwrap();
    let e = s.check().unwrap_err();
    assert!(
        matches!(&e, StoreError::Corrupt { detail, .. } if detail.contains("curves.")),
        "{e}"
    );
    let e = s.curves(id).unwrap_err();
    assert!(e.is_bad_input(), "{e:?}");
    db.raw()
        .batch_execute("ALTER TABLE tests ALTER COLUMN time_s TYPE text")
        .unwrap();
    let s = PgStore::open(&db.url).unwrap();
    let e = s.list(&Filter::default()).unwrap_err();
    assert!(e.is_bad_input(), "{e:?}");
    // a database that does not exist: the user's wrong URL
    let e = PgStore::open(&with_dbname(&server_url(), "no_such_database_here")).unwrap_err();
    assert!(e.is_bad_input(), "{e:?}");
    assert!(chain(&e).contains("does not exist"), "{}", chain(&e));
}

/// 8 writers, each with its own connection, store 1,000 tests in all on 4 axes created by
/// whoever comes first; 50 contents are offered by all 8 writers at the same moment (a
/// barrier before each). Afterwards exactly the 1,000 are stored, once each, and every
/// writer was told `Added` or `Duplicate` with the id of the stored test.
#[test]
#[ignore = "needs a PostgreSQL server: scripts/postgres-tests.sh"]
fn postgres_concurrent_writers_lose_and_duplicate_nothing() {
    const WRITERS: u32 = 8;
    const SHARED: u32 = 50;
    const OWN: u32 = (1000 - SHARED) / WRITERS; // 118 or so each, see `own_total`
    let own_total = OWN * WRITERS;
    let extra = 1000 - SHARED - own_total; // given to writer 0
    let db = FreshDb::new("writers");
    drop(PgStore::open(&db.url).unwrap());
    let axis_of = |content: u32| {
        let machines = ["lathe 1", "lathe 2"];
        let axes = ["X", "Z"];
        (
            machines[(content % 2) as usize],
            axes[((content / 2) % 2) as usize],
        )
    };
    let barrier = Arc::new(Barrier::new(WRITERS as usize));
    let handles: Vec<_> = (0..WRITERS)
        .map(|w| {
            let url = db.url.clone();
            let barrier = Arc::clone(&barrier);
            std::thread::spawn(move || {
                let mut s = PgStore::open(&url).unwrap();
                let mut seen: Vec<(u32, AddOutcome)> = Vec::new();
                let own: Vec<u32> = {
                    let n = OWN + if w == 0 { extra } else { 0 };
                    let start = 1000 + w * 10_000;
                    (start..start + n).collect()
                };
                let per_shared = own.len() / SHARED as usize;
                let mut own = own.into_iter();
                for k in 0..SHARED {
                    // all 8 offer shared content k at the same moment
                    barrier.wait();
                    let (m, a) = axis_of(k);
                    let mut t = new_test(m, a, 1 + k % 28, TestKind::Triangle, k);
                    t.reference = k.is_multiple_of(10);
                    seen.push((k, s.add(&t).unwrap()));
                    for c in own.by_ref().take(per_shared) {
                        let (m, a) = axis_of(c);
                        let mut t = new_test(m, a, 1 + c % 28, TestKind::Strokes, c);
                        t.reference = c.is_multiple_of(37);
                        seen.push((c, s.add(&t).unwrap()));
                    }
                }
                for c in own {
                    let (m, a) = axis_of(c);
                    seen.push((
                        c,
                        s.add(&new_test(m, a, 1 + c % 28, TestKind::Strokes, c))
                            .unwrap(),
                    ));
                }
                seen
            })
        })
        .collect();
    let results: Vec<Vec<(u32, AddOutcome)>> =
        handles.into_iter().map(|h| h.join().unwrap()).collect();
    let s = PgStore::open(&db.url).unwrap();
    s.check().unwrap();
    let rows = s.list(&Filter::default()).unwrap();
    assert_eq!(rows.len(), 1000, "exactly the expected number stored");
    let stored: BTreeMap<String, i64> = rows
        .iter()
        .map(|r| (r.content_sha256.clone(), r.id))
        .collect();
    assert_eq!(stored.len(), 1000, "no content stored twice");
    let mut added_per_content: BTreeMap<u32, usize> = BTreeMap::new();
    let mut expected: BTreeSet<String> = BTreeSet::new();
    for seen in &results {
        for (c, o) in seen {
            let sha = format!("{c:064x}");
            expected.insert(sha.clone());
            let id = stored[&sha];
            match o {
                AddOutcome::Added(x) => {
                    assert_eq!(*x, id);
                    *added_per_content.entry(*c).or_default() += 1;
                }
                AddOutcome::Duplicate(x) => assert_eq!(*x, id, "duplicate of the stored test"),
            }
        }
    }
    assert_eq!(
        expected,
        stored.keys().cloned().collect::<BTreeSet<_>>(),
        "none lost"
    );
    assert_eq!(added_per_content.len(), 1000);
    assert!(
        added_per_content.values().all(|&n| n == 1),
        "each added once"
    );
    // every stored test is whole
    for (m, a) in [
        ("lathe 1", "X"),
        ("lathe 1", "Z"),
        ("lathe 2", "X"),
        ("lathe 2", "Z"),
    ] {
        let n = s
            .list(&Filter {
                machine: Some(m.into()),
                axis: Some(a.into()),
            })
            .unwrap()
            .len();
        let series = s.series(m, a).unwrap();
        assert_eq!(series["fs_n"].len(), n);
        assert_eq!(series["Interval forward 0-50 mm"].len(), n);
    }
    let refs = rows.iter().filter(|r| r.reference).count();
    assert!(refs <= 4, "one reference per axis at most: {refs}");
}

/// The child of [`postgres_killed_writer_leaves_only_whole_tests`]: adds tests one after the
/// other and prints `committed CONTENT ID` after each commit. Does nothing unless the parent
/// set `FEEDSCOPE_TEST_PG_CHILD_URL`.
#[test]
#[ignore = "needs a PostgreSQL server: scripts/postgres-tests.sh"]
fn postgres_writer_child() {
    use std::io::Write;
    let Ok(url) = std::env::var("FEEDSCOPE_TEST_PG_CHILD_URL") else {
        return;
    };
    let mut s = PgStore::open(&url).unwrap();
    let mut out = std::io::stdout().lock();
    for c in 0..100_000u32 {
        let o = s
            .add(&new_test("m", "Z", 1 + c % 28, TestKind::Triangle, c))
            .unwrap();
        let AddOutcome::Added(id) = o else {
            panic!("{o:?}")
        };
        writeln!(out, "committed {c} {id}").unwrap();
        out.flush().unwrap();
    }
}

/// SIGKILL of a writer in the middle of its stream (most likely inside a transaction: it
/// sleeps 15 ms in each): every test it reported committed is stored whole, nothing else
/// but possibly the one it was committing, and the store passes `check()`.
#[test]
#[ignore = "needs a PostgreSQL server: scripts/postgres-tests.sh"]
fn postgres_killed_writer_leaves_only_whole_tests() {
    let db = FreshDb::new("killed");
    drop(PgStore::open(&db.url).unwrap());
    let mut child = Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "postgres::tests::postgres_writer_child",
            "--ignored",
            "--nocapture",
            "--test-threads=1",
        ])
        .env("FEEDSCOPE_TEST_PG_CHILD_URL", &db.url)
        .env("FEEDSCOPE_TEST_SLEEP_IN_TX_MS", "15")
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    let mut committed: BTreeMap<u32, i64> = BTreeMap::new();
    while committed.len() < 40 {
        let line = lines.next().expect("the child ended early").unwrap();
        // libtest's "test NAME ... " may precede the first line
        if let Some(rest) = line.split("committed ").nth(1) {
            let (c, id) = rest.split_once(' ').unwrap();
            committed.insert(c.parse().unwrap(), id.parse().unwrap());
        }
    }
    child.kill().unwrap(); // SIGKILL
    assert!(!child.wait().unwrap().success());
    // what it printed before dying
    for line in lines.map_while(Result::ok) {
        // libtest's "test NAME ... " may precede the first line
        if let Some(rest) = line.split("committed ").nth(1) {
            let (c, id) = rest.split_once(' ').unwrap();
            committed.insert(c.parse().unwrap(), id.parse().unwrap());
        }
    }
    let s = PgStore::open(&db.url).unwrap();
    s.check().unwrap();
    let rows = s.list(&Filter::default()).unwrap();
    let next = committed.keys().max().unwrap() + 1;
    for r in &rows {
        let c = u32::from_str_radix(&r.content_sha256, 16).unwrap();
        assert!(
            committed.get(&c) == Some(&r.id) || c == next,
            "test {} (content {c}) was never reported",
            r.id
        );
        // whole: exactly what was sent
        let sent = new_test("m", "Z", 1 + c % 28, TestKind::Triangle, c);
        let d = s.get(r.id).unwrap();
        assert_eq!(d.indicators.len(), sent.indicators.len(), "test {}", r.id);
        assert_eq!(d.intervals.len(), sent.intervals.len());
        assert_eq!(d.components.len(), sent.components.len());
        assert!(d.identified.is_some());
        assert_eq!(
            s.curves(r.id).unwrap().map(|c| c.to_json()),
            sent.curves.map(|c| c.to_json())
        );
    }
    for (c, id) in &committed {
        assert!(
            rows.iter().any(|r| r.id == *id),
            "committed test {c} (id {id}) lost"
        );
    }
    // no result rows without their test, no test without its indicators
    let orphans: i64 = db
        .raw()
        .query_one(
            "SELECT (SELECT count(*) FROM tests t WHERE NOT EXISTS
                       (SELECT 1 FROM indicators i WHERE i.test_id = t.id))
                  + (SELECT count(*) FROM indicators i WHERE NOT EXISTS
                       (SELECT 1 FROM tests t WHERE t.id = i.test_id))",
            &[],
        )
        .unwrap()
        .get(0);
    assert_eq!(orphans, 0);
}

#[test]
fn passwords_are_redacted() {
    for (url, shown) in [
        (
            "postgres://ann:secret@db:5432/h",
            "postgres://ann:***@db:5432/h",
        ),
        (
            "postgresql://ann:p%40ss:w@db/h?x=1",
            "postgresql://ann:***@db/h?x=1",
        ),
        ("postgres://ann@db/h", "postgres://ann@db/h"),
        (
            "postgres://db/h?password=secret&user=ann",
            "postgres://db/h?password=***&user=ann",
        ),
        (
            "host=db password=secret user=ann",
            "host=db password=*** user=ann",
        ),
        (
            "postgres://ann:secret@/h?host=/tmp",
            "postgres://ann:***@/h?host=/tmp",
        ),
    ] {
        assert_eq!(redact(url), shown, "{url}");
    }
}

#[test]
fn bad_addresses_are_bad_input_and_name_no_password() {
    for (url, needle) in [
        (
            "postgres://ann:secret@127.0.0.1:5432/h?sslmode=require",
            "TLS is not supported",
        ),
        (
            "postgres://ann:secret@127.0.0.1:notaport/h",
            "not a PostgreSQL connection URL",
        ),
        (
            "postgres://ann:secret@127.0.0.1/h?sslmode=sometimes",
            "not a PostgreSQL",
        ),
    ] {
        let e = PgStore::open(url).unwrap_err();
        assert!(matches!(e, StoreError::BadAddress { .. }), "{e:?}");
        assert!(e.is_bad_input());
        let msg = e.to_string();
        assert!(msg.contains(needle), "{msg}");
        assert!(!msg.contains("secret"), "{msg}");
        assert!(msg.contains("ann:***@127.0.0.1"), "{msg}");
    }
}

/// Nothing listens on port 1 of the loopback: a failure of the operation (exit code 1), not
/// the input's fault, with the engine's words.
#[test]
fn an_unreachable_server_is_an_io_failure() {
    let e = PgStore::open("postgres://ann:secret@127.0.0.1:1/h").unwrap_err();
    assert!(
        matches!(&e, StoreError::Backend(b) if b.kind() == BackendErrorKind::Other),
        "{e:?}"
    );
    assert_eq!(e.kind(), feedscope::ErrorKind::Io);
    assert!(!chain(&e).contains("secret"));
    assert!(chain(&e).contains("connect"), "{}", chain(&e));
}

#[test]
fn database_names_are_replaced_in_urls() {
    assert_eq!(with_dbname("postgres://u@h:1/a", "b"), "postgres://u@h:1/b");
    assert_eq!(
        with_dbname("postgres://u@h:1/a?x=y", "b"),
        "postgres://u@h:1/b?x=y"
    );
    assert_eq!(with_dbname("postgres://u@h:1", "b"), "postgres://u@h:1/b");
    assert_eq!(
        NEEDS,
        "needs a PostgreSQL server: scripts/postgres-tests.sh"
    );
}
