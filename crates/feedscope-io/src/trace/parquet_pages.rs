//! A check of every page header of the column chunks a trace read will decode, before any page
//! is decoded.
//!
//! The decoder (parquet 60) trusts a page header's sizes: it reserves the claimed uncompressed
//! size before it decompresses, so a 1 kB file whose page claims 1.4 GB costs 1.4 GB (a fuzz
//! finding). A page of a flat column holds at most one value per row of its row group, so its
//! size is bounded by the row group's row count from the footer and the column's physical
//! type; a header beyond that bound, or pages that do not tile their column chunk, are
//! refused here as corrupt, naming the row group, the column and the byte offset.
//!
//! The headers are Thrift compact-protocol structs (`PageHeader` of the Parquet format); the
//! reader is written here because parquet 60 keeps its own private. It reads the three
//! sizes, the value counts of the data, dictionary and v2 data page headers, and skips every
//! other field by its wire type.

use parquet::basic::Type as PhysicalType;
use parquet::file::metadata::ParquetMetaData;
use parquet::file::reader::ChunkReader;

use super::TraceError;

/// Longest string value a page is allowed to need per row (bytes, plus its 4-byte length): a
/// channel name is a few dozen bytes; this only keeps a claimed size from being unbounded.
const MAX_STRING_BYTES: u64 = 1024;
/// Per-value room for definition levels and encoding overhead (bytes): RLE/bit-packed levels
/// and delta encodings add at most a few bytes per value.
const LEVEL_BYTES_PER_VALUE: u64 = 16;
/// Room every page has whatever its row count (bytes): small pages never come near it.
const PAGE_SLACK_BYTES: u64 = 1 << 20;
/// First read of a page header (bytes); doubled while the header runs past it.
const HEADER_WINDOW: u64 = 256;
/// Longest page header accepted (bytes): a header holds sizes, counts and statistics.
const MAX_HEADER_BYTES: u64 = 16 << 20;
/// Deepest nesting of Thrift structs and lists skipped in a header.
const MAX_DEPTH: u32 = 32;

/// The fields of a page header the check needs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct PageHeader {
    /// Bytes of the header itself.
    header_len: u64,
    /// The page's size once decompressed (bytes).
    uncompressed: i64,
    /// The page's size in the file (bytes).
    compressed: i64,
    /// Values the data or dictionary page header claims (`None` for other pages).
    values: Option<i64>,
}

/// Why a header could not be read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Bad {
    /// The bytes ended inside the header.
    Truncated,
    /// The bytes are not a Thrift compact struct.
    Malformed(&'static str),
}

