//! Statistical correctness of light sampling: χ² goodness of fit of the directions that
//! `Light::sample` returns against `Light::pdf_hit` (area lights) and `Light::pdf_escape`
//! (lights at infinity), and of an environment map's compensated samples (`Light::sample_from`)
//! against `Light::pdf_escape_from`; Monte Carlo irradiance by light sampling, and by light and
//! BSDF sampling weighed by MIS, against closed forms.
//!
//! Scenes hold one emitter and use the linear-list accelerator, so that these tests depend on
//! the lights alone.

mod support;

use support::chi2;

use std::sync::Arc;

use candela_render::accel::AccelKind;

use candela_render::image::Image;
use candela_render::interaction::SurfaceProps;
use candela_render::light::Emission;
use candela_render::light::{
    Components, Environment, HemisphereLight, Light, ShadingPoint, Target,
};
use candela_render::material::Material;
use candela_render::math::{Point2, Point3, Ray, Transform, Vec3, PI};
use candela_render::sampling::Pcg32;
use candela_render::shape::{Cube, Disk, Mesh, Parallelogram, Shape, Sphere};
use candela_render::spectrum::Wavelengths;
use candela_render::stats::RayStats;
use candela_render::texture::{ImageTexture, Texture};
use candela_render::{Rgb, Scene, SceneBuilder};
use chi2::{mean_and_error, sidak, Chi2, Grid, ALPHA};

const SAMPLES: usize = 200_000;
const ROWS: usize = 24;
/// Emitted radiance of the area lights.
const L: f32 = 2.5;

/// The emitters of the suite.
#[derive(Clone, Copy, Debug)]
enum Emitter {
    /// A sphere placed by a similarity (cone sampling from outside).
    Sphere,
    /// A sphere placed by a non-uniform scaling and a rotation (an ellipsoid: area sampling).
    Ellipsoid,
    /// A parallelogram.
    Parallelogram,
    /// A disk stretched into an ellipse.
    Disk,
    /// A rotated, non-uniformly scaled box.
    Box,
    /// A closed, irregular octahedron made of triangles of different areas.
    Mesh,
}

fn sphere_place() -> (Point3, f32) {
    (Point3::new(0.4, -0.3, 3.0), 0.8)
}

fn ellipsoid_place() -> Transform {
    Transform::translation(Vec3::new(0.2, 0.5, 3.0))
        * Transform::rotation(Vec3::new(1.0, 1.0, 0.3), 40.0).unwrap()
        * Transform::scaling(Vec3::new(1.3, 0.5, 0.8))
}

fn box_place() -> Transform {
    Transform::translation(Vec3::new(-0.3, 0.2, 3.5))
        * Transform::rotation(Vec3::new(0.2, 1.0, 0.5), 35.0).unwrap()
        * Transform::scaling(Vec3::new(0.9, 0.4, 0.6))
}

fn octahedron() -> Vec<[Point3; 3]> {
    let c = Vec3::new(0.1, -0.2, 3.2);
    let v = [
        Point3::new(1.1, 0.1, 0.0),
        Point3::new(-0.6, 0.0, 0.1),
        Point3::new(0.0, 0.8, 0.0),
        Point3::new(0.1, -0.5, 0.0),
        Point3::new(0.0, 0.1, 0.9),
        Point3::new(0.05, 0.0, -0.4),
    ]
    .map(|p| p + c);
    let faces = [
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ];
    faces.iter().map(|f| [v[f[0]], v[f[1]], v[f[2]]]).collect()
}

fn parallelogram() -> Parallelogram {
    Parallelogram::new(
        Point3::new(-0.8, -0.5, 2.0),
        Vec3::new(1.5, 0.3, 0.4),
        Vec3::new(0.2, 1.1, -0.3),
    )
    .unwrap()
}

