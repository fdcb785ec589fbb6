//! The time bound: a thread that watches the input being run and, past the limit, writes it
//! to the corpus directory and ends the process with exit code 3 naming the target (a hung
//! parser cannot be interrupted from outside its thread on stable Rust).

use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

static EPOCH: OnceLock<Instant> = OnceLock::new();
/// Start of the input being run, in ns since [`EPOCH`] plus one; 0 = idle.
static STARTED: AtomicU64 = AtomicU64::new(0);
static INPUT: Mutex<Vec<u8>> = Mutex::new(Vec::new());

struct Config {
    target: Mutex<String>,
    out: PathBuf,
    limit: Duration,
}

static CONFIG: OnceLock<Config> = OnceLock::new();

fn now_ns() -> u64 {
    EPOCH.get_or_init(Instant::now).elapsed().as_nanos() as u64 + 1
}

/// Start the watchdog: inputs running longer than `limit` are written under `out` and end
/// the process. Without a call, `arm` and `disarm` cost an atomic store.
pub fn start(out: PathBuf, limit: Duration) {
    if CONFIG
        .set(Config {
            target: Mutex::new(String::new()),
            out,
            limit,
        })
        .is_err()
    {
        return;
    }
    std::thread::spawn(|| loop {
        std::thread::sleep(Duration::from_millis(20));
        let s = STARTED.load(Relaxed);
        let Some(cfg) = CONFIG.get() else { return };
        if s != 0 && Duration::from_nanos(now_ns().saturating_sub(s)) > cfg.limit {
            let target = cfg.target.lock().map(|t| t.clone()).unwrap_or_default();
            let input = INPUT.lock().map(|i| i.clone()).unwrap_or_default();
            let dir = cfg.out.join(&target);
            let _ = std::fs::create_dir_all(&dir);
            let file = dir.join(format!("timeout-{:016x}", fnv(&input)));
            let _ = std::fs::write(&file, &input);
            eprintln!(
                "feedscope-fuzz: target {target}: an input ran longer than {:?}; written to {}",
                cfg.limit,
                file.display()
            );
            std::process::exit(3);
        }
    });
}

/// Name the target whose inputs follow (for the message and the folder).
pub fn set_target(name: &str) {
    if let Some(cfg) = CONFIG.get() {
        if let Ok(mut t) = cfg.target.lock() {
            *t = name.to_string();
        }
    }
}

pub(crate) fn arm(input: &[u8]) {
    if CONFIG.get().is_none() {
        return;
    }
    if let Ok(mut i) = INPUT.lock() {
        i.clear();
        i.extend_from_slice(input);
    }
    STARTED.store(now_ns(), Relaxed);
}

pub(crate) fn disarm() {
    STARTED.store(0, Relaxed);
}

/// FNV-1a of the bytes: a stable name for a saved input.
pub fn fnv(b: &[u8]) -> u64 {
    b.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &c| {
        (h ^ u64::from(c)).wrapping_mul(0x0100_0000_01b3)
    })
}
