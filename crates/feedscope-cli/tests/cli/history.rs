//! `feedscope history`: add/list/show/export/remove, duplicates, a process killed inside its
//! transaction, concurrent writers, and foreign or damaged database files left untouched.
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::Stdio;

use feedscope::plan::{
    strokes_program, triangle_program, Limits, StrokeTestParams, TriangleParams,
};
use feedscope::sim::{simulate_profile, DynamicsMode, SamplingMode, SimConfig};
use feedscope::trace::EffortKind;
use feedscope_io::trace::{write_csv, Layout};

use crate::util::{feedscope, run, stderr, stdout};

/// Write the axis file of the default simulated lathe Z into `dir`.
pub fn axis_file(dir: &Path) -> PathBuf {
    let p = dir.join("axis.toml");
    let text = toml::to_string(&SimConfig::default().axis).unwrap();
    std::fs::write(&p, text).unwrap();
    p
}

/// A short triangular-wave test of the default lathe Z (ideal dynamics, 1 kHz torque), with
/// the static friction excess scaled by `fs_scale`.
pub fn triangle_trace(dir: &Path, name: &str, fs_scale: f64, seed: u64) -> PathBuf {
    let mut c = SimConfig {
        seed,
        ..SimConfig::default()
    };
    let mut f = c.friction.clone().unwrap();
    f.velocity.static_excess_n *= fs_scale;
    f.components.clear();
    c.friction = Some(f);
    c.dynamics.mode = DynamicsMode::Ideal;
    c.sampling.mode = SamplingMode::Synchronous;
    c.sampling.effort_kind = EffortKind::TorqueNm;
    let prog = triangle_program(
        &TriangleParams {
            window_min_mm: 120.0,
            window_max_mm: 200.0,
            feed_max_mm_min: 3000.0,
            levels: 6,
            min_cruise_s: 0.5,
            ..TriangleParams::default()
        },
        &Limits::default(),
    )
    .unwrap();
    let sim = simulate_profile(&c, &prog, &mut |_| {}).unwrap();
    let p = dir.join(name);
    let mut f = std::fs::File::create(&p).unwrap();
    write_csv(&sim.trace, &mut f, Layout::Long).unwrap();
    p
}

fn add(dir: &Path, trace: &Path, time: &str) -> std::process::Output {
    let mut c = feedscope(dir);
    c.args([
        "history",
        "--db",
        "h.db",
        "add",
        "--kind",
        "triangle",
        "--axis",
        "axis.toml",
    ])
    .arg(trace)
    .args(["--time", time]);
    run(c)
}

