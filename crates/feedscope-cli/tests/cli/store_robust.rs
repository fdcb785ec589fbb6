//! The history store and the output files under abuse, through the real binary: `history add`
//! killed with SIGKILL at random moments, several writers at once, a reader while another
//! process holds the write lock, a writer that waits for that lock in vain, damaged files; and
//! (module `outputs`) multi-file outputs that are never mixed.
use std::path::{Path, PathBuf};
use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

use rusqlite::Connection;

use crate::history::{axis_file, triangle_trace};
use crate::util::{feedscope, run, stderr, stdout};

/// The tables whose rows belong to a test.
const CHILD_TABLES: [&str; 5] = [
    "identified",
    "interval_friction",
    "components",
    "indicators",
    "curves",
];

/// `n` traces with distinct contents (the same simulated test, each with its own comment
/// line, which the trace reader skips): `t0.csv` … under `dir`.
fn traces(dir: &Path, n: usize) -> Vec<PathBuf> {
    let base = triangle_trace(dir, "base.csv", 1.0, 7);
    let text = std::fs::read_to_string(&base).unwrap();
    (0..n)
        .map(|k| {
            let p = dir.join(format!("t{k}.csv"));
            std::fs::write(&p, format!("# copy {k}\n{text}")).unwrap();
            p
        })
        .collect()
}

/// `feedscope history --db h.db add --kind triangle TRACE`, not yet started.
fn add_cmd(dir: &Path, trace: &Path) -> std::process::Command {
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
        "--time",
        "2026-01-05T08:00:00Z",
    ])
    .arg(trace)
    .stdout(Stdio::null())
    .stderr(Stdio::piped());
    c
}

/// The `source` of every stored test, sorted.
fn sources(db: &Path) -> Vec<String> {
    let c = Connection::open(db).unwrap();
    let mut st = c
        .prepare("SELECT source FROM tests ORDER BY source")
        .unwrap();
    st.query_map([], |r| r.get(0))
        .unwrap()
        .collect::<Result<_, _>>()
        .unwrap()
}

/// The file passes SQLite's full integrity and foreign-key checks, and no row of a result
/// table belongs to a test that is not there.
fn assert_sound(db: &Path) {
    let c = Connection::open(db).unwrap();
    let ok: String = c
        .query_row("PRAGMA integrity_check", [], |r| r.get(0))
        .unwrap();
    assert_eq!(ok, "ok");
    let fk: Option<String> = c
        .query_row("PRAGMA foreign_key_check", [], |r| r.get(0))
        .ok();
    assert_eq!(fk, None, "foreign key violation");
    for t in CHILD_TABLES {
        let orphans: i64 = c
            .query_row(
                &format!("SELECT count(*) FROM {t} WHERE test_id NOT IN (SELECT id FROM tests)"),
                [],
                |r| r.get(0),
            )
            .unwrap();
        assert_eq!(orphans, 0, "orphan rows in {t}");
    }
    // every stored test has its indicators: none was cut in half
    let bare: i64 = c
        .query_row(
            "SELECT count(*) FROM tests WHERE id NOT IN (SELECT test_id FROM indicators)",
            [],
            |r| r.get(0),
        )
        .unwrap();
    assert_eq!(bare, 0, "a test without its indicators");
}

/// A small deterministic generator (xorshift64*), so that a failure can be replayed.
struct Rng(u64);

impl Rng {
    fn below(&mut self, n: u64) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) % n
    }
}

