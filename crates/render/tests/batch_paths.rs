//! The path tracer's batches give every sample the radiance it gets alone, bit for bit: in a
//! small scene, whose batches give a lane the next sample as soon as its path ends, and in a
//! large one, whose batches start sixteen camera rays together (traced as packets); for full
//! and partial sample queues, from any first sample.

mod support;

use candela_render::accel::AccelKind;
use candela_render::camera::Camera;
use candela_render::integrator::{Integrator, Path, SampleBatch, BATCH_RUNS, SAMPLE_QUEUE};
use candela_render::light::{Components, Emission, Environment, Light, PointLight};
use candela_render::material::{
    Dispersion, Distribution, Material, Microfacet, Model, RoughCoating,
};
use candela_render::math::{Point3, Transform, Vec3};
use candela_render::sampling::{Pcg32, Sampler, SamplerKind};
use candela_render::shape::{Mesh, Shape, Sphere};
use candela_render::spectrum::{Ior, SampledSpectrum, Wavelengths};
use candela_render::stats::RayStats;
use candela_render::texture::Texture;
use candela_render::{Rgb, Scene, SceneBuilder};

/// Three thousand small triangles and a few spheres around the origin, lit by a point light,
/// seen by the default camera from z = 12.
fn large_scene() -> Scene {
    let mut rng = Pcg32::new(5, 9);
    let mut b = SceneBuilder::new();
    let m = b.add_material(Material::diffuse(Texture::Uniform(Rgb::new(0.7, 0.6, 0.5))));
    let mut mesh = Mesh::default();
    mesh.props.material = m;
    let mut p = || {
        Point3::new(
            rng.next_f32() - 0.5,
            rng.next_f32() - 0.5,
            rng.next_f32() - 0.5,
        )
    };
    for _ in 0..3000 {
        let c = p().to_vec() * 8.0;
        let k = mesh.positions.len() as u32;
        for _ in 0..3 {
            mesh.positions.push(Point3::ORIGIN + c + p().to_vec());
        }
        mesh.indices.push([k, k + 1, k + 2]);
    }
    b.add_mesh(mesh);
    for i in 0..6 {
        let place = Transform::translation(Vec3::new(i as f32 - 2.5, 1.0, 2.0))
            * Transform::scaling(Vec3::new(0.4, 0.4, 0.4));
        b.add_shape(Shape::Sphere(Sphere::new(place)), m, None);
    }
    b.add_light(Light::Point(
        PointLight {
            position: Point3::new(1.0, 6.0, 9.0),
            intensity: Rgb::splat(60.0),
            spectrum: None,
            falloff: Default::default(),
        },
        Components::from_intensity(Rgb::splat(60.0)),
    ));
    let mut scene = b.build(AccelKind::Bvh);
    scene.camera.world_from_camera = Transform::look_at(
        Point3::new(0.0, 0.0, 12.0),
        Point3::ORIGIN,
        Vec3::new(0.0, 1.0, 0.0),
    )
    .unwrap();
    scene
}

/// The Cornell box with every kind of vertex a batch shades: two-sided diffuse walls (seen
/// from behind too), a mirror, a plastic block, the one-sided ceiling light, a small two-sided
/// light, a textured (checkered) light, a point light and a dim constant sky (seen through the
/// open front), so that lights are chosen by their importance and sampled both by the Lambert
/// lanes and by the lights themselves.
fn mixed_scene(spectral: bool) -> Scene {
    mixed_scene_with(spectral, true)
}

