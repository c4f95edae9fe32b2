//! Intel Embree 3 as an optional backend (cargo feature `embree`, `--accel embree`), so that
//! benchmarks can trace the very same rays through Embree and through candela's own BVH.
//!
//! Embree holds the mesh triangles (one Embree geometry per mesh, default build quality and
//! scene flags, `threads=` the size of the current rayon pool; the environment variable
//! `CANDELA_EMBREE_QUALITY=high` builds at `RTC_BUILD_QUALITY_HIGH` instead, with spatial
//! splits, the quality Mitsuba 3 asks for). The other bounded primitives (spheres, boxes, …) go
//! through candela's own [`Bvh`] and routines, and the closer of the two hits is kept (ties to
//! the smaller primitive id). Embree's triangle test is not candela's
//! watertight one: hits agree with the other structures up to round-off, not bit for bit.
//!
//! Needs `libembree3` (Debian: `apt-get install libembree-dev`).

// Why unsafe code is allowed in this file: the Embree C API is reached through `extern "C"`
// declarations of the ~15 functions used, and calling them is unsafe. Every call passes
// handles that this module created and still owns (released once, in `Drop`) and pointers to
// live, correctly laid-out `#[repr(C)]` values.
#![allow(unsafe_code)]

use std::ffi::{c_char, c_void, CString};

use super::prims::{build_prims, inflate, margin, BuildPrim};
use super::{closest, Bvh};
use crate::geometry::{Geometry, PrimRef};
use crate::interaction::Hit;
use crate::math::{Bounds3, Ray};
use crate::stats::RayStats;

type RtcDevice = *mut c_void;
type RtcScene = *mut c_void;
type RtcGeometry = *mut c_void;

const RTC_BUILD_QUALITY_HIGH: u32 = 2;
const RTC_GEOMETRY_TYPE_TRIANGLE: u32 = 0;
const RTC_BUFFER_TYPE_INDEX: u32 = 0;
const RTC_BUFFER_TYPE_VERTEX: u32 = 1;
const RTC_FORMAT_UINT3: u32 = 0x5003;
const RTC_FORMAT_FLOAT3: u32 = 0x9003;
const RTC_INVALID_GEOMETRY_ID: u32 = u32::MAX;
const RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT: u32 = 0;

/// `struct RTCRay`.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug)]
struct RtcRay {
    org: [f32; 3],
    tnear: f32,
    dir: [f32; 3],
    time: f32,
    tfar: f32,
    mask: u32,
    id: u32,
    flags: u32,
}

/// `struct RTCHit` (one instance level).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug)]
struct RtcHit {
    ng: [f32; 3],
    u: f32,
    v: f32,
    prim_id: u32,
    geom_id: u32,
    inst_id: [u32; 1],
}

/// `struct RTCRayHit`.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug)]
struct RtcRayHit {
    ray: RtcRay,
    hit: RtcHit,
}

/// `struct RTCIntersectContext` (one instance level, no minimum width).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
struct RtcIntersectContext {
    flags: u32,
    filter: Option<extern "C" fn(*const c_void)>,
    inst_id: [u32; 1],
}

/// `struct RTCRayHit16`: `RTCRay16` (org x, y, z, tnear, dir x, y, z, time, tfar; mask, id,
/// flags) then `RTCHit16` (Ng x, y, z, u, v; primID, geomID, instID), sixteen lanes each.
#[repr(C, align(64))]
struct RtcRayHit16 {
    ray: [[f32; 16]; 9],
    ray_ids: [[u32; 16]; 3],
    hit: [[f32; 16]; 5],
    hit_ids: [[u32; 16]; 3],
}

const _: () = assert!(std::mem::size_of::<RtcRayHit16>() == 1280);
const _: () = assert!(std::mem::size_of::<RtcRay>() == 48);
const _: () = assert!(std::mem::size_of::<RtcRayHit>() == 80);
const _: () = assert!(std::mem::size_of::<RtcIntersectContext>() == 24);

