//! Renders split over processes, machines and sittings (issue 17): partial renders merged into
//! the same bytes as one run, merges that refuse what does not fit, checkpoints that survive
//! SIGINT, SIGKILL and time limits, animation frames, JSON progress.

mod support;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use support::{candela, scratch, stderr};

/// A small demo frame: 24 samples per pixel.
const FRAME: [&str; 6] = ["--width", "72", "--height", "40", "--spp", "24"];

fn run_ok(args: &[&str]) {
    let o = candela(args);
    assert!(o.status.success(), "{args:?} failed: {}", stderr(&o));
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn demo_part(dir: &Path, name: &str, extra: &[&str]) -> PathBuf {
    let p = dir.join(name);
    let mut args = vec!["demo", "-q", "--partial", s(&p)];
    args.extend(FRAME);
    args.extend(extra);
    run_ok(&args);
    p
}

fn whole(dir: &Path, ext: &str, threads: &str) -> Vec<u8> {
    let p = dir.join(format!("whole-{threads}.{ext}"));
    let mut args = vec!["demo", "-q", "-o", s(&p), "--threads", threads];
    args.extend(FRAME);
    run_ok(&args);
    std::fs::read(p).unwrap()
}

fn merge(dir: &Path, parts: &[&Path], out: &str, extra: &[&str]) -> std::process::Output {
    let o = dir.join(out);
    let mut args = vec!["merge", "-o", s(&o)];
    args.extend(parts.iter().map(|p| s(p)));
    args.extend(extra);
    candela(&args)
}

#[test]
fn any_split_merges_into_the_bytes_of_one_render() {
    let dir = scratch("farm-splits");
    let reference_pfm = whole(&dir, "pfm", "2");
    assert_eq!(reference_pfm, whole(&dir, "pfm", "1"));
    let reference_png = whole(&dir, "png", "2");
    // Sample ranges, tiles, and both at once, on one and two threads.
    let splits: [&[&[&str]]; 3] = [
        &[
            &["--samples", "0..4", "--threads", "1"],
            &["--samples", "4..20"],
            &["--samples", "20..24", "--threads", "1"],
        ],
        &[
            &["--crop", "0,30,0,40"],
            &["--crop", "30,72,0,17", "--threads", "1"],
            &["--crop", "30,72,17,40"],
        ],
        &[
            &["--crop", "0,72,0,9", "--samples", "0..7"],
            &["--crop", "0,72,0,9", "--samples", "7..24", "--threads", "1"],
            &["--crop", "0,72,9,40", "--samples", "0..24"],
        ],
    ];
    for (k, split) in splits.iter().enumerate() {
        let parts: Vec<PathBuf> = split
            .iter()
            .enumerate()
            .map(|(i, extra)| demo_part(&dir, &format!("s{k}-{i}.part"), extra))
            .collect();
        let refs: Vec<&Path> = parts.iter().map(|p| p.as_path()).collect();
        let o = merge(&dir, &refs, &format!("m{k}.pfm"), &[]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(
            std::fs::read(dir.join(format!("m{k}.pfm"))).unwrap(),
            reference_pfm
        );
        let o = merge(&dir, &refs, &format!("m{k}.png"), &[]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(
            std::fs::read(dir.join(format!("m{k}.png"))).unwrap(),
            reference_png
        );
    }
    // Merges of merges: two tiles' sample ranges first, then the tiles.
    let a = demo_part(
        &dir,
        "t0a.part",
        &["--crop", "0,72,0,20", "--samples", "0..12"],
    );
    let b = demo_part(
        &dir,
        "t0b.part",
        &["--crop", "0,72,0,20", "--samples", "12..24"],
    );
    let c = demo_part(&dir, "t1.part", &["--crop", "0,72,20,40"]);
    let o = merge(&dir, &[&a, &b], "t0.part", &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = merge(&dir, &[&dir.join("t0.part"), &c], "mm.pfm", &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(dir.join("mm.pfm")).unwrap(), reference_pfm);
}

/// Spectral renders split and merge into the same bytes too (the wavelengths come from each
/// sample's own numbers), on any thread count; a spectral part and an RGB part do not merge.
#[test]
fn spectral_splits_merge_into_the_bytes_of_one_render() {
    let dir = scratch("farm-spectral");
    let reference = {
        let p = dir.join("whole.pfm");
        let mut args = vec!["demo", "-q", "--spectral", "--threads", "2", "-o", s(&p)];
        args.extend(FRAME);
        run_ok(&args);
        std::fs::read(p).unwrap()
    };
    let a = demo_part(
        &dir,
        "a.part",
        &["--spectral", "--samples", "0..8", "--threads", "1"],
    );
    let b = demo_part(&dir, "b.part", &["--spectral", "--samples", "8..24"]);
    let o = merge(&dir, &[&a, &b], "m.pfm", &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(dir.join("m.pfm")).unwrap(), reference);
    let rgb = demo_part(&dir, "rgb.part", &["--samples", "8..24"]);
    let o = merge(&dir, &[&a, &rgb], "x.pfm", &[]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("spectral"), "{}", stderr(&o));
    assert!(!dir.join("x.pfm").exists());
}

#[test]
fn merge_refuses_what_does_not_fit_and_writes_nothing() {
    let dir = scratch("farm-refusals");
    let a = demo_part(&dir, "a.part", &["--samples", "0..12"]);
    let b = demo_part(&dir, "b.part", &["--samples", "12..24"]);
    let overlapping = demo_part(&dir, "o.part", &["--samples", "8..16", "--crop", "0,8,0,8"]);
    let seeded = demo_part(&dir, "seed.part", &["--samples", "12..24", "--seed", "3"]);
    let defined = demo_part(&dir, "def.part", &["--samples", "12..24", "-d", "x=2"]);
    let bigger = dir.join("big.part");
    run_ok(&[
        "demo",
        "-q",
        "--partial",
        s(&bigger),
        "--width",
        "73",
        "--height",
        "40",
        "--spp",
        "24",
        "--samples",
        "12..24",
    ]);
    // The same demo as a scene file, then the file changed: another scene.
    let scene = dir.join("demo.scene");
    std::fs::write(&scene, candela_scene_demo()).unwrap();
    let from_file = dir.join("file.part");
    let mut args = vec![
        "render",
        s(&scene),
        "-q",
        "--partial",
        s(&from_file),
        "--samples",
        "12..24",
    ];
    args.extend(FRAME);
    run_ok(&args);
    let truncated = dir.join("truncated.part");
    let bytes = std::fs::read(&b).unwrap();
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
    let foreign = dir.join("foreign.part");
    std::fs::write(&foreign, b"P6\n2 2\n255\n").unwrap();

    let cases: [(&Path, &str); 7] = [
        (&overlapping, "overlap"),
        (&seeded, "seed"),
        (&defined, "defines"),
        (&bigger, "73×40"),
        (&from_file, "scene"),
        (&truncated, "truncated"),
        (&foreign, "not a candela partial file"),
    ];
    for (bad, pattern) in cases {
        let o = merge(&dir, &[&a, &b, bad], "out.pfm", &[]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{bad:?}: {err}");
        assert!(
            err.contains(pattern),
            "{bad:?}: expected '{pattern}' in: {err}"
        );
        let named = bad.file_name().unwrap().to_str().unwrap();
        assert!(err.contains(named), "the message names the file: {err}");
        assert!(!dir.join("out.pfm").exists());
    }
    // Missing samples: refused with what is missing, or written on request.
    let o = merge(&dir, &[&a], "out.pfm", &[]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        err.contains("samples 12..24: missing in 2880 of 2880 pixels"),
        "{err}"
    );
    assert!(!dir.join("out.pfm").exists());
    let o = merge(&dir, &[&a], "out.pfm", &["--allow-incomplete"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("incomplete"));
    assert!(dir.join("out.pfm").exists());
}

/// The demo scene's source, as a scene file would hold it (with one more comment: another
/// file, another hash).
fn candela_scene_demo() -> String {
    let demo = candela(&["--version"]);
    assert!(demo.status.success());
    let src = std::fs::read_to_string(support::repo().join("crates/scene/src/demo.scene")).unwrap();
    format!("{src}\n# changed\n")
}

/// A render that takes a few seconds, checkpointing often.
const LONG: [&str; 6] = ["--width", "200", "--height", "120", "--spp", "256"];

fn start_long(out: &Path, ckpt: &Path) -> std::process::Child {
    let mut args = vec![
        "demo",
        "-q",
        "-o",
        s(out),
        "--checkpoint",
        s(ckpt),
        "--checkpoint-every",
        "0.2",
    ];
    args.extend(LONG);
    Command::new(env!("CARGO_BIN_EXE_candela"))
        .args(&args)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn wait_for(path: &Path) {
    let start = Instant::now();
    while !path.exists() {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "no checkpoint appeared"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn long_reference(dir: &Path) -> Vec<u8> {
    let p = dir.join("reference.pfm");
    let mut args = vec!["demo", "-q", "-o", s(&p)];
    args.extend(LONG);
    run_ok(&args);
    std::fs::read(p).unwrap()
}

fn resume(dir: &Path, ckpt: &Path, out: &str) -> Vec<u8> {
    let p = dir.join(out);
    let mut args = vec!["demo", "-q", "-o", s(&p), "--resume", s(ckpt)];
    args.extend(LONG);
    run_ok(&args);
    std::fs::read(p).unwrap()
}

#[test]
fn interrupted_and_killed_renders_resume_to_the_same_bytes() {
    let dir = scratch("farm-resume");
    let reference = long_reference(&dir);

    // SIGINT: the render saves what it has and exits 130 without an image.
    let (out, ckpt) = (dir.join("int.pfm"), dir.join("int.ckpt"));
    let child = start_long(&out, &ckpt);
    wait_for(&ckpt);
    std::thread::sleep(Duration::from_millis(150));
    let pid = child.id().to_string();
    assert!(Command::new("kill")
        .args(["-INT", &pid])
        .status()
        .unwrap()
        .success());
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{err}");
    assert!(
        err.contains("interrupted") && err.contains("--resume"),
        "{err}"
    );
    assert!(!out.exists());
    assert_eq!(resume(&dir, &ckpt, "int.pfm"), reference);

    // SIGKILL: the last checkpoint holds whole passes.
    let (out, ckpt) = (dir.join("kill.pfm"), dir.join("kill.ckpt"));
    let mut child = start_long(&out, &ckpt);
    wait_for(&ckpt);
    std::thread::sleep(Duration::from_millis(250));
    child.kill().unwrap();
    child.wait().unwrap();
    assert_eq!(resume(&dir, &ckpt, "kill.pfm"), reference);

    // A time limit: an image of the passes done and a checkpoint to finish from.
    let (out, ckpt) = (dir.join("time.pfm"), dir.join("time.ckpt"));
    let mut args = vec![
        "demo",
        "-q",
        "-o",
        s(&out),
        "--checkpoint",
        s(&ckpt),
        "--time-limit",
        "0.3",
    ];
    args.extend(LONG);
    let o = candela(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("time limit"), "{}", stderr(&o));
    let early = std::fs::read(&out).unwrap();
    assert_eq!(early.len(), reference.len());
    assert_ne!(early, reference);
    assert_eq!(resume(&dir, &ckpt, "time.pfm"), reference);

    // A checkpoint of another render is refused.
    let o = candela(&[
        "demo",
        "-q",
        "-o",
        s(&dir.join("x.pfm")),
        "--resume",
        s(&ckpt),
        "--seed",
        "1",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("another render"), "{}", stderr(&o));
}

#[test]
fn frames_vary_the_clock_and_number_the_files() {
    let dir = scratch("farm-frames");
    let scene = support::repo().join("examples/course-demo.scene");
    let pattern = dir.join("f_%03d.png");
    run_ok(&[
        "render",
        s(&scene),
        "-q",
        "--width",
        "32",
        "--height",
        "24",
        "--frames",
        "88..91",
        "-o",
        s(&pattern),
    ]);
    let frames: Vec<Vec<u8>> = (88..91)
        .map(|f| std::fs::read(dir.join(format!("f_{f:03}.png"))).unwrap())
        .collect();
    // Frame 90 is the scene with clock = 90.
    let single = dir.join("single.png");
    run_ok(&[
        "render",
        s(&scene),
        "-q",
        "--width",
        "32",
        "--height",
        "24",
        "-d",
        "clock=90",
        "-o",
        s(&single),
    ]);
    assert_eq!(frames[2], std::fs::read(&single).unwrap());
    assert_ne!(frames[0], frames[2]);
    // Without a frame number every frame would overwrite one file.
    let o = candela(&[
        "demo",
        "-q",
        "--frames",
        "0..2",
        "-o",
        s(&dir.join("x.png")),
    ]);
    assert_eq!(o.status.code(), Some(2), "a usage error");
    assert!(stderr(&o).contains("%d"), "{}", stderr(&o));
}

#[test]
fn json_progress_reports_samples_rate_and_eta() {
    let dir = scratch("farm-json");
    let out = dir.join("p.pfm");
    let mut args = vec![
        "demo",
        "-o",
        s(&out),
        "--progress",
        "json",
        "--time-limit",
        "100",
    ];
    args.extend(LONG);
    let o = candela(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    let lines: Vec<&str> = err.lines().filter(|l| l.starts_with('{')).collect();
    assert!(!lines.is_empty(), "{err}");
    for l in &lines {
        assert!(l.ends_with('}'), "{l}");
        for key in [
            "\"event\":",
            "\"samples_done\":",
            "\"samples_total\":",
            "\"rays_per_s\":",
            "\"eta_s\":",
        ] {
            assert!(l.contains(key), "{key} missing in {l}");
        }
    }
    let last = lines.last().unwrap();
    assert!(last.contains("\"event\":\"done\""), "{last}");
    assert!(
        last.contains(&format!("\"samples_done\":{}", 200 * 120 * 256)),
        "{last}"
    );
}
