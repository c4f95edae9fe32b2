//! The scene description: what a candela scene file says, checked and with every
//! transformation evaluated, before anything is built for rendering.
//!
//! Every node keeps the [`Pos`] of the token that introduced it, so that the builder can report
//! later problems (a missing mesh file, a construct it does not support yet) with
//! [`SceneDescription::error`] as `file:line:col: message` plus the source line and a caret.
//!
//! What the parser guarantees:
//! - every [`MaterialRef`] and [`ShapeKind::Instance`] index is valid in this description, and an
//!   instance inside a named shape refers to an earlier named shape (no cycles);
//! - every number is finite, every transformation is finite and invertible and its last matrix
//!   row is `0 0 0 1`;
//! - directions (`spot_light`, `distant_light`, `hemisphere_light`, polyhedron normals) have a
//!   positive, finite length, so they can be normalised (they are kept as written);
//! - indices of refraction, roughness, camera aspect ratio and perspective distance are
//!   positive; exponents, attenuation coefficients are not negative; a spot cutoff is in
//!   (0°, 180°]; a checkered pigment has at least one step;
//! - an inline spectrum has 2 to [`MAX_SPECTRUM_SAMPLES`] samples with positive, strictly
//!   increasing wavelengths; a blackbody has a positive temperature and a non-negative scale,
//!   and its colour is finite; a blackbody is never a reflectance (only an emission, a light or
//!   the environment);
//! - a metal's name is one of [`metal_names`](candela_render::spectrum::metal_names), its
//!   roughness is not negative; a dispersive glass's index is positive over the visible range.

use crate::error::{Pos, SceneError, SourceFile};
use candela_render::math::{Point3, Transform, Vec3};
use candela_render::spectrum::{Ior, Spectrum};
use candela_render::Rgb;
use std::collections::HashMap;
use std::path::PathBuf;

/// A parsed scene file.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneDescription {
    /// The file the description comes from (for error messages and relative paths).
    pub source: SourceFile,
    /// The float variables with their final values: the command-line overrides, then every
    /// `float` statement (an overridden name keeps the command-line value).
    pub floats: HashMap<String, f32>,
    /// The materials in the order of their `material` statements.
    pub materials: Vec<Material>,
    /// Material name → index into [`Self::materials`].
    pub material_index: HashMap<String, usize>,
    /// The shapes declared with `shape NAME(S)`, in order (not added to the world by themselves).
    pub named_shapes: Vec<NamedShape>,
    /// Shape name → index into [`Self::named_shapes`].
    pub shape_index: HashMap<String, usize>,
    /// The shapes added to the world (every top-level shape expression), in order.
    pub shapes: Vec<Shape>,
    /// The camera, if the file has one.
    pub camera: Option<Camera>,
    /// The lights (`point_light`, `spot_light`, `distant_light`, `hemisphere_light`), in order.
    pub lights: Vec<Light>,
    /// The `ambient_light` statements, in order.
    pub ambient_lights: Vec<AmbientLight>,
    /// The `environment` statements, in order.
    pub environments: Vec<Environment>,
    /// The reconstruction filter of a `filter(…)` statement, with its position.
    pub filter: Option<(candela_render::filter::Filter, Pos)>,
}

impl SceneDescription {
    /// An empty description of `source`.
    pub fn new(source: SourceFile) -> Self {
        Self {
            source,
            floats: HashMap::new(),
            materials: Vec::new(),
            material_index: HashMap::new(),
            named_shapes: Vec::new(),
            shape_index: HashMap::new(),
            shapes: Vec::new(),
            camera: None,
            filter: None,
            lights: Vec::new(),
            ambient_lights: Vec::new(),
            environments: Vec::new(),
        }
    }

    /// The material a reference points to.
    ///
    /// # Panics
    /// If the reference does not come from this description.
    pub fn material(&self, r: &MaterialRef) -> &Material {
        &self.materials[r.index]
    }

