//! Simulator config files: the TOML of `feedscope simulate` and the NC program file it may
//! name (`motion.program_file`), read here so that the simulator itself opens no file.

use std::path::Path;

use feedscope::sim::{SimConfig, SimError};

/// Read the file of `cfg.motion.program_file` into `cfg.motion.program_file_contents`, unless
/// they are there already; nothing to do without a program file.
///
/// # Errors
/// [`SimError::Program`] naming the file, with line 0, when it cannot be read or is larger
/// than [`crate::nc::MAX_FILE_BYTES`].
pub fn load_program_file(cfg: &mut SimConfig) -> Result<(), SimError> {
    let m = &mut cfg.motion;
    if let (Some(path), None) = (&m.program_file, &m.program_file_contents) {
        m.program_file_contents = Some(crate::nc::read_bytes(path).map_err(SimError::Program)?);
    }
    Ok(())
}

/// Parse and validate a config that lives in `dir`: a relative `motion.program_file` is taken
/// relative to `dir`, and the program file is read once every key has been checked on its own
/// (so a bad key is reported before a missing program).
///
/// # Errors
/// As [`SimConfig::from_toml_str`]; [`SimError::Program`] when the program file cannot be
/// read.
pub fn config_from_toml_str_in_dir(text: &str, dir: &Path) -> Result<SimConfig, SimError> {
    let mut cfg = SimConfig::parse_toml(text)?;
    if let Some(p) = &cfg.motion.program_file {
        if p.is_relative() {
            cfg.motion.program_file = Some(dir.join(p));
        }
    }
    cfg.validate_settings()?;
    load_program_file(&mut cfg)?;
    cfg.validate()?;
    Ok(cfg)
}

/// Read, parse and validate a config file; a relative `motion.program_file` is taken relative
/// to the config file and read.
///
/// # Errors
/// [`SimError::Parse`] when the file cannot be read; as [`config_from_toml_str_in_dir`].
pub fn read_config(path: &Path) -> Result<SimConfig, SimError> {
    let text =
        crate::bounded::read_to_string(path, crate::bounded::MAX_CONFIG_BYTES).map_err(|e| {
            SimError::Parse {
                message: format!("cannot read {}: {e}", path.display()),
            }
        })?;
    let dir = path.parent().unwrap_or(Path::new("."));
    config_from_toml_str_in_dir(&text, dir)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn program_file_is_read_relative_to_the_config() {
        let run = |c: &SimConfig| feedscope::sim::simulate(c, &mut |_| {}).unwrap();
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("p.nc"),
            "; siemens\nG71 G90 G94\nG0 Z10\nG1 Z20 F600\n",
        )
        .unwrap();
        let cfg_path = dir.path().join("sim.toml");
        std::fs::write(
            &cfg_path,
            "[motion]\nprogram_file = \"p.nc\"\n[dynamics]\nmode = \"ideal\"\n",
        )
        .unwrap();
        let c = read_config(&cfg_path).unwrap();
        assert_eq!(c.motion.program_file, Some(dir.path().join("p.nc")));
        let out = run(&c);
        assert_eq!(out.truth.strokes.len(), 2);
        assert_eq!(out.truth.strokes[1].line, Some(4));
        // from a string, relative to the working directory: the file is not there
        let text = std::fs::read_to_string(&cfg_path).unwrap();
        let e = SimConfig::from_toml_str(&text).unwrap_err().to_string();
        assert!(e.contains("p.nc") && e.contains("line 0"), "{e}");
        let e = config_from_toml_str_in_dir(&text, Path::new("/nonexistent"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("/nonexistent/p.nc: line 0: cannot read the file"),
            "{e}"
        );
    }

    #[test]
    fn a_bad_key_is_reported_before_a_missing_program() {
        let text = "[motion]\nprogram_file = \"gone.nc\"\njerk_mm_s3 = 0\n";
        let e = config_from_toml_str_in_dir(text, Path::new("/nonexistent"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("motion.jerk_mm_s3"), "{e}");
    }
}
