//! The `feedscope` command-line tool: a thin front end over `feedscope-app`.
//!
//! # The layers
//! ```text
//!   feedscope           maths: estimation, fits, identification, the twin
//!       ↑
//!   feedscope-io        files       feedscope-store   the condition history
//!   feedscope-live      live sources (MTConnect, OPC UA)
//!       ↑
//!   feedscope-app       use cases: Request → run → Report
//!       ↑
//!   feedscope-cli (`feedscope`), feedscope-py (`import feedscope`), a server    ← this crate
//! ```
//! A command (`cmd/`) reads its arguments, builds the use case's request, runs it and presents
//! the report: tables on stdout, plots and the HTML report (drawn by `feedscope_app::plot` and
//! `feedscope_app::report`). Diagnostics are
//! printed as `warning:`; a finding asked for with `--fail-on-warning` as `attention:` (exit
//! code 1); errors as `error:` (2 bad input, 1 otherwise).
//!
//! ```text
//! feedscope demo                       # the whole method on the twin's data
//! feedscope estimate trace.csv --axis axis.toml -o friction.csv
//! ```
use clap::Parser;
mod cmd;
mod front;
mod output;
mod store;

// mimalloc keeps freed pages for reuse; with the system allocator every stroke's multi-megabyte
// work and output arrays went back to the OS and were zeroed again (~20 % of estimation time).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> std::process::ExitCode {
    // A damaged Parquet file can make the decoder panic; that panic is caught and reported as
    // an error naming the file, so its message would only look like a crash.
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        if !feedscope_io::trace::decoding_untrusted_parquet() {
            default_hook(info);
        }
    }));
    let cli = cmd::Cli::parse();
    cmd::run(cli)
}
