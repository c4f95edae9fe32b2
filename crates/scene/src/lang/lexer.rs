//! The lexer of the candela scene language: turns the text into [`Token`]s with positions.
//!
//! - Whitespace separates tokens; `#` starts a comment that runs to the end of the line.
//! - Identifiers: a letter or `_`, then letters, digits or `_`. Keywords are identifiers too:
//!   the parser recognises them by context, so that course files may use any name.
//! - Numbers: an optional sign (as in the course's lexer: `-4` is one token), digits with an
//!   optional decimal point (`2`, `2.`, `.5`, `2.5`) and an optional exponent (`1e-5`,
//!   `2.5E+3`). Numbers must fit in an `f32` (`1e999` is an error).
//! - Strings: `"…"` on one line, without escapes.
//! - Symbols: `( ) [ ] < > , * / :` and a `-` or `+` that does not start a number (the unary
//!   minus in front of a variable: `-clock`); `:` separates a wavelength from its value in
//!   `spectrum(400:0.2, …)`.

use crate::error::{Pos, SceneError, SourceFile};
use std::fmt;
use std::iter::Peekable;
use std::str::CharIndices;

/// The kind of a token, with its value.
#[derive(Clone, Debug, PartialEq)]
pub enum TokenKind {
    /// An identifier or a keyword.
    Ident(String),
    /// A number literal (finite).
    Number(f32),
    /// A string literal, without the quotes.
    Str(String),
    /// One of `( ) [ ] < > , * / : - +`.
    Symbol(char),
    /// The end of the text.
    Eof,
}

/// A token with the position of its first character.
#[derive(Clone, Debug, PartialEq)]
pub struct Token {
    /// What it is.
    pub kind: TokenKind,
    /// Where it starts.
    pub pos: Pos,
    /// Its text as written (empty at the end of the file).
    pub text: String,
}

impl Token {
    /// True when the token is the symbol `c`.
    pub fn is_symbol(&self, c: char) -> bool {
        self.kind == TokenKind::Symbol(c)
    }

    /// The identifier's name, if the token is an identifier.
    pub fn ident(&self) -> Option<&str> {
        match &self.kind {
            TokenKind::Ident(name) => Some(name),
            _ => None,
        }
    }
}

/// Describes the token in messages: `')'`, `'sky'`, `'1.5'`, `string "a.pfm"`, `end of file`.
impl fmt::Display for Token {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        const MAX: usize = 40;
        let text: String = self.text.chars().take(MAX).collect();
        let dots = if self.text.chars().nth(MAX).is_some() {
            "…"
        } else {
            ""
        };
        match self.kind {
            TokenKind::Eof => f.write_str("end of file"),
            TokenKind::Str(_) => write!(f, "string {text}{dots}"),
            _ => write!(f, "'{text}{dots}'"),
        }
    }
}

/// The symbols that form a token by themselves.
const SYMBOLS: &str = "()[]<>,*-+/:";

/// A lexer over a source text, producing tokens one at a time.
pub struct Lexer<'a> {
    source: &'a SourceFile,
    chars: Peekable<CharIndices<'a>>,
    pos: Pos,
}

impl<'a> Lexer<'a> {
    /// A lexer at the start of `source` (a leading byte-order mark is skipped).
    pub fn new(source: &'a SourceFile) -> Self {
        let mut chars = source.text.char_indices().peekable();
        chars.next_if(|&(_, c)| c == '\u{feff}');
        Self {
            source,
            chars,
            pos: Pos::new(1, 1),
        }
    }

    fn peek(&mut self) -> Option<char> {
        self.chars.peek().map(|&(_, c)| c)
    }

    /// The character after the next one.
    fn peek2(&self) -> Option<char> {
        self.chars.clone().nth(1).map(|(_, c)| c)
    }

    fn offset(&mut self) -> usize {
        self.chars
            .peek()
            .map_or(self.source.text.len(), |&(i, _)| i)
    }

    fn bump(&mut self) -> Option<char> {
        let (_, c) = self.chars.next()?;
        if c == '\n' {
            self.pos = Pos::new(self.pos.line.saturating_add(1), 1);
        } else {
            self.pos.col = self.pos.col.saturating_add(1);
        }
        Some(c)
    }

