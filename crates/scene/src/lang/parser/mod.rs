//! The parser of the candela scene language: recursive descent, with an explicit stack for CSG.
//!
//! Keywords are contextual: the parser recognises them where a construct is expected, so a course
//! file may name a material or a variable anything. Shape names (`shape NAME(…)`) are the
//! exception: they cannot be statement or shape keywords, since a bare name is a statement.
//!
//! Transformations are evaluated while parsing; names of materials, shapes and variables are
//! checked when they are used. The parser never panics, limits the nesting of shape expressions
//! to [`MAX_DEPTH`] and reports the first error in the text.

mod lights;
mod materials;
mod shapes;
mod spectra;
mod values;

use super::ast::*;
use super::lexer::{Lexer, Token, TokenKind};
use crate::error::{Pos, SceneError, SourceFile};
use candela_render::Rgb;
use std::collections::{HashMap, HashSet};
use std::path::Path;

/// The deepest nesting of shape expressions (CSG operands) the parser accepts.
pub const MAX_DEPTH: usize = 256;

/// Words that start a statement or a shape expression: they cannot name a shape.
const RESERVED_SHAPE_NAMES: &[&str] = &[
    "float",
    "material",
    "camera",
    "filter",
    "shape",
    "point_light",
    "spot_light",
    "distant_light",
    "hemisphere_light",
    "ambient_light",
    "environment",
    "sphere",
    "plane",
    "box",
    "cylinder",
    "triangle",
    "parallelogram",
    "polygon",
    "polyhedron",
    "mesh",
    "union",
    "difference",
    "intersection",
    "fusion",
    "instance",
];

/// Parses a scene from `text`; `path` names the file in messages and is the base of relative file
/// names. `overrides` are the command-line variables: they exist from the start and win over
/// `float` statements of the same name.
pub fn parse_scene(
    text: &str,
    path: &Path,
    overrides: &HashMap<String, f32>,
) -> Result<SceneDescription, SceneError> {
    let source = SourceFile::new(path, text);
    let mut parser = Parser::new(&source, overrides)?;
    parser.scene()?;
    Ok(parser.desc)
}

/// Reads and parses the scene file at `path` (see [`parse_scene`]).
pub fn parse_scene_file(
    path: &Path,
    overrides: &HashMap<String, f32>,
) -> Result<SceneDescription, SceneError> {
    let limits = candela_imageio::Limits::default();
    let bytes = candela_imageio::input::read_file(path, limits.max_file_bytes)
        .map_err(|e| SceneError::new(path, format!("cannot read the scene file: {e}")))?;
    let text = String::from_utf8(bytes).map_err(|e| SceneError::invalid_utf8(path, &e))?;
    parse_scene(&text, path, overrides)
}

/// Parses a command-line definition `NAME=VALUE` (or the course's `NAME:VALUE`).
pub fn parse_define(s: &str) -> Result<(String, f32), String> {
    let (name, value) = s
        .split_once(['=', ':'])
        .ok_or_else(|| format!("invalid definition '{s}': expected NAME=VALUE"))?;
    let (name, value) = (name.trim(), value.trim());
    let mut chars = name.chars();
    let is_ident = chars.next().is_some_and(|c| c.is_alphabetic() || c == '_')
        && chars.all(|c| c.is_alphanumeric() || c == '_');
    if !is_ident {
        return Err(format!("invalid variable name '{name}' in '{s}'"));
    }
    match value.parse::<f32>() {
        Ok(v) if v.is_finite() => Ok((name.to_owned(), v)),
        _ => Err(format!(
            "invalid value '{value}' for '{name}': expected a finite number"
        )),
    }
}

type PResult<T> = Result<T, SceneError>;

/// The CSG operation named `word`, with its syntax.
fn csg_op(word: &str) -> Option<(CsgOp, &'static str)> {
    Some(match word {
        "union" => (CsgOp::Union, "union(shape, shape [, transformation])"),
        "difference" => (
            CsgOp::Difference,
            "difference(shape, shape [, transformation])",
        ),
        "intersection" => (
            CsgOp::Intersection,
            "intersection(shape, shape [, transformation])",
        ),
        "fusion" => (CsgOp::Fusion, "fusion(shape, shape [, transformation])"),
        _ => return None,
    })
}

/// A CSG operation whose operands are being parsed.
struct PendingCsg {
    op: CsgOp,
    pos: Pos,
    args: Args,
    /// The first operand, once parsed.
    first: Option<Shape>,
}

