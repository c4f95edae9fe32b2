//! Materials: how surfaces scatter light.
//!
//! A closed set of models, each in its own file as it lands. Every material of the candela
//! language is two-sided (scene-language.md §2b).

use crate::color::Rgb;
use crate::math::Point2;
use crate::texture::Texture;

/// Index of a material in the scene's table.
pub type MaterialId = u32;

/// The closed set of materials.
#[derive(Clone, Debug, PartialEq)]
pub enum Material {
    /// Lambertian reflection ρ/π (the course's `diffuse`).
    Diffuse {
        /// Reflectance ρ.
        reflectance: Texture,
    },
    /// A perfect mirror scaled by a reflectance (the course's `specular`).
    Specular {
        /// Reflectance.
        reflectance: Texture,
    },
}

impl Material {
    /// The material's main colour at `uv` (what the `flat` renderer shows).
    pub fn base_color(&self, uv: Point2) -> Rgb {
        match self {
            Material::Diffuse { reflectance } | Material::Specular { reflectance } => reflectance.eval(uv),
        }
    }
}