    /// Consumes characters while `f` holds.
    fn bump_while(&mut self, f: impl Fn(char) -> bool) {
        while self.peek().is_some_and(&f) {
            self.bump();
        }
    }

    fn skip_whitespace_and_comments(&mut self) {
        while let Some(c) = self.peek() {
            if c == '#' {
                self.bump_while(|c| c != '\n');
            } else if c.is_whitespace() {
                self.bump();
            } else {
                break;
            }
        }
    }

    /// The next token; [`TokenKind::Eof`] at the end (and again on every later call).
    pub fn next_token(&mut self) -> Result<Token, SceneError> {
        self.skip_whitespace_and_comments();
        let pos = self.pos;
        let start = self.offset();
        let Some(c) = self.peek() else {
            return Ok(Token {
                kind: TokenKind::Eof,
                pos,
                text: String::new(),
            });
        };
        let starts_number = |c: Option<char>| c.is_some_and(|c| c.is_ascii_digit() || c == '.');
        let kind = if c.is_alphabetic() || c == '_' {
            self.bump_while(|c| c.is_alphanumeric() || c == '_');
            TokenKind::Ident(self.source.text[start..self.offset()].to_owned())
        } else if c.is_ascii_digit()
            || (c == '.' && self.peek2().is_some_and(|c| c.is_ascii_digit()))
            || ((c == '-' || c == '+') && starts_number(self.peek2()))
        {
            self.number(pos, start)?
        } else if c == '"' {
            self.bump();
            self.bump_while(|c| c != '"' && c != '\n');
            if self.bump() != Some('"') {
                return Err(self.source.error(pos, "unterminated string"));
            }
            let end = self.offset();
            TokenKind::Str(self.source.text[start + 1..end - 1].to_owned())
        } else if SYMBOLS.contains(c) {
            self.bump();
            TokenKind::Symbol(c)
        } else {
            return Err(self.source.error(pos, format!("invalid character {c:?}")));
        };
        Ok(Token {
            kind,
            pos,
            text: self.source.text[start..self.offset()].to_owned(),
        })
    }

    /// A number starting at `start`: `[+-] digits [. digits] [(e|E) [+-] digits]`, with at least
    /// one digit before the exponent.
    fn number(&mut self, pos: Pos, start: usize) -> Result<TokenKind, SceneError> {
        if matches!(self.peek(), Some('-' | '+')) {
            self.bump();
        }
        self.bump_while(|c| c.is_ascii_digit());
        if self.peek() == Some('.') {
            self.bump();
            self.bump_while(|c| c.is_ascii_digit());
        }
        let mut valid = true;
        if matches!(self.peek(), Some('e' | 'E')) {
            self.bump();
            if matches!(self.peek(), Some('-' | '+')) {
                self.bump();
            }
            valid = self.peek().is_some_and(|c| c.is_ascii_digit());
            self.bump_while(|c| c.is_ascii_digit());
        }
        // Glued letters, digits or points (`2x`, `1.2.3`) make the whole run invalid.
        if self
            .peek()
            .is_some_and(|c| c.is_alphanumeric() || c == '_' || c == '.')
        {
            valid = false;
            self.bump_while(|c| c.is_alphanumeric() || c == '_' || c == '.');
        }
        let text = &self.source.text[start..self.offset()];
        let value: f32 = match text.parse() {
            Ok(v) if valid => v,
            _ => return Err(self.source.error(pos, format!("invalid number '{text}'"))),
        };
        if !value.is_finite() {
            return Err(self
                .source
                .error(pos, format!("number '{text}' is out of range")));
        }
        Ok(TokenKind::Number(value))
    }
}

