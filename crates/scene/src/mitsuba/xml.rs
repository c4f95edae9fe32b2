//! The XML layer of the Mitsuba importer: the document as a tree of elements with their
//! positions, `$name` parameters substituted in document order (property values are read by
//! [`super::props`]).

use crate::error::{Pos, SceneError, SourceFile};

/// Deepest element nesting accepted (real scenes need a handful of levels).
pub const MAX_DEPTH: usize = 128;
/// Longest attribute value after `$name` substitution, in bytes (defaults that refer to each
/// other could otherwise grow exponentially).
pub const MAX_EXPANDED: usize = 1 << 16;
/// Most XML nodes (elements, text, comments) in a file.
pub const MAX_NODES: u32 = 1 << 22;

/// An XML element after parameter substitution.
#[derive(Debug)]
pub(super) struct Element {
    /// The tag name.
    pub tag: String,
    /// Where the element starts (its `<`).
    pub pos: Pos,
    /// The attributes, in order.
    pub attrs: Vec<Attr>,
    /// The child elements, in order.
    pub children: Vec<Element>,
}

/// An attribute with its substituted value.
#[derive(Debug)]
pub(super) struct Attr {
    /// The attribute's name.
    pub name: String,
    /// The value after `$name` substitution.
    pub value: String,
    /// Where the value starts.
    pub pos: Pos,
}

impl Element {
    /// The attribute `name`, if present.
    pub fn attr(&self, name: &str) -> Option<&Attr> {
        self.attrs.iter().find(|a| a.name == name)
    }

    /// The value of the attribute `name`, if present.
    pub fn get(&self, name: &str) -> Option<&str> {
        self.attr(name).map(|a| a.value.as_str())
    }

    /// The `type` attribute (empty when missing).
    pub fn kind(&self) -> &str {
        self.get("type").unwrap_or("")
    }

    /// `<tag type="kind">`, to name the element in messages.
    pub fn describe(&self) -> String {
        match self.get("type") {
            Some(t) => format!("<{} type=\"{t}\">", self.tag),
            None => format!("<{}>", self.tag),
        }
    }

    /// A stable key for caches (the element's address; the tree outlives every cache).
    pub fn key(&self) -> usize {
        self as *const Element as usize
    }
}

/// Byte offsets → 1-based line and column (columns count characters).
struct LineIndex<'a> {
    text: &'a str,
    starts: Vec<usize>,
    /// The last position asked for (byte, column): columns further along its line are counted
    /// from there, so that the positions of a document in order take linear time even when it
    /// is all on one line.
    last: std::cell::Cell<(usize, usize)>,
}

impl<'a> LineIndex<'a> {
    fn new(text: &'a str) -> Self {
        let starts = std::iter::once(0)
            .chain(text.match_indices('\n').map(|(i, _)| i + 1))
            .collect();
        Self {
            text,
            starts,
            last: std::cell::Cell::new((0, 1)),
        }
    }

    fn pos(&self, byte: usize) -> Pos {
        let byte = byte.min(self.text.len());
        let line = self.starts.partition_point(|&s| s <= byte).max(1);
        let start = self.starts[line - 1];
        let count = |from: usize| self.text.get(from..byte).map(|s| s.chars().count());
        let col = match self.last.get() {
            (b, c) if (start..=byte).contains(&b) => count(b).map(|n| c + n),
            _ => None,
        }
        .or_else(|| count(start).map(|n| n + 1))
        .unwrap_or(1);
        self.last.set((byte, col));
        Pos::new(line as u32, col as u32)
    }
}

/// A `$name` parameter: from the command line or a `<default>`.
struct Param {
    name: String,
    value: String,
    from_cli: bool,
    used: bool,
}

/// Parses `src` into a tree of elements, substituting parameters in document order.
/// Returns the root element and the command-line parameters the scene never used.
pub(super) fn parse(
    src: &SourceFile,
    defines: &[(String, String)],
) -> Result<(Element, Vec<String>), SceneError> {
    let text: &str = &src.text;
    let opts = roxmltree::ParsingOptions {
        allow_dtd: false,
        nodes_limit: MAX_NODES,
        ..roxmltree::ParsingOptions::default()
    };
    let doc = roxmltree::Document::parse_with_options(text, opts).map_err(|e| {
        let lines = LineIndex::new(text);
        let p = match e {
            // Errors about the end of the file are reported there, not at 1:1.
            roxmltree::Error::UnexpectedEndOfStream
            | roxmltree::Error::UnclosedRootNode
            | roxmltree::Error::NoRootNode => lines.pos(text.len()),
            roxmltree::Error::DtdDetected => lines.pos(text.find("<!DOCTYPE").unwrap_or(0)),
            _ => {
                let p = e.pos();
                Pos::new(p.row, p.col)
            }
        };
        if matches!(e, roxmltree::Error::NodesLimitReached) {
            return src.error(
                p,
                format!("the file has more than {MAX_NODES} XML nodes (see docs/limits.md)"),
            );
        }
        let msg = e.to_string();
        // roxmltree ends its messages with " at line:col"; the position is shown anyway.
        let msg = msg.rsplit_once(" at ").map_or(msg.as_str(), |(m, _)| m);
        src.error(p, format!("malformed XML: {msg}"))
    })?;
    let mut params: Vec<Param> = defines
        .iter()
        .map(|(n, v)| Param {
            name: n.clone(),
            value: v.clone(),
            from_cli: true,
            used: false,
        })
        .collect();
    let mut p = Parser {
        src,
        lines: LineIndex::new(text),
        params: &mut params,
    };
    let root = p.element(doc.root_element(), 0)?;
    let unused = params
        .iter()
        .filter(|p| p.from_cli && !p.used)
        .map(|p| format!("{}={}", p.name, p.value))
        .collect();
    Ok((root, unused))
}

