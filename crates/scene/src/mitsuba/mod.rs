//! Mitsuba 3 XML import (`.xml`), with Mitsuba's semantics so that the same file gives the same
//! image within noise.
//!
//! The document is read in two passes. [`xml`] turns it into a tree of elements with their
//! positions, substituting `$name` parameters in document order (`<default>`s, overridden by
//! `-d NAME=VALUE`) and parsing every property value; then the loader walks the `<scene>`,
//! resolving `<ref id>`s (to any id of the file) and building candela's scene:
//!
//! - sensors `perspective` (`fov`/`focal_length`, `fov_axis`; Mitsuba's camera frame: +z forward,
//!   +y up, +x to the left of the image), `thinlens` (depth of field), `orthographic`; film
//!   `hdrfilm` (`width`, `height`), any sampler (`sample_count`);
//! - shapes `sphere`, `rectangle`, `disk`, `cube`, `obj`, `ply` with `to_world`, `flip_normals`,
//!   `face_normals`, a BSDF (Mitsuba's default: one-sided diffuse 0.5) and an `area` emitter
//!   (one-sided, on the side of the normal);
//! - BSDFs `diffuse`, `conductor`, `roughconductor`, `dielectric`, `roughdielectric`, `plastic`,
//!   `roughplastic` (all one-sided) and `twosided`; textures `bitmap` and `checkerboard`;
//! - emitters `point`, `spot`, `directional`, `constant`, `envmap`;
//! - integrators `path` and its equivalents without media (`volpath`, …) and `direct` (the path
//!   tracer limited to depth 2), which become [`RenderHints`].
//!
//! Unknown parameters are warnings with their position; unknown plugins, and features whose
//! absence would change the image, are errors at their position.
//!
//! Checked against Mitsuba 3.9.1 (`scalar_rgb`) renders of the same files. Known differences:
//! - `envmap`: Mitsuba puts the centres of the first and last rows on the poles, candela's
//!   bilinear lookup half a texel inside (at most half a texel of vertical shift);
//! - texture `to_uv` transforms may scale and translate u and v, not rotate or shear them
//!   (an error says so);
//! - emissive meshes with vertex normals emit on the side of the geometric normal turned to the
//!   interpolated one, Mitsuba on the side of the interpolated normal (only silhouettes differ);
//! - a sphere whose `to_world` scales non-uniformly stays round, as in Mitsuba, but its uv follow
//!   the rotation of the polar decomposition instead of Mitsuba's inverse `to_world`;
//! - films are filtered with a box (warning otherwise), crop windows are ignored (warnings);
//! - colours are RGB: spectra must be single values (a flat emitted spectrum has the colour of
//!   illuminant E, as in Mitsuba's RGB variants); conductor presets are Mitsuba's RGB values;
//! - a scene without `<sensor>` gets a default camera (Mitsuba 3.9.1 cannot render it).

mod bsdf;
mod math;
mod presets;
mod shapes;
mod xml;