/// [`mixed_scene`] with or without its sky: without, its shapes and point light are few
/// enough for every vertex to sample every light (`every_light`), the shapes' samples
/// weighed by MIS.
fn mixed_scene_with(spectral: bool, sky: bool) -> Scene {
    let base = support::radiosity::cornell(AccelKind::Bvh);
    let mut b = SceneBuilder::new();
    for (i, mat) in base.materials.iter().enumerate() {
        let mut mat = mat.clone();
        if i % 2 == 0 {
            mat.two_sided = true;
        }
        b.add_material(mat);
    }
    let mirror = b.add_material(Material::two_sided(Model::Specular {
        reflectance: Texture::Uniform(Rgb::splat(0.9)),
    }));
    let plastic = b.add_material(Material::one_sided(Model::Plastic {
        kd: Texture::Uniform(Rgb::new(0.2, 0.4, 0.6)),
        ks: Texture::Uniform(Rgb::splat(1.0)),
        eta: 1.5,
        nonlinear: false,
    }));
    // Rough GGX conductors, shaded in the batch's lanes: gold, and a two-sided tinted one
    // without an index.
    let gold = b.add_material(Material::one_sided(Model::Conductor {
        eta_k: Some((
            Texture::Uniform(Rgb::new(0.143, 0.374, 1.442)),
            Texture::Uniform(Rgb::new(3.983, 2.385, 1.603)),
        )),
        reflectance: Texture::Uniform(Rgb::splat(1.0)),
        mf: Some(Microfacet::new(Distribution::Ggx, 0.2)),
    }));
    let rough = b.add_material(Material::two_sided(Model::Conductor {
        eta_k: None,
        reflectance: Texture::Uniform(Rgb::new(0.9, 0.8, 0.6)),
        mf: Some(Microfacet::new(Distribution::Ggx, 0.45)),
    }));
    // Rough plastics with a GGX coating, also shaded in the lanes: one-sided and two-sided
    // (`nonlinear`).
    let rough_plastic = |two_sided: bool, alpha: f32, nonlinear: bool| {
        let model = Model::RoughPlastic {
            kd: Texture::Uniform(Rgb::new(0.15, 0.35, 0.6)),
            ks: Texture::Uniform(Rgb::splat(0.8)),
            coating: Box::new(RoughCoating::new(
                Microfacet::new(Distribution::Ggx, alpha),
                1.5,
            )),
            nonlinear,
        };
        if two_sided {
            Material::two_sided(model)
        } else {
            Material::one_sided(model)
        }
    };
    let coated = b.add_material(rough_plastic(false, 0.15, false));
    let coated2 = b.add_material(rough_plastic(true, 0.4, true));
    let e = b.add_emission(base.emissions[0].clone());
    for (i, o) in base.geometry.objects().iter().enumerate() {
        let mat = match i {
            7 => mirror,
            6 => plastic,
            5 if o.props.emission.is_none() => gold,
            3 if o.props.emission.is_none() => rough,
            4 if o.props.emission.is_none() => coated,
            2 if o.props.emission.is_none() => coated2,
            _ => o.props.material,
        };
        b.add_shape(o.shape.clone(), mat, o.props.emission.map(|_| e));
    }
    let white = base.geometry.objects()[0].props.material;
    let two_sided = b.add_emission(Emission {
        radiance: Texture::Uniform(Rgb::new(3.0, 5.0, 4.0)),
        two_sided: true,
    });
    b.add_shape(
        support::radiosity::para([-0.6, 0.2, -0.3], [0.2, 0.0, 0.0], [0.0, 0.15, 0.1]),
        white,
        Some(two_sided),
    );
    let checkered = b.add_emission(Emission {
        radiance: Texture::Checkered {
            c1: Rgb::new(4.0, 1.0, 1.0),
            c2: Rgb::new(1.0, 1.0, 4.0),
            steps: [4.0, 4.0],
            offset: [0.0, 0.0],
        },
        two_sided: false,
    });
    b.add_shape(
        support::radiosity::para([0.5, 0.6, 0.2], [0.0, -0.2, 0.0], [0.0, 0.0, -0.2]),
        white,
        Some(checkered),
    );
    // Sphere lights, sampled in the lanes by the cone they subtend: one-sided (dark from
    // inside) and two-sided.
    for (c, r, two_sided) in [
        ([0.55, -0.55, 0.45], 0.12, false),
        ([-0.5, 0.65, -0.45], 0.08, true),
    ] {
        let e = b.add_emission(Emission {
            radiance: Texture::Uniform(Rgb::new(6.0, 4.0, 2.5)),
            two_sided,
        });
        let place = Transform::translation(Vec3::new(c[0], c[1], c[2]))
            * Transform::scaling(Vec3::new(r, r, r));
        b.add_shape(Shape::Sphere(Sphere::new(place)), white, Some(e));
    }
    b.add_light(Light::Point(
        PointLight {
            position: Point3::new(0.3, 0.8, 0.5),
            intensity: Rgb::splat(0.4),
            spectrum: None,
            falloff: Default::default(),
        },
        Components::from_intensity(Rgb::splat(0.4)),
    ));
    if sky {
        b.add_light(Light::Environment(Environment::new(
            Texture::Uniform(Rgb::new(0.1, 0.15, 0.2)),
            Transform::IDENTITY,
        )));
    }
    finish(b, base.camera, spectral)
}

