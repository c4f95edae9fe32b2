//! Triangle meshes and the watertight ray–triangle test.
//!
//! Scene syntax: `triangle(MAT, [a], [b], [c])` (a one-triangle mesh), `mesh(MAT, T, "file")`
//! (OBJ or PLY), Mitsuba `obj`/`ply`. A mesh stores one array per attribute, in world space;
//! a triangle is an index into its mesh.
//!
//! The intersection is the watertight test of Woop, Benthin and Wald (JCGT 2013): the ray is
//! sheared so that it runs along +z, and the triangle's 2D edge functions decide the inside
//! test β ≥ 0, γ ≥ 0, β + γ ≤ 1 consistently along shared edges, so that rays never leak
//! between adjacent triangles. uv = (β, γ) unless the mesh has texture coordinates; the
//! geometric normal is (B−A)×(C−A); the shading normal interpolates vertex normals.

use super::{LocalGeometry, ShapeHit};
use crate::interaction::SurfaceProps;
use crate::math::{Bounds3, Frame, Normal3, Point2, Point3, Ray, Vec3};

/// Meshes of at most this many triangles keep their flat-shaded triangles' [`Face`]s ready;
/// larger ones compute them at every hit (their faces would not stay in the caches).
pub const FACE_TRIANGLES: usize = 4096;

/// What a flat-shaded triangle (no vertex normals, or the same one at its three corners) keeps
/// ready for its hits ([`Mesh::faces`]): the normals, ∂p/∂u and the shading frame, which do not
/// vary over it. Only the point and the texture coordinates are computed at a hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Face {
    /// The geometric normal (on the side of the shading normal).
    pub n: Normal3,
    /// The shading normal.
    pub ns: Normal3,
    /// ∂p/∂u.
    pub dpdu: Vec3,
    /// The shading frame of `ns` and `dpdu`.
    pub frame: Frame,
}

/// A triangle mesh in world space.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions.
    pub positions: Vec<Point3>,
    /// Vertex normals: empty, or one per vertex.
    pub normals: Vec<Normal3>,
    /// Vertex texture coordinates: empty, or one per vertex.
    pub uvs: Vec<Point2>,
    /// Vertex indices of each triangle.
    pub indices: Vec<[u32; 3]>,
    /// Material, emission and light of every triangle.
    pub props: SurfaceProps,
}

/// The ray in the sheared space of the watertight test, computed once per ray.
#[derive(Clone, Copy, Debug)]
pub struct ShearedRay {
    /// The axes that become x, y and z (z: the largest component of the direction).
    pub(crate) k: [usize; 3],
    /// The shear: d[kx]/d[kz], d[ky]/d[kz] and 1/d[kz].
    pub(crate) s: [f32; 3],
}

impl ShearedRay {
    /// Precomputes the permutation and shear of `ray`.
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let k = Self::axes(ray);
        let [kx, ky, kz] = k;
        let dz = ray.d[kz];
        Self {
            k,
            s: [ray.d[kx] / dz, ray.d[ky] / dz, 1.0 / dz],
        }
    }

    /// The axes that become x, y and z: z along the largest component of the direction, x
    /// and y swapped when it is negative (to keep the winding). The shear is then
    /// `[d[kx] / d[kz], d[ky] / d[kz], 1 / d[kz]]`.
    ///
    /// Without branches: the axis of a random direction is not predictable, and its
    /// mispredictions cost more than these few selects (the same choice as
    /// [`Vec3::max_dimension`](crate::math::Vec3::max_dimension), ties included).
    #[inline]
    pub(crate) fn axes(ray: &Ray) -> [usize; 3] {
        // [kx, ky, kz] by kz and the sign of d[kz].
        const AXES: [[usize; 3]; 6] = [
            [1, 2, 0],
            [2, 1, 0],
            [2, 0, 1],
            [0, 2, 1],
            [0, 1, 2],
            [1, 0, 2],
        ];
        let d = ray.d;
        let a = d.abs();
        let x_over_y = a.x > a.y;
        let (m, dm) = if x_over_y { (a.x, d.x) } else { (a.y, d.y) };
        let over_z = m > a.z;
        let kz = if over_z { usize::from(!x_over_y) } else { 2 };
        let dz = if over_z { dm } else { d.z };
        AXES[2 * kz + usize::from(dz < 0.0)]
    }

    /// A stand-in for queries that test no triangle (analytic shapes ignore it).
    #[inline(always)]
    pub(crate) fn unused() -> Self {
        Self {
            k: [0, 1, 2],
            s: [0.0; 3],
        }
    }
}

