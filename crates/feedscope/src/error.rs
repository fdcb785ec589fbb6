//! What an error means to its caller, whatever its domain: [`ErrorKind`].
//!
//! Every error enum of feedscope (this crate, `feedscope-io`, `feedscope-store`) has a
//! `kind()` method returning one of these, so that a front end decides on the kind alone (the
//! CLI maps it to its exit code; a server would map it to a status) instead of listing error
//! types.
//!
//! ```
//! use feedscope::ErrorKind;
//! use feedscope::stribeck::StribeckError;
//! assert_eq!(StribeckError::NoMotion.kind(), ErrorKind::BadInput);
//! ```
/// The class of an error, for a caller that must decide what to do with it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum ErrorKind {
    /// What the user gave is wrong and the message says what: a file's content, a parameter,
    /// measurement data that do not allow the analysis, a file or test that does not exist.
    BadInput,
    /// A file, database or device could not be read or written although it exists
    /// (permissions, a full disk, a lock held too long).
    Io,
    /// A failure that the input does not explain (an engine's internal error).
    Internal,
}

impl ErrorKind {
    /// The kind of an operating-system error met while reading or writing something the user
    /// named: a missing file, and a file whose bytes are not what the reader expects
    /// (`InvalidData`: `std::fs::read_to_string` of a file that is not UTF-8) are the user's
    /// input ([`ErrorKind::BadInput`]); anything else is [`ErrorKind::Io`].
    ///
    /// ```
    /// use feedscope::ErrorKind;
    /// use std::io::{Error, ErrorKind as Io};
    /// assert_eq!(ErrorKind::of_io(&Error::from(Io::NotFound)), ErrorKind::BadInput);
    /// assert_eq!(ErrorKind::of_io(&Error::from(Io::InvalidData)), ErrorKind::BadInput);
    /// assert_eq!(ErrorKind::of_io(&Error::from(Io::PermissionDenied)), ErrorKind::Io);
    /// ```
    pub fn of_io(error: &std::io::Error) -> Self {
        match error.kind() {
            std::io::ErrorKind::NotFound | std::io::ErrorKind::InvalidData => ErrorKind::BadInput,
            _ => ErrorKind::Io,
        }
    }
}