/// Check the page headers of the given leaf columns in every row group of a file (see the
/// module doc). `file_len` is the file's length in bytes.
pub(super) fn check_pages<R: ChunkReader>(
    file: &R,
    meta: &ParquetMetaData,
    leaves: &[usize],
    name: &str,
) -> Result<(), TraceError> {
    let file_len = file.len();
    let mut windows = Windows::new(file);
    let corrupt = |g: usize, col: &str, reason: String| TraceError::Parquet {
        source_name: name.to_string(),
        reason: format!("row group {g}, column `{col}`: {reason}"),
    };
    for (g, rg) in meta.row_groups().iter().enumerate() {
        let rows = u64::try_from(rg.num_rows())
            .map_err(|_| corrupt(g, "*", format!("negative row count {}", rg.num_rows())))?;
        for &leaf in leaves {
            let Some(chunk) = rg.columns().get(leaf) else {
                continue;
            };
            let col = chunk.column_descr().name();
            let start = chunk
                .dictionary_page_offset()
                .unwrap_or_else(|| chunk.data_page_offset());
            let (Ok(start), Ok(len)) =
                (u64::try_from(start), u64::try_from(chunk.compressed_size()))
            else {
                return Err(corrupt(
                    g,
                    col,
                    format!(
                        "the footer gives a negative offset ({start}) or size ({})",
                        chunk.compressed_size()
                    ),
                ));
            };
            let end = start
                .checked_add(len)
                .filter(|&e| e <= file_len)
                .ok_or_else(|| {
                    corrupt(
                        g,
                        col,
                        format!(
                            "the column chunk (bytes {start} + {len}) runs past the end of the \
                         file ({file_len} bytes)"
                        ),
                    )
                })?;
            let width = value_bytes(chunk.column_type(), chunk.column_descr().type_length());
            let bound = rows
                .saturating_mul(width + LEVEL_BYTES_PER_VALUE)
                .saturating_add(PAGE_SLACK_BYTES);
            let ahead = if len <= READ_WINDOW { READ_WINDOW } else { 0 };
            let mut pos = start;
            while pos < end {
                let h = read_header(&mut windows, pos, end, ahead).map_err(|why| {
                    corrupt(g, col, format!("the page header at byte {pos} {why}"))
                })?;
                let body = pos + h.header_len;
                let left = end - body.min(end);
                match u64::try_from(h.compressed) {
                    Ok(c) if c <= left => {}
                    _ => {
                        return Err(corrupt(
                            g,
                            col,
                            format!(
                                "the page at byte {pos} claims {} bytes, but its column chunk \
                                 has {left} left",
                                h.compressed
                            ),
                        ))
                    }
                }
                match u64::try_from(h.uncompressed) {
                    Ok(u) if u <= bound => {}
                    _ => {
                        return Err(corrupt(
                            g,
                            col,
                            format!(
                                "the page at byte {pos} claims {} bytes uncompressed, more than \
                                 the {rows} rows of its row group can hold ({bound} bytes at \
                                 most for {:?} values)",
                                h.uncompressed,
                                chunk.column_type()
                            ),
                        ))
                    }
                }
                if let Some(v) = h.values {
                    if u64::try_from(v).map_or(true, |v| v > rows) {
                        return Err(corrupt(
                            g,
                            col,
                            format!(
                                "the page at byte {pos} claims {v} values, but its row group \
                                 has {rows} rows"
                            ),
                        ));
                    }
                }
                pos = body + h.compressed as u64;
            }
        }
    }
    Ok(())
}

/// Largest encoded size of one value of a physical type (bytes).
fn value_bytes(t: PhysicalType, type_length: i32) -> u64 {
    match t {
        PhysicalType::BOOLEAN => 1,
        PhysicalType::INT32 | PhysicalType::FLOAT => 4,
        PhysicalType::INT64 | PhysicalType::DOUBLE => 8,
        PhysicalType::INT96 => 12,
        PhysicalType::FIXED_LEN_BYTE_ARRAY => u64::try_from(type_length).unwrap_or(0),
        PhysicalType::BYTE_ARRAY => 4 + MAX_STRING_BYTES,
    }
}

/// Reads of a file that keep the last one: the headers in a small column chunk and in the
/// small chunks after it come from one read of [`READ_WINDOW`] bytes (a logger's 6,000 row
/// groups of 100 rows would otherwise cost a read per chunk), while a large chunk's headers
/// are read alone, not with the page bodies between them.
struct Windows<'f, R> {
    file: &'f R,
    file_len: u64,
    start: u64,
    bytes: bytes::Bytes,
}

/// Read of [`Windows`] for the headers of a chunk no larger (bytes).
const READ_WINDOW: u64 = 64 << 10;

impl<'f, R: ChunkReader> Windows<'f, R> {
    fn new(file: &'f R) -> Self {
        Self {
            file,
            file_len: file.len(),
            start: 0,
            bytes: bytes::Bytes::new(),
        }
    }

    /// The bytes `[pos, pos + len)`, `len` at most the file's bytes from `pos`; a new read
    /// takes `ahead` bytes when that is more.
    fn get(&mut self, pos: u64, len: u64, ahead: u64) -> parquet::errors::Result<&[u8]> {
        let end = self.start + self.bytes.len() as u64;
        if pos < self.start || pos + len > end {
            let want = len.max(ahead).min(self.file_len.saturating_sub(pos));
            self.bytes = self.file.get_bytes(pos, want as usize)?;
            self.start = pos;
        }
        let from = (pos - self.start) as usize;
        Ok(&self.bytes[from..from + len as usize])
    }
}