/// `history add` killed with SIGKILL at random moments (seeded), some of them inside the
/// write transaction (the test hook sleeps there): the file stays sound, every add that
/// reported success is stored, and none is stored twice.
#[test]
fn adds_killed_at_random_lose_nothing_committed() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    axis_file(d);
    const RUNS: usize = 14;
    let files = traces(d, RUNS);
    // One add to time the command, and to have a database to start from.
    let t0 = Instant::now();
    let o = run({
        let mut c = add_cmd(d, &files[0]);
        c.stderr(Stdio::piped());
        c
    });
    assert!(o.status.success(), "{}", stderr(&o));
    let full_ms = u64::try_from(t0.elapsed().as_millis()).unwrap().max(50);
    let mut succeeded = vec![files[0].clone()];
    let mut killed = 0;
    let mut rng = Rng(0x5EED_F00D_1234_5678);
    for f in &files[1..] {
        let mut c = add_cmd(d, f);
        // Half the runs dwell 300 ms inside the transaction, widening the window there.
        let in_tx = rng.below(2) == 0;
        if in_tx {
            c.env("FEEDSCOPE_TEST_SLEEP_IN_TX_MS", "300");
        }
        let mut child: Child = c.spawn().unwrap();
        let delay = rng.below(full_ms + if in_tx { 300 } else { 0 });
        std::thread::sleep(Duration::from_millis(delay));
        // SIGKILL; an error only means the process had already ended
        let _ = child.kill();
        let o = child.wait_with_output().unwrap();
        if o.status.success() {
            succeeded.push(f.clone());
        } else {
            // killed (no exit code), never a failure of its own
            assert_eq!(o.status.code(), None, "{}", stderr(&o));
            killed += 1;
        }
        assert_sound(&d.join("h.db"));
    }
    assert!(
        killed >= RUNS / 3,
        "only {killed} of {RUNS} runs were killed"
    );
    let stored = sources(&d.join("h.db"));
    for f in &succeeded {
        let name = f.display().to_string();
        assert!(stored.contains(&name), "{name} reported stored but missing");
    }
    let mut unique = stored.clone();
    unique.dedup();
    assert_eq!(unique, stored, "a trace stored twice");
    // The command works on the file afterwards, and a killed add can be repeated.
    let mut c = feedscope(d);
    c.args(["history", "--db", "h.db", "check"]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    for f in files
        .iter()
        .filter(|f| !stored.contains(&f.display().to_string()))
    {
        let o = run({
            let mut c = add_cmd(d, f);
            c.stdout(Stdio::piped());
            c
        });
        assert!(o.status.success(), "{}", stderr(&o));
    }
    assert_eq!(sources(&d.join("h.db")).len(), RUNS);
    assert_sound(&d.join("h.db"));
}

/// Four writers at once, each adding its own traces and one trace they all add: every own
/// trace is stored once, the shared one once, and every writer succeeds.
#[test]
fn concurrent_writers_lose_and_duplicate_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    axis_file(d);
    const WRITERS: usize = 4;
    const EACH: usize = 2;
    let files = traces(d, WRITERS * EACH + 1);
    let shared = files[WRITERS * EACH].clone();
    // the schema first, so that every writer starts from the same file
    let mut c = feedscope(d);
    c.args(["history", "--db", "h.db", "check"]);
    assert!(run(c).status.success());
    let writers: Vec<_> = (0..WRITERS)
        .map(|w| {
            let mine: Vec<PathBuf> = files[w * EACH..(w + 1) * EACH].to_vec();
            let shared = shared.clone();
            let dir = d.to_path_buf();
            std::thread::spawn(move || {
                for f in mine.iter().chain([&shared]) {
                    let mut c = add_cmd(&dir, f);
                    // hold the lock a while, so that the others queue behind it
                    c.env("FEEDSCOPE_TEST_SLEEP_IN_TX_MS", "100");
                    let o = c.output().unwrap();
                    assert!(o.status.success(), "{}", stderr(&o));
                }
            })
        })
        .collect();
    for w in writers {
        w.join().unwrap();
    }
    let stored = sources(&d.join("h.db"));
    let mut want: Vec<String> = files.iter().map(|f| f.display().to_string()).collect();
    want.sort();
    assert_eq!(stored, want, "each trace stored exactly once");
    assert_sound(&d.join("h.db"));
}

/// Another process holds the write lock (an open `BEGIN IMMEDIATE`): `history list`, `show`
/// and `check` still answer, with the stored test, while the lock is held.
#[test]
fn readers_answer_while_another_process_writes() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    axis_file(d);
    let files = traces(d, 1);
    let o = run(add_cmd(d, &files[0]));
    assert!(o.status.success(), "{}", stderr(&o));
    let lock = Connection::open(d.join("h.db")).unwrap();
    lock.execute_batch("BEGIN IMMEDIATE").unwrap();
    for sub in [
        vec!["list", "--format", "json"],
        vec!["show", "1", "--format", "json"],
        vec!["check"],
    ] {
        let mut c = feedscope(d);
        // with the lock still held, any wait for it would fail at once
        c.args(["history", "--db", "h.db"])
            .args(&sub)
            .env("FEEDSCOPE_BUSY_TIMEOUT_S", "0");
        let o = run(c);
        assert!(o.status.success(), "{sub:?}: {}", stderr(&o));
        assert!(stdout(&o).contains("1"), "{sub:?}: {}", stdout(&o));
    }
    lock.execute_batch("ROLLBACK").unwrap();
}

