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
    use feedscope_io::axis::AxisFileError;
    use feedscope_io::friction_csv::FrictionCsvError;
    use feedscope_io::stribeck_table::TableError;
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

    /// One value of every error type the commands can return, with its exit code; a context
    /// over it does not change the code.
    #[test]
    fn exit_code_of_every_error_type() {
        use feedscope::estimate::Direction;
        let io = |k| Error::from(k);
        // the kinds themselves
        assert_eq!(exit_code_of(ErrorKind::BadInput), 2);
        assert_eq!(exit_code_of(ErrorKind::Io), 1);
        assert_eq!(exit_code_of(ErrorKind::Internal), 1);
        // feedscope
        let axis_err = feedscope::axis::AxisParams::parse(
            "lead_mm = 1\n",
            feedscope::axis::ConfigFormat::Toml,
            "a.toml",
        )
        .unwrap_err();
        assert_eq!(code(axis_err), 2);
        assert_eq!(
            code(feedscope::dynamics::DynamicsError::MassNotPositiveDefinite { position_m: 0.1 }),
            2
        );
        assert_eq!(
            code(feedscope::estimate::EstimateError::BadSamplesPerLead),
            2
        );
        assert_eq!(
            code(feedscope::history::HistoryError::TooFewPoints { needed: 5, got: 2 }),
            2
        );
        assert_eq!(
            code(feedscope::ident::IdentError::NotIdentifiable {
                reason: "no reversal".into()
            }),
            2
        );
        assert_eq!(
            code(feedscope::lugre::LuGreError::TooFewPoints {
                points: 1,
                needed: 8
            }),
            2
        );
        assert_eq!(code(feedscope::map::MapError::NoStrokes), 2);
        assert_eq!(
            code(feedscope::nc::NcError {
                source_name: "p.nc".into(),
                line: 3,
                message: "G999".into()
            }),
            2
        );
        assert_eq!(
            code(feedscope::order::OrderError::NonFinite { index: 4 }),
            2
        );
        assert_eq!(code(feedscope::order::OrderError::Fft("plan".into())), 1);
        assert_eq!(
            code(feedscope::plan::PlanError::FeedTooHigh {
                feed_mm_min: 9e4,
                limit_mm_min: 3e4
            }),
            2
        );
        assert_eq!(
            code(feedscope::profile::ProfileError::RankDeficient { column: 1 }),
            2
        );
        assert_eq!(
            code(feedscope::profile::ProfileError::Spectrum(
                feedscope::order::OrderError::Fft("plan".into())
            )),
            1
        );
        assert_eq!(code(feedscope::sim::SimError::Diverged { time_s: 1.0 }), 2);
        assert_eq!(code(feedscope::spline::SplineError::TooFewKnots(1)), 2);
        assert_eq!(code(feedscope::stribeck::StribeckError::NoMotion), 2);
        assert_eq!(
            code(feedscope::study::StudyError::OneFeed {
                direction: Direction::Forward,
                feed_mm_min: 100.0
            }),
            2
        );
        // feedscope-io
        let trace_io = |k| feedscope_io::trace::TraceError::Io {
            source_name: "t.csv".into(),
            error: io(k),
        };
        assert_eq!(code(trace_io(IoKind::NotFound)), 2);
        assert_eq!(code(trace_io(IoKind::PermissionDenied)), 1);
        assert_eq!(
            code(feedscope_io::trace::TraceError::Empty {
                source_name: "t.csv".into()
            }),
            2
        );
        let import_io = |k| feedscope_io::import::ImportError::Io {
            source_name: "s.log".into(),
            error: io(k),
        };
        assert_eq!(code(import_io(IoKind::NotFound)), 2);
        assert_eq!(code(import_io(IoKind::PermissionDenied)), 1);
        assert_eq!(
            code(feedscope_io::import::ImportError::BadParam(
                "--rate-hz".into()
            )),
            2
        );
        // feedscope-store
        use feedscope_store::{BackendError, BackendErrorKind, StoreError};
        assert_eq!(code(StoreError::NoSuchTest(7)), 2);
        assert_eq!(
            code(StoreError::Corrupt {
                path: "h.db".into(),
                detail: "page 3".into()
            }),
            2
        );
        assert_eq!(code(StoreError::Io(io(IoKind::PermissionDenied))), 1);
        // PostgreSQL: another application's schema and an unusable URL are the user's
        assert_eq!(
            code(StoreError::ForeignSchema {
                path: "postgres://u@h/db".into(),
                schema: "public".into(),
                tables: 3,
                example: "invoices".into()
            }),
            2
        );
        assert_eq!(
            code(StoreError::BadAddress {
                path: "postgres://u@h/db".into(),
                detail: "TLS is not supported yet".into()
            }),
            2
        );
        let backend = |k| StoreError::Backend(BackendError::new(k, "engine says no"));
        assert_eq!(code(backend(BackendErrorKind::NotADatabase)), 2);
        assert_eq!(code(backend(BackendErrorKind::Other)), 1);
        assert_eq!(
            code(BackendError::new(BackendErrorKind::Corrupt, "damaged")),
            2
        );
        // `history check` finding damage is a failed check, not bad input.
        assert_eq!(
            code(history::CheckFailed(StoreError::Corrupt {
                path: "h.db".into(),
                detail: "page 3".into()
            })),
            1
        );
        // the CLI's own and foreign errors
        assert_eq!(
            code(feedscope_app::AppError::bad_input(
                "--segments must be at least 1"
            )),
            2
        );
        assert_eq!(code(toml::from_str::<toml::Table>("= 1").unwrap_err()), 2);
        assert_eq!(code(serde_json::from_str::<u8>("x").unwrap_err()), 2);
        assert_eq!(code(io(IoKind::NotFound)), 2);
        assert_eq!(code(io(IoKind::PermissionDenied)), 1);
        assert_eq!(exit_code(&anyhow::anyhow!("all 2 runs failed")), 1);
        // a context changes nothing; bad input anywhere in the chain wins
        let e = anyhow::Error::new(feedscope::stribeck::StribeckError::NoMotion)
            .context("fitting")
            .context("writing out/stribeck.json");
        assert_eq!(exit_code(&e), 2);
        let e = anyhow::Error::new(io(IoKind::NotFound))
            .context(StoreError::Io(io(IoKind::PermissionDenied)));
        assert_eq!(exit_code(&e), 2);
    }

    /// The readers that moved to feedscope-io keep the exit codes of the CLI code they
    /// replace: content errors are bad input (2); an unreadable file is bad input only when it
    /// is missing (anyhow's `.context("reading …")` over the OS error did the same).
    #[test]
    fn exit_codes_of_the_feedscope_io_readers() {
        let code = |e: anyhow::Error| exit_code(&e);
        let read = |kind| AxisFileError::Read {
            source_name: "a.toml".into(),
            error: Error::from(kind),
        };
        assert_eq!(code(read(IoKind::NotFound).into()), 2);
        assert_eq!(code(read(IoKind::PermissionDenied).into()), 1);
        let bad_axis = feedscope::axis::AxisParams::parse(
            "lead_mm = 1\n",
            feedscope::axis::ConfigFormat::Toml,
            "a.toml",
        )
        .unwrap_err();
        assert_eq!(code(AxisFileError::from(bad_axis).into()), 2);

        let csv_read = |kind| FrictionCsvError::Read {
            source_name: "f.csv".into(),
            error: Error::from(kind),
        };
        assert_eq!(code(csv_read(IoKind::NotFound).into()), 2);
        assert_eq!(code(csv_read(IoKind::PermissionDenied).into()), 1);
        // A directory opens but does not read: the bare OS error, as before.
        assert_eq!(
            code(FrictionCsvError::Head(Error::from(IoKind::IsADirectory)).into()),
            1
        );
        let bad_row = FrictionCsvError::BadDirection {
            source_name: "f.csv".into(),
            line: 2,
            text: "up".into(),
        };
        assert_eq!(code(bad_row.into()), 2);

        let table_read = |kind| TableError::Read {
            source_name: "t.csv".into(),
            error: Error::from(kind),
        };
        assert_eq!(code(table_read(IoKind::NotFound).into()), 2);
        assert_eq!(code(table_read(IoKind::PermissionDenied).into()), 1);
        let zero = TableError::ZeroFeed {
            source_name: "t.csv".into(),
            line: 3,
        };
        assert_eq!(code(zero.into()), 2);
        assert_eq!(
            code(TableError::BadEfficiency { efficiency: 2.0 }.into()),
            2
        );
    }
}
