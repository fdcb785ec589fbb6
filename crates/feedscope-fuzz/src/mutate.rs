//! Structure-aware mutations: text is seen as lines, comma- (or pipe-) separated fields and
//! numbers, TOML/JSON as `key = value` lines, Parquet as typed columns. A mutation of a
//! number replaces it by an extreme; of a column, scales or retypes it; of rows, reorders,
//! duplicates or deletes them; of the bytes, truncates, flips or inserts non-UTF-8.

use std::sync::Arc;

use arrow_array::{
    Array, ArrayRef, Float32Array, Float64Array, Int32Array, Int64Array, RecordBatch, StringArray,
};
use arrow_schema::{DataType, Field, Schema};

use crate::rng::Rng;

/// Numbers a parser must survive (as text).
pub const EXTREMES: &[&str] = &[
    "0",
    "-0",
    "1e308",
    "-1e308",
    "1e300",
    "-1e300",
    "NaN",
    "nan",
    "inf",
    "-inf",
    "infinity",
    "1e-320",
    "4.9e-324",
    "9223372036854775807",
    "-9223372036854775808",
    "18446744073709551616",
    "4294967296",
    "2147483648",
    "99999999999999999999999999999999999999999999999999999999999999999999",
    "0.000000000000000000000000000000000000000000000000000000000000000000001",
    "1e4",
    "-1",
    "1.7976931348623157e308",
    "0x10",
    "1_000",
    "+",
    "-",
    ".",
    "1e",
    "--1",
];

/// Text inserted to break UTF-8 or the syntax.
const JUNK: &[&[u8]] = &[
    b"\xff",
    b"\xc3\x28",
    b"\xed\xa0\x80",
    b"\xef\xbb\xbf",
    b"\0",
    b"\r",
    b"\n",
    b",",
    b"|",
    b"\"",
    b"=",
    b"[",
    b"]]",
    b"{",
    b"#",
    b"\x1b[31m",
];

/// Byte spans `(start, end)` of the numbers in `t` (optional sign, digits, dot, exponent).
pub fn numbers(t: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < t.len() {
        let c = t[i];
        let starts = c.is_ascii_digit()
            || ((c == b'-' || c == b'+' || c == b'.')
                && t.get(i + 1).is_some_and(u8::is_ascii_digit));
        // Not inside a word (`X1_ActualPosition`, `lead_mm`).
        let in_word = i > 0 && (t[i - 1].is_ascii_alphanumeric() || t[i - 1] == b'_');
        if !starts || in_word {
            i += 1;
            continue;
        }
        let s = i;
        i += 1;
        while i < t.len()
            && (t[i].is_ascii_digit()
                || t[i] == b'.'
                || ((t[i] == b'e' || t[i] == b'E')
                    && t.get(i + 1)
                        .is_some_and(|&d| d.is_ascii_digit() || d == b'-' || d == b'+'))
                || ((t[i] == b'-' || t[i] == b'+') && (t[i - 1] == b'e' || t[i - 1] == b'E')))
        {
            i += 1;
        }
        out.push((s, i));
    }
    out
}

/// Byte spans of the lines of `t` (without their terminator).
fn lines(t: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut s = 0;
    for (i, &c) in t.iter().enumerate() {
        if c == b'\n' {
            out.push((s, i));
            s = i + 1;
        }
    }
    if s < t.len() {
        out.push((s, t.len()));
    }
    out
}

fn splice(t: &[u8], (s, e): (usize, usize), with: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(t.len() + with.len());
    out.extend_from_slice(&t[..s]);
    out.extend_from_slice(with);
    out.extend_from_slice(&t[e..]);
    out
}

/// Multiply every number in field `col` (separator `sep`) of every line after the first by
/// `factor`: a whole column in other units, the `positions ×1e4` case.
fn scale_column(t: &[u8], sep: u8, col: usize, factor: f64) -> Vec<u8> {
    let mut out = Vec::with_capacity(t.len() + t.len() / 4);
    for (k, (s, e)) in lines(t).into_iter().enumerate() {
        let line = &t[s..e];
        if k == 0 {
            out.extend_from_slice(line);
        } else {
            for (j, f) in line.split(|&c| c == sep).enumerate() {
                if j > 0 {
                    out.push(sep);
                }
                let parsed = std::str::from_utf8(f)
                    .ok()
                    .and_then(|x| x.trim().parse::<f64>().ok());
                match parsed {
                    Some(v) if j == col => {
                        out.extend_from_slice(format!("{}", v * factor).as_bytes())
                    }
                    _ => out.extend_from_slice(f),
                }
            }
        }
        out.push(b'\n');
    }
    out
}

