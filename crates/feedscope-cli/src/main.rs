//! The `feedscope` command-line tool.
use clap::Parser;
mod cmd;
mod output;
mod plot;
mod report;

// mimalloc keeps freed pages for reuse; with the system allocator every stroke's multi-megabyte
// work and output arrays went back to the OS and were zeroed again (~20 % of estimation time).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> std::process::ExitCode {
    // A damaged Parquet file can make the decoder panic; that panic is caught and reported as
    // an error naming the file, so its message would only look like a crash.
    //
    // `print!` panics when stdout is a closed pipe (`feedscope history list | head -1`). That is
    // not an error: whatever the command stored or wrote is complete, only the reader left. End
    // quietly with 0, as ripgrep does.
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let message = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        // std's message: "failed printing to stdout: Broken pipe (os error 32)".
        if message.starts_with("failed printing to stdout")
            && message.to_ascii_lowercase().contains("broken pipe")
        {
            std::process::exit(0);
        }
        if !feedscope_io::trace::decoding_untrusted_parquet() {
            default_hook(info);
        }
    }));
    let cli = cmd::Cli::parse();
    cmd::run(cli)
}
