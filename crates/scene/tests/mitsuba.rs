//! Mitsuba 3 XML import: snippets of each feature → the built scene (camera rays, shapes,
//! materials, lights, hints), errors at `line:col`, `-d` overrides, and the Cornell box, whose
//! camera and geometry are checked against Mitsuba's camera model computed from first
//! principles.

use candela_render::integrator::{Flat, Integrator, Normals, OnOff, Path as PathTracer};

use candela_render::light::{Light, SpotProfile};
use candela_render::material::Model;
use candela_render::math::{Point3, Ray, Vec3};
use candela_render::render::{render, RenderSettings};
use candela_render::shape::Shape;
use candela_render::spectrum::Wavelengths;
use candela_render::stats::RayStats;
use candela_render::texture::{Filter, ImageTexture, Texture};
use candela_render::{Image, Rgb};
use std::path::Path;

mod support;

use support::mitsuba::{
    assert_error_starts_with, error_of, load, load_at, scene, tmpdir, try_load_with,
};

fn close(a: Vec3, b: Vec3) -> bool {
    a.approx_eq(b, 1e-4)
}

fn dir(x: f32, y: f32, z: f32) -> Vec3 {
    Vec3::new(x, y, z).normalize()
}

const SENSOR_200X100: &str = r#"<film type="hdrfilm"><integer name="width" value="200"/><integer name="height" value="100"/><rfilter type="box"/></film>"#;

fn camera_scene(fov: &str, origin: &str) -> String {
    scene(&format!(
        r#"<sensor type="perspective">{fov}
            <transform name="to_world"><lookat origin="{origin}" target="1, 2, 0" up="0, 1, 0"/></transform>
            {SENSOR_200X100}
        </sensor>"#
    ))
}