/// The state of a parenthesised, comma-separated argument list.
struct Args {
    /// The construct's syntax, quoted in argument-count errors.
    syntax: &'static str,
    /// True after an argument: the next one must be preceded by a comma.
    need_comma: bool,
}

struct Parser<'s> {
    source: &'s SourceFile,
    lexer: Lexer<'s>,
    /// The current token (one token of lookahead).
    tok: Token,
    desc: SceneDescription,
    /// Variables set on the command line.
    overridden: HashSet<String>,
    /// Where each `float` was first defined.
    float_pos: HashMap<String, Pos>,
}

impl<'s> Parser<'s> {
    fn new(source: &'s SourceFile, overrides: &HashMap<String, f32>) -> PResult<Self> {
        let mut lexer = Lexer::new(source);
        let tok = lexer.next_token()?;
        let mut desc = SceneDescription::new(source.clone());
        desc.floats = overrides.clone();
        Ok(Self {
            source,
            lexer,
            tok,
            desc,
            overridden: overrides.keys().cloned().collect(),
            float_pos: HashMap::new(),
        })
    }

    // ----- tokens -----

    /// Moves to the next token and returns the current one.
    fn advance(&mut self) -> PResult<Token> {
        let next = self.lexer.next_token()?;
        Ok(std::mem::replace(&mut self.tok, next))
    }

    fn error(&self, pos: Pos, message: impl Into<String>) -> SceneError {
        self.source.error(pos, message)
    }

    /// `expected WHAT but found TOKEN`, at the current token.
    fn unexpected(&self, what: &str) -> SceneError {
        self.error(
            self.tok.pos,
            format!("expected {what} but found {}", self.tok),
        )
    }

    /// A wrong number of arguments, at the current token.
    fn count_error(&self, expected: char, too: &str, syntax: &str) -> SceneError {
        let found = &self.tok;
        let message = format!(
            "expected '{expected}' but found {found}: too {too} arguments, the syntax is {syntax}"
        );
        self.error(found.pos, message)
    }

    fn expect_symbol(&mut self, c: char) -> PResult<()> {
        if !self.tok.is_symbol(c) {
            return Err(self.unexpected(&format!("'{c}'")));
        }
        self.advance().map(drop)
    }

    /// The current identifier (cloned), if the current token is one.
    fn word(&self) -> Option<String> {
        self.tok.ident().map(str::to_owned)
    }

    /// An identifier with its position.
    fn name(&mut self, what: &str) -> PResult<(String, Pos)> {
        let Some(name) = self.word() else {
            return Err(self.unexpected(what));
        };
        let pos = self.advance()?.pos;
        Ok((name, pos))
    }

    // ----- argument lists -----

    /// Parses `( … )`, with `body` reading the arguments through [`Self::arg`] and
    /// [`Self::more`]; `syntax` is quoted when the number of arguments is wrong.
    fn args<T>(
        &mut self,
        syntax: &'static str,
        body: impl FnOnce(&mut Self, &mut Args) -> PResult<T>,
    ) -> PResult<T> {
        let mut args = self.open(syntax)?;
        let value = body(self, &mut args)?;
        self.close(&args)?;
        Ok(value)
    }

    /// `(`, starting an argument list.
    fn open(&mut self, syntax: &'static str) -> PResult<Args> {
        self.expect_symbol('(')?;
        Ok(Args {
            syntax,
            need_comma: false,
        })
    }

    /// `)`, ending an argument list.
    fn close(&mut self, args: &Args) -> PResult<()> {
        if self.tok.is_symbol(',') && args.need_comma {
            return Err(self.count_error(')', "many", args.syntax));
        }
        self.expect_symbol(')')
    }

    /// The comma before an argument, unless it is the first or [`Self::more`] consumed it.
    fn separator(&mut self, args: &mut Args) -> PResult<()> {
        if args.need_comma {
            if self.tok.is_symbol(')') {
                return Err(self.count_error(',', "few", args.syntax));
            }
            self.expect_symbol(',')?;
            args.need_comma = false;
        }
        Ok(())
    }

    /// One argument, after its [separator](Self::separator).
    fn arg<T>(&mut self, args: &mut Args, f: impl FnOnce(&mut Self) -> PResult<T>) -> PResult<T> {
        self.separator(args)?;
        let value = f(self)?;
        args.need_comma = true;
        Ok(value)
    }