fn ids(dir: &Path) -> Vec<i64> {
    let mut c = feedscope(dir);
    c.args(["history", "--db", "h.db", "list", "--format", "json"]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    v.as_array()
        .unwrap()
        .iter()
        .map(|t| t["id"].as_i64().unwrap())
        .collect()
}

fn check_ok(dir: &Path) {
    let mut c = feedscope(dir);
    c.args(["history", "--db", "h.db", "check"]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("integrity ok, schema version 1"),
        "{}",
        stdout(&o)
    );
}

#[test]
fn add_list_show_export_remove() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    axis_file(d);
    let a = triangle_trace(d, "a.csv", 1.0, 1);
    let b = triangle_trace(d, "b.csv", 1.2, 2);
    let o = add(d, &a, "2026-01-05T08:00:00Z");
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("stored test 1"), "{}", stdout(&o));
    let o = add(d, &b, "2026-01-12T08:00:00+01:00");
    assert!(o.status.success(), "{}", stderr(&o));
    // the same bytes again, even under another name and time: not duplicated
    std::fs::copy(&a, d.join("a-copy.csv")).unwrap();
    let o = add(d, &d.join("a-copy.csv"), "2026-02-01T00:00:00Z");
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("already stored as test 1"),
        "{}",
        stdout(&o)
    );
    assert_eq!(ids(d), vec![1, 2]);

    let mut c = feedscope(d);
    c.args(["history", "--db", "h.db", "show", "2", "--format", "json"]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["time_utc"], "2026-01-12T07:00:00Z");
    assert_eq!(v["axis"], "simulated lathe Z");
    let fs = v["identified"]["fs_n"].as_f64().unwrap();
    let se = v["identified"]["fs_std_n"].as_f64().unwrap();
    // truth ≈ 250 N mean level + 1.2·80 N excess over the 120-200 mm window; identification
    // within a few percent (the ident round trips hold 5 %)
    assert!(
        fs > 300.0 && fs < 420.0 && se > 0.0 && se < 20.0,
        "Fs {fs} ± {se}"
    );

    // environment variable instead of --db
    let mut c = feedscope(d);
    c.env("FEEDSCOPE_DB", d.join("h.db"))
        .args(["history", "export", "--format", "csv"]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "test_id,machine,axis,time_utc,kind,indicator,value,std_error,unit"
    );
    assert_eq!(lines.count(), 10, "5 indicators × 2 tests:\n{text}");
    let mut c = feedscope(d);
    c.args([
        "history", "--db", "h.db", "export", "--format", "json", "-o", "x.json",
    ]);
    assert!(run(c).status.success());
    let v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("x.json")).unwrap()).unwrap();
    assert_eq!(v.as_array().unwrap().len(), 10);

    // remove asks; "n" keeps it, "y" removes it, --yes does not ask
    for (answer, left) in [("n\n", vec![1, 2]), ("y\n", vec![2])] {
        let mut c = feedscope(d);
        c.args(["history", "--db", "h.db", "remove", "1"])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        let mut child = c.spawn().unwrap();
        child
            .stdin
            .take()
            .unwrap()
            .write_all(answer.as_bytes())
            .unwrap();
        let o = child.wait_with_output().unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(ids(d), left);
    }
    let mut c = feedscope(d);
    c.args(["history", "--db", "h.db", "remove", "2", "--yes"]);
    assert!(run(c).status.success());
    assert!(ids(d).is_empty());
    let mut c = feedscope(d);
    c.args(["history", "--db", "h.db", "show", "2"]);
    assert_eq!(run(c).status.code(), Some(2));
    check_ok(d);
}

#[test]
fn bad_time_is_bad_input() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    axis_file(d);
    std::fs::write(d.join("t.csv"), "x").unwrap();
    let o = add(d, &d.join("t.csv"), "last tuesday");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("RFC 3339"), "{}", stderr(&o));
    assert!(
        !d.join("h.db").exists(),
        "nothing created before validation"
    );
}

/// Issue 34 item 8: an add refused for its trace (one that cannot be read, one whose table
/// never moves) creates no database; once one exists, a refused add leaves it as it was.
#[test]
fn a_refused_add_creates_no_database() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    axis_file(d);
    std::fs::write(
        d.join("bad.csv"),
        "time_s,channel,value\n0.0,position_mm,x\n",
    )
    .unwrap();
    let mut still = String::from("time_s,channel,value\n");
    for k in 0..2000 {
        let t = k as f64 * 0.01;
        still.push_str(&format!("{t},position_mm,100.0\n{t},current_a,0.5\n"));
    }
    std::fs::write(d.join("still.csv"), still).unwrap();
    for name in ["bad.csv", "still.csv"] {
        let o = add(d, &d.join(name), "2030-01-01T00:00:00Z");
        assert_eq!(o.status.code(), Some(2), "{name}: {}", stderr(&o));
        assert!(!d.join("h.db").exists(), "{name}: a database was created");
    }
    let good = triangle_trace(d, "good.csv", 1.0, 5);
    let o = add(d, &good, "2030-01-01T00:00:00Z");
    assert!(o.status.success(), "{}", stderr(&o));
    let before = ids(d);
    let o = add(d, &d.join("still.csv"), "2030-01-02T00:00:00Z");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_eq!(ids(d), before);
}

