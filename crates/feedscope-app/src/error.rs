//! The one error type of the use cases: what went wrong ([`ErrorKind`]), the request field it
//! concerns when there is one, and the error below it.
use feedscope::ErrorKind;

/// An error of a use case. Its message is complete on its own (the file, the field, what is
/// wrong); [`source`](std::error::Error::source) is the error of the layer below, when there
/// is one, for a front end that prints causes.
#[derive(Debug)]
pub struct AppError {
    kind: ErrorKind,
    field: Option<&'static str>,
    message: String,
    source: Option<Box<dyn std::error::Error + Send + Sync + 'static>>,
    /// The message is the source's own: causes start below the source.
    transparent: bool,
}

impl AppError {
    /// A request field that is invalid: `reason` says why.
    pub fn invalid(field: &'static str, reason: impl Into<String>) -> Self {
        Self {
            kind: ErrorKind::BadInput,
            field: Some(field),
            message: reason.into(),
            source: None,
            transparent: false,
        }
    }

    /// Bad input that is no one field's: a file's content, data that do not allow the
    /// analysis.
    pub fn bad_input(message: impl Into<String>) -> Self {
        Self {
            kind: ErrorKind::BadInput,
            field: None,
            message: message.into(),
            source: None,
            transparent: false,
        }
    }

    /// The work could not be done although the request was valid and no one input explains
    /// it (every run of a test set failed): [`ErrorKind::Internal`], the binary's exit code 1.
    pub fn failed(message: impl Into<String>) -> Self {
        Self {
            kind: ErrorKind::Internal,
            field: None,
            message: message.into(),
            source: None,
            transparent: false,
        }
    }

    /// `context` (what was being done), caused by `source`; the kind is `kind`.
    pub fn caused(
        kind: ErrorKind,
        context: impl Into<String>,
        source: impl std::error::Error + Send + Sync + 'static,
    ) -> Self {
        Self {
            kind,
            field: None,
            message: context.into(),
            source: Some(Box::new(source)),
            transparent: false,
        }
    }

    /// `context` (what was being done), caused by `source`, whose kind it keeps as the crates
    /// below say it ([`ErrorKind::Internal`] for a type they do not know).
    pub fn within(
        context: impl Into<String>,
        source: impl std::error::Error + Send + Sync + 'static,
    ) -> Self {
        let kind = kind_below(&source);
        Self::caused(kind, context, source)
    }

    /// An error of the layer below as it is: its message, its causes, and its kind as the
    /// crates below say it ([`ErrorKind::Internal`] for a type they do not know).
    pub fn from_error(error: impl std::error::Error + Send + Sync + 'static) -> Self {
        let kind = kind_below(&error);
        Self {
            kind,
            field: None,
            message: error.to_string(),
            source: Some(Box::new(error)),
            transparent: true,
        }
    }

    /// The same error, naming the request field it concerns.
    pub fn for_field(mut self, field: &'static str) -> Self {
        self.field = Some(field);
        self
    }

    /// What the error means to the caller: a front end maps it to an exit code or a status.
    pub fn kind(&self) -> ErrorKind {
        self.kind
    }

    /// The request field the error concerns (its name in the request's serde form).
    pub fn field(&self) -> Option<&'static str> {
        self.field
    }
}

impl std::fmt::Display for AppError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for AppError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        let inner = self
            .source
            .as_deref()
            .map(|e| e as &(dyn std::error::Error + 'static));
        if self.transparent {
            inner.and_then(|e| e.source())
        } else {
            inner
        }
    }
}

/// The kind of an error of the crates below as they say it: the store's, else the I/O crate's
/// (which falls back to the maths crate's), else [`ErrorKind::Internal`].
fn kind_below(e: &(dyn std::error::Error + 'static)) -> ErrorKind {
    feedscope_store::error_kind(e)
        .or_else(|| feedscope_io::error_kind(e))
        .unwrap_or(ErrorKind::Internal)
}

/// The kind of one error of a chain when it is an [`AppError`]; `None` for any other type
/// (the crates below say theirs: `feedscope::error::kind_of`, `feedscope_io::error_kind`).
pub fn error_kind(e: &(dyn std::error::Error + 'static)) -> Option<ErrorKind> {
    e.downcast_ref::<AppError>().map(AppError::kind)
}

/// The kind of one error of a chain as the layers say it: an [`AppError`]'s own, else the
/// store's, else the I/O crate's (which falls back to the maths crate's); `None` for a type
/// none of them knows. What every front end classifies errors by (with
/// `feedscope::error::kind_of_chain` over the whole chain).
pub fn kind_of(e: &(dyn std::error::Error + 'static)) -> Option<ErrorKind> {
    error_kind(e)
        .or_else(|| feedscope_store::error_kind(e))
        .or_else(|| feedscope_io::error_kind(e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_error_says_its_kind_field_and_cause() {
        let e = AppError::invalid("kernel_half_width_s", "must be positive, got -1");
        assert_eq!(e.kind(), ErrorKind::BadInput);
        assert_eq!(e.field(), Some("kernel_half_width_s"));
        assert_eq!(e.to_string(), "must be positive, got -1");
        let io = std::io::Error::from(std::io::ErrorKind::PermissionDenied);
        let e = AppError::caused(ErrorKind::Io, "writing ident.json", io);
        let dyn_e: &(dyn std::error::Error + 'static) = &e;
        assert_eq!(error_kind(dyn_e), Some(ErrorKind::Io));
        assert!(std::error::Error::source(&e).is_some());
        assert_eq!(error_kind(&std::fmt::Error), None);
    }
}
