//! Stochastic opacity (Mitsuba's `mask`): a masked surface of opacity α stops a fraction α of
//! the rays that reach it, shadow rays included, independently per layer; decisions are the
//! same for a ray traced alone or in a batch, and fully opaque or fully clear masks are exact.

use candela_render::accel::AccelKind;
use candela_render::material::{Material, Model};
use candela_render::math::{Point3, Ray, RayBatch, Vec3, BATCH};
use candela_render::sampling::Pcg32;
use candela_render::shape::{Parallelogram, Shape};
use candela_render::stats::RayStats;
use candela_render::texture::Texture;
use candela_render::{Rgb, Scene, SceneBuilder};

/// Two parallel squares of opacity `a1` (z = 1) and `a2` (z = 2), plus an opaque one at z = 3.
fn layers(a1: f32, a2: f32) -> Scene {
    let mut b = SceneBuilder::new();
    for (z, a) in [(1.0, Some(a1)), (2.0, Some(a2)), (3.0, None)] {
        let mut m = Material::one_sided(Model::Diffuse {
            reflectance: Texture::Uniform(Rgb::splat(0.5)),
        });
        m.opacity = a.map(|a| Texture::Uniform(Rgb::splat(a)));
        let id = b.add_material(m);
        let sq = Parallelogram::new(
            Point3::new(-10.0, -10.0, z),
            Vec3::new(20.0, 0.0, 0.0),
            Vec3::new(0.0, 20.0, 0.0),
        )
        .unwrap();
        b.add_shape(Shape::Parallelogram(sq), id, None);
    }
    b.build(AccelKind::default())
}

fn ray(rng: &mut Pcg32) -> Ray {
    let o = Point3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, 0.0);
    Ray::new(
        o,
        Vec3::new(rng.next_f32() * 0.2, rng.next_f32() * 0.2, 1.0),
    )
}

#[test]
fn masked_layers_stop_their_share_of_rays() {
    let (a1, a2) = (0.3, 0.6);
    let s = layers(a1, a2);
    let mut rng = Pcg32::new(3, 5);
    let n = 40_000;
    let mut counts = [0usize; 3];
    let mut stats = RayStats::default();
    for _ in 0..n {
        let r = ray(&mut rng);
        let h = s.intersect(&r, &mut stats).unwrap();
        let si = s.geometry.interaction(&r, &h);
        counts[(si.p.z.round() as usize) - 1] += 1;
    }
    // Expected: a1, (1 − a1)·a2, (1 − a1)(1 − a2); within 5 binomial standard deviations.
    let p = [a1, (1.0 - a1) * a2, (1.0 - a1) * (1.0 - a2)];
    for k in 0..3 {
        let e = p[k] as f64 * n as f64;
        let sd = (e * (1.0 - p[k] as f64)).sqrt();
        assert!(
            (counts[k] as f64 - e).abs() < 5.0 * sd,
            "layer {k}: {} vs {e}",
            counts[k]
        );
    }
    // Shadow rays ending before the opaque square: unblocked with probability (1 − a1)(1 − a2).
    let mut free = 0;
    for _ in 0..n {
        let mut r = ray(&mut rng);
        r.tmax = 2.5;
        if !s.occluded(&r, &mut stats) {
            free += 1;
        }
    }
    let e = p[2] as f64 * n as f64;
    assert!(
        (free as f64 - e).abs() < 5.0 * (e * (1.0 - p[2] as f64)).sqrt(),
        "{free} vs {e}"
    );
}

#[test]
fn batches_and_single_rays_agree_and_extreme_masks_are_exact() {
    let s = layers(0.5, 0.5);
    let mut rng = Pcg32::new(9, 1);
    let mut stats = RayStats::default();
    for _ in 0..50 {
        let mut batch = RayBatch::default();
        let rays: Vec<Ray> = (0..BATCH).map(|_| ray(&mut rng)).collect();
        for (i, r) in rays.iter().enumerate() {
            batch.set(i, r);
        }
        let mut hits = [None; BATCH];
        s.intersect_batch(&batch, &mut hits, &mut stats);
        let blocked = s.occluded_batch(&batch, &mut stats);
        for (i, r) in rays.iter().enumerate() {
            assert_eq!(hits[i], s.intersect(r, &mut stats));
            assert_eq!(blocked >> i & 1 == 1, s.occluded(r, &mut stats));
        }
    }
    // Opacity 1 everywhere: always the first square; opacity 0: always the opaque one.
    for (a, z) in [(1.0, 1.0), (0.0, 3.0)] {
        let s = layers(a, a);
        for _ in 0..1000 {
            let r = ray(&mut rng);
            let h = s.intersect(&r, &mut stats).unwrap();
            assert_eq!(s.geometry.interaction(&r, &h).p.z.round(), z);
        }
    }
}