/// The Cornell box with every delta surface `Path::delta_vertex` shades in a batch, and
/// nearby ones the general vertex shades: spheres of a one-sided perfect mirror (Mitsuba's
/// conductor without an index), a two-sided tinted mirror, glass (η = 1.5), an index-matched
/// glass (η = 1), a dispersive glass (in spectral mode it keeps only the hero wavelength), a
/// glass with a checkered transmittance, a rough glass and a gold conductor (both general); a
/// two-sided mirror rectangle seen from both sides; and a glass sphere around the camera (its
/// rays start inside: total internal reflection). `every` lights it by three point lights
/// instead of its ceiling light (every vertex samples every light).
fn delta_scene(spectral: bool, every: bool) -> Scene {
    let base = support::radiosity::cornell(AccelKind::Bvh);
    let mut b = SceneBuilder::new();
    for mat in &base.materials {
        b.add_material(mat.clone());
    }
    let e = b.add_emission(base.emissions[0].clone());
    for o in base.geometry.objects().iter().take(6) {
        let emission = o.props.emission.filter(|_| !every).map(|_| e);
        b.add_shape(o.shape.clone(), o.props.material, emission);
    }
    let glass = |eta: f32, t: Texture| Model::Dielectric {
        eta,
        dispersion: None,
        reflectance: Texture::Uniform(Rgb::splat(1.0)),
        transmittance: t,
        mf: None,
    };
    let clear = || Texture::Uniform(Rgb::splat(1.0));
    let materials = [
        Material::one_sided(Model::Conductor {
            eta_k: None,
            reflectance: clear(),
            mf: None,
        }),
        Material::two_sided(Model::Specular {
            reflectance: Texture::Uniform(Rgb::new(0.9, 0.7, 0.5)),
        }),
        Material::one_sided(glass(1.5, clear())),
        Material::one_sided(glass(1.0, Texture::Uniform(Rgb::new(0.8, 0.9, 1.0)))),
        Material::one_sided(Model::Dielectric {
            eta: 1.5,
            dispersion: Some(Box::new(Dispersion {
                interior: Ior::Cauchy { a: 1.5, b: 0.02 },
                exterior: 1.0,
            })),
            reflectance: clear(),
            transmittance: clear(),
            mf: None,
        }),
        Material::one_sided(glass(
            1.33,
            Texture::Checkered {
                c1: Rgb::new(1.0, 0.6, 0.6),
                c2: Rgb::new(0.6, 0.6, 1.0),
                steps: [8.0, 8.0],
                offset: [0.0, 0.0],
            },
        )),
        Material::one_sided(Model::Dielectric {
            eta: 1.5,
            dispersion: None,
            reflectance: clear(),
            transmittance: clear(),
            mf: Some(Microfacet::new(Distribution::Ggx, 0.3)),
        }),
        Material::one_sided(Model::Conductor {
            eta_k: Some((
                Texture::Uniform(Rgb::new(0.143, 0.374, 1.442)),
                Texture::Uniform(Rgb::new(3.983, 2.385, 1.603)),
            )),
            reflectance: clear(),
            mf: None,
        }),
        // Rough conductors: GGX (shaded in the batch's lanes) with and without an index, one
        // of them two-sided, and Beckmann (by the general vertex).
        Material::one_sided(Model::Conductor {
            eta_k: Some((
                Texture::Uniform(Rgb::new(0.143, 0.374, 1.442)),
                Texture::Uniform(Rgb::new(3.983, 2.385, 1.603)),
            )),
            reflectance: clear(),
            mf: Some(Microfacet::new(Distribution::Ggx, 0.15)),
        }),
        Material::two_sided(Model::Conductor {
            eta_k: None,
            reflectance: Texture::Uniform(Rgb::new(0.9, 0.6, 0.3)),
            mf: Some(Microfacet::new(Distribution::Ggx, 0.5)),
        }),
        Material::one_sided(Model::Conductor {
            eta_k: None,
            reflectance: clear(),
            mf: Some(Microfacet::new(Distribution::Beckmann, 0.3)),
        }),
        // A rough plastic with a GGX coating (in the lanes).
        Material::two_sided(Model::RoughPlastic {
            kd: Texture::Uniform(Rgb::new(0.6, 0.3, 0.2)),
            ks: clear(),
            coating: Box::new(RoughCoating::new(
                Microfacet::new(Distribution::Ggx, 0.25),
                1.5,
            )),
            nonlinear: false,
        }),
    ];
    let spheres = [
        ([-0.5, -0.7, -0.3], 0.3),
        ([0.55, 0.55, -0.5], 0.3),
        ([0.4, -0.65, 0.3], 0.33),
        ([-0.6, 0.5, 0.2], 0.25),
        ([0.0, 0.0, -0.2], 0.3),
        ([-0.55, -0.1, 0.6], 0.2),
        ([0.6, -0.05, 0.5], 0.2),
        ([0.0, -0.8, 0.7], 0.15),
        ([-0.2, 0.75, -0.6], 0.2),
        ([0.75, 0.3, -0.1], 0.2),
        ([-0.75, -0.75, 0.5], 0.15),
        ([0.2, 0.4, 0.4], 0.18),
    ];
    for (m, (c, r)) in materials.into_iter().zip(spheres) {
        let m = b.add_material(m);
        let place = Transform::translation(Vec3::new(c[0], c[1], c[2]))
            * Transform::scaling(Vec3::new(r, r, r));
        b.add_shape(Shape::Sphere(Sphere::new(place)), m, None);
    }
    // A two-sided mirror open to both sides, seen from both (mirrored onto its front).
    let mirror = b.add_material(Material::two_sided(Model::Specular {
        reflectance: Texture::Uniform(Rgb::new(0.8, 0.8, 0.9)),
    }));
    b.add_shape(
        support::radiosity::para([-0.3, 0.1, -0.8], [0.5, 0.0, 0.3], [0.0, 0.6, 0.0]),
        mirror,
        None,
    );
    // The glass around the camera.
    let inside = b.add_material(Material::one_sided(glass(1.5, clear())));
    let eye = base.camera.world_from_camera.point(Point3::ORIGIN);
    let place =
        Transform::translation(eye.to_vec()) * Transform::scaling(Vec3::new(0.05, 0.05, 0.05));
    b.add_shape(Shape::Sphere(Sphere::new(place)), inside, None);
    if every {
        add_point_lights(&mut b, [0.6, 0.3, 0.9]);
    }
    finish(b, base.camera, spectral)
}

