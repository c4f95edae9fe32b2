//! Textures ("pigments" in the course): colours that vary over a surface's (u, v).
//!
//! - `uniform(<c>)`: the same colour everywhere.
//! - `checkered(<c1>, <c2>, n)`: `c1` where ⌊u·n⌋ and ⌊v·n⌋ have the same parity, else `c2`.
//! - `image("file")`: the image pixel at column ⌊u·W⌋ and row ⌊v·H⌋ (row 0 at the top; clamped)
//!   with nearest filtering, as in the course. Image textures may also filter bilinearly, repeat
//!   instead of clamping, and scale and offset (u, v) first (Mitsuba's `bitmap` and `envmap`).
//! - a [`Spectrum`] (a tabulated or measured spectrum, a blackbody, or an RGB colour upsampled
//!   once when the scene is prepared for spectral rendering): the same everywhere, its RGB
//!   conversion in RGB mode.
//!
//! [`Texture::eval`] gives the RGB colour; [`Texture::spectral`] gives the four lanes a path
//! carries ([`Wavelengths`]): the RGB colour in RGB mode, the spectrum at the sampled wavelengths
//! in spectral mode (RGB colours upsampled according to what they stand for, [`RgbRole`]).

use crate::color::Rgb;
use crate::image::Image;
use crate::math::{floor_i64, Point2};
use crate::spectrum::{upsample, RgbRole, SampledSpectrum, Spectrum, Wavelengths};
use std::sync::Arc;

/// How an image texture is looked up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    /// The pixel containing (u, v) (the course's lookup).
    Nearest,
    /// Bilinear interpolation of the four nearest pixel centres (wrapping in u).
    Bilinear,
}

/// What an image lookup does outside [0, 1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    /// Clamp to the border pixels (the course).
    Clamp,
    /// Repeat the image periodically.
    Repeat,
}

/// An image mapped onto the uv square: the lookup point is `uv·scale + offset`.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageTexture {
    /// The pixels (linear).
    pub image: Arc<Image>,
    /// The lookup.
    pub filter: Filter,
    /// Behaviour outside [0, 1) in u and in v.
    pub wrap: [Wrap; 2],
    /// Scales uv before the lookup.
    pub scale: [f32; 2],
    /// Added to uv after scaling.
    pub offset: [f32; 2],
}

impl ImageTexture {
    /// The course's lookup of `image`: nearest pixel, clamped, uv as is.
    pub fn new(image: Arc<Image>) -> Self {
        Self {
            image,
            filter: Filter::Nearest,
            wrap: [Wrap::Clamp; 2],
            scale: [1.0, 1.0],
            offset: [0.0, 0.0],
        }
    }

    /// The colour at (u, v).
    #[inline]
    pub fn eval(&self, uv: Point2) -> Rgb {
        let (w, h) = (self.image.width(), self.image.height());
        if w == 0 || h == 0 {
            return Rgb::BLACK;
        }
        let u = uv.x * self.scale[0] + self.offset[0];
        let v = uv.y * self.scale[1] + self.offset[1];
        let index = |i: i64, n: usize, wrap: Wrap| match wrap {
            Wrap::Clamp => i.clamp(0, n as i64 - 1) as usize,
            // Within one period of the image (every lookup of coordinates in [0, 1]) without
            // the integer division of `rem_euclid`, four per bilinear lookup (a frame under
            // an environment map: about 1 % faster).
            Wrap::Repeat => {
                let n = n as i64;
                let r = if i < 0 {
                    i + n
                } else if i >= n {
                    i - n
                } else {
                    i
                };
                if (0..n).contains(&r) {
                    r as usize
                } else {
                    i.rem_euclid(n) as usize
                }
            }
        };
        match self.filter {
            Filter::Nearest => {
                let col = index(floor_i64(u * w as f32), w, self.wrap[0]);
                let row = index(floor_i64(v * h as f32), h, self.wrap[1]);
                self.image.get(col, row)
            }
            Filter::Bilinear => {
                let x = u * w as f32 - 0.5;
                let y = v * h as f32 - 0.5;
                let (x0, y0) = (floor_i64(x), floor_i64(y));
                let (fx, fy) = (x - x0 as f32, y - y0 as f32);
                let px = |i: i64| index(i, w, self.wrap[0]);
                let py = |j: i64| index(j, h, self.wrap[1]);
                let img = &self.image;
                let a = img.get(px(x0), py(y0)) * (1.0 - fx) + img.get(px(x0 + 1), py(y0)) * fx;
                let b =
                    img.get(px(x0), py(y0 + 1)) * (1.0 - fx) + img.get(px(x0 + 1), py(y0 + 1)) * fx;
                a * (1.0 - fy) + b * fy
            }
        }
    }
}

