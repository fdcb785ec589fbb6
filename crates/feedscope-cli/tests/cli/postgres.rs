//! `--store SPEC` / `FEEDSCOPE_STORE` and `history migrate` against a real PostgreSQL server
//! (`scripts/postgres-tests.sh` starts one and sets `FEEDSCOPE_TEST_POSTGRES`; these tests
//! fail without it), plus the refusals that need no server: a bad URL, TLS, an unreachable
//! port, `--db` with `--store`, and no password in any message.
use std::path::Path;
use std::process::Output;

use crate::history::{axis_file, triangle_trace};
use crate::util::{feedscope, run, stderr, stdout};

/// The server's URL; a PostgreSQL test run without it fails (it is never silently skipped).
fn server_url() -> String {
    std::env::var("FEEDSCOPE_TEST_POSTGRES").unwrap_or_else(|_| {
        panic!("FEEDSCOPE_TEST_POSTGRES is not set: run these tests with scripts/postgres-tests.sh")
    })
}

/// `url` with its database name replaced by `db`.
fn with_dbname(url: &str, db: &str) -> String {
    let rest = url.find("://").map_or(0, |i| i + 3);
    match url[rest..].find('/') {
        Some(p) => format!("{}/{db}", &url[..rest + p]),
        None => format!("{url}/{db}"),
    }
}

/// `url` with a password after its user: the server trusts the loopback, so it is never
/// checked, but it must never be printed either.
fn with_password(url: &str, password: &str) -> String {
    let rest = url.find("://").unwrap() + 3;
    let at = rest
        + url[rest..]
            .find('@')
            .expect("a user in FEEDSCOPE_TEST_POSTGRES");
    format!("{}:{password}{}", &url[..at], &url[at..])
}

/// A database of its own for one test, dropped at the end.
struct FreshDb {
    admin: String,
    name: String,
    url: String,
}

impl FreshDb {
    fn new(tag: &str) -> Self {
        let admin = server_url();
        let name = format!("fscli_{tag}_{}", std::process::id());
        let mut c = postgres::Client::connect(&admin, postgres::NoTls).unwrap();
        c.batch_execute(&format!("CREATE DATABASE {name}")).unwrap();
        let url = with_dbname(&admin, &name);
        Self { admin, name, url }
    }
}

impl Drop for FreshDb {
    fn drop(&mut self) {
        if let Ok(mut c) = postgres::Client::connect(&self.admin, postgres::NoTls) {
            let _ = c.batch_execute(&format!(
                "DROP DATABASE IF EXISTS {} WITH (FORCE)",
                self.name
            ));
        }
    }
}

/// `feedscope ARGS` in `dir`.
fn fs(dir: &Path, args: &[&str]) -> Output {
    let mut c = feedscope(dir);
    c.args(args)
        .env_remove("FEEDSCOPE_STORE")
        .env_remove("FEEDSCOPE_DB");
    run(c)
}

fn ok(o: &Output) -> String {
    assert!(o.status.success(), "{}", stderr(o));
    stdout(o)
}

/// Three triangle tests of the simulated lathe Z (the second is the reference).
fn traces(d: &Path) -> Vec<(std::path::PathBuf, &'static str)> {
    axis_file(d);
    vec![
        (triangle_trace(d, "a.csv", 1.0, 1), "2026-01-05T08:00:00Z"),
        (triangle_trace(d, "b.csv", 1.1, 2), "2026-01-12T08:00:00Z"),
        (triangle_trace(d, "c.csv", 1.25, 3), "2026-01-19T08:00:00Z"),
    ]
}

/// A constant-feed stroke test of the simulated lathe Z (as in `history.rs`'s stroke test).
fn stroke_trace(dir: &Path, name: &str, seed: u64) -> std::path::PathBuf {
    use feedscope::plan::{strokes_program, Limits, StrokeTestParams};
    use feedscope::sim::{simulate_profile, SamplingMode, SimConfig};
    let mut c = SimConfig {
        seed,
        ..SimConfig::default()
    };
    c.sampling.mode = SamplingMode::Synchronous;
    c.sampling.effort_kind = feedscope::trace::EffortKind::TorqueNm;
    let prog = strokes_program(
        &StrokeTestParams {
            from_mm: 20.0,
            to_mm: 260.0,
            feeds_mm_min: vec![600.0],
            repeats: 1,
            dwell_s: 0.5,
            accel_mm_s2: 1000.0,
        },
        &Limits::default(),
    )
    .unwrap();
    let sim = simulate_profile(&c, &prog, &mut |_| {}).unwrap();
    let p = dir.join(name);
    let mut f = std::fs::File::create(&p).unwrap();
    feedscope_io::trace::write_csv(&sim.trace, &mut f, feedscope_io::trace::Layout::Long).unwrap();
    p
}