/// Three point lights in the Cornell box, of these intensities.
fn add_point_lights(b: &mut SceneBuilder, intensities: [f32; 3]) {
    let positions = [
        Point3::new(0.3, 0.8, 0.5),
        Point3::new(-0.5, 0.2, 0.9),
        Point3::new(0.0, 0.9, -0.6),
    ];
    for (p, i) in positions.into_iter().zip(intensities) {
        b.add_light(Light::Point(
            PointLight {
                position: p,
                intensity: Rgb::splat(i),
                spectrum: None,
                falloff: Default::default(),
            },
            Components::from_intensity(Rgb::splat(i)),
        ));
    }
}

/// The scene of `b` seen by `camera`, with its spectra prepared when `spectral`.
fn finish(mut b: SceneBuilder, camera: Camera, spectral: bool) -> Scene {
    b.camera(camera);
    let mut scene = b.build(AccelKind::Bvh);
    if spectral {
        scene.prepare_spectral();
    }
    scene
}

/// The Cornell box lit by three point lights only (its ceiling light does not emit): every
/// vertex samples every light, each with its own shadow ray.
fn delta_lit_scene(spectral: bool) -> Scene {
    let base = support::radiosity::cornell(AccelKind::Bvh);
    let mut b = SceneBuilder::new();
    for mat in &base.materials {
        b.add_material(mat.clone());
    }
    for o in base.geometry.objects() {
        b.add_shape(o.shape.clone(), o.props.material, None);
    }
    add_point_lights(&mut b, [0.4, 0.2, 0.7]);
    finish(b, base.camera, spectral)
}

