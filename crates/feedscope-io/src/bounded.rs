//! Whole-file reads with a size bound: a configuration, a program or a table is read into
//! memory at once, and a path that names something endless (`/dev/zero`, a named pipe fed
//! forever) or a file of another kind must end in an error, not in an allocation that grows
//! until the machine runs out of memory.
//!
//! The bounds are far above any real file of the kind and far below a machine's memory.

use std::io::Read;
use std::path::Path;

/// Largest configuration file (axis, simulator, drive, thresholds, test-set index, Stribeck
/// table) read (bytes): 16 MiB. Real ones are a few kB.
pub const MAX_CONFIG_BYTES: u64 = 16 << 20;

/// Largest NC program read (bytes): 256 MiB (a long CAM program is tens of MB).
pub const MAX_PROGRAM_BYTES: u64 = 256 << 20;

/// Largest friction CSV or controller recording read whole (bytes): 4 GiB.
pub const MAX_DATA_BYTES: u64 = 4 << 30;

/// Read at most `max_bytes` of `path`; more is an [`std::io::ErrorKind::InvalidData`] error
/// saying so (callers wrap it with the file's name, and it counts as bad input).
///
/// # Errors
/// The operating system's error, or the size bound.
pub fn read(path: &Path, max_bytes: u64) -> std::io::Result<Vec<u8>> {
    let file = std::fs::File::open(path)?;
    let hint = file.metadata().map_or(0, |m| m.len()).min(max_bytes);
    let mut bytes = Vec::with_capacity(usize::try_from(hint).unwrap_or(0));
    file.take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max_bytes {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!(
                "larger than {}: not a file of this kind (or a device that never ends)",
                show_bytes(max_bytes)
            ),
        ));
    }
    Ok(bytes)
}

/// [`read`] as UTF-8 text; text that is not UTF-8 is an
/// [`std::io::ErrorKind::InvalidData`] error naming the first bad byte.
///
/// # Errors
/// As [`read`], and text that is not UTF-8.
pub fn read_to_string(path: &Path, max_bytes: u64) -> std::io::Result<String> {
    String::from_utf8(read(path, max_bytes)?).map_err(|e| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!(
                "not UTF-8 text (byte {} is invalid)",
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

fn show_bytes(n: u64) -> String {
    if n >= 1 << 30 && n.is_multiple_of(1 << 30) {
        format!("{} GiB", n >> 30)
    } else if n >= 1 << 20 && n.is_multiple_of(1 << 20) {
        format!("{} MiB", n >> 20)
    } else {
        format!("{n} bytes")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_within_the_bound_is_read_and_one_beyond_is_refused() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("a.toml");
        std::fs::write(&p, b"lead_mm = 10\n").unwrap();
        assert_eq!(read_to_string(&p, 13).unwrap(), "lead_mm = 10\n");
        let e = read_to_string(&p, 12).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::InvalidData);
        assert!(e.to_string().contains("larger than 12 bytes"), "{e}");
        std::fs::write(&p, b"a\xffb").unwrap();
        let e = read_to_string(&p, 100).unwrap_err();
        assert!(e.to_string().contains("byte 1"), "{e}");
    }

    /// `/dev/zero` ends in the bound's error, after reading no more than the bound.
    #[cfg(unix)]
    #[test]
    fn an_endless_device_is_refused() {
        let e = read(Path::new("/dev/zero"), 1 << 16).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::InvalidData);
        assert_eq!(show_bytes(MAX_CONFIG_BYTES), "16 MiB");
        assert_eq!(show_bytes(MAX_DATA_BYTES), "4 GiB");
    }
}