/// `thinlens`: the aperture is a disk of `aperture_radius` around the eye, and every ray for a
/// screen point crosses the pinhole ray where it is `focus_distance` ahead along the view axis
/// (Mitsuba's definition); the radius is required, the focus distance defaults to far_clip.
#[test]
fn thin_lens_camera() {
    let lens_scene = |params: &str| {
        scene(&format!(
            r#"<sensor type="thinlens"><float name="fov" value="60"/>{params}
                <transform name="to_world"><lookat origin="1, 2, 3" target="1, 2, 0" up="0, 1, 0"/></transform>
                {SENSOR_200X100}
            </sensor>"#
        ))
    };
    let l = load(&lens_scene(
        r#"<float name="aperture_radius" value="0.25"/><float name="focus_distance" value="4"/>"#,
    ));
    let cam = l.scene.camera;
    let lens = cam.lens.expect("a lens");
    assert_eq!((lens.radius, lens.focus_distance), (0.25, 4.0));
    let pinhole = cam.ray(0.7, 0.4);
    // The view axis is -z: the plane in focus is z = 3 - 4.
    let focus = pinhole.at(-4.0 / pinhole.d.z);
    for s in [[0.1, 0.2], [0.9, 0.5], [0.5, 0.99]] {
        let r = cam.ray_through_lens(0.7, 0.4, s);
        assert!(
            (r.o.z - 3.0).abs() < 1e-5 && (r.o - Point3::new(1.0, 2.0, 3.0)).norm() <= 0.25 + 1e-5
        );
        let t = (focus.z - r.o.z) / r.d.z;
        assert!(
            (r.at(t) - focus).norm() < 1e-4,
            "{:?} vs {focus:?}",
            r.at(t)
        );
    }
    let far = load(&lens_scene(
        r#"<float name="aperture_radius" value="0.1"/><float name="far_clip" value="50"/>"#,
    ));
    assert_eq!(far.scene.camera.lens.unwrap().focus_distance, 50.0);
    // A zero aperture is a pinhole.
    let zero = load(&lens_scene(r#"<float name="aperture_radius" value="0"/>"#));
    assert_eq!(zero.scene.camera.lens, None);
    assert_error_starts_with(&lens_scene(""), "2:1: thinlens needs an 'aperture_radius'");
}

#[test]
fn perspective_camera_uses_mitsubas_frame() {
    // Looking along -z with +y up: the image's right is +x (Mitsuba's local +x is on the left).
    let l = load(&camera_scene(
        r#"<float name="fov" value="90"/>"#,
        "1, 2, 3",
    ));
    let cam = l.scene.camera;
    let c = cam.ray(0.5, 0.5);
    assert!(c.o.approx_eq(Point3::new(1.0, 2.0, 3.0), 1e-5), "{:?}", c.o);
    assert!(close(c.d, dir(0.0, 0.0, -1.0)));
    // fov_axis defaults to x: 45° to each side.
    assert!(close(cam.ray(1.0, 0.5).d, dir(1.0, 0.0, -1.0)));
    assert!(close(cam.ray(0.0, 0.5).d, dir(-1.0, 0.0, -1.0)));
    // The film is 2:1, so vertically tan = 1/2; v = 1 is the top.
    assert!(close(cam.ray(0.5, 1.0).d, dir(0.0, 0.5, -1.0)));
    assert_eq!((l.hints.width, l.hints.height), (Some(200), Some(100)));
}

#[test]
fn field_of_view_axes() {
    let t30 = 30f32.to_radians().tan();
    let top = |fov: &str| {
        load(&camera_scene(fov, "1, 2, 3"))
            .scene
            .camera
            .ray(0.5, 1.0)
            .d
    };
    let right = |fov: &str| {
        load(&camera_scene(fov, "1, 2, 3"))
            .scene
            .camera
            .ray(1.0, 0.5)
            .d
    };
    let fov = |axis: &str| {
        format!(r#"<float name="fov" value="60"/><string name="fov_axis" value="{axis}"/>"#)
    };
    assert!(close(top(&fov("y")), dir(0.0, t30, -1.0)));
    // A wide film: the smaller axis is y, the larger x.
    assert!(close(top(&fov("smaller")), dir(0.0, t30, -1.0)));
    assert!(close(right(&fov("larger")), dir(t30, 0.0, -1.0)));
    assert!(close(right(&fov("X")), dir(t30, 0.0, -1.0)));
    // Diagonal: the corner ray is 30° off the axis.
    let corner = load(&camera_scene(&fov("diagonal"), "1, 2, 3"))
        .scene
        .camera
        .ray(1.0, 1.0)
        .d;
    assert!((corner.dot(dir(0.0, 0.0, -1.0)) - 30f32.to_radians().cos()).abs() < 1e-5);
    // No fov: a 50 mm lens on 36×24 mm film, measured along the diagonal.
    let corner = load(&camera_scene("", "1, 2, 3"))
        .scene
        .camera
        .ray(1.0, 1.0)
        .d;
    let half_diag = (43.266615f32 / 100.0).atan();
    assert!((corner.dot(dir(0.0, 0.0, -1.0)) - half_diag.cos()).abs() < 1e-5);
    // The sensor's to_world must not scale (Mitsuba rejects it).
    let e = error_of(&scene(
        r#"<sensor type="perspective"><transform name="to_world"><scale value="2"/></transform></sensor>"#,
    ));
    assert!(
        e.starts_with("2:28: ") && e.contains("must not scale"),
        "{e}"
    );
}

#[test]
fn orthographic_camera() {
    let l = load(&scene(&format!(
        r#"<sensor type="orthographic">
            <transform name="to_world"><scale x="3" y="3"/><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
            {SENSOR_200X100}
        </sensor>"#
    )));
    // The local square [-1,1] × [-1/aspect, 1/aspect], scaled by 3 and turned to look down -z.
    let r = l.scene.camera.ray(1.0, 1.0);
    assert!(r.o.approx_eq(Point3::new(3.0, 1.5, 5.0), 1e-5), "{:?}", r.o);
    assert!(close(r.d, dir(0.0, 0.0, -1.0)));
}

#[test]
fn film_sampler_and_integrator_hints() {
    let xml = scene(
        r#"<integrator type="path"><integer name="max_depth" value="1"/><integer name="rr_depth" value="3"/><boolean name="hide_emitters" value="true"/></integrator>
           <sensor type="perspective"><sampler type="independent"><integer name="sample_count" value="17"/></sampler>
           <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="24"/><rfilter type="box"/></film></sensor>"#,
    );
    let h = load(&xml).hints;
    assert_eq!((h.width, h.height, h.spp), (Some(32), Some(24), Some(17)));
    assert_eq!(
        (
            h.integrator.as_deref(),
            h.max_depth,
            h.rr_depth,
            h.hide_emitters
        ),
        (Some("path"), Some(1), Some(3), true)
    );
    // Mitsuba's direct illumination is the path tracer limited to two vertices.
    let h = load(&scene(r#"<integrator type="direct"/>"#)).hints;
    assert_eq!(
        (h.integrator.as_deref(), h.max_depth),
        (Some("path"), Some(2))
    );
    // Defaults: Mitsuba's 768×576 film, 4 samples, unlimited path tracing.
    let l = load(&scene(""));
    assert_eq!(
        (
            l.hints.width,
            l.hints.height,
            l.hints.spp,
            l.hints.max_depth
        ),
        (Some(768), Some(576), Some(4), Some(-1))
    );
    assert!(
        l.warnings.iter().any(|w| w.contains("no <sensor>")),
        "{:?}",
        l.warnings
    );
    // Errors with positions.
    assert_error_starts_with(
        &scene(r#"<integrator type="path"><integer name="max_depth" value="-2"/></integrator>"#),
        "2:25: 'max_depth' must be between -1",
    );
    assert_error_starts_with(
        &scene(
            r#"<sensor type="perspective"><film type="hdrfilm"><integer name="width" value="0"/></film></sensor>"#,
        ),
        "2:49: 'width' must be between 1",
    );
    assert_error_starts_with(
        &scene(
            r#"<sensor type="perspective"><film type="hdrfilm"><integer name="width" value="99999999999999999999"/></film></sensor>"#,
        ),
        "2:78: '99999999999999999999' is out of range",
    );
    // An unknown integrator is an error at its position.
    assert_error_starts_with(
        &scene(r#"<integrator type="bdpt"/>"#),
        "2:1: unsupported integrator 'bdpt'",
    );
    // `moment` renders its first nested integrator as that integrator, with a note.
    let l = load(&scene(
        r#"<integrator type="moment">
    <integrator type="direct"/>
    <integrator type="path"/>
</integrator>"#,
    ));
    assert_eq!(
        (l.hints.integrator.as_deref(), l.hints.max_depth),
        (Some("path"), Some(2))
    );
    assert!(
        l.warnings.iter().any(|w| w.contains(
            "scenes/test.xml:2:1: integrator 'moment': rendering its first nested integrator 'direct'"
        )),
        "{:?}",
        l.warnings
    );
    let l = load(&scene(
        r#"<integrator type="moment"><integrator type="path"><integer name="max_depth" value="3"/></integrator></integrator>"#,
    ));
    assert_eq!(l.hints.max_depth, Some(3));
    assert_error_starts_with(
        &scene(r#"<integrator type="moment"><integrator type="bdpt"/></integrator>"#),
        "2:27: unsupported integrator 'bdpt'",
    );
    assert_error_starts_with(
        &scene(r#"<integrator type="moment"/>"#),
        "2:1: integrator 'moment' needs a nested <integrator>",
    );
}

#[test]
fn defaults_substitution_and_overrides() {
    let xml = scene(
        r#"<default name="spp" value="8"/>
           <default name="res" value="40"/>
           <default name="r" value="0.5"/>
           <sensor type="perspective"><sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
           <film type="hdrfilm"><integer name="width" value="$res"/><integer name="height" value="$res"/><rfilter type="box"/></film></sensor>
           <shape type="sphere" id="price\$1"><float name="radius" value="$r"/></shape>"#,
    );
    let h = load(&xml).hints;
    assert_eq!((h.width, h.spp), (Some(40), Some(8)));
    // -d overrides a <default>; an unused -d is a warning.
    let l = try_load_with(
        Path::new("scenes/test.xml"),
        &xml,
        &[("res", "64"), ("typo", "1")],
    )
    .unwrap();
    assert_eq!(
        (l.hints.width, l.hints.height, l.hints.spp),
        (Some(64), Some(64), Some(8))
    );
    assert!(
        l.warnings.iter().any(|w| w.contains("-d typo=1")),
        "{:?}",
        l.warnings
    );
    // Substitution happens anywhere in a value; the longest name wins.
    let l = try_load_with(
        Path::new("s.xml"),
        &scene(r#"<default name="a" value="1"/><default name="ab" value="2"/><shape type="sphere"><float name="radius" value="$ab.$a"/></shape>"#),
        &[],
    )
    .unwrap();
    let Shape::Sphere(s) = &l.scene.geometry.objects()[0].shape else {
        panic!()
    };
    assert!(s
        .world_from_object
        .point(Point3::new(1.0, 0.0, 0.0))
        .approx_eq(Point3::new(2.1, 0.0, 0.0), 1e-5));
    // An undefined parameter is an error at its '$'.
    let e = error_of(&scene(
        r#"<shape type="sphere"><float name="radius" value="1 + $nope"/></shape>"#,
    ));
    assert_eq!(e, "2:54: undefined parameter $nope (define it with <default name=\"nope\" value=\"…\"/> or -d nope=…)");
    // A <default> only applies after it.
    assert_error_starts_with(
        &scene(
            r#"<shape type="sphere"><float name="radius" value="$r"/></shape><default name="r" value="1"/>"#,
        ),
        "2:50: undefined parameter $r",
    );
}

/// The transformation of the only sphere.
fn sphere_transform(xml: &str) -> candela_render::math::Transform {
    let l = load(xml);
    match &l.scene.geometry.objects()[0].shape {
        Shape::Sphere(s) => s.world_from_object,
        s => panic!("not a sphere: {s:?}"),
    }
}

#[test]
fn transforms_compose_in_order() {
    let t = |ops: &str| {
        sphere_transform(&scene(&format!(
            r#"<shape type="sphere"><transform name="to_world">{ops}</transform></shape>"#
        )))
    };
    // translate then rotate: T = R·Tr, so the centre moves to R·(1,0,0) = (0,1,0).
    let m = t(r#"<translate x="1"/><rotate z="1" angle="90"/>"#);
    assert!(m
        .point(Point3::ORIGIN)
        .approx_eq(Point3::new(0.0, 1.0, 0.0), 1e-6));
    let m = t(r#"<rotate z="1" angle="90"/><translate x="1"/>"#);
    assert!(m
        .point(Point3::ORIGIN)
        .approx_eq(Point3::new(1.0, 0.0, 0.0), 1e-6));
    // value= forms, a 16- and a 9-value matrix.
    let m = t(r#"<scale value="2"/><translate value="1, 2, 3"/>"#);
    assert!(m
        .point(Point3::new(1.0, 0.0, 0.0))
        .approx_eq(Point3::new(3.0, 2.0, 3.0), 1e-6));
    let m = t(r#"<matrix value="2 0 0 1  0 2 0 2  0 0 2 3  0 0 0 1"/>"#);
    assert!(m
        .point(Point3::new(0.0, 0.0, 1.0))
        .approx_eq(Point3::new(1.0, 2.0, 5.0), 1e-6));
    let m = t(r#"<matrix value="0 -1 0 1 0 0 0 0 1"/>"#);
    assert!(m.vector(Vec3::X).approx_eq(Vec3::Y, 1e-6));
    // lookat: local z towards the target.
    let m = t(r#"<lookat origin="1, 1, 1" target="1, 1, 5" up="0, 1, 0"/>"#);
    assert!(
        m.vector(Vec3::Z).approx_eq(Vec3::Z, 1e-6)
            && m.point(Point3::ORIGIN)
                .approx_eq(Point3::new(1.0, 1.0, 1.0), 1e-6)
    );
    // Errors.
    let e = error_of(&scene(
        r#"<shape type="sphere"><transform name="to_world"><scale x="0"/></transform></shape>"#,
    ));
    assert!(
        e.starts_with("2:22: the shape is degenerate")
            || e.starts_with("2:22: the transformation is singular"),
        "{e}"
    );
    let e = error_of(&scene(
        r#"<shape type="sphere"><transform name="to_world"><rotate angle="3"/></transform></shape>"#,
    ));
    assert_eq!(e, "2:49: the rotation axis is zero");
    let e = error_of(&scene(
        r#"<shape type="sphere"><transform name="to_world"><matrix value="1 2 3"/></transform></shape>"#,
    ));
    assert_eq!(e, "2:64: a matrix needs 9 or 16 numbers, not 3");
    assert_error_starts_with(
        &scene(
            r#"<shape type="sphere"><transform name="to_world"><lookat origin="0,0,0" target="0,0,0"/></transform></shape>"#,
        ),
        "2:49: invalid <lookat>",
    );
    let e = error_of(&scene(r#"<shape type="sphere"><translate x="1"/></shape>"#));
    assert_eq!(e, "2:22: <translate> can only appear inside a <transform>");
}

/// A BSDF that reads texture coordinates, so that a mesh is not loaded as parallelograms.
const CHECKERED: &str =
    r#"<bsdf type="diffuse"><texture type="checkerboard" name="reflectance"/></bsdf>"#;

#[test]
fn analytic_shapes() {
    let l = load(&scene(
        &r#"<shape type="sphere"><point name="center" x="1" y="2" z="3"/><float name="radius" value="0.5"/></shape>
           <shape type="rectangle"><transform name="to_world"><scale x="2"/><translate z="1"/></transform></shape>
           <shape type="rectangle"><boolean name="flip_normals" value="true"/>{CHECKERED}</shape>
           <shape type="disk"><boolean name="flip_normals" value="true"/></shape>
           <shape type="cube"><transform name="to_world"><translate x="5"/></transform></shape>"#
            .replace("{CHECKERED}", CHECKERED),
    ));
    let objects = l.scene.geometry.objects();
    let b = objects[0].shape.bounds().unwrap();
    assert!(
        b.min.approx_eq(Point3::new(0.5, 1.5, 2.5), 1e-5)
            && b.max.approx_eq(Point3::new(1.5, 2.5, 3.5), 1e-5)
    );
    let Shape::Parallelogram(p) = &objects[1].shape else {
        panic!("{:?}", objects[1].shape)
    };
    // [-1,1]² scaled by 2 in x: corner (-2,-1,1), edges (4,0,0) and (0,2,0), normal +z.
    assert!(
        p.p.approx_eq(Point3::new(-2.0, -1.0, 1.0), 1e-6)
            && p.v.approx_eq(Vec3::new(4.0, 0.0, 0.0), 1e-6)
    );
    assert!(p.normal().to_vec().approx_eq(Vec3::Z, 1e-6));
    // A flipped rectangle keeps Mitsuba's uv, so it becomes two triangles facing -z.
    let m = &l.scene.geometry.meshes()[0];
    let g = m.geometry(0, 0.2, 0.2);
    assert!(g.n.to_vec().approx_eq(-Vec3::Z, 1e-6), "{:?}", g.n);
    let Shape::Disk(d) = &objects[2].shape else {
        panic!()
    };
    assert!(d.geometry(0.1, 0.1).n.to_vec().approx_eq(-Vec3::Z, 1e-6));
    assert!(matches!(objects[3].shape, Shape::Cube(_)));
    // No BSDF: Mitsuba's one-sided diffuse 0.5.
    let mat = &l.scene.materials[objects[0].props.material as usize];
    assert!(!mat.two_sided);
    assert_eq!(
        mat.model,
        Model::Diffuse {
            reflectance: Texture::Uniform(Rgb::splat(0.5))
        }
    );
    // A mirroring transform flips the edges' cross product but not Mitsuba's normal: two
    // triangles facing +z again.
    let l = load(&scene(&format!(
        r#"<shape type="rectangle"><transform name="to_world"><scale x="-1"/></transform>{CHECKERED}</shape>"#
    )));
    let g = l.scene.geometry.meshes()[0].geometry(0, 0.2, 0.2);
    assert!(g.n.to_vec().approx_eq(Vec3::Z, 1e-6), "{:?}", g.n);
    // Errors.
    for (radius, expected) in [
        (
            r#"<float name="radius" value="-1"/>"#,
            "2:22: the radius must be positive, not -1",
        ),
        (
            r#"<float name="radius" value="nan"/>"#,
            "2:50: 'nan' is not a finite number",
        ),
        (
            r#"<float name="radius" value="1e999"/>"#,
            "2:50: '1e999' is not a finite number",
        ),
        (
            r#"<integer name="radius" value="x"/>"#,
            "2:52: 'x' is not an integer",
        ),
        (
            r#"<string name="radius" value="1"/>"#,
            "2:22: 'radius' must be a number, not a string",
        ),
    ] {
        let e = error_of(&scene(&format!(r#"<shape type="sphere">{radius}</shape>"#)));
        assert_eq!(e, expected);
    }
    assert_error_starts_with(
        &scene(r#"<shape type="teapot"/>"#),
        "2:1: unsupported shape 'teapot'",
    );
    // An unknown parameter is a warning at its position.
    let l = load(&scene(
        r#"<shape type="sphere"><float name="radiuss" value="2"/></shape>"#,
    ));
    assert_eq!(
        l.warnings[0],
        "scenes/test.xml:2:22: <shape type=\"sphere\">: unknown or unsupported parameter 'radiuss' is ignored"
    );
}

#[test]
fn meshes_from_files() {
    let dir = tmpdir("meshes");
    // A square without normals, two triangles, v up in OBJ.
    std::fs::write(
        dir.join("quad.obj"),
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n",
    )
    .unwrap();
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    std::fs::write(dir.join("tri.ply"), ply).unwrap();
    let l = load_at(
        &dir.join("s.xml"),
        &scene(&format!(
            r#"<shape type="obj"><string name="filename" value="quad.obj"/><transform name="to_world"><translate z="2"/></transform>{CHECKERED}</shape>
               <shape type="obj"><string name="filename" value="quad.obj"/><boolean name="face_normals" value="true"/><boolean name="flip_normals" value="true"/>{CHECKERED}</shape>
               <shape type="ply"><string name="filename" value="tri.ply"/><emitter type="area"><rgb name="radiance" value="1, 2, 3"/></emitter></shape>"#
        )),
    );
    let m = l.scene.geometry.meshes();
    assert_eq!(m.len(), 3);
    // Mitsuba computes vertex normals for meshes without them; face_normals keeps them flat.
    assert_eq!(m[0].normals.len(), 4);
    assert!(m[0].normals[0].to_vec().approx_eq(Vec3::Z, 1e-6));
    assert!(m[0].positions.iter().all(|p| p.z == 2.0));
    assert!(m[1].normals.is_empty());
    assert!(m[1]
        .geometry(0, 0.2, 0.2)
        .n
        .to_vec()
        .approx_eq(-Vec3::Z, 1e-6));
    // OBJ's v is flipped (Mitsuba's flip_tex_coords defaults to true).
    assert_eq!(m[0].uvs[0], candela_render::math::Point2::new(0.0, 1.0));
    // The emissive mesh is an area light emitting on one side only; its BSDF is black.
    assert!(matches!(l.scene.lights[0], Light::Area(_)));
    let e = &l.scene.emissions[m[2].props.emission.unwrap() as usize];
    assert!(!e.two_sided && e.radiance == Texture::Uniform(Rgb::new(1.0, 2.0, 3.0)));
    let black = &l.scene.materials[m[2].props.material as usize];
    assert_eq!(
        black.model,
        Model::Diffuse {
            reflectance: Texture::Uniform(Rgb::BLACK)
        }
    );
    assert_eq!(l.mesh_stats.map(|s| s.0), Some(5));
    // Without a texture reading its coordinates, the quad is loaded as a parallelogram (lit:
    // a rectangle light), facing as its triangles wind.
    let l = load_at(
        &dir.join("s.xml"),
        &scene(
            r#"<shape type="obj"><string name="filename" value="quad.obj"/><emitter type="area"><rgb name="radiance" value="1, 2, 3"/></emitter></shape>"#,
        ),
    );
    assert!(l.scene.geometry.meshes().is_empty());
    let Shape::Parallelogram(q) = &l.scene.geometry.objects()[0].shape else {
        panic!("{:?}", l.scene.geometry.objects())
    };
    assert!(q.normal().to_vec().approx_eq(Vec3::Z, 1e-6));
    assert!((q.area() - 1.0).abs() < 1e-6);
    assert!(matches!(&l.scene.lights[0], Light::Area(a) if a.area == 1.0));
    // A missing file is an error at the file name.
    let e = try_load_with(
        &dir.join("s.xml"),
        &scene(r#"<shape type="ply"><string name="filename" value="nope.ply"/></shape>"#),
        &[],
    )
    .unwrap_err();
    assert_eq!(e.pos.map(|p| (p.line, p.col)), Some((2, 19)));
    assert!(e.message.contains("nope.ply"), "{}", e.message);
}

/// The material of the first object.
fn first_material(xml: &str) -> candela_render::material::Material {
    let l = load(xml);
    let id = l.scene.geometry.objects()[0].props.material;
    l.scene.materials[id as usize].clone()
}

fn bsdf(inner: &str) -> String {
    scene(&format!(r#"<shape type="sphere">{inner}</shape>"#))
}

#[test]
fn bsdfs_and_presets() {
    let m = first_material(&bsdf(
        r#"<bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.1, 0.2, 0.3"/></bsdf></bsdf>"#,
    ));
    assert!(m.two_sided);
    assert_eq!(
        m.model,
        Model::Diffuse {
            reflectance: Texture::Uniform(Rgb::new(0.1, 0.2, 0.3))
        }
    );
    // Conductors: a perfect mirror by default, or a named material's (η, k).
    let m = first_material(&bsdf(r#"<bsdf type="conductor"/>"#));
    assert!(
        matches!(
            m.model,
            Model::Conductor {
                eta_k: None,
                mf: None,
                ..
            }
        ) && !m.two_sided
    );
    let m = first_material(&bsdf(
        r#"<bsdf type="conductor"><string name="material" value="Au"/><spectrum name="specular_reflectance" value="0.5"/></bsdf>"#,
    ));
    let Model::Conductor {
        eta_k: Some((eta, k)),
        reflectance,
        ..
    } = m.model
    else {
        panic!()
    };
    assert!(
        eta.average()
            .approx_eq(Rgb::new(0.143036, 0.375307, 1.44205), 1e-5)
            && k.average()
                .approx_eq(Rgb::new(3.983, 2.38556, 1.60336), 1e-5)
    );
    // Spectral renders use the measured η(λ), k(λ).
    assert!(matches!(eta, Texture::Spectral { .. }) && matches!(k, Texture::Spectral { .. }));
    assert_eq!(reflectance, Texture::Uniform(Rgb::splat(0.5)));
    let m = first_material(&bsdf(
        r#"<bsdf type="roughconductor"><rgb name="eta" value="0.2, 0.9, 1.1"/><float name="k" value="3"/><string name="distribution" value="ggx"/><float name="alpha" value="0.3"/></bsdf>"#,
    ));
    let Model::Conductor {
        eta_k: Some((eta, k)),
        mf: Some(mf),
        ..
    } = m.model
    else {
        panic!()
    };
    assert_eq!(
        (eta, k),
        (
            Texture::Uniform(Rgb::new(0.2, 0.9, 1.1)),
            Texture::Uniform(Rgb::splat(3.0))
        )
    );
    assert_eq!(
        mf,
        candela_render::material::Microfacet::new(candela_render::material::Distribution::Ggx, 0.3)
    );
    // Anisotropic roughness along u and v (Beckmann by default).
    let m = first_material(&bsdf(
        r#"<bsdf type="roughconductor"><float name="alpha_u" value="0.05"/><float name="alpha_v" value="0.4"/></bsdf>"#,
    ));
    let Model::Conductor { mf: Some(mf), .. } = m.model else {
        panic!()
    };
    assert_eq!(
        mf,
        candela_render::material::Microfacet::anisotropic(
            candela_render::material::Distribution::Beckmann,
            0.05,
            0.4
        )
    );
    // Dielectrics: bk7 in air by default; named or numeric indices.
    let m = first_material(&bsdf(r#"<bsdf type="dielectric"/>"#));
    let Model::Dielectric { eta, mf: None, .. } = m.model else {
        panic!()
    };
    assert!((eta - 1.5046 / 1.000277).abs() < 1e-6);
    let m = first_material(&bsdf(
        r#"<bsdf type="roughdielectric"><string name="int_ior" value="Water"/><float name="ext_ior" value="1"/></bsdf>"#,
    ));
    let Model::Dielectric {
        eta, mf: Some(_), ..
    } = m.model
    else {
        panic!()
    };
    assert!((eta - 1.333).abs() < 1e-6);
    // Plastics: polypropylene in air.
    let m = first_material(&bsdf(
        r#"<bsdf type="plastic"><rgb name="diffuse_reflectance" value="0.2"/><boolean name="nonlinear" value="true"/></bsdf>"#,
    ));
    let Model::Plastic {
        kd,
        eta,
        nonlinear: true,
        ..
    } = m.model
    else {
        panic!()
    };
    assert!(kd == Texture::Uniform(Rgb::splat(0.2)) && (eta - 1.49 / 1.000277).abs() < 1e-6);
    let m = first_material(&bsdf(
        r#"<bsdf type="roughplastic"><float name="alpha" value="0.2"/></bsdf>"#,
    ));
    assert!(matches!(
        m.model,
        Model::RoughPlastic {
            nonlinear: false,
            ..
        }
    ));
    // References reuse one material; forward references work too.
    let l = load(&scene(
        r#"<shape type="sphere"><ref id="m"/></shape><shape type="disk"><ref id="m"/></shape>
           <bsdf type="diffuse" id="m"/>"#,
    ));
    let o = l.scene.geometry.objects();
    assert_eq!(o[0].props.material, o[1].props.material);
    // Errors.
    assert_error_starts_with(
        &bsdf(r#"<bsdf type="conductor"><string name="material" value="Unobtainium"/></bsdf>"#),
        "2:45: unknown conductor material 'Unobtainium' (known: none, a-C, Ag, Al",
    );
    assert_error_starts_with(
        &bsdf(r#"<bsdf type="dielectric"><string name="int_ior" value="glas"/></bsdf>"#),
        "2:46: unknown index of refraction 'glas'",
    );
    assert_error_starts_with(
        &bsdf(
            r#"<bsdf type="roughplastic"><float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.2"/></bsdf>"#,
        ),
        "2:48: roughplastic is isotropic",
    );
    assert_error_starts_with(
        &bsdf(r#"<bsdf type="principled"/>"#),
        "2:22: unsupported BSDF 'principled'",
    );
    let e = error_of(&bsdf(r#"<ref id="nothing"/>"#));
    assert_eq!(e, "2:31: unknown id 'nothing'");
    assert_error_starts_with(
        &scene(r#"<bsdf type="twosided" id="a"><ref id="a"/></bsdf>"#),
        "2:1: circular reference",
    );
    let e = error_of(&scene(
        r#"<bsdf type="diffuse" id="a"/><bsdf type="diffuse" id="a"/>"#,
    ));
    assert_eq!(e, "2:55: the id 'a' is already used (line 2)");
    assert_error_starts_with(
        &bsdf(r#"<bsdf type="diffuse"/><bsdf type="diffuse"/>"#),
        "2:44: <shape type=\"sphere\"> takes a single <bsdf>",
    );
}

#[test]
fn textures() {
    let dir = tmpdir("textures");
    let img =
        Image::from_pixels(2, 1, vec![Rgb::new(1.0, 0.0, 0.0), Rgb::new(0.0, 0.0, 1.0)]).unwrap();
    candela_imageio::write_image(
        &dir.join("t.pfm"),
        &img,
        &candela_imageio::ToneMap::default(),
    )
    .unwrap();
    let l = load_at(
        &dir.join("s.xml"),
        &scene(
            r#"<texture type="bitmap" id="t"><string name="filename" value="t.pfm"/><string name="filter_type" value="nearest"/></texture>
               <shape type="rectangle"><bsdf type="diffuse"><ref name="reflectance" id="t"/></bsdf></shape>
               <shape type="disk"><bsdf type="diffuse"><texture type="checkerboard" name="reflectance">
                   <rgb name="color0" value="1"/><transform name="to_uv"><scale value="3"/></transform></texture></bsdf></shape>
               <shape type="disk"><bsdf type="diffuse"><texture type="checkerboard" name="reflectance">
                   <transform name="to_uv"><scale x="8" y="4"/><translate x="0.25"/></transform></texture></bsdf></shape>
               <shape type="cube"><bsdf type="diffuse"><ref name="reflectance" id="t"/></bsdf></shape>"#,
        ),
    );
    let o = l.scene.geometry.objects();
    let Model::Diffuse {
        reflectance:
            Texture::Image(ImageTexture {
                image,
                filter,
                scale,
                ..
            }),
    } = &l.scene.materials[o[0].props.material as usize].model
    else {
        panic!()
    };
    assert_eq!(
        (image.width(), *filter, *scale),
        (2, Filter::Nearest, [1.0, 1.0])
    );
    let Model::Diffuse { reflectance } = &l.scene.materials[o[1].props.material as usize].model
    else {
        panic!()
    };
    assert_eq!(
        *reflectance,
        Texture::Checkered {
            c1: Rgb::WHITE,
            c2: Rgb::splat(0.2),
            steps: [6.0; 2],
            offset: [0.0; 2],
        }
    );
    // Separate scales of u and v, then a shift: u' = 8u + 0.25, v' = 4v.
    let Model::Diffuse { reflectance } = &l.scene.materials[o[2].props.material as usize].model
    else {
        panic!()
    };
    assert_eq!(
        *reflectance,
        Texture::Checkered {
            c1: Rgb::splat(0.4),
            c2: Rgb::splat(0.2),
            steps: [16.0, 8.0],
            offset: [0.5, 0.0],
        }
    );
    assert_error_starts_with(
        &scene(
            r#"<texture type="checkerboard"><transform name="to_uv"><rotate z="1" angle="30"/></transform></texture>"#,
        ),
        "2:30: to_uv: only scalings and translations",
    );
    // A textured cube becomes Mitsuba's mesh (its per-face uv).
    assert_eq!(l.scene.geometry.meshes()[0].len(), 12);
    // Errors at the file name.
    let e = try_load_with(
        &dir.join("s.xml"),
        &scene(r#"<texture type="bitmap"><string name="filename" value="missing.png"/></texture>"#),
        &[],
    )
    .unwrap_err();
    assert_eq!(e.pos.map(|p| (p.line, p.col)), Some((2, 24)));
    let e = error_of(&scene(r#"<texture type="bitmap"/>"#));
    assert_eq!(e, "2:1: bitmap needs a 'filename'");
    assert_error_starts_with(
        &bsdf(r#"<bsdf type="diffuse"><bsdf type="diffuse" name="reflectance"/></bsdf>"#),
        "2:43: 'reflectance' must be a colour or a <texture>",
    );
}

#[test]
fn emitters() {
    let l = load(&scene(
        r#"<emitter type="point"><point name="position" value="1, 2, 3"/><rgb name="intensity" value="5"/></emitter>
           <emitter type="spot"><transform name="to_world"><lookat origin="0, 4, 0" target="0, 0, 0"/></transform>
               <float name="cutoff_angle" value="30"/></emitter>
           <emitter type="directional"><vector name="direction" x="0" y="-2" z="0"/><spectrum name="irradiance" value="2"/></emitter>
           <emitter type="constant"><rgb name="radiance" value="0.5"/></emitter>
           <shape type="rectangle"><emitter type="area"><rgb name="radiance" value="3"/></emitter></shape>"#,
    ));
    let lights = &l.scene.lights;
    let Light::Point(p, _) = &lights[0] else {
        panic!()
    };
    assert_eq!(
        (p.position, p.intensity),
        (Point3::new(1.0, 2.0, 3.0), Rgb::splat(5.0))
    );
    assert_eq!(p.falloff, candela_render::light::Falloff::INVERSE_SQUARE);
    let Light::Spot(s, _) = &lights[1] else {
        panic!()
    };
    assert!(s.position.approx_eq(Point3::new(0.0, 4.0, 0.0), 1e-6) && close(s.axis, -Vec3::Y));
    // beam_width defaults to 3/4 of the cut-off angle.
    assert!((s.cos_cutoff - 30f32.to_radians().cos()).abs() < 1e-6);
    let SpotProfile::Linear { cos_beam, .. } = s.profile else {
        panic!("{:?}", s.profile)
    };
    assert!((cos_beam - 22.5f32.to_radians().cos()).abs() < 1e-6);
    assert_eq!(s.profile, SpotProfile::linear(cos_beam, s.cos_cutoff));
    let Light::Distant(d, _) = &lights[2] else {
        panic!()
    };
    assert!(close(d.direction, -Vec3::Y));
    // Mitsuba's RGB variants turn an emitted flat spectrum into the colour of illuminant E.
    assert!(
        d.irradiance
            .approx_eq(Rgb::new(2.40958, 1.896582, 1.817832), 1e-5),
        "{:?}",
        d.irradiance
    );
    let Light::Environment(env) = &lights[3] else {
        panic!()
    };
    assert_eq!(
        env.radiance(Vec3::X, &Wavelengths::Rgb).to_rgb(),
        Rgb::splat(0.5)
    );
    // The area emitter: one-sided, on the side of the rectangle's normal (+z).
    assert!(matches!(lights[4], Light::Area(_)));
    let e = &l.scene.emissions[0];
    assert!(!e.two_sided);
    let n = candela_render::math::Normal3::new(0.0, 0.0, 1.0);
    let uv = candela_render::math::Point2::new(0.5, 0.5);
    assert_eq!(
        (
            e.radiance_at(uv, n, Vec3::Z, &Wavelengths::Rgb).to_rgb(),
            e.radiance_at(uv, n, -Vec3::Z, &Wavelengths::Rgb).to_rgb()
        ),
        (Rgb::splat(3.0), Rgb::BLACK)
    );
    // Errors.
    let e = error_of(&scene(r#"<emitter type="area"/>"#));
    assert_eq!(e, "2:1: an area emitter must be nested in a <shape>");
    assert_error_starts_with(
        &scene(r#"<emitter type="sunsky"/>"#),
        "2:1: unsupported emitter 'sunsky'",
    );
    assert_error_starts_with(
        &scene(
            r#"<emitter type="spot"><float name="cutoff_angle" value="10"/><float name="beam_width" value="20"/></emitter>"#,
        ),
        "2:61: 'beam_width' must be between 0 and 10",
    );
    assert_error_starts_with(
        &scene(r#"<shape type="sphere"><emitter type="point"/></shape>"#),
        "2:22: only area emitters can be attached to shapes",
    );
}

#[test]
fn environment_map_follows_mitsubas_lat_long_convention() {
    let dir = tmpdir("envmap");
    // 8×4 texels, each with its own colour.
    let (w, h) = (8, 4);
    let px = (0..w * h)
        .map(|i| Rgb::new((i % w) as f32, (i / w) as f32, 1.0))
        .collect();
    let img = Image::from_pixels(w, h, px).unwrap();
    candela_imageio::write_image(
        &dir.join("env.pfm"),
        &img,
        &candela_imageio::ToneMap::default(),
    )
    .unwrap();
    let l = load_at(
        &dir.join("s.xml"),
        &scene(
            r#"<emitter type="envmap"><string name="filename" value="env.pfm"/><float name="scale" value="2"/>
               <transform name="to_world"><rotate y="1" angle="90"/></transform></emitter>"#,
        ),
    );
    let Light::Environment(env) = &l.scene.lights[0] else {
        panic!()
    };
    // Mitsuba: the local direction d = to_world⁻¹·ω is looked up at u = atan2(d.x, -d.z)/2π,
    // v = acos(d.y)/π. Pick directions at texel centres, where bilinear filtering is exact.
    let rot = candela_render::math::Transform::rotation(Vec3::Y, 90.0).unwrap();
    for (col, row) in [(0usize, 1usize), (2, 1), (5, 2), (7, 2)] {
        // The texel centre is at u = (col + ½)/w, and rows sit at v = row/(h − 1) in Mitsuba.
        let (u, v) = ((col as f32 + 0.5) / w as f32, row as f32 / (h - 1) as f32);
        let (phi, theta) = (u * 2.0 * std::f32::consts::PI, v * std::f32::consts::PI);
        let d = Vec3::new(
            phi.sin() * theta.sin(),
            theta.cos(),
            -phi.cos() * theta.sin(),
        );
        let got = env.radiance(rot.vector(d), &Wavelengths::Rgb).to_rgb();
        assert!(
            got.approx_eq(Rgb::new(col as f32, row as f32, 1.0) * 2.0, 1e-3),
            "texel ({col}, {row}): {got:?}"
        );
    }
}

#[test]
fn malformed_documents() {
    let e = error_of("<scene version=\"3.0.0\">\n  <shape type=\"sphere\">\n</scene>");
    assert_eq!(e, "3:1: malformed XML: expected 'shape' tag, not 'scene'");
    let e = error_of("<bsdf version=\"3.0.0\" type=\"diffuse\"/>");
    assert_eq!(e, "1:1: the root element must be <scene>, not <bsdf>");
    assert_error_starts_with(
        "<scene>\n</scene>",
        "1:1: <scene> needs a 'version' attribute",
    );
    let e = error_of("<scene version=\"three\"/>");
    assert_eq!(e, "1:17: invalid version number 'three'");
    let e = error_of(&scene(
        r#"<shape type="sphere"><float name="radius"/></shape>"#,
    ));
    assert_eq!(e, "2:22: <float> needs the attribute 'value'");
    let e = error_of(&scene(r#"<shape type="sphere"><float value="1"/></shape>"#));
    assert_eq!(e, "2:22: <float> needs the attribute 'name'");
    let e = error_of(&scene(
        r#"<shape type="sphere"><float name="radius" value="1"/><float name="radius" value="2"/></shape>"#,
    ));
    assert_eq!(e, "2:54: the parameter 'radius' is given twice");
    let e = error_of(&scene(r#"<shape type="sphere"><frobnicate/></shape>"#));
    assert_eq!(e, "2:22: unknown element <frobnicate>");
    assert_error_starts_with(
        &scene(r#"<medium type="homogeneous"/>"#),
        "2:1: participating media",
    );
    let e = error_of(&scene(
        r#"<shape type="sphere"><boolean name="flip_normals" value="yes"/></shape>"#,
    ));
    assert_eq!(e, "2:58: 'yes' is not a boolean (true or false)");
    // Deep nesting is an error, not a stack overflow.
    let deep = format!(
        "<scene version=\"3.0.0\">{}{}</scene>",
        "<shape type=\"sphere\">".repeat(500),
        "</shape>".repeat(500)
    );
    assert!(error_of(&deep).contains("nested too deeply"));
    // Mitsuba 0.6 files: camelCase names are upgraded.
    let l = load("<scene version=\"0.6.0\"><shape type=\"sphere\"><bsdf type=\"dielectric\"><float name=\"intIOR\" value=\"2\"/></bsdf></shape></scene>");
    let Model::Dielectric { eta, .. } = &l.scene.materials[0].model else {
        panic!()
    };
    assert!((eta - 2.0 / 1.000277).abs() < 1e-6);
}

// ---------------------------------------------------------------------------------------------
// The Cornell box: camera and geometry against Mitsuba's model, from first principles.
// ---------------------------------------------------------------------------------------------

const CORNELL: &str = include_str!("data/cornell.xml");
const CORNELL_PATH: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/cornell.xml");

/// What a camera ray of Mitsuba's camera hits in the Cornell box, computed in double precision
/// from the numbers of the XML: the walls are the faces of [-1,1]³ (the rectangles' matrices
/// are ±90° rotations), the boxes are [-1,1]³ under their matrices, the light is the rectangle
/// |x| ≤ 0.23, -0.18 ≤ z ≤ 0.2 at y = 0.99. Returns the facing unit normal and whether the
/// hit is the light.
struct Analytic {
    boxes: Vec<[[f64; 4]; 3]>,
}

type V = [f64; 3];

fn sub(a: V, b: V) -> V {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: V, b: V) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Solves the 3×3 system m·x = b (Cramer's rule).
fn solve(m: &[[f64; 4]; 3], b: V) -> V {
    let det = |c: [V; 3]| {
        dot(
            c[0],
            [
                c[1][1] * c[2][2] - c[1][2] * c[2][1],
                c[1][2] * c[2][0] - c[1][0] * c[2][2],
                c[1][0] * c[2][1] - c[1][1] * c[2][0],
            ],
        )
    };
    let cols: [V; 3] = [
        [m[0][0], m[1][0], m[2][0]],
        [m[0][1], m[1][1], m[2][1]],
        [m[0][2], m[1][2], m[2][2]],
    ];
    let d = det(cols);
    let mut x = [0.0; 3];
    for (i, xi) in x.iter_mut().enumerate() {
        let mut c = cols;
        c[i] = b;
        *xi = det(c) / d;
    }
    x
}

impl Analytic {
    fn new() -> Self {
        // The boxes' matrices of cornell.xml (rows; the last row is 0 0 0 1).
        let small = [
            [0.28689146, 0.0, -0.087711513, 0.335000008],
            [0.0, 0.300000012, 0.0, -0.699999988],
            [0.087711513, 0.0, 0.28689146, 0.379999995],
        ];
        let large = [
            [0.284909755, 0.0, 0.0939491391, -0.330000013],
            [0.0, 0.610000014, 0.0, -0.400000006],
            [-0.0939491391, 0.0, 0.284909755, -0.280000001],
        ];
        Self {
            boxes: vec![small, large],
        }
    }

    /// Mitsuba's camera ray through the continuous film position (x, y) of an n×n film: eye at
    /// (0, 0, 3.9) looking along -z, +y up, image x towards +x (the XML's to_world maps the
    /// camera's +x, its left, to -x), 39.3077° along the smaller axis (x for a square film).
    fn ray(x: f64, y: f64, n: f64) -> (V, V) {
        let t = (39.3077f64.to_radians() / 2.0).tan();
        let (sx, sy) = ((2.0 * x / n - 1.0) * t, (1.0 - 2.0 * y / n) * t);
        ([0.0, 0.0, 3.9], [sx, sy, -1.0])
    }

    /// True when the pixel centre (x, y) of an n×n film is not within 0.01 pixel of an edge:
    /// rays 0.01 pixel away on either side hit the same surface.
    fn robust(&self, x: usize, y: usize, n: usize) -> bool {
        let key = |dx: f64, dy: f64| {
            let (o, d) = Self::ray(x as f64 + 0.5 + dx, y as f64 + 0.5 + dy, n as f64);
            self.hit(o, d)
                .map(|h| (h.1.map(|c| (c * 1e3).round() as i64), h.2))
        };
        let k = key(0.0, 0.0);
        [(0.01, 0.0), (-0.01, 0.0), (0.0, 0.01), (0.0, -0.01)]
            .iter()
            .all(|&(dx, dy)| key(dx, dy) == k)
    }

    /// The closest hit: (t, facing normal, is the light).
    fn hit(&self, o: V, d: V) -> Option<(f64, V, bool)> {
        let mut best: Option<(f64, V, bool)> = None;
        let mut consider = |t: f64, n: V, light: bool| {
            if t > 1e-9 && best.is_none_or(|b| t < b.0) {
                let n = if dot(n, d) > 0.0 { n.map(|x| -x) } else { n };
                best = Some((t, n, light));
            }
        };
        // Walls: the faces of [-1,1]³ except the front (z = 1).
        for axis in 0..3 {
            for side in [-1.0, 1.0] {
                if axis == 2 && side > 0.0 || d[axis] == 0.0 {
                    continue;
                }
                let t = (side - o[axis]) / d[axis];
                let p = [0, 1, 2].map(|k| o[k] + t * d[k]);
                if (0..3).all(|k| k == axis || p[k].abs() <= 1.0) {
                    let mut n = [0.0; 3];
                    n[axis] = 1.0;
                    consider(t, n, false);
                }
            }
        }
        // The light, just below the ceiling.
        let t = (0.99 - o[1]) / d[1];
        let p = [0, 1, 2].map(|k| o[k] + t * d[k]);
        if p[0].abs() <= 0.23 && (-0.18..=0.2).contains(&p[2]) {
            consider(t, [0.0, 1.0, 0.0], true);
        }
        // The boxes: slabs in their frames; the normal is the inverse transpose of the face's.
        for m in &self.boxes {
            let lo = solve(m, sub(o, [m[0][3], m[1][3], m[2][3]]));
            let ld = solve(m, d);
            let (mut near, mut far, mut face) = (f64::NEG_INFINITY, f64::INFINITY, 0);
            for a in 0..3 {
                let (t0, t1) = ((-1.0 - lo[a]) / ld[a], (1.0 - lo[a]) / ld[a]);
                if t0.min(t1) > near {
                    near = t0.min(t1);
                    face = a;
                }
                far = far.min(t0.max(t1));
            }
            if near <= far && near > 0.0 {
                // (M⁻ᵀ)·e_face = the face-th row of M⁻¹, i.e. the solution of Mᵀ·n = e_face.
                let mt = [
                    [m[0][0], m[1][0], m[2][0], 0.0],
                    [m[0][1], m[1][1], m[2][1], 0.0],
                    [m[0][2], m[1][2], m[2][2], 0.0],
                ];
                let mut e = [0.0; 3];
                e[face] = 1.0;
                let n = solve(&mt, e);
                let len = dot(n, n).sqrt();
                consider(near, n.map(|x| x / len), false);
            }
        }
        best
    }
}

fn render_cornell(integrator: &dyn Integrator, n: usize) -> Image {
    let l = try_load_with(Path::new(CORNELL_PATH), CORNELL, &[("res", &n.to_string())]).unwrap();
    assert_eq!(
        (l.hints.width, l.hints.height),
        (Some(n as u32), Some(n as u32))
    );
    let settings = RenderSettings {
        width: n,
        height: n,
        spp: 1,
        ..Default::default()
    };
    render(&l.scene, integrator, &settings, &|_| {}).image
}

#[test]
fn cornell_box_camera_and_geometry_match_mitsuba() {
    let l = try_load_with(Path::new(CORNELL_PATH), CORNELL, &[]).unwrap();
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    assert_eq!(
        (
            l.hints.width,
            l.hints.spp,
            l.hints.max_depth,
            l.hints.rr_depth
        ),
        (Some(512), Some(64), Some(8), Some(5))
    );
    // With one sample per pixel the renderer traces the pixel centres: classify every centre
    // with the analytic model and compare with candela's normals and flat renders.
    let n = 96;
    let normals = render_cornell(&Normals, n);
    let flat = render_cornell(&Flat, n);
    let onoff = render_cornell(&OnOff, n);
    let a = Analytic::new();
    let (mut mismatches, mut lights, mut misses) = (Vec::new(), 0, 0);
    for y in 0..n {
        for x in 0..n {
            let (o, d) = Analytic::ray(x as f64 + 0.5, y as f64 + 0.5, n as f64);
            let got = normals.get(x, y);
            if !a.robust(x, y, n) {
                continue;
            }
            let expected = match a.hit(o, d) {
                None => {
                    misses += 1;
                    (Rgb::BLACK, false)
                }
                Some((_, nn, light)) => {
                    lights += light as usize;
                    (
                        Rgb::new(
                            ((nn[0] + 1.0) / 2.0) as f32,
                            ((nn[1] + 1.0) / 2.0) as f32,
                            ((nn[2] + 1.0) / 2.0) as f32,
                        ),
                        light,
                    )
                }
            };
            let on = onoff.get(x, y) == Rgb::WHITE;
            // The light is the only surface brighter than its reflectance in the flat render.
            let lit = flat.get(x, y).max_component() > 10.0;
            if !got.approx_eq(expected.0, 2e-3)
                || on != (expected.0 != Rgb::BLACK)
                || lit != expected.1
            {
                mismatches.push((x, y, got, expected));
            }
        }
    }
    // The opening of the box: the walls' front edges at z = 1 leave a thin black frame.
    assert!(misses > 4 * n && misses < 10 * n, "{misses}");
    assert!(lights > 20, "{lights}");
    // Exactly on an edge, float rounding may pick either side: allow a handful of pixels.
    assert!(
        mismatches.len() <= 3,
        "{} mismatches, e.g. {:?}",
        mismatches.len(),
        &mismatches[..mismatches.len().min(5)]
    );
}

#[test]
fn cornell_box_sides_and_emitter_orientation() {
    let l = try_load_with(Path::new(CORNELL_PATH), CORNELL, &[]).unwrap();
    let s = &l.scene;
    let mut st = RayStats::default();
    let eye = Point3::new(0.0, 0.0, 3.9);
    // Every wall is seen from its front side (Mitsuba's one-sided BSDFs would be black
    // otherwise): floor, ceiling, back, red, green.
    for target in [
        [0.0, -1.0, 0.8],
        [0.0, 1.0, 0.5],
        [0.0, 0.5, -1.0],
        [-1.0, 0.5, 0.5],
        [1.0, 0.5, 0.5],
    ] {
        let p = Point3::new(target[0], target[1], target[2]);
        let si = s.interact(&Ray::new(eye, p - eye), &mut st).unwrap();
        assert!(
            si.p.approx_eq(p, 1e-4) && si.front_face(),
            "{target:?}: {:?}",
            si.p
        );
        assert!(!s.material(&si).two_sided);
    }
    // The light emits downwards only.
    let up = s
        .interact(&Ray::new(Point3::new(0.0, 0.0, 0.0), Vec3::Y), &mut st)
        .unwrap();
    assert!((up.p.y - 0.99).abs() < 1e-5 && up.n.to_vec().approx_eq(-Vec3::Y, 1e-5));
    assert_eq!(
        s.emitted(&up, &Wavelengths::Rgb).to_rgb(),
        Rgb::new(18.387, 13.9873, 6.75357)
    );
    let down = s
        .interact(&Ray::new(Point3::new(0.0, 0.995, 0.0), -Vec3::Y), &mut st)
        .unwrap();
    assert!((down.p.y - 0.99).abs() < 1e-5);
    assert_eq!(s.emitted(&down, &Wavelengths::Rgb).to_rgb(), Rgb::BLACK);
    // Mitsuba's max_depth = 1: only emitters seen directly.
    let n = 48;
    let img = render_cornell(
        &PathTracer {
            max_depth: Some(1),
            rr_depth: 5,
            hide_emitters: false,
        },
        n,
    );
    let a = Analytic::new();
    for y in 0..n {
        for x in 0..n {
            let (o, d) = Analytic::ray(x as f64 + 0.5, y as f64 + 0.5, n as f64);
            let light = a.hit(o, d).is_some_and(|h| h.2);
            assert_eq!(img.get(x, y) != Rgb::BLACK, light, "pixel ({x}, {y})");
        }
    }
}
