//! Affine transformations stored together with their inverse.
//!
//! A [`Transform`] keeps the matrix `m` and its inverse `inv`, so that a shape can move rays into
//! its own frame with `T⁻¹` and move normals back with the inverse transpose, without inverting a
//! matrix per ray. The elementary transformations build their inverse in closed form; only
//! [`Transform::from_matrix`] inverts numerically (in f64) and reports a singular matrix.
//!
//! Composition follows the course: `a * b` applies `b` first, then `a`. Angles are in degrees and
//! rotations are right-handed.

use super::{Normal3, Point3, Vec3};
use std::ops::Mul;

/// A 4×4 matrix of f32, row-major: `m[row][col]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Matrix4 {
    /// The rows.
    pub m: [[f32; 4]; 4],
}

impl Matrix4 {
    /// The identity matrix.
    pub const IDENTITY: Matrix4 = Matrix4 {
        m: [
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 0.0, 0.0, 1.0],
        ],
    };

    /// Builds from rows.
    pub const fn new(m: [[f32; 4]; 4]) -> Self {
        Self { m }
    }

    /// The transpose.
    pub fn transpose(&self) -> Matrix4 {
        let mut t = [[0.0; 4]; 4];
        for (i, row) in t.iter_mut().enumerate() {
            for (j, x) in row.iter_mut().enumerate() {
                *x = self.m[j][i];
            }
        }
        Matrix4 { m: t }
    }

    /// The inverse by Gauss–Jordan elimination with partial pivoting in f64, or `None` when the
    /// matrix is singular (or not finite).
    pub fn inverse(&self) -> Option<Matrix4> {
        let mut a = [[0f64; 8]; 4];
        for i in 0..4 {
            for j in 0..4 {
                a[i][j] = self.m[i][j] as f64;
            }
            a[i][4 + i] = 1.0;
        }
        let scale = self
            .m
            .iter()
            .flatten()
            .fold(0f64, |s, &x| s.max((x as f64).abs()));
        if !(scale.is_finite() && scale > 0.0) {
            return None;
        }
        for col in 0..4 {
            let pivot = (col..4)
                .max_by(|&r, &s| a[r][col].abs().total_cmp(&a[s][col].abs()))
                .unwrap_or(col);
            if a[pivot][col].abs() <= 1e-12 * scale {
                return None;
            }
            a.swap(col, pivot);
            let p = a[col][col];
            for x in a[col].iter_mut() {
                *x /= p;
            }
            for r in 0..4 {
                if r != col {
                    let f = a[r][col];
                    if f != 0.0 {
                        for c in 0..8 {
                            a[r][c] -= f * a[col][c];
                        }
                    }
                }
            }
        }
        let mut inv = [[0f32; 4]; 4];
        for i in 0..4 {
            for j in 0..4 {
                inv[i][j] = a[i][4 + j] as f32;
            }
        }
        let inv = Matrix4 { m: inv };
        inv.m.iter().flatten().all(|x| x.is_finite()).then_some(inv)
    }

    /// True when every entry is within `eps` of `o`'s.
    pub fn approx_eq(&self, o: &Matrix4, eps: f32) -> bool {
        self.m
            .iter()
            .flatten()
            .zip(o.m.iter().flatten())
            .all(|(a, b)| (a - b).abs() <= eps)
    }
}

impl Mul for Matrix4 {
    type Output = Matrix4;
    fn mul(self, o: Matrix4) -> Matrix4 {
        let mut r = [[0f32; 4]; 4];
        for (i, row) in r.iter_mut().enumerate() {
            for (j, x) in row.iter_mut().enumerate() {
                // Accumulate in f64 so that long compositions lose no precision.
                *x = (0..4)
                    .map(|k| self.m[i][k] as f64 * o.m[k][j] as f64)
                    .sum::<f64>() as f32;
            }
        }
        Matrix4 { m: r }
    }
}

/// An affine transformation with its inverse.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// The matrix.
    pub m: Matrix4,
    /// Its inverse.
    pub inv: Matrix4,
}

impl Default for Transform {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Transform {
    /// The identity.
    pub const IDENTITY: Transform = Transform {
        m: Matrix4::IDENTITY,
        inv: Matrix4::IDENTITY,
    };

    /// Builds from a matrix and its inverse (the caller guarantees `m·inv = I`).
    pub const fn from_pair(m: Matrix4, inv: Matrix4) -> Self {
        Self { m, inv }
    }

    /// Builds from a matrix, inverting it numerically; `None` if it is singular.
    pub fn from_matrix(m: Matrix4) -> Option<Self> {
        m.inverse().map(|inv| Self { m, inv })
    }

    /// The inverse transformation (swaps the two matrices).
    pub fn inverse(&self) -> Transform {
        Transform {
            m: self.inv,
            inv: self.m,
        }
    }

