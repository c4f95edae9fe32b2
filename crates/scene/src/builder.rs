//! Builds a render scene from a scene description of the candela language, validating what the
//! parser could not (files, singular transformations, unbounded polyhedra, CSG operands), each
//! error at its source position.
//!
//! Spectra become [`Texture::Spectral`] textures (and the `spectrum` of point, spot and distant
//! lights) whose RGB colour is [`Spectrum::to_rgb`] in the role of the place they are used:
//! [`RgbRole::Reflectance`] for the pigments of BRDFs, [`RgbRole::Emission`] for emissions,
//! lights and the environment, [`RgbRole::OpticalConstant`] for a metal's measured η and k.

use crate::error::{Pos, SceneError};
use crate::lang::ast::{
    self, BrdfKind, LightKind, PigmentKind, SceneDescription, ShapeKind, SpectrumDef,
    MAX_SPECTRUM_SAMPLES,
};
use crate::loaded::{check_mesh_memory, INSTANCE_BYTES, MAX_CSG_SOLIDS, MAX_SHAPES};
use candela_imageio::Limits;
use candela_render::accel::AccelKind;
use candela_render::camera::Camera;
use candela_render::light::Emission;
use candela_render::light::{
    Components, DistantLight, Environment, Falloff, HemisphereLight, Light, PointLight, SpotLight,
    SpotProfile,
};
use candela_render::material::{
    Dispersion, Distribution, Lobe, Material, MaterialId, Microfacet, Model,
};
use candela_render::math::{Transform, Vec3};
use candela_render::scene::SceneBuilder;
use candela_render::shape::{
    Csg, CsgError, CsgNode, CsgOp, Cube, Cylinder, Mesh, Parallelogram, Plane, Polygon,
    PolygonError, Polyhedron, Shape, Solid, Sphere,
};
use candela_render::spectrum::{metal, RgbRole, Spectrum};
use candela_render::texture::{ImageTexture, Texture};
use candela_render::{Rgb, Scene};
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;

/// What the builder reports besides the scene.
#[derive(Clone, Debug, Default)]
pub struct BuildReport {
    /// Warnings with their positions, ready to print.
    pub warnings: Vec<String>,
    /// Triangles in meshes.
    pub triangles: usize,
    /// Bytes per mesh triangle (attributes, indices, primitive record), when there are meshes.
    pub bytes_per_triangle: Option<f64>,
    /// Positions of `ambient_light`s and `components(…)`: terms of the local model only.
    pub local_model_terms: Vec<String>,
    /// The files read (meshes, images and spectra).
    pub inputs: Vec<PathBuf>,
}

/// Builds the render scene of `desc` with the acceleration structure `accel`.
pub fn build_scene(
    desc: &SceneDescription,
    accel: AccelKind,
    limits: &Limits,
) -> Result<(Scene, BuildReport), SceneError> {
    let mut b = Builder {
        desc,
        limits: *limits,
        shapes: 0,
        scene: SceneBuilder::new(),
        materials: Vec::new(),
        images: HashMap::new(),
        spectra: HashMap::new(),
        meshes: HashMap::new(),
        groups: HashMap::new(),
        csg_trees: HashMap::new(),
        instances: 0,
        report: BuildReport::default(),
        mesh_bytes: 0.0,
    };
    b.materials()?;
    b.camera();
    b.lights()?;
    for shape in &desc.shapes {
        b.add_shape(shape, &Transform::IDENTITY, 0)?;
    }
    if b.report.triangles > 0 {
        b.report.bytes_per_triangle = Some(b.mesh_bytes / b.report.triangles as f64);
    }
    Ok((b.scene.build(accel), b.report))
}

struct Builder<'a> {
    desc: &'a SceneDescription,
    limits: Limits,
    /// Shapes placed so far (copies counted).
    shapes: usize,
    scene: SceneBuilder,
    /// Material index of the description → render material and emission.
    materials: Vec<(MaterialId, Option<u32>)>,
    images: HashMap<PathBuf, Arc<candela_render::Image>>,
    /// Spectrum files read so far.
    spectra: HashMap<PathBuf, Arc<Spectrum>>,
    meshes: HashMap<PathBuf, Arc<Mesh>>,
    /// Shared groups of meshes placed through instances: (file, material) → group.
    groups: HashMap<(PathBuf, MaterialId), u32>,
    /// The CSG trees of named shapes used in CSG trees (or placed), built once and shared by
    /// every use: named shape index → tree in the named shape's own coordinates.
    csg_trees: HashMap<usize, Arc<Csg>>,
    /// Instances of those groups placed so far.
    instances: usize,
    report: BuildReport,
    mesh_bytes: f64,
}

