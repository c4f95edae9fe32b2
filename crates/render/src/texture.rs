//! Textures ("pigments" in the course): colours that vary over a surface's (u, v).
//!
//! - `uniform(<c>)`: the same colour everywhere.
//! - `checkered(<c1>, <c2>, n)`: `c1` where ⌊u·n⌋ and ⌊v·n⌋ have the same parity, else `c2`.
//! - `image("file")`: the image pixel at column ⌊u·W⌋ and row ⌊v·H⌋ (row 0 at the top; clamped)
//!   with nearest filtering, as in the course; bilinear filtering is optional.

use crate::color::Rgb;
use crate::image::Image;
use crate::math::Point2;
use std::sync::Arc;

/// How an image texture is looked up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    /// The pixel containing (u, v) (the course's lookup).
    Nearest,
    /// Bilinear interpolation of the four nearest pixel centres (wrapping in u).
    Bilinear,
}

/// The closed set of textures.
#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    /// A constant colour.
    Uniform(Rgb),
    /// A checkerboard of `steps × steps` squares over the unit uv square.
    Checkered {
        /// Colour of the squares whose indices have equal parity.
        c1: Rgb,
        /// Colour of the others.
        c2: Rgb,
        /// Squares per unit of u and v.
        steps: u32,
    },
    /// An image mapped onto the uv square.
    Image {
        /// The pixels (linear).
        image: Arc<Image>,
        /// The lookup.
        filter: Filter,
        /// Scales uv before the lookup (1 = the image covers the unit square once).
        scale: [f32; 2],
    },
}

impl Texture {
    /// The colour at (u, v).
    #[inline]
    pub fn eval(&self, uv: Point2) -> Rgb {
        match self {
            Texture::Uniform(c) => *c,
            Texture::Checkered { c1, c2, steps } => {
                let n = *steps as f32;
                let iu = (uv.x * n).floor() as i64;
                let iv = (uv.y * n).floor() as i64;
                if iu.rem_euclid(2) == iv.rem_euclid(2) {
                    *c1
                } else {
                    *c2
                }
            }
            Texture::Image { image, filter, scale } => {
                let (u, v) = (uv.x * scale[0], uv.y * scale[1]);
                match filter {
                    Filter::Nearest => nearest(image, u, v),
                    Filter::Bilinear => bilinear(image, u, v),
                }
            }
        }
    }

    /// The average colour (exact for uniform and checkered, the pixel mean for images).
    pub fn average(&self) -> Rgb {
        match self {
            Texture::Uniform(c) => *c,
            Texture::Checkered { c1, c2, .. } => (*c1 + *c2) * 0.5,
            Texture::Image { image, .. } => {
                let m = image.mean();
                Rgb::new(m[0] as f32, m[1] as f32, m[2] as f32)
            }
        }
    }

    /// The largest value of any channel anywhere (for bounds on emitted power).
    pub fn max_value(&self) -> f32 {
        match self {
            Texture::Uniform(c) => c.max_component(),
            Texture::Checkered { c1, c2, .. } => c1.max_component().max(c2.max_component()),
            Texture::Image { image, .. } => image.pixels().iter().fold(0.0, |m, p| m.max(p.max_component())),
        }
    }
}

fn nearest(image: &Image, u: f32, v: f32) -> Rgb {
    let (w, h) = (image.width(), image.height());
    if w == 0 || h == 0 {
        return Rgb::BLACK;
    }
    let col = ((u * w as f32) as i64).clamp(0, w as i64 - 1) as usize;
    let row = ((v * h as f32) as i64).clamp(0, h as i64 - 1) as usize;
    image.get(col, row)
}

fn bilinear(image: &Image, u: f32, v: f32) -> Rgb {
    let (w, h) = (image.width(), image.height());
    if w == 0 || h == 0 {
        return Rgb::BLACK;
    }
    let x = u * w as f32 - 0.5;
    let y = v * h as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let px = |i: i64| i.rem_euclid(w as i64) as usize;
    let py = |j: i64| j.clamp(0, h as i64 - 1) as usize;
    let (x0, y0) = (x0 as i64, y0 as i64);
    let a = image.get(px(x0), py(y0)) * (1.0 - fx) + image.get(px(x0 + 1), py(y0)) * fx;
    let b = image.get(px(x0), py(y0 + 1)) * (1.0 - fx) + image.get(px(x0 + 1), py(y0 + 1)) * fx;
    a * (1.0 - fy) + b * fy
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checkered_follows_the_course() {
        let c1 = Rgb::new(1.0, 2.0, 3.0);
        let c2 = Rgb::new(10.0, 20.0, 30.0);
        let t = Texture::Checkered { c1, c2, steps: 2 };
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
        let t = Texture::Image { image: Arc::new(img), filter: Filter::Nearest, scale: [1.0, 1.0] };
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
        let t = Texture::Image { image: Arc::new(img), filter: Filter::Bilinear, scale: [1.0, 1.0] };
        assert!((t.eval(Point2::new(0.5, 0.5)).r - 0.5).abs() < 1e-6);
        assert!((t.eval(Point2::new(0.75, 0.5)).r - 1.0).abs() < 1e-6);
        assert!((t.eval(Point2::new(0.25, 0.5)).r - 0.0).abs() < 1e-6);
    }
}
