//! BSDFs, textures and images of Mitsuba scenes.
//!
//! Every BSDF is one-sided, as in Mitsuba (a surface seen from the back is black), unless
//! wrapped in `twosided`. Defaults are Mitsuba's: `diffuse` reflectance 0.5; conductors are
//! perfect mirrors (`material="none"`) unless a `material` or `eta`/`k` is given; dielectrics
//! have `int_ior` = bk7 (1.5046) and `ext_ior` = air (1.000277); plastics polypropylene (1.49);
//! rough models use a Beckmann distribution with α = 0.1.

use super::props::{Props, Value};
use super::xml::Element;
use super::{presets, Loader};
use crate::error::{Pos, SceneError};
use candela_render::material::{
    Dispersion, Distribution, Material, MaterialId, Microfacet, Model, RoughCoating,
    REFERENCE_WAVELENGTH,
};
use candela_render::spectrum::{Ior, RgbRole, Spectrum, LAMBDA_MAX, LAMBDA_MIN};
use candela_render::texture::{Filter, ImageTexture, Texture, Wrap};
use candela_render::{Image, Rgb};
use std::sync::Arc;

/// Mitsuba clamps roughness to at least this value.
const MIN_ALPHA: f64 = 1e-4;

/// True when a texture varies over the surface.
pub(super) fn varies(t: &Texture) -> bool {
    !matches!(t, Texture::Uniform(_))
}

impl<'t> Loader<'t> {
    /// The material of a `<bsdf>` element (built once per element).
    pub(super) fn material(&mut self, e: &'t Element) -> Result<MaterialId, SceneError> {
        if let Some(&id) = self.materials.get(&e.key()) {
            return Ok(id);
        }
        let (model, two_sided, textured, opacity) = self.bsdf(e)?;
        let id = self.add_material(
            Material {
                model,
                two_sided,
                opacity,
            },
            textured,
        );
        self.materials.insert(e.key(), id);
        Ok(id)
    }

    fn add_material(&mut self, m: Material, textured: bool) -> MaterialId {
        let id = self.scene.add_material(m);
        self.textured.resize(id as usize + 1, false);
        self.textured[id as usize] = textured;
        id
    }

    /// Mitsuba's BSDF for shapes without one: a one-sided diffuse of reflectance 0.5, or 0 on
    /// emitters (which then only emit).
    pub(super) fn default_material(&mut self, emitter: bool) -> MaterialId {
        if let Some(id) = self.default_materials[emitter as usize] {
            return id;
        }
        let m = Material::one_sided(Model::Diffuse {
            reflectance: Texture::Uniform(Rgb::splat(if emitter { 0.0 } else { 0.5 })),
        });
        let id = self.add_material(m, false);
        self.default_materials[emitter as usize] = Some(id);
        id
    }

    /// The model of a `<bsdf>`, whether it is two-sided, whether a texture varies, and its
    /// stochastic opacity (`mask`).
    #[allow(clippy::type_complexity)]
    fn bsdf(&mut self, e: &'t Element) -> Result<(Model, bool, bool, Option<Texture>), SceneError> {
        self.enter(e)?;
        let p = self.props(e)?;
        let mut textured = false;
        let kind = e.kind();
        let model = match kind {
            "twosided" => {
                let inner = p.objects("bsdf");
                let (b, _) = match inner.as_slice() {
                    [one] => *one,
                    [a, b] if a.0.key() == b.0.key() => *a,
                    [_, (_, pos)] => return Err(p.error(*pos, "twosided with different front and back BSDFs is not supported")),
                    _ => return Err(p.error(e.pos, "twosided needs one nested <bsdf>")),
                };
                let (model, _, t, opacity) = self.bsdf(b)?;
                self.finish(&p);
                self.leave();
                return Ok((model, true, t, opacity));
            }
            // Mitsuba's `mask`: the nested BSDF with probability `opacity`, a straight pass
            // otherwise (shadow rays too).
            "mask" => {
                let inner = p.objects("bsdf");
                let [(b, _)] = inner.as_slice() else {
                    return Err(p.error(e.pos, "mask needs one nested <bsdf>"));
                };
                let opacity = self.tex(&p, "opacity", 0.5, false, &mut textured)?;
                let (model, two_sided, t, inner_opacity) = self.bsdf(b)?;
                if inner_opacity.is_some() {
                    return Err(p.error(e.pos, "a mask inside a mask is not supported"));
                }
                self.finish(&p);
                self.leave();
                return Ok((model, two_sided, t || textured, Some(opacity)));
            }
            "diffuse" => Model::Diffuse {
                reflectance: self.tex(&p, "reflectance", 0.5, false, &mut textured)?,
            },
            "conductor" | "roughconductor" => Model::Conductor {
                eta_k: self.conductor_ior(&p)?,
                reflectance: self.tex(&p, "specular_reflectance", 1.0, false, &mut textured)?,
                mf: if kind == "roughconductor" { Some(self.microfacet(&p, true)?) } else { None },
            },
            "dielectric" | "roughdielectric" => {
                let (eta, dispersion) = self.dispersive_eta(&p)?;
                Model::Dielectric {
                eta,
                dispersion,
                reflectance: self.tex(&p, "specular_reflectance", 1.0, false, &mut textured)?,
                transmittance: self.tex(&p, "specular_transmittance", 1.0, false, &mut textured)?,
                mf: if kind == "roughdielectric" { Some(self.microfacet(&p, true)?) } else { None },
            }},
            "plastic" | "roughplastic" => {
                let kd = self.tex(&p, "diffuse_reflectance", 0.5, false, &mut textured)?;
                let ks = self.tex(&p, "specular_reflectance", 1.0, false, &mut textured)?;
                let eta = self.eta(&p, "polypropylene")?;
                let nonlinear = p.or("nonlinear", false)?;
                if kind == "plastic" {
                    Model::Plastic { kd, ks, eta, nonlinear }
                } else {
                    let coating = Box::new(RoughCoating::new(self.microfacet(&p, false)?, eta));
                    Model::RoughPlastic { kd, ks, coating, nonlinear }
                }
            }
            other => {
                return Err(p.error(
                    e.pos,
                    format!(
                        "unsupported BSDF '{other}' (supported: diffuse, conductor, roughconductor, dielectric, roughdielectric, plastic, roughplastic, twosided, mask)"
                    ),
                ))
            }
        };
        self.finish(&p);
        self.leave();
        Ok((model, false, textured, None))
    }

