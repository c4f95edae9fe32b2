//! The `candela` command line, end to end: every example renders, errors are reported with
//! positions or option names and leave no output, and images do not depend on thread counts.

mod support;

use candela_render::{Image, Rgb};
use support::{candela, repo, scratch, stderr};

/// Every scene of examples/ renders at a small size with its default integrator and with the
/// preview ones.
#[test]
fn every_example_renders() {
    let dir = scratch("examples");
    let mut n = 0;
    let entries = ["examples", "examples/mitsuba", "examples/instancing"]
        .iter()
        .flat_map(|d| std::fs::read_dir(repo().join(d)).unwrap());
    for entry in entries {
        let path = entry.unwrap().path();
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        if ext != "scene" && ext != "xml" {
            continue;
        }
        n += 1;
        let out = dir.join(format!(
            "{}.pfm",
            path.file_stem().unwrap().to_str().unwrap()
        ));
        for integrator in ["path", "whitted", "normals"] {
            let o = candela(&[
                "render",
                path.to_str().unwrap(),
                "--width",
                "24",
                "--height",
                "18",
                "--spp",
                "2",
                "--integrator",
                integrator,
                "-q",
                "-o",
                out.to_str().unwrap(),
            ]);
            assert!(
                o.status.success(),
                "{} ({integrator}): {}",
                path.display(),
                stderr(&o)
            );
            assert!(out.exists());
        }
    }
    assert!(n >= 15, "only {n} examples");
}

/// A scene error names file:line:col, shows the line with a caret, exits non-zero and writes
/// nothing.
#[test]
fn scene_errors_have_positions_and_leave_no_output() {
    let dir = scratch("errors");
    let cases = [
        (
            "unknown material",
            "material m(diffuse(<1, 1, 1>))\nsphere(nope, identity)\n",
            "2:8",
        ),
        ("bad token", "material m(diffuse(<1, 1, 1>))\n  $\n", "2:3"),
        (
            "second camera",
            "camera(orthogonal, identity, 1, 1)\ncamera(orthogonal, identity, 1, 1)\n",
            "2:1",
        ),
        (
            "missing mesh",
            "material m(diffuse(<1, 1, 1>))\nmesh(m, identity, \"nowhere.obj\")\n",
            "2:",
        ),
        (
            "singular transform",
            "material m(diffuse(<1, 1, 1>))\nsphere(m, scaling([1, 0, 1]))\n",
            "2:",
        ),
    ];
    for (what, text, pos) in cases {
        let scene = dir.join("bad.scene");
        std::fs::write(&scene, text).unwrap();
        let out = dir.join("out.png");
        let o = candela(&[
            "render",
            scene.to_str().unwrap(),
            "-q",
            "-o",
            out.to_str().unwrap(),
        ]);
        let err = stderr(&o);
        assert!(!o.status.success(), "{what}: accepted");
        assert!(err.contains(&format!("bad.scene:{pos}")), "{what}: {err}");
        assert!(err.contains('^'), "{what}: no caret in {err}");
        assert!(!out.exists(), "{what}: an output was written");
        assert!(!err.contains("panicked"), "{what}: {err}");
    }
    let o = candela(&["render", dir.join("absent.scene").to_str().unwrap(), "-q"]);
    assert!(!o.status.success() && stderr(&o).contains("absent.scene"));
}

