//! Mitsuba's `<include filename="…"/>`: the children of the included file's `<scene>` take the
//! place of the `<include>` element, recursively.
//!
//! File names resolve against the folder of the including file, then (as Mitsuba's file
//! resolver does) against the main scene's folder. Cycles are errors at the `<include>` that
//! closes them; nesting is limited to [`MAX_INCLUDE_DEPTH`].
//!
//! Every file keeps its own positions for messages: the elements of an included file get line
//! numbers shifted into a range of their own beyond the main file's lines (*virtual lines*), and
//! [`Sources`] maps an error or warning at a virtual line back to `included.xml:line:col`.
//! `$name` parameters: the command line's `-d` values apply in every file; a `<default>` applies
//! in the file that declares it.

use super::xml::{self, Element};
use crate::error::{Pos, SceneError, SourceFile};
use std::path::{Path, PathBuf};

/// The deepest chain of nested includes accepted (Mitsuba's limit is 15).
pub const MAX_INCLUDE_DEPTH: usize = 15;

/// The most `<include>`s expanded in one scene, each inclusion of a file counted (a file
/// included twice by each of several levels multiplies).
pub const MAX_INCLUSIONS: usize = 4096;

/// The files of one Mitsuba scene: the main file, then every included file with the first
/// virtual line before its own lines.
#[derive(Debug)]
pub(super) struct Sources {
    /// `(base, file)`: the file's line `n` is the virtual line `base + n`; the main file has
    /// base 0.
    files: Vec<(u32, SourceFile)>,
    /// The base of the next included file.
    next: u32,
}

/// Lines in `text` (a final line without a newline counts).
fn line_count(text: &str) -> u32 {
    u32::try_from(text.matches('\n').count() + 1).unwrap_or(u32::MAX)
}

impl Sources {
    /// The sources of a scene whose main file is `main`.
    pub fn new(main: &SourceFile) -> Self {
        Self {
            files: vec![(0, main.clone())],
            next: line_count(&main.text).saturating_add(1),
        }
    }

    /// Registers an included file; returns its base.
    fn add(&mut self, src: SourceFile) -> u32 {
        let base = self.next;
        self.next = base.saturating_add(line_count(&src.text)).saturating_add(1);
        self.files.push((base, src));
        base
    }

    /// The file a (possibly virtual) position is in, and the position in that file.
    pub fn locate(&self, pos: Pos) -> (&SourceFile, Pos) {
        let i = self
            .files
            .iter()
            .rposition(|(base, _)| *base < pos.line || *base == 0)
            .unwrap_or(0);
        let (base, src) = &self.files[i];
        (src, Pos::new(pos.line - base, pos.col))
    }

    /// An error made with the main file's [`SourceFile::error`] at a virtual position, moved to
    /// the included file it is in (other errors are returned unchanged).
    pub fn remap(&self, e: SceneError) -> SceneError {
        let main = &self.files[0].1;
        match e.pos {
            Some(pos) if e.path == main.path && self.files.len() > 1 => {
                let (src, p) = self.locate(pos);
                if std::ptr::eq(src, main) {
                    e
                } else {
                    SceneError {
                        message: e.message,
                        ..src.error(p, "")
                    }
                }
            }
            _ => e,
        }
    }

    /// `file:line:col` of a (possibly virtual) position.
    pub fn describe(&self, pos: Pos) -> String {
        let (src, p) = self.locate(pos);
        format!("{}:{p}", src.path.display())
    }
}

/// Moves every position of `e` down by `base` lines.
fn shift(e: &mut Element, base: u32) {
    e.pos.line = e.pos.line.saturating_add(base);
    for a in &mut e.attrs {
        a.pos.line = a.pos.line.saturating_add(base);
    }
    for c in &mut e.children {
        shift(c, base);
    }
}

/// What expanding the includes of one tree needs.
pub(super) struct Expander<'a> {
    /// The files read so far.
    pub sources: &'a mut Sources,
    /// The command line's `-d` definitions.
    pub defines: &'a [(String, String)],
    /// The command-line definitions no file has used yet.
    pub unused: Vec<String>,
    /// The limits files are read within.
    pub limits: &'a candela_imageio::Limits,
    /// Inclusions expanded so far.
    pub inclusions: usize,
    /// Bytes of included files read so far (each inclusion counted): at most
    /// `limits.max_file_bytes` in all, as for one scene file.
    pub included_bytes: u64,
}

