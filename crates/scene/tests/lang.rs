//! Data-driven tests of the candela scene language: source text → description fragment, or
//! source text → error at `line:col`.

use candela_render::math::{Matrix4, Point3, Transform, Vec3};
use candela_render::Rgb;
use candela_scene::lang::*;
use candela_scene::Pos;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

mod support;

use support::lang::{error_of, parse, parse_with};

fn approx(a: Transform, b: Transform) -> bool {
    a.m.approx_eq(&b.m, 1e-5) && a.inv.approx_eq(&b.inv, 1e-4)
}

fn rgb(r: f32, g: f32, b: f32) -> Rgb {
    Rgb::new(r, g, b)
}

fn uniform(p: &Pigment) -> Rgb {
    match p.kind {
        PigmentKind::Uniform(c) => c,
        ref k => panic!("not uniform: {k:?}"),
    }
}

/// The transformation of the only world shape.
fn shape_transform(d: &SceneDescription) -> Transform {
    assert_eq!(d.shapes.len(), 1);
    d.shapes[0].transform()
}

/// Materials used by the other snippets.
const MATS: &str = "material m(diffuse(uniform(<0.5, 0.5, 0.5>)), uniform(<0, 0, 0>))\n";

/// The scene of the course's examples (demo.txt), plus an image pigment.
const DEMO: &str = r#"
float clock(150)

material sky_material(
    diffuse(uniform(<0, 0, 0>)),
    uniform(<0.7, 0.5, 1>)
)

# Here is a comment

material ground_material(
    diffuse(checkered(<0.3, 0.5, 0.1>,
                      <0.1, 0.2, 0.5>, 4)),
    uniform(<0, 0, 0>)
)

material sphere_material(
    specular(uniform(<0.5, 0.5, 0.5>)),
    uniform(<0, 0, 0>)
)

material image_material(
    diffuse(image("my file.pfm")),
    <5.0, 500.0, 300.0>
) # Comment at the end of the line

plane (sky_material, translation([0, 0, 100]) * rotation_y(clock))
plane (ground_material, identity)

sphere(sphere_material, translation([0, 0, 1]))

camera(perspective, rotation_z(30) * translation([-4, 0, 1]), 1.0, 2.0)
"#;

#[test]
fn course_demo_scene() {
    let d = parse(DEMO);
    assert_eq!(d.floats, HashMap::from([("clock".to_owned(), 150.0)]));
    let names: Vec<_> = d.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "sky_material",
            "ground_material",
            "sphere_material",
            "image_material"
        ]
    );
    assert_eq!(d.material_index["sphere_material"], 2);

    let sky = &d.materials[0];
    assert_eq!(sky.pos, Pos::new(4, 10));
    assert!(matches!(&sky.brdf.kind, BrdfKind::Diffuse { kd } if uniform(kd) == Rgb::BLACK));
    assert_eq!(sky.brdf.pos, Pos::new(5, 5));
    assert_eq!(uniform(&sky.emission), rgb(0.7, 0.5, 1.0));

    let BrdfKind::Diffuse { kd } = &d.materials[1].brdf.kind else {
        panic!()
    };
    assert_eq!(
        kd.kind,
        PigmentKind::Checkered {
            color1: rgb(0.3, 0.5, 0.1),
            color2: rgb(0.1, 0.2, 0.5),
            steps: 4
        }
    );
    assert_eq!(kd.pos, Pos::new(12, 13));
    assert!(matches!(&d.materials[2].brdf.kind,
        BrdfKind::Specular { ks } if uniform(ks) == rgb(0.5, 0.5, 0.5)));
    let BrdfKind::Diffuse { kd } = &d.materials[3].brdf.kind else {
        panic!()
    };
    let PigmentKind::Image(file) = &kd.kind else {
        panic!()
    };
    assert_eq!(file.name, "my file.pfm");
    assert_eq!(file.path, PathBuf::from("scenes/my file.pfm"));
    assert_eq!(file.pos, Pos::new(23, 19));
    assert_eq!(uniform(&d.materials[3].emission), rgb(5.0, 500.0, 300.0));

    assert_eq!(d.shapes.len(), 3);
    let ShapeKind::Plane {
        material,
        transform,
    } = &d.shapes[0].kind
    else {
        panic!()
    };
    assert_eq!(
        (material.name.as_str(), material.index, material.pos),
        ("sky_material", 0, Pos::new(27, 8))
    );
    let expected =
        Transform::translation(Vec3::new(0.0, 0.0, 100.0)) * Transform::rotation_y(150.0);
    assert!(approx(*transform, expected));
    assert_eq!(d.shapes[0].pos, Pos::new(27, 1));
    assert!(
        matches!(&d.shapes[1].kind, ShapeKind::Plane { material, transform }
        if material.index == 1 && transform.is_identity())
    );
    assert!(
        matches!(&d.shapes[2].kind, ShapeKind::Sphere { material, transform }
        if material.index == 2 && *transform == Transform::translation(Vec3::Z))
    );

    let camera = d.camera.as_ref().unwrap();
    assert_eq!(camera.projection, Projection::Perspective);
    let expected = Transform::rotation_z(30.0) * Transform::translation(Vec3::new(-4.0, 0.0, 1.0));
    assert!(approx(camera.transform, expected));
    assert_eq!((camera.aspect_ratio, camera.distance), (1.0, 2.0));
    assert_eq!(camera.pos, Pos::new(32, 1));
    assert!(d.lights.is_empty() && d.ambient_lights.is_empty() && d.environments.is_empty());
}