    /// True when another (optional) argument follows; consumes its comma.
    fn more(&mut self, args: &mut Args) -> PResult<bool> {
        if args.need_comma {
            if self.tok.is_symbol(')') {
                return Ok(false);
            }
            if !self.tok.is_symbol(',') {
                return Err(self.unexpected("',' or ')'"));
            }
            self.advance()?;
            args.need_comma = false;
        }
        Ok(true)
    }

    // ----- values -----

    fn scene(&mut self) -> PResult<()> {
        while self.tok.kind != TokenKind::Eof {
            let Some(word) = self.word() else {
                return Err(self.unexpected("a statement"));
            };
            match word.as_str() {
                "float" => self.float_statement()?,
                "material" => self.material_statement()?,
                "camera" => self.camera_statement()?,
                "filter" => self.filter_statement()?,
                "shape" => self.shape_statement()?,
                "point_light" | "spot_light" | "distant_light" | "hemisphere_light" => {
                    let light = self.light(&word)?;
                    self.desc.lights.push(light);
                }
                "ambient_light" => {
                    let pos = self.advance()?.pos;
                    let intensity =
                        self.args("ambient_light(<r, g, b>)", |p, a| p.arg(a, Self::color))?;
                    self.desc
                        .ambient_lights
                        .push(AmbientLight { intensity, pos });
                }
                "environment" => {
                    let pos = self.advance()?.pos;
                    let (pigment, transform) = self
                        .args("environment(pigment [, transformation])", |p, a| {
                            Ok((p.arg(a, Self::pigment)?, p.optional_transformation(a)?))
                        })?;
                    self.desc.environments.push(Environment {
                        pigment,
                        transform,
                        pos,
                    });
                }
                w if RESERVED_SHAPE_NAMES.contains(&w) || self.desc.shape_index.contains_key(w) => {
                    let shape = self.shape()?;
                    self.desc.shapes.push(shape);
                }
                _ => return Err(self.error(self.tok.pos, format!("unknown statement '{word}'"))),
            }
        }
        Ok(())
    }

    /// `float NAME(number)`.
    fn float_statement(&mut self) -> PResult<()> {
        self.advance()?;
        let (name, pos) = self.name("a variable name")?;
        let value = self.args("float NAME(number)", |p, a| p.arg(a, Self::number))?;
        if self.overridden.contains(&name) {
            return Ok(());
        }
        if let Some(first) = self.float_pos.get(&name) {
            return Err(self.error(
                pos,
                format!("variable '{name}' cannot be redefined (first defined at {first})"),
            ));
        }
        self.float_pos.insert(name.clone(), pos);
        self.desc.floats.insert(name, value);
        Ok(())
    }

    /// `material NAME(brdf [, emission])`.
    fn material_statement(&mut self) -> PResult<()> {
        self.advance()?;
        let (name, pos) = self.name("a material name")?;
        if let Some(&index) = self.desc.material_index.get(&name) {
            let first = self.desc.materials.get(index).map_or(pos, |m| m.pos);
            return Err(self.error(
                pos,
                format!("material '{name}' is already defined (at {first})"),
            ));
        }
        let (brdf, emission) = self.args("material NAME(brdf [, emission pigment])", |p, a| {
            let brdf = p.arg(a, Self::brdf)?;
            let emission = if p.more(a)? {
                p.arg(a, Self::pigment)?
            } else {
                Pigment {
                    kind: PigmentKind::Uniform(Rgb::BLACK),
                    pos,
                }
            };
            Ok((brdf, emission))
        })?;
        let index = self.desc.materials.len();
        self.desc.material_index.insert(name.clone(), index);
        self.desc.materials.push(Material {
            name,
            brdf,
            emission,
            pos,
        });
        Ok(())
    }

