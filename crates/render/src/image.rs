//! HDR images: a grid of linear RGB pixels, row 0 at the top.

use crate::color::Rgb;

/// A high-dynamic-range image of linear RGB pixels, stored row-major with row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    width: usize,
    height: usize,
    pixels: Vec<Rgb>,
}

impl Image {
    /// A black image. Sizes of 0 are allowed (an empty image).
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            pixels: vec![Rgb::BLACK; width * height],
        }
    }

    /// Builds from pixels in row-major order, top row first; `None` if the count is wrong.
    pub fn from_pixels(width: usize, height: usize, pixels: Vec<Rgb>) -> Option<Self> {
        (width.checked_mul(height) == Some(pixels.len())).then_some(Self {
            width,
            height,
            pixels,
        })
    }

    /// Width in pixels.
    #[inline]
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    #[inline]
    pub fn height(&self) -> usize {
        self.height
    }

    /// All pixels, row-major, top row first.
    #[inline]
    pub fn pixels(&self) -> &[Rgb] {
        &self.pixels
    }

    /// All pixels, mutably.
    #[inline]
    pub fn pixels_mut(&mut self) -> &mut [Rgb] {
        &mut self.pixels
    }

    /// True when `(x, y)` lies inside the image.
    #[inline]
    pub fn valid(&self, x: usize, y: usize) -> bool {
        x < self.width && y < self.height
    }

    /// The pixel at column `x`, row `y` (row 0 at the top). Panics outside the image.
    #[inline]
    pub fn get(&self, x: usize, y: usize) -> Rgb {
        assert!(
            self.valid(x, y),
            "pixel ({x}, {y}) outside a {}×{} image",
            self.width,
            self.height
        );
        self.pixels[y * self.width + x]
    }

    /// Sets the pixel at column `x`, row `y`. Panics outside the image.
    #[inline]
    pub fn set(&mut self, x: usize, y: usize, c: Rgb) {
        assert!(
            self.valid(x, y),
            "pixel ({x}, {y}) outside a {}×{} image",
            self.width,
            self.height
        );
        self.pixels[y * self.width + x] = c;
    }

    /// The mean of all pixels, accumulated in f64.
    pub fn mean(&self) -> [f64; 3] {
        let mut s = [0f64; 3];
        for p in &self.pixels {
            s[0] += p.r as f64;
            s[1] += p.g as f64;
            s[2] += p.b as f64;
        }
        let n = self.pixels.len().max(1) as f64;
        s.map(|x| x / n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixels_are_row_major_top_first() {
        let mut img = Image::new(7, 4);
        assert_eq!(img.width(), 7);
        assert_eq!(img.height(), 4);
        assert!(img.valid(6, 3) && !img.valid(7, 0) && !img.valid(0, 4));
        img.set(3, 2, Rgb::new(1.0, 2.0, 3.0));
        assert_eq!(img.get(3, 2), Rgb::new(1.0, 2.0, 3.0));
        assert_eq!(img.pixels()[2 * 7 + 3], Rgb::new(1.0, 2.0, 3.0));
        assert!(Image::from_pixels(2, 2, vec![Rgb::BLACK; 3]).is_none());
        let m = img.mean();
        assert!((m[2] - 3.0 / 28.0).abs() < 1e-12);
    }
}