    /// `distribution` and `alpha`, or `alpha_u` and `alpha_v` (anisotropic, along the surface's
    /// u and v directions, where `anisotropic`: conductors and dielectrics, as in Mitsuba).
    fn microfacet(&self, p: &Props, anisotropic: bool) -> Result<Microfacet, SceneError> {
        let dist = match p.choice("distribution", &["beckmann", "ggx"])?.as_str() {
            "ggx" => Distribution::Ggx,
            _ => Distribution::Beckmann,
        };
        let range = (0.0, 1e4);
        let alpha = p.number_in("alpha", 0.1, range)?;
        p.ignore(&["sample_visible"]);
        let clamp = |a: f64| a.max(MIN_ALPHA) as f32;
        if p.has("alpha_u") || p.has("alpha_v") {
            if p.has("alpha") {
                return Err(p.error(
                    p.pos("alpha"),
                    "give either 'alpha' or 'alpha_u' and 'alpha_v', not both",
                ));
            }
            let (u, v) = (
                p.number_in("alpha_u", 0.1, range)?,
                p.number_in("alpha_v", 0.1, range)?,
            );
            if u != v && !anisotropic {
                return Err(p.error(
                    p.pos("alpha_u"),
                    "roughplastic is isotropic (as in Mitsuba): give 'alpha', or equal 'alpha_u' and 'alpha_v'",
                ));
            }
            return Ok(Microfacet::anisotropic(dist, clamp(u), clamp(v)));
        }
        Ok(Microfacet::new(dist, clamp(alpha)))
    }

    /// The relative index `int_ior / ext_ior`; each is a number or a named material.
    /// A dielectric's relative index, and its dispersion when `int_ior` is a `<spectrum>` of
    /// λ:n pairs (a candela extension; RGB renders use the index at the sodium D line,
    /// [`REFERENCE_WAVELENGTH`]).
    fn dispersive_eta(&mut self, p: &Props) -> Result<(f32, Option<Box<Dispersion>>), SceneError> {
        let spectrum = match p.item("int_ior").map(|i| (&i.value, i.pos)) {
            Some((Value::Spectrum(s), pos)) => Some((s.clone(), pos)),
            Some((&Value::SpectrumFile(f, fpos), pos)) => Some((self.spectrum_file(f, fpos)?, pos)),
            _ => None,
        };
        let Some((s, pos)) = spectrum else {
            return Ok((self.eta(p, "bk7")?, None));
        };
        let interior = match s {
            Spectrum::Constant(c) => Ior::Constant(c),
            Spectrum::Tabulated(t) => Ior::Tabulated(t),
            _ => {
                return Err(p.error(
                    pos,
                    "'int_ior' as a spectrum must be a number or wavelength:index pairs",
                ))
            }
        };
        let n_d = interior.eval(REFERENCE_WAVELENGTH);
        let bad = |lambda: f32| !(interior.eval(lambda) > 0.0 && interior.eval(lambda).is_finite());
        if bad(n_d) || bad(LAMBDA_MIN) || bad(LAMBDA_MAX) {
            return Err(p.error(pos, "'int_ior' must be positive at every wavelength"));
        }
        let exterior = self.eta_of(p, "ext_ior", "air")?;
        Ok((
            n_d / exterior,
            Some(Box::new(Dispersion { interior, exterior })),
        ))
    }