/// One text mutation of `t`.
pub fn mutate_text_once(rng: &mut Rng, t: &[u8]) -> Vec<u8> {
    let ls = lines(t);
    match rng.below(16) {
        // A number replaced by an extreme (the most telling mutation: weighted double).
        0..=2 => {
            let nums = numbers(t);
            if nums.is_empty() {
                return mutate_bytes_once(rng, t);
            }
            let span = *rng.pick(&nums);
            splice(t, span, rng.pick(EXTREMES).as_bytes())
        }
        // A number scaled (1e4, 1e-4, -1): plausible-looking but out of range.
        3 => {
            let nums = numbers(t);
            if nums.is_empty() {
                return mutate_bytes_once(rng, t);
            }
            let span = *rng.pick(&nums);
            let v: f64 = std::str::from_utf8(&t[span.0..span.1])
                .ok()
                .and_then(|s| s.parse().ok())
                .unwrap_or(1.0);
            let f = *rng.pick(&[1e4, 1e-4, -1.0, 1e8, 1e300]);
            splice(t, span, format!("{}", v * f).as_bytes())
        }
        // A whole column scaled.
        4 => {
            let sep = if t.contains(&b'|') && !t.contains(&b',') {
                b'|'
            } else {
                b','
            };
            let f = *rng.pick(&[1e4, 1e-4, -1.0, 1e6, 1e300, 0.0]);
            scale_column(t, sep, rng.below(6), f)
        }
        // Rows: swap, duplicate, delete, reverse a block.
        5 | 6 if ls.len() > 2 => {
            let a = 1 + rng.below(ls.len() - 1);
            let b = 1 + rng.below(ls.len() - 1);
            let mut v: Vec<&[u8]> = ls.iter().map(|&(s, e)| &t[s..e]).collect();
            match rng.below(4) {
                0 => v.swap(a, b),
                1 => {
                    let most = if rng.one_in(8) { 2000 } else { 3 };
                    let n = 1 + rng.below(most);
                    let line = v[a];
                    for _ in 0..n {
                        v.insert(a, line);
                    }
                }
                2 => {
                    v.remove(a);
                }
                _ => {
                    let (lo, hi) = (a.min(b), a.max(b));
                    v[lo..=hi].reverse();
                }
            }
            let mut out = v.join(&b'\n');
            out.push(b'\n');
            out
        }
        // A field deleted, added, emptied or replaced by text.
        7 if !ls.is_empty() => {
            let (s, e) = *rng.pick(&ls);
            let line = &t[s..e];
            let sep = if line.contains(&b'|') { b'|' } else { b',' };
            let mut f: Vec<&[u8]> = line.split(|&c| c == sep).collect();
            let k = rng.below(f.len());
            match rng.below(4) {
                0 if f.len() > 1 => {
                    f.remove(k);
                }
                1 => f.insert(k, b"1"),
                2 => f[k] = b"",
                _ => f[k] = b"abc",
            }
            splice(t, (s, e), &f.join(&sep))
        }
        // `key = value` lines: values swapped between keys, a value retyped, a line repeated.
        8 | 9 => {
            let kv: Vec<(usize, usize, usize)> = ls
                .iter()
                .filter_map(|&(s, e)| {
                    let line = &t[s..e];
                    let eq = line.iter().position(|&c| c == b'=' || c == b':')?;
                    Some((s, s + eq + 1, e))
                })
                .collect();
            if kv.is_empty() {
                return mutate_bytes_once(rng, t);
            }
            let &(s, v, e) = rng.pick(&kv);
            match rng.below(4) {
                0 => {
                    let &(_, v2, e2) = rng.pick(&kv);
                    let other = t[v2..e2].to_vec();
                    splice(t, (v, e), &other)
                }
                1 => {
                    let choices: [&[u8]; 10] = [
                        b" \"text\"",
                        b" []",
                        b" {}",
                        b" true",
                        b" -1",
                        b" 1e308",
                        b" nan",
                        b" inf",
                        b" [1e308, -1e308]",
                        b" \"\xff\"",
                    ];
                    let new = *rng.pick(&choices);
                    splice(t, (v, e), new)
                }
                2 => {
                    let line = t[s..e].to_vec();
                    let mut with = line.clone();
                    with.push(b'\n');
                    with.extend_from_slice(&line);
                    splice(t, (s, e), &with)
                }
                _ => splice(t, (s, e), b""),
            }
        }
        // The file cut short: at a random byte, or inside the last line.
        10 | 11 => {
            if t.is_empty() {
                return t.to_vec();
            }
            let cut = if rng.one_in(2) && !ls.is_empty() {
                let (s, e) = ls[ls.len() - 1];
                s + rng.below(e - s + 1)
            } else {
                rng.below(t.len())
            };
            t[..cut].to_vec()
        }
        _ => mutate_bytes_once(rng, t),
    }
}