    /// Translation by `v`.
    pub fn translation(v: Vec3) -> Self {
        let t = |s: f32| {
            Matrix4::new([
                [1.0, 0.0, 0.0, s * v.x],
                [0.0, 1.0, 0.0, s * v.y],
                [0.0, 0.0, 1.0, s * v.z],
                [0.0, 0.0, 0.0, 1.0],
            ])
        };
        Self {
            m: t(1.0),
            inv: t(-1.0),
        }
    }

    /// Scaling by the factors of `v` (no factor may be zero for the inverse to exist).
    pub fn scaling(v: Vec3) -> Self {
        let s = |x: f32, y: f32, z: f32| {
            Matrix4::new([
                [x, 0.0, 0.0, 0.0],
                [0.0, y, 0.0, 0.0],
                [0.0, 0.0, z, 0.0],
                [0.0, 0.0, 0.0, 1.0],
            ])
        };
        Self {
            m: s(v.x, v.y, v.z),
            inv: s(1.0 / v.x, 1.0 / v.y, 1.0 / v.z),
        }
    }

    /// Rotation about an axis (0 = x, 1 = y, 2 = z) by `degrees`, right-handed.
    fn rotation_axis(axis: usize, degrees: f32) -> Self {
        let (s, c) = (degrees as f64).to_radians().sin_cos();
        let (s, c) = (s as f32, c as f32);
        let rot = |s: f32| {
            let (i, j) = ((axis + 1) % 3, (axis + 2) % 3);
            let mut m = Matrix4::IDENTITY;
            m.m[i][i] = c;
            m.m[i][j] = -s;
            m.m[j][i] = s;
            m.m[j][j] = c;
            m
        };
        Self {
            m: rot(s),
            inv: rot(-s),
        }
    }

    /// Rotation about x by `degrees`.
    pub fn rotation_x(degrees: f32) -> Self {
        Self::rotation_axis(0, degrees)
    }
    /// Rotation about y by `degrees`.
    pub fn rotation_y(degrees: f32) -> Self {
        Self::rotation_axis(1, degrees)
    }
    /// Rotation about z by `degrees`.
    pub fn rotation_z(degrees: f32) -> Self {
        Self::rotation_axis(2, degrees)
    }

    /// Rotation about an arbitrary axis by `degrees` (Rodrigues), right-handed; `None` for a zero axis.
    pub fn rotation(axis: Vec3, degrees: f32) -> Option<Self> {
        let len = axis.norm();
        if !(len > 0.0 && len.is_finite()) {
            return None;
        }
        let a = axis / len;
        let (s, c) = (degrees as f64).to_radians().sin_cos();
        let (s, c) = (s as f32, c as f32);
        let t = 1.0 - c;
        let m = Matrix4::new([
            [
                t * a.x * a.x + c,
                t * a.x * a.y - s * a.z,
                t * a.x * a.z + s * a.y,
                0.0,
            ],
            [
                t * a.x * a.y + s * a.z,
                t * a.y * a.y + c,
                t * a.y * a.z - s * a.x,
                0.0,
            ],
            [
                t * a.x * a.z - s * a.y,
                t * a.y * a.z + s * a.x,
                t * a.z * a.z + c,
                0.0,
            ],
            [0.0, 0.0, 0.0, 1.0],
        ]);
        Some(Self {
            m,
            inv: m.transpose(),
        })
    }

    /// The frame with origin `origin` and orthonormal axes `x`, `y`, `z` as columns: maps the
    /// local axes onto them.
    pub fn from_frame(origin: Point3, x: Vec3, y: Vec3, z: Vec3) -> Self {
        let m = Matrix4::new([
            [x.x, y.x, z.x, origin.x],
            [x.y, y.y, z.y, origin.y],
            [x.z, y.z, z.z, origin.z],
            [0.0, 0.0, 0.0, 1.0],
        ]);
        // Orthonormal columns: the inverse is the transposed rotation after the translation.
        let inv = Matrix4::new([
            [x.x, x.y, x.z, -x.dot(origin.to_vec())],
            [y.x, y.y, y.z, -y.dot(origin.to_vec())],
            [z.x, z.y, z.z, -z.dot(origin.to_vec())],
            [0.0, 0.0, 0.0, 1.0],
        ]);
        Self { m, inv }
    }

    /// A camera placement in the course's convention: the camera at `eye` looks towards
    /// `target` along its local +x, with its local +z as close to `up` as possible.
    /// `None` when `eye == target` or `up` is parallel to the view direction.
    pub fn look_at(eye: Point3, target: Point3, up: Vec3) -> Option<Self> {
        let forward = (target - eye).normalize();
        let left = up.cross(forward);
        let len = left.norm();
        if !(len > 1e-6 && forward.is_finite()) {
            return None;
        }
        let left = left / len;
        let up = forward.cross(left);
        Some(Self::from_frame(eye, forward, left, up))
    }