impl Expander<'_> {
    /// Replaces every `<include>` below `e` (which belongs to the file `file`, whose chain of
    /// includers is `stack`) by the children of the included scene.
    pub fn expand(
        &mut self,
        e: &mut Element,
        file: &Path,
        stack: &mut Vec<PathBuf>,
    ) -> Result<(), SceneError> {
        if !e.children.iter().any(|c| c.tag == "include") {
            for c in &mut e.children {
                self.expand(c, file, stack)?;
            }
            return Ok(());
        }
        let children = std::mem::take(&mut e.children);
        for mut c in children {
            if c.tag != "include" {
                self.expand(&mut c, file, stack)?;
                e.children.push(c);
                continue;
            }
            let included = self.include(&c, file, stack)?;
            e.children.extend(included);
        }
        Ok(())
    }

    /// The elements `<include>` element `inc` stands for.
    fn include(
        &mut self,
        inc: &Element,
        file: &Path,
        stack: &mut Vec<PathBuf>,
    ) -> Result<Vec<Element>, SceneError> {
        let err = |s: &Sources, pos: Pos, msg: String| s.remap(s.files[0].1.error(pos, msg));
        let Some(name) = inc.attr("filename") else {
            return Err(err(
                self.sources,
                inc.pos,
                "<include> needs the attribute 'filename'".into(),
            ));
        };
        if let Some(a) = inc.attrs.iter().find(|a| a.name != "filename") {
            return Err(err(
                self.sources,
                a.pos,
                format!("<include>: unexpected attribute '{}'", a.name),
            ));
        }
        let given = Path::new(&name.value);
        let here = file.parent().unwrap_or(Path::new("")).join(given);
        let main_dir = self.sources.files[0].1.dir().join(given);
        let path = if given.is_absolute() || here.is_file() {
            here.clone()
        } else if main_dir.is_file() {
            main_dir
        } else {
            let tried = if here == main_dir {
                format!("'{}'", here.display())
            } else {
                format!("'{}' and '{}'", here.display(), main_dir.display())
            };
            return Err(err(
                self.sources,
                name.pos,
                format!("included file '{}' not found (tried {tried})", name.value),
            ));
        };
        let canonical = path.canonicalize().unwrap_or_else(|_| path.clone());
        if let Some(i) = stack.iter().position(|p| *p == canonical) {
            let chain: Vec<String> = stack[i..]
                .iter()
                .chain(std::iter::once(&canonical))
                .map(|p| {
                    p.file_name()
                        .map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into())
                })
                .collect();
            return Err(err(
                self.sources,
                name.pos,
                format!("<include> cycle: {}", chain.join(" → ")),
            ));
        }
        if stack.len() > MAX_INCLUDE_DEPTH {
            return Err(err(
                self.sources,
                inc.pos,
                format!("<include>s are nested more than {MAX_INCLUDE_DEPTH} deep"),
            ));
        }
        self.inclusions += 1;
        if self.inclusions > MAX_INCLUSIONS {
            return Err(err(
                self.sources,
                inc.pos,
                format!("more than {MAX_INCLUSIONS} <include>s are expanded (each inclusion of a file counts; see docs/limits.md)"),
            ));
        }
        crate::inputs::record(&path);
        let budget = self
            .limits
            .max_file_bytes
            .saturating_sub(self.included_bytes);
        let bytes = candela_imageio::input::read_file(&path, budget).map_err(|e| {
            err(
                self.sources,
                name.pos,
                format!(
                    "cannot read the included file '{}': {e}{}",
                    path.display(),
                    if budget < self.limits.max_file_bytes {
                        " (the included files together, each inclusion counted, may not exceed the limit)"
                    } else {
                        ""
                    }
                ),
            )
        })?;
        self.included_bytes += bytes.len() as u64;
        let text = String::from_utf8(bytes).map_err(|e| SceneError::invalid_utf8(&path, &e))?;
        let src = SourceFile::new(&path, text);
        let (mut root, unused) = xml::parse(&src, self.defines)?;
        self.unused.retain(|d| unused.contains(d));
        if root.tag != "scene" {
            return Err(src.error(
                root.pos,
                format!(
                    "the root element of an included file must be <scene>, not <{}>",
                    root.tag
                ),
            ));
        }
        let base = self.sources.add(src);
        shift(&mut root, base);
        stack.push(canonical);
        let r = self.expand(&mut root, &path, stack);
        stack.pop();
        r?;
        Ok(root.children)
    }
}
