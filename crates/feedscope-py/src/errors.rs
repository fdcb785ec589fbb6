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

/// The kind of one error of a chain: the bindings' own usage errors, else what the store, the
/// I/O crate and the library say of theirs (the classification the CLI uses too).
fn kind_of(e: &(dyn std::error::Error + 'static)) -> Option<ErrorKind> {
    if e.is::<BadInput>() {
        return Some(ErrorKind::BadInput);
    }
    feedscope_app::error::error_kind(e)
        .or_else(|| feedscope_store::error_kind(e))
        .or_else(|| feedscope_io::error_kind(e))
}

/// The kind of an error chain, by the rule the CLI decides its exit code with.
fn error_kind(err: &anyhow::Error) -> ErrorKind {
    feedscope::error::kind_of_chain(err.chain(), kind_of)
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