    /// Applies to a point (with the homogeneous division when the last row is not (0,0,0,1)).
    #[inline]
    pub fn point(&self, p: Point3) -> Point3 {
        apply_point(&self.m, p)
    }
    /// Applies the inverse to a point.
    #[inline]
    pub fn inv_point(&self, p: Point3) -> Point3 {
        apply_point(&self.inv, p)
    }
    /// Applies to a vector (ignores the translation).
    #[inline]
    pub fn vector(&self, v: Vec3) -> Vec3 {
        apply_vector(&self.m, v)
    }
    /// Applies the inverse to a vector.
    #[inline]
    pub fn inv_vector(&self, v: Vec3) -> Vec3 {
        apply_vector(&self.inv, v)
    }
    /// Applies to a normal: by the inverse transpose, so that it stays perpendicular to the
    /// transformed surface. The result is not normalised.
    #[inline]
    pub fn normal(&self, n: Normal3) -> Normal3 {
        let m = &self.inv.m;
        Normal3::new(
            m[0][0] * n.x + m[1][0] * n.y + m[2][0] * n.z,
            m[0][1] * n.x + m[1][1] * n.y + m[2][1] * n.z,
            m[0][2] * n.x + m[1][2] * n.y + m[2][2] * n.z,
        )
    }

    /// True when the transformation swaps handedness (negative determinant of the linear part).
    pub fn swaps_handedness(&self) -> bool {
        let m = &self.m.m;
        let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        det < 0.0
    }

    /// True when `m·inv` is the identity within `eps`.
    pub fn is_consistent(&self, eps: f32) -> bool {
        (self.m * self.inv).approx_eq(&Matrix4::IDENTITY, eps)
    }

