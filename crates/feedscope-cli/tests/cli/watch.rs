//! `feedscope watch` against real servers on loopback (run by scripts/live-tests.sh): the SHDR
//! replay helper `scripts/shdr-replay.py` serving the real Okuma log.
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::util::{feedscope, stderr, stdout};

const AXIS: &str = "name = \"guessed\"\nlead_mm = 10.0\ntable_mass_kg = 300.0\n\
                    inertia_kgm2 = 0.001\ndamping_nms_per_rad = 0.0\n\
                    torque_constant_nm_per_a = 1.0\n";

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The Python of the live test environment; the test fails without it.
fn python() -> String {
    std::env::var("FEEDSCOPE_TEST_PYTHON")
        .expect("FEEDSCOPE_TEST_PYTHON is not set: run scripts/live-tests.sh")
}

/// Start the replay helper on `log` with `args`; its child and port.
fn replay(
    log: &Path,
    args: &[&str],
) -> (
    std::process::Child,
    BufReader<std::process::ChildStdout>,
    u16,
) {
    let mut c = Command::new(python())
        .arg(repo().join("scripts/shdr-replay.py"))
        .arg(log)
        .args(args)
        .stdout(Stdio::piped())
        .spawn()
        .expect("starting scripts/shdr-replay.py");
    let mut out = BufReader::new(c.stdout.take().unwrap());
    let mut line = String::new();
    out.read_line(&mut line).unwrap();
    let port = line
        .trim()
        .strip_prefix("PORT ")
        .expect("PORT line")
        .parse()
        .unwrap();
    (c, out, port)
}

fn interrupt(pid: u32) {
    let ok = Command::new("kill")
        .args(["-INT", &pid.to_string()])
        .status()
        .unwrap()
        .success();
    assert!(ok);
}

/// The whole Okuma log (6.5 min of hobbing, with a pieced-in older recording) replayed at
/// 20× speed: watch finds motion episodes, none is a stroke test, the back-step of the
/// timestamps is a gap, nothing is stored; Ctrl-C stops it cleanly with exit 0.
#[test]
#[ignore = "needs the live test servers: scripts/live-tests.sh"]
fn real_machining_over_shdr_stores_no_test() {
    let d = tempfile::tempdir().unwrap();
    let packed =
        std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/real/okuma.txt.zst"))
            .unwrap();
    let log = d.path().join("okuma.txt");
    std::fs::write(&log, zstd::decode_all(&packed[..]).unwrap()).unwrap();
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/import/okuma_Devices.xml"),
        d.path().join("Devices.xml"),
    )
    .unwrap();
    std::fs::write(d.path().join("axis.toml"), AXIS).unwrap();
    let (mut server, mut out, port) = replay(&log, &["--speed", "20"]);
    let mut c = feedscope(d.path());
    c.args([
        "watch",
        "shdr",
        "--adapter",
        &format!("127.0.0.1:{port}"),
        "--devices",
        "Devices.xml",
        "--axis",
        "Z1",
        "--torque-per-load-nm",
        "20",
        "--axis-file",
        "axis.toml",
        "--kind",
        "strokes",
        "--db",
        "t.db",
    ])
    .stdout(Stdio::piped())
    .stderr(Stdio::piped());
    let child = c.spawn().unwrap();
    let pid = child.id();
    // Wait for the replay to finish (≈ 20 s at 20×), then give watch its standstill.
    let t0 = Instant::now();
    let mut line = String::new();
    while out.read_line(&mut line).unwrap() > 0 && !line.starts_with("DONE") {
        line.clear();
        assert!(t0.elapsed() < Duration::from_secs(120), "replay too slow");
    }
    std::thread::sleep(Duration::from_secs(3));
    interrupt(pid);
    let o = child.wait_with_output().unwrap();
    let _ = server.kill();
    let (so, se) = (stdout(&o), stderr(&o));
    assert_eq!(o.status.code(), Some(0), "{se}");
    assert!(!so.contains("stored test"), "{so}");
    assert!(se.contains("not a strokes test"), "{se}");
    assert!(se.contains("control timestamps stepped back"), "{se}");
    assert!(se.contains("stopped; 0 test(s) stored"), "{se}");
    let l = feedscope(d.path())
        .args(["history", "list", "--db", "t.db"])
        .output()
        .unwrap();
    assert_eq!(
        stdout(&l).lines().count(),
        1,
        "only the header: {}",
        stdout(&l)
    );
}
