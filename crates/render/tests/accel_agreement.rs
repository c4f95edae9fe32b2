//! Every acceleration structure returns exactly the closest hit of the linear list: the same
//! primitive, t, normal and uv, bit for bit (property test over random scenes and rays).

mod common;

use candela_render::accel::AccelKind;
use candela_render::math::{Ray, Vec3};
use candela_render::sampling::Pcg32;
use candela_render::stats::RayStats;
use proptest::prelude::*;

const STRUCTURES: &[AccelKind] = &[AccelKind::Bvh];

fn agree(seed: u64, n: usize, rays: usize) {
    let reference = common::random_scene(seed, n, AccelKind::None);
    let mut st = RayStats::default();
    for &kind in STRUCTURES {
        let scene = common::random_scene(seed, n, kind);
        let mut rng = Pcg32::new(seed, 99);
        for i in 0..rays {
            let o = common::point(&mut rng, 14.0);
            // Half the rays are aimed at the centre of the scene, half are random.
            let d = if i % 2 == 0 { -o.to_vec() + common::point(&mut rng, 3.0).to_vec() } else { common::direction(&mut rng) };
            let mut ray = Ray::new(o, d);
            if i % 5 == 0 {
                ray.tmax = 5.0 + rng.next_f32() * 10.0;
            }
            let a = reference.intersect(&ray, &mut st);
            let b = scene.intersect(&ray, &mut st);
            assert_eq!(a, b, "{kind:?}, seed {seed}, ray {i}: {ray:?}");
            if let (Some(a), Some(b)) = (a, b) {
                let (sa, sb) = (reference.geometry.interaction(&ray, &a), scene.geometry.interaction(&ray, &b));
                assert_eq!(sa, sb);
            }
            assert_eq!(reference.occluded(&ray, &mut st), scene.occluded(&ray, &mut st), "{kind:?}, seed {seed}, ray {i}");
        }
    }
}

#[test]
fn structures_agree_on_a_scene_with_duplicates() {
    agree(1, 400, 4000);
    // Rays along the axes, through the duplicated sphere.
    let reference = common::random_scene(2, 50, AccelKind::None);
    let bvh = common::random_scene(2, 50, AccelKind::Bvh);
    let mut st = RayStats::default();
    for d in [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X] {
        let r = Ray::new(candela_render::math::Point3::new(0.5, 0.5, 0.5) - d * 20.0, d);
        let a = reference.intersect(&r, &mut st);
        assert_eq!(a, bvh.intersect(&r, &mut st));
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]
    #[test]
    fn structures_agree_on_random_scenes(seed in any::<u64>(), n in 1usize..300) {
        agree(seed, n, 300);
    }
}