    /// True when the transformation is the identity.
    pub fn is_identity(&self) -> bool {
        self.m == Matrix4::IDENTITY
    }
}

#[inline]
fn apply_point(m: &Matrix4, p: Point3) -> Point3 {
    let m = &m.m;
    let x = m[0][0] * p.x + m[0][1] * p.y + m[0][2] * p.z + m[0][3];
    let y = m[1][0] * p.x + m[1][1] * p.y + m[1][2] * p.z + m[1][3];
    let z = m[2][0] * p.x + m[2][1] * p.y + m[2][2] * p.z + m[2][3];
    let w = m[3][0] * p.x + m[3][1] * p.y + m[3][2] * p.z + m[3][3];
    if w == 1.0 {
        Point3::new(x, y, z)
    } else {
        Point3::new(x / w, y / w, z / w)
    }
}

#[inline]
fn apply_vector(m: &Matrix4, v: Vec3) -> Vec3 {
    let m = &m.m;
    Vec3::new(
        m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z,
        m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
        m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z,
    )
}

impl Mul for Transform {
    type Output = Transform;
    /// `a * b` applies `b` first, then `a`; the inverse is `b⁻¹ a⁻¹`.
    fn mul(self, o: Transform) -> Transform {
        Transform {
            m: self.m * o.m,
            inv: o.inv * self.inv,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const EPS: f32 = 1e-5;

    #[test]
    fn matrix_product_by_hand() {
        let a = Matrix4::new([
            [1.0, 2.0, 3.0, 4.0],
            [5.0, 6.0, 7.0, 8.0],
            [9.0, 9.0, 8.0, 7.0],
            [6.0, 5.0, 4.0, 1.0],
        ]);
        let b = Matrix4::new([
            [3.0, 5.0, 2.0, 4.0],
            [4.0, 1.0, 0.0, 5.0],
            [6.0, 3.0, 2.0, 0.0],
            [1.0, 4.0, 2.0, 1.0],
        ]);
        let expected = Matrix4::new([
            [33.0, 32.0, 16.0, 18.0],
            [89.0, 84.0, 40.0, 58.0],
            [118.0, 106.0, 48.0, 88.0],
            [63.0, 51.0, 22.0, 50.0],
        ]);
        assert_eq!(a * b, expected);
    }

    #[test]
    fn numeric_inverse_matches_hand_computed_one() {
        let m = Matrix4::new([
            [1.0, 2.0, 3.0, 4.0],
            [5.0, 6.0, 7.0, 8.0],
            [9.0, 9.0, 8.0, 7.0],
            [0.0, 0.0, 0.0, 1.0],
        ]);
        let inv = Matrix4::new([
            [-3.75, 2.75, -1.0, 0.0],
            [5.75, -4.75, 2.0, 1.0],
            [-2.25, 2.25, -1.0, -2.0],
            [0.0, 0.0, 0.0, 1.0],
        ]);
        let t = Transform::from_matrix(m).unwrap();
        assert!(t.inv.approx_eq(&inv, EPS), "{:?}", t.inv);
        assert!(t.is_consistent(EPS));
        assert!(Transform::from_matrix(Matrix4::new([[0.0; 4]; 4])).is_none());
        let mut singular = Matrix4::IDENTITY;
        singular.m[2][2] = 0.0;
        assert!(Transform::from_matrix(singular).is_none());
    }

    #[test]
    fn elementary_transforms_carry_exact_inverses() {
        let all = [
            Transform::translation(Vec3::new(1.0, 2.0, 3.0)),
            Transform::scaling(Vec3::new(2.0, 5.0, 10.0)),
            Transform::rotation_x(30.0),
            Transform::rotation_y(45.0),
            Transform::rotation_z(60.0),
            Transform::rotation(Vec3::new(1.0, 1.0, 0.5), 33.0).unwrap(),
            Transform::look_at(Point3::new(1.0, 2.0, 3.0), Point3::ORIGIN, Vec3::Z).unwrap(),
        ];
        for t in all {
            assert!(t.is_consistent(EPS), "{t:?}");
        }
        let c = all[0] * all[2] * all[1] * all[4];
        assert!(c.is_consistent(EPS));
    }

    #[test]
    fn rotations_are_right_handed() {
        assert!(Transform::rotation_x(90.0)
            .vector(Vec3::Y)
            .approx_eq(Vec3::Z, EPS));
        assert!(Transform::rotation_y(90.0)
            .vector(Vec3::Z)
            .approx_eq(Vec3::X, EPS));
        assert!(Transform::rotation_z(90.0)
            .vector(Vec3::X)
            .approx_eq(Vec3::Y, EPS));
        let r = Transform::rotation(Vec3::Z, 90.0).unwrap();
        assert!(r.vector(Vec3::X).approx_eq(Vec3::Y, EPS));
    }

    #[test]
    fn composition_applies_right_operand_first() {
        let t = Transform::translation(Vec3::new(1.0, 0.0, 0.0));
        let r = Transform::rotation_z(90.0);
        // r * t: translate to (1,0,0), then rotate to (0,1,0).
        assert!((r * t)
            .point(Point3::ORIGIN)
            .to_vec()
            .approx_eq(Vec3::Y, EPS));
        // t * r: the rotation leaves the origin fixed, then translate.
        assert!((t * r)
            .point(Point3::ORIGIN)
            .to_vec()
            .approx_eq(Vec3::X, EPS));
        let p = Point3::new(1.0, 2.0, 3.0);
        assert!((t * r).inv_point((t * r).point(p)).approx_eq(p, EPS));
    }

    #[test]
    fn points_vectors_normals_transform_differently() {
        let t = Transform::translation(Vec3::new(1.0, 2.0, 3.0))
            * Transform::scaling(Vec3::new(2.0, 1.0, 1.0));
        assert_eq!(
            t.point(Point3::new(1.0, 1.0, 1.0)),
            Point3::new(3.0, 3.0, 4.0)
        );
        assert_eq!(t.vector(Vec3::new(1.0, 1.0, 1.0)), Vec3::new(2.0, 1.0, 1.0));
        // The plane x + y = 0 has normal (1,1,0); scaled by 2 in x it becomes x/2 + y = 0.
        let n = t.normal(Normal3::new(1.0, 1.0, 0.0));
        assert_eq!(n, Normal3::new(0.5, 1.0, 0.0));
        let tangent = t.vector(Vec3::new(1.0, -1.0, 0.0));
        assert_eq!(n.dot_vec(tangent), 0.0);
        assert!(Transform::scaling(Vec3::new(-1.0, 1.0, 1.0)).swaps_handedness());
        assert!(!Transform::rotation_x(10.0).swaps_handedness());
    }

    #[test]
    fn look_at_follows_the_course_camera_convention() {
        let t = Transform::look_at(Point3::new(-1.0, 0.0, 0.0), Point3::ORIGIN, Vec3::Z).unwrap();
        assert!(
            t.is_identity()
                || t.m
                    .approx_eq(&Transform::translation(Vec3::new(-1.0, 0.0, 0.0)).m, EPS)
        );
        let t = Transform::look_at(Point3::new(0.0, 0.0, 5.0), Point3::ORIGIN, Vec3::Y).unwrap();
        assert!(t.vector(Vec3::X).approx_eq(-Vec3::Z, EPS));
        assert!(t.vector(Vec3::Z).approx_eq(Vec3::Y, EPS));
        assert!(Transform::look_at(Point3::ORIGIN, Point3::new(0.0, 0.0, 1.0), Vec3::Z).is_none());
    }
}
