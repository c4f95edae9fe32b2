//! Materials: pigments (uniform, checkered, image, spectra), BRDFs and their microfacet
//! distributions, and references to named materials.

use super::{PResult, Parser};
use crate::lang::ast::*;
use crate::lang::lexer::TokenKind;
use candela_render::spectrum::Spectrum;
use candela_render::Rgb;

impl Parser<'_> {
    pub(super) fn pigment(&mut self) -> PResult<Pigment> {
        let pos = self.tok.pos;
        let kind = if self.tok.is_symbol('<') {
            PigmentKind::Uniform(self.color()?)
        } else {
            match self.word().as_deref() {
                Some("uniform") => {
                    self.advance()?;
                    PigmentKind::Uniform(
                        self.args("uniform(<r, g, b>)", |p, a| p.arg(a, Self::color))?,
                    )
                }
                Some("checkered") => {
                    self.advance()?;
                    self.args("checkered(<r, g, b>, <r, g, b>, steps)", |p, a| {
                        Ok(PigmentKind::Checkered {
                            color1: p.arg(a, Self::color)?,
                            color2: p.arg(a, Self::color)?,
                            steps: p.arg(a, |p| {
                                p.checked_number(
                                    |n| n >= 1.0,
                                    "the number of steps must be at least 1",
                                )
                            })? as u32,
                        })
                    })?
                }
                Some("image") => {
                    self.advance()?;
                    PigmentKind::Image(self.args("image(\"file\")", |p, a| p.arg(a, Self::file))?)
                }
                Some("spectrum" | "blackbody") => PigmentKind::Spectrum(self.spectrum_def()?),
                _ => return Err(self.unexpected("a pigment")),
            }
        };
        Ok(Pigment { kind, pos })
    }

    /// A pigment of a BRDF (a reflectance or transmittance): any pigment but a blackbody.
    pub(super) fn reflectance(&mut self) -> PResult<Pigment> {
        let pigment = self.pigment()?;
        if let PigmentKind::Spectrum(SpectrumDef::Inline(Spectrum::Blackbody { .. })) = pigment.kind
        {
            return Err(self.error(
                pigment.pos,
                "a blackbody is an emission, not a reflectance: use it for a material's emission, a light or the environment",
            ));
        }
        Ok(pigment)
    }

    pub(super) fn brdf(&mut self) -> PResult<Brdf> {
        let pos = self.tok.pos;
        let word = self.word().unwrap_or_default();
        let positive = |what: &'static str| {
            move |p: &mut Self| p.checked_number(|x| x > 0.0, &format!("{what} must be positive"))
        };
        let exponent =
            |p: &mut Self| p.checked_number(|x| x >= 0.0, "the exponent must not be negative");
        let kind = match word.as_str() {
            "diffuse" | "specular" => {
                self.advance()?;
                let syntax = if word == "diffuse" {
                    "diffuse(pigment)"
                } else {
                    "specular(pigment)"
                };
                let pigment = self.args(syntax, |p, a| p.arg(a, Self::reflectance))?;
                if word == "diffuse" {
                    BrdfKind::Diffuse { kd: pigment }
                } else {
                    BrdfKind::Specular { ks: pigment }
                }
            }
            "phong" | "blinn_phong" => {
                self.advance()?;
                let syntax = if word == "phong" {
                    "phong(kd, ks, exponent)"
                } else {
                    "blinn_phong(kd, ks, exponent)"
                };
                let (kd, ks, exponent) = self.args(syntax, |p, a| {
                    Ok((
                        p.arg(a, Self::reflectance)?,
                        p.arg(a, Self::reflectance)?,
                        p.arg(a, exponent)?,
                    ))
                })?;
                if word == "phong" {
                    BrdfKind::Phong { kd, ks, exponent }
                } else {
                    BrdfKind::BlinnPhong { kd, ks, exponent }
                }
            }
            "cook_torrance" => {
                self.advance()?;
                self.args(
                    "cook_torrance(kd, ks, roughness [, ior [, \"beckmann\"|\"ggx\"]])",
                    |p, a| {
                        let kd = p.arg(a, Self::reflectance)?;
                        let ks = p.arg(a, Self::reflectance)?;
                        let roughness = p.arg(a, positive("the roughness"))?;
                        let mut ior = 1.5;
                        let mut distribution = Distribution::Ggx;
                        if p.more(a)? {
                            ior = p.arg(a, positive("the index of refraction"))?;
                            if p.more(a)? {
                                distribution = p.arg(a, Self::distribution)?;
                            }
                        }
                        Ok(BrdfKind::CookTorrance {
                            kd,
                            ks,
                            roughness,
                            ior,
                            distribution,
                        })
                    },
                )?
            }
            "glass" => {
                self.advance()?;
                self.args("glass(ior [, kt])", |p, a| {
                    let (ior, dispersion) = p.arg(a, Self::glass_ior)?;
                    let kt = if p.more(a)? {
                        p.arg(a, Self::reflectance)?
                    } else {
                        Pigment {
                            kind: PigmentKind::Uniform(Rgb::WHITE),
                            pos,
                        }
                    };
                    Ok(BrdfKind::Glass {
                        ior,
                        kt,
                        dispersion,
                    })
                })?
            }
            "metal" => {
                self.advance()?;
                self.metal()?
            }
            _ => return Err(self.unexpected("a BRDF")),
        };
        Ok(Brdf { kind, pos })
    }

    pub(super) fn distribution(&mut self) -> PResult<Distribution> {
        let distribution = match &self.tok.kind {
            TokenKind::Str(s) if s == "beckmann" => Distribution::Beckmann,
            TokenKind::Str(s) if s == "ggx" => Distribution::Ggx,
            _ => return Err(self.unexpected("\"beckmann\" or \"ggx\"")),
        };
        self.advance()?;
        Ok(distribution)
    }

    /// A material name that must exist.
    pub(super) fn material_ref(&mut self) -> PResult<MaterialRef> {
        let Some(name) = self.word() else {
            return Err(self.unexpected("a material name"));
        };
        let Some(&index) = self.desc.material_index.get(&name) else {
            return Err(self.error(self.tok.pos, format!("unknown material '{name}'")));
        };
        let pos = self.advance()?.pos;
        Ok(MaterialRef { name, index, pos })
    }

    // ----- shapes -----
}
