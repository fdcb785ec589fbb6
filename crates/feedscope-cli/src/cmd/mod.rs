//! One module per subcommand; `run` maps errors to documented exit codes.
//!
//! Exit codes: 0 success; 1 a check failed or a requested failure condition was met; 2 bad
//! input or usage (unreadable or malformed files, invalid parameters).
use clap::{Parser, Subcommand};

mod analyze;
mod demo;
mod dynamics;
mod estimate;
mod fit_stribeck;
pub(crate) mod history;
mod identify;
mod import;
mod map;
mod plan;
mod report;
mod simulate;

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
}

/// Marks an error as the user's input being wrong (exit code 2).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct BadInput(pub String);

/// Exit code for an error: 2 when any cause is bad input, else 1.
pub fn exit_code(err: &anyhow::Error) -> u8 {
    use feedscope::{axis::AxisError, estimate::EstimateError};
    use feedscope_io::{
        axis::AxisFileError, friction_csv::FrictionCsvError, stribeck_table::TableError,
        trace::TraceError,
    };
    let input = err.chain().any(|c| {
        c.is::<BadInput>()
            || c.is::<TraceError>()
            || c.is::<AxisError>()
            // An unreadable axis file, friction CSV or table is bad input only when missing
            // (its `std::io::Error` is next in the chain, below); what it holds always is.
            || c.downcast_ref::<AxisFileError>().is_some_and(|e| !e.is_io())
            || c.downcast_ref::<FrictionCsvError>().is_some_and(|e| !e.is_io())
            || c.downcast_ref::<TableError>().is_some_and(|e| !e.is_io())
            || c.is::<EstimateError>()
            || c.is::<feedscope_io::import::ImportError>()
            || c.is::<feedscope::nc::NcError>()
            || c.is::<feedscope::sim::SimError>()
            || c.is::<feedscope::profile::ProfileError>()
            || c.is::<toml::de::Error>()
            || c.is::<serde_json::Error>()
            || c.downcast_ref::<std::io::Error>()
                .is_some_and(|e| e.kind() == std::io::ErrorKind::NotFound)
    });
    if input {
        2
    } else {
        1
    }
}

/// True when the error is only a closed stdout (e.g. `feedscope ... | head`).
fn is_broken_pipe(err: &anyhow::Error) -> bool {
    err.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

pub fn run(cli: Cli) -> std::process::ExitCode {
    let result = match cli.command {
        Command::Demo(a) => demo::run(a),
        Command::Analyze(a) => analyze::run(a),
        Command::Estimate(a) => estimate::run(a),
        // Prints its own errors and chooses its exit code (2 bad input, 1 otherwise).
        Command::Simulate(a) => return simulate::run(a),
        Command::Dynamics(a) => dynamics::run(a),
        Command::Identify(a) => identify::run(a),
        Command::Plan(a) => plan::run(a),
        Command::FitStribeck(a) => fit_stribeck::run(a),
        Command::Map(a) => map::run(a),
        Command::History(a) => history::run(a),
        Command::Report(a) => report::run(a),
        Command::Import(a) => import::run(a),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) if is_broken_pipe(&e) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::from(exit_code(&e))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use feedscope_io::axis::AxisFileError;
    use feedscope_io::friction_csv::FrictionCsvError;
    use feedscope_io::stribeck_table::TableError;
    use std::io::{Error, ErrorKind};

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
        assert_eq!(code(read(ErrorKind::NotFound).into()), 2);
        assert_eq!(code(read(ErrorKind::PermissionDenied).into()), 1);
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
        assert_eq!(code(csv_read(ErrorKind::NotFound).into()), 2);
        assert_eq!(code(csv_read(ErrorKind::PermissionDenied).into()), 1);
        // A directory opens but does not read: the bare OS error, as before.
        assert_eq!(
            code(FrictionCsvError::Head(Error::from(ErrorKind::IsADirectory)).into()),
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
        assert_eq!(code(table_read(ErrorKind::NotFound).into()), 2);
        assert_eq!(code(table_read(ErrorKind::PermissionDenied).into()), 1);
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
