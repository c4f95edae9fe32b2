//! RGB radiance and reflectance (linear, f32).

use std::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Sub};

/// A linear RGB triple: radiance, irradiance, reflectance or any per-channel quantity.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Rgb {
    /// Red.
    pub r: f32,
    /// Green.
    pub g: f32,
    /// Blue.
    pub b: f32,
}

impl Rgb {
    /// Black (0, 0, 0).
    pub const BLACK: Rgb = Rgb::new(0.0, 0.0, 0.0);
    /// White (1, 1, 1).
    pub const WHITE: Rgb = Rgb::new(1.0, 1.0, 1.0);

    /// Builds from three channels.
    #[inline]
    pub const fn new(r: f32, g: f32, b: f32) -> Self {
        Self { r, g, b }
    }

    /// The grey `(v, v, v)`.
    #[inline]
    pub const fn splat(v: f32) -> Self {
        Self::new(v, v, v)
    }

    /// True when all channels are exactly zero.
    #[inline]
    pub fn is_black(self) -> bool {
        self.r == 0.0 && self.g == 0.0 && self.b == 0.0
    }

    /// True when all channels are finite.
    #[inline]
    pub fn is_finite(self) -> bool {
        self.r.is_finite() && self.g.is_finite() && self.b.is_finite()
    }

    /// Largest channel.
    #[inline]
    pub fn max_component(self) -> f32 {
        self.r.max(self.g).max(self.b)
    }

    /// Smallest channel.
    #[inline]
    pub fn min_component(self) -> f32 {
        self.r.min(self.g).min(self.b)
    }

    /// Mean of the channels.
    #[inline]
    pub fn average(self) -> f32 {
        (self.r + self.g + self.b) / 3.0
    }

    /// Relative luminance Y of linear sRGB/Rec. 709 primaries.
    #[inline]
    pub fn luminance(self) -> f32 {
        0.2126 * self.r + 0.7152 * self.g + 0.0722 * self.b
    }

    /// The course's luminosity `(max + min) / 2`, used by its tone mapping.
    #[inline]
    pub fn luminosity(self) -> f32 {
        (self.max_component() + self.min_component()) / 2.0
    }

    /// Applies `f` to every channel.
    #[inline]
    pub fn map(self, f: impl Fn(f32) -> f32) -> Rgb {
        Rgb::new(f(self.r), f(self.g), f(self.b))
    }

    /// The channels as an array.
    #[inline]
    pub fn to_array(self) -> [f32; 3] {
        [self.r, self.g, self.b]
    }

    /// Channel-wise approximate equality.
    pub fn approx_eq(self, o: Rgb, eps: f32) -> bool {
        (self.r - o.r).abs() <= eps && (self.g - o.g).abs() <= eps && (self.b - o.b).abs() <= eps
    }
}

impl Add for Rgb {
    type Output = Rgb;
    #[inline]
    fn add(self, o: Rgb) -> Rgb {
        Rgb::new(self.r + o.r, self.g + o.g, self.b + o.b)
    }
}
impl AddAssign for Rgb {
    #[inline]
    fn add_assign(&mut self, o: Rgb) {
        *self = *self + o;
    }
}
impl Sub for Rgb {
    type Output = Rgb;
    #[inline]
    fn sub(self, o: Rgb) -> Rgb {
        Rgb::new(self.r - o.r, self.g - o.g, self.b - o.b)
    }
}
impl Mul for Rgb {
    type Output = Rgb;
    #[inline]
    fn mul(self, o: Rgb) -> Rgb {
        Rgb::new(self.r * o.r, self.g * o.g, self.b * o.b)
    }
}
impl MulAssign for Rgb {
    #[inline]
    fn mul_assign(&mut self, o: Rgb) {
        *self = *self * o;
    }
}
impl Mul<f32> for Rgb {
    type Output = Rgb;
    #[inline]
    fn mul(self, s: f32) -> Rgb {
        Rgb::new(self.r * s, self.g * s, self.b * s)
    }
}
impl Mul<Rgb> for f32 {
    type Output = Rgb;
    #[inline]
    fn mul(self, c: Rgb) -> Rgb {
        c * self
    }
}
impl MulAssign<f32> for Rgb {
    #[inline]
    fn mul_assign(&mut self, s: f32) {
        *self = *self * s;
    }
}
impl Div<f32> for Rgb {
    type Output = Rgb;
    #[inline]
    fn div(self, s: f32) -> Rgb {
        self * (1.0 / s)
    }
}
impl Div for Rgb {
    type Output = Rgb;
    #[inline]
    fn div(self, o: Rgb) -> Rgb {
        Rgb::new(self.r / o.r, self.g / o.g, self.b / o.b)
    }
}
impl DivAssign<f32> for Rgb {
    #[inline]
    fn div_assign(&mut self, s: f32) {
        *self = *self / s;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_arithmetic_by_hand() {
        let a = Rgb::new(1.0, 2.0, 3.0);
        let b = Rgb::new(5.0, 6.0, 7.0);
        assert_eq!(a + b, Rgb::new(6.0, 8.0, 10.0));
        assert_eq!(a * b, Rgb::new(5.0, 12.0, 21.0));
        assert_eq!(a * 2.0, Rgb::new(2.0, 4.0, 6.0));
        assert_eq!(b - a, Rgb::new(4.0, 4.0, 4.0));
        assert_eq!(a.luminosity(), 2.0);
        assert_eq!(Rgb::new(9.0, 5.0, 1.0).luminosity(), 5.0);
        assert!((Rgb::WHITE.luminance() - 1.0).abs() < 1e-6);
        assert!(Rgb::BLACK.is_black());
        assert!(!Rgb::new(f32::NAN, 0.0, 0.0).is_finite());
    }
}
