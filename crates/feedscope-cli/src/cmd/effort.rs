//! Errors about the effort channel in the words of the `--effort` flag that chooses it.
use feedscope::trace::EffortKind;
use feedscope_io::trace::TraceError;

use super::BadInput;

/// The value of `--effort` that selects `k`.
fn flag_value(k: EffortKind) -> &'static str {
    match k {
        EffortKind::CurrentA => "current",
        EffortKind::TorqueNm => "torque",
    }
}

/// A trace reader's error, restated for a command that has `--effort`: a file with both
/// channels names the flag and its values; a channel asked for with `--effort` and absent
/// names the flag as given. Other errors pass unchanged.
pub fn name_the_flag(e: TraceError, asked: Option<EffortKind>) -> anyhow::Error {
    match (e, asked) {
        (TraceError::AmbiguousEffort { source_name }, _) => BadInput(format!(
            "{source_name}: both `current_a` and `torque_nm` are present; choose one with \
             --effort current or --effort torque"
        ))
        .into(),
        (e @ TraceError::MissingChannel { .. }, Some(k)) if matches!(&e, TraceError::MissingChannel { channel, .. } if channel == k.column()) => {
            anyhow::Error::new(e).context(format!("--effort {}", flag_value(k)))
        }
        (e, _) => e.into(),
    }
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
