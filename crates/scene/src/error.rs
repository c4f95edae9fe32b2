//! Errors of the whole crate: positions in a source file and [`SceneError`].
//!
//! Every error names the file it comes from. When it has a position it renders as
//! `path:line:col: message`, followed by the offending source line and a caret under the
//! column whenever that line is known:
//!
//! ```text
//! scene.txt:3:14: unknown material 'skyy'
//! plane (skyy, identity)
//!        ^
//! ```
//!
//! Code that runs after parsing (the builder, the mesh loader) keeps the [`Pos`] stored in the
//! scene description and the [`SourceFile`] to produce the same kind of message later, e.g.
//! `source.error(file.pos, "mesh file not found")`.

use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A position in a source file: 1-based line and column (columns count characters, a tab
/// counts as one column).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Pos {
    /// Line, starting at 1.
    pub line: u32,
    /// Column, starting at 1.
    pub col: u32,
}

impl Pos {
    /// Builds a position from a 1-based line and column.
    pub const fn new(line: u32, col: u32) -> Self {
        Self { line, col }
    }
}

impl fmt::Display for Pos {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.line, self.col)
    }
}

/// The text of a scene file with its path; cheap to clone (the text is shared).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SourceFile {
    /// The path as given by the user (used in messages and to resolve relative file names).
    pub path: PathBuf,
    /// The whole text.
    pub text: Arc<str>,
}

impl SourceFile {
    /// Wraps a text read from `path`.
    pub fn new(path: impl Into<PathBuf>, text: impl Into<Arc<str>>) -> Self {
        Self {
            path: path.into(),
            text: text.into(),
        }
    }

    /// The text of the 1-based line `line` without its line terminator, if it exists.
    pub fn line(&self, line: u32) -> Option<&str> {
        let index = usize::try_from(line).ok()?.checked_sub(1)?;
        let text = self.text.split('\n').nth(index)?;
        Some(text.strip_suffix('\r').unwrap_or(text))
    }

    /// The folder that relative file names in this source resolve against.
    pub fn dir(&self) -> &Path {
        self.path.parent().unwrap_or(Path::new(""))
    }

    /// Resolves a file name written in this source against its folder (absolute names stay).
    pub fn resolve(&self, name: &str) -> PathBuf {
        self.dir().join(name)
    }

    /// An error at `pos` in this file, showing the source line with a caret.
    pub fn error(&self, pos: Pos, message: impl Into<String>) -> SceneError {
        let line = self.line(pos.line).map(str::to_owned);
        SceneError {
            path: self.path.clone(),
            pos: Some(pos),
            message: message.into(),
            source_line: line,
        }
    }
}

/// An error while reading, parsing or building a scene.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneError {
    /// The file the error is about.
    pub path: PathBuf,
    /// Where in the file, when known.
    pub pos: Option<Pos>,
    /// What went wrong.
    pub message: String,
    /// The text of the line at `pos`, rendered under the message with a caret.
    pub source_line: Option<String>,
}

impl SceneError {
    /// An error about a whole file (no position), rendered `path: message`.
    pub fn new(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        Self {
            path: path.into(),
            pos: None,
            message: message.into(),
            source_line: None,
        }
    }

    /// An error at a position whose source line is unknown, rendered `path:line:col: message`.
    /// See [`SourceFile::error`] to include the source line.
    pub fn at(path: impl Into<PathBuf>, pos: Pos, message: impl Into<String>) -> Self {
        Self {
            pos: Some(pos),
            ..Self::new(path, message)
        }
    }

    /// The error for a file that is not UTF-8: the line and column of the first invalid byte,
    /// with the valid start of its line.
    pub fn invalid_utf8(path: impl Into<PathBuf>, e: &std::string::FromUtf8Error) -> Self {
        let bytes = e.as_bytes();
        let at = e.utf8_error().valid_up_to();
        let valid = std::str::from_utf8(&bytes[..at]).unwrap_or_default();
        let line = valid.matches('\n').count() + 1;
        let line_start = valid.rfind('\n').map_or(0, |i| i + 1);
        let col = valid[line_start..].chars().count() + 1;
        Self::at(
            path,
            Pos::new(line as u32, col as u32),
            format!(
                "invalid UTF-8 (byte 0x{:02x}): scene files are UTF-8 text",
                bytes[at]
            ),
        )
        .with_source_line(valid[line_start..].trim_end_matches('\r').to_string())
    }

    /// Attaches the text of the line at the error's position.
    pub fn with_source_line(mut self, line: impl Into<String>) -> Self {
        self.source_line = Some(line.into());
        self
    }
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.path.display())?;
        let Some(pos) = self.pos else {
            return write!(f, ": {}", self.message);
        };
        write!(f, ":{pos}: {}", self.message)?;
        if let Some(line) = &self.source_line {
            // Keep the tabs before the column so that the caret lines up in any terminal.
            // A column past the end of the line (the end of the file) puts the caret just after it.
            let before = usize::try_from(pos.col.saturating_sub(1)).unwrap_or(usize::MAX);
            let pad: String = line
                .chars()
                .take(before)
                .map(|c| if c == '\t' { '\t' } else { ' ' })
                .collect();
            write!(f, "\n{line}\n{pad}^")?;
        }
        Ok(())
    }
}

impl std::error::Error for SceneError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_position_source_line_and_caret() {
        let src = SourceFile::new("dir/a.txt", "first\n\tsphere(x, identity)\r\nlast");
        let e = src.error(Pos::new(2, 9), "unknown material 'x'");
        assert_eq!(
            e.to_string(),
            "dir/a.txt:2:9: unknown material 'x'\n\tsphere(x, identity)\n\t       ^"
        );
        // A position after the end of the line (e.g. the end of the file).
        let e = src.error(Pos::new(3, 5), "expected ')' but found end of file");
        assert_eq!(
            e.to_string(),
            "dir/a.txt:3:5: expected ')' but found end of file\nlast\n    ^"
        );
    }

    #[test]
    fn renders_without_source_line_or_position() {
        let e = SceneError::at("a.txt", Pos::new(1, 2), "bad");
        assert_eq!(e.to_string(), "a.txt:1:2: bad");
        let e = SceneError::new("missing.txt", "cannot read the scene file");
        assert_eq!(e.to_string(), "missing.txt: cannot read the scene file");
        let e = SceneError::at("a.txt", Pos::new(1, 1), "bad").with_source_line("xyz");
        assert_eq!(e.to_string(), "a.txt:1:1: bad\nxyz\n^");
    }

    #[test]
    fn invalid_utf8_is_reported_at_its_byte() {
        let e = String::from_utf8(b"ab\ncd\xffe".to_vec()).unwrap_err();
        let e = SceneError::invalid_utf8("s.txt", &e);
        assert_eq!(
            e.to_string(),
            "s.txt:2:3: invalid UTF-8 (byte 0xff): scene files are UTF-8 text\ncd\n  ^"
        );
    }

    #[test]
    fn lines_and_paths() {
        let src = SourceFile::new("scenes/s.txt", "a\r\nb\n");
        assert_eq!(src.line(1), Some("a"));
        assert_eq!(src.line(2), Some("b"));
        assert_eq!(src.line(3), Some(""));
        assert_eq!(src.line(4), None);
        assert_eq!(src.line(0), None);
        assert_eq!(src.resolve("t.pfm"), Path::new("scenes/t.pfm"));
        let bare = SourceFile::new("s.txt", "");
        assert_eq!(bare.resolve("t.pfm"), Path::new("t.pfm"));
    }
}