    /// `camera(perspective|orthogonal, T, aspect_ratio, distance)`.
    fn camera_statement(&mut self) -> PResult<()> {
        let pos = self.tok.pos;
        if let Some(first) = &self.desc.camera {
            return Err(self.error(
                pos,
                format!(
                    "a second camera (the camera is already defined at {})",
                    first.pos
                ),
            ));
        }
        self.advance()?;
        let camera = self.args(
            "camera(perspective|orthogonal, transformation, aspect_ratio, distance)",
            |p, a| {
                let projection = p.arg(a, |p| {
                    let projection = match p.word().as_deref() {
                        Some("perspective") => Projection::Perspective,
                        Some("orthogonal") => Projection::Orthogonal,
                        _ => return Err(p.unexpected("'perspective' or 'orthogonal'")),
                    };
                    p.advance()?;
                    Ok(projection)
                })?;
                let transform = p.arg(a, Self::transformation)?;
                let aspect_ratio = p.arg(a, |p| {
                    p.checked_number(|x| x > 0.0, "the aspect ratio must be positive")
                })?;
                let distance = p.arg(a, |p| {
                    p.checked_number(
                        |x| x > 0.0 || projection == Projection::Orthogonal,
                        "the distance of a perspective camera must be positive",
                    )
                })?;
                Ok(Camera {
                    projection,
                    transform,
                    aspect_ratio,
                    distance,
                    pos,
                })
            },
        )?;
        self.desc.camera = Some(camera);
        Ok(())
    }

    /// `filter(NAME [, parameters])`: the reconstruction filter, with Mitsuba's names and
    /// defaults.
    fn filter_statement(&mut self) -> PResult<()> {
        use candela_render::filter::{Filter, FILTER_NAMES};
        let pos = self.tok.pos;
        if let Some((_, first)) = &self.desc.filter {
            return Err(self.error(
                pos,
                format!("a second filter (the filter is already defined at {first})"),
            ));
        }
        self.advance()?;
        const SYNTAX: &str = "filter(box | tent [, radius] | gaussian [, stddev] | mitchell [, B, C] | catmullrom | lanczos [, lobes])";
        let filter = self.args(SYNTAX, |p, a| {
            let (name, name_pos) = p.arg(a, |p| p.name("a filter name"))?;
            let Some(default) = Filter::by_name(&name) else {
                return Err(p.error(
                    name_pos,
                    format!(
                        "unknown filter '{name}' (expected one of: {})",
                        FILTER_NAMES.join(", ")
                    ),
                ));
            };
            let filter = match default {
                Filter::Tent { .. } if p.more(a)? => Filter::Tent {
                    radius: p.arg(a, |p| {
                        p.checked_number(
                            |x| x > 1e-3 && x <= 64.0,
                            "the radius must be in (0.001, 64]",
                        )
                    })?,
                },
                Filter::Gaussian { .. } if p.more(a)? => Filter::Gaussian {
                    stddev: p.arg(a, |p| {
                        p.checked_number(
                            |x| x > 1e-3 && x <= 16.0,
                            "the standard deviation must be in (0.001, 16]",
                        )
                    })?,
                },
                Filter::Mitchell { .. } if name == "mitchell" && p.more(a)? => {
                    let coefficient = |p: &mut Self| {
                        p.checked_number(
                            |x| (-100.0..=100.0).contains(&x),
                            "B and C must be in [-100, 100]",
                        )
                    };
                    Filter::Mitchell {
                        b: p.arg(a, coefficient)?,
                        c: p.arg(a, coefficient)?,
                    }
                }
                Filter::Lanczos { .. } if p.more(a)? => Filter::Lanczos {
                    lobes: p.arg(a, |p| {
                        p.checked_number(
                            |x| (1.0..=64.0).contains(&x) && x.fract() == 0.0,
                            "the number of lobes must be a whole number from 1 to 64",
                        )
                    })? as u32,
                },
                f => f,
            };
            Ok(filter)
        })?;
        self.desc.filter = Some((filter, pos));
        Ok(())
    }

    /// `shape NAME(S)`.
    fn shape_statement(&mut self) -> PResult<()> {
        self.advance()?;
        let (name, pos) = self.name("a shape name")?;
        if RESERVED_SHAPE_NAMES.contains(&name.as_str()) {
            return Err(self.error(
                pos,
                format!("'{name}' is a keyword and cannot name a shape"),
            ));
        }
        if let Some(&index) = self.desc.shape_index.get(&name) {
            let first = self.desc.named_shapes.get(index).map_or(pos, |s| s.pos);
            return Err(self.error(
                pos,
                format!("shape '{name}' is already defined (at {first})"),
            ));
        }
        let shape = self.args("shape NAME(shape)", |p, a| p.arg(a, Self::shape))?;
        let index = self.desc.named_shapes.len();
        self.desc.shape_index.insert(name.clone(), index);
        self.desc.named_shapes.push(NamedShape { name, shape, pos });
        Ok(())
    }
}
