//! Batches of rays through the BVH ([`RayBatch`]).
//!
//! A small scene, whose root's children are all leaves ([`Bvh::flat`]), is tested brute force:
//! each parallelogram, sphere and box is broadcast and tested against all the rays at once,
//! sixteen lanes wide ([`crate::simd::Wide`]: one AVX-512 register, two AVX or four SSE ones),
//! by lane-exact copies of the shapes' scalar tests, so every lane gets the single-ray hit bit
//! for bit. These primitives are kept in increasing id order ([`FlatPrim`]), so that a strict
//! `t < best` is the single-ray rule "equal t goes to the smaller id" (the tests live in
//! [`super::lanes`]). Other primitives of a small scene go through the single-ray leaf routines,
//! lane by lane. In a deeper tree, each group of enough coherent rays goes down as a packet
//! ([`super::packet`]) and the other rays one by one through the single-ray traversal.

use super::lanes::{test, FlatPrim, Lanes};
use super::layout::{Kind, Ref, COUNT_MASK, KIND_SHIFT};
use super::packet::{Coherence, Groups};
use super::Bvh;
use crate::geometry::Geometry;
use crate::interaction::Hit;
use crate::math::{Ray, RayBatch, BATCH};
use crate::simd::{SimdLevel, Wide, WideKernel};
use crate::stats::RayStats;

/// The closest hits of a batch, one per lane (`None` for misses and inactive lanes).
pub type BatchHits = [Option<Hit>; BATCH];

impl Bvh {
    /// Splits the leaves of a flat tree into primitives tested in batches (sorted by id) and
    /// leaves tested ray by ray.
    pub(super) fn flat_split(&self, geometry: &Geometry) -> (Vec<FlatPrim>, Vec<Ref>) {
        let mut prims = Vec::new();
        let mut rest = Vec::new();
        for &r in &self.flat {
            let kind = Kind::from_bits((r.meta >> KIND_SHIFT).wrapping_sub(1));
            let n = (r.meta & COUNT_MASK) as usize;
            if kind == Kind::Tri {
                // Triangles: the vertices their blocks hold (what the single-ray test reads).
                for k in 0..n {
                    let (block, lane) = (&self.tris[r.child as usize + k / 4], k % 4);
                    let v = block.v.map(|p| p.map(|axis| axis[lane]));
                    prims.push(FlatPrim::Tri {
                        v,
                        id: block.id[lane],
                    });
                }
                continue;
            }
            let batchable = matches!(kind, Kind::Quad | Kind::Sphere | Kind::Box);
            if !batchable {
                rest.push(r);
                continue;
            }
            // Blocked leaves: their primitive ids, from the blocks' id lanes.
            for k in 0..n {
                let id = self.block_id(kind, r.child as usize + k / 4, k % 4);
                prims.push(FlatPrim::of(geometry, id).expect("a batchable primitive"));
            }
        }
        prims.sort_by_key(|p| match *p {
            FlatPrim::Quad { id, .. }
            | FlatPrim::Sphere { id, .. }
            | FlatPrim::Box { id, .. }
            | FlatPrim::Tri { id, .. } => id,
        });
        (prims, rest)
    }

    /// True when the tree holds no primitive (its root is an empty leaf).
    pub fn is_empty(&self) -> bool {
        self.root.meta != 0 && self.root.meta & COUNT_MASK == 0
    }

    /// True when batches test every primitive against all their rays at once (small scenes),
    /// a cost that does not shrink with the number of active lanes.
    pub fn is_flat(&self) -> bool {
        !self.flat_prims.is_empty() || !self.flat_rest.is_empty()
    }

    /// The closest hit of every active lane of `rays`.
    pub fn intersect_batch(
        &self,
        geometry: &Geometry,
        rays: &RayBatch,
        hits: &mut BatchHits,
        stats: &mut RayStats,
    ) {
        self.intersect_batch_at(SimdLevel::detected(), geometry, rays, hits, stats)
    }

