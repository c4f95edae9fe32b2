//! Values of the scene language: numbers (with `float` variables), vectors, points,
//! directions, colours, file names and transformations (evaluated while parsing).

use super::{PResult, Parser};
use crate::lang::ast::*;
use crate::lang::lexer::TokenKind;
use candela_render::math::{Matrix4, Point3, Transform, Vec3};
use candela_render::Rgb;

impl Parser<'_> {
    /// A number: an arithmetic expression of literals, `float` variables and `pi` with
    /// `+ - * /`, parentheses and unary signs (the usual precedence, left to right); the
    /// result must be finite.
    pub(super) fn number(&mut self) -> PResult<f32> {
        let pos = self.tok.pos;
        let value = self.sum(0)?;
        if !value.is_finite() {
            return Err(self.error(
                pos,
                format!("the expression is not a finite number ({value})"),
            ));
        }
        Ok(value)
    }

    /// The current token when it is a number literal written with a sign (`-4`, `+4`): in an
    /// expression it is a binary `-`/`+` followed by the number (the lexer keeps the sign on
    /// the number, as the course's lexer does).
    fn signed_literal(&self) -> Option<f32> {
        match self.tok.kind {
            TokenKind::Number(v) if self.tok.text.starts_with(['-', '+']) => Some(v),
            _ => None,
        }
    }

    /// `product (('+' | '-') product)*`.
    fn sum(&mut self, depth: usize) -> PResult<f32> {
        let mut acc = self.product(depth)?;
        loop {
            if let Some(v) = self.signed_literal() {
                // `a -4 * b` is `a + (-4) * b`.
                self.advance()?;
                let rest = self.product_from(v, depth)?;
                acc += rest;
            } else if self.tok.is_symbol('+') || self.tok.is_symbol('-') {
                let minus = self.tok.is_symbol('-');
                self.advance()?;
                let rhs = self.product(depth)?;
                acc = if minus { acc - rhs } else { acc + rhs };
            } else {
                return Ok(acc);
            }
        }
    }

    /// `unary (('*' | '/') unary)*`.
    fn product(&mut self, depth: usize) -> PResult<f32> {
        let first = self.unary(depth)?;
        self.product_from(first, depth)
    }

    /// The rest of a product whose first factor is `acc`.
    fn product_from(&mut self, mut acc: f32, depth: usize) -> PResult<f32> {
        loop {
            if self.tok.is_symbol('*') {
                self.advance()?;
                acc *= self.unary(depth)?;
            } else if self.tok.is_symbol('/') {
                self.advance()?;
                let pos = self.tok.pos;
                let d = self.unary(depth)?;
                if d == 0.0 {
                    return Err(self.error(pos, "division by zero"));
                }
                acc /= d;
            } else {
                return Ok(acc);
            }
        }
    }

    /// `('+' | '-') unary | '(' sum ')' | LITERAL_NUMBER | IDENTIFIER | 'pi'`.
    fn unary(&mut self, depth: usize) -> PResult<f32> {
        if depth > super::MAX_DEPTH {
            return Err(self.error(self.tok.pos, "the expression is nested too deeply"));
        }
        if self.tok.is_symbol('-') || self.tok.is_symbol('+') {
            let negate = self.tok.is_symbol('-');
            self.advance()?;
            let v = self.unary(depth + 1)?;
            return Ok(if negate { -v } else { v });
        }
        if self.tok.is_symbol('(') {
            self.advance()?;
            let v = self.sum(depth + 1)?;
            self.expect_symbol(')')?;
            return Ok(v);
        }
        let value = match &self.tok.kind {
            TokenKind::Number(v) => *v,
            TokenKind::Ident(name) => match self.desc.floats.get(name) {
                Some(&v) => v,
                None if name == "pi" => std::f32::consts::PI,
                None => return Err(self.error(self.tok.pos, format!("unknown variable '{name}'"))),
            },
            _ => return Err(self.unexpected("a number")),
        };
        self.advance()?;
        Ok(value)
    }

    /// A number satisfying `ok`, else the error `message` at the number.
    pub(super) fn checked_number(
        &mut self,
        ok: impl Fn(f32) -> bool,
        message: &str,
    ) -> PResult<f32> {
        let pos = self.tok.pos;
        let value = self.number()?;
        if !ok(value) {
            return Err(self.error(pos, format!("{message} (found {value})")));
        }
        Ok(value)
    }

    /// `OPEN number , number , number CLOSE`.
    pub(super) fn triple(&mut self, open: char, close: char, what: &str) -> PResult<[f32; 3]> {
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

    pub(super) fn vector(&mut self) -> PResult<Vec3> {
        self.triple('[', ']', "a vector '[x, y, z]'")
            .map(Vec3::from_array)
    }

    pub(super) fn point(&mut self) -> PResult<Point3> {
        self.vector().map(Vec3::to_point)
    }

    /// A vector with a positive, finite length (so that it can be normalised).
    pub(super) fn direction(&mut self) -> PResult<Vec3> {
        let pos = self.tok.pos;
        let v = self.vector()?;
        let length = v.norm();
        if !(length > 0.0 && length.is_finite()) {
            return Err(self.error(pos, "a direction must have a positive, finite length"));
        }
        Ok(v)
    }

    /// `<r, g, b>`: a reflectance, a radiance or an intensity, never negative.
    pub(super) fn color(&mut self) -> PResult<Rgb> {
        let pos = self.tok.pos;
        let [r, g, b] = self.triple('<', '>', "a colour '<r, g, b>'")?;
        if r < 0.0 || g < 0.0 || b < 0.0 {
            return Err(self.error(
                pos,
                format!("a colour must not be negative (found <{r}, {g}, {b}>)"),
            ));
        }
        Ok(Rgb::new(r, g, b))
    }

    /// A string literal naming a file, resolved against the scene's folder.
    pub(super) fn file(&mut self) -> PResult<FileRef> {
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
    pub(super) fn transformation(&mut self) -> PResult<Transform> {
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

    pub(super) fn basic_transformation(&mut self) -> PResult<Transform> {
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
}