/// The closed set of textures.
#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    /// A constant colour.
    Uniform(Rgb),
    /// A checkerboard: square (i, j) holds the point with ⌊u·steps_u + offset_u⌋ = i and
    /// ⌊v·steps_v + offset_v⌋ = j (the course's `steps × steps` squares over the unit uv square
    /// when both steps are `steps` and the offsets 0).
    Checkered {
        /// Colour of the squares whose indices have equal parity.
        c1: Rgb,
        /// Colour of the others.
        c2: Rgb,
        /// Squares per unit of u and of v.
        steps: [f32; 2],
        /// Shift of the pattern, in squares along u and v.
        offset: [f32; 2],
    },
    /// An image mapped onto the uv square.
    Image(ImageTexture),
    /// A spectrum, the same everywhere.
    Spectral {
        /// Its colour in RGB mode (the conversion Mitsuba's RGB variants make).
        rgb: Rgb,
        /// The spectrum.
        spectrum: Arc<Spectrum>,
    },
}

impl Texture {
    /// The colour at (u, v).
    #[inline(always)]
    pub fn eval(&self, uv: Point2) -> Rgb {
        // Uniform colours, the common case, without a call.
        match self {
            Texture::Uniform(c) => *c,
            _ => self.eval_varying(uv),
        }
    }

    /// The value at (u, v) in the lanes of a path: the colour in RGB mode; in spectral mode
    /// the spectrum at the sampled wavelengths (RGB colours upsampled in `role`).
    #[inline(always)]
    pub fn spectral(&self, uv: Point2, w: &Wavelengths, role: RgbRole) -> SampledSpectrum {
        match (self, w) {
            // Read straight from the texture: a colour merged from the two arms of `eval`
            // goes through the stack, in pieces a whole-vector load cannot be forwarded from.
            // `from_rgb_whole`: the colour is made in one vector register, so that where the
            // arms meet in memory (the other arms' results are returned there) it is written
            // with one store, which a whole-vector load is forwarded from; `from_rgb` wrote
            // it as two halves (a store-forwarding stall at every lookup).
            (Texture::Uniform(c), Wavelengths::Rgb) => SampledSpectrum::from_rgb_whole(*c),
            // A measured spectrum (a named metal's index) has its colour ready.
            (Texture::Spectral { rgb, .. }, Wavelengths::Rgb) => {
                SampledSpectrum::from_rgb_whole(*rgb)
            }
            _ => self.spectral_varying(uv, w, role),
        }
    }

    /// [`Texture::spectral`] for everything but a uniform colour in RGB mode.
    #[inline(never)]
    fn spectral_varying(&self, uv: Point2, w: &Wavelengths, role: RgbRole) -> SampledSpectrum {
        match (self, w) {
            (Texture::Uniform(c), Wavelengths::Rgb) => SampledSpectrum::from_rgb(*c),
            (_, Wavelengths::Rgb) => SampledSpectrum::from_rgb(self.eval_varying(uv)),
            (Texture::Spectral { spectrum, .. }, Wavelengths::Sampled(s)) => spectrum.eval4(s),
            _ => w.colour(self.eval(uv), role),
        }
    }

    /// True when the texture is the same everywhere (it never reads texture coordinates).
    pub fn is_constant(&self) -> bool {
        matches!(self, Texture::Uniform(_) | Texture::Spectral { .. })
    }

    /// A spectrum as a texture (`rgb`: its colour in RGB mode).
    pub fn spectrum(spectrum: Spectrum, rgb: Rgb) -> Self {
        Texture::Spectral {
            rgb,
            spectrum: Arc::new(spectrum),
        }
    }

    /// Readies the texture for spectral rendering in `role`: a uniform colour is upsampled
    /// once here rather than at every lookup. Nothing changes in RGB mode.
    pub fn prepare_spectral(&mut self, role: RgbRole) {
        if let Texture::Uniform(c) = *self {
            *self = Texture::spectrum(upsample(c, role), c);
        }
    }

    /// [`Texture::eval`] for the textures that vary over the surface.
    #[inline(never)]
    fn eval_varying(&self, uv: Point2) -> Rgb {
        match self {
            Texture::Uniform(c) => *c,
            Texture::Checkered {
                c1,
                c2,
                steps,
                offset,
            } => {
                let iu = floor_i64(uv.x * steps[0] + offset[0]);
                let iv = floor_i64(uv.y * steps[1] + offset[1]);
                if iu.rem_euclid(2) == iv.rem_euclid(2) {
                    *c1
                } else {
                    *c2
                }
            }
            Texture::Image(t) => t.eval(uv),
            Texture::Spectral { rgb, .. } => *rgb,
        }
    }

