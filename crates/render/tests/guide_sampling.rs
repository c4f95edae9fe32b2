//! Caustic guides (`sampling::guide`): the mixture of cosine-weighted and cone sampling that
//! diffuse vertices use in scenes with mirrors or smooth glass. χ² goodness of fit of the
//! mixture's samples against its density, and the path tracer's images with and without the
//! guides agreeing in the mean (the estimator stays unbiased).

mod support;

use candela_render::integrator::Path;
use candela_render::math::{Frame, Point3, Vec3};
use candela_render::sampling::guide::{Guide, GuideCones};
use candela_render::sampling::warp;
use chi2::{sidak, Chi2, Grid, ALPHA};
use support::chi2;

/// Shading points, each with its normal and guides (some seen from inside, one tiny cone).
fn cases() -> Vec<(&'static str, Point3, Vec3, Vec<Guide>)> {
    let g = |x: f32, y: f32, z: f32, r: f32| Guide {
        c: Point3::new(x, y, z),
        r,
    };
    vec![
        (
            "one sphere above",
            Point3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
            vec![g(0.5, 0.3, 2.0, 0.6)],
        ),
        (
            "two spheres, one partly below the surface, tilted normal",
            Point3::new(0.2, -0.1, 0.3),
            Vec3::new(0.3, -0.4, 0.866).normalize(),
            vec![g(1.5, 0.0, 0.4, 0.7), g(-0.5, 1.0, 1.5, 0.3)],
        ),
        (
            "four guides: one around the point, one tiny and far",
            Point3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
            vec![
                g(0.0, 0.0, 0.0, 1.0),
                g(1.0, 1.0, 1.0, 0.5),
                g(-20.0, 5.0, 10.0, 0.5),
                g(0.0, -1.0, 0.5, 0.4),
            ],
        ),
    ]
}

/// The mixture's sample from three uniform numbers, as the path tracer draws it
/// (`guided_sample`: the direction pair's first number picks the strategy), with the density
/// it reports.
fn sample(cones: &GuideCones, frame: &Frame, u: [f32; 3]) -> Option<(Vec3, f32)> {
    let (j, v) = cones.split(u[0]);
    let d = match j {
        Some(j) => cones.sample(j, [v, u[1]]),
        None => frame.to_world(warp::square_to_cosine_hemisphere([v, u[1]])),
    };
    let pdf = cones.mix(warp::cosine_hemisphere_pdf(d.dot(frame.n)), d);
    Some((d, pdf))
}

#[test]
fn the_mixture_samples_its_density() {
    let cases = cases();
    let level = sidak(ALPHA, cases.len());
    for (k, (name, p, n, guides)) in cases.iter().enumerate() {
        let cones = GuideCones::at(guides, *p);
        assert!(cones.n > 0, "{name}: no cone seen");
        let frame = Frame::from_normal(n.to_normal());
        let test = Chi2 {
            name,
            grid: Grid::new(*n, 1.0, 24),
            samples: 400_000,
            seed: 11 + k as u64,
            expected_mass: Some(1.0),
            level,
        };
        let pdf = |d: Vec3| cones.mix(warp::cosine_hemisphere_pdf(d.dot(frame.n)), d);
        let r = test.run(|u| sample(&cones, &frame, u), pdf);
        if let Err(e) = r {
            panic!("{e}");
        }
    }
}

/// The Cornell box with a mirror box (whose bounding sphere guides the diffuse vertices)
/// rendered with and without the guides: the difference image's mean over 8 × 8 blocks is
/// zero within four standard errors of the blocks' spread, in every channel, and the guides
/// make some difference (they are in use).
#[test]
fn guided_and_unguided_images_agree_in_the_mean() {
    let guided = support::radiosity::cornell_with_mirror();
    assert!(!guided.guides.is_empty());
    let mut plain = support::radiosity::cornell_with_mirror();
    plain.guides.clear();
    let path = Path::default();
    let (res, spp) = (48, 64);
    let a = support::radiosity::image(&guided, &path, res, spp);
    let b = support::radiosity::image(&plain, &path, res, spp);
    let block = 6;
    let blocks = res / block;
    let mut differ = false;
    for c in 0..3 {
        let mut means = Vec::new();
        for by in 0..blocks {
            for bx in 0..blocks {
                let mut s = 0.0f64;
                for y in by * block..(by + 1) * block {
                    for x in bx * block..(bx + 1) * block {
                        let (pa, pb) = (a.get(x, y), b.get(x, y));
                        let (va, vb) = ([pa.r, pa.g, pa.b][c], [pb.r, pb.g, pb.b][c]);
                        differ |= va != vb;
                        s += (va - vb) as f64;
                    }
                }
                means.push(s / (block * block) as f64);
            }
        }
        let m = means.iter().sum::<f64>() / means.len() as f64;
        let var = means.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (means.len() - 1) as f64;
        let se = (var / means.len() as f64).sqrt();
        assert!(
            m.abs() <= 4.0 * se,
            "channel {c}: mean difference {m} against a standard error {se}"
        );
    }
    assert!(differ, "the guides changed nothing");
}
