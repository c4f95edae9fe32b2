//! Elements (nodes of the subdivision forest of each surface) and patches (one side of a leaf
//! element): building them from their corners, and splitting them.

use super::Meshing;
use crate::math::{Point3, Vec3};
use crate::radiosity::NONE;

/// A node of the element forest.
#[derive(Clone, Debug)]
pub(crate) struct Element {
    /// The surface it lies on.
    pub surface: u32,
    /// Quad domains: (s0, t0, s1, t1). Triangle domains: unused.
    pub rect: [f32; 4],
    /// Triangle domains: the three parameter corners.
    pub tri: [[f32; 2]; 3],
    /// World corners (quads: (s0,t0), (s1,t0), (s1,t1), (s0,t1); triangles: a, b, c, c).
    pub corners: [Point3; 4],
    /// 3 or 4.
    pub nverts: u8,
    /// The true surface point at the parameter centre.
    pub centre: Point3,
    /// The unit front normal at the centre.
    pub normal: Vec3,
    /// The unit normal of the planar polygon, on the side of `normal`.
    pub pnormal: Vec3,
    /// Area of the planar polygon.
    pub area: f32,
    /// First of the four children, or NONE for a leaf.
    pub children: u32,
    /// The parent, or NONE for a root.
    pub parent: u32,
    /// Adaptive refinement depth (uniform splits of large triangles do not count).
    pub level: u8,
    /// Patch of each side (NONE when that side has none).
    pub patch: [u32; 2],
}

impl Element {
    /// The parameter point at local coordinates (a, b) ∈ [0,1]² (quads) or barycentrics of the
    /// element's second and third corners (triangles).
    #[inline]
    pub fn param(&self, tri: bool, a: f32, b: f32) -> (f32, f32) {
        if tri {
            let [p0, p1, p2] = self.tri;
            let c = 1.0 - a - b;
            (
                c * p0[0] + a * p1[0] + b * p2[0],
                c * p0[1] + a * p1[1] + b * p2[1],
            )
        } else {
            let [s0, t0, s1, t1] = self.rect;
            (s0 + (s1 - s0) * a, t0 + (t1 - t0) * b)
        }
    }

    /// The largest edge of the polygon.
    pub fn max_edge(&self) -> f32 {
        let n = self.nverts as usize;
        (0..n)
            .map(|k| self.corners[k].distance(self.corners[(k + 1) % n]))
            .fold(0.0, f32::max)
    }
}

/// A patch: one side of a leaf element, with its Lambertian data.
#[derive(Clone, Debug)]
pub(crate) struct Patch {
    /// The leaf element it is a side of.
    pub elem: u32,
    /// 0 front, 1 back.
    pub side: u8,
    /// Area.
    pub area: f64,
    /// Reflectance ρ per channel.
    pub rho: [f64; 3],
    /// Emitted radiosity E = π·L_e per channel.
    pub emit: [f64; 3],
    /// The centre on the true surface and the unit normal of this side.
    pub centre: Point3,
    /// Unit normal of its side.
    pub normal: Vec3,
}

impl Meshing {
    pub(super) fn make_quad(&self, sid: u32, rect: [f32; 4], level: u8) -> Element {
        let map = &self.surfaces[sid as usize].map;
        let [s0, t0, s1, t1] = rect;
        let corners = [
            map.point(s0, t0),
            map.point(s1, t0),
            map.point(s1, t1),
            map.point(s0, t1),
        ];
        let (sc, tc) = (0.5 * (s0 + s1), 0.5 * (t0 + t1));
        let centre = map.point(sc, tc);
        let normal = map.normal(sc, tc);
        let cross = (corners[2] - corners[0]).cross(corners[3] - corners[1]);
        let outline = Outline {
            corners,
            nverts: 4,
            centre,
            normal,
            cross,
        };
        finish(sid, rect, [[0.0; 2]; 3], outline, level)
    }

