//! Shape expressions: primitives, named shapes and CSG operations, parsed with an explicit
//! stack so that the nesting depth is bounded.

use super::{csg_op, Args, PResult, Parser, PendingCsg, MAX_DEPTH, RESERVED_SHAPE_NAMES};
use crate::lang::ast::*;
use candela_render::math::Transform;

/// The most vertices a `polygon` may have.
pub const MAX_POLYGON_VERTICES: usize = 4096;

impl Parser<'_> {
    /// A shape expression. CSG operations are parsed with an explicit stack, not by recursion,
    /// and may nest up to [`MAX_DEPTH`] levels.
    pub(super) fn shape(&mut self) -> PResult<Shape> {
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
    pub(super) fn simple_shape(&mut self) -> PResult<ShapeKind> {
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
    pub(super) fn primitive(&mut self, word: &str) -> PResult<ShapeKind> {
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
            "cylinder" => self.args("cylinder(material, transformation)", |p, a| {
                let (material, transform) = placed(p, a)?;
                Ok(ShapeKind::Cylinder {
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
            "polygon" => self.args("polygon(material, [p1], [p2], [p3], …)", |p, a| {
                let material = p.arg(a, Self::material_ref)?;
                let mut vertices = Vec::new();
                while vertices.len() < 3 || p.more(a)? {
                    if vertices.len() >= MAX_POLYGON_VERTICES {
                        return Err(p.error(
                            p.tok.pos,
                            format!("a polygon has at most {MAX_POLYGON_VERTICES} vertices"),
                        ));
                    }
                    vertices.push(p.arg(a, |p| {
                        let pos = p.tok.pos;
                        Ok((p.point()?, pos))
                    })?);
                }
                Ok(ShapeKind::Polygon { material, vertices })
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
    pub(super) fn optional_transformation(&mut self, args: &mut Args) -> PResult<Transform> {
        if self.more(args)? {
            self.arg(args, Self::transformation)
        } else {
            Ok(Transform::IDENTITY)
        }
    }

    /// The name of a declared shape, with its index.
    pub(super) fn shape_name(&mut self) -> PResult<(String, usize)> {
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
}