/// Deepest nesting of instances (a shape may not contain itself, but chains can be long).
const MAX_NESTING: u32 = 256;

impl Builder<'_> {
    fn err(&self, pos: Pos, msg: impl Into<String>) -> SceneError {
        self.desc.error(pos, msg)
    }

    /// The spectrum `def` names (reading a file the first time it is named), with its colour
    /// in `role`; `pos` is where it is written.
    fn spectrum(
        &mut self,
        def: &SpectrumDef,
        role: RgbRole,
        pos: Pos,
    ) -> Result<(Arc<Spectrum>, Rgb), SceneError> {
        let spectrum = match def {
            SpectrumDef::Inline(s) => Arc::new(s.clone()),
            SpectrumDef::File(file) => self.spectrum_file(file)?,
        };
        let rgb = spectrum.to_rgb(role);
        if !rgb.is_finite() {
            return Err(self.err(
                pos,
                "the spectrum's values are too large (its colour is not finite)",
            ));
        }
        Ok((spectrum, rgb))
    }

    /// The spectrum file `file` names: `λ value` lines (`#` comments), checked like an inline
    /// spectrum.
    fn spectrum_file(&mut self, file: &ast::FileRef) -> Result<Arc<Spectrum>, SceneError> {
        let path = self.locate(file, "spectrum")?;
        if let Some(s) = self.spectra.get(&path) {
            return Ok(s.clone());
        }
        let name = &file.name;
        let bytes = candela_imageio::input::read_file(&path, self.limits.max_file_bytes)
            .map_err(|e| self.err(file.pos, format!("cannot read spectrum '{name}': {e}")))?;
        crate::inputs::record(&path);
        self.report.inputs.push(path.clone());
        let text = String::from_utf8(bytes)
            .map_err(|_| self.err(file.pos, format!("spectrum '{name}' is not UTF-8 text")))?;
        let spectrum = Spectrum::parse_spd(&text).map_err(|e| {
            let at = e.line.map(|l| format!(" (line {l})")).unwrap_or_default();
            self.err(file.pos, format!("spectrum '{name}'{at}: {}", e.message))
        })?;
        if let Spectrum::Tabulated(t) = &spectrum {
            let samples = t.samples();
            if samples.len() > MAX_SPECTRUM_SAMPLES {
                return Err(self.err(
                    file.pos,
                    format!("spectrum '{name}' has more than {MAX_SPECTRUM_SAMPLES} samples"),
                ));
            }
            if let Some(&(l, v)) = samples.iter().find(|(l, v)| !(*l > 0.0 && *v >= 0.0)) {
                return Err(self.err(
                    file.pos,
                    format!("spectrum '{name}': the sample {l}:{v} is not a positive wavelength with a non-negative value"),
                ));
            }
        }
        let spectrum = Arc::new(spectrum);
        self.spectra.insert(path, spectrum.clone());
        Ok(spectrum)
    }

    /// The texture of the pigment `p` (spectra converted to RGB in `role`).
    fn texture(&mut self, p: &ast::Pigment, role: RgbRole) -> Result<Texture, SceneError> {
        Ok(match &p.kind {
            PigmentKind::Spectrum(def) => {
                let (spectrum, rgb) = self.spectrum(def, role, p.pos)?;
                Texture::Spectral { rgb, spectrum }
            }
            PigmentKind::Uniform(c) => Texture::Uniform(*c),
            PigmentKind::Checkered {
                color1,
                color2,
                steps,
            } => Texture::Checkered {
                c1: *color1,
                c2: *color2,
                steps: [*steps as f32; 2],
                offset: [0.0; 2],
            },
            PigmentKind::Image(file) => {
                let path = self.locate(file, "image")?;
                let image = match self.images.get(&path) {
                    Some(i) => i.clone(),
                    None => {
                        let img = candela_imageio::read_image_within(&path, &self.limits).map_err(
                            |e| {
                                self.err(
                                    file.pos,
                                    format!("cannot load image '{}': {e}", file.name),
                                )
                            },
                        )?;
                        self.report.inputs.push(path.clone());
                        crate::inputs::record(&path);
                        let mut img = img;
                        let clamped = crate::loaded::clamp_texels(&mut img);
                        if clamped > 0 {
                            self.report.warnings.push(format!(
                                "{}:{}: image '{}': {clamped} texels negative or not finite, clamped to 0",
                                self.desc.source.path.display(),
                                file.pos,
                                file.name
                            ));
                        }
                        let img = Arc::new(img);
                        self.images.insert(path, img.clone());
                        img
                    }
                };
                if image.width() == 0 || image.height() == 0 {
                    return Err(self.err(file.pos, format!("image '{}' is empty", file.name)));
                }
                Texture::Image(ImageTexture::new(image))
            }
        })
    }

    fn materials(&mut self) -> Result<(), SceneError> {
        for m in &self.desc.materials {
            let model = match &m.brdf.kind {
                BrdfKind::Diffuse { kd } => Model::Diffuse {
                    reflectance: self.texture(kd, RgbRole::Reflectance)?,
                },
                BrdfKind::Specular { ks } => Model::Specular {
                    reflectance: self.texture(ks, RgbRole::Reflectance)?,
                },
                BrdfKind::Phong { kd, ks, exponent }
                | BrdfKind::BlinnPhong { kd, ks, exponent } => Model::Phong {
                    lobe: if matches!(m.brdf.kind, BrdfKind::Phong { .. }) {
                        Lobe::Phong
                    } else {
                        Lobe::BlinnPhong
                    },
                    kd: self.texture(kd, RgbRole::Reflectance)?,
                    ks: self.texture(ks, RgbRole::Reflectance)?,
                    n: exponent.max(0.0),
                },
                BrdfKind::CookTorrance {
                    kd,
                    ks,
                    roughness,
                    ior,
                    distribution,
                } => Model::CookTorrance {
                    kd: self.texture(kd, RgbRole::Reflectance)?,
                    ks: self.texture(ks, RgbRole::Reflectance)?,
                    mf: Microfacet::new((*distribution).into(), *roughness),
                    ior: *ior,
                },
                BrdfKind::Glass {
                    ior,
                    kt,
                    dispersion,
                } => {
                    if !(*ior > 0.0) {
                        return Err(self.err(
                            m.brdf.pos,
                            format!("the index of refraction must be positive, not {ior}"),
                        ));
                    }
                    Model::Dielectric {
                        eta: *ior,
                        dispersion: dispersion.as_ref().map(|interior| {
                            Box::new(Dispersion {
                                interior: interior.clone(),
                                exterior: 1.0,
                            })
                        }),
                        reflectance: Texture::Uniform(Rgb::WHITE),
                        transmittance: self.texture(kt, RgbRole::Reflectance)?,
                        mf: None,
                    }
                }
                BrdfKind::Metal {
                    name,
                    roughness,
                    distribution,
                } => {
                    let (eta, k) = metal(name)
                        .ok_or_else(|| self.err(m.brdf.pos, format!("unknown metal '{name}'")))?;
                    let measured = |s: Spectrum| {
                        let rgb = s.to_rgb(RgbRole::OpticalConstant);
                        Texture::spectrum(s, rgb)
                    };
                    Model::Conductor {
                        eta_k: Some((measured(eta), measured(k))),
                        reflectance: Texture::Uniform(Rgb::WHITE),
                        mf: (*roughness > 0.0)
                            .then(|| Microfacet::new((*distribution).into(), *roughness)),
                    }
                }
            };
            let id = self.scene.add_material(Material::two_sided(model));
            let emission = match &m.emission.kind {
                PigmentKind::Uniform(c) if c.is_black() => None,
                _ => {
                    let radiance = self.texture(&m.emission, RgbRole::Emission)?;
                    Some(self.scene.add_emission(Emission {
                        radiance,
                        two_sided: true,
                    }))
                }
            };
            self.materials.push((id, emission));
        }
        Ok(())
    }

    fn camera(&mut self) {
        match &self.desc.camera {
            Some(c) => {
                let cam = match c.projection {
                    ast::Projection::Perspective => {
                        Camera::perspective(c.distance, c.aspect_ratio, c.transform)
                    }
                    ast::Projection::Orthogonal => Camera::orthogonal(c.aspect_ratio, c.transform),
                };
                self.scene.camera(cam);
            }
            None => self.report.warnings.push(format!(
                "{}: no camera: using a perspective camera at the origin looking along +x",
                self.desc.source.path.display()
            )),
        }
    }

    fn lights(&mut self) -> Result<(), SceneError> {
        let desc = self.desc;
        let here = |pos: Pos| format!("{}:{pos}", desc.source.path.display());
        for l in &self.desc.lights {
            if l.components.is_some() {
                self.report
                    .local_model_terms
                    .push(format!("{}: components(…)", here(l.pos)));
            }
            // A spectrum's colour (for RGB renders and the local model's default components).
            let (intensity, spectrum) = match &l.spectrum {
                Some(def) => {
                    let (s, rgb) = self.spectrum(def, RgbRole::Emission, l.pos)?;
                    (rgb, Some(s))
                }
                None => (l.intensity(), None),
            };
            let c = l.components.unwrap_or(ast::Components {
                ambient: Rgb::BLACK,
                diffuse: intensity,
                specular: intensity,
            });
            let components = Components {
                ambient: c.ambient,
                diffuse: c.diffuse,
                specular: c.specular,
            };
            let unit = |v: Vec3, what: &str| -> Result<Vec3, SceneError> {
                let n = v.norm();
                if n > 0.0 && n.is_finite() {
                    Ok(v / n)
                } else {
                    Err(self
                        .desc
                        .error(l.pos, format!("the {what} must not be the zero vector")))
                }
            };
            let att = |a: &Option<ast::Attenuation>| a.map(|a| [a.constant, a.linear, a.quadratic]);
            let light = match &l.kind {
                LightKind::Point {
                    position,
                    radius,
                    attenuation,
                    ..
                } => Light::Point(
                    PointLight {
                        position: *position,
                        intensity,
                        spectrum,
                        falloff: Falloff {
                            radius: *radius,
                            attenuation: att(attenuation),
                        },
                    },
                    components,
                ),
                LightKind::Spot {
                    position,
                    direction,
                    cutoff_deg,
                    exponent,
                    attenuation,
                    ..
                } => Light::Spot(
                    SpotLight {
                        position: *position,
                        axis: unit(*direction, "spot direction")?,
                        intensity,
                        spectrum,
                        cos_cutoff: cutoff_deg.to_radians().cos(),
                        profile: SpotProfile::Power(*exponent),
                        falloff: Falloff {
                            radius: 0.0,
                            attenuation: att(attenuation),
                        },
                        pattern: None,
                    },
                    components,
                ),
                LightKind::Distant { direction, .. } => Light::Distant(
                    DistantLight {
                        direction: unit(*direction, "light direction")?,
                        irradiance: intensity,
                        spectrum,
                    },
                    components,
                ),
                LightKind::Hemisphere { up, .. } => Light::Hemisphere(
                    HemisphereLight {
                        radiance: intensity,
                        up: unit(*up, "up direction")?,
                    },
                    components,
                ),
            };
            self.scene.add_light(light);
        }
        for a in &self.desc.ambient_lights {
            self.report
                .local_model_terms
                .push(format!("{}: ambient_light", here(a.pos)));
            self.scene.add_ambient(a.intensity);
        }
        for e in &self.desc.environments {
            let tex = self.texture(&e.pigment, RgbRole::Emission)?;
            let t = self.check_transform(&e.transform, e.pos)?;
            self.scene
                .add_light(Light::Environment(Environment::new(tex, t)));
        }
        Ok(())
    }

    fn check_transform(&self, t: &Transform, pos: Pos) -> Result<Transform, SceneError> {
        let finite =
            t.m.m
                .iter()
                .flatten()
                .chain(t.inv.m.iter().flatten())
                .all(|x| x.is_finite());
        if finite
            && t.is_consistent(
                1e-3 * (1.0 + t.m.m.iter().flatten().fold(0f32, |a, x| a.max(x.abs()))),
            )
        {
            Ok(*t)
        } else {
            Err(self.err(pos, "the transformation is singular (a scaling by zero?)"))
        }
    }

    /// Where the file `file` names is: beside the scene file, or else (for a relative name)
    /// in the current directory, as the course's program looks for it; an error naming both
    /// places when it is in neither.
    fn locate(&self, file: &ast::FileRef, what: &str) -> Result<PathBuf, SceneError> {
        let here = std::path::Path::new(&file.name);
        if file.path.exists() || here.is_absolute() {
            return Ok(file.path.clone());
        }
        if here.exists() {
            return Ok(here.to_path_buf());
        }
        let cwd = std::env::current_dir()
            .map(|d| d.join(here))
            .unwrap_or_else(|_| here.to_path_buf());
        if self.desc.source.path == std::path::Path::new(crate::loaded::STDIN_NAME) {
            // A scene from standard input has no folder of its own.
            return Err(self.err(
                file.pos,
                format!(
                    "{what} file '{}' not found in the current directory ('{}')",
                    file.name,
                    cwd.display()
                ),
            ));
        }
        Err(self.err(
            file.pos,
            format!(
                "{what} file '{}' not found: tried '{}' (beside the scene file) and '{}' (the current directory)",
                file.name,
                file.path.display(),
                cwd.display()
            ),
        ))
    }

    fn mesh(&mut self, file: &ast::FileRef) -> Result<Arc<Mesh>, SceneError> {
        let path = self.locate(file, "mesh")?;
        if let Some(m) = self.meshes.get(&path) {
            return Ok(m.clone());
        }
        let m = crate::mesh::load_mesh(&path, &Transform::IDENTITY, &self.limits)
            .map_err(|e| self.err(file.pos, e))?;
        self.report.inputs.push(path.clone());
        if m.is_empty() {
            self.report.warnings.push(format!(
                "{}:{}: mesh '{}' has no triangles",
                self.desc.source.path.display(),
                file.pos,
                file.name
            ));
        }
        let m = Arc::new(m);
        self.meshes.insert(path, m.clone());
        Ok(m)
    }

    fn props(&self, m: &ast::MaterialRef) -> (MaterialId, Option<u32>) {
        self.materials[m.index]
    }

    /// Adds `shape`, moved by `extra` (the placements of enclosing instances), to the world.
    fn add_shape(
        &mut self,
        shape: &ast::Shape,
        extra: &Transform,
        depth: u32,
    ) -> Result<(), SceneError> {
        if depth > MAX_NESTING {
            return Err(self.err(shape.pos, "shapes are nested too deeply"));
        }
        if !matches!(shape.kind, ShapeKind::Instance { .. }) {
            self.count_shape(shape.pos)?;
        }
        let place = |b: &Self, t: &Transform| b.check_transform(&(*extra * *t), shape.pos);
        match &shape.kind {
            ShapeKind::Sphere {
                material,
                transform,
            } => {
                let (m, e) = self.props(material);
                let t = place(self, transform)?;
                self.scene.add_shape(Shape::Sphere(Sphere::new(t)), m, e);
            }
            ShapeKind::Plane {
                material,
                transform,
            } => {
                let (m, e) = self.props(material);
                let t = place(self, transform)?;
                self.scene.add_shape(Shape::Plane(Plane::new(t)), m, e);
            }
            ShapeKind::Cylinder {
                material,
                transform,
            } => {
                let (m, e) = self.props(material);
                let t = place(self, transform)?;
                self.scene
                    .add_shape(Shape::Cylinder(Cylinder::new(t)), m, e);
            }
            ShapeKind::Box {
                material,
                transform,
            } => {
                let (m, e) = self.props(material);
                let t = place(self, transform)?;
                self.scene.add_shape(Shape::Cube(Cube::new(t)), m, e);
            }
            ShapeKind::Triangle { material, vertices } => {
                let (m, e) = self.props(material);
                let mut mesh = Mesh {
                    positions: vertices.iter().map(|v| extra.point(*v)).collect(),
                    indices: vec![[0, 1, 2]],
                    ..Default::default()
                };
                let [a, b, c] = [mesh.positions[0], mesh.positions[1], mesh.positions[2]];
                if !((b - a).cross(c - a).norm() > 0.0) {
                    return Err(self.err(
                        shape.pos,
                        "the triangle is degenerate (its vertices are aligned)",
                    ));
                }
                mesh.props.material = m;
                mesh.props.emission = e;
                self.add_mesh(mesh, shape.pos)?;
            }
            ShapeKind::Polygon { material, vertices } => {
                let (m, e) = self.props(material);
                let points: Vec<_> = vertices.iter().map(|(v, _)| extra.point(*v)).collect();
                let polygon = Polygon::new(&points).map_err(|err| {
                    let pos = match err {
                        PolygonError::NotCoplanar(i) | PolygonError::NotConvex(i) => {
                            vertices.get(i).map_or(shape.pos, |v| v.1)
                        }
                        _ => shape.pos,
                    };
                    self.err(pos, format!("polygon: {err}"))
                })?;
                self.scene.add_shape(Shape::Polygon(polygon), m, e);
            }
            ShapeKind::Parallelogram {
                material,
                origin,
                edge1,
                edge2,
            } => {
                let (m, e) = self.props(material);
                let p = Parallelogram::new(
                    extra.point(*origin),
                    extra.vector(*edge1),
                    extra.vector(*edge2),
                )
                .ok_or_else(|| {
                    self.err(
                        shape.pos,
                        "the parallelogram is degenerate (its edges are parallel or zero)",
                    )
                })?;
                self.scene.add_shape(Shape::Parallelogram(p), m, e);
            }
            ShapeKind::Polyhedron { material, .. } => {
                let (m, e) = self.props(material);
                let p = self.polyhedron(shape, extra)?;
                self.scene.add_shape(Shape::Polyhedron(p), m, e);
            }
            ShapeKind::Mesh {
                material,
                transform,
                file,
            } => {
                let (m, e) = self.props(material);
                let t = place(self, transform)?;
                let source = self.mesh(file)?;
                if depth > 0 && e.is_none() {
                    // Reached through instance(…): the file's mesh is shared by every placement
                    // with this material (two-level ray tracing), not copied.
                    return self.add_mesh_instance(&source, file, m, t, shape.pos);
                }
                self.count_mesh(&source, shape.pos)?;
                let mut mesh = source.transformed(&t);
                mesh.props.material = m;
                mesh.props.emission = e;
                self.add_mesh(mesh, shape.pos)?;
            }
            ShapeKind::Csg { .. } => {
                let mut nodes = Vec::new();
                self.csg(shape, extra, &mut nodes, depth)?;
                let csg = self.csg_tree(nodes, shape.pos)?;
                self.scene.add_shape(Shape::Csg(Box::new(csg)), 0, None);
            }
            ShapeKind::Instance {
                index, transform, ..
            } => {
                let named = &self.desc.named_shape(*index).shape;
                if matches!(named.kind, ShapeKind::Csg { .. }) {
                    // A named CSG shape placed in the world: a reference to its shared tree.
                    self.count_shape(shape.pos)?;
                    let mut nodes = Vec::new();
                    self.csg(shape, extra, &mut nodes, depth)?;
                    let csg = self.csg_tree(nodes, shape.pos)?;
                    self.scene.add_shape(Shape::Csg(Box::new(csg)), 0, None);
                    return Ok(());
                }
                let t = place(self, transform)?;
                self.add_shape(named, &t, depth + 1)?;
            }
        }
        Ok(())
    }

    /// Counts one more shape placed in the world (at `pos`), failing beyond the limit.
    fn count_shape(&mut self, pos: Pos) -> Result<(), SceneError> {
        self.shapes += 1;
        if self.shapes > MAX_SHAPES {
            return Err(self.err(
                pos,
                format!("the scene places more than {MAX_SHAPES} shapes (every copy of an instance counted; see docs/limits.md)"),
            ));
        }
        Ok(())
    }

    /// Places the mesh `source` (from `file`) with material `material` by `t` as an instance of
    /// a shared group, made on its first placement.
    fn add_mesh_instance(
        &mut self,
        source: &Mesh,
        file: &ast::FileRef,
        material: MaterialId,
        t: Transform,
        pos: Pos,
    ) -> Result<(), SceneError> {
        let key = (self.locate(file, "mesh")?, material);
        let group = match self.groups.get(&key) {
            Some(&g) => g,
            None => {
                self.count_mesh(source, pos)?;
                let mut mesh = source.clone();
                mesh.props.material = material;
                self.report.triangles += mesh.len();
                self.mesh_bytes += crate::mesh::bytes_per_triangle(&mesh) * mesh.len() as f64;
                let g = self
                    .scene
                    .add_group(Vec::new(), vec![mesh])
                    .map_err(|e| self.err(pos, e.to_string()))?;
                self.groups.insert(key, g);
                g
            }
        };
        self.instances += 1;
        check_mesh_memory(
            self.mesh_bytes + self.instances as f64 * INSTANCE_BYTES,
            self.report.triangles,
            &self.limits,
        )
        .map_err(|e| self.err(pos, e))?;
        self.scene.add_instance(group, t);
        Ok(())
    }

    /// Fails before `mesh` is copied once more when the copy would exceed the memory limit.
    fn count_mesh(&self, mesh: &Mesh, pos: Pos) -> Result<(), SceneError> {
        let bytes = crate::mesh::bytes_per_triangle(mesh) * mesh.len() as f64;
        check_mesh_memory(
            self.mesh_bytes + bytes + self.instances as f64 * INSTANCE_BYTES,
            self.report.triangles + mesh.len(),
            &self.limits,
        )
        .map_err(|e| self.err(pos, e))
    }

    fn add_mesh(&mut self, mesh: Mesh, pos: Pos) -> Result<(), SceneError> {
        self.count_mesh(&mesh, pos)?;
        self.report.triangles += mesh.len();
        self.mesh_bytes += crate::mesh::bytes_per_triangle(&mesh) * mesh.len() as f64;
        self.scene.add_mesh_or_parallelograms(mesh);
        Ok(())
    }

    fn polyhedron(&self, shape: &ast::Shape, extra: &Transform) -> Result<Polyhedron, SceneError> {
        let ShapeKind::Polyhedron {
            transform,
            half_spaces,
            ..
        } = &shape.kind
        else {
            unreachable!("called on polyhedra only")
        };
        let t = self.check_transform(&(*extra * *transform), shape.pos)?;
        let hs: Vec<(Vec3, f32)> = half_spaces.iter().map(|h| (h.normal, h.d)).collect();
        Polyhedron::new(t, &hs).map_err(|e| match e {
            candela_render::shape::PolyhedronError::BadNormal(i) => {
                self.err(half_spaces[i].pos, e.to_string())
            }
            _ => self.err(shape.pos, e.to_string()),
        })
    }

    /// The CSG tree of the named shape `index` in its own coordinates, built on its first use
    /// (at nesting depth `depth`) and shared by all.
    fn shared_csg(&mut self, index: usize, depth: u32) -> Result<Arc<Csg>, SceneError> {
        if let Some(tree) = self.csg_trees.get(&index) {
            return Ok(tree.clone());
        }
        let named = &self.desc.named_shape(index).shape;
        let mut nodes = Vec::new();
        self.csg(named, &Transform::IDENTITY, &mut nodes, depth)?;
        let tree = Arc::new(self.csg_tree(nodes, named.pos)?);
        self.csg_trees.insert(index, tree.clone());
        Ok(tree)
    }

    /// The CSG tree of `nodes` (written at `pos`), within the limits on its expanded size.
    fn csg_tree(&self, nodes: Vec<CsgNode>, pos: Pos) -> Result<Csg, SceneError> {
        let too_large = |n: u64| {
            self.err(
                pos,
                format!("the CSG tree expands to {n} solids, more than {MAX_CSG_SOLIDS} (every use of a named shape counted: a ray may have to test each; see docs/limits.md)"),
            )
        };
        let csg = Csg::new(nodes).map_err(|e| match e {
            CsgError::TooLarge(n) => too_large(n),
            CsgError::Invalid => self.err(pos, "invalid CSG tree"),
        })?;
        if csg.leaves() as usize > MAX_CSG_SOLIDS {
            return Err(too_large(csg.leaves() as u64));
        }
        if csg.depth() > MAX_NESTING {
            return Err(self.err(pos, "shapes are nested too deeply"));
        }
        Ok(csg)
    }

    /// Appends the CSG nodes of `shape` (operands first) and returns the index of its root.
    /// A named shape used as an operand is a [`CsgNode::Shared`] reference to its tree, built
    /// once (spheres and boxes, as small as a reference, are copied).
    fn csg(
        &mut self,
        shape: &ast::Shape,
        extra: &Transform,
        nodes: &mut Vec<CsgNode>,
        depth: u32,
    ) -> Result<u32, SceneError> {
        if depth > MAX_NESTING {
            return Err(self.err(shape.pos, "shapes are nested too deeply"));
        }
        let leaf = |solid: Solid, m: &ast::MaterialRef, b: &Self, nodes: &mut Vec<CsgNode>| {
            let (material, emission) = b.props(m);
            nodes.push(CsgNode::Leaf {
                solid,
                props: candela_render::interaction::SurfaceProps {
                    material,
                    emission,
                    light: None,
                },
            });
            Ok((nodes.len() - 1) as u32)
        };
        match &shape.kind {
            ShapeKind::Sphere { material, transform } => {
                let t = self.check_transform(&(*extra * *transform), shape.pos)?;
                leaf(Solid::Sphere(Sphere::new(t)), material, self, nodes)
            }
            ShapeKind::Box { material, transform } => {
                let t = self.check_transform(&(*extra * *transform), shape.pos)?;
                leaf(Solid::Cube(Cube::new(t)), material, self, nodes)
            }
            ShapeKind::Polyhedron { material, .. } => {
                let p = self.polyhedron(shape, extra)?;
                leaf(Solid::Polyhedron(p), material, self, nodes)
            }
            ShapeKind::Mesh { material, transform, file } => {
                let t = self.check_transform(&(*extra * *transform), shape.pos)?;
                let source = self.mesh(file)?;
                self.count_mesh(&source, shape.pos)?;
                let m = source.transformed(&t);
                self.report.triangles += m.len();
                self.mesh_bytes += crate::mesh::bytes_per_triangle(&m) * m.len() as f64;
                leaf(Solid::Mesh(m), material, self, nodes)
            }
            ShapeKind::Csg { op, operands, transform } => {
                let t = self.check_transform(&(*extra * *transform), shape.pos)?;
                let a = self.csg(&operands[0], &t, nodes, depth + 1)?;
                let b = self.csg(&operands[1], &t, nodes, depth + 1)?;
                nodes.push(CsgNode::Op {
                    op: match op {
                        ast::CsgOp::Union => CsgOp::Union,
                        ast::CsgOp::Difference => CsgOp::Difference,
                        ast::CsgOp::Intersection => CsgOp::Intersection,
                        ast::CsgOp::Fusion => CsgOp::Fusion,
                    },
                    a,
                    b,
                });
                Ok((nodes.len() - 1) as u32)
            }
            ShapeKind::Instance { index, transform, .. } => {
                let t = self.check_transform(&(*extra * *transform), shape.pos)?;
                let named = &self.desc.named_shape(*index).shape;
                if matches!(named.kind, ShapeKind::Sphere { .. } | ShapeKind::Box { .. }) {
                    // As small as a reference: copied.
                    return self.csg(named, &t, nodes, depth + 1);
                }
                let tree = self.shared_csg(*index, depth + 1)?;
                if depth + 1 + tree.depth() > MAX_NESTING {
                    return Err(self.err(shape.pos, "shapes are nested too deeply"));
                }
                nodes.push(CsgNode::Shared { tree, placement: t });
                Ok((nodes.len() - 1) as u32)
            }
            ShapeKind::Plane { .. } | ShapeKind::Triangle { .. } | ShapeKind::Parallelogram { .. } | ShapeKind::Polygon { .. } | ShapeKind::Cylinder { .. } => Err(self.err(
                shape.pos,
                "CSG operands must be solids (sphere, box, polyhedron, closed mesh or CSG); planes, triangles, parallelograms, polygons and (open) cylinders enclose no volume",
            )),
        }
    }
}

impl From<ast::Distribution> for Distribution {
    fn from(d: ast::Distribution) -> Self {
        match d {
            ast::Distribution::Beckmann => Distribution::Beckmann,
            ast::Distribution::Ggx => Distribution::Ggx,
        }
    }
}