/// SIGKILL while `history add` is inside its transaction: the committed test stays, the
/// killed one is absent, the file passes the integrity check, and the lock is released
/// (the same trace then lands).
#[test]
fn killed_add_loses_nothing_committed() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    axis_file(d);
    let a = triangle_trace(d, "a.csv", 1.0, 1);
    let b = triangle_trace(d, "b.csv", 1.1, 2);
    assert!(add(d, &a, "2026-01-05T08:00:00Z").status.success());
    let mut c = feedscope(d);
    c.args([
        "history",
        "--db",
        "h.db",
        "add",
        "--kind",
        "triangle",
        "--axis",
        "axis.toml",
    ])
    .arg(&b)
    .args(["--time", "2026-01-12T08:00:00Z"])
    .env("FEEDSCOPE_TEST_SLEEP_IN_TX_MS", "60000")
    .stdout(Stdio::null())
    .stderr(Stdio::piped());
    let mut child = c.spawn().unwrap();
    let mut err = BufReader::new(child.stderr.take().unwrap());
    let mut line = String::new();
    loop {
        line.clear();
        assert!(err.read_line(&mut line).unwrap() > 0, "child ended early");
        if line.contains("inside the transaction") {
            break;
        }
    }
    // the rows of test 2 are written but not committed
    child.kill().unwrap(); // SIGKILL
    let status = child.wait().unwrap();
    assert!(!status.success());
    check_ok(d);
    assert_eq!(ids(d), vec![1]);
    let o = add(d, &b, "2026-01-12T08:00:00Z");
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(ids(d), vec![1, 2]);
    check_ok(d);
}

/// Two `add`s at the same time: the second waits on the busy timeout while the first holds
/// the write lock (the first sleeps 1.5 s inside its transaction); both land.
#[test]
fn concurrent_adds_both_land() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    axis_file(d);
    let a = triangle_trace(d, "a.csv", 1.0, 1);
    let b = triangle_trace(d, "b.csv", 1.1, 2);
    // create the schema first so both writers start from the same file
    let mut c = feedscope(d);
    c.args(["history", "--db", "h.db", "check"]);
    assert!(run(c).status.success());
    let spawn = |trace: &Path, time: &str, sleep: &str| {
        let mut c = feedscope(d);
        c.args([
            "history",
            "--db",
            "h.db",
            "add",
            "--kind",
            "triangle",
            "--axis",
            "axis.toml",
        ])
        .arg(trace)
        .args(["--time", time])
        .env("FEEDSCOPE_TEST_SLEEP_IN_TX_MS", sleep)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
        c.spawn().unwrap()
    };
    let first = spawn(&a, "2026-01-05T08:00:00Z", "1500");
    let second = spawn(&b, "2026-01-12T08:00:00Z", "0");
    for child in [first, second] {
        let o = child.wait_with_output().unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
    }
    assert_eq!(ids(d).len(), 2);
    check_ok(d);
}

fn expect_untouched(d: &Path, bytes: &[u8], what: &str) {
    for sub in [vec!["list"], vec!["check"], vec!["export"]] {
        let mut c = feedscope(d);
        c.args(["history", "--db", "h.db"]).args(&sub);
        let o = run(c);
        assert_eq!(o.status.code(), Some(2), "{sub:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(what), "{sub:?}: {}", stderr(&o));
        assert!(stderr(&o).contains("not modified"), "{}", stderr(&o));
        assert_eq!(
            std::fs::read(d.join("h.db")).unwrap(),
            bytes,
            "file changed"
        );
    }
    let trace = d.join("t.csv");
    let o = add(d, &trace, "2026-01-05T08:00:00Z");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(d.join("h.db")).unwrap(),
        bytes,
        "file changed by add"
    );
}

