//! Mitsuba 3 XML import (`.xml`), with Mitsuba's semantics so that the same file gives the same
//! image within noise.
//!
//! The document is read in two passes. The `xml` module turns it into a tree of elements with
//! their positions, substituting `$name` parameters in document order (`<default>`s, overridden
//! by `-d NAME=VALUE`), and `props` reads every property value; then the loader walks the
//! `<scene>`, resolving `<ref id>`s (to any id of the file) and building candela's scene, one
//! file per plugin family (`sensor`, `shapes`, `bsdfs`, `emitters`, `integrators`):
//!
//! - sensors `perspective` (`fov`/`focal_length`, `fov_axis`; Mitsuba's camera frame: +z forward,
//!   +y up, +x to the left of the image), `thinlens` (depth of field), `orthographic`; film
//!   `hdrfilm` (`width`, `height`), any sampler (`sample_count`);
//! - shapes `sphere`, `rectangle`, `disk`, `cube`, `cylinder`, `obj`, `ply`, `serialized` with `to_world`, `flip_normals`,
//!   `face_normals`, a BSDF (Mitsuba's default: one-sided diffuse 0.5) and an `area` emitter
//!   (one-sided, on the side of the normal);
//! - BSDFs `diffuse`, `conductor`, `roughconductor`, `dielectric`, `roughdielectric`, `plastic`,
//!   `roughplastic` (all one-sided), `twosided` and `mask`; textures `bitmap` and `checkerboard`;
//! - emitters `point`, `spot`, `directional`, `constant`, `envmap`;
//! - integrators `path` and its equivalents without media (`volpath`, …), `direct` (the path
//!   tracer limited to depth 2) and `moment` (its first nested integrator), which become
//!   [`RenderHints`]; `<include>` (see `include`); `serialized` meshes.
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
//! - crop windows are ignored (warnings); the reconstruction filter is the Gaussian when the
//!   film names none, as in Mitsuba;
//! - spectra (`<spectrum>` values, λ:value lists, files and the `uniform`, `blackbody`,
//!   `regular`, `irregular`, `d65`, `srgb` plugins; see `spectra.rs`) are used as they are by
//!   spectral renders (`--spectral`, as Mitsuba's spectral variants) and converted to RGB as
//!   Mitsuba's RGB variants do otherwise (a flat emitted spectrum has the colour of illuminant
//!   E; a blackbody, which Mitsuba's RGB variants refuse, gets its colour); named conductors use
//!   their measured η(λ), k(λ) spectrally and Mitsuba's RGB values otherwise; a dielectric's
//!   `int_ior` may be a `<spectrum>` of λ:n pairs (a candela extension: dispersion, spectral
//!   renders only; RGB renders use the index at 587.56 nm);
//! - a scene without `<sensor>` gets a default camera (Mitsuba 3.9.1 cannot render it).
//! - `mask`: shadow rays pass masked surfaces stochastically (Mitsuba's stop at them, so its
//!   point and spot lights cast full shadows behind masks); a pass is not a bounce (Mitsuba
//!   counts it towards `max_depth`); a `checkerboard` opacity follows the checkerboard's colours
//!   (Mitsuba 3.9.1's scalar lookup swaps them);
//! - JPEG textures are decoded by `zune-jpeg`, Mitsuba uses libjpeg: texels differ by up to
//!   ~2 % of full scale (rounding, chroma upsampling), seen as ≲1 % differences where such a
//!   texture dominates;
//! - reconstruction filters wider than the box splat samples, as Mitsuba's film does, but
//!   divide by the weight each pixel expects rather than by the sum of the weights it received
//!   (an unbiased estimate of the same normalised convolution, exact in any order; see
//!   `candela_render::splat`); with output variables they are importance-sampled instead (each
//!   sample stays in its pixel, whose noise is then its own), where negative-lobed filters are
//!   noisier and border pixels see samples outside the film.

mod bsdfs;
mod emitters;
mod include;
mod integrators;
mod math;
mod presets;
mod props;
mod sensor;
mod shapes;
mod spectra;
mod xml;