use self::math::M4;
use self::xml::{Element, Props};
use crate::error::{Pos, SceneError, SourceFile};
use crate::loaded::{LoadOptions, LoadedScene, RenderHints};
use candela_render::camera::{Camera, Lens};
use candela_render::light::{
    Components, DistantLight, Environment, Falloff, Light, PointLight, SpotLight, SpotProfile,
};
use candela_render::material::MaterialId;
use candela_render::math::{Point3, Transform, Vec3};
use candela_render::scene::SceneBuilder;
use candela_render::shape::Mesh;
use candela_render::texture::{Filter, ImageTexture, Texture, Wrap};
use candela_render::{Image, Rgb};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Loads a Mitsuba 3 scene: `text` is the content of the file at `path`; relative file names
/// resolve against its folder.
pub fn load_mitsuba(
    path: &Path,
    text: &str,
    opts: &LoadOptions,
) -> Result<LoadedScene, SceneError> {
    let src = SourceFile::new(path, text);
    let (root, unused_defines) = xml::parse(&src, &opts.defines)?;
    if root.tag != "scene" {
        return Err(src.error(
            root.pos,
            format!("the root element must be <scene>, not <{}>", root.tag),
        ));
    }
    let version = root.attr("version").ok_or_else(|| {
        src.error(
            root.pos,
            "<scene> needs a 'version' attribute (e.g. version=\"3.0.0\")",
        )
    })?;
    let major = parse_version(&version.value).ok_or_else(|| {
        src.error(
            version.pos,
            format!("invalid version number '{}'", version.value),
        )
    })?;
    let mut ids = HashMap::new();
    collect_ids(&root, &src, &mut ids)?;
    let mut l = Loader {
        src,
        ids,
        upgrade: major < 2,
        search: Vec::new(),
        scene: SceneBuilder::new(),
        hints: RenderHints {
            width: Some(768),
            height: Some(576),
            spp: Some(4),
            integrator: Some("path".into()),
            max_depth: Some(-1),
            rr_depth: Some(5),
            hide_emitters: false,
        },
        warnings: Vec::new(),
        materials: HashMap::new(),
        textured: Vec::new(),
        default_materials: [None; 2],
        textures: HashMap::new(),
        images: HashMap::new(),
        meshes: HashMap::new(),
        active: Vec::new(),
        has_sensor: false,
        triangles: 0,
        mesh_bytes: 0.0,
    };
    for d in unused_defines {
        l.warnings.push(format!(
            "{}: -d {d}: the scene has no such parameter",
            path.display()
        ));
    }
    l.scene_element(&root)?;
    let Loader {
        scene,
        hints,
        mut warnings,
        has_sensor,
        triangles,
        mesh_bytes,
        ..
    } = l;
    let mut scene = scene.build(opts.accel);
    if !has_sensor {
        scene.camera = default_camera(&scene.geometry.bounds(), &hints);
        warnings.push(format!(
            "{}: no <sensor>: using a default camera (45° wide, looking along +z at the whole scene)",
            path.display()
        ));
    }
    Ok(LoadedScene {
        scene,
        hints,
        warnings,
        mesh_stats: (triangles > 0).then(|| (triangles, mesh_bytes / triangles as f64)),
        local_model_terms: Vec::new(),
    })
}

/// The major version of a `x.y.z` version number.
fn parse_version(v: &str) -> Option<u32> {
    let parts: Vec<&str> = v.trim().split('.').collect();
    if parts.is_empty() || parts.len() > 3 || parts.iter().any(|p| p.parse::<u32>().is_err()) {
        return None;
    }
    parts[0].parse().ok()
}

/// Every `id` of the document (at any depth), and `<alias id as>`.
fn collect_ids<'t>(
    e: &'t Element,
    src: &SourceFile,
    ids: &mut HashMap<String, &'t Element>,
) -> Result<(), SceneError> {
    for c in &e.children {
        if c.tag == "alias" {
            let (Some(id), Some(alias)) = (c.attr("id"), c.attr("as")) else {
                return Err(src.error(c.pos, "<alias> needs the attributes 'id' and 'as'"));
            };
            let target = *ids
                .get(&id.value)
                .ok_or_else(|| src.error(id.pos, format!("unknown id '{}'", id.value)))?;
            if ids.insert(alias.value.clone(), target).is_some() {
                return Err(src.error(
                    alias.pos,
                    format!("the id '{}' is already used", alias.value),
                ));
            }
            continue;
        }
        if c.tag != "ref" {
            if let Some(id) = c.attr("id") {
                if let Some(prev) = ids.insert(id.value.clone(), c) {
                    return Err(src.error(
                        id.pos,
                        format!(
                            "the id '{}' is already used (line {})",
                            id.value, prev.pos.line
                        ),
                    ));
                }
            }
        }
        collect_ids(c, src, ids)?;
    }
    Ok(())
}

/// A camera for scenes without one (older Mitsuba versions' default): 45° horizontal field of
/// view, looking along +z at the centre of the scene's bounds from far enough to see all of it.
fn default_camera(b: &candela_render::math::Bounds3, hints: &RenderHints) -> Camera {
    let aspect = hints.width.unwrap_or(768) as f64 / hints.height.unwrap_or(576).max(1) as f64;
    let to_world = if b.is_empty() || !b.is_finite() {
        M4::IDENTITY
    } else {
        let (c, e) = (b.centroid(), b.diagonal());
        let distance = e.x.max(e.y).max(e.z) as f64 / (2.0 * 22.5f64.to_radians().tan());
        M4::translate([c.x as f64, c.y as f64, b.min.z as f64 - distance])
    };
    perspective(&to_world, 45.0, aspect)
        .unwrap_or_else(|| Camera::perspective(1.0, aspect as f32, Transform::IDENTITY))
}

