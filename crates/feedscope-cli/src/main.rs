//! The `feedscope` command-line tool.
use clap::Parser;
mod cmd;
mod front;
mod output;
mod plot;
mod report;
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
