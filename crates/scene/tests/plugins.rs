//! Shapes and plugins of issue 15: the cylinder in both formats (Mitsuba's `p0`, `p1`, `radius`
//! folded into the placement, the candela language's `cylinder(MAT, T)`), checked by rays with
//! hand-computed hits; Mitsuba spot lights with a projected texture; Mitsuba's `mask` BSDF.

mod support;

use candela_render::math::{Point3, Ray, Vec3};
use candela_render::spectrum::Wavelengths;
use candela_render::stats::RayStats;
use candela_render::Scene;
use support::mitsuba::{error_of, load, scene};

/// The hit distance and point of a ray.
fn hit(s: &Scene, o: [f32; 3], d: [f32; 3]) -> Option<(f32, Point3)> {
    let ray = Ray::new(
        Point3::new(o[0], o[1], o[2]),
        Vec3::new(d[0], d[1], d[2]).normalize(),
    );
    let h = s.intersect(&ray, &mut RayStats::default())?;
    let si = s.geometry.interaction(&ray, &h);
    Some((h.t, si.p))
}

#[test]
fn mitsuba_cylinders_follow_p0_p1_and_radius() {
    // Axis from (1, 0, 0) to (1, 0, 2) with radius 0.5, then moved up by 1.
    let l = load(&scene(
        r#"<shape type="cylinder"><point name="p0" x="1" y="0" z="0"/><point name="p1" x="1" y="0" z="2"/>
  <float name="radius" value="0.5"/><transform name="to_world"><translate z="1"/></transform></shape>"#,
    ));
    let (t, p) = hit(&l.scene, [-3.0, 0.0, 2.0], [1.0, 0.0, 0.0]).unwrap();
    assert!((t - 3.5).abs() < 1e-4, "{t}");
    assert!((p.z - 2.0).abs() < 1e-4);
    // Above the top (z = 3) and below the bottom (z = 1): open and bounded.
    assert!(hit(&l.scene, [-3.0, 0.0, 3.2], [1.0, 0.0, 0.0]).is_none());
    assert!(hit(&l.scene, [-3.0, 0.0, 0.8], [1.0, 0.0, 0.0]).is_none());
    // Down the axis: no caps.
    assert!(hit(&l.scene, [1.0, 0.0, 10.0], [0.0, 0.0, -1.0]).is_none());
    let e = error_of(&scene(
        r#"<shape type="cylinder"><boolean name="flip_normals" value="true"/></shape>"#,
    ));
    assert!(e.contains("flip_normals on a cylinder"), "{e}");
}

#[test]
fn the_candela_language_has_cylinders() {
    let dir = support::mitsuba::tmpdir("cylinder-lang");
    let path = dir.join("c.txt");
    std::fs::write(
        &path,
        "material m(diffuse(<1, 1, 1>))\ncylinder(m, translation([0, 0, 1]) * scaling([2, 2, 3]))\n",
    )
    .unwrap();
    let l = candela_scene::load_scene(&path, &Default::default()).unwrap();
    let (t, _) = hit(&l.scene, [-5.0, 0.0, 2.5], [1.0, 0.0, 0.0]).unwrap();
    assert!((t - 3.0).abs() < 1e-4);
    assert!(hit(&l.scene, [-5.0, 0.0, 4.5], [1.0, 0.0, 0.0]).is_none());
    let d = support::lang::parse(
        "material m(diffuse(<1, 1, 1>))\nunion(cylinder(m, identity), sphere(m, identity))",
    );
    let e = candela_scene::builder::build_scene(&d, Default::default(), &Default::default())
        .unwrap_err();
    assert!(e.message.contains("CSG operands must be solids"), "{e}");
}

/// A spot light's projected texture: the quadrants of a checkerboard along directions in the
/// light's frame (uv = ½ + ½·(x, y)/(z·tan cut-off)).
#[test]
fn mitsuba_spot_lights_project_their_texture() {
    use candela_render::light::Light;
    use candela_render::Rgb;
    let l = load(&scene(
        r#"<emitter type="spot"><float name="cutoff_angle" value="45"/>
  <texture type="checkerboard" name="texture"><rgb name="color0" value="1, 0, 0"/><rgb name="color1" value="0, 0, 1"/></texture>
</emitter>"#,
    ));
    let Some(Light::Spot(spot, _)) = l.scene.lights.first() else {
        panic!("no spot light");
    };
    // Axis +z, frame x, y: tan 45° = 1, so w = (0.2, 0.2, 1) looks up uv = (0.6, 0.6).
    let w = |x: f32, y: f32| Vec3::new(x, y, 1.0).normalize();
    assert_eq!(
        spot.pattern(w(0.2, 0.2), &Wavelengths::Rgb).to_rgb(),
        Rgb::new(1.0, 0.0, 0.0)
    );
    assert_eq!(
        spot.pattern(w(-0.2, -0.2), &Wavelengths::Rgb).to_rgb(),
        Rgb::new(1.0, 0.0, 0.0)
    );
    assert_eq!(
        spot.pattern(w(0.2, -0.2), &Wavelengths::Rgb).to_rgb(),
        Rgb::new(0.0, 0.0, 1.0)
    );
    // Behind the light: nothing.
    assert_eq!(
        spot.pattern(Vec3::new(0.0, 0.0, -1.0), &Wavelengths::Rgb)
            .to_rgb(),
        Rgb::BLACK
    );
}

#[test]
fn mitsuba_masks_give_their_material_an_opacity() {
    use candela_render::texture::Texture;
    use candela_render::Rgb;
    let l = load(&scene(
        r#"<shape type="sphere"><bsdf type="twosided"><bsdf type="mask"><float name="opacity" value="0.25"/>
  <bsdf type="diffuse"/></bsdf></bsdf></shape>
<shape type="sphere"><bsdf type="mask"><bsdf type="diffuse"/></bsdf></shape>"#,
    ));
    assert!(l.scene.has_masks);
    let m = &l.scene.materials;
    let with = |a: f32| {
        m.iter()
            .find(|m| m.opacity == Some(Texture::Uniform(Rgb::splat(a))))
            .map(|m| m.two_sided)
    };
    assert_eq!(with(0.25), Some(true));
    // Mitsuba's default opacity is 0.5; one-sided without twosided.
    assert_eq!(with(0.5), Some(false));
    let e = error_of(&scene(
        r#"<shape type="sphere"><bsdf type="mask"/></shape>"#,
    ));
    assert!(e.contains("mask needs one nested <bsdf>"), "{e}");
}
