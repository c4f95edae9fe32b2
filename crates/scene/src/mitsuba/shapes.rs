//! Shapes of Mitsuba scenes, with Mitsuba's parameterisations and normal orientations.
//!
//! - `sphere`: `center`, `radius`, then `to_world`; uv as candela's sphere (φ/2π, θ/π).
//! - `rectangle`: [-1,1]² of the plane z = 0, normal +z, uv = ((x+1)/2, (y+1)/2): a
//!   parallelogram, or two triangles when the normal must point against the edges' cross
//!   product (`flip_normals`, or a mirroring `to_world`).
//! - `disk`: the unit disk of z = 0, normal +z (`flip_normals` mirrors z).
//! - `cube`: [-1,1]³ with outward normals; Mitsuba's 12-triangle mesh (its per-face uv) when
//!   textured or flipped, candela's analytic cube otherwise.
//! - `obj`, `ply`: `filename`, `face_normals` (flat shading), `flip_normals`,
//!   `flip_tex_coords` (OBJ, default true); meshes without normals get Mitsuba's angle-weighted
//!   vertex normals unless `face_normals` is set.
//!
//! - `shapegroup` (with an `id`): shapes (any of the above, each with its own `to_world` and
//!   BSDF) built once into a shared group with its own acceleration structure; it renders
//!   nothing by itself. Emitters and nested shapegroups or instances are refused, as in
//!   Mitsuba 3.
//! - `instance`: a `<ref>` to a shapegroup and a `to_world`: the group placed again, its
//!   geometry shared (two-level ray tracing, `candela_render::instance`).
//!
//! Mitsuba normals transform by the inverse transpose of `to_world`.

use super::math::M4;
use super::xml::Element;
use super::Loader;
use crate::error::SceneError;
use candela_render::light::Emission;
use candela_render::math::{Normal3, Point2, Point3, Transform, Vec3};
use candela_render::shape::{Cube, Cylinder, Disk, Mesh, Parallelogram, Shape, Sphere};
use std::sync::Arc;

impl<'t> Loader<'t> {
    /// A `<shape>`: placed in the world, except a `shapegroup` (built, placed only by
    /// instances).
    pub(super) fn shape(&mut self, e: &'t Element) -> Result<(), SceneError> {
        match e.kind() {
            "shapegroup" => self.shape_group(e).map(|_| ()),
            "instance" => self.instance(e),
            _ => {
                let (shape, material, emission) = self.build_shape(e, false)?;
                match shape {
                    Built::Shape(s) => {
                        self.scene.add_shape(s, material, emission);
                    }
                    Built::Mesh(m) => self.add_mesh(m, material, emission),
                }
                Ok(())
            }
        }
    }

    /// A `shapegroup`'s shared geometry (built once, however many instances refer to it):
    /// its group index. Its shapes keep their own `to_world` (group space) and BSDFs; emitters
    /// and nested groups or instances are refused, as in Mitsuba 3.
    fn shape_group(&mut self, e: &'t Element) -> Result<u32, SceneError> {
        if let Some(&g) = self.groups.get(&e.key()) {
            return Ok(g);
        }
        self.enter(e)?;
        let p = self.props(e)?;
        let (mut shapes, mut meshes) = (Vec::new(), Vec::new());
        for (c, pos) in p.objects("shape") {
            if matches!(c.kind(), "shapegroup" | "instance") {
                return Err(p.error(
                    pos,
                    format!(
                        "nested instancing is not supported: a shapegroup cannot contain {}",
                        c.describe()
                    ),
                ));
            }
            match self.build_shape(c, true)? {
                (Built::Shape(s), material, _) => shapes.push((s, material)),
                (Built::Mesh(mut m), material, _) => {
                    m.props.material = material;
                    self.triangles += m.len();
                    self.mesh_bytes += crate::mesh::bytes_per_triangle(&m) * m.len() as f64;
                    meshes.push(m);
                }
            }
        }
        if shapes.is_empty() && meshes.is_empty() {
            self.warn(e.pos, "the shapegroup has no shapes");
        }
        self.finish(&p);
        let g = self
            .scene
            .add_group(shapes, meshes)
            .map_err(|err| self.err(e.pos, err.to_string()))?;
        self.leave();
        self.groups.insert(e.key(), g);
        Ok(g)
    }

