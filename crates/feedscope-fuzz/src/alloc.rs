//! A counting global allocator: live bytes, the peak since the last reset, and a hard cap
//! beyond which an allocation is refused.
//!
//! Stable Rust has no allocation-error hook, so a refused allocation still ends the process
//! (`memory allocation of N bytes failed`). Before refusing, the allocator writes the input
//! being run to the file registered with [`set_dump`] (opened beforehand: nothing is
//! allocated on that path), so the finding is kept. The soft per-input limit is checked by
//! the runner after the input returns, from [`peak`].
#![allow(unsafe_code)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::fs::File;
use std::io::Write;
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};
use std::sync::{Mutex, OnceLock};

/// The allocator; installed by the crate as `#[global_allocator]`.
pub struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);
static HARD_CAP: AtomicUsize = AtomicUsize::new(usize::MAX);
static DUMP: OnceLock<File> = OnceLock::new();
/// The input being run, for the dump on a refused allocation.
pub(crate) static CURRENT: Mutex<Vec<u8>> = Mutex::new(Vec::new());

/// Bytes allocated and not freed.
pub fn live() -> usize {
    LIVE.load(Relaxed)
}

/// Highest [`live`] since the last [`reset_peak`].
pub fn peak() -> usize {
    PEAK.load(Relaxed)
}

/// Start a new peak measurement at the current live bytes.
pub fn reset_peak() {
    PEAK.store(LIVE.load(Relaxed), Relaxed);
}

/// Refuse any allocation that would bring the live bytes above `bytes`.
pub fn set_hard_cap(bytes: usize) {
    HARD_CAP.store(bytes, Relaxed);
}

/// The file a refused allocation writes the current input to (once per process).
pub fn set_dump(file: File) {
    let _ = DUMP.set(file);
}

fn reserve(n: usize) -> bool {
    let now = LIVE.fetch_add(n, Relaxed).saturating_add(n);
    if now > HARD_CAP.load(Relaxed) {
        LIVE.fetch_sub(n, Relaxed);
        refused(n);
        return false;
    }
    PEAK.fetch_max(now, Relaxed);
    true
}

#[cold]
fn refused(_n: usize) {
    // Nothing here allocates: a raw write of bytes already held.
    let mut err = std::io::stderr();
    let _ = err
        .write_all(b"feedscope-fuzz: allocation over the hard memory cap refused; input dumped\n");
    if let (Some(f), Ok(cur)) = (DUMP.get(), CURRENT.try_lock()) {
        let mut f: &File = f;
        let _ = f.write_all(&cur);
    }
}

// SAFETY: every call forwards to `System` with the caller's layout; the counters are atomics
// and do not affect the memory returned.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if !reserve(layout.size()) {
            return std::ptr::null_mut();
        }
        // SAFETY: forwarded with the caller's layout (non-zero size, as GlobalAlloc requires).
        let p = unsafe { System.alloc(layout) };
        if p.is_null() {
            LIVE.fetch_sub(layout.size(), Relaxed);
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if !reserve(layout.size()) {
            return std::ptr::null_mut();
        }
        // SAFETY: as `alloc`.
        let p = unsafe { System.alloc_zeroed(layout) };
        if p.is_null() {
            LIVE.fetch_sub(layout.size(), Relaxed);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` was returned by this allocator (so by `System`) with `layout`.
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Relaxed);
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let old = layout.size();
        if new_size > old && !reserve(new_size - old) {
            return std::ptr::null_mut();
        }
        // SAFETY: `ptr` was returned by `System` with `layout`; the caller guarantees
        // `new_size` is valid for its alignment.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if p.is_null() {
            if new_size > old {
                LIVE.fetch_sub(new_size - old, Relaxed);
            }
        } else if new_size < old {
            LIVE.fetch_sub(old - new_size, Relaxed);
        }
        p
    }
}
