//! Python bindings of feedscope: the native module `feedscope._feedscope` behind the Python
//! package `feedscope` (`python/feedscope/__init__.py`).
//!
//! # The layers
//! ```text
//!   feedscope           maths: estimation, fits, identification, the twin
//!       ↑
//!   feedscope-io        files       feedscope-store   the condition history
//!       ↑
//!   feedscope-app       use cases: Request → run → Report
//!       ↑
//!   feedscope-cli (`feedscope`), feedscope-py (`import feedscope`), a server    ← this crate
//! ```
//! A keyword call becomes a use case's request of `feedscope-app` and its result is that
//! use case's report (`to_dict()` is its serde form), the same request and report as the
//! `feedscope` binary's subcommand of the same name, with the same defaults, so that its
//! numbers agree with the binary's to the last printed digit; its errors carry the binary's messages and map to a
//! Python exception per [`feedscope::ErrorKind`] ([`errors`]). Long work runs with the GIL
//! released. Arrays handed to Python are the library's own vectors, moved into numpy without a
//! copy; arrays handed in are read through a borrowed view and copied once into the library's
//! [`feedscope::trace::Trace`], which owns its samples.
//!
//! Built by maturin (`crates/feedscope-py/pyproject.toml`), which enables the
//! `extension-module` feature; `cargo build`/`clippy`/`doc` of the workspace build it as a plain
//! library without that feature. See `crates/feedscope-py/README.md`.
#![warn(missing_docs)]
#![deny(clippy::float_cmp)]

use pyo3::prelude::*;

mod analyze;
mod axis;
mod convert;
mod dynamics;
pub mod errors;
mod estimate;
mod front;
mod history;
mod ident;
mod map;
mod plan;
mod sim;
mod stribeck;
mod trace;

// The binary uses mimalloc for the same reason (estimation frees and reallocates
// multi-megabyte arrays per stroke; the system allocator returned them to the OS and zeroed
// them again, ~20 % of estimation time). Only Rust allocations of this module use it.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// The native module; `feedscope/__init__.py` re-exports its contents.
#[pymodule]
fn _feedscope(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    // As the binary's `main`: a damaged Parquet file can make the decoder panic; the reader
    // catches that panic and returns an error naming the file, so the default hook's message
    // on stderr would only look like a crash. Any other panic is reported as usual (and PyO3
    // raises it as `pyo3_runtime.PanicException` instead of unwinding into Python). The hook
    // belongs to this extension's own Rust runtime, not to the interpreter.
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        if !feedscope_io::trace::decoding_untrusted_parquet() {
            default_hook(info);
        }
    }));
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("FeedscopeError", py.get_type::<errors::FeedscopeError>())?;
    m.add("BadInputError", py.get_type::<errors::BadInputError>())?;
    m.add("IoError", py.get_type::<errors::IoError>())?;
    m.add("InternalError", py.get_type::<errors::InternalError>())?;
    m.add_class::<axis::Axis>()?;
    m.add_class::<trace::Trace>()?;
    m.add_function(wrap_pyfunction!(trace::read_trace, m)?)?;
    m.add_class::<estimate::Stroke>()?;
    m.add_class::<estimate::EstimateResult>()?;
    m.add_function(wrap_pyfunction!(estimate::estimate, m)?)?;
    m.add_class::<sim::Simulation>()?;
    m.add_function(wrap_pyfunction!(sim::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(sim::default_sim_config, m)?)?;
    m.add_class::<analyze::StrokeProfile>()?;
    m.add_class::<analyze::AnalyzeResult>()?;
    m.add_function(wrap_pyfunction!(analyze::analyze, m)?)?;
    m.add_class::<plan::Plan>()?;
    m.add_function(wrap_pyfunction!(plan::plan_strokes, m)?)?;
    m.add_function(wrap_pyfunction!(plan::plan_triangle, m)?)?;
    m.add_class::<stribeck::StribeckResult>()?;
    m.add_function(wrap_pyfunction!(stribeck::fit_stribeck, m)?)?;
    m.add_class::<ident::IdentifyResult>()?;
    m.add_function(wrap_pyfunction!(ident::identify, m)?)?;
    m.add_class::<dynamics::DynamicsResult>()?;
    m.add_function(wrap_pyfunction!(dynamics::dynamics, m)?)?;
    m.add_class::<history::History>()?;
    m.add_class::<history::HistoryEntry>()?;
    m.add_class::<history::TrendResult>()?;
    m.add_class::<map::MapResult>()?;
    m.add_function(wrap_pyfunction!(map::map, m)?)?;
    Ok(())
}