/// A check of a parsed description.
type Check = fn(&SceneDescription);

/// Every construct of the course language and of the extensions: source → fragment.
const ACCEPTED: &[(&str, Check)] = &[
    // ----- §1 -----
    ("float a(1.5) float b(a) float c(-a)", |d| {
        assert_eq!((d.floats["a"], d.floats["b"], d.floats["c"]), (1.5, 1.5, -1.5))
    }),
    ("float e(1e-5) float f(2.5E+3) float g(.5) float h(+2)", |d| {
        assert_eq!(
            (d.floats["e"], d.floats["f"], d.floats["g"], d.floats["h"]),
            (1e-5, 2500.0, 0.5, 2.0)
        )
    }),
    ("sphere(m, identity)", |d| {
        assert!(matches!(d.shapes[0].kind, ShapeKind::Sphere { .. }));
        assert!(shape_transform(d).is_identity());
    }),
    ("plane(m, scaling([1, 2, 4]))", |d| {
        assert!(matches!(d.shapes[0].kind, ShapeKind::Plane { .. }));
        assert_eq!(shape_transform(d), Transform::scaling(Vec3::new(1.0, 2.0, 4.0)));
    }),
    ("sphere(m, rotation_x(10) * rotation_y(20) * rotation_z(30))", |d| {
        let t = Transform::rotation_x(10.0) * Transform::rotation_y(20.0) * Transform::rotation_z(30.0);
        assert!(approx(shape_transform(d), t));
    }),
    ("float angle(90) sphere(m, rotation_z(-angle) * translation([1, 0, 0]))", |d| {
        let p = shape_transform(d).point(Point3::ORIGIN);
        assert!(p.approx_eq(Point3::new(0.0, -1.0, 0.0), 1e-6), "{p:?}");
    }),
    ("camera(orthogonal, identity, 1.333, 0)", |d| {
        let c = d.camera.as_ref().unwrap();
        assert_eq!((c.projection, c.aspect_ratio, c.distance), (Projection::Orthogonal, 1.333, 0.0));
    }),
    ("point_light([1, 2, 3], <4, 5, 6>, 0.1)", |d| {
        assert_eq!(
            d.lights[0].kind,
            LightKind::Point {
                position: Point3::new(1.0, 2.0, 3.0),
                intensity: rgb(4.0, 5.0, 6.0),
                radius: 0.1,
                attenuation: None
            }
        );
        assert_eq!(d.lights[0].components, None);
        assert_eq!(d.lights[0].pos, Pos::new(2, 1));
    }),
    ("material e(diffuse(<1, 1, 1>), checkered(<1, 0, 0>, <0, 1, 0>, 2.9))", |d| {
        assert!(matches!(d.materials[1].emission.kind, PigmentKind::Checkered { steps: 2, .. }));
    }),
    // ----- §2: materials -----
    ("material e(specular(<1, 1, 1>))", |d| {
        assert_eq!(uniform(&d.materials[1].emission), Rgb::BLACK);
    }),
    ("material p(phong(<0.5, 0, 0>, uniform(<0.2, 0.2, 0.2>), 20))", |d| {
        let BrdfKind::Phong { kd, ks, exponent } = &d.materials[1].brdf.kind else { panic!() };
        assert_eq!((uniform(kd), uniform(ks), *exponent), (rgb(0.5, 0.0, 0.0), rgb(0.2, 0.2, 0.2), 20.0));
    }),
    ("material p(blinn_phong(<0.5, 0, 0>, <1, 1, 1>, 0))", |d| {
        assert!(matches!(d.materials[1].brdf.kind, BrdfKind::BlinnPhong { exponent: 0.0, .. }));
    }),
    ("material p(cook_torrance(<0.5, 0, 0>, <1, 1, 1>, 0.3))", |d| {
        assert!(matches!(d.materials[1].brdf.kind, BrdfKind::CookTorrance {
            roughness: 0.3, ior: 1.5, distribution: Distribution::Ggx, .. }));
    }),
    ("material p(cook_torrance(<0.5, 0, 0>, <1, 1, 1>, 0.3, 2.4))", |d| {
        assert!(matches!(d.materials[1].brdf.kind, BrdfKind::CookTorrance {
            ior: 2.4, distribution: Distribution::Ggx, .. }));
    }),
    ("material p(cook_torrance(<0.5, 0, 0>, <1, 1, 1>, 0.3, 2.4, \"beckmann\"))", |d| {
        assert!(matches!(d.materials[1].brdf.kind, BrdfKind::CookTorrance {
            distribution: Distribution::Beckmann, .. }));
    }),
    ("material p(cook_torrance(<0.5, 0, 0>, <1, 1, 1>, 0.3, 1.5, \"ggx\"))", |d| {
        assert!(matches!(d.materials[1].brdf.kind, BrdfKind::CookTorrance {
            distribution: Distribution::Ggx, .. }));
    }),
    ("material g(glass(1.5))", |d| {
        let BrdfKind::Glass { ior, kt, dispersion: None } = &d.materials[1].brdf.kind else { panic!() };
        assert_eq!((*ior, uniform(kt)), (1.5, Rgb::WHITE));
    }),
    ("material g(glass(1.33, <0.9, 0.9, 1>), <0, 0, 0>)", |d| {
        let BrdfKind::Glass { ior, kt, dispersion: None } = &d.materials[1].brdf.kind else { panic!() };
        assert_eq!((*ior, uniform(kt)), (1.33, rgb(0.9, 0.9, 1.0)));
    }),
    ("material sphere(diffuse(<1, 1, 1>)) material glass(specular(<1, 1, 1>)) box(glass, identity)", |d| {
        // Keywords are contextual: course files may name a material anything.
        assert_eq!(d.material_index["glass"], 2);
        assert!(matches!(&d.shapes[0].kind, ShapeKind::Box { material, .. } if material.name == "glass"));
    }),
    // ----- §2: shapes -----
    ("box(m, translation([1, 2, 3]))", |d| {
        assert!(matches!(d.shapes[0].kind, ShapeKind::Box { .. }));
        assert_eq!(shape_transform(d), Transform::translation(Vec3::new(1.0, 2.0, 3.0)));
    }),
    ("triangle(m, [0, 0, 0], [1, 0, 0], [0, 1, 0])", |d| {
        let ShapeKind::Triangle { vertices, .. } = &d.shapes[0].kind else { panic!() };
        assert_eq!(vertices[1], Point3::new(1.0, 0.0, 0.0));
        assert!(shape_transform(d).is_identity());
    }),
    ("parallelogram(m, [1, 1, 1], [2, 0, 0], [0, 3, 0])", |d| {
        assert_eq!(d.shapes[0].kind, ShapeKind::Parallelogram {
            material: d.shapes[0].material().unwrap().clone(),
            origin: Point3::new(1.0, 1.0, 1.0),
            edge1: Vec3::new(2.0, 0.0, 0.0),
            edge2: Vec3::new(0.0, 3.0, 0.0),
        });
    }),
    ("polyhedron(m, identity, [1, 0, 0], 1)", |d| {
        let ShapeKind::Polyhedron { half_spaces, .. } = &d.shapes[0].kind else { panic!() };
        assert_eq!(half_spaces.len(), 1);
    }),
    ("polyhedron(m, identity, [1, 1, 1], 1, [-1, 0, 0], 0, [0, -1, 0], 0,\n [0, 0, -1], 0)", |d| {
        let ShapeKind::Polyhedron { half_spaces, .. } = &d.shapes[0].kind else { panic!() };
        assert_eq!(half_spaces.len(), 4);
        assert_eq!(half_spaces[3], HalfSpace { normal: -Vec3::Z, d: 0.0, pos: Pos::new(3, 2) });
    }),
    ("mesh(m, scaling([2, 2, 2]), \"models/bunny.obj\")", |d| {
        let ShapeKind::Mesh { file, .. } = &d.shapes[0].kind else { panic!() };
        assert_eq!(file.path, PathBuf::from("scenes/models/bunny.obj"));
        assert_eq!(file.pos, Pos::new(2, 29));
    }),
    ("mesh(m, identity, \"/abs/bunny.ply\")", |d| {
        let ShapeKind::Mesh { file, .. } = &d.shapes[0].kind else { panic!() };
        assert_eq!(file.path, PathBuf::from("/abs/bunny.ply"));
    }),
    ("union(sphere(m, identity), box(m, identity))", |d| {
        let ShapeKind::Csg { op, operands, transform } = &d.shapes[0].kind else { panic!() };
        assert_eq!(*op, CsgOp::Union);
        assert!(transform.is_identity());
        assert!(matches!(operands[0].kind, ShapeKind::Sphere { .. }));
        assert!(matches!(operands[1].kind, ShapeKind::Box { .. }));
        assert_eq!(operands[1].pos, Pos::new(2, 28));
    }),
    ("difference(sphere(m, identity), intersection(box(m, identity),\
      fusion(sphere(m, identity), sphere(m, identity)), translation([0, 0, 1])), scaling([2, 2, 2]))", |d| {
        let ShapeKind::Csg { op: CsgOp::Difference, operands, transform } = &d.shapes[0].kind else { panic!() };
        assert_eq!(*transform, Transform::scaling(Vec3::new(2.0, 2.0, 2.0)));
        let ShapeKind::Csg { op: CsgOp::Intersection, operands, transform } = &operands[1].kind else { panic!() };
        assert_eq!(*transform, Transform::translation(Vec3::Z));
        assert!(matches!(operands[1].kind, ShapeKind::Csg { op: CsgOp::Fusion, .. }));
    }),
    ("shape ball(sphere(m, identity))", |d| {
        assert!(d.shapes.is_empty());
        assert_eq!(d.shape_index["ball"], 0);
        assert_eq!((d.named_shapes[0].name.as_str(), d.named_shapes[0].pos), ("ball", Pos::new(2, 7)));
    }),
    ("shape ball(sphere(m, identity)) ball instance(ball) instance(ball, translation([1, 0, 0]))", |d| {
        assert_eq!(d.shapes.len(), 3);
        for (shape, t) in d.shapes.iter().zip([Transform::IDENTITY, Transform::IDENTITY, Transform::translation(Vec3::X)]) {
            assert!(matches!(&shape.kind, ShapeKind::Instance { name, index: 0, transform } if name == "ball" && *transform == t));
        }
        assert_eq!(d.shapes[0].pos, Pos::new(2, 33));
    }),
    ("shape a(sphere(m, identity)) shape b(union(a, instance(a, translation([1, 0, 0])))) b", |d| {
        assert!(matches!(&d.shapes[0].kind, ShapeKind::Instance { index: 1, .. }));
        let ShapeKind::Csg { operands, .. } = &d.named_shape(1).shape.kind else { panic!() };
        assert!(matches!(&operands[0].kind, ShapeKind::Instance { index: 0, .. }));
    }),
    // ----- §2: transformations -----
    ("sphere(m, rotation([0, 0, 2], 90))", |d| {
        assert!(approx(shape_transform(d), Transform::rotation_z(90.0)));
    }),
    ("sphere(m, look_at([-1, 0, 0], [0, 0, 0], [0, 0, 1]))", |d| {
        assert!(approx(shape_transform(d), Transform::translation(-Vec3::X)));
    }),
    ("sphere(m, matrix(1, 0, 0, 1,  0, 2, 0, 2,  0, 0, 4, 3,  0, 0, 0, 1))", |d| {
        let t = Transform::translation(Vec3::new(1.0, 2.0, 3.0)) * Transform::scaling(Vec3::new(1.0, 2.0, 4.0));
        assert!(approx(shape_transform(d), t));
        assert_eq!(shape_transform(d).m.m[1], [0.0, 2.0, 0.0, 2.0]);
    }),
    ("sphere(m, translation([1, 0, 0]) * scaling([2, 2, 2]) * identity)", |d| {
        // A * B applies B first.
        assert_eq!(shape_transform(d).point(Point3::new(1.0, 0.0, 0.0)), Point3::new(3.0, 0.0, 0.0));
    }),
    // ----- §2: lights -----
    ("point_light([0, 0, 5], <1, 1, 1>, 0, attenuation(1, 0.1, 0.01))", |d| {
        assert!(matches!(d.lights[0].kind, LightKind::Point { attenuation: Some(Attenuation {
            constant: 1.0, linear: 0.1, quadratic: 0.01 }), .. }));
    }),
    ("point_light([0, 0, 5], <1, 1, 1>, 0, components(<0.1, 0.1, 0.1>, <1, 1, 1>, <0.5, 0.5, 0.5>))", |d| {
        let c = d.lights[0].components.unwrap();
        assert_eq!((c.ambient, c.specular), (rgb(0.1, 0.1, 0.1), rgb(0.5, 0.5, 0.5)));
        assert_eq!(d.lights[0].local_components(), c);
    }),
    ("point_light([0, 0, 5], <2, 2, 2>, 0, attenuation(1, 0, 0), components(<0, 0, 0>, <1, 1, 1>, <1, 1, 1>))", |d| {
        assert!(d.lights[0].components.is_some());
        assert!(matches!(d.lights[0].kind, LightKind::Point { attenuation: Some(_), .. }));
    }),
    ("spot_light([0, 0, 5], [0, 0, -1], <10, 10, 10>, 30, 2)", |d| {
        assert_eq!(d.lights[0].kind, LightKind::Spot {
            position: Point3::new(0.0, 0.0, 5.0),
            direction: -Vec3::Z,
            intensity: rgb(10.0, 10.0, 10.0),
            cutoff_deg: 30.0,
            exponent: 2.0,
            attenuation: None,
        });
        let c = d.lights[0].local_components();
        assert_eq!((c.ambient, c.diffuse, c.specular), (Rgb::BLACK, rgb(10.0, 10.0, 10.0), rgb(10.0, 10.0, 10.0)));
    }),
    ("spot_light([0, 0, 5], [0, 0, -1], <1, 1, 1>, 30, 2, attenuation(0, 0, 1), components(<0, 0, 0>, <1, 1, 1>, <1, 1, 1>))", |d| {
        assert!(d.lights[0].components.is_some());
    }),
    ("distant_light([0, -1, -1], <1, 0.9, 0.8>)", |d| {
        assert_eq!(d.lights[0].kind, LightKind::Distant { direction: Vec3::new(0.0, -1.0, -1.0), intensity: rgb(1.0, 0.9, 0.8) });
    }),
    ("distant_light([0, 0, -1], <1, 1, 1>, components(<0.1, 0.1, 0.1>, <1, 1, 1>, <1, 1, 1>))", |d| {
        assert!(d.lights[0].components.is_some());
    }),
    ("hemisphere_light(<0.5, 0.5, 1>)", |d| {
        assert_eq!(d.lights[0].kind, LightKind::Hemisphere { intensity: rgb(0.5, 0.5, 1.0), up: Vec3::Z });
    }),
    ("hemisphere_light(<1, 1, 1>, [0, 1, 0])", |d| {
        assert!(matches!(d.lights[0].kind, LightKind::Hemisphere { up: Vec3::Y, .. }));
    }),
    ("hemisphere_light(<1, 1, 1>, components(<0, 0, 0>, <1, 1, 1>, <1, 1, 1>))", |d| {
        assert!(matches!(d.lights[0].kind, LightKind::Hemisphere { up: Vec3::Z, .. }));
        assert!(d.lights[0].components.is_some());
    }),
    ("hemisphere_light(<1, 1, 1>, [0, 1, 0], components(<0, 0, 0>, <1, 1, 1>, <1, 1, 1>))", |d| {
        assert!(matches!(d.lights[0].kind, LightKind::Hemisphere { up: Vec3::Y, .. }));
        assert!(d.lights[0].components.is_some());
    }),
    ("ambient_light(<0.1, 0.1, 0.1>) ambient_light(<0.2, 0, 0>)", |d| {
        assert_eq!(d.ambient_lights.len(), 2);
        assert_eq!((d.ambient_lights[1].intensity, d.ambient_lights[1].pos), (rgb(0.2, 0.0, 0.0), Pos::new(2, 32)));
    }),
    ("environment(image(\"sky.pfm\"), rotation_z(90))", |d| {
        let e = &d.environments[0];
        assert!(matches!(&e.pigment.kind, PigmentKind::Image(f) if f.path == Path::new("scenes/sky.pfm")));
        assert!(approx(e.transform, Transform::rotation_z(90.0)));
    }),
    ("environment(<0.1, 0.2, 0.3>)", |d| {
        assert_eq!(uniform(&d.environments[0].pigment), rgb(0.1, 0.2, 0.3));
        assert!(d.environments[0].transform.is_identity());
    }),
    // ----- lexing details -----
    ("# only a comment", |d| assert!(d.shapes.is_empty())),
    ("sphere # comment\n(m, # another\n identity)", |d| assert_eq!(d.shapes.len(), 1)),
    ("\tsphere(m,\r\n\tidentity)", |d| assert_eq!(d.shapes[0].pos, Pos::new(2, 2))),
];

