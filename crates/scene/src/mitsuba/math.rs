//! 4×4 matrices in double precision: Mitsuba composes its transforms in double precision
//! while parsing; candela's single-precision [`Transform`] is made once at the end.

use candela_render::math::{Matrix4, Transform};

/// A 4×4 matrix, row-major (`m[row][col]`), acting on column vectors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct M4(pub [[f64; 4]; 4]);

type V3 = [f64; 3];

fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normalize(a: V3) -> Option<V3> {
    let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    (n > 1e-12 && n.is_finite()).then(|| [a[0] / n, a[1] / n, a[2] / n])
}

impl M4 {
    /// The identity.
    pub const IDENTITY: M4 = M4([
        [1.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ]);

    /// The matrix whose columns are `x`, `y`, `z` and the translation `t`.
    pub fn from_columns(x: V3, y: V3, z: V3, t: V3) -> M4 {
        M4([
            [x[0], y[0], z[0], t[0]],
            [x[1], y[1], z[1], t[1]],
            [x[2], y[2], z[2], t[2]],
            [0.0, 0.0, 0.0, 1.0],
        ])
    }

    /// Translation by `v`.
    pub fn translate(v: V3) -> M4 {
        Self::from_columns([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], v)
    }

    /// Scaling by the factors of `v`.
    pub fn scale(v: V3) -> M4 {
        Self::from_columns(
            [v[0], 0.0, 0.0],
            [0.0, v[1], 0.0],
            [0.0, 0.0, v[2]],
            [0.0; 3],
        )
    }

    /// Mitsuba 3's rotation by `degrees` about `axis`: c·I + (1 − c)·a·aᵀ + s·[a]×, a right-handed
    /// rotation for a unit axis. Like Mitsuba 3, the axis is *not* normalised (a longer axis
    /// also scales and shears). `None` for a zero axis.
    pub fn rotate(a: V3, degrees: f64) -> Option<M4> {
        normalize(a)?;
        let (s, c) = degrees.to_radians().sin_cos();
        let t = 1.0 - c;
        Some(M4([
            [
                t * a[0] * a[0] + c,
                t * a[0] * a[1] - s * a[2],
                t * a[0] * a[2] + s * a[1],
                0.0,
            ],
            [
                t * a[0] * a[1] + s * a[2],
                t * a[1] * a[1] + c,
                t * a[1] * a[2] - s * a[0],
                0.0,
            ],
            [
                t * a[0] * a[2] - s * a[1],
                t * a[1] * a[2] + s * a[0],
                t * a[2] * a[2] + c,
                0.0,
            ],
            [0.0, 0.0, 0.0, 1.0],
        ]))
    }

    /// Mitsuba's `look_at`: local +z towards the target, +x = up × direction (to the left of
    /// the view), +y the corrected up; a zero `up` is replaced by a perpendicular vector.
    pub fn look_at(origin: V3, target: V3, up: V3) -> Option<M4> {
        let dir = normalize(sub(target, origin))?;
        let up = if up == [0.0; 3] {
            // Any vector perpendicular to the direction, as Mitsuba's coordinate_system does.
            if dir[2].abs() < 0.9 {
                cross(dir, [0.0, 0.0, 1.0])
            } else {
                cross(dir, [1.0, 0.0, 0.0])
            }
        } else {
            up
        };
        let left = normalize(cross(up, dir))?;
        let new_up = cross(dir, left);
        Some(Self::from_columns(left, new_up, dir, origin))
    }

    /// A matrix from 16 row-major values, or 9 (the linear part).
    pub fn from_values(v: &[f64]) -> Option<M4> {
        let n = match v.len() {
            16 => 4,
            9 => 3,
            _ => return None,
        };
        let mut m = Self::IDENTITY;
        for (i, x) in v.iter().enumerate() {
            m.0[i / n][i % n] = *x;
        }
        Some(m)
    }

    /// `self · o` (`o` applies first).
    pub fn mul(&self, o: &M4) -> M4 {
        let mut r = [[0.0; 4]; 4];
        for (i, row) in r.iter_mut().enumerate() {
            for (j, x) in row.iter_mut().enumerate() {
                *x = (0..4).map(|k| self.0[i][k] * o.0[k][j]).sum();
            }
        }
        M4(r)
    }

    /// Applies to a point.
    pub fn point(&self, p: V3) -> V3 {
        let m = &self.0;
        [0, 1, 2].map(|i| m[i][0] * p[0] + m[i][1] * p[1] + m[i][2] * p[2] + m[i][3])
    }

    /// Applies to a vector.
    pub fn vector(&self, v: V3) -> V3 {
        let m = &self.0;
        [0, 1, 2].map(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2])
    }

    /// The determinant of the linear part.
    pub fn det3(&self) -> f64 {
        let m = &self.0;
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    }

    /// The inverse by Gauss–Jordan elimination with partial pivoting; `None` when singular.
    pub fn inverse(&self) -> Option<M4> {
        let mut a = self.0;
        let mut inv = Self::IDENTITY.0;
        let scale = a.iter().flatten().fold(0f64, |m, x| m.max(x.abs()));
        for col in 0..4 {
            let piv = (col..4).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
            if !(a[piv][col].abs() > 1e-12 * scale) {
                return None;
            }
            a.swap(col, piv);
            inv.swap(col, piv);
            let d = a[col][col];
            for j in 0..4 {
                a[col][j] /= d;
                inv[col][j] /= d;
            }
            for i in 0..4 {
                if i != col {
                    let f = a[i][col];
                    for j in 0..4 {
                        a[i][j] -= f * a[col][j];
                        inv[i][j] -= f * inv[col][j];
                    }
                }
            }
        }
        Some(M4(inv))
    }

