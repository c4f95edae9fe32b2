//! Hemicube form factors (Cohen and Greenberg 1985), the lecture's image-precision method.
//!
//! A half cube of side 2 stands on the patch's centre, its top face at height 1 along the
//! normal and four half faces around it, each cut into pixels: `res × res` on the top,
//! `res × res/2` on each side (`RadiosityOptions::hemicube_resolution`, default 128). Each pixel carries its
//! *delta form factor*, the form factor from the differential patch to the pixel:
//! ΔF = ΔA / (π (x² + y² + 1)²) on the top face (pixel centre (x, y, 1)) and
//! ΔF = z ΔA / (π (y² + z² + 1)²) on a side face (pixel centre (1, y, z)), with ΔA = (2/res)²;
//! the table is normalised so that the pixels sum exactly to 1.
//!
//! Every leaf element of the scene is projected onto the five faces (clipped to each face's
//! frustum and to the patch's tangent plane), rasterised with a z-buffer that keeps the nearest
//! surface per pixel, and the pixel's ΔF goes to the patch of the element's side that faces the
//! eye. Σ_j F_ij is then the fraction of the hemisphere covered by patches: 1 in a closed room
//! (up to gaps between polygons, which are measure zero). Elements whose facing side has no patch
//! absorb what they cover. The depth test compares 1/depth, interpolated exactly from the
//! element's plane equation.

use super::mesh::Meshing;
use super::row::{Row, RowAcc};
use super::NONE;
use crate::math::{Frame, Point3, Vec3};

/// An item-buffer value: nothing drawn.
const EMPTY: u32 = u32::MAX;
/// An item-buffer value: a surface without a patch on the visible side.
const ABSORBER: u32 = u32::MAX - 1;

/// The scene's leaf elements, ready to be projected.
#[derive(Clone, Debug, Default)]
pub(crate) struct Raster {
    elems: Vec<RasterElem>,
}

#[derive(Clone, Debug)]
struct RasterElem {
    v: [Point3; 4],
    nv: u8,
    /// Unit polygon normal (front side).
    pn: Vec3,
    /// Centroid of the corners and the radius of the bounding sphere around it.
    mid: Point3,
    radius: f32,
    patch: [u32; 2],
    elem: u32,
}

impl Raster {
    /// Collects the leaf elements of `mesh`.
    pub fn new(mesh: &Meshing) -> Self {
        let mut elems = Vec::new();
        for (i, e) in mesh.elements.iter().enumerate() {
            if e.children != NONE || !(e.area > 0.0) {
                continue;
            }
            let n = e.nverts as usize;
            let mut mid = Vec3::ZERO;
            for c in &e.corners[..n] {
                mid += c.to_vec();
            }
            let mid = (mid / n as f32).to_point();
            let radius = e.corners[..n]
                .iter()
                .map(|c| c.distance(mid))
                .fold(0.0, f32::max);
            elems.push(RasterElem {
                v: e.corners,
                nv: e.nverts,
                pn: e.pnormal,
                mid,
                radius,
                patch: e.patch,
                elem: i as u32,
            });
        }
        Self { elems }
    }
}

/// The delta form factors of a hemicube of resolution `res`.
#[derive(Clone, Debug)]
pub(crate) struct Hemicube {
    res: usize,
    top: Vec<f32>,
    side: Vec<f32>,
}

/// Per-thread buffers: 1/depth and item per pixel of the five faces.
#[derive(Clone, Debug, Default)]
pub(crate) struct HemicubeScratch {
    w: Vec<f32>,
    item: Vec<u32>,
}