#[test]
fn every_construct_parses() {
    for &(text, check) in ACCEPTED {
        let text = format!("{MATS}{text}");
        check(&parse(&text));
    }
}

/// Every error: source → `line:col: message` (line 1 holds the material `m`).
const REJECTED: &[(&str, &str)] = &[
    // names
    ("sphere(n, identity)", "2:8: unknown material 'n'"),
    ("float a(b)", "2:9: unknown variable 'b'"),
    ("sphere(m, rotation_z(-angle))", "2:23: unknown variable 'angle'"),
    ("float a(1)\nfloat a(2)", "3:7: variable 'a' cannot be redefined (first defined at 2:7)"),
    ("material m(diffuse(<1, 1, 1>))", "2:10: material 'm' is already defined (at 1:10)"),
    ("instance(ball)", "2:10: unknown shape 'ball'"),
    ("union(ball, sphere(m, identity))", "2:7: unknown shape 'ball'"),
    ("shape s(sphere(m, identity)) shape s(box(m, identity))", "2:36: shape 's' is already defined (at 2:7)"),
    ("shape box(sphere(m, identity))", "2:7: 'box' is a keyword and cannot name a shape"),
    ("xyz(1)", "2:1: unknown statement 'xyz'"),
    ("new material a(diffuse(<1, 1, 1>))", "2:1: unknown statement 'new'"),
    ("(sphere)", "2:1: expected a statement but found '('"),
    ("42", "2:1: expected a statement but found '42'"),
    // camera
    ("camera(perspective, identity, 1, 1)\n camera(orthogonal, identity, 1, 1)",
        "3:2: a second camera (the camera is already defined at 2:1)"),
    ("camera(fisheye, identity, 1, 1)", "2:8: expected 'perspective' or 'orthogonal' but found 'fisheye'"),
    ("camera(perspective, identity, 0, 1)", "2:31: the aspect ratio must be positive (found 0)"),
    ("camera(perspective, identity, 1, -2)", "2:34: the distance of a perspective camera must be positive (found -2)"),
    // argument counts
    ("sphere(m)", "2:9: expected ',' but found ')': too few arguments, the syntax is sphere(material, transformation)"),
    ("sphere(m, identity, identity)", "2:19: expected ')' but found ',': too many arguments, the syntax is sphere(material, transformation)"),
    ("sphere(m, identity,)", "2:19: expected ')' but found ',': too many arguments, the syntax is sphere(material, transformation)"),
    ("sphere(m identity)", "2:10: expected ',' but found 'identity'"),
    ("sphere m", "2:8: expected '(' but found 'm'"),
    ("sphere(m, identity", "2:19: expected ')' but found end of file"),
    ("material a(diffuse(<1, 1, 1>)", "2:30: expected ',' or ')' but found end of file"),
    ("translation([1, 2, 3])", "2:1: unknown statement 'translation'"),
    ("sphere(m, translation([1, 2]))", "2:28: expected ',' but found ']'"),
    ("sphere(m, translation([1, 2, 3, 4]))", "2:31: expected ']' but found ','"),
    ("sphere(m, matrix(1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 1))",
        "2:61: expected ',' but found ')': too few arguments, the syntax is matrix(m00, m01, …, m33) with 16 numbers"),
    ("float x(1, 2)", "2:10: expected ')' but found ',': too many arguments, the syntax is float NAME(number)"),
    ("triangle(m, [0, 0, 0], [1, 0, 0])", "2:33: expected ',' but found ')': too few arguments, the syntax is triangle(material, [a], [b], [c])"),
    ("polyhedron(m, identity)", "2:23: expected ',' but found ')': too few arguments, the syntax is polyhedron(material, transformation, [n1], d1, [n2], d2, …)"),
    ("polyhedron(m, identity, [1, 0, 0])", "2:34: expected ',' but found ')': too few arguments, the syntax is polyhedron(material, transformation, [n1], d1, [n2], d2, …)"),
    ("union(sphere(m, identity))", "2:26: expected ',' but found ')': too few arguments, the syntax is union(shape, shape [, transformation])"),
    ("ambient_light()", "2:15: expected a colour '<r, g, b>' but found ')'"),
    // types
    ("sphere(m, [1, 2, 3])", "2:11: expected a transformation but found '['"),
    ("sphere(<1, 1, 1>, identity)", "2:8: expected a material name but found '<'"),
    ("sphere(m, translation(<1, 2, 3>))", "2:23: expected a vector '[x, y, z]' but found '<'"),
    ("sphere(m, rotation_z([1, 2, 3]))", "2:22: expected a number but found '['"),
    ("sphere(m, rotation_z(\"x\"))", "2:22: expected a number but found string \"x\""),
    ("sphere(m, identity * )", "2:22: expected a transformation but found ')'"),
    ("sphere(m, scale([1, 1, 1]))", "2:11: expected a transformation but found 'scale'"),
    ("material a(uniform(<1, 1, 1>))", "2:12: expected a BRDF but found 'uniform'"),
    ("material a(diffuse(diffuse(<1, 1, 1>)))", "2:20: expected a pigment but found 'diffuse'"),
    ("material a(diffuse([1, 1, 1]))", "2:20: expected a pigment but found '['"),
    ("material a(diffuse(image(sky)))", "2:26: expected a file name string but found 'sky'"),
    ("material a(diffuse(image(\"\")))", "2:26: empty file name"),
    ("point_light(<1, 1, 1>, [1, 1, 1], 1)", "2:13: expected a vector '[x, y, z]' but found '<'"),
    ("point_light([1, 1, 1], <1, 1, 1>, 1, 2)", "2:38: expected 'attenuation(…)' or 'components(…)' but found '2'"),
    ("distant_light([1, 1, 1], <1, 1, 1>, attenuation(1, 0, 0))", "2:37: expected 'components(…)' but found 'attenuation'"),
    ("point_light([1, 1, 1], <1, 1, 1>, 1, attenuation(1, 0, 0), attenuation(1, 0, 0))", "2:60: 'attenuation' is given twice"),
    ("union(m, sphere(m, identity))", "2:7: unknown shape 'm'"),
    ("union(<1, 1, 1>, sphere(m, identity))", "2:7: expected a shape but found '<'"),
    ("shape 3(sphere(m, identity))", "2:7: expected a shape name but found '3'"),
    ("float 3(1)", "2:7: expected a variable name but found '3'"),
    // values
    ("sphere(m, scaling([1, 0, 1]))", "2:11: invalid scaling: a scaling factor is zero"),
    ("sphere(m, matrix(1, 0, 0, 0,  0, 1, 0, 0,  0, 0, 0, 0,  0, 0, 0, 1))", "2:11: invalid matrix: the matrix is singular"),
    ("sphere(m, matrix(1, 0, 0, 0,  0, 1, 0, 0,  0, 0, 1, 0,  0, 0, 1, 1))", "2:11: invalid matrix: the last row must be 0, 0, 0, 1"),
    ("sphere(m, rotation([0, 0, 0], 30))", "2:11: invalid rotation: the axis must have a positive, finite length"),
    ("sphere(m, look_at([0, 0, 0], [0, 0, 1], [0, 0, 1]))",
        "2:11: invalid look_at: the eye is at the target, or up is parallel to the view direction"),
    ("sphere(m, scaling([1e30, 1e30, 1e30]) * scaling([1e30, 1, 1]))", "2:11: the transformation overflows (it is not finite)"),
    ("float big(1e999)", "2:11: number '1e999' is out of range"),
    ("material a(diffuse(checkered(<1, 1, 1>, <0, 0, 0>, 0)))", "2:52: the number of steps must be at least 1 (found 0)"),
    ("material a(glass(0))", "2:18: the index of refraction must be positive (found 0)"),
    ("material a(phong(<1, 1, 1>, <1, 1, 1>, -1))", "2:40: the exponent must not be negative (found -1)"),
    ("material a(cook_torrance(<1, 1, 1>, <1, 1, 1>, 0))", "2:48: the roughness must be positive (found 0)"),
    ("material a(cook_torrance(<1, 1, 1>, <1, 1, 1>, 0.1, 1.5, \"phong\"))",
        "2:58: expected \"beckmann\" or \"ggx\" but found string \"phong\""),
    ("spot_light([0, 0, 0], [0, 0, 0], <1, 1, 1>, 30, 1)", "2:23: a direction must have a positive, finite length"),
    ("spot_light([0, 0, 0], [0, 0, 1], <1, 1, 1>, 190, 1)", "2:45: the cutoff angle must be in (0, 180] degrees (found 190)"),
    ("point_light([0, 0, 0], <1, 1, 1>, 1, attenuation(1, -1, 0))", "2:53: an attenuation coefficient must not be negative (found -1)"),
    ("polyhedron(m, identity, [0, 0, 0], 1)", "2:25: a direction must have a positive, finite length"),
    ("distant_light([1e-30, 0, 0], <1, 1, 1>)", "2:15: a direction must have a positive, finite length"),
    ("hemisphere_light(<1, 1, 1>, [0, 3e38, 3e38])", "2:29: a direction must have a positive, finite length"),
    // tokens
    ("sphere(m, @)", "2:11: invalid character '@'"),
    ("material a(diffuse(image(\"sky.pfm)))", "2:26: unterminated string"),
    ("sphere(m, translation([1, 2, 3x]))", "2:30: invalid number '3x'"),
    ("sphere(m, rotation_z(- -x))", "2:25: unknown variable 'x'"),
    ("sphere(m, rotation_z(2 * ))", "2:26: expected a number but found ')'"),
];

