//! Writing results: atomic file creation, progress bars.

/// `println!` that returns the write error instead of panicking: a closed stdout
/// (`feedscope ... | head -1`) then reaches `cmd::run` as a broken pipe, which ends the
/// command quietly with exit 0. Use inside functions returning `anyhow::Result`.
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout().lock(), $($arg)*)?
    }};
}
pub(crate) use outln;

/// `print!` with the same error handling as [`outln!`].
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        write!(std::io::stdout().lock(), $($arg)*)?
    }};
}
pub(crate) use out;

pub use feedscope_app::output::{write_atomic, OutputSet};

/// On Ctrl-C (SIGINT) remove the temporary files of the outputs being written
/// ([`feedscope_app::output::remove_unfinished`]) and exit with 130, as a shell reports an
/// interrupted command: the outputs of an earlier run stay as they were and no partial one is
/// left beside them. Not for `watch`, which ends on Ctrl-C itself.
pub fn remove_temporaries_on_interrupt() {
    // Fails only when a handler is already set, which then decides.
    let _ = ctrlc::set_handler(|| {
        let removed = feedscope_app::output::remove_unfinished();
        eprintln!("interrupted: {removed} unfinished output file(s) removed");
        std::process::exit(130);
    });
}

/// A progress bar on stderr (hidden when stderr is not a terminal).
pub fn bar(len: u64, what: &str) -> indicatif::ProgressBar {
    let pb = indicatif::ProgressBar::new(len);
    pb.set_style(
        indicatif::ProgressStyle::with_template(
            "{prefix:>10} [{bar:40.cyan/blue}] {percent:>3}% {msg} ({eta})",
        )
        .expect("static template")
        .progress_chars("=> "),
    );
    pb.set_prefix(what.to_string());
    pb
}
