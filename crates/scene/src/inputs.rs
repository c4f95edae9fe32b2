//! The files a scene load reads, recorded as it reads them, so that a render can name its inputs
//! (a partial render's scene hash covers the scene file and everything it loads).
//!
//! Loading runs on one thread; [`collecting`] records every [`record`]ed path of the closure it
//! runs on that thread, in first-read order without repeats.

use std::cell::RefCell;
use std::path::{Path, PathBuf};

thread_local! {
    static INPUTS: RefCell<Option<Vec<PathBuf>>> = const { RefCell::new(None) };
}

/// Notes that the load being collected reads `path` (nothing when no collection runs).
pub(crate) fn record(path: &Path) {
    INPUTS.with(|i| {
        if let Some(list) = i.borrow_mut().as_mut() {
            if !list.iter().any(|p| p == path) {
                list.push(path.to_path_buf());
            }
        }
    });
}

/// Runs `f`, returning its result and the files it read. Nested collections add to the
/// outermost one.
pub(crate) fn collecting<T>(f: impl FnOnce() -> T) -> (T, Vec<PathBuf>) {
    let outer = INPUTS.with(|i| i.borrow().is_some());
    if outer {
        return (f(), Vec::new());
    }
    INPUTS.with(|i| *i.borrow_mut() = Some(Vec::new()));
    let out = f();
    let files = INPUTS.with(|i| i.borrow_mut().take()).unwrap_or_default();
    (out, files)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_each_file_once_in_order_and_only_while_collecting() {
        record(Path::new("ignored"));
        let ((), files) = collecting(|| {
            record(Path::new("a"));
            record(Path::new("b"));
            record(Path::new("a"));
        });
        assert_eq!(files, [PathBuf::from("a"), PathBuf::from("b")]);
        let ((), none) = collecting(|| {});
        assert!(none.is_empty());
    }
}
