//! Writing results: an output file that appears whole or not at all ([`AtomicFile`]), the
//! outputs of one run that appear together ([`OutputSet`]), and the folder an output needs.
//! Every front end that writes files writes them through here, so that an error or an
//! interrupt never leaves a partial output beside the previous run's.
use std::io::Write;
use std::path::{Path, PathBuf};

use feedscope::ErrorKind;

use crate::AppError;

type Result<T, E = AppError> = std::result::Result<T, E>;

/// An operating-system error met while `context`: its kind as [`ErrorKind::of_io`] says
/// (a missing file is the user's input).
pub fn io_error(context: impl Into<String>, e: std::io::Error) -> AppError {
    AppError::caused(ErrorKind::of_io(&e), context, e)
}

/// `.io_context(|| "what was being done")` on an I/O result, as anyhow's `with_context`.
trait IoContext<T> {
    fn io_context(self, context: impl FnOnce() -> String) -> Result<T>;
}

impl<T> IoContext<T> for std::io::Result<T> {
    fn io_context(self, context: impl FnOnce() -> String) -> Result<T> {
        self.map_err(|e| io_error(context(), e))
    }
}

impl<T> IoContext<T> for Option<T> {
    fn io_context(self, context: impl FnOnce() -> String) -> Result<T> {
        self.ok_or_else(|| AppError::bad_input(context()))
    }
}

/// Make the folder of the output file `dest` when it is missing; refuse a `dest` that is a
/// folder itself (an output flag takes a file name), so that no write fails with the name of
/// its temporary file.
///
/// # Errors
/// Bad input when `dest` is a folder; the file-system error, naming the folder, when it
/// cannot be made.
pub fn ensure_parent_dir(dest: &Path) -> Result<()> {
    if dest.is_dir() {
        return Err(AppError::bad_input(format!(
            "{} is a folder; the output must be a file name (e.g. {})",
            dest.display(),
            dest.join("out.csv").display()
        )));
    }
    match dest.parent() {
        Some(dir) if !dir.as_os_str().is_empty() && !dir.is_dir() => std::fs::create_dir_all(dir)
            .io_context(|| {
                format!(
                    "creating the folder {} for {}",
                    dir.display(),
                    dest.display()
                )
            }),
        _ => Ok(()),
    }
}

/// The temporary name of `dest` for the process `pid` with `suffix` (`tmp` or `bak`):
/// `.NAME.PID.SUFFIX` beside it, hidden, and recognisable as ours by [`remove_stale`].
fn side_name(dest: &Path, pid: u32, suffix: &str) -> Result<PathBuf> {
    let name = dest
        .file_name()
        .io_context(|| format!("{} is not a file path", dest.display()))?;
    let mut side = std::ffi::OsString::from(".");
    side.push(name);
    side.push(format!(".{pid}.{suffix}"));
    Ok(dest.with_file_name(side))
}

/// Whether process `pid` may still be running. Only Linux can tell (by `/proc`); elsewhere
/// every process counts as alive, so that no temporary file of a running command is removed.
fn pid_alive(pid: u32) -> bool {
    if cfg!(target_os = "linux") && Path::new("/proc/self").exists() {
        Path::new("/proc").join(pid.to_string()).exists()
    } else {
        true
    }
}