    /// The average colour (exact for uniform and checkered, the pixel mean for images).
    pub fn average(&self) -> Rgb {
        match self {
            Texture::Uniform(c) | Texture::Spectral { rgb: c, .. } => *c,
            Texture::Checkered { c1, c2, .. } => (*c1 + *c2) * 0.5,
            Texture::Image(t) => {
                let m = t.image.mean();
                Rgb::new(m[0] as f32, m[1] as f32, m[2] as f32)
            }
        }
    }

    /// The largest value of any channel anywhere (for bounds on emitted power).
    pub fn max_value(&self) -> f32 {
        match self {
            Texture::Uniform(c) | Texture::Spectral { rgb: c, .. } => c.max_component(),
            Texture::Checkered { c1, c2, .. } => c1.max_component().max(c2.max_component()),
            Texture::Image(t) => t
                .image
                .pixels()
                .iter()
                .fold(0.0, |m, p| m.max(p.max_component())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_texture_gives_the_same_lanes_by_either_path() {
        let w = Wavelengths::Rgb;
        let c = Rgb::new(0.25, 0.5, 0.75);
        let textures = [
            Texture::Uniform(c),
            Texture::Checkered {
                c1: c,
                c2: Rgb::splat(2.0),
                steps: [2.0; 2],
                offset: [0.0; 2],
            },
            Texture::spectrum(Spectrum::Constant(0.5), c),
        ];
        for t in &textures {
            for uv in [Point2::new(0.25, 0.25), Point2::new(0.75, 0.25)] {
                let want = SampledSpectrum::from_rgb(t.eval(uv));
                assert_eq!(t.spectral(uv, &w, RgbRole::Reflectance), want);
                assert_eq!(t.spectral_varying(uv, &w, RgbRole::Reflectance), want);
            }
        }
    }

    #[test]
    fn checkered_follows_the_course() {
        let c1 = Rgb::new(1.0, 2.0, 3.0);
        let c2 = Rgb::new(10.0, 20.0, 30.0);
        let t = Texture::Checkered {
            c1,
            c2,
            steps: [2.0; 2],
            offset: [0.0; 2],
        };
        assert_eq!(t.eval(Point2::new(0.25, 0.25)), c1);
        assert_eq!(t.eval(Point2::new(0.75, 0.25)), c2);
        assert_eq!(t.eval(Point2::new(0.25, 0.75)), c2);
        assert_eq!(t.eval(Point2::new(0.75, 0.75)), c1);
        assert_eq!(t.eval(Point2::new(-0.25, 0.25)), c2);
    }

    #[test]
    fn image_lookup_follows_the_course() {
        let mut img = Image::new(2, 2);
        img.set(0, 0, Rgb::new(1.0, 2.0, 3.0));
        img.set(1, 0, Rgb::new(2.0, 3.0, 1.0));
        img.set(0, 1, Rgb::new(2.0, 1.0, 3.0));
        img.set(1, 1, Rgb::new(3.0, 2.0, 1.0));
        let t = Texture::Image(ImageTexture::new(Arc::new(img)));
        assert_eq!(t.eval(Point2::new(0.0, 0.0)), Rgb::new(1.0, 2.0, 3.0));
        assert_eq!(t.eval(Point2::new(1.0, 0.0)), Rgb::new(2.0, 3.0, 1.0));
        assert_eq!(t.eval(Point2::new(0.0, 1.0)), Rgb::new(2.0, 1.0, 3.0));
        assert_eq!(t.eval(Point2::new(1.0, 1.0)), Rgb::new(3.0, 2.0, 1.0));
    }

    #[test]
    fn bilinear_interpolates_between_pixel_centres() {
        let mut img = Image::new(2, 1);
        img.set(0, 0, Rgb::splat(0.0));
        img.set(1, 0, Rgb::splat(1.0));
        let mut t = ImageTexture::new(Arc::new(img));
        t.filter = Filter::Bilinear;
        t.wrap = [Wrap::Clamp; 2];
        assert!((t.eval(Point2::new(0.5, 0.5)).r - 0.5).abs() < 1e-6);
        assert!((t.eval(Point2::new(0.75, 0.5)).r - 1.0).abs() < 1e-6);
        assert!((t.eval(Point2::new(0.25, 0.5)).r - 0.0).abs() < 1e-6);
        // Repeating, the left border blends with the right column.
        t.wrap = [Wrap::Repeat; 2];
        assert!((t.eval(Point2::new(0.0, 0.5)).r - 0.5).abs() < 1e-6);
        // Nearest with repeat wraps whole images; offset shifts the lookup.
        t.filter = Filter::Nearest;
        assert_eq!(t.eval(Point2::new(1.25, 0.5)).r, 0.0);
        t.offset = [0.5, 0.0];
        assert_eq!(t.eval(Point2::new(0.25, 0.5)).r, 1.0);
    }
}
