//! `candela render --integrator radiosity` end to end: both Cornell boxes (candela language and
//! Mitsuba XML), the options `--patch-size`, `--form-factors`, `--solver`, `--radiosity-cache`
//! (saved, reused, detected as stale, recovered when corrupt), and errors naming the option.

mod support;

use std::path::Path;
use std::process::Output;
use support::{candela, repo, scratch, stderr};

fn render(scene: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "render",
        scene.to_str().unwrap(),
        "--integrator",
        "radiosity",
        "--width",
        "32",
        "--height",
        "32",
        "-q",
        "--stats",
        "-o",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    candela(&args)
}

#[test]
fn both_cornell_boxes_render_with_every_method_and_solver() {
    let dir = scratch("cornell");
    let scenes = [
        repo().join("examples/cornell-box.scene"),
        repo().join("examples/cornell-box.xml"),
    ];
    for scene in &scenes {
        for (ff, solver) in [("hemicube", "gauss-seidel"), ("raycast", "progressive")] {
            let out = dir.join("c.pfm");
            let o = render(
                scene,
                &out,
                &[
                    "--patch-size",
                    "0.3",
                    "--form-factors",
                    ff,
                    "--solver",
                    solver,
                ],
            );
            assert!(
                o.status.success(),
                "{} {ff} {solver}: {}",
                scene.display(),
                stderr(&o)
            );
            let err = stderr(&o);
            assert!(
                err.contains(&format!("{ff} form factors"))
                    && err.contains(&format!("{solver} solver")),
                "{err}"
            );
            assert!(err.contains("converged"), "{err}");
            assert!(std::fs::metadata(&out).unwrap().len() > 32 * 32 * 12);
        }
    }
}

#[test]
fn the_cache_is_saved_reused_and_replaced_when_stale() {
    let dir = scratch("cache");
    let scene = repo().join("examples/cornell-box.scene");
    let cache = dir.join("cornell.rad");
    let cache_arg = cache.to_str().unwrap().to_string();
    let first = dir.join("first.pfm");
    let o = render(
        &scene,
        &first,
        &["--patch-size", "0.4", "--radiosity-cache", &cache_arg],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let saved = std::fs::read(&cache).expect("the cache was written");
    // No temporary file is left behind.
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 2);

    // Same scene and options: loaded, the same image, the file unchanged.
    let second = dir.join("second.pfm");
    let o = render(
        &scene,
        &second,
        &["--patch-size", "0.4", "--radiosity-cache", &cache_arg],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("loaded from the cache"),
        "{}",
        stderr(&o)
    );
    assert_eq!(
        std::fs::read(&first).unwrap(),
        std::fs::read(&second).unwrap()
    );
    assert_eq!(std::fs::read(&cache).unwrap(), saved);

    // Other options: stale, solved again and replaced.
    let o = render(
        &scene,
        &second,
        &["--patch-size", "0.5", "--radiosity-cache", &cache_arg],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("does not match"), "{}", stderr(&o));
    assert_ne!(std::fs::read(&cache).unwrap(), saved);

    // A corrupt file: solved again and replaced.
    std::fs::write(&cache, b"garbage").unwrap();
    let o = render(
        &scene,
        &second,
        &["--patch-size", "0.4", "--radiosity-cache", &cache_arg],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("invalid"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&cache).unwrap(), saved);
}

#[test]
fn bad_radiosity_options_are_errors_naming_the_option() {
    let dir = scratch("errors");
    let scene = repo().join("examples/cornell-box.scene");
    let out = dir.join("x.png");
    for (args, option) in [
        (
            vec!["--form-factors", "radiance"],
            "--form-factors 'radiance'",
        ),
        (vec!["--solver", "jacobi"], "--solver 'jacobi'"),
        (vec!["--patch-size", "-1"], "--patch-size"),
        (vec!["--patch-size", "0"], "--patch-size"),
    ] {
        let o = render(&scene, &out, &args);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(stderr(&o).contains(option), "{args:?}: {}", stderr(&o));
        assert!(!out.exists(), "{args:?} wrote an image");
    }
    // The names are checked whatever the integrator.
    let o = candela(&[
        "render",
        scene.to_str().unwrap(),
        "--solver",
        "jacobi",
        "-q",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success() && stderr(&o).contains("--solver 'jacobi'"));
}

/// SIGTERM during a long radiosity solve (a 20 000-triangle mesh: a patch per triangle at
/// least) ends the process at once with status 130 and writes nothing: nothing is finished
/// before rendering begins, and the solve does not poll for interruptions.
#[test]
fn an_interrupted_solve_ends_at_once_and_writes_nothing() {
    use std::process::{Command, Stdio};
    use std::time::{Duration, Instant};
    let dir = scratch("radiosity-interrupt");
    let n = 100;
    let mut obj = String::new();
    for j in 0..=n {
        for i in 0..=n {
            obj += &format!(
                "v {} {} {}\n",
                i as f32 / n as f32,
                j as f32 / n as f32,
                ((i * j) % 7) as f32 * 0.01
            );
        }
    }
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i + 1;
            obj += &format!(
                "f {} {} {}\nf {} {} {}\n",
                a,
                a + 1,
                a + n + 2,
                a,
                a + n + 2,
                a + n + 1
            );
        }
    }
    std::fs::write(dir.join("grid.obj"), obj).unwrap();
    let scene = dir.join("s.scene");
    std::fs::write(
        &scene,
        "material m(diffuse(<0.7, 0.7, 0.7>))\nmesh(m, identity, \"grid.obj\")\n\
         material e(diffuse(<0.5, 0.5, 0.5>), <4, 4, 4>)\nsphere(e, translation([0.5, 0.5, 2]) * scaling([0.2, 0.2, 0.2]))\n\
         camera(perspective, look_at([0.5, -2, 2], [0.5, 0.5, 0], [0, 0, 1]), 1, 1)\n",
    )
    .unwrap();
    let out = dir.join("o.pfm");
    let child = Command::new(env!("CARGO_BIN_EXE_candela"))
        .args([
            "render",
            scene.to_str().unwrap(),
            "--integrator",
            "radiosity",
            "-q",
        ])
        .args([
            "--width",
            "16",
            "--height",
            "16",
            "-o",
            out.to_str().unwrap(),
        ])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    let start = Instant::now();
    let pid = child.id().to_string();
    assert!(Command::new("kill")
        .args(["-TERM", &pid])
        .status()
        .unwrap()
        .success());
    let o = child.wait_with_output().unwrap();
    let err = stderr(&o);
    assert!(
        start.elapsed() < Duration::from_secs(3),
        "took {:?}",
        start.elapsed()
    );
    assert_eq!(o.status.code(), Some(130), "{err}");
    assert!(err.contains("nothing written"), "{err}");
    assert!(!out.exists());
}
