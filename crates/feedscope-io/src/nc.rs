//! NC program files: [`read_program`] reads one and parses it with
//! [`NcProgram::parse_bytes`], errors naming the file.

use std::path::Path;

use feedscope::nc::{NcError, NcProgram, ParseOptions};

/// Largest program file read (bytes): 256 MiB, far above any program feedscope can time.
pub const MAX_FILE_BYTES: u64 = 256 << 20;

/// The bytes of a program file, refused when larger than [`MAX_FILE_BYTES`].
///
/// # Errors
/// [`NcError`] naming the file, with line 0, when the file cannot be read or is too large.
pub fn read_bytes(path: &Path) -> Result<Vec<u8>, NcError> {
    let name = path.display().to_string();
    let file_error = |message: String| NcError {
        source_name: name.clone(),
        line: 0,
        message,
    };
    let len = std::fs::metadata(path)
        .map_err(|e| file_error(format!("cannot read the file: {e}")))?
        .len();
    if len > MAX_FILE_BYTES {
        return Err(file_error(format!(
            "{len} bytes, more than the {MAX_FILE_BYTES} this reader accepts"
        )));
    }
    crate::bounded::read(path, crate::bounded::MAX_PROGRAM_BYTES)
        .map_err(|e| file_error(format!("cannot read the file: {e}")))
}

/// Read a program file; errors name the file.
///
/// # Errors
/// [`NcError`] with line 0 when the file cannot be read (or is larger than
/// [`MAX_FILE_BYTES`]), else as [`NcProgram::parse_bytes`].
pub fn read_program(path: &Path, opts: &ParseOptions) -> Result<NcProgram, NcError> {
    let bytes = read_bytes(path)?;
    NcProgram::parse_bytes(&bytes, &path.display().to_string(), opts)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn files_and_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.nc");
        std::fs::write(&path, b"G21\r\nG1 Z1. F100\r\nG1 Z\xff2.\r\n").unwrap();
        let e = read_program(&path, &ParseOptions::default()).unwrap_err();
        assert_eq!(e.line, 3);
        assert!(
            e.message.contains("UTF-8") && e.message.contains("0xFF"),
            "{e}"
        );
        assert!(
            e.to_string().starts_with(&path.display().to_string()),
            "{e}"
        );
        std::fs::write(&path, b"G21\r\nG1 Z1. F100\r\nG1 Z2.\r\n").unwrap();
        let p = read_program(&path, &ParseOptions::default()).unwrap();
        assert_eq!(p.steps.len(), 2);
        let e = read_program(&dir.path().join("missing.nc"), &ParseOptions::default()).unwrap_err();
        assert_eq!(e.line, 0);
        assert!(e.to_string().contains("missing.nc"), "{e}");
    }
}
