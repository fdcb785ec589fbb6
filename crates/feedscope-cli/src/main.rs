//! The `feedscope` command-line tool.
use clap::Parser;
mod cmd;
mod output;
mod plot;
mod report;
mod store;

fn main() -> std::process::ExitCode {
    let cli = cmd::Cli::parse();
    cmd::run(cli)
}
