//! Mitsuba `<sensor>` plugins (perspective, orthographic, thin lens) with their `<film>` and
//! `<sampler>`: the camera, the image size and the sample count.

use super::math::M4;
use super::props::Props;
use super::xml::Element;
use super::Loader;
use crate::error::SceneError;
use crate::loaded::RenderHints;
use candela_render::camera::{Camera, Lens};
use candela_render::filter::Filter;
use candela_render::math::Transform;

impl<'t> Loader<'t> {
    /// `<sensor>`: the camera and the film, sampler hints.
    pub(super) fn sensor(&mut self, e: &'t Element) -> Result<(), SceneError> {
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
            self.warn(e.pos, "no <film>: Mitsuba's default 768×576 film");
            self.hints.filter = Some(Filter::Gaussian { stddev: 0.5 });
        }
        if let Some((s, _)) = p.object("sampler")? {
            let sp = self.props(s)?;
            self.hints.spp =
                Some(sp.int_in("sample_count", 4, (1, crate::loaded::MAX_SPP as i64))? as u32);
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

    /// `<rfilter>`: Mitsuba's reconstruction filters with their parameters and defaults.
    fn rfilter(&mut self, e: &'t Element) -> Result<Filter, SceneError> {
        let p = self.props(e)?;
        let filter = match e.kind() {
            "box" => Filter::Box,
            "tent" => Filter::Tent {
                radius: p.number_in("radius", 1.0, (1e-3, 64.0))? as f32,
            },
            "gaussian" => Filter::Gaussian {
                stddev: p.number_in("stddev", 0.5, (1e-3, 16.0))? as f32,
            },
            "mitchell" => Filter::Mitchell {
                b: p.number_in("B", 1.0 / 3.0, (-100.0, 100.0))? as f32,
                c: p.number_in("C", 1.0 / 3.0, (-100.0, 100.0))? as f32,
            },
            "catmullrom" => Filter::Mitchell { b: 0.0, c: 0.5 },
            "lanczos" => Filter::Lanczos {
                lobes: p.int_in("lobes", 3, (1, 64))? as u32,
            },
            other => {
                return Err(self.err(
                    e.pos,
                    format!(
                        "unknown reconstruction filter '{other}' (expected one of: {})",
                        candela_render::filter::FILTER_NAMES.join(", ")
                    ),
                ))
            }
        };
        self.finish(&p);
        Ok(filter)
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
        const MAX: i64 = crate::loaded::MAX_SIDE as i64;
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
        self.hints.filter = Some(match p.object("rfilter")? {
            Some((f, _)) => self.rfilter(f)?,
            None => Filter::Gaussian { stddev: 0.5 },
        });
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
}

/// A camera for scenes without one (older Mitsuba versions' default): 45° horizontal field of
/// view, looking along +z at the centre of the scene's bounds from far enough to see all of it.
pub(super) fn default_camera(b: &candela_render::math::Bounds3, hints: &RenderHints) -> Camera {
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
