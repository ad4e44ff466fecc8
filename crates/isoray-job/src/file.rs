//! Files written whole or not at all: output goes to a temporary file
//! beside the target, is flushed to disk and renamed over the target, so
//! readers see the old file or the new one, never a part, and a failure or
//! a cancellation leaves an existing file as it was. The one mechanism of
//! scene files, images and meshes.
//!
//! ```
//! let dir = std::env::temp_dir().join(format!("isoray-job-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir).unwrap();
//! let path = dir.join("out.txt");
//! isoray_job::file::write_atomic(&path, b"old").unwrap();
//! // A write that fails leaves the old file.
//! let failed = isoray_job::file::replace_atomically(&path, |_tmp| Err(std::io::Error::other("disk full")));
//! assert!(failed.is_err());
//! assert_eq!(std::fs::read(&path).unwrap(), b"old");
//! # std::fs::remove_dir_all(&dir).unwrap();
//! ```

use std::fs;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// A temporary file beside its target (`.<name>.tmp-<pid>-<n>`), removed
/// when dropped unless [`TempFile::commit`] renamed it over the target.
#[derive(Debug)]
pub struct TempFile {
    path: PathBuf,
    target: PathBuf,
    done: bool,
}

impl TempFile {
    /// Creates a new, empty temporary file in the directory of `target`
    /// (never an existing file) and opens it for writing.
    pub fn beside(target: &Path) -> io::Result<(TempFile, fs::File)> {
        static COUNTER: AtomicU64 = AtomicU64::new(0);
        let dir = match target.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        let name = target
            .file_name()
            .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "the path names no file"))?;
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let path = dir.join(format!(".{}.tmp-{}-{n}", name.to_string_lossy(), std::process::id()));
        let file = fs::OpenOptions::new().write(true).create_new(true).open(&path)?;
        Ok((
            TempFile {
                path,
                target: target.to_path_buf(),
                done: false,
            },
            file,
        ))
    }

    /// The temporary file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Flushes the temporary file to disk and renames it over the target.
    /// On failure the temporary file is removed and the target is untouched.
    pub fn commit(mut self) -> io::Result<()> {
        fs::File::open(&self.path)?.sync_all()?;
        fs::rename(&self.path, &self.target)?;
        self.done = true;
        Ok(())
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if !self.done {
            let _ = fs::remove_file(&self.path);
        }
    }
}

/// Lets `write` fill a temporary file beside `path` (it may also create
/// the file again at that path), then flushes it and renames it over
/// `path`; on any failure the temporary file is removed and the old file
/// is left as it was.
pub fn replace_atomically(path: &Path, write: impl FnOnce(&Path) -> io::Result<()>) -> io::Result<()> {
    let (tmp, file) = TempFile::beside(path)?;
    drop(file);
    write(tmp.path())?;
    tmp.commit()
}

/// Writes `bytes` to `path` atomically (see [`replace_atomically`]).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let (tmp, mut file) = TempFile::beside(path)?;
    file.write_all(bytes)?;
    drop(file);
    tmp.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("isoray-job-{name}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        fs::create_dir_all(&d).unwrap();
        d
    }

    fn leftovers(d: &Path) -> Vec<String> {
        fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.contains(".tmp-"))
            .collect()
    }

    #[test]
    fn a_failed_write_leaves_the_old_file_and_no_temporary() {
        let d = dir("fail");
        let path = d.join("scene.toml");
        write_atomic(&path, b"first").unwrap();
        let e = replace_atomically(&path, |tmp| {
            fs::write(tmp, b"half")?;
            Err(io::Error::other("stopped"))
        });
        assert!(e.is_err());
        assert_eq!(fs::read(&path).unwrap(), b"first");
        assert!(leftovers(&d).is_empty());
        write_atomic(&path, b"second").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"second");
        assert!(leftovers(&d).is_empty());
        fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn an_uncommitted_temporary_is_removed() {
        let d = dir("drop");
        let target = d.join("mesh.obj");
        let (tmp, mut f) = TempFile::beside(&target).unwrap();
        f.write_all(b"partial").unwrap();
        assert_eq!(leftovers(&d).len(), 1);
        drop(tmp);
        assert!(leftovers(&d).is_empty());
        assert!(!target.exists());
        fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_missing_directory_is_an_error() {
        let d = dir("missing");
        let e = write_atomic(&d.join("no/such/dir/out.png"), b"x");
        assert!(e.is_err());
        fs::remove_dir_all(&d).unwrap();
    }
}