/// Most triangles a mesh may have to be taken for parallelograms ([`Mesh::parallelograms`]).
pub const MAX_PARALLELOGRAM_TRIANGLES: usize = 64;

impl Mesh {
    /// The mesh as parallelograms, when it is a few of them (up to
    /// [`MAX_PARALLELOGRAM_TRIANGLES`] triangles): each two consecutive triangles share an edge,
    /// wind the same way and make a parallelogram (the vertex of one opposite the shared edge
    /// is the other's mirror image through the edge's midpoint, to 4 ulps of the coordinates),
    /// and the shading is flat (no vertex normals, or each one along its face's normal).
    /// A quad of an OBJ or PLY file (walls, floors, boxes and lights) comes as two such
    /// triangles, which cost twice the intersection tests of one parallelogram. The
    /// parallelograms cover the same surface with the same normals; their texture
    /// coordinates are their own, so the caller asks for them only when nothing reads them.
    /// Each parallelogram starts at the first triangle's vertex opposite the shared edge, its
    /// edges towards the shared edge's ends in the triangle's winding order (so that v × w
    /// is the triangles' winding normal).
    pub fn parallelograms(&self) -> Option<Vec<super::Parallelogram>> {
        let n = self.indices.len();
        if n == 0 || !n.is_multiple_of(2) || n > MAX_PARALLELOGRAM_TRIANGLES {
            return None;
        }
        let pos = |i: u32| self.positions.get(i as usize).copied();
        let mut out = Vec::with_capacity(n / 2);
        for pair in self.indices.chunks_exact(2) {
            let (t1, t2) = (pair[0], pair[1]);
            // The vertex of t1 not in t2, first, and t1's other two in its winding order.
            let k = (0..3).find(|&k| !t2.contains(&t1[k]))?;
            let [x, e1, e2] = [t1[k], t1[(k + 1) % 3], t1[(k + 2) % 3]];
            if !(t2.contains(&e1) && t2.contains(&e2)) || e1 == e2 || x == e1 || x == e2 {
                return None;
            }
            let y = *t2.iter().find(|&&i| i != e1 && i != e2)?;
            // t2 runs the shared edge the other way (e2 before e1) when both wind alike.
            let j = t2.iter().position(|&i| i == e2)?;
            if t2[(j + 1) % 3] != e1 {
                return None;
            }
            let (px, p1, p2, py) = (pos(x)?, pos(e1)?, pos(e2)?, pos(y)?);
            let (v, w) = (p1 - px, p2 - px);
            let far = p1 + (p2 - px);
            let scale = [px, p1, p2, py]
                .iter()
                .flat_map(|p| [p.x.abs(), p.y.abs(), p.z.abs()])
                .fold(0.0f32, f32::max);
            let gap = py - far;
            let tol = 4.0 * f32::EPSILON * scale;
            if !(gap.x.abs() <= tol && gap.y.abs() <= tol && gap.z.abs() <= tol) {
                return None;
            }
            let q = super::Parallelogram::new(px, v, w)?;
            if !self.normals.is_empty() {
                let n = q.normal().to_vec();
                for i in [x, e1, e2, y] {
                    let ns = self.normals.get(i as usize)?.to_vec();
                    let len = ns.norm();
                    if !(ns.dot(n) >= (1.0 - 1e-6) * len) {
                        return None;
                    }
                }
            }
            out.push(q);
        }
        Some(out)
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.indices.len()
    }

    /// True when the mesh has no triangle.
    pub fn is_empty(&self) -> bool {
        self.indices.is_empty()
    }