impl Hemicube {
    /// The table for resolution `res` (rounded up to an even number, at least 8).
    pub fn new(res: u32) -> Self {
        let res = (res.max(8) as usize).div_ceil(2) * 2;
        let half = res / 2;
        let d = 2.0 / res as f64;
        let da = d * d;
        let mut top = vec![0f64; res * res];
        let mut side = vec![0f64; res * half];
        for j in 0..res {
            for i in 0..res {
                let (x, y) = ((i as f64 + 0.5) * d - 1.0, (j as f64 + 0.5) * d - 1.0);
                let r = x * x + y * y + 1.0;
                top[j * res + i] = da / (std::f64::consts::PI * r * r);
            }
        }
        for j in 0..half {
            for i in 0..res {
                let (y, z) = ((i as f64 + 0.5) * d - 1.0, (j as f64 + 0.5) * d);
                let r = y * y + z * z + 1.0;
                side[j * res + i] = z * da / (std::f64::consts::PI * r * r);
            }
        }
        let total: f64 = top.iter().sum::<f64>() + 4.0 * side.iter().sum::<f64>();
        Self {
            res,
            top: top.iter().map(|x| (x / total) as f32).collect(),
            side: side.iter().map(|x| (x / total) as f32).collect(),
        }
    }

    /// Pixels of the five faces.
    fn pixels(&self) -> usize {
        self.res * self.res + 4 * self.res * (self.res / 2)
    }

    /// Fresh buffers for one thread.
    pub fn scratch(&self) -> HemicubeScratch {
        HemicubeScratch {
            w: vec![0.0; self.pixels()],
            item: vec![EMPTY; self.pixels()],
        }
    }

    /// Row `i` of the form-factor matrix: F_ij for every patch j seen from patch i's centre.
    pub fn row(
        &self,
        raster: &Raster,
        mesh: &Meshing,
        i: u32,
        scratch: &mut HemicubeScratch,
        acc: &mut RowAcc,
    ) -> Row {
        let p = &mesh.patches[i as usize];
        let (c, n) = (p.centre, p.normal);
        let frame = Frame::from_normal(n.to_normal());
        let eps = 1e-6 * mesh.scale;
        scratch.w.fill(0.0);
        scratch.item.fill(EMPTY);
        let res = self.res;
        let half = res / 2;
        for re in &raster.elems {
            if re.elem == p.elem {
                continue;
            }
            // Entirely below the tangent plane?
            if (re.mid - c).dot(n) + re.radius <= eps {
                continue;
            }
            // Which side of the element faces the eye (edge-on: invisible).
            let k = re.pn.dot(c - re.v[0]);
            if k.abs() <= eps * 1e-3 {
                continue;
            }
            let item = match re.patch[if k > 0.0 { 0 } else { 1 }] {
                NONE => ABSORBER,
                id => id,
            };
            let nv = re.nv as usize;
            let mut local = [[0f32; 3]; 4];
            let mut zmax = f32::NEG_INFINITY;
            for (l, v) in local.iter_mut().zip(&re.v[..nv]) {
                let q = frame.to_local(*v - c);
                *l = [q.x, q.y, q.z];
                zmax = zmax.max(q.z);
            }
            if zmax <= eps {
                continue;
            }
            let pl = frame.to_local(re.pn);
            // The plane n·x = kk in local coordinates (kk ≠ 0 since the eye is off the plane).
            let kk = -k;
            // The outcodes of all five faces at once (5 bits per face).
            let (mut all_and, mut all_or) = (u32::MAX, 0u32);
            for q in &local[..nv] {
                let c = all_outcodes(q, eps);
                all_and &= c;
                all_or |= c;
            }
            for face in 0..5usize {
                if (all_and >> (5 * face)) & 0x1f != 0 {
                    continue;
                }
                let or = ((all_or >> (5 * face)) & 0x1f) as u8;
                let top = face == 0;
                let mut poly = [[0f32; 3]; 12];
                for (dst, src) in poly.iter_mut().zip(&local[..nv]) {
                    *dst = to_face(face, *src);
                }
                let count = if or == 0 {
                    nv
                } else {
                    clip(&mut poly, nv, eps, top, or)
                };
                if count < 3 {
                    continue;
                }
                let nf = to_face(face, [pl.x, pl.y, pl.z]);
                let (offset, rows) = if top {
                    (0, res)
                } else {
                    (res * res + (face - 1) * res * half, half)
                };
                let mut buffer = FaceBuffer {
                    res,
                    rows,
                    top,
                    w: &mut scratch.w[offset..offset + res * rows],
                    item: &mut scratch.item[offset..offset + res * rows],
                };
                raster_polygon(
                    &mut buffer,
                    &poly[..count],
                    [nf[0] / kk, nf[1] / kk, nf[2] / kk],
                    item,
                );
            }
        }
        // Sum the delta form factors per patch (runs of equal items first), and those of
        // absorbers and of surfaces nearer than half the patch size (1/depth above w_near).
        let top_px = res * res;
        let side_px = res * half;
        let w_near = 2.0 / mesh.patch_size.max(eps);
        let mut occluded = 0f64;
        let mut add_face = |items: &[u32], ws: &[f32], table: &[f32]| {
            let (mut cur, mut sum) = (EMPTY, 0f64);
            for ((&it, &df), &w) in items.iter().zip(table).zip(ws) {
                if it == ABSORBER || (it != EMPTY && w > w_near) {
                    occluded += df as f64;
                }
                if it != cur {
                    if cur < ABSORBER {
                        acc.add(cur, sum);
                    }
                    cur = it;
                    sum = 0.0;
                }
                sum += df as f64;
            }
            if cur < ABSORBER {
                acc.add(cur, sum);
            }
        };
        add_face(&scratch.item[..top_px], &scratch.w[..top_px], &self.top);
        for f in 0..4 {
            let off = top_px + f * side_px;
            add_face(
                &scratch.item[off..off + side_px],
                &scratch.w[off..off + side_px],
                &self.side,
            );
        }
        let mut row = acc.finish();
        row.occluded = occluded as f32;
        row
    }
}

