//! feedscope-fuzz: structure-aware fuzzing of feedscope's parsers and config readers on the
//! stable toolchain (no `cargo fuzz`, no nightly).
//!
//! Each [`targets::Target`] calls a parser of `feedscope-io` (or a config parser of
//! `feedscope`) in process on inputs mutated from real files and the digital twin
//! ([`mutate`]). [`run_one`] runs one input under the four assertions: no panic
//! (`catch_unwind`), a time bound (a watchdog thread, [`watchdog`]), a memory bound (a
//! counting global allocator, [`alloc`]), and a sane result or a bad-input refusal (the
//! target's own checks).
//!
//! ```
//! use feedscope_fuzz::{run_one, targets, Limits, Outcome};
//! let t = targets::by_name("axis_toml").unwrap();
//! let dir = tempfile::tempdir().unwrap();
//! let ctx = targets::Ctx { dir: dir.path().to_path_buf() };
//! let out = run_one(&t, b"lead_mm = -1\n", &ctx, &Limits::default());
//! assert_eq!(out.outcome, Outcome::Rejected);
//! ```
#![warn(missing_docs)]
#![deny(clippy::float_cmp)]

pub mod alloc;
pub mod mutate;
pub mod rng;
pub mod seeds;
pub mod targets;
pub mod watchdog;

use std::panic::AssertUnwindSafe;
use std::sync::Mutex;
use std::time::Duration;

#[global_allocator]
static GLOBAL: alloc::Counting = alloc::Counting;

/// The bounds every input is held to.
#[derive(Debug, Clone, Copy)]
pub struct Limits {
    /// Wall time of one input.
    pub time: Duration,
    /// Peak memory one input may add (bytes).
    pub mem_bytes: usize,
}

impl Default for Limits {
    /// 5 s and 512 MB: a parser of a file of at most a few MB needs a fraction of either.
    fn default() -> Self {
        Self {
            time: Duration::from_secs(5),
            mem_bytes: 512 << 20,
        }
    }
}

/// What one input gave.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Outcome {
    /// Accepted, and the result passed the target's sanity checks.
    Accepted,
    /// Refused as bad input.
    Rejected,
    /// A panic, a memory bound exceeded, a wrong error kind or an insane accepted result.
    Finding(String),
}

/// An input's outcome with the memory it took.
#[derive(Debug, Clone)]
pub struct Run {
    /// What happened.
    pub outcome: Outcome,
    /// Peak memory above the live memory at the start (bytes).
    pub peak_bytes: usize,
}

static PANIC_MESSAGE: Mutex<Option<String>> = Mutex::new(None);

/// Replace the panic hook by one that records the message for [`run_one`] and prints
/// nothing (a panic is reported as a finding, with its input).
pub fn quiet_panics() {
    std::panic::set_hook(Box::new(|info| {
        let msg = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "(non-string payload)".into());
        let at = info
            .location()
            .map(|l| format!(" at {}:{}", l.file(), l.line()))
            .unwrap_or_default();
        if let Ok(mut m) = PANIC_MESSAGE.lock() {
            *m = Some(format!("{msg}{at}"));
        }
    }));
}

/// Run one input of `target` under the limits (the time bound is the watchdog's, armed
/// here when one runs).
pub fn run_one(target: &targets::Target, input: &[u8], ctx: &targets::Ctx, limits: &Limits) -> Run {
    if let Ok(mut cur) = alloc::CURRENT.lock() {
        cur.clear();
        cur.extend_from_slice(input);
    }
    let base = alloc::live();
    alloc::set_hard_cap(base.saturating_add(limits.mem_bytes.saturating_mul(2)));
    alloc::reset_peak();
    watchdog::arm(input);
    let r = std::panic::catch_unwind(AssertUnwindSafe(|| target.run(input, ctx)));
    watchdog::disarm();
    let peak_bytes = alloc::peak().saturating_sub(base);
    alloc::set_hard_cap(usize::MAX);
    let mut outcome = match r {
        Ok(Ok(targets::Verdict::Accepted)) => Outcome::Accepted,
        Ok(Ok(targets::Verdict::Rejected)) => Outcome::Rejected,
        Ok(Err(f)) => Outcome::Finding(f),
        Err(_) => {
            let msg = PANIC_MESSAGE
                .lock()
                .ok()
                .and_then(|mut m| m.take())
                .unwrap_or_default();
            Outcome::Finding(format!("panic: {msg}"))
        }
    };
    if peak_bytes > limits.mem_bytes && !matches!(outcome, Outcome::Finding(_)) {
        outcome = Outcome::Finding(format!(
            "peak memory {} MB above the limit of {} MB for a {}-byte input",
            peak_bytes >> 20,
            limits.mem_bytes >> 20,
            input.len()
        ));
    }
    Run {
        outcome,
        peak_bytes,
    }
}
