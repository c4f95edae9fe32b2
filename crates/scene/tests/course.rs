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
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n",
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