/// The Cornell box of `mixed_scene` made of triangle meshes: each parallelogram two triangles
/// (its boxes and lights too), so that batches test triangles in their lanes and the Lambert
/// lanes sample mesh lights. Flat-shaded meshes keep their faces: without vertex normals, with
/// one normal at the corners (the ceiling light), with texture coordinates (the back wall);
/// the small two-sided light is smooth-shaded (sampled by the light itself), and one checkered
/// light is not uniform (likewise).
fn mesh_scene(spectral: bool) -> Scene {
    let base = mixed_scene(false);
    let mut b = SceneBuilder::new();
    for mat in &base.materials {
        b.add_material(mat.clone());
    }
    for e in &base.emissions {
        b.add_emission(e.clone());
    }
    for (i, o) in base.geometry.objects().iter().enumerate() {
        let Shape::Parallelogram(q) = &o.shape else {
            b.add_shape(o.shape.clone(), o.props.material, o.props.emission);
            continue;
        };
        let mut mesh = Mesh {
            positions: vec![q.p, q.p + q.v, q.p + q.v + q.w, q.p + q.w],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            ..Mesh::default()
        };
        mesh.props.material = o.props.material;
        mesh.props.emission = o.props.emission;
        let n = q.normal();
        match (i, o.props.emission) {
            (0, Some(_)) => mesh.normals = vec![n; 4],
            (_, Some(_)) if i % 2 == 0 => {
                // Smooth: its faces are not kept.
                mesh.normals = vec![n, n, -n, n];
            }
            (3, None) => {
                mesh.uvs = [(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (0.0, 1.0)]
                    .map(|(u, v)| candela_render::math::Point2::new(u, v))
                    .to_vec()
            }
            _ => {}
        }
        b.add_mesh(mesh);
    }
    for l in &base.lights {
        if matches!(l, Light::Point(..) | Light::Environment(..)) {
            b.add_light(l.clone());
        }
    }
    finish(b, base.camera, spectral)
}

/// Samples `first..last` of pixel (x, y) of a 32 × 32 image, traced as one queue and one by
/// one: the same radiance and wavelengths, bit for bit.
fn check(scene: &Scene, pixel: (usize, usize), range: (u32, u32), spp: u32) {
    check_in(scene, pixel, range, spp, false);
}

/// [`check`], with four sampled wavelengths per path when `spectral`.
fn check_in(scene: &Scene, pixel: (usize, usize), range: (u32, u32), spp: u32, spectral: bool) {
    check_runs(scene, &[(pixel, range)], spp, spectral);
}

/// Samples `first..last` of pixel (x, y).
type Run = ((usize, usize), (u32, u32));

/// Runs of samples `first..last` of pixels (x, y) of a 32 × 32 image (each run with its own
/// sampler, as the renderer gathers them), traced as one batch and one by one: the same
/// radiance and wavelengths, bit for bit.
fn check_runs(scene: &Scene, runs: &[Run], spp: u32, spectral: bool) {
    let (out, singles, labels) = batch_and_singles(scene, runs, spp, spectral, Path::radiance);
    let mut lit = 0;
    for k in 0..out.len() {
        assert_eq!(
            out[k].0 .0.map(f32::to_bits),
            singles[k].0 .0.map(f32::to_bits),
            "{}",
            labels[k]
        );
        assert_eq!(out[k].1, singles[k].1, "{}", labels[k]);
        lit += !out[k].0.is_black() as usize;
    }
    assert!(lit > 0, "{runs:?}: nothing lit, nothing compared");
}

/// How one path alone is traced: [`Path::radiance`], or [`Path::radiance_alone`] with mirrors
/// and glass through their BSDFs.
type Single = fn(
    &Path,
    &Scene,
    &candela_render::math::Ray,
    &mut Wavelengths,
    &mut Sampler,
    &mut RayStats,
) -> SampledSpectrum;

/// The runs traced as one batch and one by one with `single`: the radiance and wavelengths of
/// each sample both ways, and its label.
#[allow(clippy::type_complexity)]
fn batch_and_singles(
    scene: &Scene,
    runs: &[Run],
    spp: u32,
    spectral: bool,
    single: Single,
) -> (
    Vec<(SampledSpectrum, Wavelengths)>,
    Vec<(SampledSpectrum, Wavelengths)>,
    Vec<String>,
) {
    let path = Path {
        max_depth: Some(8),
        rr_depth: 2,
        hide_emitters: false,
    };
    let mut samplers = vec![Sampler::new(0, 0); runs.len()];
    let mut rays = Vec::new();
    let mut cursors = Vec::new();
    let mut lambdas = Vec::new();
    let mut samplers_of = Vec::new();
    let mut labels = Vec::new();
    for (r, (&((x, y), (first, last)), sampler)) in runs.iter().zip(&mut samplers).enumerate() {
        sampler.reset_for_pixel(SamplerKind::Sobol, 7, (y * 32 + x) as u64, spp);
        sampler.draw_range(first, last);
        for i in first..last {
            let [sx, sy] = sampler.pixel_sample(i);
            rays.push(
                scene
                    .camera
                    .ray((x as f32 + sx) / 32.0, 1.0 - (y as f32 + sy) / 32.0),
            );
            lambdas.push(if spectral {
                Wavelengths::sample(sampler.next_1d())
            } else {
                Wavelengths::Rgb
            });
            cursors.push(sampler.cursor());
            samplers_of.push(r as u8);
            labels.push(format!("pixel ({x}, {y}) sample {i}"));
        }
    }
    let n = rays.len();
    let singles: Vec<(SampledSpectrum, Wavelengths)> = (0..n)
        .map(|k| {
            let sampler = &mut samplers[samplers_of[k] as usize];
            sampler.resume(cursors[k]);
            let mut lambda = lambdas[k];
            let l = single(
                &path,
                scene,
                &rays[k],
                &mut lambda,
                sampler,
                &mut RayStats::default(),
            );
            (l, lambda)
        })
        .collect();
    let mut out = vec![SampledSpectrum::ZERO; n];
    let batch = SampleBatch {
        rays: &rays,
        lambdas: &mut lambdas,
        cursors: &mut cursors,
        samplers_of: &samplers_of,
    };
    path.radiance_batch(
        scene,
        batch,
        &mut samplers,
        &mut RayStats::default(),
        &mut out,
    );
    (out.into_iter().zip(lambdas).collect(), singles, labels)
}

/// Runs of several pixels in one batch (the renderer gathers up to `BATCH_RUNS`): paths of one
/// pixel take the lanes another's leave, and each still gets its single path's bits, in small
/// scenes (lanes refilled), in the every-light mode (delta lights alone, and with emissive
/// shapes), in spectral mode, and in a deep tree.
#[test]
fn runs_of_several_pixels_in_one_batch_agree_with_single_paths() {
    let runs = [
        ((16, 16), (0, 64)),
        ((5, 20), (0, 64)),
        ((25, 9), (3, 40)),
        ((12, 28), (0, 17)),
    ];
    assert!(runs.len() <= BATCH_RUNS);
    let cornell = support::radiosity::cornell(AccelKind::Bvh);
    assert!(cornell.accel.refills_lanes());
    check_runs(&cornell, &runs, 64, false);
    for spectral in [false, true] {
        check_runs(&mixed_scene(spectral), &runs, 64, spectral);
        check_runs(&mixed_scene_with(spectral, false), &runs, 64, spectral);
        check_runs(&delta_lit_scene(spectral), &runs, 64, spectral);
    }
    check_runs(&delta_scene(false, false), &runs, 64, false);
    let large = large_scene();
    assert!(!large.accel.refills_lanes());
    check_runs(&large, &runs, 64, false);
    // Two runs of one pixel (its samples 0..64 and 64..128), beside another pixel's.
    check_runs(
        &cornell,
        &[((7, 7), (0, 64)), ((7, 7), (64, 128)), ((20, 3), (0, 64))],
        128,
        false,
    );
}

#[test]
fn small_scene_batches_refill_their_lanes_and_agree_with_single_paths() {
    let scene = support::radiosity::cornell(AccelKind::Bvh);
    assert!(scene.accel.refills_lanes());
    for (pixel, range, spp) in [
        ((16, 16), (0, 64), 64),
        ((5, 20), (0, 64), 64),
        ((25, 9), (3, 40), 64),
        ((12, 28), (60, 100), 128),
    ] {
        assert!((range.1 - range.0) as usize <= SAMPLE_QUEUE);
        check(&scene, pixel, range, spp);
    }
}

/// A pixel (x, y), the samples `first..last` of it traced, and its sample count.
type Queue = ((usize, usize), (u32, u32), u32);

/// Pixels, sample ranges and sample counts of the Cornell boxes with every kind of vertex:
/// full and partial queues, from the first sample and from later ones.
const MIXED_SAMPLES: [Queue; 6] = [
    ((16, 16), (0, 64), 64),
    ((5, 20), (0, 64), 64),
    ((25, 9), (3, 40), 64),
    ((12, 28), (60, 100), 128),
    ((28, 3), (0, 64), 64),
    ((9, 9), (0, 64), 64),
];

#[test]
fn every_kind_of_vertex_in_a_batch_agrees_with_single_paths_in_rgb_and_spectral_mode() {
    for spectral in [false, true] {
        let scene = mixed_scene(spectral);
        assert!(scene.accel.refills_lanes());
        for (pixel, range, spp) in MIXED_SAMPLES {
            check_in(&scene, pixel, range, spp, spectral);
        }
    }
}

#[test]
fn cornell_box_meshes_agree_in_batches_and_alone_in_rgb_and_spectral_mode() {
    for spectral in [false, true] {
        let scene = mesh_scene(spectral);
        assert!(scene.accel.refills_lanes() && scene.geometry.meshes().len() > 6);
        for (pixel, range, spp) in MIXED_SAMPLES {
            check_in(&scene, pixel, range, spp, spectral);
        }
    }
}

#[test]
fn paths_sampling_every_delta_light_agree_in_batches_and_alone() {
    for spectral in [false, true] {
        let scene = delta_lit_scene(spectral);
        for (pixel, range, spp) in [((16, 16), (0, 64), 64), ((5, 20), (3, 40), 64)] {
            check_in(&scene, pixel, range, spp, spectral);
        }
    }
}

#[test]
fn mirror_and_glass_vertices_agree_in_batches_and_alone_in_rgb_and_spectral_mode() {
    for every in [false, true] {
        for spectral in [false, true] {
            let scene = delta_scene(spectral, every);
            assert!(scene.accel.refills_lanes());
            for (pixel, range, spp) in [
                ((16, 16), (0, 64), 64),
                ((8, 24), (0, 64), 64),
                ((22, 25), (3, 40), 64),
                ((20, 10), (60, 100), 128),
                ((10, 12), (0, 64), 64),
                ((5, 5), (0, 64), 64),
                ((27, 20), (0, 64), 64),
            ] {
                check_in(&scene, pixel, range, spp, spectral);
            }
        }
    }
}

/// The mirror and glass vertices of the batches ([`Path::delta_vertex`], which sample in the
/// plane of incidence) against the same paths shaded through the BSDFs and their shading
/// frames: the directions differ in their last bits, so a path may now and then take another
/// turn (a grazing ray, a roulette draw at the edge), but every other sample keeps its
/// radiance to a relative 1e-4, and the sums agree.
#[test]
fn mirror_and_glass_vertices_agree_with_the_bsdfs_route() {
    for spectral in [false, true] {
        let scene = delta_scene(spectral, false);
        let runs: Vec<Run> = [(16, 16), (8, 24), (22, 25), (10, 12), (5, 5), (27, 20)]
            .iter()
            .map(|&p| (p, (0, 64)))
            .collect();
        for run in runs {
            let (out, singles, labels) =
                batch_and_singles(&scene, &[run], 64, spectral, |p, s, r, l, sm, st| {
                    p.radiance_alone(s, r, l, sm, st, false)
                });
            let (mut same, mut lit) = (0, 0);
            let (mut sum_a, mut sum_b) = (0.0f64, 0.0f64);
            for k in 0..out.len() {
                let (a, b) = (out[k].0 .0, singles[k].0 .0);
                let close = (0..4).all(|c| (a[c] - b[c]).abs() <= 1e-4 * a[c].abs().max(1.0));
                same += close as usize;
                lit += !out[k].0.is_black() as usize;
                sum_a += a.iter().map(|&x| x as f64).sum::<f64>();
                sum_b += b.iter().map(|&x| x as f64).sum::<f64>();
                assert_eq!(out[k].1, singles[k].1, "{}", labels[k]);
            }
            assert!(lit > 10, "{run:?}: {lit} lit");
            assert!(
                same + 2 >= out.len(),
                "{run:?}: {same} of {} agree",
                out.len()
            );
            assert!(
                (sum_a - sum_b).abs() <= 0.05 * sum_b.abs().max(1.0),
                "{run:?}: {sum_a} {sum_b}"
            );
        }
    }
}

#[test]
fn large_scene_batches_start_together_and_agree_with_single_paths() {
    let scene = large_scene();
    assert!(!scene.accel.refills_lanes());
    for (pixel, range, spp) in [((16, 16), (0, 64), 64), ((14, 18), (7, 44), 64)] {
        check(&scene, pixel, range, spp);
    }
}
