//! What a use case asks of the front end that runs it: where its progress goes, and how the
//! user spells a request field in a message.

/// The front end a use case runs under.
pub trait FrontEnd: Sync {
    /// A named stage of the work began ("reading trace.csv", "fitting").
    fn stage(&self, _what: &str) {}

    /// `done` of `total` steps of `what` ("analyse") are done; the first call of a `what`
    /// begins its bar, `done == total` ends it.
    fn progress(&self, _what: &str, _done: usize, _total: usize) {}

    /// Something the user should know now, while the work goes on (a reader's warning); it
    /// is in the report too.
    fn notice(&self, _message: &str) {}

    /// How the user names a request field (`--compare` on the command line, `compare` in
    /// Python). The default is the request's serde name in backquotes.
    fn name(&self, field: &str) -> String {
        format!("`{field}`")
    }

    /// How the user gives `field` the value `value` (`--effort torque` on the command line,
    /// `effort="torque"` in Python); messages that ask for a choice use it. The default is the
    /// request's serde form.
    fn spell(&self, field: &str, value: &str) -> String {
        format!("`{field}` = \"{value}\"")
    }

    /// How the user stores a test in the history, for a message about an empty store.
    fn how_to_add(&self) -> String {
        "a `history add` request".to_string()
    }

    /// The machine a use case takes when the user names none: `None` when it is the only
    /// one stored (the command line's `--machine`), else this name (Python's
    /// `machine="machine"`).
    fn default_machine(&self) -> Option<&str> {
        None
    }
}

/// A front end that shows no progress and spells fields in the request's serde form.
#[derive(Debug, Clone, Copy, Default)]
pub struct Quiet;

impl FrontEnd for Quiet {}
