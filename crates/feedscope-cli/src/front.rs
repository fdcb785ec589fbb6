//! The command line as a front end of the use cases (`feedscope_app::FrontEnd`): how a request
//! field is spelled as a flag, and where notices go.
use feedscope_app::FrontEnd;

/// Request fields whose flag is not `--` and the field's name with `_` as `-`.
const FLAGS: &[(&str, &str)] = &[
    ("kernel_half_width_s", "--kernel-s"),
    ("reversal_guard_s", "--guard-s"),
    ("fit_offset", "--no-offset"),
    ("breaks_mm", "--breaks"),
    ("positions_mm", "--positions"),
    ("table_feeds_mm_min", "--table-feeds"),
    ("input", "INPUT"),
];

/// The flag of a request field.
pub fn flag(field: &str) -> String {
    FLAGS
        .iter()
        .find(|(f, _)| *f == field)
        .map(|(_, flag)| (*flag).to_string())
        .unwrap_or_else(|| format!("--{}", field.replace('_', "-")))
}

/// The command line: notices are printed on stderr as they come, progress is a bar on stderr
/// (hidden when stderr is not a terminal), fields are spelled as flags.
#[derive(Debug, Default)]
pub struct Cli {
    /// The bar of the work under way, and what it counts.
    bar: std::sync::Mutex<Option<(String, indicatif::ProgressBar)>>,
}

impl Cli {
    fn clear_bar(&self) {
        let mut bar = self.bar.lock().unwrap_or_else(|p| p.into_inner());
        if let Some((_, pb)) = bar.take() {
            pb.finish_and_clear();
        }
    }
}

impl Drop for Cli {
    fn drop(&mut self) {
        self.clear_bar();
    }
}

impl FrontEnd for Cli {
    fn progress(&self, what: &str, done: usize, total: usize) {
        let mut bar = self.bar.lock().unwrap_or_else(|p| p.into_inner());
        if bar.as_ref().is_some_and(|(w, _)| w != what) {
            if let Some((_, pb)) = bar.take() {
                pb.finish_and_clear();
            }
        }
        let (_, pb) =
            bar.get_or_insert_with(|| (what.to_string(), crate::output::bar(total as u64, what)));
        pb.set_position(done as u64);
        if done >= total {
            pb.finish_and_clear();
            *bar = None;
        }
    }

    fn notice(&self, message: &str) {
        eprintln!("warning: {message}");
    }

    fn name(&self, field: &str) -> String {
        flag(field)
    }

    fn spell(&self, field: &str, value: &str) -> String {
        format!("{} {value}", flag(field))
    }

    fn how_to_add(&self) -> String {
        format!("`{}`", crate::cmd::how_to_add(None))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_are_spelled_as_their_flags() {
        assert_eq!(Cli::default().spell("effort", "torque"), "--effort torque");
        assert_eq!(Cli::default().name("compare"), "--compare");
        assert_eq!(flag("kernel_half_width_s"), "--kernel-s");
        assert_eq!(flag("min_speed_mm_min"), "--min-speed-mm-min");
    }

    /// A trace reader's error about the effort channel names the `--effort` flag.
    #[test]
    fn effort_errors_name_the_flag() {
        use feedscope::trace::EffortKind;
        use feedscope_app::recording::{effort_error, Effort};
        use feedscope_io::trace::TraceError;
        let name_the_flag = |e, asked: Option<EffortKind>| -> anyhow::Error {
            effort_error(e, asked.map(Effort::of), &Cli::default()).into()
        };
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
        assert_eq!(crate::cmd::exit_code(&e), 2);
        // A missing position is not about the flag.
        let e = name_the_flag(missing("position_mm"), Some(EffortKind::TorqueNm));
        assert!(!format!("{e:#}").contains("--effort"), "{e:#}");
    }
}
