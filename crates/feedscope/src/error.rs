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

/// The kind of one error of a chain when it is this crate's or a foreign one whose kind is
/// known here: every error enum of this crate says its own; a file that does not parse (TOML,
/// JSON) is bad input; an operating-system error is [`ErrorKind::of_io`]. `None` for any other
/// type: `feedscope_io::error_kind` and `feedscope_store::error_kind` add theirs on top, and
/// a front end its own.
pub fn kind_of(e: &(dyn std::error::Error + 'static)) -> Option<ErrorKind> {
    use crate::{
        axis::AxisError, compensation::CompensationError, dynamics::DynamicsError,
        estimate::EstimateError, history::HistoryError, ident::IdentError, lugre::LuGreError,
        map::MapError, nc::NcError, order::OrderError, plan::PlanError, profile::ProfileError,
        sim::SimError, spline::SplineError, stribeck::StribeckError, study::StudyError,
    };
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
    );
    if e.is::<toml::de::Error>() || e.is::<serde_json::Error>() {
        return Some(ErrorKind::BadInput);
    }
    e.downcast_ref::<std::io::Error>().map(ErrorKind::of_io)
}

/// The kind of a chain of errors (an error and its sources), each classified by `kind_of`:
/// [`ErrorKind::BadInput`] when any of them is bad input (a missing file under an I/O wrapper
/// is still the user's input), else the first known kind, else [`ErrorKind::Internal`].
///
/// ```
/// use feedscope::error::{kind_of, kind_of_chain};
/// use feedscope::ErrorKind;
/// use std::io::{Error, ErrorKind as Io};
/// let (denied, missing) = (Error::from(Io::PermissionDenied), Error::from(Io::NotFound));
/// let chain = |v: &[&Error]| {
///     let v: Vec<&(dyn std::error::Error + 'static)> = v.iter().map(|e| *e as _).collect();
///     kind_of_chain(v, kind_of)
/// };
/// assert_eq!(chain(&[&denied]), ErrorKind::Io);
/// assert_eq!(chain(&[&denied, &missing]), ErrorKind::BadInput);
/// assert_eq!(chain(&[]), ErrorKind::Internal);
/// ```
pub fn kind_of_chain<'a>(
    chain: impl IntoIterator<Item = &'a (dyn std::error::Error + 'static)>,
    kind_of: impl Fn(&(dyn std::error::Error + 'static)) -> Option<ErrorKind>,
) -> ErrorKind {
    let mut first = None;
    for e in chain {
        match kind_of(e) {
            Some(ErrorKind::BadInput) => return ErrorKind::BadInput,
            Some(k) => {
                first.get_or_insert(k);
            }
            None => {}
        }
    }
    first.unwrap_or(ErrorKind::Internal)
}