/// One byte-level mutation: a flipped byte, inserted junk, a removed or repeated span.
pub fn mutate_bytes_once(rng: &mut Rng, t: &[u8]) -> Vec<u8> {
    let mut v = t.to_vec();
    if v.is_empty() {
        let junk: &[u8] = rng.pick::<&[u8]>(JUNK);
        v.extend_from_slice(junk);
        return v;
    }
    let at = rng.below(v.len());
    match rng.below(5) {
        0 => v[at] ^= 1 << rng.below(8),
        1 => v[at] = rng.next_u64() as u8,
        2 => {
            let j = *rng.pick(JUNK);
            v.splice(at..at, j.iter().copied());
        }
        3 => {
            let end = (at + 1 + rng.below(64)).min(v.len());
            v.drain(at..end);
        }
        _ => {
            let end = (at + 1 + rng.below(64)).min(v.len());
            let span = v[at..end].to_vec();
            v.splice(at..at, span);
        }
    }
    v
}

/// One to four stacked text mutations.
pub fn mutate_text(rng: &mut Rng, seed: &[u8]) -> Vec<u8> {
    let mut v = mutate_text_once(rng, seed);
    for _ in 0..rng.below(4) {
        v = mutate_text_once(rng, &v);
    }
    v
}

/// One to four stacked byte mutations (binary formats).
pub fn mutate_binary(rng: &mut Rng, seed: &[u8]) -> Vec<u8> {
    let mut v = mutate_bytes_once(rng, seed);
    for _ in 0..rng.below(4) {
        if rng.one_in(4) {
            // An integer field overwritten with an extreme, little endian.
            let x: u64 = *rng.pick(&[0, u64::MAX, i64::MAX as u64, 1 << 31, u32::MAX as u64]);
            let at = rng.below(v.len().max(1));
            for (k, b) in x.to_le_bytes().iter().enumerate().take(4 << rng.below(2)) {
                if let Some(slot) = v.get_mut(at + k) {
                    *slot = *b;
                }
            }
        } else {
            v = mutate_bytes_once(rng, &v);
        }
    }
    v
}

/// A Parquet seed decoded once: its batch, mutated per input and written again.
#[derive(Debug, Clone)]
pub struct ParquetSeed {
    /// The columns as read.
    pub batch: RecordBatch,
}

fn as_f64(a: &ArrayRef) -> Option<Vec<Option<f64>>> {
    if let Some(x) = a.as_any().downcast_ref::<Float64Array>() {
        return Some(x.iter().collect());
    }
    if let Some(x) = a.as_any().downcast_ref::<Float32Array>() {
        return Some(x.iter().map(|v| v.map(f64::from)).collect());
    }
    if let Some(x) = a.as_any().downcast_ref::<Int32Array>() {
        return Some(x.iter().map(|v| v.map(f64::from)).collect());
    }
    if let Some(x) = a.as_any().downcast_ref::<Int64Array>() {
        return Some(x.iter().map(|v| v.map(|i| i as f64)).collect());
    }
    None
}