/// Bad options name the option and exit non-zero before any work.
#[test]
fn option_errors_name_the_option() {
    let dir = scratch("options");
    let out = dir.join("x.png");
    let o = out.to_str().unwrap();
    for (args, name) in [
        (vec!["demo", "--width", "0", "-o", o], "--width"),
        (vec!["demo", "--height", "99999999", "-o", o], "--height"),
        (vec!["demo", "--spp", "abc", "-o", o], "--spp"),
        (
            vec!["demo", "--integrator", "magic", "-o", o],
            "--integrator",
        ),
        (vec!["demo", "--accel", "magic", "-o", o], "--accel"),
        (vec!["demo", "--sampler", "magic", "-o", o], "--sampler"),
        (vec!["demo", "-o", "picture.bmp"], "--output"),
        (vec!["demo", "--threads", "0", "-o", o], "--threads"),
        (vec!["demo", "--gamma", "-1", "-o", o], "--gamma"),
        (vec!["demo", "-d", "novalue", "-o", o], "--define"),
    ] {
        let r = candela(&args);
        assert!(!r.status.success(), "{args:?} accepted");
        assert!(stderr(&r).contains(name), "{args:?}: {}", stderr(&r));
        assert!(!out.exists());
    }
}

/// The same scene and seed give the same bytes with one thread and with several.
#[test]
fn images_do_not_depend_on_the_thread_count() {
    let dir = scratch("threads");
    let run = |threads: &str, sampler: &str, name: &str| {
        let out = dir.join(name);
        let o = candela(&[
            "demo",
            "--width",
            "40",
            "--height",
            "30",
            "--spp",
            "4",
            "--seed",
            "5",
            "--sampler",
            sampler,
            "--threads",
            threads,
            "-q",
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        std::fs::read(out).unwrap()
    };
    for sampler in ["sobol", "stratified", "independent"] {
        let a = run("1", sampler, "one.pfm");
        let b = run("3", sampler, "three.pfm");
        assert_eq!(a, b, "{sampler}");
    }
}

/// An instanced scene (Mitsuba shapegroup and instances, the course's instances of a mesh)
/// gives the same bytes with one thread and with two, shape output variable included.
#[test]
fn instanced_images_do_not_depend_on_the_thread_count() {
    let dir = scratch("threads-instances");
    for scene in ["small.xml", "small.scene"] {
        let path = repo().join("examples/instancing").join(scene);
        let run = |threads: &str| {
            let out = dir.join(format!("{scene}-{threads}.exr"));
            let o = candela(&[
                "render",
                path.to_str().unwrap(),
                "--width",
                "40",
                "--height",
                "30",
                "--spp",
                "4",
                "--integrator",
                "path",
                "--aov",
                "shape,normal",
                "--threads",
                threads,
                "-q",
                "-o",
                out.to_str().unwrap(),
            ]);
            assert!(o.status.success(), "{}", stderr(&o));
            std::fs::read(out).unwrap()
        };
        assert_eq!(run("1"), run("2"), "{scene}");
    }
}

/// `convert` applies the course's tone mapping: a uniform grey PFM of value 1 with a = 0.18,
/// γ = 1 maps every channel to 0.18/1.18 → byte int(255·0.152542) = 38.
#[test]
fn convert_tone_maps_by_the_course_formulas() {
    let dir = scratch("convert");
    let pfm = dir.join("grey.pfm");
    let grey = Image::from_pixels(2, 1, vec![Rgb::WHITE; 2]).unwrap();
    std::fs::write(&pfm, candela_imageio::write_pfm(&grey)).unwrap();
    let png = dir.join("grey.png");
    let o = candela(&["convert", pfm.to_str().unwrap(), png.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let exr = dir.join("grey.exr");
    let o = candela(&["convert", pfm.to_str().unwrap(), exr.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let back = dir.join("back.pfm");
    let o = candela(&["convert", exr.to_str().unwrap(), back.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(&pfm).unwrap(), std::fs::read(&back).unwrap());
    let png_bytes = std::fs::read(&png).unwrap();
    assert!(png_bytes.starts_with(b"\x89PNG"));
    let decoded = candela_imageio::png::read_png(&png_bytes).unwrap();
    // Decoding applies the sRGB curve; re-encode to get the stored byte back.
    let byte = (candela_imageio::tonemap::srgb_oetf(decoded.get(0, 0).r) * 255.0).round() as u8;
    assert_eq!(byte, 38);
    let bad = candela(&[
        "convert",
        dir.join("missing.pfm").to_str().unwrap(),
        png.to_str().unwrap(),
    ]);
    assert!(!bad.status.success() && stderr(&bad).contains("missing.pfm"));
}

/// `--stats` reports rays, time and Mrays/s.
#[test]
fn stats_report_rays_and_speed() {
    let dir = scratch("stats");
    let out = dir.join("d.png");
    let o = candela(&[
        "demo",
        "--width",
        "32",
        "--height",
        "24",
        "--stats",
        "-q",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("Mrays/s") && err.contains("rays"), "{err}");
    assert!(out.exists());
}

/// `candela` in `dir` with `args`, standard input read from `input`.
fn candela_stdin(
    dir: &std::path::Path,
    input: &std::path::Path,
    args: &[&str],
) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_candela"))
        .current_dir(dir)
        .args(args)
        .stdin(std::fs::File::open(input).unwrap())
        .output()
        .expect("the binary runs")
}

/// `render -` reads the scene from standard input: a candela scene with a mesh and a Mitsuba
/// scene with meshes (found from the current folder) render the bytes of the same files; a
/// partial render from standard input merges with one from the file; errors say `<stdin>`.
#[test]
fn a_scene_on_standard_input_renders_as_the_file() {
    let dir = scratch("stdin");
    let size = ["--width", "24", "--height", "18", "--spp", "2", "-q"];
    for (folder, scene) in [
        ("examples", "mesh.scene"),
        ("examples/mitsuba", "mesh-roughconductor.xml"),
    ] {
        let folder = repo().join(folder);
        let (a, b) = (dir.join("file.pfm"), dir.join("stdin.pfm"));
        let mut args = vec!["render", scene, "-o", a.to_str().unwrap()];
        args.extend(size);
        let o = candela_stdin(&folder, std::path::Path::new("/dev/null"), &args);
        assert!(o.status.success(), "{}", stderr(&o));
        args[1] = "-";
        args[3] = b.to_str().unwrap();
        let o = candela_stdin(&folder, &folder.join(scene), &args);
        assert!(o.status.success(), "{scene}: {}", stderr(&o));
        assert_eq!(
            std::fs::read(&a).unwrap(),
            std::fs::read(&b).unwrap(),
            "{scene}"
        );
    }
    // Half the samples from standard input, half from the file: one render.
    let scene = dir.join("s.scene");
    std::fs::write(
        &scene,
        "material m(diffuse(<0.8, 0.5, 0.2>))\nsphere(m, translation([3, 0, 0]))\ncamera(perspective, identity, 1, 1)\n",
    )
    .unwrap();
    let run = |input: &str, extra: &[&str]| {
        let mut args = vec!["render", input];
        args.extend(size);
        args.extend(extra);
        let o = candela_stdin(&dir, &scene, &args);
        assert!(o.status.success(), "{}", stderr(&o));
    };
    run("-", &["--samples", "0..1", "--partial", "a.part"]);
    run("s.scene", &["--samples", "1..2", "--partial", "b.part"]);
    run("s.scene", &["-o", "whole.pfm"]);
    let o = candela(&[
        "merge",
        "-o",
        dir.join("merged.pfm").to_str().unwrap(),
        dir.join("a.part").to_str().unwrap(),
        dir.join("b.part").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(dir.join("merged.pfm")).unwrap(),
        std::fs::read(dir.join("whole.pfm")).unwrap()
    );
    // The default output is stdin.png.
    run("-", &[]);
    assert!(dir.join("stdin.png").exists());
    std::fs::write(
        &scene,
        "material m(diffuse(<1, 1, 1>))\n\nbox(m, nowhere)\n",
    )
    .unwrap();
    let o = candela_stdin(&dir, &scene, &["render", "-", "-q", "-o", "x.pfm"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).starts_with("candela: error: <stdin>:3:8: "),
        "{}",
        stderr(&o)
    );
    assert!(!dir.join("x.pfm").exists());
}
