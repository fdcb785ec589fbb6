//! How a use case ended when it did not fail.
//!
//! A finding the user asked to be told by the exit status (`history trend --fail-on-warning`
//! in a CI job or a cron script) is not an error: the command did its work and printed it.
//! It ends with an [`Outcome::Attention`], which a command-line front end reports as a
//! status line (`attention: ...`) and exit code 1, while errors print `error: ...`.
//!
//! ```
//! use feedscope_app::Outcome;
//! assert_eq!(Outcome::Done.exit_code(), 0);
//! let o = Outcome::Attention("fs_n of M1/X is at warning".into());
//! assert_eq!((o.exit_code(), o.to_string().as_str()), (1, "fs_n of M1/X is at warning"));
//! ```
use std::fmt;

use serde::Serialize;

/// The end of a use case that did its work.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(tag = "outcome", content = "status", rename_all = "snake_case")]
pub enum Outcome {
    /// Done; nothing the caller asked to be alerted to.
    Done,
    /// Done, with a finding the caller asked to be alerted to; the status says what.
    Attention(String),
}

impl Outcome {
    /// The documented exit code: 0 done, 1 attention (the code of an error that is not the
    /// input's fault; a script tells them apart by the `attention:` line).
    pub fn exit_code(&self) -> u8 {
        match self {
            Self::Done => 0,
            Self::Attention(_) => 1,
        }
    }
}

impl fmt::Display for Outcome {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Done => f.write_str("done"),
            Self::Attention(s) => f.write_str(s),
        }
    }
}