/// A structured Parquet mutation: a numeric column retyped (Int32, Int64, Float32, string),
/// cells replaced by extremes or nulls, rows reordered or cut, a column renamed or dropped;
/// then the file written again (and, one time in four, its bytes mutated too).
pub fn mutate_parquet(rng: &mut Rng, seed: &ParquetSeed) -> Vec<u8> {
    let b = &seed.batch;
    let mut fields: Vec<Field> = b
        .schema()
        .fields()
        .iter()
        .map(|f| f.as_ref().clone())
        .collect();
    let mut cols: Vec<ArrayRef> = b.columns().to_vec();
    for _ in 0..1 + rng.below(3) {
        if cols.is_empty() {
            break;
        }
        let k = rng.below(cols.len());
        let Some(vals) = as_f64(&cols[k]) else {
            // The channel column of the long layout: rename a channel cell or drop the column.
            if rng.one_in(3) {
                cols.remove(k);
                fields.remove(k);
            }
            continue;
        };
        match rng.below(8) {
            0 => {
                cols[k] = Arc::new(Int32Array::from_iter(
                    vals.iter().map(|v| v.map(|x| x as i32)),
                ));
                fields[k] = Field::new(fields[k].name(), DataType::Int32, true);
            }
            1 => {
                cols[k] = Arc::new(Int64Array::from_iter(
                    vals.iter().map(|v| v.map(|x| (x * 1e3) as i64)),
                ));
                fields[k] = Field::new(fields[k].name(), DataType::Int64, true);
            }
            2 => {
                cols[k] = Arc::new(Float32Array::from_iter(
                    vals.iter().map(|v| v.map(|x| x as f32)),
                ));
                fields[k] = Field::new(fields[k].name(), DataType::Float32, true);
            }
            3 => {
                cols[k] = Arc::new(StringArray::from_iter(
                    vals.iter().map(|v| v.map(|x| x.to_string())),
                ));
                fields[k] = Field::new(fields[k].name(), DataType::Utf8, true);
            }
            4 | 5 => {
                let mut v = vals.clone();
                let n = 1 + rng.below(4);
                for _ in 0..n {
                    let i = rng.below(v.len().max(1));
                    if let Some(c) = v.get_mut(i) {
                        *c = *rng.pick(&[
                            Some(1e308),
                            Some(-1e308),
                            Some(f64::NAN),
                            Some(f64::INFINITY),
                            Some(1e300),
                            Some(-0.0),
                            Some(5e-324),
                            None,
                        ]);
                    }
                }
                if rng.one_in(3) {
                    let f = *rng.pick(&[1e4, -1.0, 1e-4, 1e300]);
                    v.iter_mut().for_each(|c| *c = c.map(|x| x * f));
                }
                cols[k] = Arc::new(Float64Array::from(v));
                fields[k] = Field::new(fields[k].name(), DataType::Float64, true);
            }
            6 => {
                let name = rng
                    .pick(&[
                        "time_s",
                        "time_ms",
                        "position_mm",
                        "position_m",
                        "current_a",
                        "torque_nm",
                        "value",
                        "x",
                    ])
                    .to_string();
                fields[k] = Field::new(name, fields[k].data_type().clone(), true);
            }
            _ => {
                cols.remove(k);
                fields.remove(k);
            }
        }
    }
    let schema = Arc::new(Schema::new(fields));
    let mut batch = match RecordBatch::try_new(schema, cols) {
        Ok(b) => b,
        Err(_) => return mutate_binary(rng, &write_parquet_batch(b)),
    };
    if batch.num_rows() > 4 && rng.one_in(3) {
        // Rows cut short or reordered.
        let n = batch.num_rows();
        batch = if rng.one_in(2) {
            batch.slice(0, rng.below(n))
        } else {
            let idx: Vec<u32> = {
                let mut v: Vec<u32> = (0..n as u32).collect();
                let (a, c) = (rng.below(n), rng.below(n));
                v.swap(a, c);
                v
            };
            let idx = arrow_array::UInt32Array::from(idx);
            let cols = batch
                .columns()
                .iter()
                .map(|c| take(c, &idx))
                .collect::<Vec<_>>();
            RecordBatch::try_new(batch.schema(), cols).unwrap_or(batch)
        };
    }
    let bytes = write_parquet_batch(&batch);
    if rng.one_in(4) {
        mutate_binary(rng, &bytes)
    } else {
        bytes
    }
}

