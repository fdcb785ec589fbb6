//! Threshold files of `feedscope history trend` and `report`: a `[thresholds]` table of alarm
//! levels per condition indicator, e.g.
//!
//! ```toml
//! [thresholds]
//! fs_n = { upper = 480 }
//! "mean_n/forward/0-100mm" = { lower = 1, upper = 900 }
//! ```
//!
//! ```
//! let t = feedscope_io::thresholds::parse("[thresholds]\nfs_n = { upper = 480 }\n", "t.toml")?;
//! assert_eq!(t["fs_n"].upper, Some(480.0));
//! assert!(feedscope_io::thresholds::parse("[thresholds]\nfs_n = { upper = nan }\n", "t.toml").is_err());
//! # Ok::<(), feedscope_io::thresholds::ThresholdsError>(())
//! ```

use std::collections::BTreeMap;
use std::path::Path;

use feedscope::history::{Indicator, Threshold, MAX_ABS_THRESHOLD};
use serde::Deserialize;

/// Why a threshold file could not be read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ThresholdsError {
    /// The file could not be read; the operating system's error is the source.
    #[error("reading {source_name}")]
    Read {
        /// The file.
        source_name: String,
        /// The operating system's error.
        #[source]
        error: std::io::Error,
    },
    /// The file is not UTF-8 text.
    #[error("{source_name}: not UTF-8 text (byte {byte_offset} is invalid)")]
    NotUtf8 {
        /// The file.
        source_name: String,
        /// Offset of the first invalid byte.
        byte_offset: usize,
    },
    /// Not TOML of the expected shape (the parser's message names the key and line).
    #[error("{source_name}: {message}")]
    Parse {
        /// The file.
        source_name: String,
        /// What the parser reported.
        message: String,
    },
    /// A key is not a condition indicator.
    #[error("{source_name}: [thresholds]: `{name}` is not a condition indicator (see `feedscope history show`)")]
    UnknownIndicator {
        /// The file.
        source_name: String,
        /// The key.
        name: String,
    },
    /// A level is not finite, or `lower` is not below `upper`.
    #[error("{source_name}: [thresholds]: `{name}`: {reason}")]
    BadLevel {
        /// The file.
        source_name: String,
        /// The key.
        name: String,
        /// What is wrong.
        reason: String,
    },
}

impl ThresholdsError {
    /// What the error means to a caller: an unreadable file is
    /// [`ErrorKind::of_io`](feedscope::ErrorKind::of_io) of the operating system's error;
    /// what it holds is [`BadInput`](feedscope::ErrorKind::BadInput).
    pub fn kind(&self) -> feedscope::ErrorKind {
        match self {
            Self::Read { error, .. } => feedscope::ErrorKind::of_io(error),
            _ => feedscope::ErrorKind::BadInput,
        }
    }
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct ThresholdFile {
    #[serde(default)]
    thresholds: BTreeMap<String, Threshold>,
}

/// Read a threshold file ([`parse`]).
///
/// # Errors
/// [`ThresholdsError::Read`], [`ThresholdsError::NotUtf8`], as [`parse`].
pub fn read(path: &Path) -> Result<BTreeMap<String, Threshold>, ThresholdsError> {
    let source_name = path.display().to_string();
    let bytes = crate::bounded::read(path, crate::bounded::MAX_CONFIG_BYTES).map_err(|error| {
        ThresholdsError::Read {
            source_name: source_name.clone(),
            error,
        }
    })?;
    let text = String::from_utf8(bytes).map_err(|e| ThresholdsError::NotUtf8 {
        source_name: source_name.clone(),
        byte_offset: e.utf8_error().valid_up_to(),
    })?;
    parse(&text, &source_name)
}

/// Parse a threshold file: known indicator keys, finite levels, `lower` below `upper`.
///
/// # Errors
/// [`ThresholdsError::Parse`], [`ThresholdsError::UnknownIndicator`],
/// [`ThresholdsError::BadLevel`].
pub fn parse(
    text: &str,
    source_name: &str,
) -> Result<BTreeMap<String, Threshold>, ThresholdsError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let f: ThresholdFile = toml::from_str(text).map_err(|e| ThresholdsError::Parse {
        source_name: source_name.to_string(),
        message: e.to_string().trim_end().to_string(),
    })?;
    for (name, t) in &f.thresholds {
        if Indicator::parse(name).is_none() {
            return Err(ThresholdsError::UnknownIndicator {
                source_name: source_name.to_string(),
                name: name.clone(),
            });
        }
        let bad = |reason: String| ThresholdsError::BadLevel {
            source_name: source_name.to_string(),
            name: name.clone(),
            reason,
        };
        for (key, v) in [("upper", t.upper), ("lower", t.lower)] {
            if let Some(v) = v.filter(|v| !v.is_finite()) {
                return Err(bad(format!("{key} = {v} is not a finite number")));
            }
            if let Some(v) = v.filter(|v| v.abs() > MAX_ABS_THRESHOLD) {
                return Err(bad(format!(
                    "{key} = {v:e} is beyond ±1e9, which no condition indicator of a feed \
                     drive comes near (a unit slip?)"
                )));
            }
        }
        if let (Some(lo), Some(hi)) = (t.lower, t.upper) {
            if lo >= hi {
                return Err(bad(format!("lower = {lo} is not below upper = {hi}")));
            }
        }
    }
    Ok(f.thresholds)
}