    /// [`Bvh::intersect_batch`] with the registers of `level` (or the widest below it).
    fn intersect_batch_at(
        &self,
        level: SimdLevel,
        geometry: &Geometry,
        rays: &RayBatch,
        hits: &mut BatchHits,
        stats: &mut RayStats,
    ) {
        *hits = [None; BATCH];
        if !self.is_flat() {
            let groups = self.packets_for(level, rays);
            for (c, lanes) in groups.iter() {
                self.intersect_packet(level, geometry, rays, c, lanes, hits, stats);
            }
            let rest = rays.active & !groups.lanes();
            let single = single_rays(rays, rest);
            self.intersect_lanes(geometry, &single, rest, hits, stats);
            return;
        }
        if !self.flat_prims.is_empty() {
            crate::simd::run_wide_at(
                level,
                Closest {
                    prims: &self.flat_prims,
                    triangles: self.flat_triangles,
                    rays,
                    hits,
                },
            );
            stats.prim_tests += self.flat_prims.len() as u64 * rays.active.count_ones() as u64;
        }
        // The other primitives lane by lane (none, in most small scenes).
        let rest = if self.flat_rest.is_empty() {
            0
        } else {
            rays.active
        };
        for i in crate::math::lanes(rest) {
            let mut ray = rays.ray(i);
            if let Some(h) = &hits[i] {
                ray.tmax = h.t.next_up();
            }
            for &r in &self.flat_rest {
                if let Some(h) = self.leaf_closest(geometry, r, &ray, stats) {
                    if crate::accel::closest(&mut hits[i], h) {
                        ray.tmax = h.t.next_up();
                    }
                }
            }
        }
    }

    /// The active lanes of `rays` that hit something (bit i for lane i).
    pub fn occluded_batch(
        &self,
        geometry: &Geometry,
        rays: &RayBatch,
        stats: &mut RayStats,
    ) -> u32 {
        self.occluded_batch_at(SimdLevel::detected(), geometry, rays, stats)
    }

    /// [`Bvh::occluded_batch`] with the registers of `level` (or the widest below it).
    fn occluded_batch_at(
        &self,
        level: SimdLevel,
        geometry: &Geometry,
        rays: &RayBatch,
        stats: &mut RayStats,
    ) -> u32 {
        if !self.is_flat() {
            let groups = self.packets_for(level, rays);
            let mut hit = 0;
            for (c, lanes) in groups.iter() {
                hit |= self.occluded_packet(level, geometry, rays, c, lanes, stats);
            }
            let rest = rays.active & !groups.lanes();
            let single = single_rays(rays, rest);
            return hit | self.occluded_lanes(geometry, &single, rest, stats);
        }
        let mut hit = 0;
        if !self.flat_prims.is_empty() {
            hit = crate::simd::run_wide_at(
                level,
                Any {
                    prims: &self.flat_prims,
                    triangles: self.flat_triangles,
                    rays,
                },
            );
            stats.prim_tests += self.flat_prims.len() as u64 * rays.active.count_ones() as u64;
        }
        let mut rest = if self.flat_rest.is_empty() {
            0
        } else {
            rays.active & !hit
        };
        while rest != 0 {
            let i = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            let ray = rays.ray(i);
            if self
                .flat_rest
                .iter()
                .any(|&r| self.leaf_any(geometry, r, &ray, stats))
            {
                hit |= 1 << i;
            }
        }
        hit
    }
}

impl Bvh {
    /// The groups of lanes of `rays` a deep tree traces as packets ([`super::packet`]): on
    /// sixteen-lane registers, the groups of enough coherent rays ([`Coherence::groups`]).
    #[inline]
    fn packets_for(&self, level: SimdLevel, rays: &RayBatch) -> Groups {
        let active = if self.root.meta != 0 || level.min(SimdLevel::supported()) < PACKET_LEVEL {
            0
        } else {
            rays.active & rays.coherent
        };
        Coherence::groups(rays, active)
    }
}