#[test]
fn foreign_and_damaged_files_are_refused_untouched() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    axis_file(d);
    triangle_trace(d, "t.csv", 1.0, 1);
    // 1. not SQLite at all
    let junk: Vec<u8> = (0..10_000u32).map(|i| (i * 7919 % 251) as u8).collect();
    std::fs::write(d.join("h.db"), &junk).unwrap();
    expect_untouched(d, &junk, "not a feedscope database");

    // 2. an SQLite database of another application
    std::fs::remove_file(d.join("h.db")).unwrap();
    {
        let c = rusqlite::Connection::open(d.join("h.db")).unwrap();
        c.execute_batch("CREATE TABLE invoices (id INTEGER PRIMARY KEY, total REAL); INSERT INTO invoices VALUES (1, 9.5);")
            .unwrap();
    }
    let bytes = std::fs::read(d.join("h.db")).unwrap();
    expect_untouched(d, &bytes, "another application");

    // 3. a feedscope database with a page overwritten
    std::fs::remove_file(d.join("h.db")).unwrap();
    assert!(add(d, &d.join("t.csv"), "2026-01-05T08:00:00Z")
        .status
        .success());
    assert!(!d.join("h.db-wal").exists(), "WAL checkpointed on close");
    let mut bytes = std::fs::read(d.join("h.db")).unwrap();
    let page = 4096;
    assert!(bytes.len() >= 4 * page, "{} bytes", bytes.len());
    for b in &mut bytes[2 * page..3 * page] {
        *b = 0xA5;
    }
    std::fs::write(d.join("h.db"), &bytes).unwrap();
    let mut c = feedscope(d);
    c.args(["history", "--db", "h.db", "list"]);
    let o = run(c);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(d.join("h.db")).unwrap(),
        bytes,
        "file changed"
    );
    let o = add(d, &d.join("t.csv"), "2026-01-06T08:00:00Z");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(d.join("h.db")).unwrap(),
        bytes,
        "file changed by add"
    );
}

/// A stroke test through `history add --kind strokes`: interval means in both directions,
/// classified components and the report curves are stored.
#[test]
fn stroke_test_stores_intervals_and_components() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    axis_file(d);
    let mut c = SimConfig::default();
    c.sampling.mode = SamplingMode::Synchronous;
    c.sampling.effort_kind = EffortKind::TorqueNm;
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
    let mut f = std::fs::File::create(d.join("s.csv")).unwrap();
    write_csv(&sim.trace, &mut f, Layout::Long).unwrap();
    drop(f);
    let mut c = feedscope(d);
    c.args([
        "history",
        "--db",
        "h.db",
        "add",
        "--kind",
        "strokes",
        "--axis",
        "axis.toml",
    ])
    .args([
        "s.csv",
        "--interval-mm",
        "40",
        "--time",
        "2026-01-05T08:00:00Z",
    ]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("data verdict: a friction profile, fluctuation orders"),
        "{}",
        stderr(&o)
    );
    let mut c = feedscope(d);
    c.args(["history", "--db", "h.db", "show", "1", "--format", "json"]);
    let o = run(c);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let iv = v["intervals"].as_array().unwrap();
    // 20-260 mm: the 40 mm bins 40-80 ... 200-240 are fully covered in both directions
    for dir in ["forward", "backward"] {
        let n = iv.iter().filter(|r| r["direction"] == dir).count();
        assert!((5..=6).contains(&n), "{dir}: {n} intervals");
    }
    // the true mean levels are 250-330 N (FrictionParams::default_for) plus σ·v = 20 N
    for r in iv {
        let m = r["mean_n"].as_f64().unwrap();
        assert!(m > 230.0 && m < 400.0, "{r}");
    }
    let names: Vec<&str> = v["indicators"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i["name"].as_str().unwrap())
        .collect();
    assert!(names.contains(&"mean_n/forward/80-120mm"), "{names:?}");
    assert!(
        names.iter().any(|n| n.starts_with("amplitude_n/")),
        "{names:?}"
    );
    assert!(!v["components"].as_array().unwrap().is_empty());
    // The data verdict travels to the report.
    let mut c = feedscope(d);
    c.args(["report", "--db", "h.db", "-o", "r.html"]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let html = std::fs::read_to_string(d.join("r.html")).unwrap();
    assert!(
        html.contains("data verdict: a friction profile, fluctuation orders and their causes"),
        "the report states the stored test's verdict"
    );
}

