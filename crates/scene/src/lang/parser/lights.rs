//! Light statements: point, spot, distant, hemisphere and ambient lights and the environment.

use super::{Args, PResult, Parser};
use crate::lang::ast::*;
use candela_render::math::Vec3;

impl Parser<'_> {
    /// The optional trailing `attenuation(c1, c2, c3)` (when `attenuation` is true) and
    /// `components(<Ia>, <Id>, <Is>)` of a light, in any order, each at most once.
    pub(super) fn light_options(
        &mut self,
        args: &mut Args,
        attenuation: bool,
    ) -> PResult<(Option<Attenuation>, Option<Components>)> {
        let (mut att, mut comp) = (None, None);
        while self.more(args)? {
            let pos = self.tok.pos;
            let word = self.word();
            let twice = |p: &Self, w: &str| p.error(pos, format!("'{w}' is given twice"));
            match word.as_deref() {
                Some(w @ "attenuation") if attenuation => {
                    if att.is_some() {
                        return Err(twice(self, w));
                    }
                    self.advance()?;
                    att = Some(self.arg(args, |p| {
                        p.args("attenuation(c1, c2, c3)", |p, a| {
                            let mut c = || {
                                p.arg(a, |p| {
                                    p.checked_number(
                                        |x| x >= 0.0,
                                        "an attenuation coefficient must not be negative",
                                    )
                                })
                            };
                            Ok(Attenuation {
                                constant: c()?,
                                linear: c()?,
                                quadratic: c()?,
                            })
                        })
                    })?);
                }
                Some(w @ "components") => {
                    if comp.is_some() {
                        return Err(twice(self, w));
                    }
                    self.advance()?;
                    comp = Some(self.arg(args, |p| {
                        p.args("components(<Ia>, <Id>, <Is>)", |p, a| {
                            Ok(Components {
                                ambient: p.arg(a, Self::color)?,
                                diffuse: p.arg(a, Self::color)?,
                                specular: p.arg(a, Self::color)?,
                            })
                        })
                    })?);
                }
                _ if attenuation => {
                    return Err(self.unexpected("'attenuation(…)' or 'components(…)'"))
                }
                _ => return Err(self.unexpected("'components(…)'")),
            }
        }
        Ok((att, comp))
    }

    pub(super) fn light(&mut self, word: &str) -> PResult<Light> {
        let pos = self.advance()?.pos;
        let cutoff = |p: &mut Self| {
            p.checked_number(
                |x| x > 0.0 && x <= 180.0,
                "the cutoff angle must be in (0, 180] degrees",
            )
        };
        let exponent =
            |p: &mut Self| p.checked_number(|x| x >= 0.0, "the exponent must not be negative");
        let mut spectrum = None;
        let (kind, components) = match word {
            "point_light" => self.args(
                "point_light([position], <r, g, b> | spectrum, radius [, attenuation(c1, c2, c3)] [, components(<Ia>, <Id>, <Is>)])",
                |p, a| {
                    let position = p.arg(a, Self::point)?;
                    let (intensity, s) = p.arg(a, Self::light_colour)?;
                    spectrum = s;
                    let radius = p.arg(a, Self::number)?;
                    let (attenuation, components) = p.light_options(a, true)?;
                    let kind = LightKind::Point { position, intensity, radius, attenuation };
                    Ok((kind, components))
                },
            )?,
            "spot_light" => self.args(
                "spot_light([position], [direction], <r, g, b> | spectrum, cutoff_degrees, exponent [, attenuation(c1, c2, c3)] [, components(<Ia>, <Id>, <Is>)])",
                |p, a| {
                    let position = p.arg(a, Self::point)?;
                    let direction = p.arg(a, Self::direction)?;
                    let (intensity, s) = p.arg(a, Self::light_colour)?;
                    spectrum = s;
                    let cutoff_deg = p.arg(a, cutoff)?;
                    let exponent = p.arg(a, exponent)?;
                    let (attenuation, components) = p.light_options(a, true)?;
                    let kind = LightKind::Spot {
                        position,
                        direction,
                        intensity,
                        cutoff_deg,
                        exponent,
                        attenuation,
                    };
                    Ok((kind, components))
                },
            )?,
            "distant_light" => self.args(
                "distant_light([direction], <r, g, b> | spectrum [, components(<Ia>, <Id>, <Is>)])",
                |p, a| {
                    let direction = p.arg(a, Self::direction)?;
                    let (intensity, s) = p.arg(a, Self::light_colour)?;
                    spectrum = s;
                    let (_, components) = p.light_options(a, false)?;
                    Ok((LightKind::Distant { direction, intensity }, components))
                },
            )?,
            _ => self.args(
                "hemisphere_light(<r, g, b> [, [up]] [, components(<Ia>, <Id>, <Is>)])",
                |p, a| {
                    if p.at_spectrum() {
                        return Err(p.error(
                            p.tok.pos,
                            "hemisphere_light takes an RGB colour '<r, g, b>' (spectra are for point, spot and distant lights, emissions and the environment)",
                        ));
                    }
                    let intensity = p.arg(a, Self::color)?;
                    let mut up = Vec3::Z;
                    if p.more(a)? && p.tok.is_symbol('[') {
                        up = p.arg(a, Self::direction)?;
                    }
                    let (_, components) = p.light_options(a, false)?;
                    Ok((LightKind::Hemisphere { intensity, up }, components))
                },
            )?,
        };
        Ok(Light {
            kind,
            components,
            spectrum,
            pos,
        })
    }

    // ----- statements -----
}
