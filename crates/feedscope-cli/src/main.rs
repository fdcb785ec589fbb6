//! The `feedscope` command-line tool.
use clap::Parser;
mod cmd;
mod output;
mod plot;
mod report;
mod store;

// mimalloc keeps freed pages for reuse; with the system allocator every stroke's multi-megabyte
// work and output arrays went back to the OS and were zeroed again (~20 % of estimation time).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> std::process::ExitCode {
    let cli = cmd::Cli::parse();
    cmd::run(cli)
}