    pub(super) fn make_tri(&self, sid: u32, tri: [[f32; 2]; 3], level: u8) -> Element {
        let map = &self.surfaces[sid as usize].map;
        let [a, b, c] = tri.map(|p| map.point(p[0], p[1]));
        let (sc, tc) = (
            (tri[0][0] + tri[1][0] + tri[2][0]) / 3.0,
            (tri[0][1] + tri[1][1] + tri[2][1]) / 3.0,
        );
        let centre = map.point(sc, tc);
        let normal = map.normal(sc, tc);
        let cross = (b - a).cross(c - a);
        let outline = Outline {
            corners: [a, b, c, c],
            nverts: 3,
            centre,
            normal,
            cross,
        };
        finish(sid, [0.0; 4], tri, outline, level)
    }

    /// Splits element `i` into four children (one refinement level deeper when `refine`);
    /// returns the index of the first.
    pub fn split(&mut self, i: u32, refine: bool) -> u32 {
        let e = self.elements[i as usize].clone();
        let first = self.elements.len() as u32;
        let tri = self.surfaces[e.surface as usize].map.is_triangle();
        let level = if refine {
            e.level.saturating_add(1)
        } else {
            e.level
        };
        let kids: Vec<Element> = if tri {
            let [p0, p1, p2] = e.tri;
            let mid = |a: [f32; 2], b: [f32; 2]| [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
            let (m01, m12, m02) = (mid(p0, p1), mid(p1, p2), mid(p0, p2));
            [
                [p0, m01, m02],
                [m01, p1, m12],
                [m02, m12, p2],
                [m12, m02, m01],
            ]
            .into_iter()
            .map(|t| self.make_tri(e.surface, t, level))
            .collect()
        } else {
            let [s0, t0, s1, t1] = e.rect;
            let (sm, tm) = (0.5 * (s0 + s1), 0.5 * (t0 + t1));
            [
                [s0, t0, sm, tm],
                [sm, t0, s1, tm],
                [s0, tm, sm, t1],
                [sm, tm, s1, t1],
            ]
            .into_iter()
            .map(|r| self.make_quad(e.surface, r, level))
            .collect()
        };
        self.elements.extend(kids.into_iter().map(|mut k| {
            k.parent = i;
            k
        }));
        let el = &mut self.elements[i as usize];
        el.children = first;
        el.patch = [NONE; 2];
        first
    }
}

/// The planar polygon of an element's corners (which lie on the true surface), with the true
/// surface's centre and normal.
struct Outline {
    /// The corners (a triangle repeats its last one).
    corners: [Point3; 4],
    /// 3 or 4.
    nverts: u8,
    /// The surface point at the centre of the element's parameter domain.
    centre: Point3,
    /// The surface normal there.
    normal: Vec3,
    /// The polygon's cross product (2·area·normal).
    cross: Vec3,
}

/// Completes an element of surface `surface` over the parameter rectangle `rect` (quads) or
/// triangle `tri` (triangles) from its outline.
fn finish(surface: u32, rect: [f32; 4], tri: [[f32; 2]; 3], o: Outline, level: u8) -> Element {
    let Outline {
        corners,
        nverts,
        centre,
        normal,
        cross,
    } = o;
    let len = cross.norm();
    let area = if len.is_finite() { 0.5 * len } else { 0.0 };
    let normal = if normal.is_finite() && normal.norm() > 0.0 {
        normal
    } else {
        Vec3::Z
    };
    let mut pnormal = if len > 0.0 && len.is_finite() {
        cross / len
    } else {
        normal
    };
    if pnormal.dot(normal) < 0.0 {
        pnormal = -pnormal;
    }
    Element {
        surface,
        rect,
        tri,
        corners,
        nverts,
        centre,
        normal,
        pnormal,
        area,
        children: NONE,
        parent: NONE,
        level,
        patch: [NONE; 2],
    }
}