/// A writer behind another process's lock says so once on stderr, waits the timeout set by
/// FEEDSCOPE_BUSY_TIMEOUT_S, then fails with exit code 1 (not the input's fault), a message
/// naming the lock, the wait and how to wait longer; nothing is stored.
#[test]
fn a_writer_behind_a_lock_waits_then_fails_with_advice() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    axis_file(d);
    let files = traces(d, 2);
    let o = run(add_cmd(d, &files[0]));
    assert!(o.status.success(), "{}", stderr(&o));
    let lock = Connection::open(d.join("h.db")).unwrap();
    lock.execute_batch("BEGIN IMMEDIATE").unwrap();
    let mut c = add_cmd(d, &files[1]);
    c.env("FEEDSCOPE_BUSY_TIMEOUT_S", "1.5");
    let o = run(c);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert_eq!(
        err.matches("is busy (another process").count(),
        1,
        "one waiting line: {err}"
    );
    assert!(err.contains("waiting up to 1.5 s"), "{err}");
    assert!(err.contains("holds its write lock"), "{err}");
    assert!(err.contains("gave up after waiting 1."), "{err}");
    assert!(err.contains("FEEDSCOPE_BUSY_TIMEOUT_S=300"), "{err}");
    lock.execute_batch("ROLLBACK").unwrap();
    assert_eq!(sources(&d.join("h.db")).len(), 1);
    // a bad value is the user's input
    let mut c = add_cmd(d, &files[1]);
    c.env("FEEDSCOPE_BUSY_TIMEOUT_S", "soon");
    let o = run(c);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("FEEDSCOPE_BUSY_TIMEOUT_S"));
}

/// Read `child`'s stderr up to the line that says it waits for the lock (`Ok` with what it
/// said so far); `Err` with all it said when it ends (gave up or finished) without one.
fn wait_for_waiting_line(child: &mut Child) -> Result<String, String> {
    use std::io::BufRead;
    let err = child.stderr.as_mut().expect("stderr piped");
    let mut seen = String::new();
    for line in std::io::BufReader::new(err).lines() {
        let line = line.unwrap();
        seen.push_str(&line);
        seen.push('\n');
        if line.contains("is busy (another process") {
            return Ok(seen);
        }
    }
    Err(seen)
}