#[test]
fn history_help() {
    let d = tempfile::tempdir().unwrap();
    for (args, name) in [
        (vec!["history", "--help"], "history_help"),
        (vec!["history", "add", "--help"], "history_add_help"),
        (vec!["history", "trend", "--help"], "history_trend_help"),
    ] {
        let mut c = feedscope(d.path());
        c.args(&args);
        let o = run(c);
        assert!(o.status.success());
        insta::assert_snapshot!(name, stdout(&o));
    }
}

/// `history reference` marks one test per axis; `list` shows it; trends then use it as μ₀.
#[test]
fn reference_test_is_marked() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    axis_file(d);
    let a = triangle_trace(d, "a.csv", 1.0, 1);
    let b = triangle_trace(d, "b.csv", 1.1, 2);
    assert!(add(d, &a, "2026-01-05T08:00:00Z").status.success());
    assert!(add(d, &b, "2026-01-12T08:00:00Z").status.success());
    for id in ["1", "2"] {
        let mut c = feedscope(d);
        c.args(["history", "--db", "h.db", "reference", id]);
        assert!(run(c).status.success());
    }
    let mut c = feedscope(d);
    c.args(["history", "--db", "h.db", "list", "--format", "json"]);
    let v: serde_json::Value = serde_json::from_slice(&run(c).stdout).unwrap();
    let refs: Vec<bool> = v
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["reference"].as_bool().unwrap())
        .collect();
    assert_eq!(
        refs,
        vec![false, true],
        "one reference per axis, the latest marked"
    );
    let mut c = feedscope(d);
    c.args(["history", "--db", "h.db", "reference", "9"]);
    assert_eq!(run(c).status.code(), Some(2));
}