fn add_args<'a>(
    store: &'a [&'a str],
    trace: &'a Path,
    time: &'a str,
    reference: bool,
) -> Vec<String> {
    let mut v: Vec<String> = ["history"].iter().map(|s| s.to_string()).collect();
    v.extend(store.iter().map(|s| s.to_string()));
    v.extend(
        [
            "add",
            "--kind",
            "triangle",
            "--axis",
            "axis.toml",
            "--time",
            time,
        ]
        .iter()
        .map(|s| s.to_string()),
    );
    v.push(trace.display().to_string());
    if reference {
        v.push("--reference".into());
    }
    v
}

fn fs_owned(dir: &Path, args: &[String]) -> Output {
    let a: Vec<&str> = args.iter().map(String::as_str).collect();
    fs(dir, &a)
}

#[test]
#[ignore = "needs a PostgreSQL server: scripts/postgres-tests.sh"]
fn postgres_store_add_list_trend_report_check() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let db = FreshDb::new("cmds");
    let url = with_password(&db.url, "hunter2");
    let shown = url.replace(":hunter2@", ":***@");
    let mut out = String::new();
    for (k, (trace, time)) in traces(d).iter().enumerate() {
        let o = fs_owned(d, &add_args(&["--store", &url], trace, time, k == 1));
        out += &(stdout(&o) + &stderr(&o));
        assert!(
            ok(&o).contains(&format!("stored test {}", k + 1)),
            "{}",
            stdout(&o)
        );
    }
    // the same trace again: recognised
    let (a, _) = &traces(d)[0];
    let o = fs_owned(
        d,
        &add_args(&["--store", &url], a, "2026-02-01T00:00:00Z", false),
    );
    assert!(
        ok(&o).contains("already stored as test 1"),
        "{}",
        stdout(&o)
    );
    // FEEDSCOPE_STORE instead of --store
    let mut c = feedscope(d);
    c.env("FEEDSCOPE_STORE", &url)
        .env_remove("FEEDSCOPE_DB")
        .args(["history", "list", "--format", "json"]);
    let o = run(c);
    out += &(stdout(&o) + &stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&ok(&o)).unwrap();
    let refs: Vec<bool> = v
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["reference"].as_bool().unwrap())
        .collect();
    assert_eq!(refs, [false, true, false]);
    let o = fs(
        d,
        &["history", "--store", &url, "trend", "--format", "json"],
    );
    out += &(stdout(&o) + &stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&ok(&o)).unwrap();
    assert_eq!(v["tests"].as_array().unwrap().len(), 3);
    let o = fs(d, &["report", "--store", &url, "-o", "r.html"]);
    out += &(stdout(&o) + &stderr(&o));
    ok(&o);
    assert!(std::fs::read_to_string(d.join("r.html"))
        .unwrap()
        .contains("<svg"));
    let o = fs(d, &["history", "--store", &url, "check"]);
    out += &(stdout(&o) + &stderr(&o));
    assert_eq!(
        ok(&o).trim(),
        format!("{shown}: integrity ok, schema version 1")
    );
    // no such test: bad input naming the store without its password
    let o = fs(d, &["history", "--store", &url, "show", "9"]);
    out += &(stdout(&o) + &stderr(&o));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains(&shown), "{}", stderr(&o));
    let o = fs(d, &["history", "--store", &url, "reference", "9"]);
    out += &(stdout(&o) + &stderr(&o));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(!out.contains("hunter2"), "the password was printed:\n{out}");
}

