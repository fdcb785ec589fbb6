//! Errors about the effort channel in the words of the `--effort` flag that chooses it.
use feedscope::trace::EffortKind;
use feedscope_app::recording::{effort_error, Effort};
use feedscope_io::trace::TraceError;

/// A trace reader's error, restated for a command that has `--effort`
/// ([`feedscope_app::recording::effort_error`] with the flag's spelling).
pub fn name_the_flag(e: TraceError, asked: Option<EffortKind>) -> anyhow::Error {
    effort_error(e, asked.map(Effort::of), &crate::front::Cli::default()).into()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn effort_errors_name_the_flag() {
        let both = name_the_flag(
            TraceError::AmbiguousEffort {
                source_name: "t.csv".into(),
            },
            None,
        );
        assert!(format!("{both:#}").contains("--effort current or --effort torque"));
        let missing = |channel: &str| TraceError::MissingChannel {
            source_name: "t.csv".into(),
            channel: channel.into(),
            found: "position, current_a".into(),
        };
        let e = name_the_flag(missing("torque_nm"), Some(EffortKind::TorqueNm));
        assert!(
            format!("{e:#}").starts_with("--effort torque: t.csv"),
            "{e:#}"
        );
        assert_eq!(super::super::exit_code(&e), 2);
        // A missing position is not about the flag.
        let e = name_the_flag(missing("position_mm"), Some(EffortKind::TorqueNm));
        assert!(!format!("{e:#}").contains("--effort"), "{e:#}");
    }
}