    /// The named shape an instance points to (`index` of [`ShapeKind::Instance`]).
    ///
    /// # Panics
    /// If the index does not come from this description.
    pub fn named_shape(&self, index: usize) -> &NamedShape {
        &self.named_shapes[index]
    }

    /// An error at `pos` in the scene file, with the source line and a caret.
    pub fn error(&self, pos: Pos, message: impl Into<String>) -> SceneError {
        self.source.error(pos, message)
    }
}

/// `material NAME(brdf [, emission])`.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// The name.
    pub name: String,
    /// How the surface scatters light.
    pub brdf: Brdf,
    /// The emitted radiance (black when omitted).
    pub emission: Pigment,
    /// The position of the name.
    pub pos: Pos,
}

/// A use of a material by name.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialRef {
    /// The name as written.
    pub name: String,
    /// Index into [`SceneDescription::materials`].
    pub index: usize,
    /// The position of the name.
    pub pos: Pos,
}

/// A BRDF with its position.
#[derive(Clone, Debug, PartialEq)]
pub struct Brdf {
    /// Which model and its parameters.
    pub kind: BrdfKind,
    /// The position of the keyword.
    pub pos: Pos,
}

/// The reflection models.
#[derive(Clone, Debug, PartialEq)]
pub enum BrdfKind {
    /// `diffuse(kd)`: Lambert, kd/π.
    Diffuse {
        /// The reflectance.
        kd: Pigment,
    },
    /// `specular(ks)`: a perfect mirror scaled by ks.
    Specular {
        /// The reflectance.
        ks: Pigment,
    },
    /// `phong(kd, ks, n)`: a diffuse term plus the lobe (r·v)^n.
    Phong {
        /// The diffuse reflectance.
        kd: Pigment,
        /// The specular reflectance.
        ks: Pigment,
        /// The exponent n (≥ 0).
        exponent: f32,
    },
    /// `blinn_phong(kd, ks, n)`: a diffuse term plus the lobe (n·h)^n.
    BlinnPhong {
        /// The diffuse reflectance.
        kd: Pigment,
        /// The specular reflectance.
        ks: Pigment,
        /// The exponent n (≥ 0).
        exponent: f32,
    },
    /// `cook_torrance(kd, ks, roughness [, ior [, distribution]])`: microfacet D·F·G.
    CookTorrance {
        /// The diffuse reflectance.
        kd: Pigment,
        /// The specular reflectance.
        ks: Pigment,
        /// The roughness (> 0).
        roughness: f32,
        /// The index of refraction for the Fresnel term (> 0, default 1.5).
        ior: f32,
        /// The microfacet distribution (default GGX).
        distribution: Distribution,
    },
    /// `glass(ior [, kt])`: a smooth dielectric.
    Glass {
        /// The index of refraction (> 0); for a dispersive glass, its index at the reference
        /// wavelength 587.56 nm (the one RGB renders use).
        ior: f32,
        /// The transmittance (default white).
        kt: Pigment,
        /// The index as a function of the wavelength when it varies (`sellmeier("…")`,
        /// `cauchy(A, B)`, `spectrum(λ:n, …)`); `None` for a number (or a constant spectrum).
        dispersion: Option<Ior>,
    },
    /// `metal("name" [, roughness [, distribution]])`: a conductor with measured optical
    /// constants.
    Metal {
        /// The name, one of [`metal_names`](candela_render::spectrum::metal_names).
        name: String,
        /// The microfacet roughness α (≥ 0; 0 is a smooth mirror).
        roughness: f32,
        /// The microfacet distribution (default GGX).
        distribution: Distribution,
    },
}

/// The most samples a spectrum may have (inline or in a file).
pub const MAX_SPECTRUM_SAMPLES: usize = 100_000;

/// A spectrum written in the scene (a pigment or a light's colour).
#[derive(Clone, Debug, PartialEq)]
pub enum SpectrumDef {
    /// `spectrum(λ:v, …)` (tabulated) or `blackbody(T [, scale])`.
    Inline(Spectrum),
    /// `spectrum("file")`: a file of `λ value` lines, read when the scene is built.
    File(FileRef),
}