/// Read the page header at `pos`, in spans that double until the header fits (within the
/// column chunk, which ends at `end`, and [`MAX_HEADER_BYTES`]).
fn read_header<R: ChunkReader>(
    file: &mut Windows<'_, R>,
    pos: u64,
    end: u64,
    ahead: u64,
) -> Result<PageHeader, String> {
    let room = end - pos;
    let mut span = HEADER_WINDOW.min(room);
    loop {
        let bytes = file
            .get(pos, span, ahead)
            .map_err(|e| format!("cannot be read ({e})"))?;
        match parse_header(bytes) {
            Ok(h) => return Ok(h),
            Err(Bad::Truncated) if span < room && span < MAX_HEADER_BYTES => {
                span = (span * 2).min(room).min(MAX_HEADER_BYTES);
            }
            Err(Bad::Truncated) if span >= MAX_HEADER_BYTES => {
                return Err(format!("is longer than {MAX_HEADER_BYTES} bytes"))
            }
            Err(Bad::Truncated) => return Err("runs past the end of its column chunk".into()),
            Err(Bad::Malformed(why)) => return Err(format!("is not a page header ({why})")),
        }
    }
}

/// Thrift compact-protocol wire types.
mod wire {
    pub const BOOL_TRUE: u8 = 1;
    pub const BOOL_FALSE: u8 = 2;
    pub const BYTE: u8 = 3;
    pub const I16: u8 = 4;
    pub const I32: u8 = 5;
    pub const I64: u8 = 6;
    pub const DOUBLE: u8 = 7;
    pub const BINARY: u8 = 8;
    pub const LIST: u8 = 9;
    pub const SET: u8 = 10;
    pub const MAP: u8 = 11;
    pub const STRUCT: u8 = 12;
    pub const UUID: u8 = 13;
}

/// A cursor over the bytes of one header.
struct Input<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl Input<'_> {
    fn byte(&mut self) -> Result<u8, Bad> {
        let b = *self.bytes.get(self.pos).ok_or(Bad::Truncated)?;
        self.pos += 1;
        Ok(b)
    }

    fn skip(&mut self, n: u64) -> Result<(), Bad> {
        let left = (self.bytes.len() - self.pos) as u64;
        if n > left {
            return Err(Bad::Truncated);
        }
        self.pos += n as usize;
        Ok(())
    }

    /// An unsigned LEB128 varint of at most 10 bytes.
    fn varint(&mut self) -> Result<u64, Bad> {
        let mut v = 0u64;
        for i in 0..10 {
            let b = self.byte()?;
            v |= u64::from(b & 0x7f) << (7 * i);
            if b & 0x80 == 0 {
                return Ok(v);
            }
        }
        Err(Bad::Malformed("a varint longer than 10 bytes"))
    }

    /// A zigzag-encoded signed varint.
    fn zigzag(&mut self) -> Result<i64, Bad> {
        let v = self.varint()?;
        Ok((v >> 1) as i64 ^ -((v & 1) as i64))
    }

    fn i32(&mut self) -> Result<i64, Bad> {
        let v = self.zigzag()?;
        i32::try_from(v)
            .map(i64::from)
            .map_err(|_| Bad::Malformed("an i32 field out of range"))
    }

    /// The next field's (id, wire type), `None` at the struct's end.
    fn field(&mut self, last_id: &mut i64) -> Result<Option<(i64, u8)>, Bad> {
        let b = self.byte()?;
        if b == 0 {
            return Ok(None);
        }
        let kind = b & 0x0f;
        let delta = i64::from(b >> 4);
        let id = if delta == 0 {
            self.zigzag()?
        } else {
            *last_id + delta
        };
        *last_id = id;
        Ok(Some((id, kind)))
    }

    /// Skip a value of a wire type; `in_list` because a bool inside a list takes a byte.
    fn skip_value(&mut self, kind: u8, in_list: bool, depth: u32) -> Result<(), Bad> {
        if depth > MAX_DEPTH {
            return Err(Bad::Malformed("structs nested too deep"));
        }
        match kind {
            wire::BOOL_TRUE | wire::BOOL_FALSE => {
                if in_list {
                    self.byte()?;
                }
            }
            wire::BYTE => self.skip(1)?,
            wire::I16 | wire::I32 | wire::I64 => {
                self.varint()?;
            }
            wire::DOUBLE => self.skip(8)?,
            wire::UUID => self.skip(16)?,
            wire::BINARY => {
                let n = self.varint()?;
                self.skip(n)?;
            }
            wire::LIST | wire::SET => {
                let h = self.byte()?;
                let n = match h >> 4 {
                    15 => self.varint()?,
                    n => u64::from(n),
                };
                let elem = h & 0x0f;
                // Every element takes at least one byte, so a claimed count beyond the bytes
                // left ends as `Truncated` without a long loop.
                for _ in 0..n {
                    self.skip_value(elem, true, depth + 1)?;
                }
            }
            wire::MAP => {
                let n = self.varint()?;
                if n > 0 {
                    let kv = self.byte()?;
                    for _ in 0..n {
                        self.skip_value(kv >> 4, true, depth + 1)?;
                        self.skip_value(kv & 0x0f, true, depth + 1)?;
                    }
                }
            }
            wire::STRUCT => self.skip_struct(depth + 1)?,
            _ => return Err(Bad::Malformed("an unknown Thrift wire type")),
        }
        Ok(())
    }

    fn skip_struct(&mut self, depth: u32) -> Result<(), Bad> {
        let mut last = 0;
        while let Some((_, kind)) = self.field(&mut last)? {
            self.skip_value(kind, false, depth)?;
        }
        Ok(())
    }

    /// A data, dictionary or v2 data page header: the value count in its field 1.
    fn page_kind_header(&mut self) -> Result<Option<i64>, Bad> {
        let mut last = 0;
        let mut values = None;
        while let Some((id, kind)) = self.field(&mut last)? {
            if id == 1 && kind == wire::I32 {
                values = Some(self.i32()?);
            } else {
                self.skip_value(kind, false, 1)?;
            }
        }
        Ok(values)
    }
}

