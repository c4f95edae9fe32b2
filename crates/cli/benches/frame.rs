//! Whole frames: the built-in demo and the Cornell box (`cargo bench --bench frame`).
//! Reports samples per second (items = camera samples).

use candela_render::integrator::{IntegratorKind, IntegratorSettings};
use candela_render::render::{render, RenderSettings};
use candela_scene::{demo_scene, load_scene, LoadOptions};
use divan::Bencher;
use std::path::Path;

fn main() {
    divan::main();
}

fn frame(b: Bencher, loaded: candela_scene::LoadedScene, integrator: &str, size: usize, spp: u32) {
    let settings = RenderSettings {
        width: size,
        height: size,
        spp,
        ..Default::default()
    };
    let kind = IntegratorKind::from_name(integrator).unwrap();
    let s = IntegratorSettings {
        max_depth: loaded.hints.max_depth,
        num_of_rays: 1,
        rr_depth: loaded.hints.rr_depth,
        hide_emitters: loaded.hints.hide_emitters,
        ..Default::default()
    };
    let integ = kind.build(&loaded.scene, &s).unwrap().integrator;
    b.counter(divan::counter::ItemsCount::new(size * size * spp as usize))
        .bench(|| render(&loaded.scene, integ.as_ref(), &settings, &|_| {}));
}

#[divan::bench(sample_count = 5)]
fn demo_path_128px_16spp(b: Bencher) {
    frame(
        b,
        demo_scene(&LoadOptions::default()).unwrap(),
        "path",
        128,
        16,
    );
}

#[divan::bench(sample_count = 5)]
fn demo_whitted_256px(b: Bencher) {
    frame(
        b,
        demo_scene(&LoadOptions::default()).unwrap(),
        "whitted",
        256,
        1,
    );
}

#[divan::bench(sample_count = 5)]
fn cornell_path_128px_16spp(b: Bencher) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/cornell-box.xml");
    frame(
        b,
        load_scene(&path, &LoadOptions::default()).unwrap(),
        "path",
        128,
        16,
    );
}