/// A microfacet distribution of [`BrdfKind::CookTorrance`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Distribution {
    /// `"beckmann"`.
    Beckmann,
    /// `"ggx"` (the default).
    #[default]
    Ggx,
}

/// A pigment (a colour over the surface's uv) with its position.
#[derive(Clone, Debug, PartialEq)]
pub struct Pigment {
    /// Which pigment.
    pub kind: PigmentKind,
    /// The position of the keyword (or of the `<` of a bare colour).
    pub pos: Pos,
}

/// The pigments.
#[derive(Clone, Debug, PartialEq)]
pub enum PigmentKind {
    /// `uniform(<c>)` or a bare `<c>`.
    Uniform(Rgb),
    /// `checkered(<c1>, <c2>, n)`: c1 where ⌊u·n⌋ and ⌊v·n⌋ have the same parity.
    Checkered {
        /// The first colour.
        color1: Rgb,
        /// The second colour.
        color2: Rgb,
        /// Squares per unit of u and v (≥ 1; a fractional value is truncated, as in the course).
        steps: u32,
    },
    /// `image("file")`: the nearest pixel (PFM, PNG or EXR; a lat-long map for `environment`).
    Image(FileRef),
    /// `spectrum(…)` or `blackbody(…)`: a spectrum, the same everywhere (in RGB renders its
    /// RGB conversion in the pigment's role).
    Spectrum(SpectrumDef),
}

/// A file named in the scene.
#[derive(Clone, Debug, PartialEq)]
pub struct FileRef {
    /// The name as written.
    pub name: String,
    /// The name resolved against the scene file's folder.
    pub path: PathBuf,
    /// The position of the string.
    pub pos: Pos,
}

/// `camera(perspective|orthogonal, T, aspect_ratio, distance)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// The projection.
    pub projection: Projection,
    /// The placement (the camera looks along its local +x with +z up).
    pub transform: Transform,
    /// Width / height of the screen (> 0).
    pub aspect_ratio: f32,
    /// The distance of the eye from the screen (> 0 for a perspective camera; ignored by an
    /// orthogonal one).
    pub distance: f32,
    /// The position of the keyword.
    pub pos: Pos,
}

/// The camera projections.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Projection {
    /// `perspective`.
    Perspective,
    /// `orthogonal`.
    Orthogonal,
}

/// A light statement (every kind except `ambient_light` and `environment`).
#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    /// Which light.
    pub kind: LightKind,
    /// The optional `components(<Ia>, <Id>, <Is>)` of the local model.
    pub components: Option<Components>,
    /// The spectrum when the intensity is written as `spectrum(…)` or `blackbody(…)`
    /// (point, spot and distant lights). The kind's intensity is then the spectrum's RGB
    /// emission conversion for an inline spectrum, and black for a file (the builder converts
    /// it once it has read the file).
    pub spectrum: Option<SpectrumDef>,
    /// The position of the keyword.
    pub pos: Pos,
}

impl Light {
    /// The intensity `I`.
    pub fn intensity(&self) -> Rgb {
        match self.kind {
            LightKind::Point { intensity, .. }
            | LightKind::Spot { intensity, .. }
            | LightKind::Distant { intensity, .. }
            | LightKind::Hemisphere { intensity, .. } => intensity,
        }
    }

    /// The intensities of the local model: the given components, or by default
    /// I_a = 0 and I_d = I_s = I.
    pub fn local_components(&self) -> Components {
        self.components.unwrap_or(Components {
            ambient: Rgb::BLACK,
            diffuse: self.intensity(),
            specular: self.intensity(),
        })
    }
}

