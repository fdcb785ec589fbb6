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
//! ```
use std::fmt;

use serde::{Deserialize, Serialize};

/// One diagnostic: a stable code and a message.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
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

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}