#[test]
fn every_error_is_reported_at_its_position() {
    for &(text, expected) in REJECTED {
        assert_eq!(error_of(&format!("{MATS}{text}")), expected, "for: {text}");
    }
}

#[test]
fn errors_render_with_the_source_line_and_a_caret() {
    let e = parse_with(
        "material m(diffuse(<1, 1, 1>))\n\tsphere(n, identity)\n",
        &[],
    )
    .unwrap_err();
    assert_eq!(
        e.to_string(),
        "scenes/test.txt:2:9: unknown material 'n'\n\tsphere(n, identity)\n\t       ^"
    );
    let e = parse_with("sphere(m, identity", &[]).unwrap_err();
    assert_eq!(
        e.to_string(),
        "scenes/test.txt:1:8: unknown material 'm'\nsphere(m, identity\n       ^"
    );
    // The builder reports later errors the same way from stored positions.
    let d = parse(&format!("{MATS}mesh(m, identity, \"none.obj\")"));
    let ShapeKind::Mesh { file, .. } = &d.shapes[0].kind else {
        panic!()
    };
    assert_eq!(
        d.error(file.pos, "mesh file not found").to_string(),
        "scenes/test.txt:2:19: mesh file not found\nmesh(m, identity, \"none.obj\")\n                  ^"
    );
}