    /// An `instance`: a `<ref>` to a shapegroup placed by `to_world`, sharing its geometry.
    fn instance(&mut self, e: &'t Element) -> Result<(), SceneError> {
        let p = self.props(e)?;
        if let Some((_, pos)) = p.objects("emitter").first() {
            return Err(p.error(
                *pos,
                "an instance cannot have an emitter (instanced emitters are not supported, as in Mitsuba 3)",
            ));
        }
        let targets = p.objects("shape");
        let Some(&(target, pos)) = targets.first() else {
            return Err(p.error(
                e.pos,
                "an instance needs a <ref id=\"...\"/> to a shapegroup",
            ));
        };
        if let Some((_, second)) = targets.get(1) {
            return Err(p.error(*second, "an instance refers to a single shapegroup"));
        }
        if target.kind() != "shapegroup" {
            return Err(p.error(
                pos,
                format!(
                    "an instance must refer to a shapegroup, not {}",
                    target.describe()
                ),
            ));
        }
        let group = self.shape_group(target)?;
        let (_, t) = self.to_world(&p)?;
        self.instances += 1;
        crate::loaded::check_mesh_memory(
            self.mesh_bytes + self.instances as f64 * crate::loaded::INSTANCE_BYTES,
            self.triangles,
            &self.limits,
        )
        .map_err(|msg| self.err(e.pos, msg))?;
        self.finish(&p);
        self.scene.add_instance(group, t);
        Ok(())
    }

