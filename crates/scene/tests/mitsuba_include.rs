//! Mitsuba `<include>`: relative paths, nesting, cycles, and messages positioned in the included
//! file.

mod support;

use candela_scene::mitsuba::load_mitsuba;
use candela_scene::LoadOptions;
use support::mitsuba::tmpdir;

fn write(dir: &std::path::Path, name: &str, text: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::create_dir_all(p.parent().unwrap()).unwrap();
    std::fs::write(&p, text).unwrap();
    p
}

fn load(path: &std::path::Path) -> Result<candela_scene::LoadedScene, candela_scene::SceneError> {
    let text = std::fs::read_to_string(path).unwrap();
    load_mitsuba(path, &text, &LoadOptions::default())
}

const SPHERE: &str = r#"<shape type="sphere"><float name="radius" value="0.5"/></shape>"#;

#[test]
fn includes_resolve_against_the_including_file_and_nest() {
    let dir = tmpdir("include-nest");
    write(
        &dir,
        "main.xml",
        r#"<scene version="3.0.0">
    <include filename="parts/a.xml"/>
    <shape type="sphere"/>
</scene>"#,
    );
    // a.xml includes b.xml from its own folder.
    write(
        &dir,
        "parts/a.xml",
        &format!(
            "<scene version=\"3.0.0\">\n    {SPHERE}\n    <include filename=\"b.xml\"/>\n</scene>"
        ),
    );
    write(
        &dir,
        "parts/b.xml",
        &format!("<scene version=\"3.0.0\">\n    {SPHERE}\n</scene>"),
    );
    let l = load(&dir.join("main.xml")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(l.scene.geometry.objects().len(), 3);
}

#[test]
fn errors_and_warnings_are_positioned_in_the_included_file() {
    let dir = tmpdir("include-pos");
    let main = write(
        &dir,
        "main.xml",
        r#"<scene version="3.0.0">
    <include filename="inc.xml"/>
</scene>"#,
    );
    write(
        &dir,
        "inc.xml",
        "<scene version=\"3.0.0\">\n    <shape type=\"sphere\"/>\n    <shape type=\"teapot\"/>\n</scene>",
    );
    let e = load(&main).unwrap_err();
    assert!(e.path.ends_with("inc.xml"), "{e}");
    assert_eq!(e.pos.map(|p| (p.line, p.col)), Some((3, 5)), "{e}");
    assert_eq!(
        e.source_line.as_deref(),
        Some("    <shape type=\"teapot\"/>")
    );
    assert!(e.to_string().contains("inc.xml:3:5: "), "{e}");

    // A warning (an unused parameter) in the included file.
    write(
        &dir,
        "inc.xml",
        "<scene version=\"3.0.0\">\n    <shape type=\"sphere\">\n        <float name=\"bogus\" value=\"1\"/>\n    </shape>\n</scene>",
    );
    let l = load(&main).unwrap();
    assert!(
        l.warnings.iter().any(|w| w.contains("inc.xml:3:9: ")),
        "{:?}",
        l.warnings
    );

    // Malformed XML in the included file.
    write(
        &dir,
        "inc.xml",
        "<scene version=\"3.0.0\">\n  <shape>\n</scene>",
    );
    let e = load(&main).unwrap_err();
    assert!(e.path.ends_with("inc.xml"), "{e}");
    assert!(e.message.contains("malformed XML"), "{e}");
}

#[test]
fn cycles_and_missing_files_are_errors_at_the_include() {
    let dir = tmpdir("include-cycle");
    let main = write(
        &dir,
        "a.xml",
        "<scene version=\"3.0.0\">\n  <include filename=\"b.xml\"/>\n</scene>",
    );
    write(
        &dir,
        "b.xml",
        "<scene version=\"3.0.0\">\n\n  <include filename=\"a.xml\"/>\n</scene>",
    );
    let e = load(&main).unwrap_err();
    assert!(e.path.ends_with("b.xml"), "{e}");
    assert_eq!(e.pos.map(|p| p.line), Some(3), "{e}");
    assert!(e.message.contains("cycle: a.xml → b.xml → a.xml"), "{e}");

    let main = write(
        &dir,
        "c.xml",
        "<scene version=\"3.0.0\">\n  <include filename=\"nowhere.xml\"/>\n</scene>",
    );
    let e = load(&main).unwrap_err();
    assert_eq!(e.pos.map(|p| (p.line, p.col)), Some((2, 22)), "{e}");
    assert!(e.message.contains("not found"), "{e}");

    // A file including itself.
    let main = write(
        &dir,
        "d.xml",
        "<scene version=\"3.0.0\">\n  <include filename=\"d.xml\"/>\n</scene>",
    );
    assert!(load(&main).unwrap_err().message.contains("cycle"));
}
