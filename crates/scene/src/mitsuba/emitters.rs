//! Mitsuba `<emitter>` plugins that are not shapes: point, spot, directional, constant and
//! environment maps (area emitters are attached to shapes in `shapes`).

use super::math::M4;
use super::xml::Element;
use super::Loader;
use crate::error::SceneError;
use candela_render::light::{
    Components, DistantLight, Environment, Falloff, Light, PointLight, SpotLight, SpotPattern,
    SpotProfile,
};
use candela_render::math::{Point3, Transform, Vec3};
use candela_render::spectrum::RgbRole;
use candela_render::texture::{Filter, ImageTexture, Texture, Wrap};
use std::sync::Arc;

impl<'t> Loader<'t> {
    /// A top-level `<emitter>` (area emitters belong to shapes).
    pub(super) fn emitter(&mut self, e: &'t Element) -> Result<(), SceneError> {
        let p = self.props(e)?;
        p.ignore(&["sampling_weight"]);
        let light = match e.kind() {
            kind @ ("point" | "spot") => {
                let (intensity, spectrum) = self.colour(&p, "intensity", 1.0, RgbRole::Emission)?;
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
                            spectrum: spectrum.clone(),
                            falloff: Falloff::INVERSE_SQUARE,
                        },
                        Components::from_intensity(intensity),
                    )
                } else {
                    let cutoff = p.number_in("cutoff_angle", 20.0, (0.0, 180.0))?;
                    let beam = p.number_in("beam_width", cutoff * 0.75, (0.0, cutoff))?;
                    let axis = unit(m.vector([0.0, 0.0, 1.0])).ok_or_else(|| p.error(p.pos("to_world"), "the spot's axis is degenerate"))?;
                    // Mitsuba's projected texture, in the light's frame (x, y of to_world).
                    let pattern = if p.has("texture") {
                        let mut textured = false;
                        let texture = self.tex(&p, "texture", 1.0, false, &mut textured)?;
                        let x = unit(m.vector([1.0, 0.0, 0.0])).ok_or_else(|| p.error(p.pos("to_world"), "the spot's frame is degenerate"))?;
                        let y = unit(m.vector([0.0, 1.0, 0.0])).ok_or_else(|| p.error(p.pos("to_world"), "the spot's frame is degenerate"))?;
                        Some(Box::new(SpotPattern { x, y, uv_factor: cutoff.to_radians().tan() as f32, texture }))
                    } else {
                        None
                    };
                    Light::Spot(
                        SpotLight {
                            position,
                            axis,
                            intensity,
                            spectrum,
                            cos_cutoff: cutoff.to_radians().cos() as f32,
                            profile: SpotProfile::linear(beam.to_radians().cos() as f32, cutoff.to_radians().cos() as f32),
                            falloff: Falloff::INVERSE_SQUARE,
                            pattern,
                        },
                        Components::from_intensity(intensity),
                    )
                }
            }
            "directional" => {
                let (irradiance, spectrum) = self.colour(&p, "irradiance", 1.0, RgbRole::Emission)?;
                let (m, _) = self.to_world(&p)?;
                let dir = match p.get::<[f64; 3]>("direction")? {
                    Some(_) if p.has("to_world") => return Err(p.error(p.pos("direction"), "give either 'direction' or 'to_world', not both")),
                    Some((v, _)) => v,
                    None => m.vector([0.0, 0.0, 1.0]),
                };
                let direction = unit(dir).ok_or_else(|| p.error(p.pos("direction"), "the direction must not be the zero vector"))?;
                Light::Distant(DistantLight { direction, irradiance, spectrum }, Components::from_intensity(irradiance))
            }
            "constant" => {
                let radiance = super::bsdfs::colour_texture(self.colour(&p, "radiance", 1.0, RgbRole::Emission)?);
                Light::Environment(Environment::new(radiance, Transform::IDENTITY))
            }
            "envmap" => {
                let (m, _) = self.to_world(&p)?;
                let (name, pos) = p.get::<String>("filename")?.ok_or_else(|| p.error(e.pos, "envmap needs a 'filename'"))?;
                let mut image = self.image(&name, false, pos)?;
                let scale = p.number_in("scale", 1.0, (0.0, f32::MAX as f64))? as f32;
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