/// The linear sRGB colour of a flat (equal-energy) spectrum of value 1, as Mitsuba's RGB
/// variants convert emitted spectra (it is not white: white is D65).
const FLAT_SPECTRUM: Rgb = Rgb::new(1.20479, 0.948291, 0.908916);

/// Maps candela's camera frame (x forward, y left, z up) onto Mitsuba's (z forward, x left,
/// y up).
const MITSUBA_FROM_CANDELA: M4 = M4([
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
]);

/// Candela's perspective camera for Mitsuba's `to_world` and horizontal field of view: the eye
/// at the origin of `to_world`, the screen at distance d = aspect / tan(x_fov / 2).
fn perspective(to_world: &M4, x_fov_deg: f64, aspect: f64) -> Option<Camera> {
    let d = aspect / (x_fov_deg.to_radians() / 2.0).tan();
    let t = to_world
        .mul(&MITSUBA_FROM_CANDELA)
        .mul(&M4::translate([d, 0.0, 0.0]))
        .to_transform()?;
    Some(Camera::perspective(d as f32, aspect as f32, t))
}

/// The importer's state while it walks the scene.
struct Loader<'t> {
    src: SourceFile,
    ids: HashMap<String, &'t Element>,
    /// Mitsuba 0.6 files (version < 2): camelCase parameter names.
    upgrade: bool,
    /// Folders added by `<path>`, searched before the file's folder.
    search: Vec<PathBuf>,
    scene: SceneBuilder,
    hints: RenderHints,
    warnings: Vec<String>,
    /// BSDF element → material.
    materials: HashMap<usize, MaterialId>,
    /// Per material: some texture varies over the surface.
    textured: Vec<bool>,
    /// Mitsuba's default BSDFs of shapes without and with an emitter.
    default_materials: [Option<MaterialId>; 2],
    /// Texture element → texture.
    textures: HashMap<usize, Texture>,
    images: HashMap<(PathBuf, bool), Arc<Image>>,
    meshes: HashMap<PathBuf, Arc<Mesh>>,
    /// Elements being built (to report circular references).
    active: Vec<usize>,
    has_sensor: bool,
    triangles: usize,
    mesh_bytes: f64,
}

impl<'t> Loader<'t> {
    fn err(&self, pos: Pos, msg: impl Into<String>) -> SceneError {
        self.src.error(pos, msg)
    }

    fn warn(&mut self, pos: Pos, msg: impl AsRef<str>) {
        self.warnings.push(format!(
            "{}:{pos}: {}",
            self.src.path.display(),
            msg.as_ref()
        ));
    }

