//! Writing results: atomic file creation, progress bars.
use std::io::Write;
use std::path::{Path, PathBuf};

/// `println!` that returns the write error instead of panicking: a closed stdout
/// (`feedscope ... | head -1`) then reaches `cmd::run` as a broken pipe, which ends the
/// command quietly with exit 0. Use inside functions returning `anyhow::Result`.
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout().lock(), $($arg)*)?
    }};
}
pub(crate) use outln;

/// `print!` with the same error handling as [`outln!`].
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        write!(std::io::stdout().lock(), $($arg)*)?
    }};
}
pub(crate) use out;

use anyhow::{Context, Result};

/// A file written under a temporary name and renamed into place on [`AtomicFile::commit`];
/// dropped without commit, it is removed, so an error never leaves a partial output behind.
pub struct AtomicFile {
    tmp: PathBuf,
    dest: PathBuf,
    file: Option<std::io::BufWriter<std::fs::File>>,
}

impl AtomicFile {
    /// Start `dest`; its folder is made when missing ([`crate::paths::ensure_parent_dir`]).
    pub fn create(dest: &Path) -> Result<Self> {
        crate::paths::ensure_parent_dir(dest)?;
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

/// Print on stderr what a trace read warns about: position samples dropped as glitches (one
/// line: the count, the speed limit, the first few times with their lines or rows), as
/// `warning: SOURCE: ...`. Prints nothing for a clean read.
pub fn print_read_warnings(source: &str, report: &feedscope_io::trace::ReadReport) {
    if let Some(w) = report.glitch_warning() {
        eprintln!("warning: {source}: {w}");
    }
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
