//! The parser of the candela scene language: recursive descent, with an explicit stack for CSG.
//!
//! Keywords are contextual: the parser recognises them where a construct is expected, so a course
//! file may name a material or a variable anything. Shape names (`shape NAME(…)`) are the
//! exception: they cannot be statement or shape keywords, since a bare name is a statement.
//!
//! Transformations are evaluated while parsing; names of materials, shapes and variables are
//! checked when they are used. The parser never panics, limits the nesting of shape expressions
//! to [`MAX_DEPTH`] and reports the first error in the text.

use super::ast::*;
use super::lexer::{Lexer, Token, TokenKind};
use crate::error::{Pos, SceneError, SourceFile};
use candela_render::math::{Matrix4, Point3, Transform, Vec3};
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
    "triangle",
    "parallelogram",
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
    let text = std::fs::read_to_string(path)
        .map_err(|e| SceneError::new(path, format!("cannot read the scene file: {e}")))?;
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

    /// `[+|-] (LITERAL_NUMBER | IDENTIFIER)`.
    fn number(&mut self) -> PResult<f32> {
        let negate = self.tok.is_symbol('-');
        if negate || self.tok.is_symbol('+') {
            self.advance()?;
        }
        let value = match &self.tok.kind {
            TokenKind::Number(v) => *v,
            TokenKind::Ident(name) => match self.desc.floats.get(name) {
                Some(&v) => v,
                None => return Err(self.error(self.tok.pos, format!("unknown variable '{name}'"))),
            },
            _ => return Err(self.unexpected("a number")),
        };
        self.advance()?;
        Ok(if negate { -value } else { value })
    }

    /// A number satisfying `ok`, else the error `message` at the number.
    fn checked_number(&mut self, ok: impl Fn(f32) -> bool, message: &str) -> PResult<f32> {
        let pos = self.tok.pos;
        let value = self.number()?;
        if !ok(value) {
            return Err(self.error(pos, format!("{message} (found {value})")));
        }
        Ok(value)
    }

    /// `OPEN number , number , number CLOSE`.
    fn triple(&mut self, open: char, close: char, what: &str) -> PResult<[f32; 3]> {
        if !self.tok.is_symbol(open) {
            return Err(self.unexpected(what));
        }
        self.advance()?;
        let x = self.number()?;
        self.expect_symbol(',')?;
        let y = self.number()?;
        self.expect_symbol(',')?;
        let z = self.number()?;
        self.expect_symbol(close)?;
        Ok([x, y, z])
    }

    fn vector(&mut self) -> PResult<Vec3> {
        self.triple('[', ']', "a vector '[x, y, z]'")
            .map(Vec3::from_array)
    }

    fn point(&mut self) -> PResult<Point3> {
        self.vector().map(Vec3::to_point)
    }

    /// A vector with a positive, finite length (so that it can be normalised).
    fn direction(&mut self) -> PResult<Vec3> {
        let pos = self.tok.pos;
        let v = self.vector()?;
        let length = v.norm();
        if !(length > 0.0 && length.is_finite()) {
            return Err(self.error(pos, "a direction must have a positive, finite length"));
        }
        Ok(v)
    }

    fn color(&mut self) -> PResult<Rgb> {
        let [r, g, b] = self.triple('<', '>', "a colour '<r, g, b>'")?;
        Ok(Rgb::new(r, g, b))
    }

    /// A string literal naming a file, resolved against the scene's folder.
    fn file(&mut self) -> PResult<FileRef> {
        let TokenKind::Str(name) = &self.tok.kind else {
            return Err(self.unexpected("a file name string"));
        };
        if name.is_empty() {
            return Err(self.error(self.tok.pos, "empty file name"));
        }
        let file = FileRef {
            name: name.clone(),
            path: self.source.resolve(name),
            pos: self.tok.pos,
        };
        self.advance()?;
        Ok(file)
    }

    // ----- transformations -----

    /// `basic ( '*' basic )*`, evaluated; `A * B` applies B first.
    fn transformation(&mut self) -> PResult<Transform> {
        let pos = self.tok.pos;
        let mut t = self.basic_transformation()?;
        while self.tok.is_symbol('*') {
            self.advance()?;
            t = t * self.basic_transformation()?;
        }
        let finite = |m: &Matrix4| m.m.iter().flatten().all(|x| x.is_finite());
        if !(finite(&t.m) && finite(&t.inv)) {
            return Err(self.error(pos, "the transformation overflows (it is not finite)"));
        }
        Ok(t)
    }

    fn basic_transformation(&mut self) -> PResult<Transform> {
        let pos = self.tok.pos;
        let Some(word) = self.word() else {
            return Err(self.unexpected("a transformation"));
        };
        const NAMES: &[&str] = &[
            "identity",
            "translation",
            "scaling",
            "rotation_x",
            "rotation_y",
            "rotation_z",
            "rotation",
            "look_at",
            "matrix",
        ];
        if !NAMES.contains(&word.as_str()) {
            return Err(self.unexpected("a transformation"));
        }
        let invalid = |p: &Self, what: &str| p.error(pos, format!("invalid {word}: {what}"));
        let rotation = |p: &mut Self, syntax, f: fn(f32) -> Transform| {
            p.args(syntax, |p, a| p.arg(a, Self::number)).map(f)
        };
        self.advance()?;
        Ok(match word.as_str() {
            "translation" => self
                .args("translation([x, y, z])", |p, a| p.arg(a, Self::vector))
                .map(Transform::translation)?,
            "scaling" => {
                let v = self.args("scaling([x, y, z])", |p, a| p.arg(a, Self::vector))?;
                if v.x == 0.0 || v.y == 0.0 || v.z == 0.0 {
                    return Err(invalid(self, "a scaling factor is zero"));
                }
                Transform::scaling(v)
            }
            "rotation_x" => rotation(self, "rotation_x(degrees)", Transform::rotation_x)?,
            "rotation_y" => rotation(self, "rotation_y(degrees)", Transform::rotation_y)?,
            "rotation_z" => rotation(self, "rotation_z(degrees)", Transform::rotation_z)?,
            "rotation" => {
                let (axis, deg) = self.args("rotation([axis], degrees)", |p, a| {
                    Ok((p.arg(a, Self::vector)?, p.arg(a, Self::number)?))
                })?;
                Transform::rotation(axis, deg)
                    .ok_or_else(|| invalid(self, "the axis must have a positive, finite length"))?
            }
            "look_at" => {
                let (eye, target, up) = self.args("look_at([eye], [target], [up])", |p, a| {
                    Ok((
                        p.arg(a, Self::point)?,
                        p.arg(a, Self::point)?,
                        p.arg(a, Self::vector)?,
                    ))
                })?;
                Transform::look_at(eye, target, up).ok_or_else(|| {
                    invalid(
                        self,
                        "the eye is at the target, or up is parallel to the view direction",
                    )
                })?
            }
            "matrix" => {
                let mut m = Matrix4::IDENTITY;
                self.args("matrix(m00, m01, …, m33) with 16 numbers", |p, a| {
                    m.m.iter_mut()
                        .flatten()
                        .try_for_each(|x| p.arg(a, Self::number).map(|v| *x = v))
                })?;
                if m.m[3] != [0.0, 0.0, 0.0, 1.0] {
                    return Err(invalid(self, "the last row must be 0, 0, 0, 1"));
                }
                Transform::from_matrix(m).ok_or_else(|| invalid(self, "the matrix is singular"))?
            }
            _ => Transform::IDENTITY, // identity
        })
    }

    // ----- materials -----

    fn pigment(&mut self) -> PResult<Pigment> {
        let pos = self.tok.pos;
        let kind = if self.tok.is_symbol('<') {
            PigmentKind::Uniform(self.color()?)
        } else {
            match self.word().as_deref() {
                Some("uniform") => {
                    self.advance()?;
                    PigmentKind::Uniform(
                        self.args("uniform(<r, g, b>)", |p, a| p.arg(a, Self::color))?,
                    )
                }
                Some("checkered") => {
                    self.advance()?;
                    self.args("checkered(<r, g, b>, <r, g, b>, steps)", |p, a| {
                        Ok(PigmentKind::Checkered {
                            color1: p.arg(a, Self::color)?,
                            color2: p.arg(a, Self::color)?,
                            steps: p.arg(a, |p| {
                                p.checked_number(
                                    |n| n >= 1.0,
                                    "the number of steps must be at least 1",
                                )
                            })? as u32,
                        })
                    })?
                }
                Some("image") => {
                    self.advance()?;
                    PigmentKind::Image(self.args("image(\"file\")", |p, a| p.arg(a, Self::file))?)
                }
                _ => return Err(self.unexpected("a pigment")),
            }
        };
        Ok(Pigment { kind, pos })
    }

    fn brdf(&mut self) -> PResult<Brdf> {
        let pos = self.tok.pos;
        let word = self.word().unwrap_or_default();
        let positive = |what: &'static str| {
            move |p: &mut Self| p.checked_number(|x| x > 0.0, &format!("{what} must be positive"))
        };
        let exponent =
            |p: &mut Self| p.checked_number(|x| x >= 0.0, "the exponent must not be negative");
        let kind = match word.as_str() {
            "diffuse" | "specular" => {
                self.advance()?;
                let syntax = if word == "diffuse" {
                    "diffuse(pigment)"
                } else {
                    "specular(pigment)"
                };
                let pigment = self.args(syntax, |p, a| p.arg(a, Self::pigment))?;
                if word == "diffuse" {
                    BrdfKind::Diffuse { kd: pigment }
                } else {
                    BrdfKind::Specular { ks: pigment }
                }
            }
            "phong" | "blinn_phong" => {
                self.advance()?;
                let syntax = if word == "phong" {
                    "phong(kd, ks, exponent)"
                } else {
                    "blinn_phong(kd, ks, exponent)"
                };
                let (kd, ks, exponent) = self.args(syntax, |p, a| {
                    Ok((
                        p.arg(a, Self::pigment)?,
                        p.arg(a, Self::pigment)?,
                        p.arg(a, exponent)?,
                    ))
                })?;
                if word == "phong" {
                    BrdfKind::Phong { kd, ks, exponent }
                } else {
                    BrdfKind::BlinnPhong { kd, ks, exponent }
                }
            }
            "cook_torrance" => {
                self.advance()?;
                self.args(
                    "cook_torrance(kd, ks, roughness [, ior [, \"beckmann\"|\"ggx\"]])",
                    |p, a| {
                        let kd = p.arg(a, Self::pigment)?;
                        let ks = p.arg(a, Self::pigment)?;
                        let roughness = p.arg(a, positive("the roughness"))?;
                        let mut ior = 1.5;
                        let mut distribution = Distribution::Ggx;
                        if p.more(a)? {
                            ior = p.arg(a, positive("the index of refraction"))?;
                            if p.more(a)? {
                                distribution = p.arg(a, Self::distribution)?;
                            }
                        }
                        Ok(BrdfKind::CookTorrance {
                            kd,
                            ks,
                            roughness,
                            ior,
                            distribution,
                        })
                    },
                )?
            }
            "glass" => {
                self.advance()?;
                self.args("glass(ior [, kt])", |p, a| {
                    let ior = p.arg(a, positive("the index of refraction"))?;
                    let kt = if p.more(a)? {
                        p.arg(a, Self::pigment)?
                    } else {
                        Pigment {
                            kind: PigmentKind::Uniform(Rgb::WHITE),
                            pos,
                        }
                    };
                    Ok(BrdfKind::Glass { ior, kt })
                })?
            }
            _ => return Err(self.unexpected("a BRDF")),
        };
        Ok(Brdf { kind, pos })
    }

    fn distribution(&mut self) -> PResult<Distribution> {
        let distribution = match &self.tok.kind {
            TokenKind::Str(s) if s == "beckmann" => Distribution::Beckmann,
            TokenKind::Str(s) if s == "ggx" => Distribution::Ggx,
            _ => return Err(self.unexpected("\"beckmann\" or \"ggx\"")),
        };
        self.advance()?;
        Ok(distribution)
    }

    /// A material name that must exist.
    fn material_ref(&mut self) -> PResult<MaterialRef> {
        let Some(name) = self.word() else {
            return Err(self.unexpected("a material name"));
        };
        let Some(&index) = self.desc.material_index.get(&name) else {
            return Err(self.error(self.tok.pos, format!("unknown material '{name}'")));
        };
        let pos = self.advance()?.pos;
        Ok(MaterialRef { name, index, pos })
    }

    // ----- shapes -----

    /// A shape expression. CSG operations are parsed with an explicit stack, not by recursion,
    /// and may nest up to [`MAX_DEPTH`] levels.
    fn shape(&mut self) -> PResult<Shape> {
        let mut pending: Vec<PendingCsg> = Vec::new();
        loop {
            let pos = self.tok.pos;
            // Descend through the CSG operations to the first operand that is not one.
            if let Some((op, syntax)) = self.tok.ident().and_then(csg_op) {
                if pending.len() >= MAX_DEPTH {
                    let message =
                        format!("shapes are nested too deeply (more than {MAX_DEPTH} levels)");
                    return Err(self.error(pos, message));
                }
                self.advance()?;
                let args = self.open(syntax)?;
                pending.push(PendingCsg {
                    op,
                    pos,
                    args,
                    first: None,
                });
                continue;
            }
            let kind = self.simple_shape()?;
            let mut shape = Shape { kind, pos };
            // Climb back up, completing every operation whose second operand this was.
            loop {
                let Some(mut csg) = pending.pop() else {
                    return Ok(shape);
                };
                csg.args.need_comma = true;
                let Some(first) = csg.first.take() else {
                    csg.first = Some(shape);
                    self.separator(&mut csg.args)?;
                    pending.push(csg);
                    break;
                };
                let transform = self.optional_transformation(&mut csg.args)?;
                self.close(&csg.args)?;
                shape = Shape {
                    kind: ShapeKind::Csg {
                        op: csg.op,
                        operands: Box::new([first, shape]),
                        transform,
                    },
                    pos: csg.pos,
                };
            }
        }
    }

    /// A shape expression that is not a CSG operation.
    fn simple_shape(&mut self) -> PResult<ShapeKind> {
        let pos = self.tok.pos;
        let Some(word) = self.word() else {
            return Err(self.unexpected("a shape"));
        };
        if let Some(&index) = self.desc.shape_index.get(&word) {
            self.advance()?;
            return Ok(ShapeKind::Instance {
                name: word,
                index,
                transform: Transform::IDENTITY,
            });
        }
        if !RESERVED_SHAPE_NAMES.contains(&word.as_str()) {
            return Err(self.error(pos, format!("unknown shape '{word}'")));
        }
        self.advance()?;
        self.primitive(&word)
    }

    /// The arguments of a shape that is not CSG, after its keyword.
    fn primitive(&mut self, word: &str) -> PResult<ShapeKind> {
        let placed = |p: &mut Self, a: &mut Args| -> PResult<(MaterialRef, Transform)> {
            Ok((
                p.arg(a, Self::material_ref)?,
                p.arg(a, Self::transformation)?,
            ))
        };
        match word {
            "sphere" => self.args("sphere(material, transformation)", |p, a| {
                let (material, transform) = placed(p, a)?;
                Ok(ShapeKind::Sphere {
                    material,
                    transform,
                })
            }),
            "plane" => self.args("plane(material, transformation)", |p, a| {
                let (material, transform) = placed(p, a)?;
                Ok(ShapeKind::Plane {
                    material,
                    transform,
                })
            }),
            "box" => self.args("box(material, transformation)", |p, a| {
                let (material, transform) = placed(p, a)?;
                Ok(ShapeKind::Box {
                    material,
                    transform,
                })
            }),
            "triangle" => self.args("triangle(material, [a], [b], [c])", |p, a| {
                Ok(ShapeKind::Triangle {
                    material: p.arg(a, Self::material_ref)?,
                    vertices: [
                        p.arg(a, Self::point)?,
                        p.arg(a, Self::point)?,
                        p.arg(a, Self::point)?,
                    ],
                })
            }),
            "parallelogram" => self.args("parallelogram(material, [p], [v], [w])", |p, a| {
                Ok(ShapeKind::Parallelogram {
                    material: p.arg(a, Self::material_ref)?,
                    origin: p.arg(a, Self::point)?,
                    edge1: p.arg(a, Self::vector)?,
                    edge2: p.arg(a, Self::vector)?,
                })
            }),
            "polyhedron" => self.args(
                "polyhedron(material, transformation, [n1], d1, [n2], d2, …)",
                |p, a| {
                    let (material, transform) = placed(p, a)?;
                    let mut half_spaces = Vec::new();
                    loop {
                        let (pos, normal) = p.arg(a, |p| Ok((p.tok.pos, p.direction()?)))?;
                        let d = p.arg(a, Self::number)?;
                        half_spaces.push(HalfSpace { normal, d, pos });
                        if !p.more(a)? {
                            break;
                        }
                    }
                    Ok(ShapeKind::Polyhedron {
                        material,
                        transform,
                        half_spaces,
                    })
                },
            ),
            "mesh" => self.args("mesh(material, transformation, \"file\")", |p, a| {
                let (material, transform) = placed(p, a)?;
                let file = p.arg(a, Self::file)?;
                Ok(ShapeKind::Mesh {
                    material,
                    transform,
                    file,
                })
            }),
            "instance" => self.args("instance(name [, transformation])", |p, a| {
                let (name, index) = p.arg(a, Self::shape_name)?;
                let transform = p.optional_transformation(a)?;
                Ok(ShapeKind::Instance {
                    name,
                    index,
                    transform,
                })
            }),
            _ => Err(self.error(self.tok.pos, format!("unknown shape '{word}'"))),
        }
    }

    /// `[, transformation]` at the end of an argument list (identity when absent).
    fn optional_transformation(&mut self, args: &mut Args) -> PResult<Transform> {
        if self.more(args)? {
            self.arg(args, Self::transformation)
        } else {
            Ok(Transform::IDENTITY)
        }
    }

    /// The name of a declared shape, with its index.
    fn shape_name(&mut self) -> PResult<(String, usize)> {
        let Some(name) = self.word() else {
            return Err(self.unexpected("a shape name"));
        };
        let Some(&index) = self.desc.shape_index.get(&name) else {
            return Err(self.error(self.tok.pos, format!("unknown shape '{name}'")));
        };
        self.advance()?;
        Ok((name, index))
    }

    // ----- lights -----

    /// The optional trailing `attenuation(c1, c2, c3)` (when `attenuation` is true) and
    /// `components(<Ia>, <Id>, <Is>)` of a light, in any order, each at most once.
    fn light_options(
        &mut self,
        args: &mut Args,
        attenuation: bool,
    ) -> PResult<(Option<Attenuation>, Option<Components>)> {
        let (mut att, mut comp) = (None, None);
        while self.more(args)? {
            let pos = self.tok.pos;
            let word = self.word();
            let twice = |p: &Self, w: &str| p.error(pos, format!("'{w}' is given twice"));
            match word.as_deref() {
                Some(w @ "attenuation") if attenuation => {
                    if att.is_some() {
                        return Err(twice(self, w));
                    }
                    self.advance()?;
                    att = Some(self.arg(args, |p| {
                        p.args("attenuation(c1, c2, c3)", |p, a| {
                            let mut c = || {
                                p.arg(a, |p| {
                                    p.checked_number(
                                        |x| x >= 0.0,
                                        "an attenuation coefficient must not be negative",
                                    )
                                })
                            };
                            Ok(Attenuation {
                                constant: c()?,
                                linear: c()?,
                                quadratic: c()?,
                            })
                        })
                    })?);
                }
                Some(w @ "components") => {
                    if comp.is_some() {
                        return Err(twice(self, w));
                    }
                    self.advance()?;
                    comp = Some(self.arg(args, |p| {
                        p.args("components(<Ia>, <Id>, <Is>)", |p, a| {
                            Ok(Components {
                                ambient: p.arg(a, Self::color)?,
                                diffuse: p.arg(a, Self::color)?,
                                specular: p.arg(a, Self::color)?,
                            })
                        })
                    })?);
                }
                _ if attenuation => {
                    return Err(self.unexpected("'attenuation(…)' or 'components(…)'"))
                }
                _ => return Err(self.unexpected("'components(…)'")),
            }
        }
        Ok((att, comp))
    }

    fn light(&mut self, word: &str) -> PResult<Light> {
        let pos = self.advance()?.pos;
        let cutoff = |p: &mut Self| {
            p.checked_number(
                |x| x > 0.0 && x <= 180.0,
                "the cutoff angle must be in (0, 180] degrees",
            )
        };
        let exponent =
            |p: &mut Self| p.checked_number(|x| x >= 0.0, "the exponent must not be negative");
        let (kind, components) = match word {
            "point_light" => self.args(
                "point_light([position], <r, g, b>, radius [, attenuation(c1, c2, c3)] [, components(<Ia>, <Id>, <Is>)])",
                |p, a| {
                    let position = p.arg(a, Self::point)?;
                    let intensity = p.arg(a, Self::color)?;
                    let radius = p.arg(a, Self::number)?;
                    let (attenuation, components) = p.light_options(a, true)?;
                    let kind = LightKind::Point { position, intensity, radius, attenuation };
                    Ok((kind, components))
                },
            )?,
            "spot_light" => self.args(
                "spot_light([position], [direction], <r, g, b>, cutoff_degrees, exponent [, attenuation(c1, c2, c3)] [, components(<Ia>, <Id>, <Is>)])",
                |p, a| {
                    let position = p.arg(a, Self::point)?;
                    let direction = p.arg(a, Self::direction)?;
                    let intensity = p.arg(a, Self::color)?;
                    let cutoff_deg = p.arg(a, cutoff)?;
                    let exponent = p.arg(a, exponent)?;
                    let (attenuation, components) = p.light_options(a, true)?;
                    let kind = LightKind::Spot {
                        position,
                        direction,
                        intensity,
                        cutoff_deg,
                        exponent,
                        attenuation,
                    };
                    Ok((kind, components))
                },
            )?,
            "distant_light" => self.args(
                "distant_light([direction], <r, g, b> [, components(<Ia>, <Id>, <Is>)])",
                |p, a| {
                    let direction = p.arg(a, Self::direction)?;
                    let intensity = p.arg(a, Self::color)?;
                    let (_, components) = p.light_options(a, false)?;
                    Ok((LightKind::Distant { direction, intensity }, components))
                },
            )?,
            _ => self.args(
                "hemisphere_light(<r, g, b> [, [up]] [, components(<Ia>, <Id>, <Is>)])",
                |p, a| {
                    let intensity = p.arg(a, Self::color)?;
                    let mut up = Vec3::Z;
                    if p.more(a)? && p.tok.is_symbol('[') {
                        up = p.arg(a, Self::direction)?;
                    }
                    let (_, components) = p.light_options(a, false)?;
                    Ok((LightKind::Hemisphere { intensity, up }, components))
                },
            )?,
        };
        Ok(Light {
            kind,
            components,
            pos,
        })
    }

    // ----- statements -----

    fn scene(&mut self) -> PResult<()> {
        while self.tok.kind != TokenKind::Eof {
            let Some(word) = self.word() else {
                return Err(self.unexpected("a statement"));
            };
            match word.as_str() {
                "float" => self.float_statement()?,
                "material" => self.material_statement()?,
                "camera" => self.camera_statement()?,
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