    /// The properties of `e`.
    fn props(&self, e: &'t Element) -> Result<Props<'t>, SceneError> {
        Props::new(e, &self.ids, &self.src, self.upgrade)
    }

    /// Reports the parameters of `p` that nothing read.
    fn finish(&mut self, p: &Props) {
        for (pos, msg) in p.unused() {
            self.warn(pos, msg);
        }
    }

    /// Enters the construction of `e`; an error if `e` is already being built (a `<ref>` cycle).
    fn enter(&mut self, e: &Element) -> Result<(), SceneError> {
        if self.active.contains(&e.key()) {
            return Err(self.err(
                e.pos,
                format!("circular reference: {} refers to itself", e.describe()),
            ));
        }
        self.active.push(e.key());
        Ok(())
    }

    fn leave(&mut self) {
        self.active.pop();
    }

    /// A file name of the scene: absolute, or relative to a `<path>` folder where it exists,
    /// or to the scene file's folder.
    fn resolve(&self, name: &str) -> PathBuf {
        let p = Path::new(name);
        if p.is_absolute() {
            return p.to_path_buf();
        }
        self.search
            .iter()
            .map(|d| d.join(p))
            .find(|f| f.exists())
            .unwrap_or_else(|| self.src.resolve(name))
    }

    /// The transformation `to_world` of `p` (identity when absent); an error when singular.
    fn to_world(&self, p: &Props) -> Result<(M4, Transform), SceneError> {
        let (m, pos) = p
            .get::<M4>("to_world")?
            .unwrap_or((M4::IDENTITY, p.owner.pos));
        let t = m.to_transform().ok_or_else(|| {
            self.err(
                pos,
                "the transformation is singular (a scaling by zero?) or not affine",
            )
        })?;
        Ok((m, t))
    }

    /// A colour property that must not vary over a surface: a number, `<rgb>` or `<spectrum>`.
    /// A flat `<spectrum>` is grey, except for what emitters emit (`emitted`), where Mitsuba's
    /// RGB variants give it the colour of a flat spectrum.
    fn color(&self, p: &Props, name: &str, default: f32, emitted: bool) -> Result<Rgb, SceneError> {
        let Some(i) = p.item(name) else {
            return Ok(Rgb::splat(default));
        };
        match i.value {
            xml::Value::Float(v) => Ok(Rgb::splat(v as f32)),
            xml::Value::Int(v) => Ok(Rgb::splat(v as f32)),
            xml::Value::Spectrum(v) if emitted => Ok(FLAT_SPECTRUM * v as f32),
            xml::Value::Spectrum(v) => Ok(Rgb::splat(v as f32)),
            xml::Value::Rgb([r, g, b]) => Ok(Rgb::new(r as f32, g as f32, b as f32)),
            ref v => Err(self.err(
                i.pos,
                format!(
                    "'{name}' must be a colour (<rgb>, <spectrum> or <float>), not {}",
                    v.describe()
                ),
            )),
        }
    }

    /// The children of `<scene>`, in order.
    fn scene_element(&mut self, root: &'t Element) -> Result<(), SceneError> {
        let p = self.props(root)?;
        for c in &root.children {
            match c.tag.as_str() {
                "integrator" => self.integrator(c)?,
                "sensor" => self.sensor(c)?,
                "bsdf" => {
                    self.material(c)?;
                }
                "texture" => {
                    self.texture_plugin(c)?;
                }
                "shape" => self.shape(c)?,
                "emitter" => self.emitter(c)?,
                "path" => {
                    let v = c
                        .attr("value")
                        .ok_or_else(|| self.err(c.pos, "<path> needs the attribute 'value'"))?;
                    let dir = self.resolve(&v.value);
                    if !dir.is_dir() {
                        return Err(self.err(
                            v.pos,
                            format!("<path>: folder '{}' not found", dir.display()),
                        ));
                    }
                    self.search.insert(0, dir);
                }
                "medium" | "phase" | "volume" => {
                    return Err(self.err(
                        c.pos,
                        format!("participating media ({}) are not supported", c.describe()),
                    ))
                }
                "film" | "sampler" | "rfilter" => {
                    return Err(self.err(c.pos, format!("<{}> must be inside a <sensor>", c.tag)));
                }
                _ => {}
            }
        }
        for tag in [
            "integrator",
            "sensor",
            "bsdf",
            "texture",
            "shape",
            "emitter",
        ] {
            p.objects(tag);
        }
        self.finish(&p);
        Ok(())
    }

    /// `<integrator>`: render hints.
    fn integrator(&mut self, e: &'t Element) -> Result<(), SceneError> {
        let p = self.props(e)?;
        let max_depth = |p: &Props| {
            p.int_in("max_depth", -1, (-1, i32::MAX as i64))
                .map(|d| d as i32)
        };
        let rr_depth = |p: &Props| {
            p.int_in("rr_depth", 5, (1, u32::MAX as i64))
                .map(|d| d as u32)
        };
        let (depth, rr) = match e.kind() {
            "path" | "volpath" | "volpathmis" | "prb" | "prbvolpath" | "ptracer" => {
                (max_depth(&p)?, rr_depth(&p)?)
            }
            // Mitsuba's `direct` is physically based direct illumination: paths of at most two
            // vertices, which is what the path tracer computes with max_depth 2.
            "direct" | "direct_projective" => {
                p.ignore(&["emitter_samples", "bsdf_samples", "shading_samples"]);
                (2, 5)
            }
            other => {
                self.warn(e.pos, format!("integrator '{other}' is not supported: the path tracer is suggested instead"));
                return Ok(());
            }
        };
        self.hints.integrator = Some("path".into());
        self.hints.max_depth = Some(depth);
        self.hints.rr_depth = Some(rr);
        self.hints.hide_emitters = p.or("hide_emitters", false)?;
        p.ignore(&["samples_per_pass", "timeout"]);
        self.finish(&p);
        Ok(())
    }

    /// `<sensor>`: the camera and the film, sampler hints.
    fn sensor(&mut self, e: &'t Element) -> Result<(), SceneError> {
        if self.has_sensor {
            self.warn(
                e.pos,
                "only the first <sensor> is rendered: this one is ignored",
            );
            return Ok(());
        }
        self.has_sensor = true;
        let p = self.props(e)?;
        let (mut width, mut height) = (768u32, 576u32);
        if let Some((film, _)) = p.object("film")? {
            (width, height) = self.film(film)?;
        } else {
            self.warn(e.pos, "no <film>: Mitsuba's default 768×576 film (candela filters with a box, Mitsuba with a Gaussian)");
        }
        if let Some((s, _)) = p.object("sampler")? {
            let sp = self.props(s)?;
            self.hints.spp = Some(sp.int_in("sample_count", 4, (1, u32::MAX as i64))? as u32);
            sp.ignore(&["seed", "jitter", "dimension", "scramble"]);
            self.finish(&sp);
        }
        self.hints.width = Some(width);
        self.hints.height = Some(height);
        let aspect = width as f64 / height as f64;
        let (to_world, _) = self.to_world(&p)?;
        let far_clip = p.number_in("far_clip", 1e4, (f64::MIN_POSITIVE, f64::MAX))?;
        p.ignore(&["near_clip", "shutter_open", "shutter_close", "srf"]);
        let camera = match e.kind() {
            kind @ ("perspective" | "thinlens") => {
                let lin = to_world.0;
                if (0..3).any(|c| {
                    ((0..3).map(|r| lin[r][c] * lin[r][c]).sum::<f64>() - 1.0).abs() > 1e-3
                }) {
                    return Err(self.err(
                        p.pos("to_world"),
                        "the sensor's to_world must not scale (Mitsuba rejects it)",
                    ));
                }
                // Mitsuba's thin lens: the aperture radius is required, the focus distance
                // defaults to the far clipping distance.
                let lens = if kind == "thinlens" {
                    if !p.has("aperture_radius") {
                        return Err(self.err(e.pos, "thinlens needs an 'aperture_radius'"));
                    }
                    let radius = p.number_in("aperture_radius", 0.0, (0.0, f64::MAX))?;
                    let focus =
                        p.number_in("focus_distance", far_clip, (f64::MIN_POSITIVE, f64::MAX))?;
                    (radius > 0.0).then_some(Lens {
                        radius: radius as f32,
                        focus_distance: focus as f32,
                    })
                } else {
                    None
                };
                for n in ["principal_point_offset_x", "principal_point_offset_y"] {
                    if p.or(n, 0.0)? != 0.0 {
                        self.warn(p.pos(n), format!("'{n}' is not supported and is ignored"));
                    }
                }
                p.ignore(&["focus_distance"]);
                let fov = self.x_fov(&p, aspect)?;
                let camera = perspective(&to_world, fov, aspect).ok_or_else(|| {
                    self.err(p.pos("to_world"), "the camera transformation is singular")
                })?;
                match lens {
                    Some(l) => camera.with_lens(l),
                    None => camera,
                }
            }
            "orthographic" => {
                // Mitsuba's orthographic camera sees [-1,1] × [-1/aspect, 1/aspect] of its local
                // x-y plane (before to_world) along +z.
                let a = aspect;
                let local = M4([
                    [0.0, 1.0 / a, 0.0, 0.0],
                    [0.0, 0.0, 1.0 / a, 0.0],
                    [1.0, 0.0, 0.0, 1.0],
                    [0.0, 0.0, 0.0, 1.0],
                ]);
                let t = to_world.mul(&local).to_transform().ok_or_else(|| {
                    self.err(p.pos("to_world"), "the camera transformation is singular")
                })?;
                Camera::orthogonal(aspect as f32, t)
            }
            other => {
                return Err(self.err(
                    e.pos,
                    format!(
                    "unsupported sensor '{other}' (supported: perspective, thinlens, orthographic)"
                ),
                ))
            }
        };
        self.scene.camera(camera);
        self.finish(&p);
        Ok(())
    }

    /// Mitsuba's horizontal field of view in degrees from `fov` and `fov_axis`, or
    /// `focal_length` (35 mm film, diagonal).
    fn x_fov(&self, p: &Props, aspect: f64) -> Result<f64, SceneError> {
        let (fov, axis) = if p.has("fov") {
            if p.has("focal_length") {
                return Err(p.error(
                    p.pos("focal_length"),
                    "give either 'fov' or 'focal_length', not both",
                ));
            }
            let fov = p.number_in("fov", 0.0, (1e-6, 180.0 - 1e-6))?;
            let axis = p.choice("fov_axis", &["x", "y", "smaller", "larger", "diagonal"])?;
            let axis = match axis.as_str() {
                "smaller" => (if aspect > 1.0 { "y" } else { "x" }).to_string(),
                "larger" => (if aspect > 1.0 { "x" } else { "y" }).to_string(),
                _ => axis,
            };
            (fov, axis)
        } else {
            let f = p.or("focal_length", "50mm".to_string())?;
            let mm = f
                .trim()
                .trim_end_matches("mm")
                .trim()
                .parse::<f64>()
                .ok()
                .filter(|v| *v > 0.0 && v.is_finite());
            let mm = mm.ok_or_else(|| {
                p.error(
                    p.pos("focal_length"),
                    format!("'{f}' is not a focal length such as '50mm'"),
                )
            })?;
            (
                2.0 * (((36.0f64 * 36.0 + 24.0 * 24.0).sqrt()) / (2.0 * mm))
                    .atan()
                    .to_degrees(),
                "diagonal".to_string(),
            )
        };
        let half = (fov.to_radians() / 2.0).tan();
        let x = match axis.as_str() {
            "x" => fov,
            "y" => 2.0 * (half * aspect).atan().to_degrees(),
            _ => {
                2.0 * (half / (1.0 + 1.0 / (aspect * aspect)).sqrt())
                    .atan()
                    .to_degrees()
            }
        };
        if !(x > 0.0 && x < 180.0) {
            return Err(p.error(
                p.pos("fov"),
                "the horizontal field of view must be between 0 and 180 degrees",
            ));
        }
        Ok(x)
    }

    /// `<film>`: its size.
    fn film(&mut self, e: &'t Element) -> Result<(u32, u32), SceneError> {
        let p = self.props(e)?;
        if !matches!(e.kind(), "hdrfilm" | "specfilm") {
            self.warn(
                e.pos,
                format!(
                    "film '{}' is not supported: its size is used as an hdrfilm's",
                    e.kind()
                ),
            );
        }
        const MAX: i64 = 1 << 16;
        let w = p.int_in("width", 768, (1, MAX))? as u32;
        let h = p.int_in("height", 576, (1, MAX))? as u32;
        let crop = (
            p.or("crop_offset_x", 0i64)?,
            p.or("crop_offset_y", 0i64)?,
            p.or("crop_width", w as i64)?,
            p.or("crop_height", h as i64)?,
        );
        if crop != (0, 0, w as i64, h as i64) {
            self.warn(
                p.pos("crop_width"),
                "crop windows are not supported: the whole film is rendered",
            );
        }
        match p.object("rfilter")? {
            Some((f, _)) if f.kind() == "box" => {}
            Some((f, pos)) => self.warn(pos, format!("reconstruction filter '{}': candela uses a box filter (a slightly sharper image)", f.kind())),
            None => self.warn(e.pos, "no <rfilter>: Mitsuba's default is a Gaussian filter, candela uses a box filter (a slightly sharper image)"),
        }
        p.ignore(&[
            "pixel_format",
            "component_format",
            "file_format",
            "banner",
            "high_quality_edges",
            "compensate",
            "sample_border",
        ]);
        self.finish(&p);
        Ok((w, h))
    }

    /// A top-level `<emitter>` (area emitters belong to shapes).
    fn emitter(&mut self, e: &'t Element) -> Result<(), SceneError> {
        let p = self.props(e)?;
        p.ignore(&["sampling_weight"]);
        let light = match e.kind() {
            kind @ ("point" | "spot") => {
                let intensity = self.color(&p, "intensity", 1.0, true)?;
                let (m, _) = self.to_world(&p)?;
                let position = match p.get::<[f64; 3]>("position")? {
                    Some(_) if p.has("to_world") => return Err(p.error(p.pos("position"), "give either 'position' or 'to_world', not both")),
                    Some((v, _)) => v,
                    None => m.point([0.0; 3]),
                };
                let position = point(position);
                if kind == "point" {
                    Light::Point(
                        PointLight {
                            position,
                            intensity,
                            falloff: Falloff::INVERSE_SQUARE,
                        },
                        Components::from_intensity(intensity),
                    )
                } else {
                    let cutoff = p.number_in("cutoff_angle", 20.0, (0.0, 180.0))?;
                    let beam = p.number_in("beam_width", cutoff * 0.75, (0.0, cutoff))?;
                    if p.has("texture") {
                        return Err(p.error(p.pos("texture"), "spot lights with a texture are not supported"));
                    }
                    let axis = unit(m.vector([0.0, 0.0, 1.0])).ok_or_else(|| p.error(p.pos("to_world"), "the spot's axis is degenerate"))?;
                    Light::Spot(
                        SpotLight {
                            position,
                            axis,
                            intensity,
                            cos_cutoff: cutoff.to_radians().cos() as f32,
                            profile: SpotProfile::Linear(beam.to_radians().cos() as f32),
                            falloff: Falloff::INVERSE_SQUARE,
                        },
                        Components::from_intensity(intensity),
                    )
                }
            }
            "directional" => {
                let irradiance = self.color(&p, "irradiance", 1.0, true)?;
                let (m, _) = self.to_world(&p)?;
                let dir = match p.get::<[f64; 3]>("direction")? {
                    Some(_) if p.has("to_world") => return Err(p.error(p.pos("direction"), "give either 'direction' or 'to_world', not both")),
                    Some((v, _)) => v,
                    None => m.vector([0.0, 0.0, 1.0]),
                };
                let direction = unit(dir).ok_or_else(|| p.error(p.pos("direction"), "the direction must not be the zero vector"))?;
                Light::Distant(DistantLight { direction, irradiance }, Components::from_intensity(irradiance))
            }
            "constant" => Light::Environment(Environment::new(Texture::Uniform(self.color(&p, "radiance", 1.0, true)?), Transform::IDENTITY)),
            "envmap" => {
                let (m, _) = self.to_world(&p)?;
                let (name, pos) = p.get::<String>("filename")?.ok_or_else(|| p.error(e.pos, "envmap needs a 'filename'"))?;
                let mut image = self.image(&name, false, pos)?;
                let scale = p.or("scale", 1.0f32)?;
                if scale != 1.0 {
                    let mut scaled = (*image).clone();
                    for px in scaled.pixels_mut() {
                        *px *= scale;
                    }
                    image = Arc::new(scaled);
                }
                p.ignore(&["mis_compensation"]);
                // Mitsuba looks up the local direction d at u = atan2(d.x, -d.z)/2π,
                // v = acos(d.y)/π; candela's environment at u = atan2(l.y, l.x)/2π, v = acos(l.z)/π.
                // With d = (l.y, l.z, -l.x) both find the same texel.
                let d_from_l = M4::from_columns([0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0; 3]);
                let t = m.mul(&d_from_l).to_transform().ok_or_else(|| p.error(p.pos("to_world"), "the transformation is singular"))?;
                // Mitsuba puts row centres at v = row/(h − 1), repeats in u and clamps in v.
                let h = image.height() as f32;
                let tex = Texture::Image(ImageTexture {
                    filter: Filter::Bilinear,
                    wrap: [Wrap::Repeat, Wrap::Clamp],
                    scale: [1.0, (h - 1.0) / h],
                    offset: [0.0, 0.5 / h],
                    image,
                });
                Light::Environment(Environment::new(tex, t))
            }
            "area" => return Err(self.err(e.pos, "an area emitter must be nested in a <shape>")),
            other => {
                return Err(self.err(
                    e.pos,
                    format!("unsupported emitter '{other}' (supported: point, spot, directional, constant, envmap, and area in shapes)"),
                ))
            }
        };
        self.scene.add_light(light);
        self.finish(&p);
        Ok(())
    }
}

/// A point from three doubles.
fn point(v: [f64; 3]) -> Point3 {
    Point3::new(v[0] as f32, v[1] as f32, v[2] as f32)
}

/// The unit vector along `v`, if it is not zero.
fn unit(v: [f64; 3]) -> Option<Vec3> {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    (n > 0.0 && n.is_finite())
        .then(|| Vec3::new((v[0] / n) as f32, (v[1] / n) as f32, (v[2] / n) as f32))
}
