//! Hemicube form factors (Cohen and Greenberg 1985), the lecture's image-precision method.
//!
//! A half cube of side 2 stands on the patch's centre, its top face at height 1 along the
//! normal and four half faces around it, each cut into pixels: `res × res` on the top,
//! `res × res/2` on each side (`--hemicube-resolution`, default 256). Each pixel carries its
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

use super::formfactor::{Row, RowAcc};
use super::mesh::Meshing;
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
            let radius = e.corners[..n].iter().map(|c| c.distance(mid)).fold(0.0, f32::max);
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
    pub fn row(&self, raster: &Raster, mesh: &Meshing, i: u32, scratch: &mut HemicubeScratch, acc: &mut RowAcc) -> Row {
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
            for face in 0..5usize {
                let map = |q: [f32; 3]| -> [f32; 3] {
                    match face {
                        0 => [q[0], q[1], q[2]],
                        1 => [q[1], q[2], q[0]],
                        2 => [q[1], q[2], -q[0]],
                        3 => [q[0], q[2], q[1]],
                        _ => [q[0], q[2], -q[1]],
                    }
                };
                let mut poly = [[0f32; 3]; 12];
                for (dst, src) in poly.iter_mut().zip(&local[..nv]) {
                    *dst = map(*src);
                }
                let nf = map([pl.x, pl.y, pl.z]);
                let top = face == 0;
                let Some(count) = clip(&mut poly, nv, eps, top) else {
                    continue;
                };
                let (offset, rows) = if top { (0, res) } else { (res * res + (face - 1) * res * half, half) };
                raster_polygon(
                    &poly[..count],
                    [nf[0] / kk, nf[1] / kk, nf[2] / kk],
                    res,
                    rows,
                    top,
                    &mut scratch.w[offset..offset + res * rows],
                    &mut scratch.item[offset..offset + res * rows],
                    item,
                );
            }
        }
        // Sum the delta form factors per patch.
        let top_px = res * res;
        for (px, &it) in scratch.item.iter().enumerate() {
            if it >= ABSORBER {
                continue;
            }
            let df = if px < top_px {
                self.top[px]
            } else {
                self.side[(px - top_px) % (res * half)]
            };
            acc.add(it, df as f64);
        }
        acc.finish()
    }
}

/// Clips the polygon `poly[..n]` (face coordinates (a, b, d)) to the face's frustum
/// d ≥ eps, |a| ≤ d, b ≤ d and b ≥ −d (top) or b ≥ 0 (sides). Returns the new vertex count.
fn clip(poly: &mut [[f32; 3]; 12], n: usize, eps: f32, top: bool) -> Option<usize> {
    // Plane functions: inside when ≥ 0.
    let planes: [fn(&[f32; 3], f32, bool) -> f32; 5] = [
        |p, e, _| p[2] - e,
        |p, _, _| p[2] - p[0],
        |p, _, _| p[2] + p[0],
        |p, _, _| p[2] - p[1],
        |p, _, t| if t { p[2] + p[1] } else { p[1] },
    ];
    // Trivial accept/reject by outcodes.
    let mut all_in = true;
    for f in &planes {
        let mut any_in = false;
        let mut any_out = false;
        for p in &poly[..n] {
            if f(p, eps, top) >= 0.0 {
                any_in = true;
            } else {
                any_out = true;
            }
        }
        if !any_in {
            return None;
        }
        all_in &= !any_out;
    }
    if all_in {
        return Some(n);
    }
    let mut n = n;
    let mut tmp = [[0f32; 3]; 12];
    for f in &planes {
        let mut m = 0;
        for i in 0..n {
            let (a, b) = (poly[i], poly[(i + 1) % n]);
            let (fa, fb) = (f(&a, eps, top), f(&b, eps, top));
            if fa >= 0.0 {
                if m < 12 {
                    tmp[m] = a;
                    m += 1;
                }
            }
            if (fa >= 0.0) != (fb >= 0.0) {
                let t = fa / (fa - fb);
                if m < 12 {
                    tmp[m] = [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t, a[2] + (b[2] - a[2]) * t];
                    m += 1;
                }
            }
        }
        if m < 3 {
            return None;
        }
        poly[..m].copy_from_slice(&tmp[..m]);
        n = m;
    }
    Some(n)
}

/// Rasterises a clipped convex polygon into one face: pixels whose centre is inside get the
/// item when the polygon's 1/depth `w = plane·(sa, sb, 1)` is larger than the stored one.
fn raster_polygon(poly: &[[f32; 3]], plane: [f32; 3], res: usize, rows: usize, top: bool, wbuf: &mut [f32], ibuf: &mut [u32], item: u32) {
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
    let j0 = ((ymin - 0.5).ceil().max(0.0)) as usize;
    let j1 = ((ymax - 0.5).floor()).min(rows as f32 - 1.0);
    if j1 < 0.0 {
        return;
    }
    let j1 = j1 as usize;
    let boff = if top { -1.0 } else { 0.0 };
    for j in j0..=j1.min(rows - 1) {
        let yc = j as f32 + 0.5;
        let (mut xl, mut xr) = (f32::INFINITY, f32::NEG_INFINITY);
        for k in 0..n {
            let (a, b) = (pts[k], pts[(k + 1) % n]);
            if (a[1] <= yc && yc < b[1]) || (b[1] <= yc && yc < a[1]) {
                let x = a[0] + (b[0] - a[0]) * ((yc - a[1]) / (b[1] - a[1]));
                xl = xl.min(x);
                xr = xr.max(x);
            }
        }
        if !(xl < xr) {
            continue;
        }
        let i0 = (xl - 0.5).ceil().max(0.0) as usize;
        let i1 = ((xr - 0.5).ceil()).min(res as f32);
        if i1 <= 0.0 {
            continue;
        }
        let i1 = i1 as usize;
        let sb = yc * d + boff;
        let row = j * res;
        let wb = plane[1] * sb + plane[2];
        for i in i0..i1 {
            let sa = (i as f32 + 0.5) * d - 1.0;
            let w = plane[0] * sa + wb;
            let px = row + i;
            if w > wbuf[px] {
                wbuf[px] = w;
                ibuf[px] = item;
            }
        }
    }
}

/// The total of a hemicube's delta form factors (1 after normalisation), for tests.
#[allow(dead_code)]
pub(crate) fn table_total(h: &Hemicube) -> f64 {
    h.top.iter().map(|&x| x as f64).sum::<f64>() + 4.0 * h.side.iter().map(|&x| x as f64).sum::<f64>()
}