/// A new, empty store file whose write lock another program holds (an open `BEGIN
/// IMMEDIATE` on a file still in rollback-journal mode, as while it creates its schema):
/// `history add` waits for it, saying so once, and stores the test when the lock is freed;
/// held beyond the busy timeout, the add fails (exit 1) with the time it really waited. It
/// used to give up at once, "after waiting 0.0 s": SQLite does not call the busy handler for
/// the switch to WAL.
#[test]
fn a_new_file_locked_by_another_program_is_waited_for() {
    // freed while the add waits: stored
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    axis_file(d);
    let files = traces(d, 1);
    let db = d.join("h.db");
    let lock = Connection::open(&db).unwrap();
    lock.execute_batch("BEGIN IMMEDIATE").unwrap();
    assert_eq!(
        std::fs::metadata(&db).unwrap().len(),
        0,
        "a new, empty file"
    );
    let mut c = add_cmd(d, &files[0]);
    c.env("FEEDSCOPE_BUSY_TIMEOUT_S", "60");
    let mut child = c.spawn().unwrap();
    let said = match wait_for_waiting_line(&mut child) {
        Ok(s) => s,
        Err(s) => {
            let status = child.wait().unwrap();
            panic!("the add ended ({status}) without waiting for the lock: {s}");
        }
    };
    assert!(said.contains("waiting up to 60 s"), "{said}");
    lock.execute_batch("ROLLBACK").unwrap();
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{said}{}", stderr(&o));
    assert_eq!(sources(&db).len(), 1);
    assert_sound(&db);
    drop(lock);

    // held beyond the timeout: fails, with the wait it really had
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    axis_file(d);
    let files = traces(d, 1);
    let db = d.join("h.db");
    let lock = Connection::open(&db).unwrap();
    lock.execute_batch("BEGIN IMMEDIATE").unwrap();
    let mut c = add_cmd(d, &files[0]);
    c.env("FEEDSCOPE_BUSY_TIMEOUT_S", "1.5");
    let o = run(c);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert_eq!(err.matches("is busy (another process").count(), 1, "{err}");
    assert!(err.contains("holds its write lock"), "{err}");
    // the timeout, not "0.0 s" (the wait ends on the first retry at or past 1.5 s)
    let waited: f64 = err
        .split("gave up after waiting ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|x| x.parse().ok())
        .unwrap_or_else(|| panic!("no waiting time: {err}"));
    assert!(waited >= 1.5, "{err}");
    lock.execute_batch("ROLLBACK").unwrap();
    let tables: i64 = lock
        .query_row("SELECT count(*) FROM sqlite_schema", [], |r| r.get(0))
        .unwrap();
    assert_eq!(tables, 0, "nothing was written");
}

/// Damage that the quick check on opening does not see is still the user's wrong file: exit
/// code 2, the file named, and the file not modified.
#[test]
fn damage_past_the_quick_check_is_bad_input() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    axis_file(d);
    let files = traces(d, 1);
    let o = run(add_cmd(d, &files[0]));
    assert!(o.status.success(), "{}", stderr(&o));
    let db = d.join("h.db");
    let list = |d: &Path| {
        let mut c = feedscope(d);
        c.args(["history", "--db", "h.db", "list"]);
        run(c)
    };
    // a value of the wrong type, then a table missing, then the schema version reset
    for damage in [
        "UPDATE tests SET time_s = 'monday'",
        "DROP TABLE curves; DROP TABLE tests",
        "PRAGMA user_version = 0",
    ] {
        Connection::open(&db)
            .unwrap()
            .execute_batch(damage)
            .unwrap();
        let before = std::fs::read(&db).unwrap();
        let o = list(d);
        assert_eq!(o.status.code(), Some(2), "{damage}: {}", stderr(&o));
        assert!(stderr(&o).contains("h.db"), "{damage}: {}", stderr(&o));
        assert_eq!(std::fs::read(&db).unwrap(), before, "{damage}: modified");
    }
}

/// Outputs are never mixed: a multi-file command that fails leaves the previous run's files as
/// they were and no temporary file; temporary files that killed runs left are cleaned up.
mod outputs {
    use std::collections::BTreeMap;
    use std::path::Path;

    use feedscope::sim::{simulate, SimConfig, StrokeConfig};
    use feedscope_io::trace::{write_csv, Layout};

    use crate::util::{feedscope, run, stderr};

    /// A short simulated stroke test (20 → 120 mm and back at 200 mm/min) as `name`, with the
    /// axis file.
    fn stroke_trace(dir: &Path, name: &str, seed: u64) {
        let mut c = SimConfig {
            seed,
            ..SimConfig::default()
        };
        c.motion.start_mm = 20.0;
        c.motion.strokes = vec![
            StrokeConfig {
                to_mm: 120.0,
                feed_mm_min: 200.0,
                dwell_s: 1.0,
            },
            StrokeConfig {
                to_mm: 20.0,
                feed_mm_min: 200.0,
                dwell_s: 0.0,
            },
        ];
        let out = simulate(&c, &mut |_| {}).unwrap();
        write_csv(
            &out.trace,
            std::fs::File::create(dir.join(name)).unwrap(),
            Layout::Long,
        )
        .unwrap();
        std::fs::write(
            dir.join("axis.toml"),
            toml::to_string(&out.truth.axis).unwrap(),
        )
        .unwrap();
    }