/// Issue 11 through the binary: four stroke tests of a short twin (lead 8 mm, 180 kg,
/// 4 → 92 → 4 mm at 20 mm/min, 40 ms asynchronous polling), a 6 mm-wide friction bump at
/// 56 mm growing 5 N a test from the third. `history trend` with defaults flags it in test 3
/// at its position, local, and calls it local wear; the report draws the heat map and the
/// flagged range.
#[test]
fn local_wear_is_flagged_by_trend_and_drawn_by_the_report() {
    use feedscope::sim::{simulate, Bump, FrictionParams, StrokeConfig};
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let mut base = SimConfig::default();
    base.axis.lead_mm = 8.0;
    base.axis.table_mass_kg = 180.0;
    base.axis.screw_diameter_mm = Some(32.0);
    base.axis.screw_ball_diameter_mm = Some(4.763);
    base.axis.screw_balls_per_turn = Some(16.0);
    base.dynamics.mode = DynamicsMode::Ideal;
    base.sampling.position.interval_ms = 40.0;
    base.sampling.position.jitter_ms = 1.0;
    base.sampling.effort.interval_ms = 40.0;
    base.sampling.effort.jitter_ms = 1.0;
    base.sampling.effort.start_offset_ms = 20.0;
    base.motion.start_mm = 4.0;
    base.motion.strokes = vec![
        StrokeConfig {
            to_mm: 92.0,
            feed_mm_min: 20.0,
            dwell_s: 1.0,
        },
        StrokeConfig {
            to_mm: 4.0,
            feed_mm_min: 20.0,
            dwell_s: 0.0,
        },
    ];
    std::fs::write(d.join("axis.toml"), toml::to_string(&base.axis).unwrap()).unwrap();
    for k in 0..4u64 {
        let mut c = base.clone();
        c.seed = 40 + k;
        let mut f = FrictionParams::default_for(&c.axis);
        // level scatter between tests: ±0.3 %
        let level = 1.0 + 0.003 * [0.4, -0.7, 1.0, -0.2][k as usize];
        for l in [&mut f.forward, &mut f.backward] {
            l.offset_n *= level;
            l.bumps.push(Bump {
                center_mm: 56.0,
                width_mm: 6.0,
                height_n: 5.0 * k.saturating_sub(1) as f64,
            });
        }
        c.friction = Some(f);
        let sim = simulate(&c, &mut |_| {}).unwrap();
        let name = format!("s{k}.csv");
        let mut file = std::fs::File::create(d.join(&name)).unwrap();
        write_csv(&sim.trace, &mut file, Layout::Long).unwrap();
        drop(file);
        let mut c = feedscope(d);
        c.args([
            "history",
            "--db",
            "h.db",
            "add",
            "--kind",
            "strokes",
            "--axis",
            "axis.toml",
        ])
        .arg(&name)
        .args(["--time", &format!("2026-0{}-01T08:00:00Z", k + 1)]);
        let o = run(c);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let mut c = feedscope(d);
    c.args(["history", "--db", "h.db", "trend", "--format", "json"]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let dirs = v["profiles"]["directions"].as_array().unwrap();
    assert_eq!(dirs.len(), 2, "{}", v["profiles"]);
    for dir in dirs {
        let tests = dir["tests"].as_array().unwrap();
        let first = &tests[dir["first_flag"].as_u64().expect("flagged") as usize];
        assert_eq!(first["test_id"], 3, "{}", dir["direction"]);
        let r = &first["ranges"][0];
        let peak = r["peak_mm"].as_f64().unwrap();
        assert!((peak - 56.0).abs() <= 8.0, "{r}");
        assert_eq!(r["extent"], "local");
        for t in tests {
            for r in t["ranges"].as_array().unwrap() {
                let p = r["peak_mm"].as_f64().unwrap();
                assert!((p - 56.0).abs() <= 8.0, "false range {r}");
            }
        }
    }
    let diag = v["diagnosis"].to_string();
    assert!(diag.contains("Local wear"), "{diag}");
    assert!(!diag.contains("fits lubrication"), "{diag}");
    // a 3-test profile baseline and a tighter flag width are the user's to choose
    let mut c = feedscope(d);
    c.args([
        "history",
        "--db",
        "h.db",
        "trend",
        "--format",
        "json",
        "--profile-baseline-tests",
        "3",
        "--profile-limit-sigma",
        "5",
    ]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let v3: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for dir in v3["profiles"]["directions"].as_array().unwrap() {
        assert_eq!(dir["baseline_ids"], serde_json::json!([1, 2, 3]), "{dir}");
    }
    for (flag, value) in [
        ("--profile-baseline-tests", "1"),
        ("--profile-limit-sigma", "0"),
        ("--profile-limit-sigma", "NaN"),
        ("--component-false-alarm", "0"),
        ("--component-false-alarm", "0.7"),
    ] {
        let mut c = feedscope(d);
        c.args(["history", "--db", "h.db", "trend", flag, value]);
        let o = run(c);
        assert_eq!(o.status.code(), Some(2), "{flag} {value}");
        assert!(stderr(&o).contains(flag), "{flag}: {}", stderr(&o));
    }
    // text output names the flagged range
    let mut c = feedscope(d);
    c.args(["history", "--db", "h.db", "trend"]);
    let text = stdout(&run(c));
    assert!(text.contains("friction along the travel"), "{text}");
    let mut c = feedscope(d);
    c.args(["report", "--db", "h.db", "-o", "r.html"]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let html = std::fs::read_to_string(d.join("r.html")).unwrap();
    assert!(html.contains("Where is it wearing"));
    assert!(html.contains("Friction change along the travel, forward"));
    assert!(
        html.contains("flagged "),
        "the profile plot names the flagged range"
    );
}
