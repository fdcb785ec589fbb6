//! One module per subcommand; `run` maps errors to documented exit codes.
//!
//! Exit codes: 0 success; 1 a check failed or a requested failure condition was met; 2 bad
//! input or usage (unreadable or malformed files, invalid parameters).
use clap::{Parser, Subcommand};
use feedscope::ErrorKind;
use feedscope_app::Outcome;

mod analyze;
mod demo;
mod dynamics;
mod estimate;
mod export;
mod fit_stribeck;
pub(crate) mod history;
mod identify;
mod import;
mod map;
mod plan;
mod report;
mod series;
mod simulate;
mod watch;

pub use series::how_to_add;

/// feedscope: how are the ball-screw feed drives of this machine doing?
///
/// Reads what the CNC controller already records (axis position and servo motor current or
/// torque, with timestamps) and estimates the friction of the drive along its whole travel.
#[derive(Debug, Parser)]
#[command(name = "feedscope", version, about, long_about)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    // Help text from the doc comment of each `Args`.
    Demo(demo::Args),
    Analyze(analyze::Args),
    Estimate(estimate::Args),
    // Help text from the doc comment of `simulate::Args`.
    Simulate(simulate::Args),
    /// Natural frequency vs feed rate and position; torque-ripple resonance risks.
    Dynamics(dynamics::Args),
    // Help text from the doc comment of `identify::Args`.
    Identify(identify::Args),
    // Help text from the doc comment of `plan::Args`.
    Plan(plan::Args),
    // Help text from the doc comment of `fit_stribeck::Args`.
    FitStribeck(fit_stribeck::Args),
    // Help text from the doc comment of `map::Args`.
    Map(map::Args),
    // Help text from the doc comment of `history::Args`.
    History(history::Args),
    // Help text from the doc comment of `report::Args`.
    Report(report::Args),
    // Help text from the doc comment of `import::Args`.
    Import(import::Args),
    // Help text from the doc comment of `watch::Args`.
    Watch(watch::Args),
}

/// The kind of one error of a chain: `history check`'s failed check (exit code 1, though the
/// store's error alone would be bad input), else what the layers say of their errors
/// ([`feedscope_app::error::kind_of`]). A usage error the CLI finds itself is an
/// [`feedscope_app::AppError::bad_input`].
fn kind_of(e: &(dyn std::error::Error + 'static)) -> Option<ErrorKind> {
    if e.is::<history::CheckFailed>() {
        return Some(ErrorKind::Internal);
    }
    feedscope_app::error::kind_of(e)
}

/// The kind of an error: [`ErrorKind::BadInput`] when any error of its chain is bad input (a
/// missing file under an `Io` wrapper is still the user's input), else the kind of the first
/// error whose kind is known, else [`ErrorKind::Internal`].
pub fn error_kind(err: &anyhow::Error) -> ErrorKind {
    feedscope::error::kind_of_chain(err.chain(), kind_of)
}

/// The documented exit code of an error kind: 2 bad input or usage, 1 anything else (a
/// failure that is not the input's fault, a check that failed).
pub fn exit_code_of(kind: ErrorKind) -> u8 {
    match kind {
        ErrorKind::BadInput => 2,
        ErrorKind::Io | ErrorKind::Internal => 1,
        // A kind added later is not the input's fault until it says so.
        _ => 1,
    }
}

/// Exit code for an error: [`exit_code_of`] its [`error_kind`].
pub fn exit_code(err: &anyhow::Error) -> u8 {
    exit_code_of(error_kind(err))
}

/// True when the error is only a closed stdout (e.g. `feedscope ... | head`), which ends a
/// command quietly with exit code 0.
///
/// That is a broken pipe as the error itself, under nothing but `.context(…)` messages: what
/// a write to stdout returns ([`crate::output::outln!`] and the other `writeln!`s on
/// `std::io::stdout()` pass it up with `?`). A broken pipe further down a chain belongs to
/// whatever wrapped it: the connection to a PostgreSQL server arrives as a
/// [`feedscope_store::StoreError`] whose source is the pipe, and is a store failure (exit 1,
/// with its message), never a quiet success. (anyhow's `downcast_ref` looks through context
/// layers to the error they wrap, and only through them.)
fn is_closed_stdout(err: &anyhow::Error) -> bool {
    err.downcast_ref::<std::io::Error>()
        .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe)
}

pub fn run(cli: Cli) -> std::process::ExitCode {
    if !matches!(cli.command, Command::Watch(_)) {
        crate::output::remove_temporaries_on_interrupt();
    }
    let result = match cli.command {
        Command::Demo(a) => demo::run(a).map(done),
        Command::Analyze(a) => analyze::run(a).map(done),
        Command::Estimate(a) => estimate::run(a).map(done),
        // Prints its own errors and chooses its exit code (2 bad input, 1 otherwise).
        Command::Simulate(a) => return simulate::run(a),
        Command::Dynamics(a) => dynamics::run(a).map(done),
        Command::Identify(a) => identify::run(a).map(done),
        Command::Plan(a) => plan::run(a).map(done),
        Command::FitStribeck(a) => fit_stribeck::run(a).map(done),
        Command::Map(a) => map::run(a).map(done),
        Command::History(a) => history::run(a),
        Command::Report(a) => report::run(a).map(done),
        Command::Import(a) => import::run(a).map(done),
        Command::Watch(a) => watch::run(a).map(done),
    };
    match result {
        Ok(Outcome::Done) => std::process::ExitCode::SUCCESS,
        // A finding the user asked to be alerted to: a status line, not an error.
        Ok(o @ Outcome::Attention(_)) => {
            eprintln!("attention: {o}");
            std::process::ExitCode::from(o.exit_code())
        }
        Err(e) if is_closed_stdout(&e) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", error_text(&e));
            std::process::ExitCode::from(exit_code(&e))
        }
    }
}