/// Local coordinates (x, y, z) to the coordinates (a, b, d) of a face: the top looks along
/// +z; the sides along ±x and ±y, with b the height above the tangent plane.
#[inline]
fn to_face(face: usize, q: [f32; 3]) -> [f32; 3] {
    match face {
        0 => [q[0], q[1], q[2]],
        1 => [q[1], q[2], q[0]],
        2 => [q[1], q[2], -q[0]],
        3 => [q[0], q[2], q[1]],
        _ => [q[0], q[2], -q[1]],
    }
}

/// The value of clipping plane `k` at `p` (inside when ≥ 0): d ≥ eps, a ≤ d, −a ≤ d, b ≤ d,
/// and −b ≤ d (top) or b ≥ 0 (sides).
#[inline]
fn plane(k: u32, p: &[f32; 3], eps: f32, top: bool) -> f32 {
    match k {
        0 => p[2] - eps,
        1 => p[2] - p[0],
        2 => p[2] + p[0],
        3 => p[2] - p[1],
        _ => {
            if top {
                p[2] + p[1]
            } else {
                p[1]
            }
        }
    }
}

/// The bits of the clipping planes that `p` is outside of (see [`all_outcodes`]).
#[cfg(test)]
fn outcode(p: &[f32; 3], eps: f32, top: bool) -> u8 {
    let mut c = 0u8;
    for k in 0..5 {
        c |= ((plane(k, p, eps, top) < 0.0) as u8) << k;
    }
    c
}

/// The outcodes of the local point `q` for the five faces, face f in bits 5f..5f+5 (the same
/// bits as [`outcode`] of the face coordinates).
#[inline]
fn all_outcodes(q: &[f32; 3], eps: f32) -> u32 {
    let [x, y, z] = *q;
    let b = |c: bool, k: u32| (c as u32) << k;
    let side = |d: f32, a: f32, f: u32| -> u32 {
        let o = 5 * f;
        b(d < eps, o) | b(a > d, o + 1) | b(-a > d, o + 2) | b(z > d, o + 3) | b(z < 0.0, o + 4)
    };
    let top = b(z < eps, 0) | b(x > z, 1) | b(-x > z, 2) | b(y > z, 3) | b(-y > z, 4);
    top | side(x, y, 1) | side(-x, y, 2) | side(y, x, 3) | side(-y, x, 4)
}