/// Rows of `a` in the order `idx` (a small `take` for the types the mutator makes).
fn take(a: &ArrayRef, idx: &arrow_array::UInt32Array) -> ArrayRef {
    let ix: Vec<usize> = idx.values().iter().map(|&i| i as usize).collect();
    macro_rules! take_as {
        ($t:ty) => {
            if let Some(x) = a.as_any().downcast_ref::<$t>() {
                return Arc::new(
                    ix.iter()
                        .map(|&i| x.is_valid(i).then(|| x.value(i)))
                        .collect::<$t>(),
                );
            }
        };
    }
    take_as!(Float64Array);
    take_as!(Float32Array);
    take_as!(Int32Array);
    take_as!(Int64Array);
    if let Some(x) = a.as_any().downcast_ref::<StringArray>() {
        return Arc::new(
            ix.iter()
                .map(|&i| x.is_valid(i).then(|| x.value(i)))
                .collect::<StringArray>(),
        );
    }
    a.clone()
}

/// A batch as Parquet bytes (uncompressed, one row group).
pub fn write_parquet_batch(b: &RecordBatch) -> Vec<u8> {
    let mut out = Vec::new();
    let Ok(mut w) = parquet::arrow::ArrowWriter::try_new(&mut out, b.schema(), None) else {
        return Vec::new();
    };
    if w.write(b).is_err() || w.close().is_err() {
        return Vec::new();
    }
    out
}

/// Decode a Parquet seed into one batch (all row groups concatenated).
///
/// # Panics
/// When the seed is not readable Parquet (seeds are made by this crate).
pub fn parquet_seed(bytes: &[u8]) -> ParquetSeed {
    let reader = parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(
        bytes::Bytes::copy_from_slice(bytes),
    )
    .and_then(|b| b.build())
    .expect("a seed Parquet file is readable");
    let batches: Vec<RecordBatch> = reader.map(|b| b.expect("seed batch")).collect();
    let schema = batches[0].schema();
    let batch = arrow_array::RecordBatch::try_new(
        schema.clone(),
        (0..schema.fields().len())
            .map(|c| {
                let parts: Vec<&dyn Array> = batches.iter().map(|b| b.column(c).as_ref()).collect();
                concat(&parts)
            })
            .collect(),
    )
    .expect("seed batches share a schema");
    ParquetSeed { batch }
}

fn concat(parts: &[&dyn Array]) -> ArrayRef {
    if parts.len() == 1 {
        return arrow_array::make_array(parts[0].to_data());
    }
    macro_rules! cat {
        ($t:ty) => {
            if parts[0].as_any().is::<$t>() {
                return Arc::new(
                    parts
                        .iter()
                        .flat_map(|p| p.as_any().downcast_ref::<$t>().expect("same type").iter())
                        .collect::<$t>(),
                );
            }
        };
    }
    cat!(Float64Array);
    cat!(StringArray);
    panic!("seed column of an unexpected type {}", parts[0].data_type());
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_found_outside_words() {
        let t = b"X1_ActualPosition,1.98E+02,-3.5e-1,lead_mm = 10\n";
        let spans: Vec<&[u8]> = numbers(t).into_iter().map(|(s, e)| &t[s..e]).collect();
        assert_eq!(spans, [&b"1.98E+02"[..], b"-3.5e-1", b"10"]);
    }

    #[test]
    fn a_column_is_scaled_below_the_header() {
        let t = b"time_s,position_mm\n0,1\n1,2\n";
        assert_eq!(
            scale_column(t, b',', 1, 1e4),
            b"time_s,position_mm\n0,10000\n1,20000\n"
        );
    }

    #[test]
    fn mutations_are_deterministic_for_a_seed() {
        let seed = b"time_s,position_mm,current_a\n0,0,1\n0.1,0.1,1.1\n";
        let (mut a, mut b) = (Rng::new(3), Rng::new(3));
        for _ in 0..200 {
            assert_eq!(mutate_text(&mut a, seed), mutate_text(&mut b, seed));
        }
    }
}