/// The rays of lanes `lanes` of `rays` made all before any is traced ray by ray: a ray written
/// field by field and read back at once by wider loads waits for its stores to retire (a load
/// is forwarded from one store only); made first, the stores have retired by then.
#[inline(always)]
fn single_rays(rays: &RayBatch, lanes: u32) -> [Ray; BATCH] {
    let mut single = [Ray::new(crate::math::Point3::ORIGIN, crate::math::Vec3::X); BATCH];
    for i in crate::math::lanes(lanes) {
        single[i] = rays.ray(i);
    }
    single
}

/// The narrowest registers packets are taken on (see [`super::packet`]).
const PACKET_LEVEL: SimdLevel = SimdLevel::Avx2;

/// The closest-hit kernel: the primitives in id order, a strict `t < best`.
struct Closest<'a> {
    prims: &'a [FlatPrim],
    /// Some of `prims` are triangles.
    triangles: bool,
    rays: &'a RayBatch,
    hits: &'a mut BatchHits,
}

impl WideKernel for Closest<'_> {
    type Output = ();

    #[inline(always)]
    fn run<W: Wide>(self, w: W) {
        let l = Lanes::new(w, self.rays, self.triangles);
        let mut best_t = w.load(&self.rays.tmax);
        let none = w.splat_bits(u32::MAX);
        let mut best_id = none;
        let zero = w.splat(0.0);
        let (mut best_u, mut best_v, mut best_face) = (zero, zero, zero);
        for p in self.prims {
            let (h, id) = test(w, &l, best_t, p);
            let better = h.valid;
            best_t = w.select(better, h.t, best_t);
            best_id = w.select(better, w.splat_bits(id), best_id);
            best_u = w.select(better, h.u, best_u);
            best_v = w.select(better, h.v, best_v);
            best_face = w.select(better, h.face, best_face);
        }
        let (mut t, mut id, mut u, mut v, mut face) =
            ([0f32; 16], [0f32; 16], [0f32; 16], [0f32; 16], [0f32; 16]);
        w.store(best_t, &mut t);
        w.store(best_id, &mut id);
        w.store(best_u, &mut u);
        w.store(best_v, &mut v);
        w.store(best_face, &mut face);
        let mut m = self.rays.active;
        while m != 0 {
            let i = m.trailing_zeros() as usize;
            m &= m - 1;
            let prim = id[i].to_bits();
            if prim != u32::MAX {
                self.hits[i] = Some(Hit {
                    t: t[i],
                    prim,
                    uv: [u[i], v[i]],
                    sub: face[i] as u32,
                    leaf: 0,
                });
            }
        }
    }
}

/// The any-hit kernel: the lanes that hit any primitive, stopping once every active lane has.
struct Any<'a> {
    prims: &'a [FlatPrim],
    /// Some of `prims` are triangles.
    triangles: bool,
    rays: &'a RayBatch,
}