/// The kinds of lights.
#[derive(Clone, Debug, PartialEq)]
pub enum LightKind {
    /// `point_light([pos], <I>, r [, attenuation(c1, c2, c3)])`.
    Point {
        /// Where it is.
        position: Point3,
        /// The intensity I.
        intensity: Rgb,
        /// The linear radius r: the contribution is scaled by (r/d)² when r > 0.
        radius: f32,
        /// The optional distance attenuation.
        attenuation: Option<Attenuation>,
    },
    /// `spot_light([pos], [dir], <I>, cutoff_deg, k [, attenuation(c1, c2, c3)])`.
    Spot {
        /// Where it is.
        position: Point3,
        /// The axis it points along (not zero, not normalised).
        direction: Vec3,
        /// The intensity I.
        intensity: Rgb,
        /// The angle between the axis and the edge of the cone, in degrees, in (0, 180].
        cutoff_deg: f32,
        /// The fall-off exponent k (≥ 0): I·(ω·s)^k inside the cone.
        exponent: f32,
        /// The optional distance attenuation.
        attenuation: Option<Attenuation>,
    },
    /// `distant_light([dir], <I>)`: parallel rays travelling along `direction`.
    Distant {
        /// The direction the light travels (not zero, not normalised).
        direction: Vec3,
        /// The intensity I.
        intensity: Rgb,
    },
    /// `hemisphere_light(<I> [, [up]])`: radiance from the hemisphere around `up`.
    Hemisphere {
        /// The radiance.
        intensity: Rgb,
        /// The pole of the hemisphere (default +z; not zero, not normalised).
        up: Vec3,
    },
}

/// `attenuation(c1, c2, c3)`: f_att = min(1 / (c1 + c2·d + c3·d²), 1); all coefficients ≥ 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Attenuation {
    /// Constant coefficient.
    pub constant: f32,
    /// Linear coefficient.
    pub linear: f32,
    /// Quadratic coefficient.
    pub quadratic: f32,
}

/// `components(<Ia>, <Id>, <Is>)`: the intensities of the lecture's general local model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Components {
    /// I_a.
    pub ambient: Rgb,
    /// I_d.
    pub diffuse: Rgb,
    /// I_s.
    pub specular: Rgb,
}

/// `ambient_light(<I>)`: I_a of the local model.
#[derive(Clone, Debug, PartialEq)]
pub struct AmbientLight {
    /// The intensity.
    pub intensity: Rgb,
    /// The position of the keyword.
    pub pos: Pos,
}

/// `environment(pigment [, T])`: radiance from every direction that misses the scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Environment {
    /// The radiance (an image is a lat-long map).
    pub pigment: Pigment,
    /// The orientation of the map (identity when omitted).
    pub transform: Transform,
    /// The position of the keyword.
    pub pos: Pos,
}

/// `shape NAME(S)`: a shape declared without being added to the world.
#[derive(Clone, Debug, PartialEq)]
pub struct NamedShape {
    /// The name.
    pub name: String,
    /// The shape.
    pub shape: Shape,
    /// The position of the name.
    pub pos: Pos,
}

/// A shape expression with its position.
#[derive(Clone, Debug, PartialEq)]
pub struct Shape {
    /// Which shape.
    pub kind: ShapeKind,
    /// The position of the keyword (or of the name of a bare named shape).
    pub pos: Pos,
}

impl Shape {
    /// The transformation applied to the shape (identity for the shapes written in world space).
    pub fn transform(&self) -> Transform {
        match &self.kind {
            ShapeKind::Sphere { transform, .. }
            | ShapeKind::Plane { transform, .. }
            | ShapeKind::Box { transform, .. }
            | ShapeKind::Cylinder { transform, .. }
            | ShapeKind::Polyhedron { transform, .. }
            | ShapeKind::Mesh { transform, .. }
            | ShapeKind::Csg { transform, .. }
            | ShapeKind::Instance { transform, .. } => *transform,
            ShapeKind::Triangle { .. }
            | ShapeKind::Parallelogram { .. }
            | ShapeKind::Polygon { .. } => Transform::IDENTITY,
        }
    }

