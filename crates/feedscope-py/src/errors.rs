//! Library errors as Python exceptions: one class per [`ErrorKind`], under `FeedscopeError`.
//!
//! The message is the binary's: the error and its chain of causes joined by `": "`, as the CLI
//! prints `error: {e:#}` (anyhow's alternate format), so a message names the file, line or key
//! exactly as `feedscope` does on the terminal. The kind is decided as the CLI decides its exit
//! code (`feedscope-cli/src/cmd/mod.rs`): bad input anywhere in the chain wins, else the first
//! known kind, else internal.
use feedscope::ErrorKind;
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::PyErr;

create_exception!(
    feedscope,
    FeedscopeError,
    PyException,
    "Base class of every error feedscope raises for its own reasons."
);
create_exception!(
    feedscope,
    BadInputError,
    FeedscopeError,
    "What was given is wrong and the message says what (file, line, key): the binary's exit \
     code 2."
);
create_exception!(
    feedscope,
    IoError,
    FeedscopeError,
    "A file or database exists but could not be read or written (permissions, a full disk): \
     the binary's exit code 1. Not a subclass of OSError."
);
create_exception!(
    feedscope,
    InternalError,
    FeedscopeError,
    "A failure the input does not explain: the binary's exit code 1."
);

/// The kind of one error of a chain, when its type is one of feedscope's (each says its own
/// kind) or a foreign one whose kind is known (a missing file, unparsable TOML or JSON).
fn kind_of(e: &(dyn std::error::Error + 'static)) -> Option<ErrorKind> {
    use feedscope::{
        axis::AxisError, compensation::CompensationError, dynamics::DynamicsError,
        estimate::EstimateError, history::HistoryError, ident::IdentError, lugre::LuGreError,
        map::MapError, nc::NcError, order::OrderError, plan::PlanError, profile::ProfileError,
        sim::SimError, spline::SplineError, stribeck::StribeckError, study::StudyError,
    };
    use feedscope_io::{
        axis::AxisFileError, friction_csv::FrictionCsvError, import::ImportError,
        stribeck_table::TableError, thresholds::ThresholdsError, trace::TraceError,
    };
    use feedscope_store::{BackendErrorKind, StoreError};
    macro_rules! kind_if {
        ($($t:ty),* $(,)?) => {
            $(if let Some(x) = e.downcast_ref::<$t>() {
                return Some(x.kind());
            })*
        };
    }
    kind_if!(
        AxisError,
        CompensationError,
        DynamicsError,
        EstimateError,
        HistoryError,
        IdentError,
        LuGreError,
        MapError,
        NcError,
        OrderError,
        PlanError,
        ProfileError,
        SimError,
        SplineError,
        StribeckError,
        StudyError,
        AxisFileError,
        FrictionCsvError,
        ImportError,
        TableError,
        ThresholdsError,
        TraceError,
        StoreError,
    );
    if let Some(b) = e.downcast_ref::<feedscope_store::BackendError>() {
        return Some(match b.kind() {
            BackendErrorKind::NotADatabase | BackendErrorKind::Corrupt => ErrorKind::BadInput,
            _ => ErrorKind::Io,
        });
    }
    if e.is::<BadInput>() || e.is::<toml::de::Error>() || e.is::<serde_json::Error>() {
        return Some(ErrorKind::BadInput);
    }
    e.downcast_ref::<std::io::Error>().map(ErrorKind::of_io)
}

/// The kind of an error chain, as the CLI's `error_kind`.
fn error_kind(err: &anyhow::Error) -> ErrorKind {
    let kinds: Vec<ErrorKind> = err.chain().filter_map(kind_of).collect();
    if kinds.contains(&ErrorKind::BadInput) {
        ErrorKind::BadInput
    } else {
        kinds.first().copied().unwrap_or(ErrorKind::Internal)
    }
}

/// A usage error found by the bindings themselves (an argument out of range), with the same
/// meaning as the CLI's `BadInput`.
#[derive(Debug)]
pub struct BadInput(pub String);

impl std::fmt::Display for BadInput {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for BadInput {}

/// The Python exception of an error chain: its kind's class, with the CLI's message.
pub fn to_py(err: anyhow::Error) -> PyErr {
    let message = format!("{err:#}");
    match error_kind(&err) {
        ErrorKind::BadInput => BadInputError::new_err(message),
        ErrorKind::Io => IoError::new_err(message),
        _ => InternalError::new_err(message),
    }
}

/// [`to_py`] of any error feedscope returns.
pub fn py_err<E: Into<anyhow::Error>>(e: E) -> PyErr {
    to_py(e.into())
}

/// A [`BadInputError`] with `message`.
pub fn bad_input(message: impl Into<String>) -> PyErr {
    BadInputError::new_err(message.into())
}
