//! Diagnostics: what a result wants its reader to know, as data.
//!
//! Every diagnostic has a stable machine-readable [`Diagnostic::code`] (kebab-case, never
//! renamed once published, so that scripts and a server can act on it) and a
//! [`Diagnostic::message`] for people. Serialised as `{"code": ..., "message": ...}`.
//!
//! ```
//! use feedscope::diag::Diagnostic;
//! let d = Diagnostic::new("effort-unsigned", "the effort is a magnitude");
//! assert_eq!(serde_json::to_string(&d).unwrap(),
//!            r#"{"code":"effort-unsigned","message":"the effort is a magnitude"}"#);
//! assert_eq!(d.to_string(), "the effort is a magnitude");
//! // Older files stored the message alone.
//! let old: Diagnostic = serde_json::from_str(r#""a warning""#).unwrap();
//! assert_eq!((old.code.as_str(), old.message.as_str()), ("uncoded", "a warning"));
//! ```
use std::fmt;

use serde::{Deserialize, Serialize};

/// One diagnostic: a stable code and a message. Reads `{code, message}`, or a bare string (the
/// form files written before codes existed; its code is [`LEGACY`]).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(from = "Stored")]
pub struct Diagnostic {
    /// Stable kebab-case code, e.g. `few-samples-per-lead`.
    pub code: String,
    /// What a person reads.
    pub message: String,
}

impl Diagnostic {
    /// A diagnostic with `code` and `message`.
    pub fn new(code: &str, message: impl Into<String>) -> Self {
        Self {
            code: code.to_string(),
            message: message.into(),
        }
    }
}

/// Code of a diagnostic read from a file that stored only its message.
pub const LEGACY: &str = "uncoded";

/// What a file may hold for a diagnostic.
#[derive(Deserialize)]
#[serde(untagged)]
enum Stored {
    Coded { code: String, message: String },
    Text(String),
}

impl From<Stored> for Diagnostic {
    fn from(s: Stored) -> Self {
        match s {
            Stored::Coded { code, message } => Self { code, message },
            Stored::Text(message) => Self {
                code: LEGACY.to_string(),
                message,
            },
        }
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}