/// SQLite → PostgreSQL → SQLite gives the same `history export`, `trend` and `show` output,
/// the same curves and axis parameters; a second migrate adds nothing.
#[test]
#[ignore = "needs a PostgreSQL server: scripts/postgres-tests.sh"]
fn postgres_migrate_round_trip() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let db = FreshDb::new("migrate");
    let url = with_password(&db.url, "s3cret");
    for (k, (trace, time)) in traces(d).iter().enumerate() {
        ok(&fs_owned(
            d,
            &add_args(&["--db", "a.db"], trace, time, k == 1),
        ));
    }
    // two stroke tests: intervals, components and the report curves
    for (k, time) in ["2026-01-06T08:00:00Z", "2026-01-13T08:00:00Z"]
        .iter()
        .enumerate()
    {
        let t = stroke_trace(d, &format!("s{k}.csv"), 10 + k as u64);
        let mut a = add_args(&["--db", "a.db"], &t, time, false);
        a[5] = "strokes".into();
        ok(&fs_owned(d, &a));
    }
    let o = fs(d, &["history", "migrate", "--from", "a.db", "--to", &url]);
    let text = ok(&o);
    assert!(text.contains("5 tests in a.db: 5 added to"), "{text}");
    assert!(text.contains(":***@"), "{text}");
    assert!(!text.contains("s3cret") && !stderr(&o).contains("s3cret"));
    // idempotent
    let o = fs(
        d,
        &[
            "history", "migrate", "--from", "a.db", "--to", &url, "--format", "json",
        ],
    );
    let v: serde_json::Value = serde_json::from_str(&ok(&o)).unwrap();
    assert_eq!(
        v,
        serde_json::json!({"tests": 5, "added": 0, "already_there": 5})
    );
    let o = fs(d, &["history", "migrate", "--from", &url, "--to", "b.db"]);
    assert!(
        ok(&o).contains("5 added to b.db, 0 already there"),
        "{}",
        stdout(&o)
    );
    let same = |args: &[&str]| {
        let mut outs = Vec::new();
        for store in [
            ["--db", "a.db"],
            ["--store", url.as_str()],
            ["--db", "b.db"],
        ] {
            let mut a = vec!["history"];
            a.extend(store);
            a.extend(args);
            outs.push(ok(&fs(d, &a)));
        }
        assert_eq!(outs[0], outs[1], "{args:?}: SQLite and PostgreSQL differ");
        assert_eq!(outs[0], outs[2], "{args:?}: the round trip differs");
    };
    same(&["export", "--format", "json"]);
    same(&["trend", "--format", "json"]);
    same(&["list", "--format", "json"]);
    for id in ["1", "2", "3", "4", "5"] {
        same(&["show", id, "--format", "json"]);
    }
    // what the commands above do not show: curves and axis parameters
    let rows = |file: &str, sql: &str| -> Vec<(i64, String)> {
        let c = rusqlite::Connection::open(d.join(file)).unwrap();
        let mut st = c.prepare(sql).unwrap();
        st.query_map([], |r| Ok((r.get(0)?, r.get(1)?)))
            .unwrap()
            .collect::<Result<_, _>>()
            .unwrap()
    };
    for sql in [
        "SELECT test_id, json FROM curves ORDER BY test_id",
        "SELECT id, params_json FROM axes ORDER BY id",
    ] {
        let (a, b) = (rows("a.db", sql), rows("b.db", sql));
        assert!(!a.is_empty(), "{sql}");
        assert_eq!(a, b, "{sql}");
    }
    // the same store twice, and --db with migrate: usage errors
    let o = fs(d, &["history", "migrate", "--from", "a.db", "--to", "a.db"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = fs(
        d,
        &[
            "history", "--db", "a.db", "migrate", "--from", "a.db", "--to", "c.db",
        ],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = fs(
        d,
        &["history", "migrate", "--from", "none.db", "--to", "c.db"],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(!d.join("none.db").exists());
}

/// A database the server does not have: bad input (2), named without the password.
#[test]
#[ignore = "needs a PostgreSQL server: scripts/postgres-tests.sh"]
fn postgres_missing_database_is_bad_input() {
    let tmp = tempfile::tempdir().unwrap();
    let url = with_password(&with_dbname(&server_url(), "no_such_db_here"), "pw123");
    let o = fs(tmp.path(), &["history", "--store", &url, "list"]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("does not exist"), "{err}");
    assert!(
        err.contains("no_such_db_here") && err.contains(":***@"),
        "{err}"
    );
    assert!(!err.contains("pw123"), "{err}");
}

/// Refusals that need no server: a malformed URL and TLS are bad input (2); a port nobody
/// listens on is a failure of the operation (1); `--db` with `--store` is a usage error (2).
/// No message shows the password.
#[test]
fn store_urls_that_cannot_be_used() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    for (args, code, needle) in [
        (
            vec![
                "history",
                "--store",
                "postgres://ann:pw123@127.0.0.1:1/h",
                "list",
            ],
            1,
            "PostgreSQL store postgres://ann:***@127.0.0.1:1/h: ",
        ),
        (
            vec!["report", "--store", "postgres://ann:pw123@127.0.0.1:1/h"],
            1,
            "error connecting to server",
        ),
        (
            vec![
                "history",
                "--store",
                "postgres://ann:pw123@127.0.0.1:port/h",
                "list",
            ],
            2,
            "postgres://ann:***@127.0.0.1:port/h: not a PostgreSQL connection URL",
        ),
        (
            vec![
                "history",
                "--store",
                "postgresql://ann:pw123@127.0.0.1/h?sslmode=require",
                "trend",
            ],
            2,
            "TLS is not supported yet",
        ),
        (
            vec![
                "history",
                "--db",
                "a.db",
                "--store",
                "postgres://ann:pw123@h/x",
                "list",
            ],
            2,
            "give one",
        ),
    ] {
        let o = fs(d, &args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(code), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(
            !err.contains("pw123") && !stdout(&o).contains("pw123"),
            "{err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }
    assert!(!d.join("a.db").exists());
    // FEEDSCOPE_STORE naming an SQLite file works like --db
    let mut c = feedscope(d);
    c.env("FEEDSCOPE_STORE", "e.db")
        .env_remove("FEEDSCOPE_DB")
        .args(["history", "check"]);
    let o = run(c);
    assert!(ok(&o).starts_with("e.db: integrity ok"), "{}", stdout(&o));
}

#[test]
fn history_migrate_help() {
    let d = tempfile::tempdir().unwrap();
    let o = fs(d.path(), &["history", "migrate", "--help"]);
    insta::assert_snapshot!("history_migrate_help", ok(&o));
}