    /// Every file under `dir` (not folders) with its bytes.
    fn snapshot(dir: &Path) -> BTreeMap<String, Vec<u8>> {
        std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.is_file())
            .map(|p| {
                let name = p.file_name().unwrap().to_string_lossy().into_owned();
                (name, std::fs::read(&p).unwrap())
            })
            .collect()
    }

    /// The pid of a process that has ended.
    fn dead_pid() -> u32 {
        let mut c = std::process::Command::new("true").spawn().unwrap();
        let pid = c.id();
        c.wait().unwrap();
        pid
    }

    fn analyze(dir: &Path, trace: &str) -> std::process::Output {
        let mut c = feedscope(dir);
        c.args(["analyze", trace, "--axis", "axis.toml", "--out", "a"]);
        run(c)
    }

    /// `analyze` writes a set of files: one that cannot be written (a folder stands where a plot
    /// goes) fails the run with exit 2 and leaves every file of the previous run as it was, with
    /// no temporary file; the temporary files of a killed run beside the outputs are removed by
    /// the next run, those of a live process kept.
    #[test]
    fn a_failed_analyze_leaves_the_previous_set_and_stale_temporaries_go() {
        let tmp = tempfile::tempdir().unwrap();
        let d = tmp.path();
        stroke_trace(d, "one.csv", 1);
        stroke_trace(d, "two.csv", 2);
        let a = d.join("a");
        std::fs::create_dir(&a).unwrap();
        let dead = dead_pid();
        let stale = [
            format!(".friction.csv.{dead}.tmp"),
            format!(".analysis.json.{dead}.tmp"),
        ];
        // pid 1 is alive: its file may be in the middle of a write
        let live = ".friction.csv.1.tmp";
        for n in stale.iter().map(String::as_str).chain([live]) {
            std::fs::write(a.join(n), "partial").unwrap();
        }
        let o = analyze(d, "one.csv");
        assert!(o.status.success(), "{}", stderr(&o));
        for n in &stale {
            assert!(!a.join(n).exists(), "{n} left behind");
        }
        assert!(a.join(live).exists(), "a live process's file removed");
        std::fs::remove_file(a.join(live)).unwrap();

        // A folder where the second run's backward spectrum goes, late in its list of files.
        std::fs::remove_file(a.join("spectrum_backward.svg")).unwrap();
        std::fs::create_dir(a.join("spectrum_backward.svg")).unwrap();
        std::fs::write(a.join("spectrum_backward.svg").join("keep"), "x").unwrap();
        let before = snapshot(&a);
        assert!(before.contains_key("friction.csv") && before.contains_key("analysis.json"));
        let o = analyze(d, "two.csv");
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(
            stderr(&o).contains("spectrum_backward.svg"),
            "{}",
            stderr(&o)
        );
        let after = snapshot(&a);
        assert_eq!(
            after.keys().collect::<Vec<_>>(),
            before.keys().collect::<Vec<_>>(),
            "files added or removed"
        );
        for (name, bytes) in &before {
            assert!(after[name] == *bytes, "{name} changed by the failed run");
        }

        // The second trace gives other files: the run that succeeds replaces them all.
        std::fs::remove_dir_all(a.join("spectrum_backward.svg")).unwrap();
        let o = analyze(d, "two.csv");
        assert!(o.status.success(), "{}", stderr(&o));
        let done = snapshot(&a);
        assert_ne!(done["friction.csv"], before["friction.csv"]);
        assert!(
            done.keys().all(|n| !n.starts_with('.')),
            "{:?}",
            done.keys()
        );
    }
    /// Issue 34 item 4: `-o` writes through a symbolic link (the link stays, the file it names
    /// is written, also one that does not exist yet), and into a named pipe directly (it stays
    /// a pipe and its reader gets the output), as a shell redirection would.
    #[test]
    #[cfg(unix)]
    fn outputs_write_through_links_and_into_pipes() {
        use std::os::unix::fs::FileTypeExt;
        let tmp = tempfile::tempdir().unwrap();
        let d = tmp.path();
        stroke_trace(d, "one.csv", 1);
        std::fs::create_dir(d.join("real")).unwrap();
        std::fs::write(d.join("real/friction.csv"), "old").unwrap();
        std::os::unix::fs::symlink("real/friction.csv", d.join("link.csv")).unwrap();
        // a link to a file not there yet, through a second link
        std::os::unix::fs::symlink("real/new.csv", d.join("dangling.csv")).unwrap();
        std::os::unix::fs::symlink("dangling.csv", d.join("chain.csv")).unwrap();
        for out in ["link.csv", "chain.csv"] {
            let mut c = feedscope(d);
            c.args(["estimate", "one.csv", "--axis", "axis.toml", "-o", out]);
            let o = run(c);
            assert!(o.status.success(), "{}", stderr(&o));
            let m = std::fs::symlink_metadata(d.join(out)).unwrap();
            assert!(m.file_type().is_symlink(), "{out} replaced by a file");
        }
        let written = std::fs::read_to_string(d.join("real/friction.csv")).unwrap();
        assert!(written.contains("position_mm"), "{written:.200}");
        let created = std::fs::read_to_string(d.join("real/new.csv")).unwrap();
        assert!(created.contains("position_mm"), "{created:.200}");
        assert!(
            std::fs::read_dir(d.join("real")).unwrap().all(|e| !e
                .unwrap()
                .file_name()
                .to_string_lossy()
                .starts_with('.')),
            "a temporary file left beside the link's target"
        );
        // a link loop is an error naming it, not a hang
        std::os::unix::fs::symlink("loop_b.csv", d.join("loop_a.csv")).unwrap();
        std::os::unix::fs::symlink("loop_a.csv", d.join("loop_b.csv")).unwrap();
        let mut c = feedscope(d);
        c.args([
            "estimate",
            "one.csv",
            "--axis",
            "axis.toml",
            "-o",
            "loop_a.csv",
        ]);
        let o = run(c);
        assert!(!o.status.success());
        assert!(stderr(&o).contains("symbolic links"), "{}", stderr(&o));

        // A named pipe with a reader on the other end.
        let fifo = d.join("pipe.csv");
        let made = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap();
        assert!(made.success());
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read_to_string(fifo).unwrap())
        };
        let mut c = feedscope(d);
        c.args([
            "estimate",
            "one.csv",
            "--axis",
            "axis.toml",
            "-o",
            "pipe.csv",
            "--summary",
            "p.json",
            "--plot",
            "p.svg",
        ]);
        let o = run(c);
        assert!(o.status.success(), "{}", stderr(&o));
        let got = reader.join().unwrap();
        assert!(got.contains("position_mm"), "{got:.200}");
        let m = std::fs::symlink_metadata(&fifo).unwrap();
        assert!(m.file_type().is_fifo(), "the pipe was replaced");
    }
    /// Issue 34 item 11: Ctrl-C (SIGINT) while the outputs are written removes their
    /// temporary files and exits with 130; the previous outputs stay as they were.
    #[test]
    #[cfg(unix)]
    fn an_interrupt_leaves_no_temporary_file() {
        let tmp = tempfile::tempdir().unwrap();
        let d = tmp.path();
        // 300 s at 8 kHz: a trace of about 100 MB, whose writing takes long enough to be
        // caught in the middle.
        std::fs::write(
            d.join("long.toml"),
            "seed = 5\n[motion]\nstart_mm = 20\n[[motion.stroke]]\nto_mm = 320\n\
             feed_mm_min = 60\n[sampling]\nmode = \"synchronous\"\nsynchronous_rate_hz = 8000\n",
        )
        .unwrap();
        std::fs::create_dir(d.join("out")).unwrap();
        std::fs::write(d.join("out/axis.toml"), "previous").unwrap();
        let mut c = feedscope(d);
        c.args(["simulate", "--config", "long.toml", "--out", "out"])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped());
        let mut child = c.spawn().unwrap();
        let hidden = |d: &Path| {
            std::fs::read_dir(d.join("out"))
                .unwrap()
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .filter(|n| n.starts_with('.'))
                .collect::<Vec<_>>()
        };
        let start = std::time::Instant::now();
        while hidden(d).is_empty() {
            assert!(child.try_wait().unwrap().is_none(), "ended before writing");
            assert!(start.elapsed().as_secs() < 120, "no temporary file seen");
            std::thread::sleep(std::time::Duration::from_millis(2));
        }
        let killed = std::process::Command::new("kill")
            .args(["-INT", &child.id().to_string()])
            .status()
            .unwrap();
        assert!(killed.success());
        let o = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(130), "{err}");
        assert!(
            err.contains("interrupted: 1 unfinished output file(s) removed"),
            "{err}"
        );
        assert!(hidden(d).is_empty(), "{:?} left behind", hidden(d));
        assert!(!d.join("out/trace.csv").exists());
        assert_eq!(
            std::fs::read_to_string(d.join("out/axis.toml")).unwrap(),
            "previous"
        );
    }
}