/// A command that ended without a finding to alert to.
fn done(_: ()) -> Outcome {
    Outcome::Done
}

/// The error and its causes joined by ": ", as anyhow's `{:#}`, but a cause whose text the
/// message above it already quotes is left out: an error type that prints its source in its
/// own message (`#[error("identification failed: {0}")]` with `#[from]`) would otherwise
/// say everything twice.
fn error_text(e: &anyhow::Error) -> String {
    let mut out = String::new();
    let mut above = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if !above.is_empty() && above.contains(&text) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&text);
        above = text;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cause that the message above already quotes is printed once; other causes are
    /// joined as anyhow's `{:#}` joins them.
    #[test]
    fn a_cause_quoted_by_its_error_is_printed_once() {
        let ident = feedscope::ident::IdentError::NotIdentifiable {
            reason: "no motion reversal".to_string(),
        };
        let e = anyhow::Error::new(feedscope::study::StudyError::Identify(ident))
            .context("analysing t.csv");
        assert_eq!(
            error_text(&e),
            "analysing t.csv: identification failed: not identifiable: no motion reversal"
        );
        let io = std::io::Error::new(IoKind::NotFound, "no such file");
        let e = anyhow::Error::new(io).context("reading a.csv");
        assert_eq!(error_text(&e), format!("{e:#}"));
    }
    use feedscope_io::friction_csv::FrictionCsvError;
    use std::io::{Error, ErrorKind as IoKind};

    /// Only a broken pipe of stdout (the error itself, under contexts) is a quiet exit 0; the
    /// same broken pipe from the store's connection is a store failure (exit 1), wrapped or
    /// not in contexts, and so is a commit whose outcome is unknown.
    #[test]
    fn only_a_closed_stdout_is_a_quiet_success() {
        use anyhow::Context as _;
        use feedscope_store::{BackendError, BackendErrorKind, StoreError};
        let pipe = || Error::from(IoKind::BrokenPipe);
        let stdout: anyhow::Result<()> = Err(pipe()).context("writing the table");
        let e = stdout.context("history list").unwrap_err();
        assert!(is_closed_stdout(&e));
        assert!(is_closed_stdout(&anyhow::Error::new(pipe())));
        // As `postgres::Error` of a lost connection: its source is the OS error.
        #[derive(Debug, thiserror::Error)]
        #[error("error communicating with the server")]
        struct Connection(#[source] Error);
        let backend = || BackendError::new(BackendErrorKind::Other, Connection(pipe()));
        let store = anyhow::Error::new(StoreError::Backend(backend()))
            .context("PostgreSQL store postgres://u@h/db");
        assert!(!is_closed_stdout(&store), "{store:#}");
        assert!(store.chain().any(|c| c
            .downcast_ref::<Error>()
            .is_some_and(|e| e.kind() == IoKind::BrokenPipe)));
        assert_eq!(exit_code(&store), 1);
        let unknown = anyhow::Error::new(StoreError::CommitUnknown {
            path: "postgres://u@h/db".into(),
            error: backend(),
        });
        assert!(!is_closed_stdout(&unknown));
        assert_eq!(exit_code(&unknown), 1);
        // Another kind of I/O error of stdout is a failure too.
        assert!(!is_closed_stdout(&anyhow::Error::new(Error::from(
            IoKind::StorageFull
        ))));
    }

    fn code<E: std::error::Error + Send + Sync + 'static>(e: E) -> u8 {
        exit_code(&anyhow::Error::new(e))
    }

    /// The documented exit codes of the error kinds, and what the CLI adds to the layers'
    /// kinds (whose every error type is pinned in crates/feedscope-app/tests/error_kinds.rs):
    /// `history check`'s failed check, anyhow's own errors, and contexts that change nothing.
    #[test]
    fn exit_codes_of_the_kinds_and_the_cli_errors() {
        use feedscope_store::StoreError;
        assert_eq!(exit_code_of(ErrorKind::BadInput), 2);
        assert_eq!(exit_code_of(ErrorKind::Io), 1);
        assert_eq!(exit_code_of(ErrorKind::Internal), 1);
        let corrupt = || StoreError::Corrupt {
            path: "h.db".into(),
            detail: "page 3".into(),
        };
        assert_eq!(code(corrupt()), 2);
        // `history check` finding damage is a failed check, not bad input.
        assert_eq!(code(history::CheckFailed(corrupt())), 1);
        assert_eq!(
            code(feedscope_app::AppError::bad_input(
                "--segments must be at least 1"
            )),
            2
        );
        assert_eq!(code(Error::from(IoKind::PermissionDenied)), 1);
        assert_eq!(exit_code(&anyhow::anyhow!("all 2 runs failed")), 1);
        // a context changes nothing; bad input anywhere in the chain wins
        let e = anyhow::Error::new(feedscope::stribeck::StribeckError::NoMotion)
            .context("fitting")
            .context("writing out/stribeck.json");
        assert_eq!(exit_code(&e), 2);
        let e = anyhow::Error::new(Error::from(IoKind::NotFound))
            .context(StoreError::Io(Error::from(IoKind::PermissionDenied)));
        assert_eq!(exit_code(&e), 2);
        let bad_row = FrictionCsvError::BadDirection {
            source_name: "f.csv".into(),
            line: 2,
            text: "up".into(),
        };
        assert_eq!(exit_code(&anyhow::Error::from(bad_row).context("map")), 2);
    }
}