    /// The shape of a `<shape>` element with its material and emission (`grouped`: inside a
    /// shapegroup, where emitters are refused).
    fn build_shape(
        &mut self,
        e: &'t Element,
        grouped: bool,
    ) -> Result<(Built, u32, Option<u32>), SceneError> {
        let p = self.props(e)?;
        let emitter = p.object("emitter")?;
        if let (true, Some((_, pos))) = (grouped, emitter) {
            return Err(p.error(
                pos,
                "a shapegroup cannot contain emitters (instanced emitters are not supported, as in Mitsuba 3)",
            ));
        }
        let material = match p.object("bsdf")? {
            Some((b, _)) => self.material(b)?,
            None => self.default_material(emitter.is_some()),
        };
        let mut textured = self
            .textured
            .get(material as usize)
            .copied()
            .unwrap_or(false);
        let emission = match emitter {
            Some((em, pos)) if em.kind() != "area" => {
                return Err(p.error(
                    pos,
                    format!(
                        "only area emitters can be attached to shapes, not '{}'",
                        em.kind()
                    ),
                ))
            }
            Some((em, _)) => {
                let ep = self.props(em)?;
                ep.ignore(&["sampling_weight"]);
                let radiance = self.tex(&ep, "radiance", 1.0, true, &mut textured)?;
                self.finish(&ep);
                Some(self.scene.add_emission(Emission {
                    radiance,
                    two_sided: false,
                }))
            }
            None => None,
        };
        if let Some((m, pos)) = p.objects("medium").first() {
            return Err(p.error(
                *pos,
                format!("participating media ({}) are not supported", m.describe()),
            ));
        }
        let (m, t) = self.to_world(&p)?;
        let flip = p.or("flip_normals", false)?;
        let singular = |b: &Self| {
            b.err(
                p.pos("to_world"),
                "the shape is degenerate (a scaling by zero?)",
            )
        };
        let shape = match e.kind() {
            "sphere" => {
                if flip {
                    return Err(p.error(p.pos("flip_normals"), "flip_normals on a sphere is not supported"));
                }
                let c = p.or("center", [0.0; 3])?;
                let r = p.or("radius", 1.0f64)?;
                if !(r > 0.0) {
                    return Err(p.error(p.pos("radius"), format!("the radius must be positive, not {r}")));
                }
                // Mitsuba keeps a sphere round: it decomposes to_world·translate(c)·scale(r)
                // into rotation Q and stretch S and uses S's first entry as the radius.
                let full = m.mul(&M4::translate(c)).mul(&M4::scale([r; 3]));
                let (q, st) = full.polar().ok_or_else(|| singular(self))?;
                let s = st.0;
                let round = (s[0][0] - s[1][1]).abs() < 1e-6 * s[0][0].abs() && (s[0][0] - s[2][2]).abs() < 1e-6 * s[0][0].abs();
                let sheared = [s[0][1], s[0][2], s[1][2]].iter().any(|x| x.abs() > 1e-6 * s[0][0].abs());
                if !round || sheared {
                    self.warn(p.pos("to_world"), "a sphere's to_world should not scale non-uniformly or shear: like Mitsuba, the sphere stays round");
                }
                if !(s[0][0] > 0.0) || q.det3() < 0.0 {
                    return Err(p.error(p.pos("to_world"), "a mirroring to_world on a sphere is not supported"));
                }
                let centre = full.point([0.0; 3]);
                let t = M4::translate(centre).mul(&q).mul(&M4::scale([s[0][0]; 3]));
                Built::Shape(Shape::Sphere(Sphere::new(t.to_transform().ok_or_else(|| singular(self))?)))
            }
            "rectangle" => {
                // v × w follows Mitsuba's normal T^-T·z unless the transform mirrors; a flip
                // reverses Mitsuba's normal.
                let parallelogram = t.swaps_handedness() == flip;
                let v = t.vector(Vec3::new(2.0, 0.0, 0.0));
                let w = t.vector(Vec3::new(0.0, 2.0, 0.0));
                match Parallelogram::new(t.point(Point3::new(-1.0, -1.0, 0.0)), v, w) {
                    None => return Err(singular(self)),
                    Some(pg) if parallelogram => Built::Shape(Shape::Parallelogram(pg)),
                    Some(_) => Built::Mesh(rectangle_mesh(&t, flip)),
                }
            }
            "cylinder" => {
                if flip {
                    return Err(p.error(p.pos("flip_normals"), "flip_normals on a cylinder is not supported (use a twosided BSDF to see its inside)"));
                }
                let p0 = p.or("p0", [0.0; 3])?;
                let p1 = p.or("p1", [0.0, 0.0, 1.0])?;
                let r = p.or("radius", 1.0f64)?;
                let d = [p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]];
                let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                if !(r > 0.0 && r.is_finite()) {
                    return Err(p.error(p.pos("radius"), format!("the radius must be positive, not {r}")));
                }
                if !(len > 0.0 && len.is_finite()) {
                    return Err(p.error(p.pos("p1"), "p0 and p1 must be distinct"));
                }
                // Mitsuba: to_world · translate(p0) · to_frame(d/|d|) · scale(r, r, |d|), the
                // frame being Duff et al.'s basis around the axis (it places u's origin).
                let n = [d[0] / len, d[1] / len, d[2] / len];
                let sign = 1f64.copysign(n[2]);
                let a = -1.0 / (sign + n[2]);
                let b = n[0] * n[1] * a;
                let sx = [1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]];
                let sy = [b, sign + n[1] * n[1] * a, -n[1]];
                let frame = M4::from_columns(sx, sy, n, [0.0; 3]);
                let full = m.mul(&M4::translate(p0)).mul(&frame).mul(&M4::scale([r, r, len]));
                Built::Shape(Shape::Cylinder(Cylinder::new(full.to_transform().ok_or_else(|| singular(self))?)))
            }
            "disk" => {
                let m = if flip { m.mul(&M4::scale([1.0, 1.0, -1.0])) } else { m };
                Built::Shape(Shape::Disk(Disk::new(m.to_transform().ok_or_else(|| singular(self))?)))
            }
            "cube" => {
                if flip || textured {
                    Built::Mesh(cube_mesh(&t, flip))
                } else {
                    Built::Shape(Shape::Cube(Cube::new(t)))
                }
            }
            kind @ ("obj" | "ply" | "serialized") => {
                let (name, pos) = p.get::<String>("filename")?.ok_or_else(|| p.error(e.pos, format!("{kind} needs a 'filename'")))?;
                let path = self.resolve(&name);
                let index = if kind == "serialized" { p.int_in("shape_index", 0, (0, u32::MAX as i64))? as u32 } else { 0 };
                let key = if kind == "serialized" { path.join(format!("@{index}")) } else { path.clone() };
                let loaded = match self.meshes.get(&key) {
                    Some(m) => m.clone(),
                    None => {
                        let m = if kind == "serialized" {
                            let s = crate::serialized::load_serialized(&path, index, &self.limits).map_err(|msg| self.err(pos, msg))?;
                            let mut m = s.mesh;
                            let face_normals = s.flags & crate::serialized::FACE_NORMALS != 0;
                            if face_normals {
                                m.normals.clear();
                            }
                            (m, face_normals)
                        } else {
                            (crate::mesh::load_mesh(&path, &Transform::IDENTITY, &self.limits).map_err(|msg| self.err(pos, msg))?, false)
                        };
                        let m = Arc::new(m);
                        self.inputs.push(path.clone());
                        self.meshes.insert(key, m.clone());
                        m
                    }
                };
                let (loaded, file_face_normals) = (&loaded.0, loaded.1);
                // Each placement is a copy: refused before it is made when over the limit.
                crate::loaded::check_mesh_memory(
                    self.mesh_bytes + crate::mesh::bytes_per_triangle(loaded) * loaded.len() as f64,
                    self.triangles + loaded.len(),
                    &self.limits,
                )
                .map_err(|msg| self.err(pos, msg))?;
                let mut mesh = (*loaded).clone();
                if kind == "obj" && !p.or("flip_tex_coords", true)? {
                    // candela's OBJ reader already flips v, as Mitsuba does by default.
                    for uv in &mut mesh.uvs {
                        uv.y = 1.0 - uv.y;
                    }
                }
                if p.or("face_normals", false)? || file_face_normals {
                    mesh.normals.clear();
                } else if mesh.normals.is_empty() {
                    mesh.normals = vertex_normals(&mesh);
                }
                if mesh.is_empty() {
                    self.warn(pos, format!("mesh '{name}' has no triangles"));
                }
                let mut mesh = mesh.transformed(&t);
                if flip {
                    flip_mesh(&mut mesh);
                }
                Built::Mesh(mesh)
            }
            other => {
                return Err(p.error(
                    e.pos,
                    format!("unsupported shape '{other}' (supported: sphere, rectangle, disk, cube, cylinder, obj, ply, serialized, shapegroup, instance)"),
                ))
            }
        };
        self.finish(&p);
        Ok((shape, material, emission))
    }

    /// Adds a triangle mesh with its material and emission.
    fn add_mesh(&mut self, mut mesh: Mesh, material: u32, emission: Option<u32>) {
        mesh.props.material = material;
        mesh.props.emission = emission;
        self.triangles += mesh.len();
        self.mesh_bytes += crate::mesh::bytes_per_triangle(&mesh) * mesh.len() as f64;
        self.scene.add_mesh_or_parallelograms(mesh);
    }
}