/// Splits a whole source into tokens, ending with [`TokenKind::Eof`].
pub fn tokenize(source: &SourceFile) -> Result<Vec<Token>, SceneError> {
    let mut lexer = Lexer::new(source);
    let mut tokens = Vec::new();
    loop {
        let token = lexer.next_token()?;
        let end = token.kind == TokenKind::Eof;
        tokens.push(token);
        if end {
            return Ok(tokens);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use TokenKind::*;

    fn lex(text: &str) -> Result<Vec<(TokenKind, Pos)>, String> {
        let source = SourceFile::new("t.txt", text);
        tokenize(&source)
            .map(|v| v.into_iter().map(|t| (t.kind, t.pos)).collect())
            .map_err(|e| format!("{}: {}", e.pos.unwrap_or_default(), e.message))
    }

    fn kinds(text: &str) -> Vec<TokenKind> {
        lex(text).unwrap().into_iter().map(|(k, _)| k).collect()
    }

    fn id(s: &str) -> TokenKind {
        Ident(s.into())
    }

    #[test]
    fn course_lexer_example() {
        let text = "  # This is a comment\n  # This is another comment\n  material sky_material(\n      diffuse(image(\"my file.pfm\")),\n      <5.0, 500.0, 300.0>\n  ) # Comment at the end of the line\n";
        let tokens = lex(text).unwrap();
        let expected = [
            (id("material"), 3, 3),
            (id("sky_material"), 3, 12),
            (Symbol('('), 3, 24),
            (id("diffuse"), 4, 7),
            (Symbol('('), 4, 14),
            (id("image"), 4, 15),
            (Symbol('('), 4, 20),
            (Str("my file.pfm".into()), 4, 21),
            (Symbol(')'), 4, 34),
            (Symbol(')'), 4, 35),
            (Symbol(','), 4, 36),
            (Symbol('<'), 5, 7),
            (Number(5.0), 5, 8),
            (Symbol(','), 5, 11),
            (Number(500.0), 5, 13),
            (Symbol(','), 5, 18),
            (Number(300.0), 5, 20),
            (Symbol('>'), 5, 25),
            (Symbol(')'), 6, 3),
            (Eof, 7, 1),
        ];
        let expected: Vec<_> = expected
            .into_iter()
            .map(|(k, l, c)| (k, Pos::new(l, c)))
            .collect();
        assert_eq!(tokens, expected);
    }

    #[test]
    fn numbers() {
        let table: &[(&str, f32)] = &[
            ("0", 0.0),
            ("150", 150.0),
            ("1.0", 1.0),
            ("2.", 2.0),
            (".5", 0.5),
            ("-4", -4.0),
            ("+4", 4.0),
            ("-.25", -0.25),
            ("1e-5", 1e-5),
            ("2.5E+3", 2500.0),
            ("3e2", 300.0),
            ("1e-60", 0.0),
        ];
        for &(text, value) in table {
            assert_eq!(kinds(text), [Number(value), Eof], "{text}");
        }
    }

    #[test]
    fn signs_and_symbols() {
        assert_eq!(
            kinds("-clock*[1,-2]"),
            [
                Symbol('-'),
                id("clock"),
                Symbol('*'),
                Symbol('['),
                Number(1.0),
                Symbol(','),
                Number(-2.0),
                Symbol(']'),
                Eof
            ]
        );
        assert_eq!(kinds("- 2"), [Symbol('-'), Number(2.0), Eof]);
        assert_eq!(kinds("_a1 b_2"), [id("_a1"), id("b_2"), Eof]);
        assert_eq!(kinds("\u{feff}x"), [id("x"), Eof]);
    }

    #[test]
    fn errors_point_at_the_token() {
        let table: &[(&str, &str)] = &[
            ("x @", "1:3: invalid character '@'"),
            ("a\n  \"abc", "2:3: unterminated string"),
            ("\"ab\ncd\"", "1:1: unterminated string"),
            ("1e999", "1:1: number '1e999' is out of range"),
            ("-1e39", "1:1: number '-1e39' is out of range"),
            (" 1e", "1:2: invalid number '1e'"),
            ("1e+", "1:1: invalid number '1e+'"),
            ("2x", "1:1: invalid number '2x'"),
            ("1.2.3", "1:1: invalid number '1.2.3'"),
            ("\t.", "1:2: invalid character '.'"),
            ("=", "1:1: invalid character '='"),
        ];
        for &(text, expected) in table {
            assert_eq!(lex(text).unwrap_err(), expected, "{text:?}");
        }
    }
}
