//! Feeds arbitrary radiosity cache bodies to the cache check: the fuzz input follows a valid
//! header (magic, version, the scene's fingerprint) and is given a valid checksum, so that the
//! counts, the replayed refinement and the values are what gets exercised. It must accept or
//! refuse the cache, never panic.
#![no_main]

use candela_render::radiosity::{Radiosity, RadiosityOptions};
use candela_render::Scene;
use libfuzzer_sys::fuzz_target;
use std::sync::OnceLock;

const SCENE: &str = "material m(diffuse(<0.5, 0.5, 0.5>))\nbox(m, identity)\npoint_light([0, 0, 0.5], <1, 1, 1>, 0)\n";

fn fnv(bytes: &[u8]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for &x in bytes {
        h ^= x as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

struct Fixture {
    scene: Scene,
    opts: RadiosityOptions,
    header: Vec<u8>,
}

fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let desc = candela_scene::parse_scene(SCENE, "fuzz.scene".as_ref(), &Default::default())
            .expect("the fixture parses");
        let (scene, _) = candela_scene::builder::build_scene(
            &desc,
            Default::default(),
            &candela_imageio::Limits::default(),
        )
        .expect("the fixture builds");
        let opts = RadiosityOptions {
            patch_size: Some(1.0),
            ..Default::default()
        };
        let solved = Radiosity::solve(&scene, &opts);
        let bytes = solved.outcome().cache_bytes.expect("a computed solution");
        Fixture {
            header: bytes[..20].to_vec(),
            scene,
            opts,
        }
    })
}

fuzz_target!(|body: &[u8]| {
    let f = fixture();
    let mut bytes = f.header.clone();
    bytes.extend_from_slice(body);
    let h = fnv(&bytes);
    bytes.extend_from_slice(&h.to_le_bytes());
    let _ = Radiosity::check_cache(&f.scene, &f.opts, &bytes);
});
