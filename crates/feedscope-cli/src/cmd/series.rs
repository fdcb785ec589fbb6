//! The history store in the command line's words: how to store a test. (Which machine a
//! command without `--machine` means is the app's `trend::resolve_machine`.)
use std::path::Path;

/// How to store a test, for messages about an empty or missing database; `db` is the
/// database when it was given with `--db` (the environment variable and the default name
/// apply to `history add` as they do to the other commands).
pub fn how_to_add(db: Option<&Path>) -> String {
    let db = db.map_or(String::new(), |p| format!(" --db {}", p.display()));
    format!(
        "feedscope history{db} add TRACE --axis AXIS.toml --kind strokes|triangle \
         [--machine NAME]"
    )
}

#[cfg(test)]
mod tests {
    /// A lock held too long is not the input's fault (exit 1); a bad timeout value is (2).
    #[test]
    fn exit_codes_of_a_busy_store() {
        let busy = feedscope_store::StoreError::Busy {
            path: "h.db".into(),
            waited_s: 30.0,
            hint: None,
        };
        let e = anyhow::Error::new(busy).context("database h.db");
        assert_eq!(super::super::exit_code(&e), 1);
        let bad = feedscope_app::store::busy_timeout(Some("soon")).unwrap_err();
        assert_eq!(super::super::exit_code(&bad.into()), 2);
    }
}