/// What a shape element becomes.
enum Built {
    /// An analytic shape.
    Shape(Shape),
    /// A triangle mesh.
    Mesh(Mesh),
}

/// Reverses a mesh's orientation (winding and vertex normals).
fn flip_mesh(m: &mut Mesh) {
    for t in &mut m.indices {
        t.swap(1, 2);
    }
    for n in &mut m.normals {
        *n = -*n;
    }
}

/// Mitsuba's rectangle as two triangles, placed by `t` (the winding keeps the normal T^-T·z).
fn rectangle_mesh(t: &Transform, flip: bool) -> Mesh {
    let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
    let mut m = Mesh {
        positions: corners
            .iter()
            .map(|&(x, y)| Point3::new(x, y, 0.0))
            .collect(),
        uvs: corners
            .iter()
            .map(|&(x, y)| Point2::new((x + 1.0) / 2.0, (y + 1.0) / 2.0))
            .collect(),
        indices: vec![[0, 1, 2], [0, 2, 3]],
        ..Mesh::default()
    }
    .transformed(t);
    if flip {
        flip_mesh(&mut m);
    }
    m
}

/// Mitsuba's cube mesh: per face (outward normal axis and sign), four corners whose uv are
/// (0,1), (1,1), (1,0), (0,0), in two triangles (0,1,2), (3,0,2); placed by `t`.
fn cube_mesh(t: &Transform, flip: bool) -> Mesh {
    const FACES: [[[i8; 3]; 4]; 6] = [
        [[1, -1, -1], [1, -1, 1], [-1, -1, 1], [-1, -1, -1]],
        [[1, 1, -1], [-1, 1, -1], [-1, 1, 1], [1, 1, 1]],
        [[1, -1, -1], [1, 1, -1], [1, 1, 1], [1, -1, 1]],
        [[1, -1, 1], [1, 1, 1], [-1, 1, 1], [-1, -1, 1]],
        [[-1, -1, 1], [-1, 1, 1], [-1, 1, -1], [-1, -1, -1]],
        [[1, 1, -1], [1, -1, -1], [-1, -1, -1], [-1, 1, -1]],
    ];
    const UV: [(f32, f32); 4] = [(0.0, 1.0), (1.0, 1.0), (1.0, 0.0), (0.0, 0.0)];
    let mut m = Mesh::default();
    for (f, corners) in FACES.iter().enumerate() {
        let base = (f * 4) as u32;
        let p: Vec<Point3> = corners
            .iter()
            .map(|c| Point3::new(c[0] as f32, c[1] as f32, c[2] as f32))
            .collect();
        let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize().to_normal();
        m.positions.extend(&p);
        m.normals.extend([n; 4]);
        m.uvs.extend(UV.iter().map(|&(u, v)| Point2::new(u, v)));
        m.indices
            .extend([[base, base + 1, base + 2], [base + 3, base, base + 2]]);
    }
    let mut m = m.transformed(t);
    if flip {
        flip_mesh(&mut m);
    }
    m
}