    /// The vertices of triangle `i`.
    #[inline]
    pub fn vertices(&self, i: u32) -> [Point3; 3] {
        let [a, b, c] = self.indices[i as usize];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    /// Bounds of triangle `i`.
    pub fn triangle_bounds(&self, i: u32) -> Bounds3 {
        let [a, b, c] = self.vertices(i);
        Bounds3::point(a).union_point(b).union_point(c)
    }

    /// Area of triangle `i`.
    pub fn area(&self, i: u32) -> f32 {
        let [a, b, c] = self.vertices(i);
        0.5 * (b - a).cross(c - a).norm()
    }

    /// Intersects triangle `i`; `uv` of the hit holds the barycentrics (β, γ) of B and C.
    #[inline]
    pub fn intersect(&self, i: u32, ray: &Ray, sr: &ShearedRay) -> Option<ShapeHit> {
        let [a, b, c] = self.vertices(i);
        intersect_triangle(a, b, c, ray, sr)
    }

    /// Starts loading the vertex data that [`Mesh::geometry`] of triangle `i` reads (it waits
    /// for the triangle's indices, not for the vertices).
    #[inline(always)]
    pub(crate) fn prefetch_vertices(&self, i: u32) {
        let Some(&[ia, ib, ic]) = self.indices.get(i as usize) else {
            return;
        };
        for v in [ia, ib, ic] {
            if let Some(p) = self.positions.get(v as usize) {
                crate::simd::prefetch(p);
            }
            if let Some(n) = self.normals.get(v as usize) {
                crate::simd::prefetch(n);
            }
            if let Some(t) = self.uvs.get(v as usize) {
                crate::simd::prefetch(t);
            }
        }
    }

    /// The surface of triangle `i` at barycentrics (β, γ).
    pub fn geometry(&self, i: u32, beta: f32, gamma: f32) -> LocalGeometry {
        self.geometry_inline(i, beta, gamma)
    }

    /// [`Mesh::geometry`], inlined where a scene's hits are resolved (returned from a call,
    /// the surface went through memory in other pieces than the caller read back).
    #[inline(always)]
    pub(crate) fn geometry_inline(&self, i: u32, beta: f32, gamma: f32) -> LocalGeometry {
        let (ix, [a, b, c]) = self.corners(i);
        let (p, uv) = self.point_and_uv(ix, [a, b, c], beta, gamma);
        let (e1, e2) = (b - a, c - a);
        let n = winding_normal(e1, e2);
        let ns = if self.normals.is_empty() {
            n
        } else {
            let alpha = 1.0 - beta - gamma;
            let [ia, ib, ic] = ix;
            unit_or(
                self.normals[ia] * alpha + self.normals[ib] * beta + self.normals[ic] * gamma,
                n,
            )
        };
        LocalGeometry {
            p,
            n: self.on_side_of(n, ns),
            ns,
            uv,
            dpdu: self.dpdu(ix, e1, e2),
        }
    }

    /// The indices and positions of triangle `i`'s corners.
    #[inline(always)]
    fn corners(&self, i: u32) -> ([usize; 3], [Point3; 3]) {
        let ix = self.indices[i as usize].map(|x| x as usize);
        (ix, ix.map(|k| self.positions[k]))
    }

    /// The point and texture coordinates at barycentrics (β, γ) of the triangle with corners
    /// `ix` at `[a, b, c]`: (β, γ) themselves without texture coordinates.
    #[inline(always)]
    fn point_and_uv(
        &self,
        ix: [usize; 3],
        [a, b, c]: [Point3; 3],
        beta: f32,
        gamma: f32,
    ) -> (Point3, Point2) {
        let alpha = 1.0 - beta - gamma;
        let p = Point3::new(
            alpha * a.x + beta * b.x + gamma * c.x,
            alpha * a.y + beta * b.y + gamma * c.y,
            alpha * a.z + beta * b.z + gamma * c.z,
        );
        let uv = if self.uvs.is_empty() {
            Point2::new(beta, gamma)
        } else {
            let [ta, tb, tc] = ix.map(|k| self.uvs[k]);
            Point2::new(
                alpha * ta.x + beta * tb.x + gamma * tc.x,
                alpha * ta.y + beta * tb.y + gamma * tc.y,
            )
        };
        (p, uv)
    }

    /// The geometric normal `n` (following the winding) turned to the side of the shading
    /// normal `ns` when the mesh has vertex normals.
    #[inline(always)]
    fn on_side_of(&self, n: Normal3, ns: Normal3) -> Normal3 {
        if !self.normals.is_empty() && n.dot_vec(ns.to_vec()) < 0.0 {
            -n
        } else {
            n
        }
    }

    /// ∂p/∂u of the triangle with corners `ix` and edges `e1`, `e2`: `e1` without texture
    /// coordinates (or with degenerate ones), as Mitsuba 3 takes it (anisotropic roughness
    /// lies along it: `examples/mitsuba/anisotropic.xml`).
    #[inline(always)]
    fn dpdu(&self, ix: [usize; 3], e1: Vec3, e2: Vec3) -> Vec3 {
        if self.uvs.is_empty() {
            return e1;
        }
        let [ta, tb, tc] = ix.map(|k| self.uvs[k]);
        // Solve [e1 e2] = [dpdu dpdv]·[[du1 du2],[dv1 dv2]] for dpdu.
        let (du1, du2, dv1, dv2) = (tb.x - ta.x, tc.x - ta.x, tb.y - ta.y, tc.y - ta.y);
        let det = du1 * dv2 - du2 * dv1;
        if det.abs() > 1e-12 {
            (e1 * dv2 - e2 * dv1) / det
        } else {
            e1
        }
    }

    /// The [`Face`]s of a mesh of at most [`FACE_TRIANGLES`] triangles all flat-shaded (no
    /// vertex normals, or the same one at the three corners of each triangle); `None` for
    /// other meshes. A face gives what [`Mesh::geometry`] gives at every point of its
    /// triangle, except that the shading normal of equal vertex normals is that normal rather
    /// than their interpolation, renormalised at each point (equal up to round-off).
    pub fn faces(&self) -> Option<Vec<Face>> {
        if self.len() > FACE_TRIANGLES {
            return None;
        }
        let flat = self.normals.is_empty()
            || self.indices.iter().all(|t| {
                let [a, b, c] = t.map(|i| self.normals.get(i as usize).copied());
                a.is_some() && a == b && b == c
            });
        if !flat {
            return None;
        }
        Some((0..self.len() as u32).map(|i| self.face(i)).collect())
    }

    /// The [`Face`] of flat-shaded triangle `i`: the normals, ∂p/∂u and frame of
    /// [`Mesh::geometry`], with the same operations.
    fn face(&self, i: u32) -> Face {
        let (ix, [a, b, c]) = self.corners(i);
        let (e1, e2) = (b - a, c - a);
        let n = winding_normal(e1, e2);
        let ns = self.normals.get(ix[0]).map_or(n, |&s| unit_or(s, n));
        let dpdu = self.dpdu(ix, e1, e2);
        Face {
            n: self.on_side_of(n, ns),
            ns,
            dpdu,
            frame: Frame::from_normal_tangent(ns, dpdu),
        }
    }

    /// [`Mesh::geometry`] of flat-shaded triangle `i`, with its face `f`: only the point and
    /// the texture coordinates are computed (with the same operations).
    #[inline(always)]
    pub(crate) fn geometry_of_face(
        &self,
        i: u32,
        beta: f32,
        gamma: f32,
        f: &Face,
    ) -> LocalGeometry {
        let (ix, corners) = self.corners(i);
        let (p, uv) = self.point_and_uv(ix, corners, beta, gamma);
        LocalGeometry {
            p,
            n: f.n,
            ns: f.ns,
            uv,
            dpdu: f.dpdu,
        }
    }

    /// The mesh moved by `t` (positions by `t`, normals by its inverse transpose).
    pub fn transformed(&self, t: &crate::math::Transform) -> Mesh {
        let mut m = self.clone();
        for p in &mut m.positions {
            *p = t.point(*p);
        }
        for n in &mut m.normals {
            *n = t.normal(*n).normalize();
        }
        if t.swaps_handedness() {
            // Keep the winding outward: a mirror image reverses it.
            for tri in &mut m.indices {
                tri.swap(1, 2);
            }
        }
        m
    }

    /// The point at barycentrics (β, γ) of triangle `i` with its geometric normal (for light
    /// sampling).
    pub fn point(&self, i: u32, beta: f32, gamma: f32) -> (Point3, Normal3) {
        let g = self.geometry(i, beta, gamma);
        (g.p, g.n)
    }
}

/// The unit normal of a triangle with edges `e1`, `e2` (following the winding; +z for a
/// degenerate triangle).
#[inline(always)]
fn winding_normal(e1: Vec3, e2: Vec3) -> Normal3 {
    let n = e1.cross(e2).normalize().to_normal();
    if n.x.is_finite() {
        n
    } else {
        Normal3::new(0.0, 0.0, 1.0)
    }
}

/// `s` made unit length, or `fallback` when it has no direction.
#[inline(always)]
fn unit_or(s: Normal3, fallback: Normal3) -> Normal3 {
    let len = s.to_vec().norm();
    if len > 0.0 && len.is_finite() {
        s / len
    } else {
        fallback
    }
}

/// The watertight ray–triangle test. Returns `t` and (β, γ) in `uv`.
#[inline]
pub fn intersect_triangle(
    a: Point3,
    b: Point3,
    c: Point3,
    ray: &Ray,
    sr: &ShearedRay,
) -> Option<ShapeHit> {
    let [kx, ky, kz] = sr.k;
    let [sx, sy, sz] = sr.s;
    // Translate the vertices to the ray origin, then shear so that the ray runs along +z.
    let (pa, pb, pc) = (a - ray.o, b - ray.o, c - ray.o);
    let (ax, ay) = (pa[kx] - sx * pa[kz], pa[ky] - sy * pa[kz]);
    let (bx, by) = (pb[kx] - sx * pb[kz], pb[ky] - sy * pb[kz]);
    let (cx, cy) = (pc[kx] - sx * pc[kz], pc[ky] - sy * pc[kz]);
    // The scaled barycentrics are the 2D edge functions.
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    // On an edge, f32 cannot decide the sign: redo the edge functions in f64.
    if u == 0.0 || v == 0.0 || w == 0.0 {
        let f = |a: f32, b: f32, c: f32, d: f32| (a as f64 * b as f64 - c as f64 * d as f64) as f32;
        u = f(cx, by, cy, bx);
        v = f(ax, cy, ay, cx);
        w = f(bx, ay, by, ax);
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let (az, bz, cz) = (sz * pa[kz], sz * pb[kz], sz * pc[kz]);
    let t_scaled = u * az + v * bz + w * cz;
    let inv_det = 1.0 / det;
    let t = t_scaled * inv_det;
    if !(t > ray.tmin && t < ray.tmax) {
        return None;
    }
    Some(ShapeHit {
        t,
        uv: [v * inv_det, w * inv_det],
        sub: 0,
        leaf: 0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;

    /// The branch-free axes are the ones the definition gives: z along the largest |d| (ties
    /// to the later axis, as `Vec3::max_dimension`), x and y swapped when d[z] < 0.
    #[test]
    fn sheared_ray_axes_follow_the_definition() {
        let mut rng = crate::sampling::Pcg32::new(3, 1);
        let vals = [0.0, -0.0, 1.0, -1.0, 0.5, -0.5, 2.0];
        let mut dirs: Vec<Vec3> = Vec::new();
        for &x in &vals {
            for &y in &vals {
                for &z in &vals {
                    dirs.push(Vec3::new(x, y, z));
                }
            }
        }
        dirs.extend((0..1000).map(|_| {
            Vec3::new(
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
            )
        }));
        for d in dirs {
            let kz = d.max_dimension();
            let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
            if d[kz] < 0.0 {
                std::mem::swap(&mut kx, &mut ky);
            }
            let ray = Ray::new(Point3::ORIGIN, d);
            assert_eq!(ShearedRay::axes(&ray), [kx, ky, kz], "{d:?}");
        }
    }

    fn one(a: Point3, b: Point3, c: Point3) -> Mesh {
        Mesh {
            positions: vec![a, b, c],
            indices: vec![[0, 1, 2]],
            ..Default::default()
        }
    }

    fn hit(m: &Mesh, r: &Ray) -> Option<ShapeHit> {
        m.intersect(0, r, &ShearedRay::new(r))
    }

    #[test]
    fn hits_by_hand() {
        let m = one(
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
        );
        let r = Ray::new(Point3::new(0.25, 0.5, 2.0), Vec3::new(0.0, 0.0, -1.0));
        let h = hit(&m, &r).unwrap();
        assert_eq!(h.t, 2.0);
        assert_eq!(h.uv, [0.25, 0.5]);
        let g = m.geometry(0, h.uv[0], h.uv[1]);
        assert_eq!(g.p, Point3::new(0.25, 0.5, 0.0));
        assert_eq!(g.n, Normal3::new(0.0, 0.0, 1.0));
        assert_eq!((g.uv.x, g.uv.y), (0.25, 0.5));
        // From below: same hit, same (unflipped) normal.
        let r = Ray::new(Point3::new(0.25, 0.5, -3.0), Vec3::new(0.0, 0.0, 1.0));
        assert_eq!(hit(&m, &r).unwrap().t, 3.0);
        // Outside the triangle, parallel to it, behind the ray.
        assert!(hit(
            &m,
            &Ray::new(Point3::new(0.75, 0.75, 2.0), Vec3::new(0.0, 0.0, -1.0))
        )
        .is_none());
        assert!(hit(&m, &Ray::new(Point3::new(-1.0, 0.25, 0.0), Vec3::X)).is_none());
        assert!(hit(&m, &Ray::new(Point3::new(0.25, 0.25, 2.0), Vec3::Z)).is_none());
    }

    #[test]
    fn edges_and_vertices_count_as_inside() {
        let m = one(
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
        );
        for (x, y) in [
            (0.5, 0.0),
            (0.0, 0.5),
            (0.5, 0.5),
            (0.0, 0.0),
            (1.0, 0.0),
            (0.0, 1.0),
        ] {
            let r = Ray::new(Point3::new(x, y, 1.0), Vec3::new(0.0, 0.0, -1.0));
            assert!(hit(&m, &r).is_some(), "({x}, {y})");
        }
    }

    #[test]
    fn shared_edges_do_not_leak() {
        // A unit square of two triangles, and many rays aimed exactly at its diagonal.
        let m = Mesh {
            positions: vec![
                Point3::new(0.0, 0.0, 0.0),
                Point3::new(1.0, 0.0, 0.0),
                Point3::new(1.0, 1.0, 0.0),
                Point3::new(0.0, 1.0, 0.0),
            ],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            ..Default::default()
        };
        let mut rng = crate::sampling::Pcg32::new(5, 6);
        for _ in 0..10_000 {
            let s = rng.next_f32();
            let target = Point3::new(s, s, 0.0);
            let o = Point3::new(
                rng.next_f32() * 4.0 - 2.0,
                rng.next_f32() * 4.0 - 2.0,
                1.0 + rng.next_f32(),
            );
            let r = Ray::new(o, target - o);
            let sr = ShearedRay::new(&r);
            assert!(
                m.intersect(0, &r, &sr).is_some() || m.intersect(1, &r, &sr).is_some(),
                "{r:?}"
            );
        }
    }

    #[test]
    fn vertex_normals_and_uvs_are_interpolated() {
        let mut m = one(
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(2.0, 0.0, 0.0),
            Point3::new(0.0, 2.0, 0.0),
        );
        m.normals = vec![
            Normal3::new(0.0, 0.0, 1.0),
            Normal3::new(1.0, 0.0, 0.0),
            Normal3::new(0.0, 1.0, 0.0),
        ];
        m.uvs = vec![
            Point2::new(0.0, 0.0),
            Point2::new(1.0, 0.0),
            Point2::new(0.0, 1.0),
        ];
        let g = m.geometry(0, 0.5, 0.0);
        assert!(g
            .ns
            .to_vec()
            .approx_eq(Vec3::new(1.0, 0.0, 1.0).normalize(), 1e-6));
        assert_eq!((g.uv.x, g.uv.y), (0.5, 0.0));
        assert!(g.dpdu.approx_eq(Vec3::new(2.0, 0.0, 0.0), 1e-6));
        // Vertex normals pointing below flip the geometric normal to their side.
        m.normals = vec![Normal3::new(0.0, 0.0, -1.0); 3];
        assert_eq!(m.geometry(0, 0.2, 0.2).n, Normal3::new(0.0, 0.0, -1.0));
    }

    /// A flat-shaded triangle's face gives what the triangle's geometry gives at every point:
    /// bit for bit without vertex normals, the same normal (up to round-off) with three equal
    /// ones; smooth and large meshes keep no faces.
    #[test]
    fn faces_give_the_geometry_of_flat_triangles() {
        let mut rng = crate::sampling::Pcg32::new(5, 9);
        let mut u = || rng.next_f32() * 4.0 - 2.0;
        let mut m = Mesh::default();
        for i in 0..20u32 {
            m.positions
                .extend((0..3).map(|_| Point3::new(u(), u(), u())));
            m.uvs.extend((0..3).map(|_| Point2::new(u(), u())));
            m.indices.push([3 * i, 3 * i + 2, 3 * i + 1]);
        }
        // A degenerate triangle and one with degenerate texture coordinates.
        m.positions[3] = m.positions[4];
        m.uvs[6] = m.uvs[7];
        let mut rng = crate::sampling::Pcg32::new(6, 1);
        let mut bary = || {
            let (b, c) = (rng.next_f32(), rng.next_f32());
            if b + c > 1.0 {
                (1.0 - b, 1.0 - c)
            } else {
                (b, c)
            }
        };
        for normals in [false, true] {
            if normals {
                // One normal per triangle, at its three corners (not unit length).
                m.normals = (0..20)
                    .flat_map(|i| {
                        let n = Normal3::new(0.3 * i as f32 - 2.0, 1.5, -0.5);
                        [n; 3]
                    })
                    .collect();
            }
            let faces = m.faces().expect("flat-shaded: faces");
            for (i, f) in faces.iter().enumerate() {
                for _ in 0..20 {
                    let (b, c) = bary();
                    let g = m.geometry(i as u32, b, c);
                    let h = m.geometry_of_face(i as u32, b, c, f);
                    assert_eq!(
                        (g.p, g.uv, g.dpdu, g.n),
                        (h.p, h.uv, h.dpdu, h.n),
                        "triangle {i}"
                    );
                    if normals {
                        assert!(g.ns.to_vec().approx_eq(h.ns.to_vec(), 1e-6), "triangle {i}");
                    } else {
                        assert_eq!(g.ns, h.ns);
                    }
                    assert_eq!(f.frame, Frame::from_normal_tangent(h.ns, h.dpdu));
                }
            }
        }
        // Smooth: no faces; nor for a mesh too large to keep them.
        m.normals[1] = Normal3::new(0.0, 0.0, 1.0);
        assert!(m.faces().is_none());
        m.normals.clear();
        let big = Mesh {
            indices: vec![[0, 1, 2]; FACE_TRIANGLES + 1],
            ..m.clone()
        };
        assert!(big.faces().is_none() && m.faces().is_some());
    }

    /// A quad as two triangles, from the corners in order and how they are split.
    fn quad(corners: [Point3; 4], indices: [[u32; 3]; 2]) -> Mesh {
        Mesh {
            positions: corners.to_vec(),
            indices: indices.to_vec(),
            ..Mesh::default()
        }
    }

    /// Quads of two triangles become parallelograms over the same surface, facing the same
    /// way: rays hit both or neither (away from the edges), at the same distance, and the
    /// parallelogram's normal is the triangles' winding normal; whatever the diagonal and
    /// the first vertex, and after a rotation that leaves the corners a few ulps off. Shapes
    /// that are not such quads stay meshes.
    #[test]
    fn quads_of_two_triangles_are_parallelograms() {
        let rot = crate::math::Transform::rotation(Vec3::new(0.3, 1.0, -0.2), 37.0).unwrap();
        let corners = [
            Point3::new(-1.0, 0.2, -0.7),
            Point3::new(0.8, 0.2, -0.7),
            Point3::new(0.8, 0.2, 0.9),
            Point3::new(-1.0, 0.2, 0.9),
        ]
        .map(|p| rot.point(p));
        let splits = [
            [[0, 1, 2], [0, 2, 3]],
            [[1, 2, 3], [1, 3, 0]],
            [[2, 0, 1], [3, 0, 2]],
            // Winding the other way.
            [[0, 2, 1], [0, 3, 2]],
        ];
        let mut rng = crate::sampling::Pcg32::new(4, 4);
        for split in splits {
            let m = quad(corners, split);
            let qs = m.parallelograms().expect("a parallelogram");
            assert_eq!(qs.len(), 1);
            let q = &qs[0];
            let [a, b, c] = m.vertices(0);
            let wind = (b - a).cross(c - a).normalize();
            assert!(q.normal().to_vec().dot(wind) > 0.999_999);
            let (mut hits, mut checked) = (0, 0);
            for _ in 0..4000 {
                let o = Point3::new(
                    rng.next_f32() * 6.0 - 3.0,
                    rng.next_f32() * 6.0 - 3.0,
                    rng.next_f32() * 6.0 - 3.0,
                );
                let target = rot.point(Point3::new(
                    rng.next_f32() * 2.4 - 1.2,
                    0.2,
                    rng.next_f32() * 2.0 - 0.9,
                ));
                let ray = Ray::new(o, (target - o).normalize());
                let sr = ShearedRay::new(&ray);
                let tri = (0..2)
                    .filter_map(|i| {
                        let [a, b, c] = m.vertices(i);
                        intersect_triangle(a, b, c, &ray, &sr).map(|h| h.t)
                    })
                    .reduce(f32::min);
                let par = q.intersect(&ray).map(|h| h.t);
                // Away from the edges (the target's plane coordinates).
                let local = rot.inv_point(target);
                let near_edge = [local.x + 1.0, 0.8 - local.x, local.z + 0.7, 0.9 - local.z]
                    .iter()
                    .any(|d| d.abs() < 1e-3);
                if near_edge {
                    continue;
                }
                checked += 1;
                match (tri, par) {
                    (Some(t1), Some(t2)) => {
                        hits += 1;
                        // Both distances carry f32 round-off, which grows as the ray grazes
                        // the plane (1/|cos θ|).
                        let cos = ray.d.dot(wind).abs();
                        assert!((t1 - t2).abs() <= 1e-5 * t1.max(1.0) / cos, "{t1} {t2}");
                    }
                    (None, None) => {}
                    other => panic!("{other:?} for {ray:?}"),
                }
            }
            assert!(hits > 1000 && checked > 3500, "{hits} of {checked}");
        }
        // Two quads in one mesh.
        let mut two = quad(corners, splits[0]);
        two.positions
            .extend(corners.map(|p| p + Vec3::new(0.0, 3.0, 0.0)));
        two.indices.extend([[4, 5, 6], [4, 6, 7]]);
        assert_eq!(two.parallelograms().map(|q| q.len()), Some(2));

        // Not parallelograms: a trapezoid, triangles winding against each other, triangles
        // sharing no edge, an odd count, smooth normals, too many triangles.
        let mut trapezoid = corners;
        trapezoid[2] = rot.point(Point3::new(0.5, 0.2, 0.9));
        assert!(quad(trapezoid, splits[0]).parallelograms().is_none());
        assert!(quad(corners, [[0, 1, 2], [0, 3, 2]])
            .parallelograms()
            .is_none());
        assert!(quad(corners, [[0, 1, 2], [3, 3, 3]])
            .parallelograms()
            .is_none());
        let mut odd = quad(corners, splits[0]);
        odd.indices.push([0, 1, 2]);
        assert!(odd.parallelograms().is_none());
        let mut smooth = quad(corners, splits[0]);
        let n = smooth.parallelograms().unwrap()[0].normal();
        smooth.normals = vec![n; 4];
        assert!(smooth.parallelograms().is_some(), "flat normals are fine");
        smooth.normals[2] = (n.to_vec() + Vec3::new(0.1, 0.0, 0.0))
            .normalize()
            .to_normal();
        assert!(smooth.parallelograms().is_none());
        let mut many = quad(corners, splits[0]);
        for _ in 0..MAX_PARALLELOGRAM_TRIANGLES / 2 {
            many.indices.extend([[0, 1, 2], [0, 2, 3]]);
        }
        assert!(many.parallelograms().is_none());
    }
}
