//! Locating a hit on the mesh: the leaf element that contains it, found through the surface's
//! root grid and a descent through the children.

use super::surface::{unstretch, SurfaceKind, SurfaceMap};
use super::Meshing;
use crate::interaction::{Hit, SurfaceInteraction};
use crate::math::{Point3, PI};
use crate::radiosity::NONE;

impl Meshing {
    /// The leaf element containing a hit, with the local coordinates of the hit in it.
    pub fn locate(&self, hit: &Hit, si: &SurfaceInteraction) -> Option<(u32, [f32; 2])> {
        let &(first, count) = self.prim_surfaces.get(hit.prim as usize)?;
        if count == 0 {
            return None;
        }
        let s0 = &self.surfaces[first as usize];
        let (sid, s, t) = match s0.kind {
            SurfaceKind::Parallelogram | SurfaceKind::MeshTriangle => (first, hit.uv[0], hit.uv[1]),
            SurfaceKind::CubeFace => {
                let f = hit.sub.min(count - 1);
                (first + f, si.uv.x, si.uv.y)
            }
            SurfaceKind::Sphere => (first, si.uv.x, si.uv.y),
            SurfaceKind::Disk => {
                let (x, y) = (hit.uv[0], hit.uv[1]);
                let mut phi = y.atan2(x) / (2.0 * PI);
                if phi < 0.0 {
                    phi += 1.0;
                }
                (first, (x * x + y * y).sqrt(), phi)
            }
            SurfaceKind::Plane => {
                let SurfaceMap::Plane {
                    t, cx, cy, half, a, ..
                } = &s0.map
                else {
                    return None;
                };
                let q = t.inv_point(si.p);
                let u = |x: f32| 0.5 * (unstretch(*a, (x / half).clamp(-1.0, 1.0)) + 1.0);
                (first, u(q.x - cx), u(q.y - cy))
            }
            SurfaceKind::PolyFan => {
                // The fan triangle of face `sub` that contains the point best.
                let mut best: Option<(u32, f32, f32, f32)> = None;
                for k in first..first + count {
                    let sk = &self.surfaces[k as usize];
                    if sk.face != hit.sub {
                        continue;
                    }
                    let SurfaceMap::Triangle { a, b, c, .. } = &sk.map else {
                        continue;
                    };
                    let (b1, b2) = barycentric(*a, *b, *c, si.p);
                    let inside = b1.min(b2).min(1.0 - b1 - b2);
                    if best.is_none_or(|x| inside > x.3) {
                        best = Some((k, b1, b2, inside));
                    }
                }
                let (k, b1, b2, _) = best?;
                (k, b1, b2)
            }
        };
        Some(self.descend(sid, s, t))
    }

    /// The leaf element of surface `sid` at parameters (s, t) and the local coordinates in it.
    pub fn descend(&self, sid: u32, s: f32, t: f32) -> (u32, [f32; 2]) {
        let sf = &self.surfaces[sid as usize];
        let fix = |x: f32| {
            if x.is_finite() {
                x.clamp(0.0, 1.0)
            } else {
                0.5
            }
        };
        let (s, t) = (fix(s), fix(t));
        if sf.map.is_triangle() {
            let mut e = sf.first_root;
            loop {
                let el = &self.elements[e as usize];
                let [p0, p1, p2] = el.tri;
                let (l1, l2) = bary2(p0, p1, p2, [s, t]);
                let l0 = 1.0 - l1 - l2;
                if el.children == NONE {
                    return (e, [l1.clamp(0.0, 1.0), l2.clamp(0.0, 1.0)]);
                }
                let k = if l0 >= 0.5 {
                    0
                } else if l1 >= 0.5 {
                    1
                } else if l2 >= 0.5 {
                    2
                } else {
                    3
                };
                e = el.children + k;
            }
        } else {
            let i = ((s * sf.nu as f32) as u32).min(sf.nu - 1);
            let j = ((t * sf.nv as f32) as u32).min(sf.nv - 1);
            let mut e = sf.first_root + j * sf.nu + i;
            loop {
                let el = &self.elements[e as usize];
                let [s0, t0, s1, t1] = el.rect;
                if el.children == NONE {
                    let a = if s1 > s0 { (s - s0) / (s1 - s0) } else { 0.5 };
                    let b = if t1 > t0 { (t - t0) / (t1 - t0) } else { 0.5 };
                    return (e, [a.clamp(0.0, 1.0), b.clamp(0.0, 1.0)]);
                }
                let k = (s >= 0.5 * (s0 + s1)) as u32 + 2 * (t >= 0.5 * (t0 + t1)) as u32;
                e = el.children + k;
            }
        }
    }
}

/// Barycentrics (of b and c) of the projection of `p` onto the triangle's plane.
fn barycentric(a: Point3, b: Point3, c: Point3, p: Point3) -> (f32, f32) {
    let (e1, e2, q) = (b - a, c - a, p - a);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (q1, q2) = (q.dot(e1), q.dot(e2));
    let det = d11 * d22 - d12 * d12;
    if !(det.abs() > 0.0) {
        return (1.0 / 3.0, 1.0 / 3.0);
    }
    ((d22 * q1 - d12 * q2) / det, (d11 * q2 - d12 * q1) / det)
}

/// Barycentrics (of p1 and p2) of the 2D point `q` in the triangle p0 p1 p2.
fn bary2(p0: [f32; 2], p1: [f32; 2], p2: [f32; 2], q: [f32; 2]) -> (f32, f32) {
    let (e1, e2) = (
        [p1[0] - p0[0], p1[1] - p0[1]],
        [p2[0] - p0[0], p2[1] - p0[1]],
    );
    let d = [q[0] - p0[0], q[1] - p0[1]];
    let det = e1[0] * e2[1] - e1[1] * e2[0];
    if det == 0.0 {
        return (1.0 / 3.0, 1.0 / 3.0);
    }
    (
        (d[0] * e2[1] - d[1] * e2[0]) / det,
        (e1[0] * d[1] - e1[1] * d[0]) / det,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn barycentrics_of_a_projected_point() {
        let (b1, b2) = barycentric(
            Point3::ORIGIN,
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
            Point3::new(0.25, 0.5, 3.0),
        );
        assert!((b1 - 0.25).abs() < 1e-6 && (b2 - 0.5).abs() < 1e-6);
    }
}
