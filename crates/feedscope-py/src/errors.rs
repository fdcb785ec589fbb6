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

/// The kind of an error chain, by the rule the CLI decides its exit code with: the layers say
/// the kind of their errors ([`feedscope_app::error::kind_of`]); a usage error the bindings
/// find themselves (an argument out of range) is an [`feedscope_app::AppError::bad_input`].
fn error_kind(err: &anyhow::Error) -> ErrorKind {
    feedscope::error::kind_of_chain(err.chain(), feedscope_app::error::kind_of)
}

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