#[link(name = "embree3")]
extern "C" {
    fn rtcNewDevice(config: *const c_char) -> RtcDevice;
    fn rtcRetainDevice(device: RtcDevice);
    fn rtcReleaseDevice(device: RtcDevice);
    fn rtcGetDeviceError(device: RtcDevice) -> u32;
    fn rtcNewScene(device: RtcDevice) -> RtcScene;
    fn rtcRetainScene(scene: RtcScene);
    fn rtcReleaseScene(scene: RtcScene);
    fn rtcCommitScene(scene: RtcScene);
    fn rtcSetSceneBuildQuality(scene: RtcScene, quality: u32);
    fn rtcAttachGeometry(scene: RtcScene, geometry: RtcGeometry) -> u32;
    fn rtcNewGeometry(device: RtcDevice, kind: u32) -> RtcGeometry;
    fn rtcSetNewGeometryBuffer(
        geometry: RtcGeometry,
        kind: u32,
        slot: u32,
        format: u32,
        stride: usize,
        count: usize,
    ) -> *mut c_void;
    fn rtcCommitGeometry(geometry: RtcGeometry);
    fn rtcReleaseGeometry(geometry: RtcGeometry);
    fn rtcIntersect1(scene: RtcScene, context: *mut RtcIntersectContext, rayhit: *mut RtcRayHit);
    fn rtcOccluded1(scene: RtcScene, context: *mut RtcIntersectContext, ray: *mut RtcRay);
    fn rtcIntersect16(
        valid: *const i32,
        scene: RtcScene,
        context: *mut RtcIntersectContext,
        rayhit: *mut RtcRayHit16,
    );
}

/// An Embree scene over the mesh triangles of a geometry, with candela's BVH over the rest.
pub struct Embree {
    device: RtcDevice,
    scene: RtcScene,
    /// Primitive id of the first triangle of each Embree geometry (by geometry id).
    first_id: Vec<u32>,
    /// The other bounded primitives.
    others: Bvh,
}

// SAFETY: a committed Embree scene is immutable and Embree documents `rtcIntersect1` and
// `rtcOccluded1` as safe to call from any number of threads at once; the handles are
// reference-counted and released once.
unsafe impl Send for Embree {}
// SAFETY: as above: shared references only trace rays.
unsafe impl Sync for Embree {}

impl std::fmt::Debug for Embree {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Embree")
            .field("meshes", &self.first_id.len())
            .field("others", &self.others)
            .finish()
    }
}

impl Clone for Embree {
    fn clone(&self) -> Self {
        // SAFETY: both handles are live; each clone holds (and releases) one more reference.
        unsafe {
            rtcRetainDevice(self.device);
            rtcRetainScene(self.scene);
        }
        Self {
            device: self.device,
            scene: self.scene,
            first_id: self.first_id.clone(),
            others: self.others.clone(),
        }
    }
}

impl Drop for Embree {
    fn drop(&mut self) {
        // SAFETY: the handles were created by `build` (or retained by `clone`) and are
        // released exactly once here.
        unsafe {
            rtcReleaseScene(self.scene);
            rtcReleaseDevice(self.device);
        }
    }
}