/// A scene holding the emitter alone (emission two-sided or not).
fn scene(e: Emitter, two_sided: bool) -> Scene {
    let mut b = SceneBuilder::new();
    let m = b.add_material(Material::diffuse(Texture::Uniform(Rgb::splat(0.5))));
    let em = b.add_emission(Emission {
        radiance: Texture::Uniform(Rgb::splat(L)),
        two_sided,
    });
    match e {
        Emitter::Sphere => {
            let (c, r) = sphere_place();
            let t = Transform::translation(c.to_vec())
                * Transform::rotation_z(30.0)
                * Transform::scaling(Vec3::new(r, r, r));
            b.add_shape(Shape::Sphere(Sphere::new(t)), m, Some(em));
        }
        Emitter::Ellipsoid => {
            b.add_shape(Shape::Sphere(Sphere::new(ellipsoid_place())), m, Some(em));
        }
        Emitter::Parallelogram => {
            b.add_shape(Shape::Parallelogram(parallelogram()), m, Some(em));
        }
        Emitter::Disk => {
            let t = Transform::translation(Vec3::new(0.3, 0.2, 2.5))
                * Transform::rotation_x(25.0)
                * Transform::scaling(Vec3::new(0.7, 1.2, 1.0));
            b.add_shape(Shape::Disk(Disk::new(t)), m, Some(em));
        }
        Emitter::Box => {
            b.add_shape(Shape::Cube(Cube::new(box_place())), m, Some(em));
        }
        Emitter::Mesh => {
            let mut mesh = Mesh::default();
            for (i, t) in octahedron().iter().enumerate() {
                mesh.positions.extend_from_slice(t);
                let k = 3 * i as u32;
                mesh.indices.push([k, k + 1, k + 2]);
            }
            mesh.props = SurfaceProps {
                material: m,
                emission: Some(em),
                light: None,
            };
            b.add_mesh(mesh);
        }
    }
    let s = b.build(AccelKind::None);
    assert_eq!(s.lights.len(), 1, "{e:?}: one area light expected");
    s
}

/// A sample of `light` from `p` that the point really sees (samples on the hidden side of a
/// closed emitter are occluded by its front, and count as "no direction").
fn visible_sample(s: &Scene, light: &Light, p: Point3, u: [f32; 2]) -> Option<(Vec3, f32, Rgb)> {
    let ls = light.sample(&s.geometry, &s.emissions, p, u, &Wavelengths::Rgb)?;
    match ls.target {
        Target::Surface(q, _) => {
            if !s.visible(p, q, &mut RayStats::default()) {
                return None;
            }
        }
        Target::Infinite => {}
        Target::Point(_) => panic!("area and infinite lights do not target points"),
    }
    Some((ls.wi, ls.pdf, ls.li.to_rgb()))
}

/// The solid-angle density of sampling direction `d` from `p`: pdf_hit at the first hit if it
/// is an emitting point of the light, else 0.
fn area_pdf(s: &Scene, light: &Light, p: Point3, d: Vec3) -> f32 {
    match s.interact(&Ray::new(p, d), &mut RayStats::default()) {
        Some(si) if !s.emitted(&si, &Wavelengths::Rgb).to_rgb().is_black() => {
            light.pdf_hit(p, si.p, si.n)
        }
        _ => 0.0,
    }
}

/// One χ² configuration of an area light.
struct AreaCase {
    name: &'static str,
    emitter: Emitter,
    two_sided: bool,
    p: Point3,
    /// Grid axis and power.
    axis: Vec3,
    power: f64,
}

fn area_cases() -> Vec<AreaCase> {
    let (c, r) = sphere_place();
    let inside_sphere = c + Vec3::new(0.2, 0.3, -0.4);
    let ell_c = ellipsoid_place().point(Point3::ORIGIN);
    let box_c = box_place().point(Point3::ORIGIN);
    let mesh_c = Point3::new(0.1, -0.15, 3.25);
    let o = Point3::new(0.1, 0.2, -0.5);
    let to = |q: Point3| q - o;
    let _ = r;
    vec![
        AreaCase {
            name: "similar sphere, point outside (cone sampling)",
            emitter: Emitter::Sphere,
            two_sided: false,
            p: o,
            axis: to(c),
            power: 2.0,
        },
        AreaCase {
            name: "similar sphere, point inside (area sampling)",
            emitter: Emitter::Sphere,
            two_sided: true,
            p: inside_sphere,
            axis: Vec3::Z,
            power: 1.0,
        },
        AreaCase {
            name: "ellipsoid, point inside",
            emitter: Emitter::Ellipsoid,
            two_sided: true,
            p: ell_c + Vec3::new(0.3, 0.0, 0.1),
            axis: Vec3::Z,
            power: 1.0,
        },
        AreaCase {
            name: "parallelogram, two-sided, seen from its back",
            emitter: Emitter::Parallelogram,
            two_sided: true,
            p: o,
            axis: to(Point3::new(0.0, 0.2, 2.0)),
            power: 2.0,
        },
        AreaCase {
            name: "parallelogram, one-sided, seen from its front",
            emitter: Emitter::Parallelogram,
            two_sided: false,
            p: Point3::new(0.0, 0.3, 4.0),
            axis: -Vec3::Z,
            power: 2.0,
        },
        AreaCase {
            name: "elliptic disk",
            emitter: Emitter::Disk,
            two_sided: true,
            p: o,
            axis: to(Point3::new(0.3, 0.2, 2.5)),
            power: 2.0,
        },
        AreaCase {
            name: "box, point outside",
            emitter: Emitter::Box,
            two_sided: false,
            p: o,
            axis: to(box_c),
            power: 2.0,
        },
        AreaCase {
            name: "box, point inside",
            emitter: Emitter::Box,
            two_sided: true,
            p: box_c + Vec3::new(0.1, -0.1, 0.05),
            axis: Vec3::Z,
            power: 1.0,
        },
        AreaCase {
            name: "mesh, point outside",
            emitter: Emitter::Mesh,
            two_sided: false,
            p: o,
            axis: to(mesh_c),
            power: 2.0,
        },
        AreaCase {
            name: "mesh, point inside",
            emitter: Emitter::Mesh,
            two_sided: true,
            p: mesh_c,
            axis: Vec3::Z,
            power: 1.0,
        },
    ]
}