/// Clips the polygon `poly[..n]` (face coordinates) by the planes whose bits are in `planes`.
/// Returns the new vertex count (< 3: nothing left).
fn clip(poly: &mut [[f32; 3]; 12], n: usize, eps: f32, top: bool, planes: u8) -> usize {
    let mut n = n;
    let mut tmp = [[0f32; 3]; 12];
    for k in 0..5u32 {
        if planes & (1 << k) == 0 {
            continue;
        }
        let mut m = 0;
        for i in 0..n {
            let (a, b) = (poly[i], poly[if i + 1 == n { 0 } else { i + 1 }]);
            let (fa, fb) = (plane(k, &a, eps, top), plane(k, &b, eps, top));
            if fa >= 0.0 && m < 12 {
                tmp[m] = a;
                m += 1;
            }
            if (fa >= 0.0) != (fb >= 0.0) && m < 12 {
                let t = fa / (fa - fb);
                tmp[m] = [
                    a[0] + (b[0] - a[0]) * t,
                    a[1] + (b[1] - a[1]) * t,
                    a[2] + (b[2] - a[2]) * t,
                ];
                m += 1;
            }
        }
        if m < 3 {
            return 0;
        }
        poly[..m].copy_from_slice(&tmp[..m]);
        n = m;
    }
    n
}

/// ⌈x⌉ without a libm call (x within the i32 range).
#[inline]
fn ceil_i(x: f32) -> i32 {
    let i = x as i32;
    i + ((i as f32) < x) as i32
}

/// ⌊x⌋ without a libm call (x within the i32 range).
#[inline]
fn floor_i(x: f32) -> i32 {
    let i = x as i32;
    i - ((i as f32) > x) as i32
}

/// One face of the hemicube being rasterised: `rows` rows of `res` pixels (the top face, or
/// the upper half of a side face), each with its 1/depth and the item seen.
struct FaceBuffer<'a> {
    res: usize,
    rows: usize,
    top: bool,
    w: &'a mut [f32],
    item: &'a mut [u32],
}

/// Rasterises a clipped convex polygon into one face: pixels whose centre is inside get the
/// item when the polygon's 1/depth `w = plane·(sa, sb, 1)` is larger than the stored one.
fn raster_polygon(face: &mut FaceBuffer, poly: &[[f32; 3]], plane: [f32; 3], item: u32) {
    let (res, rows, top) = (face.res, face.rows, face.top);
    let d = 2.0 / res as f32;
    let inv_d = res as f32 / 2.0;
    // Pixel coordinates.
    let mut pts = [[0f32; 2]; 12];
    let n = poly.len();
    let (mut ymin, mut ymax) = (f32::INFINITY, f32::NEG_INFINITY);
    for (q, p) in pts.iter_mut().zip(poly) {
        let (sa, sb) = (p[0] / p[2], p[1] / p[2]);
        let x = (sa + 1.0) * inv_d;
        let y = if top { (sb + 1.0) * inv_d } else { sb * inv_d };
        *q = [x, y];
        ymin = ymin.min(y);
        ymax = ymax.max(y);
    }
    if !(ymin.is_finite() && ymax.is_finite()) {
        return;
    }
    let j0 = ceil_i((ymin - 0.5).max(0.0)).max(0) as usize;
    let j1 = floor_i((ymax - 0.5).min(rows as f32 - 1.0));
    if j1 < 0 {
        return;
    }
    let j1 = (j1 as usize).min(rows - 1);
    let boff = if top { -1.0 } else { 0.0 };
    for j in j0..=j1 {
        let yc = j as f32 + 0.5;
        let (mut xl, mut xr) = (f32::INFINITY, f32::NEG_INFINITY);
        for k in 0..n {
            let (a, b) = (pts[k], pts[if k + 1 == n { 0 } else { k + 1 }]);
            if (a[1] <= yc && yc < b[1]) || (b[1] <= yc && yc < a[1]) {
                let x = a[0] + (b[0] - a[0]) * ((yc - a[1]) / (b[1] - a[1]));
                xl = xl.min(x);
                xr = xr.max(x);
            }
        }
        if !(xl < xr) {
            continue;
        }
        let i0 = ceil_i((xl - 0.5).clamp(0.0, res as f32)) as usize;
        let i1 = ceil_i((xr - 0.5).clamp(0.0, res as f32)) as usize;
        if i1 <= i0 {
            continue;
        }
        let sb = yc * d + boff;
        let row = j * res;
        let wb = plane[1] * sb + plane[2];
        // Branch-free depth test over the span (vectorises).
        let ws = &mut face.w[row + i0..row + i1];
        let is = &mut face.item[row + i0..row + i1];
        let (w0, dw) = (plane[0] * ((i0 as f32 + 0.5) * d - 1.0) + wb, plane[0] * d);
        for (k, (wp, ip)) in ws.iter_mut().zip(is.iter_mut()).enumerate() {
            let w = w0 + dw * k as f32;
            let nearer = w > *wp;
            *wp = if nearer { w } else { *wp };
            *ip = if nearer { item } else { *ip };
        }
    }
}