use self::include::{Expander, Sources};
use self::math::M4;
use self::props::Props;
use self::xml::Element;
use crate::error::{Pos, SceneError, SourceFile};
use crate::loaded::{LoadOptions, LoadedScene, RenderHints};
use candela_render::material::MaterialId;
use candela_render::math::Transform;
use candela_render::scene::SceneBuilder;
use candela_render::shape::Mesh;
use candela_render::spectrum::{RgbRole, Spectrum};
use candela_render::texture::Texture;
use candela_render::{Image, Rgb};
use sensor::default_camera;
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
    let mut sources = Sources::new(&src);
    let (root, unused_defines) = {
        let (mut root, unused) = xml::parse(&src, &opts.defines)?;
        let mut ex = Expander {
            sources: &mut sources,
            defines: &opts.defines,
            unused,
            limits: &opts.limits,
            inclusions: 0,
            included_bytes: 0,
        };
        let mut stack = vec![path.canonicalize().unwrap_or_else(|_| path.to_path_buf())];
        ex.expand(&mut root, path, &mut stack)?;
        (root, ex.unused)
    };
    load_tree(src, &root, unused_defines, opts, &sources).map_err(|e| sources.remap(e))
}

/// Loads the scene whose tree (includes expanded) is `root`.
fn load_tree(
    src: SourceFile,
    root: &Element,
    unused_defines: Vec<String>,
    opts: &LoadOptions,
    sources: &Sources,
) -> Result<LoadedScene, SceneError> {
    let path = src.path.clone();
    let path = path.as_path();
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
    collect_ids(root, &src, &mut ids)?;
    let mut l = Loader {
        src,
        sources,
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
            filter: Some(candela_render::filter::Filter::Gaussian { stddev: 0.5 }),
        },
        warnings: Vec::new(),
        materials: HashMap::new(),
        textured: Vec::new(),
        default_materials: [None; 2],
        textures: HashMap::new(),
        images: HashMap::new(),
        meshes: HashMap::new(),
        groups: HashMap::new(),
        instances: 0,
        active: Vec::new(),
        has_sensor: false,
        triangles: 0,
        mesh_bytes: 0.0,
        limits: opts.limits,
        inputs: Vec::new(),
    };
    for d in unused_defines {
        l.warnings.push(format!(
            "{}: -d {d}: the scene has no such parameter",
            path.display()
        ));
    }
    l.scene_element(root)?;
    let Loader {
        scene,
        hints,
        mut warnings,
        has_sensor,
        triangles,
        mesh_bytes,
        inputs,
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
        inputs,
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
    /// Mesh files (serialized ones as `file/@index`) → the mesh and whether the file asks for
    /// face normals.
    meshes: HashMap<PathBuf, Arc<(Mesh, bool)>>,
    /// Shapegroup element → group index in the scene.
    groups: HashMap<usize, u32>,
    /// Instances placed so far.
    instances: usize,
    /// Elements being built (to report circular references).
    active: Vec<usize>,
    has_sensor: bool,
    /// The main file and the included ones, to place positions in their file.
    sources: &'t Sources,
    triangles: usize,
    mesh_bytes: f64,
    /// File sizes, image pixels, mesh memory.
    limits: candela_imageio::Limits,
    /// The files read (meshes, images).
    inputs: Vec<PathBuf>,
}

impl<'t> Loader<'t> {
    fn err(&self, pos: Pos, msg: impl Into<String>) -> SceneError {
        self.src.error(pos, msg)
    }

