//! What a trace file is: its format (CSV or Parquet, told by the first bytes) and its layout.
//! Both readers and the dispatch of [`super::read_trace_file`] use this; it uses neither.

use std::fs::File;
use std::io::{Read, Seek};
use std::path::Path;

/// Layout of a trace file (CSV or Parquet).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Layout {
    /// `time_s,channel,value`, one sample per row (asynchronous channels).
    Long,
    /// `time_s,position_mm,current_a` (or `torque_nm`), channels sampled together.
    Wide,
}

/// The four bytes every Parquet file starts (and ends) with.
pub(super) const PARQUET_MAGIC: &[u8; 4] = b"PAR1";

/// The format of a trace file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Format {
    /// Text with a header line.
    Csv,
    /// Parquet: starts with [`PARQUET_MAGIC`].
    Parquet,
}

impl Format {
    /// The format of a trace held in memory.
    pub(super) fn of_bytes(bytes: &[u8]) -> Self {
        if bytes.starts_with(PARQUET_MAGIC) {
            Self::Parquet
        } else {
            Self::Csv
        }
    }

    /// The format of an open file, from its first four bytes; the file is rewound either way.
    pub(super) fn of_file(file: &mut File) -> std::io::Result<Self> {
        let mut head = [0u8; 4];
        let mut filled = 0;
        while filled < head.len() {
            match file.read(&mut head[filled..]) {
                Ok(0) => break,
                Ok(n) => filled += n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
        file.rewind()?;
        Ok(if filled == head.len() && &head == PARQUET_MAGIC {
            Self::Parquet
        } else {
            Self::Csv
        })
    }
}

/// True when the name says Parquet (`*.parquet`, any case): such a file without the magic is
/// refused rather than parsed as CSV, which would only report a confusing bad header.
pub(super) fn named_parquet(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("parquet"))
}