/// A lat-long map with a smooth gradient and a small, very bright spot.
fn env_image() -> Texture {
    let (w, h) = (48, 24);
    let mut img = Image::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let v = 0.2 + 0.8 * (x as f32 / w as f32) + 0.5 * (y as f32 / h as f32);
            img.set(x, y, Rgb::new(v, 0.7 * v, 0.3 + v));
        }
    }
    for (x, y) in [(30, 7), (31, 7), (30, 8)] {
        img.set(x, y, Rgb::new(400.0, 300.0, 200.0));
    }
    // A black row: directions never sampled, with density 0.
    for x in 0..w {
        img.set(x, 17, Rgb::BLACK);
    }
    Texture::Image(ImageTexture::new(Arc::new(img)))
}

fn env_transform() -> Transform {
    Transform::rotation(Vec3::new(0.3, 1.0, 0.2), 50.0).unwrap()
}

fn infinite_cases() -> Vec<(&'static str, Light)> {
    vec![
        (
            "environment map with a bright spot",
            Light::Environment(Environment::new(env_image(), env_transform())),
        ),
        (
            "constant environment",
            Light::Environment(Environment::new(
                Texture::Uniform(Rgb::splat(1.5)),
                env_transform(),
            )),
        ),
        (
            "hemisphere light",
            Light::Hemisphere(
                HemisphereLight {
                    radiance: Rgb::splat(2.0),
                    up: Vec3::new(0.3, -0.5, 0.8).normalize(),
                },
                Components::from_intensity(Rgb::splat(2.0)),
            ),
        ),
    ]
}

fn tests_count() -> usize {
    // The area lights, the ellipsoid seen from outside, the lights at infinity, the
    // compensated environment map.
    area_cases().len() + 1 + infinite_cases().len() + 1
}

fn seed(name: &str) -> u64 {
    name.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ b as u64).wrapping_mul(0x0100_0000_01b3)
    })
}

