//! Where output files go: `-o dir/file` makes `dir` when it is missing, as `--out DIR` does,
//! so that no command fails with the name of its temporary file.
use std::path::Path;

use anyhow::{Context, Result};

use crate::cmd::BadInput;

/// Make the folder of the output file `dest` when it is missing; refuse a `dest` that is a
/// folder itself (an output flag takes a file name).
///
/// # Errors
/// [`BadInput`] when `dest` is a folder; the file-system error, naming the folder, when it
/// cannot be made.
pub fn ensure_parent_dir(dest: &Path) -> Result<()> {
    if dest.is_dir() {
        return Err(BadInput(format!(
            "{} is a folder; the output must be a file name (e.g. {})",
            dest.display(),
            dest.join("out.csv").display()
        ))
        .into());
    }
    match dest.parent() {
        Some(dir) if !dir.as_os_str().is_empty() && !dir.is_dir() => std::fs::create_dir_all(dir)
            .with_context(|| {
                format!(
                    "creating the folder {} for {}",
                    dir.display(),
                    dest.display()
                )
            }),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missing_folders_are_made_and_folders_refused() {
        let tmp = tempfile::tempdir().unwrap();
        let dest = tmp.path().join("a").join("b").join("out.csv");
        ensure_parent_dir(&dest).unwrap();
        assert!(tmp.path().join("a").join("b").is_dir());
        assert!(!dest.exists(), "only the folder is made");
        let e = ensure_parent_dir(&tmp.path().join("a")).unwrap_err();
        assert!(e.is::<BadInput>(), "{e:#}");
        // A plain file where a folder should be: the error names the folder.
        std::fs::write(tmp.path().join("f"), "x").unwrap();
        let e = ensure_parent_dir(&tmp.path().join("f").join("out.csv")).unwrap_err();
        assert!(format!("{e:#}").contains("creating the folder"), "{e:#}");
    }
}