    /// The transpose.
    pub fn transpose(&self) -> M4 {
        let mut r = [[0.0; 4]; 4];
        for (i, row) in r.iter_mut().enumerate() {
            for (j, x) in row.iter_mut().enumerate() {
                *x = self.0[j][i];
            }
        }
        M4(r)
    }

    /// The linear part (the translation removed).
    pub fn linear(&self) -> M4 {
        let mut m = *self;
        for r in 0..3 {
            m.0[r][3] = 0.0;
        }
        m
    }

    /// The polar decomposition of the linear part, L = Q·S (Q orthogonal, S symmetric), by the
    /// scaled Newton iteration Mitsuba uses for spheres; `None` when singular.
    pub fn polar(&self) -> Option<(M4, M4)> {
        let frob = |m: &M4| {
            m.0.iter()
                .take(3)
                .flat_map(|r| &r[..3])
                .map(|x| x * x)
                .sum::<f64>()
                .sqrt()
        };
        let l = self.linear();
        let mut q = l;
        for _ in 0..25 {
            let qi = q.inverse()?.transpose();
            let g = (frob(&qi) / frob(&q)).sqrt();
            for r in 0..3 {
                for c in 0..3 {
                    q.0[r][c] = 0.5 * (g * q.0[r][c] + qi.0[r][c] / g);
                }
            }
        }
        Some((q, q.transpose().mul(&l)))
    }

    /// The single-precision transformation; `None` when singular, not affine or not finite.
    pub fn to_transform(self) -> Option<Transform> {
        let affine = self.0[3] == [0.0, 0.0, 0.0, 1.0];
        let inv = self.inverse()?;
        let f = |m: &M4| Matrix4::new(m.0.map(|r| r.map(|x| x as f32)));
        let (m, i) = (f(&self), f(&inv));
        let finite =
            m.m.iter()
                .chain(i.m.iter())
                .flatten()
                .all(|x| x.is_finite());
        (affine && finite && self.det3().abs() > 0.0).then(|| Transform::from_pair(m, i))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: &M4, b: &M4) -> bool {
        a.0.iter()
            .flatten()
            .zip(b.0.iter().flatten())
            .all(|(x, y)| (x - y).abs() < 1e-12)
    }

    #[test]
    fn inverse_and_composition() {
        let m = M4::translate([1.0, 2.0, 3.0])
            .mul(&M4::rotate([1.0, 1.0, 0.0], 30.0).unwrap())
            .mul(&M4::scale([2.0, 3.0, 4.0]));
        assert!(close(&m.mul(&m.inverse().unwrap()), &M4::IDENTITY));
        assert!(M4::scale([1.0, 0.0, 1.0]).inverse().is_none());
        // A rotation by 90° about z maps x to y.
        let r = M4::rotate([0.0, 0.0, 1.0], 90.0)
            .unwrap()
            .vector([1.0, 0.0, 0.0]);
        assert!((r[0]).abs() < 1e-12 && (r[1] - 1.0).abs() < 1e-12);
        // Mitsuba 3 does not normalise the axis: (1, 1, 0) by 40° moves (1, -1, -1) to
        // (0.1232568, -0.1232568, -2.0516198), as its cube plugin reports.
        let r = M4::rotate([1.0, 1.0, 0.0], 40.0)
            .unwrap()
            .point([1.0, -1.0, -1.0]);
        assert!(
            (r[0] - 0.1232568).abs() < 1e-6
                && (r[1] + 0.1232568).abs() < 1e-6
                && (r[2] + 2.0516198).abs() < 1e-6,
            "{r:?}"
        );
    }

    #[test]
    fn polar_decomposition() {
        let r = M4::rotate([0.0, 1.0, 0.0], 30.0).unwrap();
        let m = M4::translate([1.0, 2.0, 3.0])
            .mul(&r)
            .mul(&M4::scale([2.0, 2.0, 2.0]));
        let (q, s) = m.polar().unwrap();
        assert!(close(&q, &r), "{q:?}");
        assert!((s.0[0][0] - 2.0).abs() < 1e-12 && s.0[0][1].abs() < 1e-12);
    }

    #[test]
    fn look_at_frame() {
        let m = M4::look_at([0.0, 0.0, 5.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]).unwrap();
        // Forward is -z, up stays +y, local x (left of the view) is -x.
        assert_eq!(m.vector([0.0, 0.0, 1.0]), [0.0, 0.0, -1.0]);
        assert_eq!(m.vector([0.0, 1.0, 0.0]), [0.0, 1.0, 0.0]);
        assert_eq!(m.vector([1.0, 0.0, 0.0]), [-1.0, 0.0, 0.0]);
        assert!(M4::look_at([0.0; 3], [0.0, 1.0, 0.0], [0.0, 2.0, 0.0]).is_none());
        assert!(M4::look_at([0.0; 3], [0.0; 3], [0.0, 1.0, 0.0]).is_none());
        assert!(M4::look_at([0.0; 3], [0.0, 0.0, 1.0], [0.0; 3]).is_some());
    }
}
