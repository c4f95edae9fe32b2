//! The course's command-line spellings and `--filter`, end to end.

mod support;

use support::{candela, scratch, stderr};

const SCENE: &str = "float clock(0)
material m(diffuse(<1, 1, 1>), <1, 1, 1>)
sphere(m, rotation_z(clock) * translation([0, 1, 0]) * scaling([0.5, 0.5, 0.5]))
camera(perspective, translation([-3, 0, 0]), 1, 1)
";

fn render(dir: &std::path::Path, name: &str, extra: &[&str]) -> Vec<u8> {
    let scene = dir.join("s.scene");
    std::fs::write(&scene, SCENE).unwrap();
    let out = dir.join(format!("{name}.pfm"));
    let mut args = vec![
        "render",
        scene.to_str().unwrap(),
        "--width",
        "16",
        "--height",
        "16",
        "--integrator",
        "flat",
        "-q",
        "-o",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let o = candela(&args);
    assert!(o.status.success(), "{name}: {}", stderr(&o));
    std::fs::read(out).unwrap()
}

#[test]
fn declare_float_is_a_synonym_of_define() {
    let dir = scratch("declare-float");
    let d = render(&dir, "d", &["-d", "clock=90"]);
    assert_eq!(render(&dir, "a", &["--declare-float", "clock:90"]), d);
    assert_eq!(render(&dir, "b", &["--declare-float=clock=90"]), d);
    assert_ne!(render(&dir, "c", &[]), d);
}

#[test]
fn filters_are_chosen_on_the_command_line() {
    let dir = scratch("filter-option");
    let boxed = render(&dir, "box", &[]);
    assert_eq!(render(&dir, "box2", &["--filter", "box"]), boxed);
    assert_ne!(
        render(&dir, "gauss", &["--filter", "gaussian", "--spp", "4"]),
        boxed
    );
    let o = candela(&["render", "x.scene", "--filter", "sinc"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--filter"), "{}", stderr(&o));
}
