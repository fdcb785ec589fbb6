//! Axis description files: [`load`] reads one and validates it with [`AxisParams::parse`],
//! TOML or (named `*.json`) JSON; [`load_for_identification`] also accepts a file without the
//! inertia and damping that the one-test identification finds.

use std::path::Path;

use feedscope::axis::{AxisError, AxisParams, ConfigFormat};

/// Why an axis file could not be loaded.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum AxisFileError {
    /// The file could not be read; the operating system's error is the source.
    #[error("reading {source_name}")]
    Read {
        /// The file.
        source_name: String,
        /// The operating system's error.
        #[source]
        error: std::io::Error,
    },
    /// The file was read but is not a valid axis description (the error names the file).
    #[error(transparent)]
    Axis(#[from] AxisError),
}

impl AxisFileError {
    /// What the error means to a caller: a file that cannot be read is
    /// [`ErrorKind::of_io`](feedscope::ErrorKind::of_io) of the operating system's error (bad input when missing); what it
    /// holds is [`BadInput`](feedscope::ErrorKind::BadInput).
    pub fn kind(&self) -> feedscope::ErrorKind {
        use feedscope::ErrorKind;
        match self {
            AxisFileError::Read { error, .. } => ErrorKind::of_io(error),
            AxisFileError::Axis(e) => e.kind(),
        }
    }
}

impl AxisFileError {
    /// True when the file could not be read (the operating system's error is the source),
    /// false when what it holds is wrong.
    pub fn is_io(&self) -> bool {
        matches!(self, Self::Read { .. })
    }
}

/// Read and validate an axis file; its syntax is told by its name
/// ([`ConfigFormat::from_path`]) and errors name it.
///
/// # Errors
/// [`AxisFileError::Read`] when the file cannot be read; [`AxisFileError::Axis`] as
/// [`AxisParams::parse`].
pub fn load(path: &Path) -> Result<AxisParams, AxisFileError> {
    let source_name = path.display().to_string();
    let text = crate::bounded::read_to_string(path, crate::bounded::MAX_CONFIG_BYTES).map_err(
        |error| AxisFileError::Read {
            source_name: source_name.clone(),
            error,
        },
    )?;
    Ok(AxisParams::parse(
        &text,
        ConfigFormat::from_path(path),
        &source_name,
    )?)
}

/// Read and validate an axis file for the one-test identification (`feedscope identify`,
/// `history add --kind triangle`): as [`load`], but `inertia_kgm2` and
/// `damping_nms_per_rad` may be absent ([`AxisParams::parse_for_identification`]).
///
/// # Errors
/// As [`load`].
pub fn load_for_identification(path: &Path) -> Result<AxisParams, AxisFileError> {
    let source_name = path.display().to_string();
    let text = crate::bounded::read_to_string(path, crate::bounded::MAX_CONFIG_BYTES).map_err(
        |error| AxisFileError::Read {
            source_name: source_name.clone(),
            error,
        },
    )?;
    Ok(AxisParams::parse_for_identification(
        &text,
        ConfigFormat::from_path(path),
        &source_name,
    )?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_name_the_file_and_tell_io_from_content() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("gone.toml");
        let e = load(&missing).unwrap_err();
        assert!(e.is_io());
        assert_eq!(e.to_string(), format!("reading {}", missing.display()));
        let bad = dir.path().join("a.json");
        std::fs::write(&bad, "{\"lead_mm\": -1}").unwrap();
        let e = load(&bad).unwrap_err();
        assert!(!e.is_io());
        assert!(e.to_string().starts_with(&bad.display().to_string()), "{e}");
    }
}