    fn eta(&self, p: &Props, int_default: &str) -> Result<f32, SceneError> {
        Ok(self.eta_of(p, "int_ior", int_default)? / self.eta_of(p, "ext_ior", "air")?)
    }

    /// The index of refraction `name`: a number or one of Mitsuba's named materials.
    fn eta_of(&self, p: &Props, name: &str, default: &str) -> Result<f32, SceneError> {
        let ior = |name: &str, default: &str| -> Result<f32, SceneError> {
            let v = match p.item(name).map(|i| (&i.value, i.pos)) {
                None => presets::ior(default).unwrap_or(1.0),
                Some((Value::Str(s), pos)) => presets::ior(s).ok_or_else(|| {
                    p.error(
                        pos,
                        format!(
                            "unknown index of refraction '{s}' (known: {})",
                            presets::ior_names()
                        ),
                    )
                })?,
                Some((&Value::Float(v), _)) => v as f32,
                Some((&Value::Int(v), _)) => v as f32,
                Some((v, pos)) => {
                    return Err(p.error(
                        pos,
                        format!(
                            "'{name}' must be a number or a material name, not {}",
                            v.describe()
                        ),
                    ))
                }
            };
            if !(v > 0.0 && v.is_finite()) {
                return Err(p.error(p.pos(name), format!("'{name}' must be positive, not {v}")));
            }
            Ok(v)
        };
        ior(name, default)
    }

    /// A conductor's (η, k): from `eta` and `k`, or the named `material`; `None` for "none"
    /// (the perfect mirror, F = 1).
    fn conductor_ior(&mut self, p: &Props) -> Result<Option<(Texture, Texture)>, SceneError> {
        if p.has("eta") || p.has("k") {
            if p.has("material") {
                return Err(p.error(
                    p.pos("material"),
                    "give either 'material' or 'eta' and 'k', not both",
                ));
            }
            let (eta, k) = (
                self.colour(p, "eta", 0.0, RgbRole::Unbounded)?,
                self.colour(p, "k", 1.0, RgbRole::Unbounded)?,
            );
            // η = 0, k = 1 is Mitsuba's "none".
            let none = eta == (Rgb::BLACK, None) && k == (Rgb::WHITE, None);
            return Ok((!none).then(|| (colour_texture(eta), colour_texture(k))));
        }
        let name = p.or("material", "none".to_string())?;
        if name == "none" {
            return Ok(None);
        }
        let (eta, k) = presets::conductor(&name).ok_or_else(|| {
            p.error(
                p.pos("material"),
                format!(
                    "unknown conductor material '{name}' (known: none, {})",
                    presets::conductor_names()
                ),
            )
        })?;
        let rgb = |c: [f32; 3]| Rgb::new(c[0], c[1], c[2]);
        // The measured η(λ), k(λ) for spectral renders; Mitsuba's RGB values otherwise.
        Ok(Some(match candela_render::spectrum::metal(&name) {
            Some((se, sk)) => (
                Texture::spectrum(se, rgb(eta)),
                Texture::spectrum(sk, rgb(k)),
            ),
            None => (Texture::Uniform(rgb(eta)), Texture::Uniform(rgb(k))),
        }))
    }

    /// A property that may vary over a surface: a colour, a number, or a `<texture>`
    /// (`emitted`: see [`Loader::color`]).
    pub(super) fn tex(
        &mut self,
        p: &Props<'t>,
        name: &str,
        default: f32,
        emitted: bool,
        textured: &mut bool,
    ) -> Result<Texture, SceneError> {
        let nested = match p.item(name).map(|i| (&i.value, i.pos)) {
            Some((&Value::Object(e), pos)) if e.tag == "texture" => Some((e, pos)),
            Some((Value::Object(e), pos)) => {
                return Err(p.error(
                    pos,
                    format!(
                        "'{name}' must be a colour or a <texture>, not {}",
                        e.describe()
                    ),
                ))
            }
            _ => None,
        };
        let t = match nested {
            Some((e, _)) => self.texture_plugin(e)?,
            None => {
                let role = if emitted {
                    RgbRole::Emission
                } else {
                    RgbRole::Reflectance
                };
                colour_texture(self.colour(p, name, default, role)?)
            }
        };
        *textured |= varies(&t);
        Ok(t)
    }