/// Remove what killed runs left beside `dest`: files named exactly `.NAME.PID.tmp` or
/// `.NAME.PID.bak` (NAME `dest`'s file name) whose process is gone. Anything else, and the
/// files of live processes, are left alone; failures are ignored (the write goes on).
fn remove_stale(dest: &Path) {
    let (Some(name), Some(dir)) = (dest.file_name().and_then(|n| n.to_str()), dest.parent()) else {
        return;
    };
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    let prefix = format!(".{name}.");
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let file = entry.file_name();
        let Some(rest) = file.to_str().and_then(|f| f.strip_prefix(&prefix)) else {
            continue;
        };
        let Some(pid) = rest
            .strip_suffix(".tmp")
            .or_else(|| rest.strip_suffix(".bak"))
            .and_then(|p| p.parse::<u32>().ok())
        else {
            continue;
        };
        if pid != std::process::id() && !pid_alive(pid) {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// A file written under a temporary name and renamed into place on [`AtomicFile::commit`];
/// dropped without commit, it is removed, so an error never leaves a partial output behind.
/// Creating it removes the temporary files that killed runs left beside the same output.
///
/// A symbolic link is written through: the file it points at is replaced, the link stays. A
/// destination that exists and is neither a regular file nor a folder (a device such as
/// `/dev/null` or `/dev/stdout`, a named pipe) is written directly, as a shell redirection
/// would: it cannot be replaced, and its output is not atomic.
pub struct AtomicFile {
    tmp: PathBuf,
    dest: PathBuf,
    file: Option<std::io::BufWriter<std::fs::File>>,
    /// Written straight into `dest` (a device or a pipe): nothing to rename or remove.
    direct: bool,
}

/// The temporary files of this process not yet renamed into place or removed: what an
/// interrupt removes ([`remove_unfinished`]).
static IN_FLIGHT: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// Note a temporary file an interrupt should remove ([`remove_unfinished`]), for a writer
/// that makes its own temporary files; [`AtomicFile`] notes its own.
pub fn register(tmp: &Path) {
    if let Ok(mut v) = IN_FLIGHT.lock() {
        v.push(tmp.to_path_buf());
    }
}

/// The temporary file is gone or in place: an interrupt leaves it alone.
pub fn unregister(tmp: &Path) {
    if let Ok(mut v) = IN_FLIGHT.lock() {
        v.retain(|p| p != tmp);
    }
}

/// Remove the temporary files of the outputs being written (what an interrupt does before the
/// process ends: the outputs of an earlier run stay as they were and no partial one is left
/// beside them); returns how many were removed. Safe to call from a signal handler's thread.
pub fn remove_unfinished() -> usize {
    IN_FLIGHT.lock().map_or(0, |v| {
        v.iter().filter(|p| std::fs::remove_file(p).is_ok()).count()
    })
}

/// How many symbolic links [`resolve_links`] follows before it calls the chain a loop (as
/// Linux's `ELOOP`).
const MAX_LINKS: usize = 40;

/// `dest` with every symbolic link at its end followed, also a link whose target does not
/// exist yet (which `canonicalize` refuses): a relative target is taken from the link's
/// folder.
fn resolve_links(dest: &Path) -> Result<PathBuf> {
    let mut path = dest.to_path_buf();
    for _ in 0..MAX_LINKS {
        match std::fs::symlink_metadata(&path) {
            Ok(m) if m.file_type().is_symlink() => {
                let target = std::fs::read_link(&path)
                    .io_context(|| format!("reading the link {}", path.display()))?;
                path = match path.parent() {
                    Some(dir) if target.is_relative() => dir.join(target),
                    _ => target,
                };
            }
            _ => return Ok(path),
        }
    }
    Err(AppError::bad_input(format!(
        "{}: more than {MAX_LINKS} symbolic links in a row (a loop?)",
        dest.display()
    )))
}

impl AtomicFile {
    /// Start `dest`; its folder is made when missing ([`ensure_parent_dir`]).
    pub fn create(dest: &Path) -> Result<Self> {
        let dest = resolve_links(dest)?;
        let special = std::fs::metadata(&dest)
            .map(|m| !m.is_file() && !m.is_dir())
            .unwrap_or(false);
        if special {
            let file = std::fs::OpenOptions::new()
                .write(true)
                .open(&dest)
                .io_context(|| format!("opening {} for writing", dest.display()))?;
            return Ok(Self {
                tmp: dest.clone(),
                dest,
                file: Some(std::io::BufWriter::with_capacity(1 << 20, file)),
                direct: true,
            });
        }
        ensure_parent_dir(&dest)?;
        let tmp = side_name(&dest, std::process::id(), "tmp")?;
        remove_stale(&dest);
        register(&tmp);
        let file = std::fs::File::create(&tmp).io_context(|| {
            unregister(&tmp);
            format!("creating {}", tmp.display())
        })?;
        Ok(Self {
            tmp,
            dest,
            file: Some(std::io::BufWriter::with_capacity(1 << 20, file)),
            direct: false,
        })
    }

    pub fn writer(&mut self) -> &mut std::io::BufWriter<std::fs::File> {
        self.file.as_mut().expect("writer used after commit")
    }

    /// Write out what is buffered; the file stays temporary.
    fn flush(&mut self) -> Result<()> {
        self.writer()
            .flush()
            .io_context(|| format!("writing {}", self.tmp.display()))
    }

    pub fn commit(mut self) -> Result<()> {
        self.flush()?;
        drop(self.file.take());
        if self.direct {
            return Ok(());
        }
        let renamed = std::fs::rename(&self.tmp, &self.dest)
            .io_context(|| format!("renaming into {}", self.dest.display()));
        if renamed.is_err() {
            let _ = std::fs::remove_file(&self.tmp);
        }
        unregister(&self.tmp);
        renamed
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.file.take().is_some() && !self.direct {
            let _ = std::fs::remove_file(&self.tmp);
            unregister(&self.tmp);
        }
    }
}

/// Write text atomically.
pub fn write_atomic(dest: &Path, bytes: &[u8]) -> Result<()> {
    let mut f = AtomicFile::create(dest)?;
    f.writer()
        .write_all(bytes)
        .io_context(|| format!("writing {}", dest.display()))?;
    f.commit()
}

/// The outputs of one command, which appear together or not at all: each is written to its
/// temporary file, and [`OutputSet::commit`] renames them all into place at the end. A command
/// that fails before then (the set dropped) leaves the previous outputs as they were and no
/// temporary file; a rename that fails during the commit puts back the outputs already
/// replaced, so the folder never holds a mix of old and new files.
#[derive(Default)]
pub struct OutputSet {
    files: Vec<AtomicFile>,
}

impl OutputSet {
    pub fn new() -> Self {
        Self::default()
    }

    /// Start one output of the set ([`AtomicFile::create`]); hand it back with
    /// [`add`](Self::add) when written.
    pub fn create(&self, dest: &Path) -> Result<AtomicFile> {
        AtomicFile::create(dest)
    }

    /// Take a written output into the set (flushed, still under its temporary name).
    pub fn add(&mut self, mut f: AtomicFile) -> Result<()> {
        f.flush()?;
        self.files.push(f);
        Ok(())
    }

    /// Write `bytes` as the output `dest` of the set.
    pub fn write(&mut self, dest: &Path, bytes: &[u8]) -> Result<()> {
        let mut f = self.create(dest)?;
        f.writer()
            .write_all(bytes)
            .io_context(|| format!("writing {}", dest.display()))?;
        self.add(f)
    }

    /// Rename every output into place. Each existing output is first linked (or copied) to
    /// `.NAME.PID.bak`, so that when a rename fails the ones done are put back.
    pub fn commit(mut self) -> Result<()> {
        let mut done: Vec<(PathBuf, Option<PathBuf>)> = Vec::with_capacity(self.files.len());
        let files = std::mem::take(&mut self.files);
        let mut result = Ok(());
        for mut f in files {
            drop(f.file.take());
            if f.direct {
                // Already written where it goes (a device or a pipe).
                continue;
            }
            let step = (|| -> Result<Option<PathBuf>> {
                let backup = if f.dest.is_file() {
                    let b = side_name(&f.dest, std::process::id(), "bak")?;
                    let _ = std::fs::remove_file(&b);
                    std::fs::hard_link(&f.dest, &b)
                        .or_else(|_| std::fs::copy(&f.dest, &b).map(drop))
                        .io_context(|| format!("keeping {} until the end", f.dest.display()))?;
                    Some(b)
                } else {
                    None
                };
                if let Err(e) = std::fs::rename(&f.tmp, &f.dest) {
                    if let Some(b) = &backup {
                        let _ = std::fs::remove_file(b);
                    }
                    return Err(io_error(format!("renaming into {}", f.dest.display()), e));
                }
                Ok(backup)
            })();
            match step {
                Ok(backup) => done.push((f.dest.clone(), backup)),
                Err(e) => {
                    let _ = std::fs::remove_file(&f.tmp);
                    result = Err(e);
                }
            }
            unregister(&f.tmp);
            if result.is_err() {
                break;
            }
        }
        if result.is_err() {
            // Put the previous set back: old files from their backups, new ones removed.
            for (dest, backup) in done.iter().rev() {
                let _ = match backup {
                    Some(b) => std::fs::rename(b, dest),
                    None => std::fs::remove_file(dest),
                };
            }
        } else {
            for b in done.iter().filter_map(|(_, b)| b.as_ref()) {
                let _ = std::fs::remove_file(b);
            }
        }
        // The temporary files not reached were removed as the loop's rest dropped.
        result
    }
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

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    /// The pid of a process that has ended.
    fn dead_pid() -> u32 {
        let mut c = std::process::Command::new("true").spawn().unwrap();
        let pid = c.id();
        c.wait().unwrap();
        pid
    }

    #[test]
    fn stale_temporaries_of_dead_processes_are_removed() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let dead = dead_pid();
        let keep = [
            // a live process (init) may still be writing it
            ".out.csv.1.tmp".to_string(),
            // not exactly our pattern, or another output's
            ".out.csv.x1.tmp".into(),
            "out.csv.123.tmp".into(),
            format!(".other.csv.{dead}.tmp"),
        ];
        let stale = [
            format!(".out.csv.{dead}.tmp"),
            format!(".out.csv.{dead}.bak"),
        ];
        for n in keep.iter().chain(&stale) {
            std::fs::write(d.join(n), "x").unwrap();
        }
        write_atomic(&d.join("out.csv"), b"new").unwrap();
        let mut want: Vec<String> = keep.to_vec();
        if !cfg!(target_os = "linux") {
            want.extend(stale.iter().cloned());
        }
        want.push("out.csv".into());
        want.sort();
        assert_eq!(names(d), want);
    }

    #[test]
    fn an_output_set_appears_whole_or_not_at_all() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        for n in ["a.csv", "b.csv"] {
            std::fs::write(d.join(n), "old").unwrap();
        }
        // dropped before the commit: old files, no temporary
        let mut set = OutputSet::new();
        set.write(&d.join("a.csv"), b"new").unwrap();
        set.write(&d.join("c.csv"), b"new").unwrap();
        drop(set);
        assert_eq!(names(d), ["a.csv", "b.csv"]);
        // a rename fails half-way (c.csv became a folder meanwhile): a.csv is put back, the
        // new b.csv removed, nothing temporary left
        std::fs::remove_file(d.join("b.csv")).unwrap();
        let mut set = OutputSet::new();
        set.write(&d.join("a.csv"), b"new").unwrap();
        set.write(&d.join("b.csv"), b"new").unwrap();
        set.write(&d.join("c.csv"), b"new").unwrap();
        set.write(&d.join("e.csv"), b"new").unwrap();
        std::fs::create_dir(d.join("c.csv")).unwrap();
        std::fs::write(d.join("c.csv").join("x"), "x").unwrap();
        let e = set.commit().unwrap_err();
        assert!(format!("{e:#}").contains("c.csv"), "{e:#}");
        assert_eq!(names(d), ["a.csv", "c.csv"]);
        assert_eq!(std::fs::read(d.join("a.csv")).unwrap(), b"old");
        // and a set that commits replaces all
        std::fs::remove_dir_all(d.join("c.csv")).unwrap();
        let mut set = OutputSet::new();
        set.write(&d.join("a.csv"), b"new").unwrap();
        set.write(&d.join("b.csv"), b"new").unwrap();
        set.commit().unwrap();
        assert_eq!(names(d), ["a.csv", "b.csv"]);
        assert_eq!(std::fs::read(d.join("a.csv")).unwrap(), b"new");
    }

    #[test]
    fn missing_folders_are_made_and_folders_refused() {
        let tmp = tempfile::tempdir().unwrap();
        let dest = tmp.path().join("a").join("b").join("out.csv");
        ensure_parent_dir(&dest).unwrap();
        assert!(tmp.path().join("a").join("b").is_dir());
        assert!(!dest.exists(), "only the folder is made");
        let e = ensure_parent_dir(&tmp.path().join("a")).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::BadInput, "{e}");
        // A plain file where a folder should be: the error names the folder.
        std::fs::write(tmp.path().join("f"), "x").unwrap();
        let e = ensure_parent_dir(&tmp.path().join("f").join("out.csv")).unwrap_err();
        assert!(e.to_string().contains("creating the folder"), "{e}");
        assert_eq!(e.kind(), ErrorKind::Io, "{e}");
    }
}
