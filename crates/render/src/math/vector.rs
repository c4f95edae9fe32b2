//! Vectors, points and normals in 3D (f32), kept as distinct types.
//!
//! `Vec3` is a direction or displacement, `Point3` a position, `Normal3` a surface normal. They
//! transform differently (see [`crate::math::Transform`]), so the type system keeps them apart:
//! `Point3 - Point3 = Vec3`, `Point3 + Vec3 = Point3`, and a `Normal3` converts to a `Vec3` only
//! explicitly.

use std::ops::{Add, AddAssign, Div, Index, Mul, MulAssign, Neg, Sub, SubAssign};

macro_rules! triple {
    ($(#[$doc:meta])* $name:ident) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, Default, PartialEq)]
        pub struct $name {
            /// x component.
            pub x: f32,
            /// y component.
            pub y: f32,
            /// z component.
            pub z: f32,
        }

        impl $name {
            /// Builds from three components.
            #[inline]
            pub const fn new(x: f32, y: f32, z: f32) -> Self {
                Self { x, y, z }
            }
            /// The components as an array.
            #[inline]
            pub fn to_array(self) -> [f32; 3] {
                [self.x, self.y, self.z]
            }
            /// Builds from an array.
            #[inline]
            pub fn from_array(a: [f32; 3]) -> Self {
                Self::new(a[0], a[1], a[2])
            }
            /// Component-wise minimum.
            #[inline]
            pub fn min(self, o: Self) -> Self {
                Self::new(self.x.min(o.x), self.y.min(o.y), self.z.min(o.z))
            }
            /// Component-wise maximum.
            #[inline]
            pub fn max(self, o: Self) -> Self {
                Self::new(self.x.max(o.x), self.y.max(o.y), self.z.max(o.z))
            }
            /// True when every component is finite.
            #[inline]
            pub fn is_finite(self) -> bool {
                self.x.is_finite() && self.y.is_finite() && self.z.is_finite()
            }
            /// Component-wise approximate equality (absolute tolerance `eps`).
            pub fn approx_eq(self, o: Self, eps: f32) -> bool {
                (self.x - o.x).abs() <= eps && (self.y - o.y).abs() <= eps && (self.z - o.z).abs() <= eps
            }
        }

        impl Index<usize> for $name {
            type Output = f32;
            #[inline]
            fn index(&self, i: usize) -> &f32 {
                match i {
                    0 => &self.x,
                    1 => &self.y,
                    _ => &self.z,
                }
            }
        }
    };
}

macro_rules! linear_ops {
    ($name:ident) => {
        impl Add for $name {
            type Output = $name;
            #[inline]
            fn add(self, o: $name) -> $name {
                $name::new(self.x + o.x, self.y + o.y, self.z + o.z)
            }
        }
        impl AddAssign for $name {
            #[inline]
            fn add_assign(&mut self, o: $name) {
                *self = *self + o;
            }
        }
        impl Sub for $name {
            type Output = $name;
            #[inline]
            fn sub(self, o: $name) -> $name {
                $name::new(self.x - o.x, self.y - o.y, self.z - o.z)
            }
        }
        impl SubAssign for $name {
            #[inline]
            fn sub_assign(&mut self, o: $name) {
                *self = *self - o;
            }
        }
        impl Neg for $name {
            type Output = $name;
            #[inline]
            fn neg(self) -> $name {
                $name::new(-self.x, -self.y, -self.z)
            }
        }
        impl Mul<f32> for $name {
            type Output = $name;
            #[inline]
            fn mul(self, s: f32) -> $name {
                $name::new(self.x * s, self.y * s, self.z * s)
            }
        }
        impl Mul<$name> for f32 {
            type Output = $name;
            #[inline]
            fn mul(self, v: $name) -> $name {
                v * self
            }
        }
        impl MulAssign<f32> for $name {
            #[inline]
            fn mul_assign(&mut self, s: f32) {
                *self = *self * s;
            }
        }
        impl Div<f32> for $name {
            type Output = $name;
            #[inline]
            fn div(self, s: f32) -> $name {
                let inv = 1.0 / s;
                self * inv
            }
        }
        impl $name {
            /// Dot product.
            #[inline]
            pub fn dot(self, o: $name) -> f32 {
                self.x * o.x + self.y * o.y + self.z * o.z
            }
            /// Squared Euclidean norm.
            #[inline]
            pub fn squared_norm(self) -> f32 {
                self.dot(self)
            }
            /// Euclidean norm.
            #[inline]
            pub fn norm(self) -> f32 {
                self.squared_norm().sqrt()
            }
            /// The unit vector along `self` (undefined for the zero vector).
            #[inline]
            pub fn normalize(self) -> $name {
                self / self.norm()
            }
            /// The component of largest absolute value's index.
            #[inline]
            pub fn max_dimension(self) -> usize {
                let a = self.abs();
                if a.x > a.y {
                    if a.x > a.z {
                        0
                    } else {
                        2
                    }
                } else if a.y > a.z {
                    1
                } else {
                    2
                }
            }
            /// Component-wise absolute value.
            #[inline]
            pub fn abs(self) -> $name {
                $name::new(self.x.abs(), self.y.abs(), self.z.abs())
            }
        }
    };
}

triple!(
    /// A direction or displacement in 3D.
    Vec3
);
triple!(
    /// A position in 3D.
    Point3
);
triple!(
    /// A surface normal in 3D (transforms by the inverse transpose).
    Normal3
);
linear_ops!(Vec3);
linear_ops!(Normal3);

impl Vec3 {
    /// The unit vector along +x.
    pub const X: Vec3 = Vec3::new(1.0, 0.0, 0.0);
    /// The unit vector along +y.
    pub const Y: Vec3 = Vec3::new(0.0, 1.0, 0.0);
    /// The unit vector along +z.
    pub const Z: Vec3 = Vec3::new(0.0, 0.0, 1.0);
    /// The zero vector.
    pub const ZERO: Vec3 = Vec3::new(0.0, 0.0, 0.0);

    /// Cross product (right-handed).
    #[inline]
    pub fn cross(self, o: Vec3) -> Vec3 {
        Vec3::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }
    /// Component-wise product.
    #[inline]
    pub fn mul_elem(self, o: Vec3) -> Vec3 {
        Vec3::new(self.x * o.x, self.y * o.y, self.z * o.z)
    }
    /// Reinterprets as a normal.
    #[inline]
    pub fn to_normal(self) -> Normal3 {
        Normal3::new(self.x, self.y, self.z)
    }
    /// Reinterprets as a point (the origin plus `self`).
    #[inline]
    pub fn to_point(self) -> Point3 {
        Point3::new(self.x, self.y, self.z)
    }
}

impl Normal3 {
    /// Reinterprets as a vector.
    #[inline]
    pub fn to_vec(self) -> Vec3 {
        Vec3::new(self.x, self.y, self.z)
    }
    /// Dot product with a vector.
    #[inline]
    pub fn dot_vec(self, v: Vec3) -> f32 {
        self.x * v.x + self.y * v.y + self.z * v.z
    }
    /// The normal flipped, if needed, to lie in the hemisphere of `v` (`n·v ≥ 0`).
    #[inline]
    pub fn face_forward(self, v: Vec3) -> Normal3 {
        if self.dot_vec(v) < 0.0 {
            -self
        } else {
            self
        }
    }
}

impl Point3 {
    /// The origin.
    pub const ORIGIN: Point3 = Point3::new(0.0, 0.0, 0.0);

    /// The vector from the origin to `self`.
    #[inline]
    pub fn to_vec(self) -> Vec3 {
        Vec3::new(self.x, self.y, self.z)
    }
    /// Squared distance between two points.
    #[inline]
    pub fn squared_distance(self, o: Point3) -> f32 {
        (self - o).squared_norm()
    }
    /// Distance between two points.
    #[inline]
    pub fn distance(self, o: Point3) -> f32 {
        (self - o).norm()
    }
    /// Affine combination `self·(1-t) + o·t`.
    #[inline]
    pub fn lerp(self, o: Point3, t: f32) -> Point3 {
        self + (o - self) * t
    }
}

impl Sub for Point3 {
    type Output = Vec3;
    #[inline]
    fn sub(self, o: Point3) -> Vec3 {
        Vec3::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}
impl Add<Vec3> for Point3 {
    type Output = Point3;
    #[inline]
    fn add(self, v: Vec3) -> Point3 {
        Point3::new(self.x + v.x, self.y + v.y, self.z + v.z)
    }
}
impl AddAssign<Vec3> for Point3 {
    #[inline]
    fn add_assign(&mut self, v: Vec3) {
        *self = *self + v;
    }
}
impl Sub<Vec3> for Point3 {
    type Output = Point3;
    #[inline]
    fn sub(self, v: Vec3) -> Point3 {
        Point3::new(self.x - v.x, self.y - v.y, self.z - v.z)
    }
}

/// A 2D point, used for surface (u, v) coordinates and samples.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Point2 {
    /// First coordinate.
    pub x: f32,
    /// Second coordinate.
    pub y: f32,
}

impl Point2 {
    /// Builds from two coordinates.
    #[inline]
    pub const fn new(x: f32, y: f32) -> Self {
        Self { x, y }
    }
}

/// `a·b` with one of them a normal: the cosine helper used by shading code.
#[inline]
pub fn abs_dot(n: Normal3, v: Vec3) -> f32 {
    n.dot_vec(v).abs()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vector_algebra_by_hand() {
        let a = Vec3::new(1.0, 2.0, 3.0);
        let b = Vec3::new(4.0, 6.0, 8.0);
        assert_eq!(a + b, Vec3::new(5.0, 8.0, 11.0));
        assert_eq!(b - a, Vec3::new(3.0, 4.0, 5.0));
        assert_eq!(a * 2.0, Vec3::new(2.0, 4.0, 6.0));
        assert_eq!(2.0 * a, Vec3::new(2.0, 4.0, 6.0));
        assert_eq!(a.dot(b), 40.0);
        assert_eq!(a.cross(b), Vec3::new(-2.0, 4.0, -2.0));
        assert_eq!(b.cross(a), Vec3::new(2.0, -4.0, 2.0));
        assert_eq!(a.squared_norm(), 14.0);
        assert!((a.norm() - 14f32.sqrt()).abs() < 1e-6);
        assert!((a.normalize().norm() - 1.0).abs() < 1e-6);
        assert_eq!(Vec3::X.cross(Vec3::Y), Vec3::Z);
        assert_eq!(-a, Vec3::new(-1.0, -2.0, -3.0));
    }

    #[test]
    fn points_and_vectors_combine_by_affine_rules() {
        let p = Point3::new(1.0, 2.0, 3.0);
        let q = Point3::new(4.0, 6.0, 8.0);
        assert_eq!(q - p, Vec3::new(3.0, 4.0, 5.0));
        assert_eq!(p + Vec3::new(1.0, 1.0, 1.0), Point3::new(2.0, 3.0, 4.0));
        assert_eq!(p.distance(q), 50f32.sqrt());
        assert_eq!(p.lerp(q, 0.5), Point3::new(2.5, 4.0, 5.5));
    }

    #[test]
    fn normals_face_forward() {
        let n = Normal3::new(0.0, 0.0, 1.0);
        assert_eq!(
            n.face_forward(Vec3::new(0.0, 1.0, -1.0)),
            Normal3::new(0.0, 0.0, -1.0)
        );
        assert_eq!(n.face_forward(Vec3::new(0.0, 1.0, 1.0)), n);
        assert_eq!(Vec3::new(0.0, 3.0, -1.0).max_dimension(), 1);
    }
}