impl Embree {
    /// Builds the Embree scene with as many build threads as the current rayon pool has.
    ///
    /// # Panics
    /// When Embree cannot create its device or reports an error building the scene.
    pub fn build(geometry: &Geometry) -> Self {
        let config = CString::new(format!(
            "threads={},verbose=0",
            rayon::current_num_threads()
        ))
        .expect("no NUL in the configuration");
        // SAFETY: `config` is a NUL-terminated string that outlives the call.
        let device = unsafe { rtcNewDevice(config.as_ptr()) };
        assert!(!device.is_null(), "Embree could not create a device");
        // SAFETY: `device` is live.
        let scene = unsafe { rtcNewScene(device) };
        if std::env::var("CANDELA_EMBREE_QUALITY").as_deref() == Ok("high") {
            // SAFETY: `scene` is live.
            unsafe { rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH) };
        }
        let mut first_id = Vec::new();
        // Primitive ids: bounded objects, then each mesh's triangles in order.
        let mut id = (0..geometry.bounded_count())
            .find(|&p| matches!(geometry.prim(p), PrimRef::Triangle { .. }))
            .unwrap_or(geometry.bounded_count());
        for mesh in geometry.meshes().iter().filter(|m| !m.is_empty()) {
            // SAFETY: `device` is live; the buffers returned by Embree hold `len` items of the
            // given stride and are written within those bounds only.
            unsafe {
                let g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
                let v = rtcSetNewGeometryBuffer(
                    g,
                    RTC_BUFFER_TYPE_VERTEX,
                    0,
                    RTC_FORMAT_FLOAT3,
                    12,
                    mesh.positions.len(),
                ) as *mut f32;
                let v = std::slice::from_raw_parts_mut(v, 3 * mesh.positions.len());
                for (dst, p) in v.chunks_exact_mut(3).zip(&mesh.positions) {
                    dst.copy_from_slice(&[p.x, p.y, p.z]);
                }
                let ix = rtcSetNewGeometryBuffer(
                    g,
                    RTC_BUFFER_TYPE_INDEX,
                    0,
                    RTC_FORMAT_UINT3,
                    12,
                    mesh.indices.len(),
                ) as *mut u32;
                let ix = std::slice::from_raw_parts_mut(ix, 3 * mesh.indices.len());
                for (dst, t) in ix.chunks_exact_mut(3).zip(&mesh.indices) {
                    dst.copy_from_slice(t);
                }
                rtcCommitGeometry(g);
                let gid = rtcAttachGeometry(scene, g);
                rtcReleaseGeometry(g);
                debug_assert_eq!(gid as usize, first_id.len());
            }
            first_id.push(id);
            id += mesh.len() as u32;
        }
        // SAFETY: `scene` and `device` are live.
        let error = unsafe {
            rtcCommitScene(scene);
            rtcGetDeviceError(device)
        };
        assert!(
            error == 0,
            "Embree failed to build the scene (error {error})"
        );
        // The other primitives: candela's BVH, boxes grown by the usual margin.
        let mut others: Vec<BuildPrim> = build_prims(geometry)
            .into_iter()
            .filter(|p| matches!(geometry.prim(p.id), PrimRef::Object(_)))
            .collect();
        let m = margin(&others.iter().fold(Bounds3::EMPTY, |b, p| b.union(p.bounds)));
        for p in &mut others {
            p.bounds = inflate(p.bounds, m);
        }
        Self {
            device,
            scene,
            first_id,
            others: Bvh::build(geometry, &others),
        }
    }

    fn context() -> RtcIntersectContext {
        RtcIntersectContext {
            flags: RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT,
            filter: None,
            inst_id: [RTC_INVALID_GEOMETRY_ID],
        }
    }

    fn rtc_ray(ray: &Ray, tfar: f32) -> RtcRay {
        RtcRay {
            org: [ray.o.x, ray.o.y, ray.o.z],
            tnear: ray.tmin,
            dir: [ray.d.x, ray.d.y, ray.d.z],
            time: 0.0,
            tfar,
            mask: u32::MAX,
            id: 0,
            flags: 0,
        }
    }

    /// The closest hit.
    pub fn intersect(&self, geometry: &Geometry, ray: &Ray, stats: &mut RayStats) -> Option<Hit> {
        // (Not even entered when empty: its ray setup costs as much as Embree's own call.)
        let mut best = if !self.others.is_empty() {
            self.others.intersect(geometry, ray, stats)
        } else {
            None
        };
        if self.first_id.is_empty() {
            return best;
        }
        let mut rh = RtcRayHit {
            ray: Self::rtc_ray(ray, best.map_or(ray.tmax, |b| b.t)),
            hit: RtcHit {
                ng: [0.0; 3],
                u: 0.0,
                v: 0.0,
                prim_id: RTC_INVALID_GEOMETRY_ID,
                geom_id: RTC_INVALID_GEOMETRY_ID,
                inst_id: [RTC_INVALID_GEOMETRY_ID],
            },
        };
        let mut ctx = Self::context();
        // SAFETY: the scene is committed and live; `ctx` and `rh` are valid for the call.
        unsafe { rtcIntersect1(self.scene, &mut ctx, &mut rh) };
        stats.prim_tests += 1;
        if rh.hit.geom_id != RTC_INVALID_GEOMETRY_ID {
            closest(
                &mut best,
                Hit {
                    t: rh.ray.tfar,
                    prim: self.first_id[rh.hit.geom_id as usize] + rh.hit.prim_id,
                    uv: [rh.hit.u, rh.hit.v],
                    sub: 0,
                    leaf: 0,
                },
            );
        }
        best
    }

    /// For benchmarks: the closest hits (primitive, t) of `rays` among Embree's triangles
    /// alone, sixteen consecutive rays at a time by `rtcIntersect16` (Embree's hybrid
    /// traversal: a packet at the top of the tree, ray by ray below), as
    /// `BVHNIntersectorKHybrid` traces Mitsuba's wavefronts of a pixel's samples.
    pub fn intersect16(&self, rays: &[Ray]) -> Vec<Option<(u32, f32)>> {
        let mut out = Vec::with_capacity(rays.len());
        let mut rh = RtcRayHit16 {
            ray: [[0.0; 16]; 9],
            ray_ids: [[0; 16]; 3],
            hit: [[0.0; 16]; 5],
            hit_ids: [[0; 16]; 3],
        };
        for group in rays.chunks(16) {
            let mut valid = [0i32; 16];
            for (i, r) in group.iter().enumerate() {
                valid[i] = -1;
                let v = [
                    r.o.x, r.o.y, r.o.z, r.tmin, r.d.x, r.d.y, r.d.z, 0.0, r.tmax,
                ];
                for (k, x) in v.into_iter().enumerate() {
                    rh.ray[k][i] = x;
                }
                rh.ray_ids[0][i] = u32::MAX;
                rh.ray_ids[1][i] = 0;
                rh.ray_ids[2][i] = 0;
                for ids in &mut rh.hit_ids {
                    ids[i] = RTC_INVALID_GEOMETRY_ID;
                }
            }
            let mut ctx = Self::context();
            // SAFETY: the scene is committed and live; `valid`, `ctx` and `rh` (64-byte
            // aligned, Embree 3's `RTCRayHit16` layout) are valid for the call.
            unsafe { rtcIntersect16(valid.as_ptr(), self.scene, &mut ctx, &mut rh) };
            for i in 0..group.len() {
                let geom = rh.hit_ids[1][i];
                out.push((geom != RTC_INVALID_GEOMETRY_ID).then(|| {
                    (
                        self.first_id[geom as usize] + rh.hit_ids[0][i],
                        rh.ray[8][i],
                    )
                }));
            }
        }
        out
    }

    /// True when anything is hit.
    pub fn occluded(&self, geometry: &Geometry, ray: &Ray, stats: &mut RayStats) -> bool {
        if !self.others.is_empty() && self.others.occluded(geometry, ray, stats) {
            return true;
        }
        if self.first_id.is_empty() {
            return false;
        }
        let mut r = Self::rtc_ray(ray, ray.tmax);
        let mut ctx = Self::context();
        // SAFETY: the scene is committed and live; `ctx` and `r` are valid for the call.
        unsafe { rtcOccluded1(self.scene, &mut ctx, &mut r) };
        stats.prim_tests += 1;
        // Embree sets tfar to -inf when the ray is blocked.
        r.tfar == f32::NEG_INFINITY
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_scenes::parallelogram_scene;
    use super::super::{Accel, AccelKind};
    use crate::geometry::Geometry;
    use crate::math::{Point3, Ray, Vec3};
    use crate::sampling::Pcg32;
    use crate::shape::Mesh;
    use crate::stats::RayStats;

    /// A closed octahedron of 8 triangles plus the analytic shapes of the parallelogram
    /// scene, so that both Embree and candela's own BVH answer.
    fn scene() -> Geometry {
        let p = parallelogram_scene();
        let v = [
            Point3::new(3.0, 0.0, 0.0),
            Point3::new(-3.0, 0.0, 0.0),
            Point3::new(0.0, 3.0, 0.0),
            Point3::new(0.0, -3.0, 0.0),
            Point3::new(0.0, 0.0, 3.0),
            Point3::new(0.0, 0.0, -3.0),
        ];
        let mesh = Mesh {
            positions: v.to_vec(),
            indices: vec![
                [0, 2, 4],
                [2, 1, 4],
                [1, 3, 4],
                [3, 0, 4],
                [2, 0, 5],
                [1, 2, 5],
                [3, 1, 5],
                [0, 3, 5],
            ],
            ..Mesh::default()
        };
        Geometry::new(p.objects().to_vec(), vec![mesh])
    }

    /// Sixteen rays at a time (`Embree::intersect16`) find what Embree finds ray by ray among
    /// its triangles (the octahedron alone, without the analytic shapes).
    #[test]
    fn sixteen_at_a_time_embree_finds_what_it_finds_ray_by_ray() {
        let full = scene();
        let g = Geometry::new(Vec::new(), full.meshes().to_vec());
        let e = super::Embree::build(&g);
        let mut rng = Pcg32::new(4, 2);
        let mut u = || rng.next_f32() * 2.0 - 1.0;
        // A pixel's bounce rays: sixteen from near one point, every way; 37 rays in all, so
        // that the last group is partial.
        let c = Point3::new(u() * 5.0, u() * 5.0, u() * 5.0);
        let rays: Vec<Ray> = (0..37)
            .map(|_| Ray::new(c + Vec3::new(u(), u(), u()) * 0.1, Vec3::new(u(), u(), u())))
            .collect();
        let mut st = RayStats::default();
        let hits = e.intersect16(&rays);
        assert_eq!(hits.len(), rays.len());
        let mut seen = 0;
        for (r, h) in rays.iter().zip(&hits) {
            let one = e.intersect(&g, r, &mut st).map(|h| (h.prim, h.t));
            assert_eq!(*h, one, "{r:?}");
            seen += h.is_some() as u32;
        }
        assert!(seen > 0);
    }

    #[test]
    fn embree_agrees_with_the_bvh_up_to_round_off() {
        let g = scene();
        let (bvh, embree) = (
            Accel::build(AccelKind::Bvh, &g),
            Accel::build(AccelKind::Embree, &g),
        );
        let mut rng = Pcg32::new(9, 9);
        let mut st = RayStats::default();
        let mut same = 0;
        for _ in 0..2000 {
            let o = Point3::new(
                rng.next_f32() * 20.0 - 10.0,
                rng.next_f32() * 20.0 - 10.0,
                rng.next_f32() * 20.0 - 10.0,
            );
            let d = Vec3::new(
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
            );
            let r = Ray::new(o, d);
            let (a, b) = (
                bvh.intersect(&g, &r, &mut st),
                embree.intersect(&g, &r, &mut st),
            );
            assert_eq!(a.is_some(), b.is_some(), "{r:?}");
            if let (Some(a), Some(b)) = (a, b) {
                assert!(
                    (a.t - b.t).abs() <= 1e-4 * a.t.abs().max(1.0),
                    "{a:?} {b:?}"
                );
                same += (a.prim == b.prim) as u32;
            }
            assert_eq!(
                bvh.occluded(&g, &r, &mut st),
                embree.occluded(&g, &r, &mut st),
                "{r:?}"
            );
        }
        assert!(same > 0);
        assert!(AccelKind::parse("embree").is_ok());
    }
}
