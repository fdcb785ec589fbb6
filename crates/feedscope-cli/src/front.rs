//! The command line as a front end of the use cases (`feedscope_app::FrontEnd`): how a request
//! field is spelled as a flag, and where notices go.
use feedscope_app::FrontEnd;

/// Request fields whose flag is not `--` and the field's name with `_` as `-`.
const FLAGS: &[(&str, &str)] = &[
    ("kernel_half_width_s", "--kernel-s"),
    ("reversal_guard_s", "--guard-s"),
    ("fit_offset", "--no-offset"),
];

/// The flag of a request field.
pub fn flag(field: &str) -> String {
    FLAGS
        .iter()
        .find(|(f, _)| *f == field)
        .map(|(_, flag)| (*flag).to_string())
        .unwrap_or_else(|| format!("--{}", field.replace('_', "-")))
}

/// The command line: notices are printed on stderr as they come, fields are spelled as flags.
#[derive(Debug, Clone, Copy, Default)]
pub struct Cli;

impl FrontEnd for Cli {
    fn notice(&self, message: &str) {
        eprintln!("warning: {message}");
    }

    fn name(&self, field: &str) -> String {
        flag(field)
    }

    fn spell(&self, field: &str, value: &str) -> String {
        format!("{} {value}", flag(field))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_are_spelled_as_their_flags() {
        assert_eq!(Cli.spell("effort", "torque"), "--effort torque");
        assert_eq!(Cli.name("compare"), "--compare");
        assert_eq!(flag("kernel_half_width_s"), "--kernel-s");
        assert_eq!(flag("min_speed_mm_min"), "--min-speed-mm-min");
    }
}