/// Vertex normals weighted by the angle of each incident triangle at the vertex (Thürmer and
/// Wüthrich 1998), as Mitsuba computes them for meshes that have none.
fn vertex_normals(m: &Mesh) -> Vec<Normal3> {
    let mut acc = vec![Vec3::ZERO; m.positions.len()];
    for tri in &m.indices {
        let p = tri.map(|i| m.positions[i as usize]);
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        let len = n.norm();
        if !(len > 0.0 && len.is_finite()) {
            continue;
        }
        let n = n / len;
        for k in 0..3 {
            let (a, b) = (
                (p[(k + 1) % 3] - p[k]).normalize(),
                (p[(k + 2) % 3] - p[k]).normalize(),
            );
            let angle = a.dot(b).clamp(-1.0, 1.0).acos();
            if angle.is_finite() {
                acc[tri[k] as usize] += n * angle;
            }
        }
    }
    acc.into_iter()
        .map(|v| {
            let len = v.norm();
            if len > 0.0 && len.is_finite() {
                (v / len).to_normal()
            } else {
                Normal3::new(0.0, 0.0, 1.0)
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cube_mesh_faces_point_outwards() {
        let m = cube_mesh(&Transform::IDENTITY, false);
        assert_eq!((m.positions.len(), m.indices.len()), (24, 12));
        for i in 0..12 {
            let g = m.geometry(i, 0.3, 0.3);
            // The centre of the cube is inside: the normal points away from it.
            assert!(g.n.dot_vec(g.p.to_vec()) > 0.0, "triangle {i}");
            assert!(g.ns.dot_vec(g.n.to_vec()) > 0.99);
        }
        let f = cube_mesh(&Transform::IDENTITY, true);
        let g = f.geometry(0, 0.3, 0.3);
        assert!(g.n.dot_vec(g.p.to_vec()) < 0.0);
    }

    #[test]
    fn smooth_normals_of_a_tetrahedron_corner() {
        let m = Mesh {
            positions: vec![
                Point3::ORIGIN,
                Point3::new(1.0, 0.0, 0.0),
                Point3::new(0.0, 1.0, 0.0),
                Point3::new(0.0, 0.0, 1.0),
            ],
            indices: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2]],
            ..Mesh::default()
        };
        let n = vertex_normals(&m);
        // Three faces meet at the origin at right angles: their mean is -(1,1,1)/√3.
        let s = 1.0 / 3f32.sqrt();
        assert!(
            n[0].to_vec().approx_eq(Vec3::new(-s, -s, -s), 1e-5),
            "{:?}",
            n[0]
        );
    }
}