#[test]
fn command_line_overrides_win() {
    // Overridden variables exist from the start and may be declared (even twice).
    let text = "float clock(150)\nfloat clock(10)\nfloat other(clock)";
    let d = parse_with(text, &[("clock", 3.0)]).unwrap();
    assert_eq!((d.floats["clock"], d.floats["other"]), (3.0, 3.0));
    // Without the override, the second definition is an error.
    let e = parse_with(text, &[]).unwrap_err();
    assert_eq!(
        (e.pos, e.message.as_str()),
        (
            Some(Pos::new(2, 7)),
            "variable 'clock' cannot be redefined (first defined at 1:7)"
        )
    );
    // Never declared in the file.
    let d = parse_with("float a(angle)", &[("angle", 45.0)]).unwrap();
    assert_eq!((d.floats["a"], d.floats["angle"]), (45.0, 45.0));
    // The demo scene with a different clock.
    let d = parse_with(DEMO, &[("clock", 0.0)]).unwrap();
    let expected = Transform::translation(Vec3::new(0.0, 0.0, 100.0));
    assert!(approx(d.shapes[0].transform(), expected));
}

#[test]
fn define_syntax() {
    assert_eq!(parse_define("clock=150"), Ok(("clock".to_owned(), 150.0)));
    assert_eq!(parse_define("clock:1.5e1"), Ok(("clock".to_owned(), 15.0)));
    assert_eq!(parse_define(" _x = -2 "), Ok(("_x".to_owned(), -2.0)));
    for bad in [
        "clock", "=1", "1a=2", "a b=1", "a=", "a=x", "a=inf", "a=NaN", "a=1e999",
    ] {
        assert!(parse_define(bad).is_err(), "{bad}");
    }
    assert_eq!(
        parse_define("a=x").unwrap_err(),
        "invalid value 'x' for 'a': expected a finite number"
    );
}