// The directions of area-light samples seen from a point follow pdf_hit: cone sampling of a
// sphere (uniform in the subtended cone), area sampling of spheres from inside, of ellipsoids
// (with the area scale |det M|·|M⁻ᵀn| of the placement), parallelograms, elliptic disks, boxes
// (faces by area) and meshes (triangles by area), converted to solid angle by d²/|cos θ|. The
// hidden half of closed emitters and the back of one-sided emitters count as "no direction":
// the density must integrate to the visible fraction.
#[test]
fn chi2_area_lights() {
    let level = sidak(ALPHA, tests_count());
    let mut failures = Vec::new();
    for c in area_cases() {
        let s = scene(c.emitter, c.two_sided);
        let light = &s.lights[0];
        let t = Chi2 {
            name: c.name,
            grid: Grid::new(c.axis, c.power, ROWS),
            samples: SAMPLES,
            seed: seed(c.name),
            // Seen from inside, every sample is visible.
            expected_mass: (c.power == 1.0).then_some(1.0),
            level,
        };
        match t.run(
            |u| visible_sample(&s, light, c.p, [u[0], u[1]]).map(|(d, p, _)| (d, p)),
            |d| area_pdf(&s, light, c.p, d),
        ) {
            Ok(r) => println!(
                "{}: p-value {:.3e}, visible mass {:.4}",
                c.name, r.p_value, r.pdf_integral
            ),
            Err(e) => failures.push(e),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The area of the image of the unit tangent square at the unit vector `u` under the linear
/// part of `t`: |M t1 × M t2| for orthonormal tangents t1, t2 (= |det M|·|M⁻ᵀu| by Nanson's
/// formula, computed here without the inverse transpose that the light uses).
fn area_scale(t: &Transform, u: Vec3) -> f32 {
    let f = candela_render::math::Frame::from_normal(u.to_normal());
    t.vector(f.s).cross(t.vector(f.t)).norm()
}

// An ellipsoid (a sphere under a rotation and a non-uniform scaling) seen from outside is
// sampled by area: its solid-angle density d²/(A(q)|cos θ|) diverges like 1/cos at the
// silhouette, which no per-cell cubature integrates to the needed accuracy. The samples are
// therefore binned in the object space of the sphere (a bijection of the visible directions),
// with the density pdf_hit · |cos θ|/d² · dA/dA_object per unit object solid angle, the
// conversion computed by the test. pdf_hit and the sampler must agree there, and the visible
// fraction must be ∫ pdf.
#[test]
fn chi2_ellipsoid_from_outside() {
    let level = sidak(ALPHA, tests_count());
    let s = scene(Emitter::Ellipsoid, false);
    let light = &s.lights[0];
    let t = ellipsoid_place();
    let p = Point3::new(0.1, 0.2, -0.5);
    // Density per unit object-space solid angle of the world point q with normal n.
    let object_density = |q: Point3, n: candela_render::math::Normal3, pdf: f32| {
        let to = p - q;
        let d2 = to.squared_norm();
        let cos = n.dot_vec(to).abs() / d2.sqrt();
        let u = t.inv_point(q).to_vec().normalize();
        pdf * cos / d2 * area_scale(&t, u)
    };
    let name = "ellipsoid, point outside (area sampling), object space";
    let test = Chi2 {
        name,
        grid: Grid::new(t.inv_vector(p - t.point(Point3::ORIGIN)), 1.0, ROWS),
        samples: SAMPLES,
        seed: seed(name),
        expected_mass: None,
        level,
    };
    let r = test.run(
        |u| {
            let ls = light.sample(
                &s.geometry,
                &s.emissions,
                p,
                [u[0], u[1]],
                &Wavelengths::Rgb,
            )?;
            let Target::Surface(q, n) = ls.target else {
                panic!("area light")
            };
            if !s.visible(p, q, &mut RayStats::default()) {
                return None;
            }
            let dir = t.inv_point(q).to_vec().normalize();
            Some((dir, object_density(q, n, ls.pdf)))
        },
        |u| {
            // The world point of the object direction u, if p sees its emitting side.
            let q = t.point(u.to_point());
            let hit = s.interact(&Ray::new(p, q - p), &mut RayStats::default());
            match hit {
                Some(si)
                    if (si.p - q).norm() < 1e-4
                        && !s.emitted(&si, &Wavelengths::Rgb).to_rgb().is_black() =>
                {
                    object_density(si.p, si.n, light.pdf_hit(p, si.p, si.n))
                }
                _ => 0.0,
            }
        },
    );
    match r {
        Ok(r) => println!(
            "{name}: p-value {:.3e}, visible mass {:.4}",
            r.p_value, r.pdf_integral
        ),
        Err(e) => panic!("{e}"),
    }
}

/// The χ² test of a light at infinity: directions binned over the whole sphere, every sample
/// one (density of mass 1).
fn whole_sphere(name: &str, level: f64) -> Chi2<'_> {
    Chi2 {
        name,
        grid: Grid::new(Vec3::Z, 1.0, ROWS),
        samples: SAMPLES,
        seed: seed(name),
        expected_mass: Some(1.0),
        level,
    }
}

// Lights at infinity: the environment map's directions follow its luminance × sin θ
// distribution converted to solid angle (pdf_uv / (2π² sin θ)), through a rotated frame; black
// texels are never sampled; the constant environment and the hemisphere light sample uniformly.
#[test]
fn chi2_infinite_lights() {
    let level = sidak(ALPHA, tests_count());
    let s = SceneBuilder::new().build(AccelKind::None);
    let mut failures = Vec::new();
    for (name, light) in infinite_cases() {
        let t = whole_sphere(name, level);
        let p = Point3::ORIGIN;
        match t.run(
            |u| visible_sample(&s, &light, p, [u[0], u[1]]).map(|(d, p, _)| (d, p)),
            |d| light.pdf_escape(d),
        ) {
            Ok(r) => println!("{name}: p-value {:.3e}", r.p_value),
            Err(e) => failures.push(e),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

// The path tracer's samples of an environment map (MIS weighs them against BSDF sampling)
// follow its compensated distribution: the directions follow pdf_escape_from, which integrates
// to 1; the directions of the map's dim gradient, no brighter than its mean, are never sampled
// (density 0 there, where the full distribution is positive), and the bright spot takes them all.
#[test]
fn chi2_environment_map_compensated() {
    let level = sidak(ALPHA, tests_count());
    let s = SceneBuilder::new().build(AccelKind::None);
    let light = Light::Environment(Environment::new(env_image(), env_transform()));
    let sp = ShadingPoint {
        p: Point3::ORIGIN,
        n: Vec3::Z,
        reflect_only: false,
    };
    let name = "environment map, compensated";
    let t = whole_sphere(name, level);
    match t.run(
        |u| {
            light
                .sample_from(
                    &s.geometry,
                    &s.emissions,
                    &sp,
                    [u[0], u[1]],
                    &Wavelengths::Rgb,
                )
                .map(|ls| (ls.wi, ls.pdf))
        },
        |d| light.pdf_escape_from(d, &sp),
    ) {
        Ok(r) => println!("{name}: p-value {:.3e}", r.p_value),
        Err(e) => panic!("{e}"),
    }
    // A direction of the gradient (the map's left edge, near its equator).
    let dim = env_transform().vector(Vec3::new(0.999, 0.04, 0.0).normalize());
    assert!(light.pdf_escape(dim) > 0.0);
    assert_eq!(light.pdf_escape_from(dim, &sp), 0.0);
}

/// The Monte Carlo irradiance E = ∫ L cos⁺θ dω at `p` (normal `n`) by sampling `light`, with
/// its standard error.
fn irradiance(
    s: &Scene,
    light: &Light,
    p: Point3,
    n: Vec3,
    samples: usize,
    seed: u64,
) -> (f64, f64) {
    let mut rng = Pcg32::new(seed, 77);
    let (mut sum, mut sum2) = (0f64, 0f64);
    for _ in 0..samples {
        let v = match visible_sample(s, light, p, [rng.next_f32(), rng.next_f32()]) {
            Some((wi, pdf, li)) => (li.average() * n.dot(wi).max(0.0) / pdf) as f64,
            None => 0.0,
        };
        sum += v;
        sum2 += v * v;
    }
    mean_and_error(sum, sum2, samples)
}

/// The irradiance E at the origin (normal `n`) from the light at infinity `light` as the path
/// tracer estimates it at a diffuse surface: one light sample (`Light::sample_from`: an
/// environment map's compensated distribution) and one cosine-weighted sample per estimate,
/// each weighed by the power heuristic against the other technique's density; with its
/// standard error.
fn mis_irradiance(s: &Scene, light: &Light, n: Vec3, samples: usize, seed: u64) -> (f64, f64) {
    use candela_render::sampling::warp;
    let sp = ShadingPoint {
        p: Point3::ORIGIN,
        n,
        reflect_only: true,
    };
    let frame = candela_render::math::Frame::from_normal(n.to_normal());
    let heuristic = |a: f32, b: f32| (a * a / (a * a + b * b)) as f64;
    let mut rng = Pcg32::new(seed, 78);
    let (mut sum, mut sum2) = (0f64, 0f64);
    for _ in 0..samples {
        let mut v = 0.0;
        let u = [rng.next_f32(), rng.next_f32()];
        if let Some(ls) = light.sample_from(&s.geometry, &s.emissions, &sp, u, &Wavelengths::Rgb) {
            let cos = n.dot(ls.wi).max(0.0);
            let pdf_bsdf = warp::cosine_hemisphere_pdf(cos);
            v += (ls.li.to_rgb().average() * cos / ls.pdf) as f64 * heuristic(ls.pdf, pdf_bsdf);
        }
        let wi = frame.to_world(warp::square_to_cosine_hemisphere([
            rng.next_f32(),
            rng.next_f32(),
        ]));
        let cos = n.dot(wi);
        let pdf_bsdf = warp::cosine_hemisphere_pdf(cos);
        if pdf_bsdf > 0.0 {
            let li = light.escaped(wi, &Wavelengths::Rgb).to_rgb().average();
            let pdf_light = light.pdf_escape_from(wi, &sp);
            v += (li * cos / pdf_bsdf) as f64 * heuristic(pdf_bsdf, pdf_light);
        }
        sum += v;
        sum2 += v * v;
    }
    mean_and_error(sum, sum2, samples)
}

/// The irradiance from a uniform polygon of radiance `l` entirely above the horizon of `n` at
/// `p` (Lambert's formula: E = l/2 · |Σ γ_k n·û_k|, γ_k the angle subtended by edge k and û_k
/// the unit normal of the plane through p and that edge).
fn polygon_irradiance(l: f64, p: Point3, n: Vec3, verts: &[Point3]) -> f64 {
    let r: Vec<[f64; 3]> = verts
        .iter()
        .map(|v| {
            let d = *v - p;
            let len = (d.x as f64 * d.x as f64 + d.y as f64 * d.y as f64 + d.z as f64 * d.z as f64)
                .sqrt();
            [d.x as f64 / len, d.y as f64 / len, d.z as f64 / len]
        })
        .collect();
    let mut sum = 0.0;
    for k in 0..r.len() {
        let (a, b) = (r[k], r[(k + 1) % r.len()]);
        let c = [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ];
        let cl = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        let gamma = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2])
            .clamp(-1.0, 1.0)
            .acos();
        sum += gamma * (n.x as f64 * c[0] + n.y as f64 * c[1] + n.z as f64 * c[2]) / cl;
    }
    0.5 * l * sum.abs()
}

// Light sampling estimates the irradiance E = ∫ L cos θ dω without bias: its Monte Carlo mean
// matches the closed forms within 3 standard errors: a sphere subtending the half-angle α on
// the normal axis gives π L sin²α, a disk of radius R at height h on its axis π L R²/(h² + R²),
// polygons (parallelogram, the visible faces of a box, the visible triangles of a mesh)
// Lambert's formula, any closed emitter around the point π L, a hemisphere light
// π L (1 + n·up)/2, a constant environment π L.
#[test]
fn irradiance_matches_closed_forms() {
    let n_samples = 100_000;
    let l = L as f64;
    let mut failures = Vec::new();
    let mut lines = Vec::new();
    let mut check = |name: &str, (est, se): (f64, f64), exact: f64| {
        lines.push(format!("{name}: {est:.5} ± {se:.5} vs {exact:.5}"));
        // 3 standard errors, plus f32 round-off (1e-5 relative) for the estimators whose
        // variance vanishes (a uniform sphere sampled by its cone).
        if !((est - exact).abs() <= 3.0 * se + 1e-5 * exact.max(1.0)) {
            failures.push(format!("{name}: light sampling estimates E = {est:.6} ± {se:.6}, the closed form is {exact:.6} ({:.1} standard errors)", (est - exact).abs() / se));
        }
    };
    let (c, r) = sphere_place();

    // Sphere on the normal axis (cone sampling), from several distances.
    let s = scene(Emitter::Sphere, false);
    // (At 1000 radii the cone's 1 − cos θ_max is below the f32 spacing near 1: it must not be
    // computed as 1 − cos θ_max.)
    for dist in [1.2f32, 3.0, 20.0, 1000.0] {
        let p = c + Vec3::new(0.0, 0.0, -dist);
        let sin2 = (r / dist) as f64 * (r / dist) as f64;
        check(
            &format!("sphere at distance {dist}"),
            irradiance(&s, &s.lights[0], p, Vec3::Z, n_samples, 1),
            PI as f64 * l * sin2,
        );
    }
    // Sphere tilted off the normal but above the horizon: E = π L sin²α cos β.
    let p = c + Vec3::new(-1.5, 0.0, -2.0);
    let axis = (c - p).normalize();
    let sin2 = (r * r / (c - p).squared_norm()) as f64;
    check(
        "sphere off-axis",
        irradiance(&s, &s.lights[0], p, Vec3::Z, n_samples, 2),
        PI as f64 * l * sin2 * axis.z as f64,
    );
    // Inside spheres and ellipsoids (area sampling): the whole hemisphere glows.
    let s2 = scene(Emitter::Sphere, true);
    check(
        "inside a sphere",
        irradiance(
            &s2,
            &s2.lights[0],
            c + Vec3::new(0.2, -0.3, 0.1),
            Vec3::new(0.3, 0.4, 0.866).normalize(),
            n_samples,
            3,
        ),
        PI as f64 * l,
    );
    let s3 = scene(Emitter::Ellipsoid, true);
    let ec = ellipsoid_place().point(Point3::ORIGIN);
    check(
        "inside an ellipsoid",
        irradiance(
            &s3,
            &s3.lights[0],
            ec + Vec3::new(0.2, 0.1, 0.0),
            Vec3::new(-0.5, 0.1, 0.86).normalize(),
            n_samples,
            4,
        ),
        PI as f64 * l,
    );

    // An ellipsoid from outside: no closed form, the reference is a fine quadrature of L cos θ
    // over the directions that hit it (a bounded integrand).
    let s4 = scene(Emitter::Ellipsoid, false);
    let p = Point3::new(0.1, 0.2, -0.5);
    let nrm = Vec3::new(0.1, 0.2, 0.97).normalize();
    let axis = (ec - p).normalize();
    let fr = candela_render::math::Frame::from_normal(axis.to_normal());
    let (k, cmin) = (1200, 0.8f64);
    let mut exact = 0.0;
    for i in 0..k {
        let cz = 1.0 - (1.0 - cmin) * (i as f64 + 0.5) / k as f64;
        let st = (1.0 - cz * cz).sqrt();
        for j in 0..k {
            let ph = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / k as f64;
            let d = fr.to_world(Vec3::new(
                (st * ph.cos()) as f32,
                (st * ph.sin()) as f32,
                cz as f32,
            ));
            if s4
                .intersect(&Ray::new(p, d), &mut RayStats::default())
                .is_some()
            {
                exact += l * nrm.dot(d).max(0.0) as f64;
            }
        }
    }
    exact *= (1.0 - cmin) / k as f64 * 2.0 * std::f64::consts::PI / k as f64;
    check(
        "ellipsoid from outside (vs quadrature)",
        irradiance(&s4, &s4.lights[0], p, nrm, n_samples, 14),
        exact,
    );

    // A circular disk of radius R facing the point at height h on its axis.
    for (rad, h) in [(0.5f32, 2.0f32), (1.5, 0.7)] {
        let mut b = SceneBuilder::new();
        let m = b.add_material(Material::diffuse(Texture::Uniform(Rgb::splat(0.5))));
        let em = b.add_emission(Emission {
            radiance: Texture::Uniform(Rgb::splat(L)),
            two_sided: false,
        });
        // The disk's normal (+z of its frame) faces the point below it.
        let t = Transform::translation(Vec3::new(0.0, 0.0, h))
            * Transform::rotation_x(180.0)
            * Transform::scaling(Vec3::new(rad, rad, 1.0));
        b.add_shape(Shape::Disk(Disk::new(t)), m, Some(em));
        let sd = b.build(AccelKind::None);
        let exact = PI as f64 * l * (rad * rad) as f64 / (h * h + rad * rad) as f64;
        check(
            &format!("disk R={rad} h={h}"),
            irradiance(&sd, &sd.lights[0], Point3::ORIGIN, Vec3::Z, n_samples, 5),
            exact,
        );
    }

    // A parallelogram, by Lambert's formula.
    let sp = scene(Emitter::Parallelogram, true);
    let pg = parallelogram();
    let quad = [pg.p, pg.p + pg.v, pg.p + pg.v + pg.w, pg.p + pg.w];
    for (p, n) in [
        (Point3::new(0.1, 0.2, -0.5), Vec3::Z),
        (
            Point3::new(-1.0, 0.5, 0.5),
            Vec3::new(0.3, -0.2, 0.93).normalize(),
        ),
    ] {
        check(
            &format!("parallelogram from {p:?}"),
            irradiance(&sp, &sp.lights[0], p, n, n_samples, 6),
            polygon_irradiance(l, p, n, &quad),
        );
    }

    // A box from outside: the faces turned to the point, by Lambert's formula; from inside: π L.
    let sb = scene(Emitter::Box, false);
    let bt = box_place();
    let p = Point3::new(0.1, 0.2, -0.5);
    let mut exact = 0.0;
    for face in 0..6u32 {
        let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
            .map(|(a, b)| bt.point(Cube::face_point(face, a, b)));
        let centre = bt.point(Cube::face_point(face, 0.0, 0.0));
        let outward = centre - bt.point(Point3::ORIGIN);
        // A face is seen from outside when the point lies on its outer side.
        let fnormal = (corners[1] - corners[0]).cross(corners[3] - corners[0]);
        let fnormal = if fnormal.dot(outward) < 0.0 {
            -fnormal
        } else {
            fnormal
        };
        if fnormal.dot(p - centre) > 0.0 {
            exact += polygon_irradiance(l, p, Vec3::Z, &corners);
        }
    }
    check(
        "box from outside",
        irradiance(&sb, &sb.lights[0], p, Vec3::Z, n_samples, 7),
        exact,
    );
    let sb2 = scene(Emitter::Box, true);
    check(
        "inside a box",
        irradiance(
            &sb2,
            &sb2.lights[0],
            bt.point(Point3::new(0.2, 0.3, -0.1)),
            Vec3::new(0.6, 0.0, 0.8),
            n_samples,
            8,
        ),
        PI as f64 * l,
    );

    // A closed mesh from outside (front triangles) and from inside.
    let sm = scene(Emitter::Mesh, false);
    let centre = Point3::new(0.1, -0.15, 3.25);
    let mut exact = 0.0;
    for t in octahedron() {
        let nrm = (t[1] - t[0]).cross(t[2] - t[0]);
        let nrm = if nrm.dot(t[0] - centre) < 0.0 {
            -nrm
        } else {
            nrm
        };
        if nrm.dot(p - t[0]) > 0.0 {
            exact += polygon_irradiance(l, p, Vec3::Z, &t);
        }
    }
    check(
        "mesh from outside",
        irradiance(&sm, &sm.lights[0], p, Vec3::Z, n_samples, 9),
        exact,
    );
    let sm2 = scene(Emitter::Mesh, true);
    check(
        "inside a mesh",
        irradiance(
            &sm2,
            &sm2.lights[0],
            centre,
            Vec3::new(0.0, -0.6, 0.8),
            n_samples,
            10,
        ),
        PI as f64 * l,
    );

    // Lights at infinity.
    let empty = SceneBuilder::new().build(AccelKind::None);
    let hemi = HemisphereLight {
        radiance: Rgb::splat(2.0),
        up: Vec3::new(0.3, -0.5, 0.8).normalize(),
    };
    let hl = Light::Hemisphere(hemi, Components::from_intensity(Rgb::splat(2.0)));
    for nrm in [hemi.up, Vec3::Z, Vec3::X, -hemi.up] {
        let exact = PI as f64 * hemi.diffuse_irradiance_over_pi(nrm).average() as f64;
        let exact_by_hand = PI as f64 * 2.0 * 0.5 * (1.0 + nrm.dot(hemi.up) as f64);
        assert!((exact - exact_by_hand).abs() < 1e-5);
        check(
            &format!("hemisphere light, normal {nrm:?}"),
            irradiance(&empty, &hl, Point3::ORIGIN, nrm, n_samples, 11),
            exact_by_hand,
        );
    }
    let env = Light::Environment(Environment::new(
        Texture::Uniform(Rgb::splat(1.5)),
        env_transform(),
    ));
    check(
        "constant environment",
        irradiance(
            &empty,
            &env,
            Point3::ORIGIN,
            Vec3::new(0.2, 0.3, 0.93).normalize(),
            n_samples,
            12,
        ),
        PI as f64 * 1.5,
    );
    // The image map: the reference integrates the (piecewise constant) map over the hemisphere
    // by a fine quadrature in (u, v).
    let tex = env_image();
    let envl = Light::Environment(Environment::new(tex.clone(), env_transform()));
    let nrm = Vec3::new(-0.4, 0.5, 0.77).normalize();
    let (nu, nv) = (1536, 768);
    let mut exact = 0.0f64;
    for j in 0..nv {
        let v = (j as f64 + 0.5) / nv as f64;
        let theta = v * std::f64::consts::PI;
        for i in 0..nu {
            let u = (i as f64 + 0.5) / nu as f64;
            let phi = u * 2.0 * std::f64::consts::PI;
            let dl = Vec3::new(
                (theta.sin() * phi.cos()) as f32,
                (theta.sin() * phi.sin()) as f32,
                theta.cos() as f32,
            );
            let d = env_transform().vector(dl);
            let cos = nrm.dot(d).max(0.0) as f64;
            let rad = tex.eval(Point2::new(u as f32, v as f32)).average() as f64;
            exact += rad
                * cos
                * theta.sin()
                * (2.0 * std::f64::consts::PI / nu as f64)
                * (std::f64::consts::PI / nv as f64);
        }
    }
    check(
        "environment map",
        irradiance(&empty, &envl, Point3::ORIGIN, nrm, n_samples, 13),
        exact,
    );
    check(
        "environment map, compensated light samples and cosine samples by MIS",
        mis_irradiance(&empty, &envl, nrm, n_samples, 14),
        exact,
    );

    println!("{}", lines.join("\n"));
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A sphere light's cone samples name a point on the sphere, facing the shading point, along
/// the sampled direction, with a unit normal: from near the surface to a thousand radii away.
#[test]
fn sphere_cone_samples_land_on_the_sphere() {
    let s = scene(Emitter::Sphere, false);
    let (c, r) = sphere_place();
    let light = &s.lights[0];
    let mut rng = Pcg32::new(12, 3);
    for dist in [1.02f32, 1.5, 4.0, 30.0, 1000.0] {
        for _ in 0..500 {
            let dir = Vec3::new(
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
            )
            .normalize();
            let p = c + dir * (r * dist);
            let u = [rng.next_f32(), rng.next_f32()];
            let ls = light
                .sample(&s.geometry, &s.emissions, p, u, &Wavelengths::Rgb)
                .expect("a sample from outside");
            let Target::Surface(q, n) = ls.target else {
                panic!("a point on the sphere")
            };
            // Round-off grows with the distance (the point is found from p, |p − c| = dist·r).
            let scale = 2e-6 * dist.max(1.0);
            assert!(((q - c).norm() - r).abs() <= scale * r, "{dist}: {q:?}");
            assert!((n.to_vec().norm() - 1.0).abs() <= scale, "{dist}: {n:?}");
            assert!(n.to_vec().dot(-ls.wi) > 0.0, "{dist}: faces away");
            assert!((ls.wi.norm() - 1.0).abs() < 1e-5);
            let to = q - p;
            assert!(to.cross(ls.wi).norm() <= scale * to.norm().max(r), "{dist}");
            assert!(to.dot(ls.wi) > 0.0);
        }
    }
}