    /// A `<texture>` element (built once per element).
    pub(super) fn texture_plugin(&mut self, e: &'t Element) -> Result<Texture, SceneError> {
        if let Some(t) = self.textures.get(&e.key()) {
            return Ok(t.clone());
        }
        self.enter(e)?;
        let p = self.props(e)?;
        let (scale, offset) = self.uv_transform(&p)?;
        let t = match e.kind() {
            "bitmap" => {
                let (name, pos) = p
                    .get::<String>("filename")?
                    .ok_or_else(|| p.error(e.pos, "bitmap needs a 'filename'"))?;
                let raw = p.or("raw", false)?;
                let filter = match p.choice("filter_type", &["bilinear", "nearest"])?.as_str() {
                    "nearest" => Filter::Nearest,
                    _ => Filter::Bilinear,
                };
                let wrap = match p
                    .choice("wrap_mode", &["repeat", "clamp", "mirror"])?
                    .as_str()
                {
                    "clamp" => Wrap::Clamp,
                    "mirror" => {
                        return Err(p.error(
                            p.pos("wrap_mode"),
                            "wrap_mode 'mirror' is not supported (use repeat or clamp)",
                        ))
                    }
                    _ => Wrap::Repeat,
                };
                p.ignore(&["format", "accel"]);
                Texture::Image(ImageTexture {
                    image: self.image(&name, raw, pos)?,
                    filter,
                    wrap: [wrap; 2],
                    scale,
                    offset,
                })
            }
            "checkerboard" => {
                let (c1, c2) = (
                    self.color(&p, "color0", 0.4, false)?,
                    self.color(&p, "color1", 0.2, false)?,
                );
                // Mitsuba: color0 where frac(u) and frac(v) of the transformed uv are on the
                // same side of ½, i.e. candela's checkerboard of 2 squares per unit of it.
                Texture::Checkered {
                    c1,
                    c2,
                    steps: scale.map(|s| 2.0 * s),
                    offset: offset.map(|o| 2.0 * o),
                }
            }
            other => {
                return Err(p.error(
                    e.pos,
                    format!("unsupported texture '{other}' (supported: bitmap, checkerboard)"),
                ))
            }
        };
        self.finish(&p);
        self.leave();
        self.textures.insert(e.key(), t.clone());
        Ok(t)
    }

    /// The scale and offset of `to_uv`, which must map u and v separately (scalings and
    /// translations; no rotation or shear).
    fn uv_transform(&self, p: &Props) -> Result<([f32; 2], [f32; 2]), SceneError> {
        let Some((m, pos)) = p.get::<super::math::M4>("to_uv")? else {
            return Ok(([1.0, 1.0], [0.0, 0.0]));
        };
        let m = m.0;
        let (scale, offset) = (
            [m[0][0] as f32, m[1][1] as f32],
            [m[0][3] as f32, m[1][3] as f32],
        );
        let usable = |x: f32| x.is_finite() && x.abs() <= 1e6;
        if m[0][1] != 0.0
            || m[1][0] != 0.0
            || scale.contains(&0.0)
            || !scale.iter().chain(&offset).all(|&x| usable(x))
        {
            return Err(p.error(
                pos,
                "to_uv: only scalings and translations of u and v are supported",
            ));
        }
        Ok((scale, offset))
    }

    /// The image `name` (resolved against the scene's folder), linear RGB. 8-bit images (PNG, JPEG, …)
    /// are sRGB-decoded unless `raw` (Mitsuba's `raw="true"` keeps the stored values).
    pub(super) fn image(
        &mut self,
        name: &str,
        raw: bool,
        pos: Pos,
    ) -> Result<Arc<Image>, SceneError> {
        let path = self.resolve(name);
        if let Some(i) = self.images.get(&(path.clone(), raw)) {
            return Ok(i.clone());
        }
        crate::inputs::record(&path);
        let mut img = candela_imageio::read_image_within(&path, &self.limits)
            .map_err(|e| self.err(pos, format!("cannot load image '{name}': {e}")))?;
        self.inputs.push(path.clone());
        if img.width() == 0 || img.height() == 0 {
            return Err(self.err(pos, format!("image '{name}' is empty")));
        }
        if raw && candela_imageio::is_srgb_encoded(&path) {
            for px in img.pixels_mut() {
                *px = px.map(candela_imageio::tonemap::srgb_oetf);
            }
        }
        let clamped = crate::loaded::clamp_texels(&mut img);
        if clamped > 0 {
            self.warn(
                pos,
                format!("image '{name}': {clamped} texels negative or not finite, clamped to 0"),
            );
        }
        let img = Arc::new(img);
        self.images.insert((path, raw), img.clone());
        Ok(img)
    }
}

/// A colour as a texture: uniform, or the spectrum it was given as (with its RGB conversion).
pub(super) fn colour_texture((rgb, spectrum): (Rgb, Option<Arc<Spectrum>>)) -> Texture {
    match spectrum {
        Some(s) => Texture::Spectral { rgb, spectrum: s },
        None => Texture::Uniform(rgb),
    }
}