struct Parser<'a> {
    src: &'a SourceFile,
    lines: LineIndex<'a>,
    params: &'a mut Vec<Param>,
}

impl Parser<'_> {
    fn element(&mut self, node: roxmltree::Node, depth: usize) -> Result<Element, SceneError> {
        let pos = self.lines.pos(node.range().start);
        if depth > MAX_DEPTH {
            return Err(self.src.error(pos, "elements are nested too deeply"));
        }
        let mut attrs = Vec::new();
        for a in node.attributes() {
            let range = a.range_value();
            // Positions inside the value are exact when it holds no XML escapes.
            let raw = self.src.text.get(range.clone()) == Some(a.value());
            let value = self.substitute(a.value(), range.start, raw)?;
            attrs.push(Attr {
                name: a.name().to_string(),
                value,
                pos: self.lines.pos(range.start),
            });
        }
        let mut e = Element {
            tag: node.tag_name().name().to_string(),
            pos,
            attrs,
            children: Vec::new(),
        };
        if e.tag == "default" {
            let (Some(name), Some(value)) = (e.get("name"), e.get("value")) else {
                return Err(self
                    .src
                    .error(pos, "<default> needs the attributes 'name' and 'value'"));
            };
            if name.is_empty() {
                return Err(self.src.error(pos, "<default>: the name is empty"));
            }
            if !self.params.iter().any(|p| p.name == name) {
                self.params.push(Param {
                    name: name.to_string(),
                    value: value.to_string(),
                    from_cli: false,
                    used: false,
                });
            }
        }
        for child in node.children().filter(|c| c.is_element()) {
            e.children.push(self.element(child, depth + 1)?);
        }
        Ok(e)
    }

    /// Replaces every `$name` by its value (the longest defined name wins, as in Mitsuba);
    /// `\$` stands for a literal dollar sign.
    fn substitute(&mut self, value: &str, start: usize, raw: bool) -> Result<String, SceneError> {
        if !value.contains('$') {
            return Ok(value.to_string());
        }
        let mut out = String::with_capacity(value.len());
        let mut rest = value;
        let mut offset = 0;
        while let Some(i) = rest.find('$') {
            if rest[..i].ends_with('\\') {
                out.push_str(&rest[..i - 1]);
                out.push('$');
            } else {
                out.push_str(&rest[..i]);
                let after = &rest[i + 1..];
                let best = self
                    .params
                    .iter_mut()
                    .filter(|p| after.starts_with(p.name.as_str()))
                    .max_by_key(|p| p.name.len());
                match best {
                    Some(p) => {
                        p.used = true;
                        if out.len() + p.value.len() > MAX_EXPANDED {
                            let name = p.name.clone();
                            return Err(self.src.error(
                                self.lines.pos(start),
                                format!("the value grows to more than {MAX_EXPANDED} bytes when ${name} is substituted (defaults that refer to each other?); see docs/limits.md"),
                            ));
                        }
                        out.push_str(&p.value);
                        let n = p.name.len();
                        rest = &after[n..];
                        offset += i + 1 + n;
                        continue;
                    }
                    None => {
                        let name: String = after
                            .chars()
                            .take_while(|c| c.is_alphanumeric() || *c == '_')
                            .collect();
                        let at = if raw { start + offset + i } else { start };
                        return Err(self.src.error(
                            self.lines.pos(at),
                            format!("undefined parameter ${name} (define it with <default name=\"{name}\" value=\"…\"/> or -d {name}=…)"),
                        ));
                    }
                }
            }
            rest = &rest[i + 1..];
            offset += i + 1;
        }
        out.push_str(rest);
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positions_count_characters() {
        let l = LineIndex::new("ab\n\tcé\nx");
        assert_eq!(l.pos(0), Pos::new(1, 1));
        assert_eq!(l.pos(3), Pos::new(2, 1));
        assert_eq!(l.pos(7), Pos::new(2, 4));
        assert_eq!(l.pos(8), Pos::new(3, 1));
        assert_eq!(l.pos(100), Pos::new(3, 2));
        // Out of order, and on the line counted last.
        assert_eq!(l.pos(4), Pos::new(2, 2));
        assert_eq!(l.pos(5), Pos::new(2, 3));
        assert_eq!(l.pos(7), Pos::new(2, 4));
        assert_eq!(l.pos(3), Pos::new(2, 1));
    }

    #[test]
    fn positions_on_one_long_line_take_linear_time() {
        let text = "<a/>".repeat(200_000);
        let l = LineIndex::new(&text);
        let start = std::time::Instant::now();
        for i in 0..200_000 {
            assert_eq!(l.pos(4 * i), Pos::new(1, 4 * i as u32 + 1));
        }
        assert!(start.elapsed().as_secs_f64() < 1.0, "{:?}", start.elapsed());
    }
}
