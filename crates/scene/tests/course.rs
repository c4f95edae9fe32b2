//! The course's conventions in the candela language: file names found beside the scene file or
//! in the current directory, float expressions, the convex polygon.

mod support;

use candela_scene::{load_scene, LoadOptions};
use support::mitsuba::tmpdir;

/// The tests run in the crate's folder, where `tests/data/tri.obj` is.
#[test]
fn files_are_found_beside_the_scene_or_in_the_current_directory() {
    let dir = tmpdir("course-paths");
    let scene = dir.join("s.txt");
    std::fs::write(
        &scene,
        "material m(diffuse(<1, 1, 1>))\nmesh(m, identity, \"tests/data/tri.obj\")\n",
    )
    .unwrap();
    let l = load_scene(&scene, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(l.scene.geometry.meshes()[0].indices.len(), 1);

    // Beside the scene wins over the current directory.
    std::fs::create_dir_all(dir.join("tests/data")).unwrap();
    std::fs::write(
        dir.join("tests/data/tri.obj"),
        // Two triangles (not a parallelogram, which would be loaded as one).
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1.5 0\nf 1 2 3\nf 2 4 3\n",
    )
    .unwrap();
    let l = load_scene(&scene, &LoadOptions::default()).unwrap();
    assert_eq!(l.scene.geometry.meshes()[0].indices.len(), 2);

    std::fs::write(
        &scene,
        "material m(diffuse(image(\"nowhere/t.pfm\")))\nsphere(m, identity)\n",
    )
    .unwrap();
    let e = load_scene(&scene, &LoadOptions::default()).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains(":1:26: image file 'nowhere/t.pfm' not found: tried '"),
        "{msg}"
    );
    assert!(msg.contains("(beside the scene file) and '"), "{msg}");
    assert!(msg.contains("(the current directory)"), "{msg}");
}

#[test]
fn numbers_are_arithmetic_expressions() {
    use support::lang::{error_of, parse};
    let value = |expr: &str| {
        let d = parse(&format!("float a(2)\nfloat x({expr})"));
        d.floats["x"]
    };
    let pi = std::f32::consts::PI;
    assert_eq!(value("2 * pi / 3"), 2.0 * pi / 3.0);
    assert_eq!(value("1 + 2 * 3"), 7.0);
    assert_eq!(value("(1 + 2) * 3"), 9.0);
    assert_eq!(value("2 - 3 - 4"), -5.0);
    assert_eq!(value("10 / 4 / 5"), 0.5);
    assert_eq!(value("1 -2"), -1.0);
    assert_eq!(value("a -4 * a"), -6.0);
    assert_eq!(value("1+2"), 3.0);
    assert_eq!(value("2 * -3"), -6.0);
    assert_eq!(value("-(a + 1)"), -3.0);
    assert_eq!(value("--a"), 2.0);
    assert_eq!(value("-a * a"), -4.0);
    assert_eq!(value("pi"), pi);
    // A variable called pi wins over the constant.
    assert_eq!(parse("float pi(3)\nfloat x(pi * 2)").floats["x"], 6.0);
    // Expressions wherever a number goes.
    let d = parse("float c(30)\nmaterial m(diffuse(<0.5 * 2, 1 / 4, 0>))\nsphere(m, rotation_z(c * 2 + 30) * translation([1 + 1, -c / 30, (2)]))");
    assert_eq!(d.materials.len(), 1);
    assert!(error_of("float x(1 / 0)").starts_with("1:13: division by zero"));
    assert!(error_of("float x((1 + 2)").starts_with("1:16: expected ')'"));
    assert!(error_of("float x(2 *)").starts_with("1:12: expected a number"));
    assert!(
        error_of("float x(1e30 * 1e30)").starts_with("1:9: the expression is not a finite number")
    );
    let deep = format!("float x({}1{})", "(".repeat(1000), ")".repeat(1000));
    assert!(error_of(&deep).contains("nested too deeply"));
}

/// A regular hexagon of circumradius 1 facing an orthogonal camera covers 3√3/2 of the 4×4
/// screen: the fraction of pixel centres that hit it.
#[test]
fn the_convex_polygon_covers_its_area() {
    use candela_render::integrator::OnOff;
    use candela_render::render::{render, RenderSettings};
    let dir = tmpdir("course-polygon");
    let scene = dir.join("hex.txt");
    // In the plane x = 1, seen along +x by the course camera (screen y, z ∈ [-2, 2]).
    let mut text = String::from("material m(diffuse(<1, 1, 1>))\npolygon(m");
    for i in 0..6 {
        let a = i as f64 * std::f64::consts::PI / 3.0;
        text += &format!(", [1, {}, {}]", a.cos(), a.sin());
    }
    text += ")\ncamera(orthogonal, scaling([2, 2, 2]), 1, 1)\n";
    std::fs::write(&scene, &text).unwrap();
    let l = load_scene(&scene, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let n = 200;
    let settings = RenderSettings {
        width: n,
        height: n,
        ..Default::default()
    };
    let img = render(&l.scene, &OnOff, &settings, &|_| {}).image;
    let hits = img.pixels().iter().filter(|p| p.r > 0.5).count() as f64;
    let expected = 1.5 * 3f64.sqrt() / 16.0;
    let got = hits / (n * n) as f64;
    assert!((got - expected).abs() < 0.005, "{got} vs {expected}");

    // Errors at the offending vertex.
    use support::lang::parse;
    let build = |t: &str| {
        let d = parse(t);
        candela_scene::builder::build_scene(&d, Default::default(), &Default::default())
            .err()
            .map(|e| format!("{}: {}", e.pos.unwrap_or_default(), e.message))
    };
    let m = "material m(diffuse(<1, 1, 1>))\n";
    assert_eq!(
        build(&format!(
            "{m}polygon(m, [0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 1])"
        ))
        .unwrap(),
        "2:45: polygon: vertex 4 is not in the plane of the others"
    );
    assert!(build(&format!(
        "{m}polygon(m, [0, 0, 0], [2, 0, 0], [1, 0.5, 0], [1, 2, 0])"
    ))
    .unwrap()
    .contains("polygon: the polygon is not convex"));
    assert!(
        support::lang::error_of(&format!("{m}polygon(m, [0, 0, 0], [1, 0, 0])"))
            .starts_with("2:32: expected ',' but found ')': too few arguments")
    );
    assert_eq!(
        build(&format!(
            "{m}polygon(m, [0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0])"
        )),
        None
    );
}
