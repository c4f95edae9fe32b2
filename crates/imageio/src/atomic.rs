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
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        Some(&self.source)
    }
}

/// Writes `bytes` to a temporary file beside `path`, flushes it and renames it onto `path`.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), AtomicWriteError> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let fail = |stage| move |source| AtomicWriteError { stage, source };
    let Some(name) = path.file_name() else {
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
    let temp = path.with_file_name(temp_name);

    let mut file = fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&temp)
        .map_err(fail("create temporary file"))?;
    let result = file
        .write_all(bytes)
        .and_then(|()| file.sync_all())
        .map_err(fail("write"))
        .and_then(|()| {
            drop(file);
            fs::rename(&temp, path).map_err(fail("rename temporary file into place"))
        });
    if result.is_err() {
        // Best effort: the original error is what matters.
        let _ = fs::remove_file(&temp);
    }
    result
}