#[test]
fn scene_files_are_read_from_disk() {
    let missing = Path::new("/nonexistent/scene.txt");
    let e = parse_scene_file(missing, &HashMap::new()).unwrap_err();
    assert_eq!(e.pos, None);
    assert!(
        e.to_string()
            .starts_with("/nonexistent/scene.txt: cannot read the scene file: "),
        "{e}"
    );

    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("lang-test");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("demo.txt");
    std::fs::write(&path, DEMO).unwrap();
    let d = parse_scene_file(&path, &HashMap::new()).unwrap();
    assert_eq!(d.source.path, path);
    let BrdfKind::Diffuse { kd } = &d.materials[3].brdf.kind else {
        panic!()
    };
    assert!(matches!(&kd.kind, PigmentKind::Image(f) if f.path == dir.join("my file.pfm")));
}

#[test]
fn nesting_is_limited() {
    let nested = |depth: usize| {
        let mut s = MATS.to_owned();
        s += &"union(sphere(m, identity), ".repeat(depth);
        s += "sphere(m, identity)";
        s += &")".repeat(depth);
        s
    };
    assert!(parse_with(&nested(MAX_DEPTH), &[]).is_ok());
    let message = format!("shapes are nested too deeply (more than {MAX_DEPTH} levels)");
    let prefix = "union(sphere(m, identity), ".len() as u32;
    for depth in [MAX_DEPTH + 1, 1_000_000] {
        let e = parse_with(&nested(depth), &[]).unwrap_err();
        assert_eq!(e.message, message);
        assert_eq!(e.pos, Some(Pos::new(2, 1 + prefix * MAX_DEPTH as u32)));
    }
    // Named shapes nest without limit: each refers to an earlier one.
    let mut text = format!("{MATS}shape s0(sphere(m, identity))\n");
    for i in 1..1000 {
        text += &format!("shape s{i}(union(s{}, s{}))\n", i - 1, i - 1);
    }
    text += "s999";
    assert!(parse_with(&text, &[]).is_ok());
}

#[test]
fn any_prefix_or_mangled_demo_gives_a_result() {
    // Truncations and single-character deletions of the demo: never a panic.
    let text = format!("{MATS}{DEMO}");
    let boundaries: Vec<usize> = text.char_indices().map(|(i, _)| i).collect();
    for &i in &boundaries {
        let _ = parse_with(&text[..i], &[]);
        let mut mangled = text.clone();
        mangled.remove(i);
        let _ = parse_with(&mangled, &[]);
    }
}

#[test]
fn identity_only_matrix_is_exact() {
    let d = parse(&format!(
        "{MATS}sphere(m, matrix(1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1))"
    ));
    assert_eq!(d.shapes[0].transform().m, Matrix4::IDENTITY);
}