    fn warn(&mut self, pos: Pos, msg: impl AsRef<str>) {
        self.warnings
            .push(format!("{}: {}", self.sources.describe(pos), msg.as_ref()));
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
        // A chain of `<ref>`s nests plugins as deeply as elements can be nested: no deeper
        // (the recursion's stack, and this list's linear search, stay small).
        if self.active.len() >= xml::MAX_DEPTH {
            return Err(self.err(
                e.pos,
                format!(
                    "{} is nested more than {} plugins deep (through <ref>s; see docs/limits.md)",
                    e.describe(),
                    xml::MAX_DEPTH
                ),
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

    /// A colour property that must not vary over a surface: a number, `<rgb>` or `<spectrum>`,
    /// as RGB (what Mitsuba's RGB variants make of it: a flat `<spectrum>` is grey, except for
    /// what emitters emit (`emitted`), where it has the colour of a flat spectrum).
    fn color(
        &mut self,
        p: &Props,
        name: &str,
        default: f32,
        emitted: bool,
    ) -> Result<Rgb, SceneError> {
        let role = if emitted {
            RgbRole::Emission
        } else {
            RgbRole::Reflectance
        };
        Ok(self.colour(p, name, default, role)?.0)
    }

    /// A colour property as RGB in `role` (see [`Spectrum::to_rgb`]) and, when given as a
    /// `<spectrum>`, the spectrum itself (for spectral renders).
    fn colour(
        &mut self,
        p: &Props,
        name: &str,
        default: f32,
        role: RgbRole,
    ) -> Result<(Rgb, Option<Arc<Spectrum>>), SceneError> {
        let Some(i) = p.item(name) else {
            return Ok((Rgb::splat(default), None));
        };
        // Never negative, like the colours below: at the samples of a tabulated spectrum,
        // every 5 nm of the visible range for the others.
        let spectrum = |s: Spectrum| {
            let negative = match &s {
                Spectrum::Tabulated(t) => t.samples().iter().any(|&(_, v)| v < 0.0),
                s => (360..=830).step_by(5).any(|l| s.eval(l as f32) < 0.0),
            };
            if negative {
                return Err(format!("'{name}' must not be negative"));
            }
            Ok(match s {
                // A flat reflectance is its grey in both modes (its upsampled spectrum is flat).
                Spectrum::Constant(c) if role != RgbRole::Emission => (Rgb::splat(c), None),
                s => (s.to_rgb(role), Some(Arc::new(s))),
            })
        };
        // Colours are reflectances, radiances, intensities or indices: never negative.
        let plain = |c: Rgb| {
            if c.r < 0.0 || c.g < 0.0 || c.b < 0.0 {
                Err(format!(
                    "'{name}' must not be negative (found {} {} {})",
                    c.r, c.g, c.b
                ))
            } else {
                Ok((c, None))
            }
        };
        let checked = match i.value {
            props::Value::Float(v) => plain(Rgb::splat(v as f32)),
            props::Value::Int(v) => plain(Rgb::splat(v as f32)),
            props::Value::Spectrum(ref s) => spectrum(s.clone()),
            props::Value::SpectrumFile(f, pos) => spectrum(self.spectrum_file(f, pos)?),
            props::Value::Rgb([r, g, b]) => plain(Rgb::new(r as f32, g as f32, b as f32)),
            ref v => Err(format!(
                "'{name}' must be a colour (<rgb>, <spectrum> or <float>), not {}",
                v.describe()
            )),
        };
        checked.map_err(|m| self.err(i.pos, m))
    }

    /// The tabulated spectrum in the file `name` (`λ value` lines, `#` comments).
    fn spectrum_file(&mut self, name: &str, pos: Pos) -> Result<Spectrum, SceneError> {
        let path = self.resolve(name);
        crate::inputs::record(&path);
        let bytes = candela_imageio::input::read_file(&path, self.limits.max_file_bytes)
            .map_err(|e| self.err(pos, format!("cannot read spectrum '{name}': {e}")))?;
        self.inputs.push(path);
        let text = String::from_utf8(bytes)
            .map_err(|_| self.err(pos, format!("spectrum '{name}' is not UTF-8 text")))?;
        let s = Spectrum::parse_spd(&text).map_err(|e| {
            let at = e.line.map(|l| format!(" (line {l})")).unwrap_or_default();
            self.err(pos, format!("spectrum '{name}'{at}: {}", e.message))
        })?;
        if let Spectrum::Tabulated(t) = &s {
            if t.samples().len() > spectra::MAX_SPECTRUM_SAMPLES {
                return Err(self.err(
                    pos,
                    format!(
                        "spectrum '{name}' has more than {} samples",
                        spectra::MAX_SPECTRUM_SAMPLES
                    ),
                ));
            }
        }
        Ok(s)
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
}