/// The total of a hemicube's delta form factors (1 after normalisation), for tests.
#[allow(dead_code)]
pub(crate) fn table_total(h: &Hemicube) -> f64 {
    h.top.iter().map(|&x| x as f64).sum::<f64>()
        + 4.0 * h.side.iter().map(|&x| x as f64).sum::<f64>()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn delta_form_factors_sum_to_one_and_follow_the_cosine_law() {
        for res in [8, 64, 255] {
            let h = Hemicube::new(res);
            assert_eq!(h.res % 2, 0);
            assert!((table_total(&h) - 1.0).abs() < 1e-5);
            // The top face's share is the form factor to a square of half side 1 at height 1.
            let top: f64 = h.top.iter().map(|&x| x as f64).sum();
            let exact = {
                // Parallel squares 2 × 2 at distance 1 from a point: 4·(1/(2π))·(a/√(1+a²))·atan(b/√(1+a²)) for
                // the quarter a = b = 1.
                let r = 2f64.sqrt();
                4.0 / (2.0 * std::f64::consts::PI) * (1.0 / r) * (1.0 / r).atan() * 2.0
            };
            if res >= 64 {
                assert!(
                    (top - exact).abs() < 2e-3,
                    "{res}: top {top}, exact {exact}"
                );
            }
        }
    }

    #[test]
    fn clipping_keeps_what_is_inside_the_frustum() {
        // A square straddling the top face's edge a = d at depth 1.
        let mut poly = [[0f32; 3]; 12];
        poly[..4].copy_from_slice(&[
            [0.5, -0.5, 1.0],
            [1.5, -0.5, 1.0],
            [1.5, 0.5, 1.0],
            [0.5, 0.5, 1.0],
        ]);
        let codes: Vec<u8> = poly[..4].iter().map(|p| outcode(p, 1e-6, true)).collect();
        let or = codes.iter().fold(0, |a, &c| a | c);
        let n = clip(&mut poly, 4, 1e-6, true, or);
        assert_eq!(n, 4);
        assert!(poly[..n]
            .iter()
            .all(|p| p[0] <= 1.0 + 1e-6 && p[0] >= 0.5 - 1e-6));
        // Below the base of a side face: nothing left.
        let mut poly = [[0f32; 3]; 12];
        poly[..3].copy_from_slice(&[[0.0, -0.5, 1.0], [0.5, -0.2, 1.0], [0.2, -0.1, 1.0]]);
        let and = poly[..3]
            .iter()
            .fold(0x1f, |a, p| a & outcode(p, 1e-6, false));
        assert_ne!(and, 0);
        assert_eq!(
            (ceil_i(-1.5), ceil_i(1.2), floor_i(-1.5), floor_i(1.0)),
            (-1, 2, -2, 1)
        );
        // The five faces' outcodes at once agree with each face's own.
        let mut rng = crate::sampling::Pcg32::new(3, 4);
        for _ in 0..10_000 {
            let q = [
                rng.next_f32() * 4.0 - 2.0,
                rng.next_f32() * 4.0 - 2.0,
                rng.next_f32() * 4.0 - 2.0,
            ];
            let all = all_outcodes(&q, 1e-3);
            for face in 0..5 {
                let own = outcode(&to_face(face, q), 1e-3, face == 0) as u32;
                assert_eq!((all >> (5 * face)) & 0x1f, own, "{q:?} face {face}");
            }
        }
    }
}