impl WideKernel for Any<'_> {
    type Output = u32;

    #[inline(always)]
    fn run<W: Wide>(self, w: W) -> u32 {
        let l = Lanes::new(w, self.rays, self.triangles);
        let tmax = w.load(&self.rays.tmax);
        let active = self.rays.active;
        let mut hit = 0u32;
        for p in self.prims {
            let (h, _) = test(w, &l, tmax, p);
            hit |= w.bits(h.valid) & active;
            if hit == active {
                break;
            }
        }
        hit
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::build_prims;
    use crate::geometry::Object;
    use crate::interaction::SurfaceProps;
    use crate::math::{Point3, Ray, Transform, Vec3};
    use crate::sampling::Pcg32;
    use crate::shape::{Cube, Mesh, Parallelogram, Shape, Sphere};

    /// A scene of `n` spheres, boxes and parallelograms (with a twin of the first primitive
    /// for exact ties; when `mixed`, a triangle and, in small scenes, a non-affine box).
    fn geometry(n: usize, seed: u64, mixed: bool) -> Geometry {
        let mut rng = Pcg32::new(seed, 5);
        let mut u = || rng.next_f32() * 2.0 - 1.0;
        let props = SurfaceProps::default();
        let mut objects = Vec::new();
        for i in 0..n {
            let c = Vec3::new(u() * 3.0, u() * 3.0, u() * 3.0);
            let place = Transform::translation(c)
                * Transform::rotation_z(u() * 180.0)
                * Transform::scaling(Vec3::new(0.5 + u().abs(), 0.4, 0.7));
            let shape = match i % 3 {
                0 => Shape::Sphere(Sphere::new(place)),
                1 => Shape::Cube(Cube::new(place)),
                _ => Shape::Parallelogram(
                    Parallelogram::new(
                        Point3::new(c.x, c.y, c.z),
                        Vec3::new(u() * 2.0, u(), 0.3),
                        Vec3::new(0.2, u() * 2.0, u()),
                    )
                    .unwrap(),
                ),
            };
            if i == 0 {
                objects.push(Object {
                    shape: shape.clone(),
                    props,
                });
            }
            objects.push(Object { shape, props });
        }
        let mut meshes = Vec::new();
        if mixed && n < 40 {
            // A box whose placement is projective: not batchable, tested ray by ray. Only in
            // flat trees: its hits can lie before the entry of its bounding box (seen on a
            // 300-primitive tree), so which hit a deep tree returns depends on the order of
            // the visit, ray by ray or in packets.
            let mut m = Transform::translation(Vec3::new(0.5, 0.2, 0.1)).m;
            m.m[3][2] = 0.05;
            if let Some(t) = Transform::from_matrix(m) {
                objects.push(Object {
                    shape: Shape::Cube(Cube::new(t)),
                    props,
                });
            }
            meshes.push(Mesh {
                positions: vec![
                    Point3::new(-1.0, -1.0, 0.5),
                    Point3::new(1.0, -1.0, 0.4),
                    Point3::new(0.0, 1.0, 0.6),
                ],
                indices: vec![[0, 1, 2]],
                ..Mesh::default()
            });
        }
        Geometry::new(objects, meshes)
    }

    fn batch(rng: &mut Pcg32, k: usize) -> RayBatch {
        let mut b = RayBatch::default();
        for i in 0..BATCH {
            let mut u = || rng.next_f32() * 2.0 - 1.0;
            let o = Point3::new(u() * 5.0, u() * 5.0, u() * 5.0);
            let d = match (i + k) % 9 {
                0 => Vec3::new(0.0, 0.0, 1.0),
                1 => Vec3::new(u(), 0.0, u()),
                _ => -o.to_vec() + Vec3::new(u(), u(), u()),
            };
            let mut ray = Ray::new(o, d);
            if i % 4 == 3 {
                ray.tmax = 0.7;
            }
            if i % 5 == 4 {
                ray.tmin = 0.2;
            }
            // Some lanes stay inactive.
            if !(i * 7 + k).is_multiple_of(11) {
                b.set(i, &ray);
            }
        }
        b
    }

    /// Traces `rays` as a batch with the registers of `level` and each active lane alone:
    /// the same closest hit and occlusion, bit for bit, and nothing for inactive lanes. Gives
    /// each active lane's hit and occlusion.
    fn batch_against_single_rays(
        bvh: &Bvh,
        g: &Geometry,
        rays: &RayBatch,
        level: SimdLevel,
    ) -> Vec<(Option<Hit>, bool)> {
        let mut st = RayStats::default();
        let mut hits = [None; BATCH];
        bvh.intersect_batch_at(level, g, rays, &mut hits, &mut st);
        let occluded = bvh.occluded_batch_at(level, g, rays, &mut st);
        let mut out = Vec::new();
        for i in 0..BATCH {
            if rays.active >> i & 1 == 0 {
                assert!(hits[i].is_none() && occluded >> i & 1 == 0);
                continue;
            }
            let ray = rays.ray(i);
            let single = bvh.intersect(g, &ray, &mut st);
            let blocked = bvh.occluded(g, &ray, &mut st);
            assert_eq!(hits[i], single, "{level:?}, lane {i}: {ray:?}");
            assert_eq!(
                occluded >> i & 1 == 1,
                blocked,
                "{level:?}, lane {i}: {ray:?}"
            );
            out.push((single, blocked));
        }
        out
    }

    #[test]
    fn batches_get_the_single_ray_hits_at_every_simd_level() {
        let levels = [SimdLevel::Sse, SimdLevel::Avx2, SimdLevel::Avx512];
        for (n, mixed) in [(5, false), (12, false), (7, true), (40, false), (300, true)] {
            let g = geometry(n, n as u64, mixed);
            let bvh = Bvh::build(&g, &build_prims(&g));
            assert_eq!(
                !bvh.flat.is_empty(),
                n < 40,
                "{n} primitives: flat tree or not"
            );
            let mut rng = Pcg32::new(1, 2);
            let mut hits_seen = 0;
            for k in 0..200 {
                let rays = batch(&mut rng, k);
                for &level in &levels {
                    for (hit, _) in batch_against_single_rays(&bvh, &g, &rays, level) {
                        hits_seen += hit.is_some() as usize;
                    }
                }
            }
            assert!(hits_seen > 500, "{n} primitives: only {hits_seen} hits");
        }
    }

    /// A batch of up to three groups: lanes aimed from near one point towards near another
    /// (coherent), in one or two groups by `k`, and the rest in random directions.
    fn grouped_batch(rng: &mut Pcg32, k: usize) -> RayBatch {
        let mut b = RayBatch::default();
        let mut u = || rng.next_f32() * 2.0 - 1.0;
        let ends: Vec<(Point3, Point3)> = (0..2)
            .map(|_| {
                (
                    Point3::new(u() * 6.0, u() * 6.0, 6.0 + u()),
                    Point3::new(u() * 2.0, u() * 2.0, u() * 2.0),
                )
            })
            .collect();
        // Lanes per group: all in the first, two groups, a group and strays, strays only.
        let split = [(16, 16), (9, 16), (7, 13), (3, 5)][k % 4];
        for i in 0..BATCH {
            let group = if i < split.0 {
                0
            } else if i < split.1 {
                1
            } else {
                2
            };
            let spread = [0.0, 0.02, 0.3][k / 4 % 3];
            let mut ray = if group < 2 {
                let (o, t) = ends[group];
                let o = o + Vec3::new(u(), u(), u()) * spread;
                Ray::new(o, t - o + Vec3::new(u(), u(), u()) * spread)
            } else {
                let o = Point3::new(u() * 5.0, u() * 5.0, u() * 5.0);
                Ray::new(o, Vec3::new(u(), u(), u()))
            };
            if i % 5 == 3 {
                ray.tmax = 4.0 + u();
            }
            if i % 7 == 6 {
                ray.tmin = 0.5;
            }
            if !(i * 7 + k).is_multiple_of(13) {
                b.set(i, &ray);
            }
        }
        b
    }

    #[test]
    fn only_a_tree_without_primitives_is_empty() {
        let empty = Geometry::new(Vec::new(), Vec::new());
        assert!(Bvh::build(&empty, &build_prims(&empty)).is_empty());
        for n in [1, 30, 300] {
            let g = geometry(n, 3, false);
            assert!(
                !Bvh::build(&g, &build_prims(&g)).is_empty(),
                "{n} primitives"
            );
        }
    }

    #[test]
    fn deep_batches_of_coherent_groups_get_the_single_ray_hits_at_every_simd_level() {
        let levels = [SimdLevel::Sse, SimdLevel::Avx2, SimdLevel::Avx512];
        for (n, mixed) in [(300, true), (900, false)] {
            let g = geometry(n, n as u64 + 1, mixed);
            let bvh = Bvh::build(&g, &build_prims(&g));
            assert!(bvh.flat.is_empty() && bvh.root.meta == 0, "a deep tree");
            let mut rng = Pcg32::new(5, 6);
            let (mut grouped, mut hits_seen, mut blocked_seen) = ([0; 3], 0, 0);
            for k in 0..600 {
                let mut rays = grouped_batch(&mut rng, k);
                if k % 3 == 2 {
                    // The caller's hint: only these lanes may go in packets.
                    rays.coherent = rng.next_u32();
                }
                let groups = Coherence::groups(&rays, rays.active);
                grouped[groups.len] += 1;
                for &level in &levels {
                    let taken = bvh.packets_for(level, &rays).lanes();
                    assert_eq!(taken & !rays.coherent, 0, "packets only of coherent lanes");
                    let mut st = RayStats::default();
                    let mut hits = [None; BATCH];
                    bvh.intersect_batch_at(level, &g, &rays, &mut hits, &mut st);
                    let occluded = bvh.occluded_batch_at(level, &g, &rays, &mut st);
                    // Each group as a packet too, at every level (the batch takes packets
                    // only on AVX2 and wider).
                    let mut packet_hits = [None; BATCH];
                    let mut packet_occluded = 0;
                    for (c, lanes) in groups.iter() {
                        bvh.intersect_packet(level, &g, &rays, c, lanes, &mut packet_hits, &mut st);
                        packet_occluded |= bvh.occluded_packet(level, &g, &rays, c, lanes, &mut st);
                    }
                    for i in 0..BATCH {
                        if rays.active >> i & 1 == 0 {
                            assert!(hits[i].is_none() && occluded >> i & 1 == 0);
                            continue;
                        }
                        let ray = rays.ray(i);
                        let single = bvh.intersect(&g, &ray, &mut st);
                        let blocked = bvh.occluded(&g, &ray, &mut st);
                        assert_eq!(hits[i], single, "{n} prims, {level:?}, batch {k}, lane {i}");
                        assert_eq!(occluded >> i & 1 == 1, blocked, "{level:?} {k} {i}");
                        if groups.lanes() >> i & 1 == 1 {
                            assert_eq!(packet_hits[i], single, "{level:?}, batch {k}, lane {i}");
                            assert_eq!(packet_occluded >> i & 1 == 1, blocked);
                        }
                        hits_seen += single.is_some() as usize;
                        blocked_seen += blocked as usize;
                    }
                }
            }
            assert!(
                grouped.iter().all(|&c| c > 60),
                "{n} primitives: batches by number of groups {grouped:?}"
            );
            assert!(
                hits_seen > 3000 && blocked_seen > 3000,
                "{n} primitives: {hits_seen} hits, {blocked_seen} blocked"
            );
        }
    }

    /// A small scene of triangles (a grid of integer vertices, a tilted fan, a sphere and a
    /// parallelogram): a flat tree whose triangles go into the batches' lanes. Rays come from
    /// every side (each axis of the sheared space, both signs) and many pass exactly through
    /// grid edges and vertices (the test's f64 edge fallback).
    #[test]
    fn batches_of_triangles_get_the_single_ray_hits_at_every_simd_level() {
        let mut positions = Vec::new();
        let mut indices = Vec::new();
        for j in 0..3 {
            for i in 0..3 {
                let (x, y) = (i as f32 - 2.0, j as f32 - 2.0);
                let base = positions.len() as u32;
                positions.extend([
                    Point3::new(x, y, 0.0),
                    Point3::new(x + 1.0, y, 0.0),
                    Point3::new(x + 1.0, y + 1.0, 0.0),
                    Point3::new(x, y + 1.0, 0.0),
                ]);
                indices.push([base, base + 1, base + 2]);
                indices.push([base, base + 2, base + 3]);
            }
        }
        // A fan standing across the grid (both windings).
        let c = positions.len() as u32;
        positions.extend([
            Point3::new(0.0, 0.0, 1.5),
            Point3::new(1.5, 0.3, -1.0),
            Point3::new(-1.2, 0.4, -1.0),
            Point3::new(0.2, -1.6, -0.8),
        ]);
        indices.extend([[c, c + 1, c + 2], [c, c + 3, c + 2], [c + 1, c + 3, c]]);
        let mesh = Mesh {
            positions,
            indices,
            ..Mesh::default()
        };
        let props = SurfaceProps::default();
        let objects = vec![
            Object {
                shape: Shape::Sphere(Sphere::new(
                    Transform::translation(Vec3::new(0.5, 0.5, 0.7))
                        * Transform::scaling(Vec3::new(0.4, 0.4, 0.4)),
                )),
                props,
            },
            Object {
                shape: Shape::Parallelogram(
                    Parallelogram::new(
                        Point3::new(-1.0, -1.0, 0.5),
                        Vec3::new(1.0, 0.0, 0.0),
                        Vec3::new(0.0, 1.0, 0.2),
                    )
                    .unwrap(),
                ),
                props,
            },
        ];
        let g = Geometry::new(objects, vec![mesh]);
        let bvh = Bvh::build(&g, &build_prims(&g));
        assert!(!bvh.flat.is_empty(), "a flat tree");
        assert!(
            bvh.flat_triangles && bvh.flat_rest.is_empty(),
            "triangles in the lanes"
        );
        let levels = [SimdLevel::Sse, SimdLevel::Avx2, SimdLevel::Avx512];
        let mut rng = Pcg32::new(7, 3);
        let (mut hits_seen, mut on_edges, mut blocked_seen) = (0, 0, 0);
        for k in 0..300 {
            let mut rays = RayBatch::default();
            for i in 0..BATCH {
                let mut u = || rng.next_f32() * 2.0 - 1.0;
                // Aimed at a grid vertex, an edge or anywhere, from any side.
                let target = match (i + k) % 3 {
                    0 => Point3::new((u() * 1.5 - 0.5).round(), (u() * 1.5 - 0.5).round(), 0.0),
                    1 => Point3::new((u() * 1.5 - 0.5).round(), u() * 1.5 - 0.5, 0.0),
                    _ => Point3::new(u() * 1.5 - 0.5, u() * 1.5 - 0.5, u()),
                };
                let o = match (i + 2 * k) % 4 {
                    // Along an axis (exact directions), or from anywhere.
                    0 => target + Vec3::new(0.0, 0.0, 3.0 * u().signum()),
                    1 => target + Vec3::new(3.0 * u().signum(), 0.0, 0.0),
                    _ => Point3::new(u() * 4.0, u() * 4.0, u() * 4.0),
                };
                let mut ray = Ray::new(o, target - o);
                if i % 6 == 5 {
                    ray.tmax = 0.6 + u().abs();
                }
                if !(i * 5 + k).is_multiple_of(9) {
                    rays.set(i, &ray);
                }
            }
            for &level in &levels {
                for (single, blocked) in batch_against_single_rays(&bvh, &g, &rays, level) {
                    hits_seen += single.is_some() as usize;
                    blocked_seen += blocked as usize;
                    on_edges += single.is_some_and(|h| {
                        h.prim >= 2
                            && (h.uv[0] == 0.0 || h.uv[1] == 0.0 || h.uv[0] + h.uv[1] == 1.0)
                    }) as usize;
                }
            }
        }
        assert!(
            hits_seen > 5000 && blocked_seen > 5000 && on_edges > 300,
            "{hits_seen} hits, {blocked_seen} blocked, {on_edges} on triangle edges"
        );
    }
}