    /// The material of a primitive shape (`None` for CSG and instances).
    pub fn material(&self) -> Option<&MaterialRef> {
        match &self.kind {
            ShapeKind::Sphere { material, .. }
            | ShapeKind::Plane { material, .. }
            | ShapeKind::Box { material, .. }
            | ShapeKind::Cylinder { material, .. }
            | ShapeKind::Triangle { material, .. }
            | ShapeKind::Parallelogram { material, .. }
            | ShapeKind::Polygon { material, .. }
            | ShapeKind::Polyhedron { material, .. }
            | ShapeKind::Mesh { material, .. } => Some(material),
            ShapeKind::Csg { .. } | ShapeKind::Instance { .. } => None,
        }
    }
}

/// The shapes.
#[derive(Clone, Debug, PartialEq)]
pub enum ShapeKind {
    /// `sphere(MAT, T)`: the unit sphere at the origin, then T.
    Sphere {
        /// The material.
        material: MaterialRef,
        /// The placement.
        transform: Transform,
    },
    /// `plane(MAT, T)`: the plane z = 0, then T.
    Plane {
        /// The material.
        material: MaterialRef,
        /// The placement.
        transform: Transform,
    },
    /// `box(MAT, T)`: the cube [-1, 1]³, then T.
    Box {
        /// The material.
        material: MaterialRef,
        /// The placement.
        transform: Transform,
    },
    /// `cylinder(MAT, T)`: the open cylinder of radius 1 around the z axis, z from 0 to 1,
    /// then T.
    Cylinder {
        /// The material.
        material: MaterialRef,
        /// The placement.
        transform: Transform,
    },
    /// `triangle(MAT, [a], [b], [c])`: vertices in world space.
    Triangle {
        /// The material.
        material: MaterialRef,
        /// The vertices a, b, c.
        vertices: [Point3; 3],
    },
    /// `parallelogram(MAT, [p], [v], [w])`: the points p + s·v + t·w with s, t in [0, 1].
    Parallelogram {
        /// The material.
        material: MaterialRef,
        /// The corner p.
        origin: Point3,
        /// The first edge v.
        edge1: Vec3,
        /// The second edge w.
        edge2: Vec3,
    },
    /// `polygon(MAT, [p1], [p2], [p3], …)`: a convex polygon, vertices in world space, in
    /// order (the builder checks that they are coplanar and convex).
    Polygon {
        /// The material.
        material: MaterialRef,
        /// The vertices (at least three), with the position of each.
        vertices: Vec<(Point3, Pos)>,
    },
    /// `polyhedron(MAT, T, [n1], d1, …)`: the convex intersection of the half-spaces
    /// n·x ≤ d, then T (the builder checks that it is bounded).
    Polyhedron {
        /// The material.
        material: MaterialRef,
        /// The placement.
        transform: Transform,
        /// At least one half-space.
        half_spaces: Vec<HalfSpace>,
    },
    /// `mesh(MAT, T, "file")`: an OBJ or PLY file.
    Mesh {
        /// The material.
        material: MaterialRef,
        /// The placement.
        transform: Transform,
        /// The file.
        file: FileRef,
    },
    /// `union|difference|intersection|fusion(S1, S2 [, T])`.
    Csg {
        /// The operation.
        op: CsgOp,
        /// The operands S1 and S2.
        operands: Box<[Shape; 2]>,
        /// The placement of the result (identity when omitted).
        transform: Transform,
    },
    /// `instance(NAME [, T])`, or a bare NAME: a declared shape, moved again by T.
    Instance {
        /// The name as written.
        name: String,
        /// Index into [`SceneDescription::named_shapes`].
        index: usize,
        /// Applied after the named shape's own transformations (identity when omitted).
        transform: Transform,
    },
}

/// A half-space `normal · x ≤ d` of a polyhedron.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HalfSpace {
    /// The outward normal (not zero, not normalised).
    pub normal: Vec3,
    /// The offset.
    pub d: f32,
    /// The position of the normal.
    pub pos: Pos,
}

/// The CSG operations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CsgOp {
    /// `union`: both shapes, with all their surfaces.
    Union,
    /// `difference`: the first shape minus the second.
    Difference,
    /// `intersection`: the common part.
    Intersection,
    /// `fusion`: a union without the interior surfaces.
    Fusion,
}
