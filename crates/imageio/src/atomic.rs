//! Atomic file writes: the bytes go to a hidden temporary file in the target's directory,
//! are flushed to disk and renamed onto the target. On failure the temporary file is removed
//! and an existing target is left untouched, so a failed write never leaves a half-written
//! file behind. Every file the program writes (images, caches) goes through here.

use std::ffi::OsString;
use std::fmt;
use std::fs;
use std::io::Write;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

/// Why an atomic write failed: the step that failed and the operating system's error.
#[derive(Debug)]
pub struct AtomicWriteError {
    /// The step: "create temporary file", "write" or "rename temporary file into place".
    pub stage: &'static str,
    /// The cause.
    pub source: std::io::Error,
}

impl fmt::Display for AtomicWriteError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.source.fmt(f)
    }
}

impl std::error::Error for AtomicWriteError {
    // Transparent: the message is the cause's, so the cause is not listed again.
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.source.source()
    }
}

/// Fails unless `path` can be replaced by an atomic write: it must be a regular file (a
/// symbolic link to one is followed) or nothing, in an existing directory. A device, a FIFO or a
/// directory is never replaced (write to standard output, `-o -`, to reach those).
pub fn check_target(path: &Path) -> Result<(), AtomicWriteError> {
    let fail = |cause: String| AtomicWriteError {
        stage: "check the target",
        source: std::io::Error::new(std::io::ErrorKind::InvalidInput, cause),
    };
    if path.file_name().is_none() {
        return Err(fail("not a file name".into()));
    }
    match fs::metadata(path) {
        Ok(meta) => match crate::input::special_kind(&meta) {
            None => Ok(()),
            Some(kind) => Err(fail(format!(
                "it is {kind}, not a regular file; only regular files are replaced (use -o - to write to standard output)"
            ))),
        },
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            if fs::symlink_metadata(path).is_ok() {
                return Err(fail("it is a dangling symbolic link".into()));
            }
            let parent = match path.parent() {
                Some(p) if !p.as_os_str().is_empty() => p,
                _ => Path::new("."),
            };
            match fs::metadata(parent) {
                Ok(m) if m.is_dir() => Ok(()),
                Ok(_) => Err(fail(format!("'{}' is not a directory", parent.display()))),
                Err(e) => Err(fail(format!(
                    "its directory '{}' cannot be used: {e}",
                    parent.display()
                ))),
            }
        }
        Err(e) => Err(AtomicWriteError {
            stage: "check the target",
            source: e,
        }),
    }
}

/// A file written beside its target, not yet renamed onto it.
struct Staged {
    temp: std::path::PathBuf,
    target: std::path::PathBuf,
}

/// Writes `bytes` to a new temporary file beside `path` (a symbolic link is resolved, so that
/// the link stays and its target is replaced) and flushes it.
fn stage(path: &Path, bytes: &[u8]) -> Result<Staged, AtomicWriteError> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let fail = |stage| move |source| AtomicWriteError { stage, source };
    check_target(path)?;
    let target = match fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => {
            fs::canonicalize(path).map_err(fail("resolve the link"))?
        }
        _ => path.to_path_buf(),
    };
    let Some(name) = target.file_name() else {
        let cause = std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a file name");
        return Err(fail("write")(cause));
    };
    let mut temp_name = OsString::from(".");
    temp_name.push(name);
    temp_name.push(format!(
        ".tmp-{}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let temp = target.with_file_name(temp_name);

    let mut file = fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&temp)
        .map_err(fail("create temporary file"))?;
    let result = file
        .write_all(bytes)
        .and_then(|()| file.sync_all())
        .map_err(fail("write"));
    drop(file);
    match result {
        Ok(()) => Ok(Staged { temp, target }),
        Err(e) => {
            // Best effort: the original error is what matters.
            let _ = fs::remove_file(&temp);
            Err(e)
        }
    }
}

impl Staged {
    fn commit(self) -> Result<(), AtomicWriteError> {
        // Checked again just before: only a regular file or nothing is replaced.
        if let Err(e) = check_target(&self.target) {
            let _ = fs::remove_file(&self.temp);
            return Err(e);
        }
        fs::rename(&self.temp, &self.target).map_err(|source| {
            let _ = fs::remove_file(&self.temp);
            AtomicWriteError {
                stage: "rename temporary file into place",
                source,
            }
        })
    }
}

/// Writes `bytes` to a temporary file beside `path`, flushes it and renames it onto `path`,
/// which must be a regular file or nothing ([`check_target`]).
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), AtomicWriteError> {
    stage(path, bytes)?.commit()
}

/// Writes several files, all or none: every file is written and flushed beside its target
/// first, and only when all are ready are they renamed into place. On a failure the index of
/// the file concerned is returned with the error, and no target has been touched (short of a
/// rename failing after the first ones, which [`check_target`] makes unlikely).
pub fn write_all_atomically(files: &[(&Path, &[u8])]) -> Result<(), (usize, AtomicWriteError)> {
    for (i, (path, _)) in files.iter().enumerate() {
        check_target(path).map_err(|e| (i, e))?;
    }
    let mut staged = Vec::with_capacity(files.len());
    for (i, (path, bytes)) in files.iter().enumerate() {
        match stage(path, bytes) {
            Ok(s) => staged.push(s),
            Err(e) => {
                for s in staged {
                    let _ = fs::remove_file(&s.temp);
                }
                return Err((i, e));
            }
        }
    }
    let mut result = Ok(());
    for (i, s) in staged.into_iter().enumerate() {
        if result.is_ok() {
            result = s.commit().map_err(|e| (i, e));
        } else {
            let _ = fs::remove_file(&s.temp);
        }
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn devices_and_directories_are_never_replaced() {
        for path in ["/dev/null", "/tmp"] {
            let e = write_atomically(Path::new(path), b"x").unwrap_err();
            assert_eq!(e.stage, "check the target", "{path}");
            assert!(e.to_string().contains("not a regular file"), "{e}");
        }
        assert!(std::fs::metadata("/dev/null")
            .unwrap()
            .file_type()
            .is_char_device_like());
    }

    trait CharDevice {
        fn is_char_device_like(&self) -> bool;
    }
    impl CharDevice for std::fs::FileType {
        fn is_char_device_like(&self) -> bool {
            use std::os::unix::fs::FileTypeExt;
            self.is_char_device()
        }
    }

    #[test]
    fn several_files_are_written_all_or_none() {
        let dir = std::env::temp_dir().join(format!("candela-atomic-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let a = dir.join("a.txt");
        let missing = dir.join("no/such/dir/b.txt");
        let err = write_all_atomically(&[(&a, b"a"), (&missing, b"b")]).unwrap_err();
        assert_eq!(err.0, 1);
        assert!(!a.exists(), "the first file must not be written");
        let b = dir.join("b.txt");
        write_all_atomically(&[(&a, b"a"), (&b, b"b")]).unwrap();
        assert_eq!(fs::read(&a).unwrap(), b"a");
        assert_eq!(fs::read(&b).unwrap(), b"b");
        // Only the targets remain: no temporary file is left behind.
        assert_eq!(fs::read_dir(&dir).unwrap().count(), 2);
        fs::remove_dir_all(&dir).unwrap();
    }
}