/// Parse a `PageHeader` at the start of `bytes`.
fn parse_header(bytes: &[u8]) -> Result<PageHeader, Bad> {
    let mut input = Input { bytes, pos: 0 };
    let (mut uncompressed, mut compressed, mut values) = (None, None, None);
    let mut last = 0;
    while let Some((id, kind)) = input.field(&mut last)? {
        match (id, kind) {
            (2, wire::I32) => uncompressed = Some(input.i32()?),
            (3, wire::I32) => compressed = Some(input.i32()?),
            // DataPageHeader, DictionaryPageHeader, DataPageHeaderV2.
            (5 | 7 | 8, wire::STRUCT) => values = input.page_kind_header()?.or(values),
            _ => input.skip_value(kind, false, 0)?,
        }
    }
    match (uncompressed, compressed) {
        (Some(uncompressed), Some(compressed)) => Ok(PageHeader {
            header_len: input.pos as u64,
            uncompressed,
            compressed,
            values,
        }),
        _ => Err(Bad::Malformed("no page sizes")),
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use std::sync::Arc;

    use arrow_array::{ArrayRef, Float64Array, RecordBatch, StringArray};
    use parquet::arrow::ArrowWriter;
    use parquet::basic::{Compression, ZstdLevel};
    use parquet::file::properties::{EnabledStatistics, WriterProperties, WriterVersion};
    use parquet::file::reader::{FileReader, SerializedFileReader};

    fn file(props: WriterProperties, rows: usize) -> bytes::Bytes {
        let t: ArrayRef = Arc::new(Float64Array::from_iter_values(
            (0..rows).map(|i| i as f64 * 0.001),
        ));
        let x: ArrayRef = Arc::new(Float64Array::from_iter_values(
            (0..rows).map(|i| (i as f64 * 0.01).sin()),
        ));
        let c: ArrayRef = Arc::new(StringArray::from_iter_values(
            (0..rows).map(|i| ["position_mm", "current_a"][i % 2]),
        ));
        let batch = RecordBatch::try_from_iter([("time_s", t), ("position_mm", x), ("channel", c)])
            .unwrap();
        let mut out = Vec::new();
        let mut w = ArrowWriter::try_new(&mut out, batch.schema(), Some(props)).unwrap();
        w.write(&batch).unwrap();
        w.close().unwrap();
        out.into()
    }

    /// Every page the checker walks is one the parquet reader finds, with the same sizes.
    fn walk_matches_the_reader(bytes: bytes::Bytes) {
        let reader = SerializedFileReader::new(bytes.clone()).unwrap();
        let meta = reader.metadata();
        for (g, rg) in meta.row_groups().iter().enumerate() {
            for (c, chunk) in rg.columns().iter().enumerate() {
                let (start, len) = chunk.byte_range();
                let mut pos = start;
                let mut walked = Vec::new();
                while pos < start + len {
                    let h = read_header(&mut Windows::new(&bytes), pos, start + len, 0).unwrap();
                    walked.push(h.compressed);
                    pos += h.header_len + h.compressed as u64;
                }
                assert_eq!(pos, start + len, "row group {g} column {c}");
                let mut pages = reader
                    .get_row_group(g)
                    .unwrap()
                    .get_column_page_reader(c)
                    .unwrap();
                let mut read = Vec::new();
                while let Some(p) = pages.get_next_page().unwrap() {
                    read.push(p.buffer().len() as i64);
                }
                // Uncompressed pages: the reader's buffer is the page's bytes in the file.
                if chunk.compression() == Compression::UNCOMPRESSED {
                    assert_eq!(walked, read, "row group {g} column {c}");
                } else {
                    assert_eq!(walked.len(), read.len(), "row group {g} column {c}");
                }
            }
        }
        let leaves: Vec<usize> = (0..meta.file_metadata().schema_descr().num_columns()).collect();
        check_pages(&bytes, meta, &leaves, "t.parquet").unwrap();
    }

    #[test]
    fn pages_written_by_parquet_are_walked_as_its_reader_reads_them() {
        for version in [WriterVersion::PARQUET_1_0, WriterVersion::PARQUET_2_0] {
            for codec in [
                Compression::UNCOMPRESSED,
                Compression::ZSTD(ZstdLevel::default()),
            ] {
                for stats in [EnabledStatistics::None, EnabledStatistics::Page] {
                    let props = WriterProperties::builder()
                        .set_writer_version(version)
                        .set_compression(codec)
                        .set_statistics_enabled(stats)
                        .set_data_page_row_count_limit(1000)
                        .set_write_batch_size(500)
                        .set_max_row_group_row_count(Some(7_000))
                        .build();
                    walk_matches_the_reader(file(props, 20_000));
                }
            }
        }
        let plain = WriterProperties::builder()
            .set_dictionary_enabled(false)
            .build();
        walk_matches_the_reader(file(plain, 3_000));
    }

    /// The bytes of a `PageHeader` with the given fields (Thrift compact).
    fn header(unc: i32, comp: i32, values: Option<i32>) -> Vec<u8> {
        fn zz(v: i64, out: &mut Vec<u8>) {
            let mut u = ((v << 1) ^ (v >> 63)) as u64;
            loop {
                let b = (u & 0x7f) as u8;
                u >>= 7;
                if u == 0 {
                    out.push(b);
                    break;
                }
                out.push(b | 0x80);
            }
        }
        let mut h = vec![0x15]; // field 1, i32: type DATA_PAGE
        zz(0, &mut h);
        h.push(0x15);
        zz(i64::from(unc), &mut h);
        h.push(0x15);
        zz(i64::from(comp), &mut h);
        if let Some(v) = values {
            h.push(0x2c); // field 5 (delta 2), struct
            h.push(0x15);
            zz(i64::from(v), &mut h);
            h.push(0x00);
        }
        h.push(0x00);
        h
    }

    #[test]
    fn headers_are_parsed_and_damage_is_named() {
        let h = header(1_386_564_245, 12, Some(3));
        assert_eq!(
            parse_header(&h),
            Ok(PageHeader {
                header_len: h.len() as u64,
                uncompressed: 1_386_564_245,
                compressed: 12,
                values: Some(3),
            })
        );
        for cut in 0..h.len() {
            assert_eq!(parse_header(&h[..cut]), Err(Bad::Truncated), "cut at {cut}");
        }
        assert!(matches!(parse_header(&[0x1e]), Err(Bad::Malformed(_))));
        assert!(matches!(parse_header(&[0x00]), Err(Bad::Malformed(_))));
        let mut long = vec![0x16];
        long.extend([0xff; 11]);
        assert!(matches!(parse_header(&long), Err(Bad::Malformed(_))));
        // A list that claims 2^32 elements ends at the bytes, not after 2^32 steps.
        let huge_list = [0x19, 0xf5, 0xff, 0xff, 0xff, 0xff, 0x0f, 0x00];
        assert_eq!(parse_header(&huge_list), Err(Bad::Truncated));
        // Nesting beyond the depth bound.
        let deep: Vec<u8> = std::iter::repeat_n(0x1c, 40).collect();
        assert!(matches!(parse_header(&deep), Err(Bad::Malformed(_))));
    }

    /// `good` with the first page header of leaf column `leaf` in row group 0 replaced by one
    /// that claims `unc` bytes uncompressed, padded to the old header's length with a field
    /// the readers skip (the page body and the footer stay where they were).
    pub(crate) fn forge_first_page(good: &bytes::Bytes, leaf: usize, unc: i32) -> Vec<u8> {
        let reader = SerializedFileReader::new(good.clone()).unwrap();
        let (start, len) = reader.metadata().row_group(0).column(leaf).byte_range();
        let old = read_header(&mut Windows::new(good), start, start + len, 0).unwrap();
        let mut forged = header(unc, old.compressed as i32, None);
        forged.pop(); // the STOP byte goes after the padding
                      // Field 15 (delta from 3), binary: a length byte, then the padding.
        let pad = old.header_len as usize - forged.len() - 3;
        assert!(pad < 128, "header of {} bytes", old.header_len);
        forged.extend([0xc8, pad as u8]);
        forged.extend(std::iter::repeat_n(0xaa, pad));
        forged.push(0x00);
        assert_eq!(forged.len() as u64, old.header_len);
        let mut bytes = good.to_vec();
        bytes[start as usize..start as usize + forged.len()].copy_from_slice(&forged);
        bytes
    }

    #[test]
    fn a_page_claiming_more_than_its_rows_can_hold_is_refused() {
        let good = file(
            WriterProperties::builder()
                .set_dictionary_enabled(false)
                .build(),
            100,
        );
        let meta = SerializedFileReader::new(good.clone())
            .unwrap()
            .metadata()
            .clone();
        let check = |bytes: &bytes::Bytes| check_pages(bytes, &meta, &[0, 1, 2], "t.parquet");
        check(&good).unwrap();
        // 100 rows of doubles: 2,400 bytes of values and levels and 1 MiB of slack.
        let bound = 100 * (8 + LEVEL_BYTES_PER_VALUE) + PAGE_SLACK_BYTES;
        let at_bound: bytes::Bytes = forge_first_page(&good, 1, bound as i32).into();
        check(&at_bound).unwrap();
        let over: bytes::Bytes = forge_first_page(&good, 1, 1_386_564_245).into();
        let err = check(&over).unwrap_err().to_string();
        assert!(
            err.contains("row group 0, column `position_mm`")
                && err.contains("claims 1386564245 bytes uncompressed")
                && err.contains("100 rows"),
            "{err}"
        );
        let negative: bytes::Bytes = forge_first_page(&good, 0, -5).into();
        let err = check(&negative).unwrap_err().to_string();
        assert!(
            err.contains("column `time_s`") && err.contains("claims -5 bytes"),
            "{err}"
        );
    }

    #[test]
    fn pages_that_do_not_tile_their_chunk_are_refused() {
        let good = file(WriterProperties::builder().build(), 100);
        let meta = SerializedFileReader::new(good.clone())
            .unwrap()
            .metadata()
            .clone();
        let (start, _) = meta.row_group(0).column(1).byte_range();
        let mut bytes = good.to_vec();
        bytes[start as usize] = 0x1e; // field 1 of wire type 14, which Thrift does not have
        let err = check_pages(&bytes::Bytes::from(bytes), &meta, &[1], "t.parquet")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains(&format!("page header at byte {start}")),
            "{err}"
        );
    }
}
